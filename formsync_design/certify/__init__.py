"""Stage 5 — certificates over gain boxes: exact/rigorous re-checks, region maps, gain design.

The public names are imported on first use (PEP 562, as in :mod:`formsync_design`), so
importing one submodule (e.g. :mod:`~.engine` for one box) does not load the region maps,
the gain design and the agent certificates with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from formsync_design.lazy import lazy_attributes

if TYPE_CHECKING:  # the lazy names for type checkers and IDEs
    from formsync_design.certify.agent import (
        AgentGainDesign as AgentGainDesign,
        certify_agent as certify_agent,
        design_agent as design_agent,
        region_agent as region_agent,
    )
    from formsync_design.certify.design import (
        DesignResult as DesignResult,
        design_gains as design_gains,
    )
    from formsync_design.certify.engine import (
        as_box as as_box,
        certify_box as certify_box,
        check_kv as check_kv,
    )
    from formsync_design.certify.multipliers import (
        certify_with_multipliers as certify_with_multipliers,
    )
    from formsync_design.certify.region import region_map as region_map
    from formsync_design.certify.results import (
        CertificationResult as CertificationResult,
        Status as Status,
    )
    from formsync_design.certify.subdivision import RegionMap as RegionMap

#: public name -> the module that defines it
_LAZY: dict[str, str] = {
    "AgentGainDesign": "formsync_design.certify.agent",
    "certify_agent": "formsync_design.certify.agent",
    "design_agent": "formsync_design.certify.agent",
    "region_agent": "formsync_design.certify.agent",
    "DesignResult": "formsync_design.certify.design",
    "design_gains": "formsync_design.certify.design",
    "as_box": "formsync_design.certify.engine",
    "certify_box": "formsync_design.certify.engine",
    "check_kv": "formsync_design.certify.engine",
    "certify_with_multipliers": "formsync_design.certify.multipliers",
    "region_map": "formsync_design.certify.region",
    "CertificationResult": "formsync_design.certify.results",
    "Status": "formsync_design.certify.results",
    "RegionMap": "formsync_design.certify.subdivision",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals())
