"""Link failures and switching topologies (issue 15, item 4): a common quadratic
Lyapunov function of the nominal loop over a set of graphs and a gain box.

Graph sets: an explicit list, or "the nominal graph minus any ``k`` links that
keep it connected" (:func:`graphs_minus_links`).  The nominal loop switches
arbitrarily among ``q'' = c_qd q' + c_s L_sigma q`` (``c_qd``, ``c_s`` derived from any
design: ``-K_o``, ``-K_q`` for Liang et al., ``-k_d``, ``-k_p`` for the PD baseline).

Class (graph-independent, so it can be common to every topology): per axis,
on the disagreement subspace ``1^perp`` (shared by every connected graph),

    ``V = a |q|^2 + 2 b q^T q' + |q'|^2``  i.e.  ``P = [[a, b], [b, 1]] (x) I``.

``P`` commutes with every ``L_sigma``, so ``A_sigma^T P + P A_sigma`` decouples
per eigenvalue ``lambda`` of each ``L_sigma``:
``F(lambda) = [[2 b c_s lambda, a + b c_qd + c_s lambda], [., 2 (b + c_qd)]]``
(computed from the derived per-mode model, not typed).  Certified when
``P > 0`` and ``F(lambda) < 0`` for every eigenvalue enclosure of every graph in
the set and every vertex of the box (``F`` is affine in the gains for fixed
``a, b``), re-checked exactly after cvxpy + Clarabel proposes ``(a, b)``.  A
common function then decreases along every switching signal (no dwell time
needed; Liberzon, *Switching in Systems and Control*, 2003, Sec. 2.1).

Scope and what is missing: the nominal linear loop only.  This class does not
keep the switching structure (``dV/dq_i'`` aligned with ``q_i' + beta s_i``):
``s_i`` depends on the current graph, so no graph-independent quadratic
function can; the switching and disturbance terms under link failures would
need an ultimate-bound argument (a design without a switching term, such as the PD
baseline, needs none: its loop is the nominal one).  When the class is empty the
result is ``undecided``; :mod:`.dwell` then certifies a dwell time.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from fractions import Fraction
from itertools import combinations
from typing import Any

import numpy as np
import sympy as sp
from scipy.linalg import expm

from formsync_design.analysis.modecheck import (
    GAINS,
    check_pd_coeffs,
    entry_coeffs,
    gain_subs,
    split_box,
)
from formsync_design.analysis.modes import LAMBDA, mode_model
from formsync_design.analysis.results import Verdict, jsonify
from formsync_design.analysis.spectrum import laplacian_spectrum
from formsync_design.errors import GraphError, InputError
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph
from formsync_design.graphs.build import Graph

__all__ = ["graphs_minus_links", "SwitchingResult", "certify_switching", "simulate_switching",
           "switching_section"]

_A, _B = sp.symbols("a b")


def graphs_minus_links(graph: Any, k: int = 1) -> list[Graph]:
    """Every connected graph obtained by removing ``k`` links from ``graph``.

    >>> [g.name for g in graphs_minus_links("ring:4", 1)][:2]
    ['ring:4 - {1-2}', 'ring:4 - {1-4}']
    >>> len(graphs_minus_links("star:5", 1))
    0
    """
    g = make_graph(graph)
    if not isinstance(k, int) or k < 0:
        raise InputError(f"expected a number of failed links k >= 0, received {k!r}")
    out = []
    for drop in combinations(g.edges, k):
        edges = tuple(e for e in g.edges if e not in drop)
        lap = np.diag(np.zeros(g.n))
        for i, j in edges:
            lap[i, i] += 1
            lap[j, j] += 1
            lap[i, j] -= 1
            lap[j, i] -= 1
        if g.n > 1 and np.linalg.eigvalsh(lap)[1] <= 1e-9:
            continue
        name = f"{g.name} - {{" + ", ".join(f"{i + 1}-{j + 1}" for i, j in drop) + "}"
        out.append(Graph(g.n, edges, name=name))
    return out


@dataclass(frozen=True)
class SwitchingResult:
    """A common Lyapunov function over a graph set and a box (or why none was found)."""

    status: Verdict
    graphs: tuple[str, ...]
    box: GainBox
    a: Fraction | None
    b: Fraction | None
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"status": str(self.status), "graphs": list(self.graphs), "box": self.box.to_dict(),
                        "P": None if self.a is None else [[self.a, self.b], [self.b, 1]],
                        "reason": self.reason})


def _class_matrices(spec: Any) -> tuple[sp.Matrix, sp.Matrix]:
    mm = mode_model(spec)
    p = sp.Matrix([[_A, _B], [_B, 1]])
    return p, (mm.a.T * p + p * mm.a).applyfunc(sp.expand)


def certify_switching(graphs: Any, box: Any, *, spec: Any = None) -> SwitchingResult:
    """Search and exactly re-check a common ``P = [[a, b], [b, 1]]`` over graphs and box.

    Examples
    --------
    >>> r = certify_switching(graphs_minus_links("ring:6", 1) + [make_graph("ring:6")],
    ...                       {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    >>> r.status.value
    'certified'
    >>> certify_switching(["ring:6", "path:6"], {"k_p": 0.4, "k_d": 1.6}, spec="pd_consensus").status.value
    'certified'
    """
    import cvxpy as cp

    from formsync_design.certify.sdp import CLARABEL_OPTIONS

    gs = [make_graph(g) for g in graphs]
    if not gs:
        raise GraphError("expected at least one connected graph in the set, received none")
    mm = mode_model(spec)
    b, _ = split_box(mm, box)
    p, f = _class_matrices(spec)
    clusters = [c for g in gs for c in laplacian_spectrum(g).clusters]
    a_v, b_v, t = cp.Variable(), cp.Variable(), cp.Variable()
    cons = [t <= 1, cp.abs(a_v) <= 1e6, cp.abs(b_v) <= 1e6]
    pm = cp.bmat([[a_v, b_v], [b_v, 1.0]])
    cons.append(pm - t * np.eye(2) >> 0)
    lam_vals = sorted({float(c.lo) for c in clusters} | {float(c.hi) for c in clusters})
    fl = sp.lambdify((_A, _B, LAMBDA, *mm.gains), f, "numpy")
    for v in b.vertices():
        gv = [float(x) for x in v]
        for lam in lam_vals:
            # F is affine in (a, b): F = F0 + a Fa + b Fb
            f0 = np.array(fl(0, 0, lam, *gv), dtype=float)
            fa = np.array(fl(1, 0, lam, *gv), dtype=float) - f0
            fb = np.array(fl(0, 1, lam, *gv), dtype=float) - f0
            scale = max(1.0, lam)
            cons.append(-(f0 + a_v * fa + b_v * fb) / scale - t * np.eye(2) >> 0)
    prob = cp.Problem(cp.Maximize(t), cons)
    try:
        with warnings.catch_warnings():  # an inaccurate solve is a hint; the exact re-check decides
            warnings.simplefilter("ignore", UserWarning)
            prob.solve(solver=cp.CLARABEL, **CLARABEL_OPTIONS)
    except (cp.error.SolverError, ValueError):  # pragma: no cover - solver failure
        return SwitchingResult(Verdict.ERROR, tuple(g.name for g in gs), b, None, None,
                               "the LMI solver failed; retry with a smaller graph set")
    names = tuple(g.name for g in gs)
    av, bv, tv = a_v.value, b_v.value, t.value
    if prob.status not in ("optimal", "optimal_inaccurate") or av is None or bv is None or tv is None \
            or float(tv) <= 0:
        return SwitchingResult(Verdict.UNDECIDED, names, b, None, None,
                               f"no common quadratic function of the class found (solver: {prob.status})")
    aq = Fraction(float(av)).limit_denominator(10**8)
    bq = Fraction(float(bv)).limit_denominator(10**8)
    ab = {_A: sp.Rational(aq.numerator, aq.denominator), _B: sp.Rational(bq.numerator, bq.denominator)}
    pn, fn = p.subs(ab), (-f).subs(ab)
    ij = ((0, 0), (0, 1), (1, 1))
    for v in b.vertices():
        sub = gain_subs(mm, v)
        pc = [entry_coeffs(pn[i, j], sub) for i, j in ij]
        fc = [entry_coeffs(fn[i, j], sub) for i, j in ij]
        for c in clusters:
            if check_pd_coeffs(pc[0], pc[1], pc[2], c)[0] != 1 or check_pd_coeffs(fc[0], fc[1], fc[2], c)[0] != 1:
                return SwitchingResult(Verdict.UNDECIDED, names, b, None, None,
                                       "the proposed common function failed the exact re-check")
    return SwitchingResult(Verdict.CERTIFIED, names, b, aq, bq,
                           "a common quadratic Lyapunov function for every graph of the set and every "
                           "gain of the box (exact re-check): stable under arbitrary link switching")


def simulate_switching(graphs: Any, gains: Any, *, tf: float = 60.0, mean_dwell: float = 1.0,
                       seed: int = 0, spec: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nominal loop (one axis) with the topology switching at random (exponential) times, at a
    gain point of the design's controller gains.

    Returns ``(t, x, sigma)``: switching instants and dense samples ``x = (q, q')``
    at every instant and every 0.1 s (exact ``expm`` propagation), the graph index.
    """
    gs = [make_graph(g) for g in graphs]
    a22, a21 = (float(x) for x in mode_model(spec).coefficients(gains))  # c_qd, c_s
    n = gs[0].n
    mats = [np.block([[np.zeros((n, n)), np.eye(n)], [a21 * g.laplacian.astype(float), a22 * np.eye(n)]])
            for g in gs]
    rng = np.random.default_rng(seed)
    x = np.concatenate([rng.normal(size=n), rng.normal(size=n)])
    x[:n] -= x[:n].mean()
    x[n:] -= x[n:].mean()
    ts, xs, sig = [0.0], [x.copy()], []
    t = 0.0
    while t < tf:
        k = int(rng.integers(len(gs)))
        dwell = min(float(rng.exponential(mean_dwell)), tf - t)
        steps = max(1, int(np.ceil(dwell / 0.1)))
        step = expm(mats[k] * (dwell / steps))
        for _ in range(steps):
            x = step @ x
            t += dwell / steps
            ts.append(t)
            xs.append(x.copy())
            sig.append(k)
    return np.array(ts), np.array(xs), np.array(sig)


def switching_section(graphs: tuple[str, ...] = ("ring:8", "star:8", "complete:8"),
                      point: tuple[str, str, str] = ("1.6", "0.4", "0.3")) -> list[str]:
    """Markdown lines: one-link-failure sets and their common Lyapunov function, per graph."""
    box = dict(zip(GAINS, point))
    lines = ["## One link failure (item 4)", "",
             f"Gains (K_o, K_q, beta) = ({', '.join(point)}); graph set = the nominal graph and every "
             "connected graph with one link removed; nominal linear loop under arbitrary switching "
             "among the set (common quadratic function, exact re-check).", "",
             "| graph | graphs in the set | verdict | common P = [[a, b], [b, 1]] |", "|---|---|---|---|"]
    for gname in graphs:
        g = make_graph(gname)
        gs = [g, *graphs_minus_links(g, 1)]
        if len(gs) == 1:
            lines.append(f"| {g.name} | 1 | - (every single link failure disconnects it) | - |")
            continue
        r = certify_switching(gs, box)
        pstr = "-" if r.a is None or r.b is None else f"a = {float(r.a):.4g}, b = {float(r.b):.4g}"
        lines.append(f"| {g.name} | {len(gs)} | {r.status.value} | {pstr} |")
    lines.append("")
    return lines
