"""Stage 5 — certificates over gain boxes: exact/rigorous re-checks, region maps, gain design."""

from formsync_design.certify.agent import (
    AgentGainDesign,
    certify_agent,
    design_agent,
    region_agent,
)
from formsync_design.certify.design import DesignResult, design_gains
from formsync_design.certify.engine import as_box, certify_box, check_kv
from formsync_design.certify.multipliers import certify_with_multipliers
from formsync_design.certify.region import region_map
from formsync_design.certify.results import CertificationResult, Status
from formsync_design.certify.subdivision import RegionMap

__all__ = [
    "Status",
    "as_box",
    "CertificationResult",
    "certify_box",
    "certify_with_multipliers",
    "check_kv",
    "RegionMap",
    "region_map",
    "DesignResult",
    "design_gains",
    "AgentGainDesign",
    "certify_agent",
    "region_agent",
    "design_agent",
]
