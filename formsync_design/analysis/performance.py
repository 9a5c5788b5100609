"""Performance-certified gains (issue 15, item 2): a certified exponential decay rate
and the settling time it guarantees.

A decay rate ``alpha`` is certified on a gain box when a quadratic ``V`` of the
certificate's class satisfies ``V' <= -2 alpha V`` along the nominal loop for
every gain in the box and every Laplacian mode, i.e. per mode
``A_k^T P_k + P_k A_k + 2 alpha P_k < 0`` (multi-affine in the gains for fixed
``alpha``, so the vertices decide; re-checked exactly over the eigenvalue
enclosures, :mod:`.certificates`).

* ``exact``: ``P_k`` is the paper's ``V``; the best rate is a generalized
  eigenvalue, computed in floating point, rounded down to a rational and then
  re-checked exactly (halved until the check passes).
* ``searched``: the switching-structured class; bisection on ``alpha`` with the
  vertex LMIs (cvxpy + Clarabel) per mode, the final multi-affine ``p``
  rounded and re-checked exactly.

Settling time (Khalil, *Nonlinear Systems*, Thm 4.10): with
``c_1 |x|^2 <= V <= c_2 |x|^2`` on the disagreement subspace
(``kappa = c_2 / c_1``), ``|x(t)| <= sqrt(kappa) |x(0)| exp(-alpha t)``, so every
initial disagreement (mode coordinates of ``q`` and ``q'``) of norm ``<= r``
is within ``eps`` after ``T = ln(sqrt(kappa) r / eps) / alpha``.
``kappa`` is bounded here in floating point from the vertex matrices at the
gain point (a reported number, not a verdict).

Scope: the nominal loop (exact model cancellation, switching gain's effect
excluded, no disturbance), as in the paper's proof.  The peak-torque bound is
:mod:`.torque`; ``--decay``/``--settle``/``--torque-limit`` restrictions are
:mod:`.requirements`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.analysis.certificates import certify, certify_exact_with, exact_candidates
from formsync_design.analysis.modecheck import (
    GAINS,
    check_pd_coeffs,
    entry_coeffs,
    gain_subs,
    split_box,
)
from formsync_design.analysis.modes import LAMBDA, ModeModel, mode_model
from formsync_design.analysis.results import Certificate, Verdict, jsonify
from formsync_design.analysis.searched import SearchedLMI, free_values, lp_coeffs, monomials, with_p
from formsync_design.analysis.spectrum import LaplacianSpectrum, laplacian_spectrum
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, json_number
from formsync_design.graphs import make_graph

__all__ = ["DecayResult", "certified_decay_rate", "spectral_decay_rate", "settling_time",
           "performance_section"]


@dataclass(frozen=True)
class DecayResult:
    """A certified decay rate on a box (``alpha = 0``: none certified)."""

    certificate: Certificate
    status: Verdict
    graph: str
    box: GainBox
    alpha: Fraction
    kappa: float
    reason: str

    def settling_time(self, r: float, eps: float) -> float:
        """Guaranteed time to ``|x| <= eps`` from ``|x(0)| <= r`` (``inf`` without a rate)."""
        return settling_time(self.alpha, self.kappa, r, eps)

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"certificate": str(self.certificate), "status": str(self.status),
                        "graph": self.graph, "box": self.box.to_dict(), "alpha": self.alpha,
                        "kappa": json_number(self.kappa), "reason": self.reason})


def settling_time(alpha: Any, kappa: float, r: float, eps: float) -> float:
    """``ln(sqrt(kappa) r / eps) / alpha`` (0 when already inside, ``inf`` for ``alpha <= 0``).

    >>> round(settling_time(Fraction(1, 2), 4.0, 1.0, 0.01), 4)
    10.5966
    """
    a = float(alpha)
    if a <= 0:
        return math.inf
    return max(0.0, math.log(math.sqrt(kappa) * r / eps) / a)


def _check_rate(mats: dict, alpha: Fraction, clusters: Any) -> bool:
    """Exact: ``-(F + 2 alpha P) > 0`` and ``P > 0`` for every vertex entry set and cluster."""
    for (pc, fc) in mats.values():
        neg = [[-(f + 2 * alpha * p) for f, p in _pad(fi, pi)] for fi, pi in zip(fc, pc)]
        for c in clusters:
            if check_pd_coeffs(pc[0], pc[1], pc[2], c)[0] != 1 or check_pd_coeffs(neg[0], neg[1], neg[2], c)[0] != 1:
                return False
    return True


def _pad(a: list[Fraction], b: list[Fraction]) -> list[tuple[Fraction, Fraction]]:
    n = max(len(a), len(b))
    return [(a[i] if i < len(a) else Fraction(0), b[i] if i < len(b) else Fraction(0)) for i in range(n)]


def _kappa(p_num: list[np.ndarray]) -> float:
    k = 1.0
    for m in p_num:
        w = np.linalg.eigvalsh((m + m.T) / 2)
        if w[0] <= 0:
            return math.inf
        k = max(k, float(w[-1] / w[0]))
    return k


_LAMBDIFIED: dict[tuple, tuple[Any, Any, ModeModel]] = {}


def _paper_functions(mm: ModeModel, syms: tuple) -> tuple[Any, Any]:
    key = (id(mm), syms)
    if key not in _LAMBDIFIED:  # mode models are cached, so the id is stable (the model is kept)
        p, f = mm.p_paper, mm.vdot(mm.p_paper)
        _LAMBDIFIED[key] = (sp.lambdify((LAMBDA, *syms), p, "numpy"),
                            sp.lambdify((LAMBDA, *syms), f, "numpy"), mm)
    fp, ff, _ = _LAMBDIFIED[key]
    return fp, ff


def _exact_rate_preview(mm: ModeModel, sp_: LaplacianSpectrum, box: GainBox, mult: dict) -> tuple[float, list]:
    """Floating-point best rate of the specification's V at the vertices (a hint) and the
    vertex matrices ``P`` (for ``kappa``)."""
    syms = (*mm.gains, *mult)
    full = GainBox((*box.ranges, *mult.values())) if mult else box
    fp, ff = _paper_functions(mm, tuple(syms))
    rates, pnum = [], []
    for v in full.vertices():
        gv = [float(x) for x in v]
        for c in sp_.clusters:
            pn = np.array(fp(c.mid, *gv), dtype=float)
            fn = np.array(ff(c.mid, *gv), dtype=float)
            pnum.append(pn)
            w = np.linalg.eigvalsh((pn + pn.T) / 2)
            if w[0] <= 0:
                return -math.inf, pnum
            li = np.linalg.inv(np.linalg.cholesky(pn))
            rates.append(float(np.linalg.eigvalsh(li @ (-fn) @ li.T).min()) / 2)
    return min(rates), pnum


def _exact_rate(mm: ModeModel, sp_: LaplacianSpectrum, box: GainBox, mult: dict,
                alpha0: float) -> Fraction | None:
    """Round ``alpha0`` down and re-check ``-(F + 2 alpha P) > 0`` exactly (halving until it passes)."""
    syms = (*mm.gains, *mult)
    full = GainBox((*box.ranges, *mult.values())) if mult else box
    p, f = mm.p_paper, mm.vdot(mm.p_paper)
    ij = ((0, 0), (0, 1), (1, 1))
    mats = {v: ([entry_coeffs(p[i, j], dict(zip(syms, v))) for i, j in ij],
                [entry_coeffs(f[i, j], dict(zip(syms, v))) for i, j in ij]) for v in full.vertices()}
    alpha = Fraction(alpha0 * (1 - 1e-6)).limit_denominator(10**9)
    for _ in range(30):
        if _check_rate(mats, alpha, sp_.clusters):
            return alpha
        alpha /= 2
    return None


def certified_decay_rate(graph: Any, box: Any, certificate: str = "exact", *, spec: Any = None,
                         bisections: int = 24) -> DecayResult:
    """The largest decay rate ``alpha`` (``V' <= -2 alpha V``) certified on a box of the
    design's gains (``exact``: the specification's ``V``, a multiplier not given chosen
    for the best rate among the grid values that certify; ``searched``: the class).

    Examples
    --------
    >>> r = certified_decay_rate("ring:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    >>> r.status.value, 0.0 < float(r.alpha) < spectral_decay_rate("ring:8", (1.6, 0.4, 0.3))
    ('certified', True)
    >>> pd = certified_decay_rate("ring:8", {"k_p": 0.4, "k_d": 1.6}, "searched", spec="pd_consensus")
    >>> 0.0 < float(pd.alpha) <= spectral_decay_rate("ring:8", (0.4, 1.6), spec="pd_consensus")
    True
    """
    cert = Certificate(str(certificate))
    if cert not in (Certificate.EXACT, Certificate.SEARCHED):
        raise InputError(f"expected a decay certificate 'exact' or 'searched', received {certificate!r}")
    g = make_graph(graph)
    mm = mode_model(spec)
    b, given = split_box(mm, box)
    shown = GainBox((*b.ranges, *given.ranges)) if given is not None else b
    sp_ = laplacian_spectrum(g)
    # a rate needs a Lyapunov function first: the exact verdict (never a solver's) decides
    base = certify(g, shown, cert, spec=spec, spectrum=sp_)
    if base.status is not Verdict.CERTIFIED:
        return DecayResult(cert, base.status if base.status is Verdict.REFUTED else Verdict.UNDECIDED,
                           g.name, shown, Fraction(0), math.inf, base.reason)
    if cert is Certificate.EXACT:
        previews = []
        for cand in exact_candidates(mm, given):
            a0, pnum = _exact_rate_preview(mm, sp_, b, cand)
            if a0 > 0:
                previews.append((a0, cand, pnum))
        previews.sort(key=lambda x: -x[0])
        for a0, cand, pnum in previews[:4]:  # the best few by the float preview, proven exactly
            if certify_exact_with(mm, sp_, b, cand)[0] is not Verdict.CERTIFIED:
                continue
            alpha = _exact_rate(mm, sp_, b, cand, a0)
            if alpha is not None:
                chosen = "".join(f", {s.name} = {float(r.lo):g}" for s, r in cand.items()
                                 if given is None or s.name not in given.names)
                return DecayResult(cert, Verdict.CERTIFIED, g.name, shown, alpha, _kappa(pnum),
                                   "exact re-check of -(F + 2 alpha P) > 0 at every vertex and mode" + chosen)
        return DecayResult(cert, Verdict.UNDECIDED, g.name, shown, Fraction(0), math.inf,
                           "no rate passed the exact re-check")
    # searched: bisection per cluster
    lmi = SearchedLMI(mm, b)
    monos = monomials(b)
    f = mm.vdot(mm.p_class)
    best = math.inf
    coeffs_per: list[tuple[Any, list[list[Fraction]]]] = []
    for c in sp_.clusters:
        st, co = lmi.solve(c.mid, 0.0)
        if co is None or lmi.t_value <= 0:
            return DecayResult(cert, Verdict.UNDECIDED, g.name, shown, Fraction(0), math.inf,
                               f"the decay-rate LMI for the mode lambda ~ {c.mid:g} ended '{st}'")
        lo, hi, good = 0.0, 1.0, co
        while True:  # bracket
            st, co = lmi.solve(c.mid, hi)
            if co is None or lmi.t_value <= 0:
                break
            lo, good, hi = hi, co, hi * 2
            if hi > 1e6:
                break
        for _ in range(bisections):
            mid = (lo + hi) / 2
            st, co = lmi.solve(c.mid, mid)
            if co is not None and lmi.t_value > 1e-9:
                lo, good = mid, co
            else:
                hi = mid
        best = min(best, lo)
        coeffs_per.append((c, [[Fraction(x).limit_denominator(10**8) for x in q] for q in good]))
    alpha = Fraction(best * (1 - 1e-4)).limit_denominator(10**9)
    ij = ((0, 0), (0, 1), (1, 1))
    ents = {v: ([lp_coeffs(mm.p_class[i, j], gain_subs(mm, v), mm.free) for i, j in ij],
                [lp_coeffs(f[i, j], gain_subs(mm, v), mm.free) for i, j in ij]) for v in b.vertices()}
    pnum = []
    for _ in range(30):
        ok = True
        for c, q in coeffs_per:
            for v in b.vertices():
                pv = free_values(q, monos, v)
                pc = [with_p(d, pv) for d in ents[v][0]]
                fc = [with_p(d, pv) for d in ents[v][1]]
                if not _check_rate({v: (pc, fc)}, alpha, [c]):
                    ok = False
                    break
                lam = c.mid
                fsub = {x: lam * float(val) for x, val in zip(mm.free, pv)}
                pnum.append(np.array(mm.p_class.subs({**gain_subs(mm, v), LAMBDA: lam, **fsub}), dtype=float))
            if not ok:
                break
        if ok:
            return DecayResult(cert, Verdict.CERTIFIED, g.name, shown, alpha, _kappa(pnum),
                               "searched V (bisection on alpha, vertex LMIs), exact re-check")
        alpha /= 2
        pnum = []
    return DecayResult(cert, Verdict.UNDECIDED, g.name, shown, Fraction(0), math.inf,
                       "no rate passed the exact re-check")


def spectral_decay_rate(graph: Any, gains: Any, *, spec: Any = None) -> float:
    """True decay rate of the nominal linear loop on the disagreement subspace (floating point):
    ``min_k -max Re(roots of det(s I - A_k))`` over the nonzero Laplacian eigenvalues, at a
    gain point of the design's controller gains.

    >>> round(spectral_decay_rate("complete:4", (2, 1, 0.1)), 6)   # s^2 + 2 s + 4: Re = -1
    1.0
    >>> round(spectral_decay_rate("complete:4", (1, 2), spec="pd_consensus"), 6)   # s^2 + 2 s + 4
    1.0
    """
    mm = mode_model(spec)
    cqd, cs = (float(x) for x in mm.coefficients(gains))
    lam = make_graph(graph).laplacian_eigenvalues[1:]
    worst = math.inf
    for lk in lam:
        roots = np.roots([1.0, -cqd, -cs * float(lk)])
        worst = min(worst, float(-roots.real.max()))
    return worst


def performance_section(graphs: tuple[str, ...] = ("ring:8", "star:8", "complete:8"),
                        point: tuple[str, str, str] = ("2.5", "0.4", "0.3")) -> list[str]:
    """Markdown lines: certified decay rates and settling times at a gain point, per graph."""
    pt = dict(zip(GAINS, point))
    r0, eps = 0.5, 0.01
    lines = ["## Certified decay rate and settling time (item 2)", "",
             f"Gains (K_o, K_q, beta) = ({', '.join(point)}); settling time to |x| <= {eps:g} from any "
             f"initial disagreement |x(0)| <= {r0:g} (mode coordinates of q and q'), from "
             "`V' <= -2 alpha V` (exact re-check). The true rate of the nominal linear loop is",
             "the outer bound (floating point).", "",
             "| graph | alpha (paper's V) | alpha (searched) | true rate | T_settle (searched) |",
             "|---|---|---|---|---|"]
    for g in graphs:
        ex = certified_decay_rate(g, pt, "exact")
        se = certified_decay_rate(g, pt, "searched")
        tr = spectral_decay_rate(g, [Fraction(x) for x in point])
        ts = se.settling_time(r0, eps)
        lines.append(f"| {make_graph(g).name} | {float(ex.alpha):.4g} ({ex.status.value}) | "
                     f"{float(se.alpha):.4g} ({se.status.value}) | {tr:.4g} | "
                     + ("-" if math.isinf(ts) else f"{ts:.3g} s") + " |")
    lines.append("")
    return lines
