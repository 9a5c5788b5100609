"""Stage 6 — simulation: the SymPy-to-CasADi bridge, compiled kernels, Monte-Carlo, figures.

Modules: :mod:`~.bridge` (SymPy -> CasADi), :mod:`~.formation` (inputs, options,
statuses), :mod:`~.kernels` (building, compiling and caching the closed loop, keyed
by the specification's content), :mod:`~.metrics`, :mod:`~.result`,
:mod:`~.simulator` (the driver; re-exports the public names), :mod:`~.montecarlo`,
:mod:`~.figures`; :mod:`~.hybrid` (exact hybrid simulation with per-agent periodic,
event-, self- and dynamic-event triggering, representation-agnostic); :mod:`~.sampled`
(a design's controller with per-spacecraft sample-and-hold on the formation, through
:mod:`~.hybrid`); agent designs (:mod:`formsync_design.spec.agent`): :mod:`~.agent_kernel`
(their compiled formation kernels), :mod:`~.agents` (formations, options, results, the
continuous driver) and :mod:`~.agent_sampled` (their sampled path).
"""

from formsync_design.sim.agents import (
    AgentFormation,
    AgentOptions,
    AgentResult,
    AgentStatus,
    Reference,
    simulate_agents,
)
from formsync_design.sim.formation import SimStatus
from formsync_design.sim.hybrid import HybridOptions, HybridResult, HybridStatus, simulate_hybrid
from formsync_design.sim.montecarlo import (
    MonteCarloResult,
    MonteCarloSettings,
    RunStatus,
    run_montecarlo,
)
from formsync_design.sim.sampled import SampledResult, TriggerSpec, parse_trigger, simulate_sampled
from formsync_design.sim.simulator import Formation, Gains, SimOptions, SimResult, simulate

__all__ = [
    "Formation",
    "Gains",
    "SimOptions",
    "SimResult",
    "SimStatus",
    "simulate",
    "MonteCarloSettings",
    "MonteCarloResult",
    "RunStatus",
    "run_montecarlo",
    "HybridOptions",
    "HybridResult",
    "HybridStatus",
    "simulate_hybrid",
    "SampledResult",
    "TriggerSpec",
    "parse_trigger",
    "simulate_sampled",
    "AgentFormation",
    "AgentOptions",
    "AgentResult",
    "AgentStatus",
    "Reference",
    "simulate_agents",
]
