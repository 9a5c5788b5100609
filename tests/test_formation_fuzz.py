"""Soundness fuzz of the formation certificate: random (design, graph, gains) triples, each
CERTIFIED and REFUTED checked against an independent numeric truth, the eigenvalues of the
finite-difference Jacobian of the compiled simulation kernel at consensus (zero false
certificates, zero false refutations).  The default suite draws a bounded number; the slow
run draws 1000 triples (the kernel is compiled once per design and graph, the gains vary)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from formsync_design.certify.formation import certify_formation
from formsync_design.gains import GainBox
from formsync_design.graphs.digraph_io import digraph_from_edges, make_digraph
from formsync_design.spec.declarations import GainRole
from formsync_design.spec.loader import load_design
from tests.fd_formation import fd_jacobian  # noqa: I001

# designs with a continuous law the kernel simulates (a sampled design's kernel holds its
# inputs: its certificate is about the continuous-time emulation, not checked here)
DESIGNS = ("ma_so3", "ma_quat_smc", "ma_mrp_ft", "liang2016", "lv2012")
# liang2016 declares no gain ranges (its Lagrangian view keeps the paper's declarations): the
# fuzz draws its agent form's gains from these (around the paper's 1.6, 0.4, 0.3, 0.01)
RANGES = {"liang2016": {"K_o": ("1/2", "3"), "K_q": ("1/20", "1"), "beta": ("1/100", "1/2"),
                        "K_v": ("1/1000", "1/10")}}
TOL = 2e-3      # the finite difference of |s|^(1/2) sat(s/phi) converges like sqrt(h)


def _graphs(design, rng, k):
    """``k`` graphs the design's formation is built on: directed cycles and weighted random
    digraphs with a spanning tree (undirected rings/paths for an undirected theorem), pinned
    at spacecraft 1 for a leader design."""
    out = []
    undirected = "undirected" in design.decl.graphs
    for t in range(k):
        n = int(rng.integers(3, 7))
        pin = [Fraction(int(rng.integers(1, 3)))] + [Fraction(0)] * (n - 1) \
            if design.decl.leader else None
        if undirected:
            out.append(make_digraph(f"{'ring' if t % 2 else 'path'}:{n}", pinning=pin))
        elif t % 2 == 0:
            arcs = [(i + 1, (i - 1) % n + 1, 1) for i in range(n)]
            out.append(digraph_from_edges(arcs, n=n, pinning=pin, name=f"C{n}"))
        else:
            w = [Fraction(1, 2), Fraction(1), Fraction(2)]
            arcs = {(i, int(rng.integers(1, i)), w[int(rng.integers(3))]) for i in range(2, n + 1)}
            have = {(i, j) for i, j, _ in arcs}
            for i in range(1, n + 1):
                for j in range(1, n + 1):
                    if i != j and (i, j) not in have and rng.random() < 0.3:
                        arcs.add((i, j, w[int(rng.integers(3))]))
            out.append(digraph_from_edges(sorted(arcs), n=n, pinning=pin, name=f"rand{t}"))
    return out


def _gains(design, rng):
    out = {}
    for g in design.decl.gains:
        if g.role != GainRole.CONTROLLER:
            continue
        if g.range is not None:
            lo, hi = Fraction(g.range.lo), Fraction(g.range.hi)
        else:
            lo, hi = (Fraction(x) for x in RANGES[design.name][g.name])
        # dyadic points of the declared range, biased low (where instabilities live)
        u = Fraction(int(rng.integers(0, 65)), 64) ** 2
        out[g.name] = lo + (hi - lo) * u
    return out


def _truth(A, n, leader):
    lam, V = np.linalg.eig(A)
    if leader:
        return float(lam.real.max())
    out = -np.inf
    for k in range(lam.size):
        v = V[:, k]
        blocks = [v[[3 * i + c if c < 3 else 3 * n + 3 * i + c - 3 for c in range(6)]]
                  for i in range(n)]
        if max(np.linalg.norm(b - blocks[0]) for b in blocks) > 1e-6 * np.linalg.norm(v):
            out = max(out, float(lam[k].real))
    return out


def _run(graphs_per_design, gains_per_graph, seed):
    rng = np.random.default_rng(seed)
    tally = {"certified": 0, "refuted": 0, "undecided": 0}
    for name in DESIGNS:
        d = load_design(name)
        for g in _graphs(d, rng, graphs_per_design):
            J = np.array([np.diag(rng.uniform(20, 80, 3)).round(1) for _ in range(g.n)])
            for _ in range(gains_per_graph):
                gains = _gains(d, rng)
                r = certify_formation(d, g, J, GainBox.parse({k: (v, v) for k, v in gains.items()}))
                tally[str(r.status)] += 1
                if str(r.status) == "undecided":
                    continue
                F = fd_jacobian(d, g, J, {k: float(v) for k, v in gains.items()}, h=1e-10)
                alpha = _truth(F, g.n, bool(d.decl.leader))
                where = f"{name} on {g.name} {g.arcs} at {gains}: truth {alpha:.3g}"
                if r.certified:
                    assert alpha < TOL, "false certificate: " + where
                else:
                    assert alpha > -TOL and alpha > r.witness.sigma - TOL, "false refutation: " + where
    return tally


def test_formation_certificates_agree_with_finite_differences():
    tally = _run(graphs_per_design=1, gains_per_graph=4, seed=7)
    assert tally["certified"] + tally["refuted"] >= 15


@pytest.mark.slow
def test_formation_certificates_agree_with_finite_differences_1000_triples():
    tally = _run(graphs_per_design=10, gains_per_graph=20, seed=11)
    assert sum(tally.values()) == 1000 and tally["refuted"] > 0 and tally["certified"] > 0
