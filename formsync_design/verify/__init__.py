"""Stage 7 — verification of a published design: case files, metrics, claims, reports.

The public names are imported on first use (PEP 562, as in :mod:`formsync_design`), so
importing a submodule such as :mod:`~.defaults` does not load every verification module,
SymPy, SciPy and matplotlib with it.  :func:`verify_case` verifies a case file
(:mod:`~.dispatch`) with the engine (:mod:`~.engine`: :func:`run_engine` of a case read by
:func:`load_engine_case`, -> :class:`EngineVerification`, its claims :class:`ClaimVerdict`).

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
    from formsync_design.verify.dispatch import verify_case as verify_case
    from formsync_design.verify.engine import (
        ClaimVerdict as ClaimVerdict,
        EngineVerification as EngineVerification,
        run_engine as run_engine,
    )
    from formsync_design.verify.enginecase import load_engine_case as load_engine_case

#: public name -> the submodule that defines it
_LAZY: dict[str, str] = {
    "AgentCase": "formsync_design.verify.agentcase",
    "load_agent_case": "formsync_design.verify.agentcase",
    "Case": "formsync_design.verify.case",
    "load_case": "formsync_design.verify.case",
    "ClaimVerdict": "formsync_design.verify.engine",
    "EngineVerification": "formsync_design.verify.engine",
    "run_engine": "formsync_design.verify.engine",
    "load_engine_case": "formsync_design.verify.enginecase",
    "verify_case": "formsync_design.verify.dispatch",
}

__all__ = ["AgentCase", "load_agent_case", "Case", "load_case", "ClaimVerdict",
           "EngineVerification", "run_engine", "load_engine_case", "verify_case"]


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals())
