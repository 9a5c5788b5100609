"""Stage 7 — verification of a published design: case files, claims, reports."""

from formsync_design.verify.agentcase import AgentCase, load_agent_case
from formsync_design.verify.case import Case, load_case
from formsync_design.verify.claims import Measurement, Outcome, Verdict, judge
from formsync_design.verify.verification import VerificationResult, verify_case

__all__ = ["AgentCase", "load_agent_case", "Case", "load_case", "Measurement", "Outcome", "Verdict", "judge", "VerificationResult",
           "verify_case"]
