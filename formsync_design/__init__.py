"""formsync-design: derive, certify and simulate decentralized attitude
synchronization controllers for spacecraft formations.

The curated public surface (``import formsync_design as fs``):

>>> import formsync_design as fs
>>> g = fs.make_graph("ring:8")
>>> conds = fs.derive_conditions(g)
>>> str(fs.certify_box(conds, {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}).status)
'certified'

The stages live in subpackages, in the order data flows: ``graphs`` →
``models`` → ``spec`` → ``derive`` → ``certify`` → ``sim`` → ``verify`` →
``sweep``, with ``cli`` on top.  Heavy stages (cvxpy, CasADi, Dask) are
imported on first use of one of their names.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from formsync_design.errors import (
    DerivationError,
    FormsyncError,
    GraphError,
    InputError,
    PackagingError,
    SimulationError,
    SolverError,
)
from formsync_design.graphs import Graph, make_graph

__version__ = "0.1.0"

# public name -> module that defines it (imported lazily, PEP 562)
_LAZY = {
    "AttitudeModel": "formsync_design.models.attitude",
    "derive_attitude_model": "formsync_design.models.attitude",
    "Spec": "formsync_design.spec.loader",
    "load_spec": "formsync_design.spec.loader",
    "MatrixFamily": "formsync_design.derive.families",
    "LyapunovConditions": "formsync_design.derive.conditions",
    "derive_conditions": "formsync_design.derive.conditions",
    "paper_conditions": "formsync_design.derive.conditions",
    "closed_form_conditions": "formsync_design.derive.conditions",
    "required_kv": "formsync_design.derive.conditions",
    "write_derivation_report": "formsync_design.derive.report",
    "CertificationResult": "formsync_design.certify.engine",
    "certify_box": "formsync_design.certify.engine",
    "region_map": "formsync_design.certify.region",
    "design_gains": "formsync_design.certify.design",
    "Formation": "formsync_design.sim.simulator",
    "Gains": "formsync_design.sim.simulator",
    "SimOptions": "formsync_design.sim.simulator",
    "SimResult": "formsync_design.sim.simulator",
    "simulate": "formsync_design.sim.simulator",
    "monte_carlo": ("formsync_design.sim.montecarlo", "run_montecarlo"),
    "MonteCarloSettings": "formsync_design.sim.montecarlo",
    "Case": "formsync_design.verify.case",
    "load_case": "formsync_design.verify.case",
    "verify_case": "formsync_design.verify.verification",
    "run_sweep": "formsync_design.sweep.campaign",
    "load_campaign": "formsync_design.sweep.campaign",
}

__all__ = [
    "__version__",
    "FormsyncError",
    "InputError",
    "GraphError",
    "DerivationError",
    "SolverError",
    "SimulationError",
    "PackagingError",
    "Graph",
    "make_graph",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    target = _LAZY.get(name)
    if target is None:
        raise AttributeError(f"module 'formsync_design' has no attribute {name!r}")
    module, attr = target if isinstance(target, tuple) else (target, name)
    value = getattr(import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
