"""The vocabularies the ``formsync`` parsers show, without importing the stages.

``formsync --help``, ``--version`` and every subcommand's ``--help`` are built
from these names; the stages that define them (the graph reader, the
disturbance models, the CasADi bridge, the simulator, the Monte-Carlo) import
numpy, SymPy or CasADi, which costs a second before a single option is read.
Each value here is the stage's own, checked equal by
``tests/test_entrypoints.py``.
"""

from __future__ import annotations

__all__ = ["GRAPH_SPEC_HELP", "SWITCHES", "DISTURBANCES", "INTEGRATORS", "MAX_RUNS"]

#: :data:`formsync_design.graphs.build.GRAPH_SPEC_HELP`
GRAPH_SPEC_HELP = (
    "ring:N | path:N | star:N | complete:N | circulant:N:a,b,... | random:N:P:SEED "
    "| cycle:N (directed) | an edge-list file (1-based 'i j' per line) | an adjacency CSV file"
)

#: :data:`formsync_design.sim.bridge.SWITCHES` (switching terms)
SWITCHES = ("sgn", "sat", "tanh")

#: :data:`formsync_design.models.disturbances.DISTURBANCES` (disturbance models)
DISTURBANCES = ("paper", "gravity-gradient", "none")

#: :data:`formsync_design.sim.formation.INTEGRATORS`
INTEGRATORS = ("auto", "rk4", "dopri5", "cvodes")

#: :data:`formsync_design.sim.montecarlo_data.MAX_RUNS` (runs per ``montecarlo`` call)
MAX_RUNS = 100_000
