"""Stage 6 — simulation: the SymPy-to-CasADi bridge, compiled kernels, Monte-Carlo, figures."""

from formsync_design.sim.montecarlo import MonteCarloResult, MonteCarloSettings, run_montecarlo
from formsync_design.sim.simulator import Formation, Gains, SimOptions, SimResult, simulate

__all__ = [
    "Formation",
    "Gains",
    "SimOptions",
    "SimResult",
    "simulate",
    "MonteCarloSettings",
    "MonteCarloResult",
    "run_montecarlo",
]
