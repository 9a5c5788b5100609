"""Stage 4 — symbolic derivation: closed loop, Lyapunov conditions as gain families,
comparison with the printed paper and the derivation report.

Modules: ``closed_loop`` (closed loop, specification resolution and cache keys),
``templates`` (per-degree local templates), ``conditions`` (assembly of
``Theta_i`` and ``Pi`` by graph), ``lyapunov`` (the result, :class:`LyapunovConditions`), ``closed_form``
(closed-form and ``K_vi`` conditions), ``families`` (gain-polynomial matrix
families), ``findings`` / ``compare`` (computed paper-versus-derivation verdicts),
``printed`` (printed-expressions loader), ``report`` (the derivation report);
``agent`` (agent designs: symbolic closed loop, time derivatives along it, the design's
certificate families).
"""

from formsync_design.derive.agent import (
    AgentClosedLoop,
    AgentConditions,
    agent_closed_loop,
    agent_conditions,
    time_derivative,
)
from formsync_design.derive.closed_form import (
    ClosedFormCondition,
    closed_form_conditions,
    kv_condition_holds,
    required_kv,
)
from formsync_design.derive.closed_loop import ClosedLoop, derive_closed_loop
from formsync_design.derive.conditions import derive_conditions, paper_conditions
from formsync_design.derive.families import MatrixFamily
from formsync_design.derive.lyapunov import LyapunovConditions

__all__ = [
    "ClosedLoop",
    "LyapunovConditions",
    "ClosedFormCondition",
    "MatrixFamily",
    "derive_closed_loop",
    "derive_conditions",
    "paper_conditions",
    "closed_form_conditions",
    "required_kv",
    "kv_condition_holds",
    "AgentClosedLoop",
    "AgentConditions",
    "agent_closed_loop",
    "agent_conditions",
    "time_derivative",
]
