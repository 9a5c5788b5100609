"""Stage 6 — simulation: the SymPy-to-CasADi bridge, compiled kernels, Monte-Carlo, figures.

Modules: :mod:`~.bridge` (SymPy -> CasADi), :mod:`~.formation` (inputs, options),
:mod:`~.kernels` (building, compiling and caching the closed loop, keyed
by the specification's content), :mod:`~.metrics`, :mod:`~.result` (the one result type
:class:`SimResult` of every formation run, Lagrangian or agent design, and its
:class:`SimStatus`), :mod:`~.disagreement` (attitude and rate disagreement),
:mod:`~.simulator` (the driver), :mod:`~.montecarlo`,
:mod:`~.figures`; :mod:`~.hybrid` (exact hybrid simulation with per-agent periodic,
event-, self- and dynamic-event triggering, representation-agnostic); :mod:`~.sampled`
(a design's controller with per-spacecraft sample-and-hold on the formation, through
:mod:`~.hybrid`); agent designs (:mod:`formsync_design.spec.agent`): :mod:`~.agent_kernel`
(their compiled formation kernels), :mod:`~.agents` (formations, options, the
continuous driver) and :mod:`~.agent_sampled` (their sampled path).

The public names are imported on first use (PEP 562, as in :mod:`formsync_design`), so
importing one submodule (e.g. :mod:`~.native`) does not load SciPy's integrators, the
agent drivers and matplotlib with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from formsync_design.lazy import lazy_attributes

if TYPE_CHECKING:  # the lazy names for type checkers and IDEs
    from formsync_design.sim.agents import (
        AgentFormation as AgentFormation,
        AgentOptions as AgentOptions,
        Reference as Reference,
        simulate_agents as simulate_agents,
    )
    from formsync_design.sim.formation import (
        Formation as Formation,
        Gains as Gains,
        SimOptions as SimOptions,
    )
    from formsync_design.sim.hybrid import (
        HybridOptions as HybridOptions,
        HybridResult as HybridResult,
        HybridStatus as HybridStatus,
        simulate_hybrid as simulate_hybrid,
    )
    from formsync_design.sim.montecarlo import run_montecarlo as run_montecarlo
    from formsync_design.sim.montecarlo_data import (
        MonteCarloResult as MonteCarloResult,
        MonteCarloRun as MonteCarloRun,
        MonteCarloSettings as MonteCarloSettings,
        RunStatus as RunStatus,
    )
    from formsync_design.sim.result import SimResult as SimResult, SimStatus as SimStatus
    from formsync_design.sim.sampled import (
        TriggerSpec as TriggerSpec,
        parse_trigger as parse_trigger,
        simulate_sampled as simulate_sampled,
    )
    from formsync_design.sim.simulator import simulate as simulate

#: public name -> the submodule that defines it
_LAZY: dict[str, str] = {
    "AgentFormation": "formsync_design.sim.agents",
    "AgentOptions": "formsync_design.sim.agents",
    "Reference": "formsync_design.sim.agents",
    "simulate_agents": "formsync_design.sim.agents",
    "SimStatus": "formsync_design.sim.result",
    "HybridOptions": "formsync_design.sim.hybrid",
    "HybridResult": "formsync_design.sim.hybrid",
    "HybridStatus": "formsync_design.sim.hybrid",
    "simulate_hybrid": "formsync_design.sim.hybrid",
    "MonteCarloResult": "formsync_design.sim.montecarlo_data",
    "MonteCarloRun": "formsync_design.sim.montecarlo_data",
    "MonteCarloSettings": "formsync_design.sim.montecarlo_data",
    "RunStatus": "formsync_design.sim.montecarlo_data",
    "run_montecarlo": "formsync_design.sim.montecarlo",
    "TriggerSpec": "formsync_design.sim.sampled",
    "parse_trigger": "formsync_design.sim.sampled",
    "simulate_sampled": "formsync_design.sim.sampled",
    "Formation": "formsync_design.sim.formation",
    "Gains": "formsync_design.sim.formation",
    "SimOptions": "formsync_design.sim.formation",
    "SimResult": "formsync_design.sim.result",
    "simulate": "formsync_design.sim.simulator",
}

__all__ = [
    "Formation",
    "Gains",
    "SimOptions",
    "SimResult",
    "SimStatus",
    "simulate",
    "MonteCarloSettings",
    "MonteCarloResult",
    "MonteCarloRun",
    "RunStatus",
    "run_montecarlo",
    "HybridOptions",
    "HybridResult",
    "HybridStatus",
    "simulate_hybrid",
    "TriggerSpec",
    "parse_trigger",
    "simulate_sampled",
    "AgentFormation",
    "AgentOptions",
    "Reference",
    "simulate_agents",
]


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals())
