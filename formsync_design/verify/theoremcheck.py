"""Theorems are checked, not echoed: a design's declared graph class tested on graph families.

A design declares the graphs its theorem covers (``GRAPHS``, e.g. "a directed spanning tree
suffices").  :func:`check_theorem` takes that as a hypothesis: on every graph of a family
that *has* the declared properties (directed cycles C3-C20, directed chains, out-stars,
seeded random sparse digraphs with a spanning tree, the case's own graph; with a leader the
same graphs pinned at their roots), at the case's gains and spacecraft (cycled to N), it
decides the formation-level certificate
(:func:`~formsync_design.certify.formation.certify_formation`).  A refuted graph is a
counterexample to the theorem as the design realises it: its witness (the unstable mode) is a
proof, and a seeded simulation from a few degrees off consensus is shown beside it as
evidence.  The verdict on the theorem is computed from the rows: ``refuted`` when a graph
inside the declared class is refuted, else ``no counterexample found`` (never "holds": the
families are finite).

>>> from formsync_design.resources import case_file
>>> from formsync_design.verify.agentcase import load_agent_case
>>> c = load_agent_case(case_file("ma_so3"))
>>> tc = check_theorem(c, cycles=range(6, 10), chains=(), stars=(), random_graphs=0, simulate=False)
>>> tc.verdict, tc.first_failing_cycle
('refuted', 8)
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

__all__ = ["TheoremRow", "TheoremCheck", "theorem_graphs", "check_theorem", "theorem_claim"]


@dataclass(frozen=True)
class TheoremRow:
    """One graph: its family, size, the formation verdict and its evidence.

    ``status``: certified / refuted / undecided; ``decay``: the certified rate;
    ``eigenvalue``: the witness's (refuted); ``sigma``: its proven real-part bound;
    ``sim_initial_deg`` / ``sim_final_deg``: the seeded simulation of a counterexample
    (largest pairwise angle, or to the reference, at t = 0 and t = ``sim_tf``).
    """

    family: str
    graph: str
    n: int
    status: str
    abscissa: float | None = None
    decay: float | None = None
    eigenvalue: complex | None = None
    sigma: float | None = None
    reason: str = ""
    sim_initial_deg: float | None = None
    sim_final_deg: float | None = None
    sim_tf: float | None = None
    sim_status: str = ""

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"family": self.family, "graph": self.graph, "n": self.n,
                               "status": self.status, "spectral_abscissa": self.abscissa}
        if self.decay is not None:
            out["decay_rate"] = self.decay
        if self.eigenvalue is not None:
            out["eigenvalue"] = [self.eigenvalue.real, self.eigenvalue.imag]
            out["real_part_above"] = self.sigma
        if self.reason:
            out["reason"] = self.reason
        if self.sim_tf is not None:
            out["simulation"] = {"initial_deg": self.sim_initial_deg, "final_deg":
                                 self.sim_final_deg, "tf": self.sim_tf, "status": self.sim_status}
        return out


@dataclass(frozen=True)
class TheoremCheck:
    """The check of one design's theorem (module docstring)."""

    design: str
    declared: tuple[str, ...]
    gains: dict[str, Fraction]
    switch: str
    phi: Fraction | None
    rows: tuple[TheoremRow, ...]
    seed: int
    sampling: str = "continuous"

    @property
    def counterexamples(self) -> tuple[TheoremRow, ...]:
        return tuple(r for r in self.rows if r.status == "refuted")

    @property
    def verdict(self) -> str:
        return "refuted" if self.counterexamples else "no counterexample found"

    @property
    def first_failing_cycle(self) -> int | None:
        cyc = [r.n for r in self.counterexamples if r.family == "directed cycle"]
        return min(cyc) if cyc else None

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.gains import json_number

        return {"design": self.design, "declared_graph_class": list(self.declared),
                "gains": {k: json_number(v) for k, v in self.gains.items()},
                "switch": self.switch, "phi": None if self.phi is None else json_number(self.phi),
                "verdict": self.verdict, "first_failing_cycle": self.first_failing_cycle,
                "seed": self.seed, "rows": [r.to_dict() for r in self.rows]}

    def markdown(self) -> list[str]:
        """The report section's lines (a table of every graph, counterexamples first)."""
        cls = ", ".join(self.declared) or "any graph"
        L = [f"The design's theorem covers graphs with: {cls}. Checked, not echoed: the "
             "formation-level certificate (exact linearisation at consensus, "
             f"sgn as {self.switch}(x/phi), phi = {self.phi}) at the case's gains "
             f"({', '.join(f'{k} = {float(v):g}' for k, v in self.gains.items())}), spacecraft of "
             "the case cycled to N, on every graph below that has those properties. "
             f"**Verdict on the theorem: {self.verdict}**"
             + (f" (first failing directed cycle: C{self.first_failing_cycle})."
                if self.first_failing_cycle else "."), "",
             "A counterexample's witness is a proof (an eigenvalue with real part above the "
             "proven bound, by the inertia theorem); its simulation (seed "
             f"{self.seed}, from a few degrees off consensus, same switch) is evidence."
             + ("" if self.sampling == "continuous" else
                f" The design samples ({self.sampling}): the certificate is about its "
                "continuous-time emulation (held values equal to current ones), not the "
                "sampled loop."), "",
             "| family | graph | N | formation verdict | evidence |", "|---|---|---|---|---|"]
        for r in sorted(self.rows, key=lambda r: (r.status != "refuted", r.family, r.n)):
            if r.status == "refuted" and r.eigenvalue is not None:
                ev = (f"eigenvalue {r.eigenvalue.real:.4g}{r.eigenvalue.imag:+.4g}j "
                      f"(Re > {r.sigma:.3g} proven)")
                if r.sim_tf is not None:
                    ev += (f"; simulation: {r.sim_initial_deg:.3g} deg at t = 0, "
                           f"{r.sim_final_deg:.3g} deg at t = {r.sim_tf:g} s ({r.sim_status})")
            elif r.status == "certified":
                ev = f"decay rate >= {r.decay:.3g} 1/s (proven)"
            else:
                ev = r.reason
            L.append(f"| {r.family} | {r.graph} | {r.n} | {r.status} | {ev} |")
        return L


def _cycle(n: int) -> list[tuple[int, int, int]]:
    return [(i + 1, (i - 1) % n + 1, 1) for i in range(n)]


def theorem_graphs(n_paper: int, *, cycles: Iterable[int] = range(3, 21),
                   chains: Iterable[int] = (4, 6, 8), stars: Iterable[int] = (4, 6, 8),
                   random_graphs: int = 6, seed: int = 2016) -> list[tuple[str, str, list, int]]:
    """``(family, name, arcs, n)`` of the families (1-based arcs ``(i, j, a_ij)``: ``i``
    receives from ``j``); the random digraphs are a random spanning tree (each spacecraft
    receives from an earlier one) plus arcs drawn with probability 0.15, weights in
    ``{1/2, 1, 3/2}``, sizes 4-10, from ``seed``.

    >>> [(f, n) for f, _, _, n in theorem_graphs(5, cycles=(3,), chains=(3,), stars=(), random_graphs=1)]
    [('directed cycle', 3), ('directed chain', 3), ('random digraph', 5)]
    """
    out: list[tuple[str, str, list, int]] = []
    for n in cycles:
        out.append(("directed cycle", f"C{n}", _cycle(n), n))
    for n in chains:
        out.append(("directed chain", f"chain{n}", [(i + 1, i, 1) for i in range(1, n)], n))
    for n in stars:
        out.append(("out-star", f"star{n}", [(i, 1, 1) for i in range(2, n + 1)], n))
    rng = np.random.default_rng(seed)
    wts = [Fraction(1, 2), Fraction(1), Fraction(3, 2)]
    for k in range(random_graphs):
        n = int(rng.integers(4, 11))
        arcs = {(i, int(rng.integers(1, i)), wts[int(rng.integers(3))]) for i in range(2, n + 1)}
        have = {(i, j) for i, j, _ in arcs}
        for i in range(1, n + 1):
            for j in range(1, n + 1):
                if i != j and (i, j) not in have and rng.random() < 0.15:
                    arcs.add((i, j, wts[int(rng.integers(3))]))
        out.append(("random digraph", f"rand{k + 1}-N{n}", sorted(arcs), n))
    return out


def _simulate(case: Any, g: Any, seed: int, tf: float, switch: str, phi: float) -> tuple[float, float, str]:
    from formsync_design.sim.agents import simulate_agents

    c = case.cycled(g.n)
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(g.n, 3)) * 0.02
    q = np.column_stack([v, np.ones(g.n)])
    q /= np.linalg.norm(q, axis=1)[:, None]
    f = c.formation(g)
    from dataclasses import replace

    f = replace(f, attitudes=q, rates=np.zeros((g.n, 3)))
    opt = replace(case.options, tf=tf, output_step=1.0, switch=switch, phi=phi)
    r = simulate_agents(case.design, f, opt)
    err = r.reference_error if r.reference_error is not None else r.attitude_error
    return float(err[0]), float(err[-1]), str(r.status)


def check_theorem(case: Any, *, cycles: Iterable[int] = range(3, 21),
                  chains: Iterable[int] = (4, 6, 8), stars: Iterable[int] = (4, 6, 8),
                  random_graphs: int = 6, seed: int = 2016, simulate: bool = True,
                  sim_tf: float = 200.0, max_simulations: int = 6, switch: str = "sat",
                  phi: str = "1/100") -> TheoremCheck:
    """Check ``case.design``'s theorem on the families (module docstring); ``case``: an
    :class:`~formsync_design.verify.agentcase.AgentCase`.  Graphs outside the declared
    class are skipped (they are no counterexample); with a leader, spacecraft 1 (the root
    of every family) is pinned with ``b = 1``."""
    from formsync_design.certify.formation import certify_formation
    from formsync_design.gains import GainBox, parse_number
    from formsync_design.graphs.digraph_io import digraph_from_edges
    from formsync_design.graphs.theorem import check_theorem_graph
    from formsync_design.spec.declarations import GainRole

    design = case.design
    ctrl = [g.name for g in design.decl.gains if g.role == GainRole.CONTROLLER]
    given = case.gains.as_dict()
    gains = {k: parse_number(given[k], k) for k in ctrl}
    box = GainBox.parse({k: (v, v) for k, v in gains.items()})
    leader = bool(design.decl.leader)
    graphs: list[tuple[str, Any]] = []
    if "undirected" in design.decl.graphs:
        from formsync_design.graphs.digraph_io import make_digraph

        for fam, sizes in (("ring", range(3, 13)), ("path", (3, 5, 8)), ("star", (4, 6, 8))):
            for n in sizes:
                pin = [1] + [0] * (n - 1) if leader else None
                graphs.append((f"undirected {fam}", make_digraph(f"{fam}:{n}", pinning=pin)))
    for fam, name, arcs, n in theorem_graphs(case.n, cycles=cycles, chains=chains, stars=stars,
                                              random_graphs=random_graphs, seed=seed):
        pin = [1] + [0] * (n - 1) if leader else None
        graphs.append((fam, digraph_from_edges(arcs, n=n, pinning=pin, name=name)))
    graphs.append(("the case's graph", case.graph()))
    rows: list[TheoremRow] = []
    sims = 0
    phi_f = float(parse_number(phi, "phi"))
    for fam, g in graphs:
        if not check_theorem_graph(g, design.decl.graphs, allow_outside=True).inside:
            continue
        r = certify_formation(design, g, case.cycled(g.n).inertias, box, switch=switch, phi=phi)
        row = TheoremRow(fam, g.name, g.n, str(r.status),
                         abscissa=None if r.evidence.get("spectral_abscissa") is None
                         else float(r.evidence["spectral_abscissa"]), decay=r.decay,
                         eigenvalue=None if r.witness is None else r.witness.eigenvalue,
                         sigma=None if r.witness is None else r.witness.sigma, reason=r.reason)
        if r.witness is not None and simulate and sims < max_simulations:
            a, b, st = _simulate(case, g, seed + sims, sim_tf, switch, phi_f)
            sims += 1
            from dataclasses import replace

            row = replace(row, sim_initial_deg=a, sim_final_deg=b, sim_tf=sim_tf, sim_status=st)
        rows.append(row)
    return TheoremCheck(design.name, tuple(design.decl.graphs), gains, switch,
                        parse_number(phi, "phi"), tuple(rows), seed, design.decl.sampling)


def theorem_claim(tc: TheoremCheck) -> tuple[str, str, str, str]:
    """``(text, measured, verdict, rule)`` of the claim "the declared graph class suffices"
    judged from ``tc``: ``fails`` with a counterexample, else ``undecided`` (finite families
    decide nothing in favour of a theorem)."""
    bad = tc.counterexamples
    cls = ", ".join(tc.declared) or "any graph"
    first = f", first failing directed cycle C{tc.first_failing_cycle}" if tc.first_failing_cycle else ""
    measured = (f"{len(bad)} of {len(tc.rows)} graphs of the class refuted ({bad[0].graph} "
                f"first{first})" if bad else f"{len(tc.rows)} graphs of the class, none refuted")
    return (f"the design's theorem: every graph with {cls} gives a convergent formation "
            "(at the case's gains)", measured, "fails" if bad else "undecided",
            "formation-level certificate (local exponential stability) on graph families: a "
            "refuted graph of the class is a counterexample; none refuted decides nothing")
