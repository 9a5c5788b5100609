"""Stage 7 — verification of a published design: case files, claims, reports.

The public names are imported on first use (PEP 562, as in :mod:`formsync_design`), so
importing a submodule such as :mod:`~.defaults` does not load every verification module,
SymPy, SciPy and matplotlib with it.  :func:`verify_case` verifies a case of any kind
(:mod:`~.dispatch`).

>>> from formsync_design.verify import load_case, verify_case
>>> callable(load_case) and callable(verify_case)
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from formsync_design.lazy import lazy_attributes

if TYPE_CHECKING:  # the lazy names for type checkers and IDEs
    from formsync_design.verify.agentcase import (
        AgentCase as AgentCase,
        load_agent_case as load_agent_case,
    )
    from formsync_design.verify.case import Case as Case, load_case as load_case
    from formsync_design.verify.claims import (
        Measurement as Measurement,
        Outcome as Outcome,
        Verdict as Verdict,
        judge as judge,
    )
    from formsync_design.verify.dispatch import verify_case as verify_case
    from formsync_design.verify.results import VerificationResult as VerificationResult

#: public name -> the submodule that defines it
_LAZY: dict[str, str] = {
    "AgentCase": "formsync_design.verify.agentcase",
    "load_agent_case": "formsync_design.verify.agentcase",
    "Case": "formsync_design.verify.case",
    "load_case": "formsync_design.verify.case",
    "Measurement": "formsync_design.verify.claims",
    "Outcome": "formsync_design.verify.claims",
    "Verdict": "formsync_design.verify.claims",
    "judge": "formsync_design.verify.claims",
    "VerificationResult": "formsync_design.verify.results",
    "verify_case": "formsync_design.verify.dispatch",
}

__all__ = ["AgentCase", "load_agent_case", "Case", "load_case", "Measurement", "Outcome",
           "Verdict", "judge", "VerificationResult", "verify_case"]


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals())
