"""A seeded, replayable falsification search in simulation: evidence where no proof decides.

Where the formation certificate cannot decide (a law that is not differentiable at consensus,
such as an ideal ``sgn`` or a power ``|s|^(1/2)``), :func:`falsify_formation` simulates the
formation on the graph from seeded initial attitudes near consensus (a few degrees) and far
from it (tens of degrees), at rest, and reports each run: its seed, the initial and final
largest pairwise angle (or angle to the reference), and whether it met the case's
convergence criterion.  A run from near consensus that ends farther from consensus than it
started is a counterexample to local stability *in simulation*: evidence, never a proof; no
such run is "none found", never "stable".  Every run is replayed by its seed.

>>> from formsync_design.resources import case_file
>>> from formsync_design.verify.agentcase import load_agent_case
>>> c = load_agent_case(case_file("ma_so3"))
>>> ev = falsify_formation(c, c.graph(), near=1, far=0, tf=30.0)
>>> ev.basis, len(ev.runs), ev.runs[0].seed
('evidence', 1, 1)
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

__all__ = ["FalsificationRun", "FalsificationEvidence", "falsify_formation"]


@dataclass(frozen=True)
class FalsificationRun:
    """One seeded run: ``spread`` the per-axis standard deviation of the initial quaternion
    vector parts (rad/2), the largest angle (deg) at the start and the end, the run's status."""

    seed: int
    kind: str
    spread: float
    initial_deg: float
    final_deg: float
    status: str

    @property
    def counterexample(self) -> bool:
        return self.kind == "near" and self.final_deg > self.initial_deg

    def to_dict(self) -> dict[str, Any]:
        return {"seed": self.seed, "kind": self.kind, "spread": self.spread,
                "initial_deg": self.initial_deg, "final_deg": self.final_deg,
                "status": self.status, "counterexample": self.counterexample}


@dataclass(frozen=True)
class FalsificationEvidence:
    """The runs and what they found (module docstring)."""

    switch: str
    tf: float
    runs: tuple[FalsificationRun, ...]
    basis: str = "evidence"

    @property
    def found(self) -> bool:
        return any(r.counterexample for r in self.runs)

    def text(self) -> str:
        head = ("falsification (simulation, evidence only): "
                + ("a counterexample to local stability found" if self.found
                   else "no counterexample found"))
        rows = [f"    seed {r.seed} ({r.kind}): {r.initial_deg:.3g} deg -> {r.final_deg:.3g} deg "
                f"at t = {self.tf:g} s ({r.status})" for r in self.runs]
        return "\n".join([head, *rows])

    def to_dict(self) -> dict[str, Any]:
        return {"basis": self.basis, "switch": self.switch, "tf": self.tf, "found": self.found,
                "runs": [r.to_dict() for r in self.runs]}


def falsify_formation(case: Any, graph: Any, *, gains: Any = None, near: int = 2, far: int = 2,
                      tf: float = 200.0, switch: str | None = None, phi: float | None = None,
                      seed: int = 1) -> FalsificationEvidence:
    """Simulate ``case`` (an :class:`~formsync_design.verify.agentcase.AgentCase`, cycled to
    the graph's size) on ``graph`` from ``near`` seeded states a few degrees off consensus and
    ``far`` tens of degrees off (module docstring); seeds ``seed, seed + 1, ...``."""
    from formsync_design.sim.agents import AgentOptions, simulate_agents

    c = case.cycled(graph.n)
    f = c.formation(graph, gains=gains)
    opt: AgentOptions = replace(case.options, tf=float(tf), output_step=1.0,
                                switch=switch or case.options.switch,
                                phi=case.options.phi if phi is None else float(phi))
    runs = []
    for k in range(near + far):
        kind, spread = ("near", 0.02) if k < near else ("far", 0.15)
        rng = np.random.default_rng(seed + k)
        v = rng.normal(size=(graph.n, 3)) * spread
        q = np.column_stack([v, np.ones(graph.n)])
        q /= np.linalg.norm(q, axis=1)[:, None]
        r = simulate_agents(case.design, replace(f, attitudes=q, rates=np.zeros((graph.n, 3))), opt)
        err = r.reference_error if r.reference_error is not None else r.attitude_error
        runs.append(FalsificationRun(seed + k, kind, spread, float(err[0]), float(err[-1]),
                                     str(r.status)))
    return FalsificationEvidence(opt.switch, float(tf), tuple(runs))
