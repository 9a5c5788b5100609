"""Gain design: maximize the certified margin over user ranges.

For a fixed ``beta`` every family is affine in ``(K_o, K_q)`` (checked term by
term: no monomial may contain both, or a square), so

    maximize  t - rho * (K_o / K_o_hi + K_q / K_q_hi)
    s.t.      F_b(K_o, K_q; beta) - t I  >= 0    for every distinct block b,
              K_o, K_q within the user ranges

is a genuine SDP (cvxpy + Clarabel).  ``Pi``'s pencil block ``a I + b M``
enters as the two linear constraints ``a + b mu >= t`` at the ends of the
rigorous spectrum enclosure of ``M``.  ``beta`` is swept over a grid.  The
best point is rounded to a short rational, certified with
:func:`~formsync_design.certify.engine.certify_box`, and the largest box
``g_i * [1 - s, 1 + s]`` (intersected with the ranges) that is still certified
is found by bisection on ``s``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, cast

import numpy as np

from formsync_design.certify.engine import Bounds, as_box, certify_box
from formsync_design.certify.growbox import largest_certified_box
from formsync_design.certify.multipliers import agent_multiplier_ranges
from formsync_design.certify.results import STATUS_MAP, CertificationResult
from formsync_design.certify.sdp import CLARABEL_OPTIONS
from formsync_design.certify.structure import analyze, pencil_spectrum
from formsync_design.errors import DerivationError, InputError

__all__ = ["BetaStep", "DesignResult", "design_gains"]


@dataclass(frozen=True)
class BetaStep:
    """One SDP of the beta sweep (float values are solver hints)."""

    beta: Fraction
    raw_status: str
    outcome: str
    t: float | None
    K_o: float | None
    K_q: float | None
    objective: float | None
    solve_time: float
    iterations: int | None

    def to_dict(self) -> dict[str, Any]:
        return {
            "beta": float(self.beta),
            "raw_status": self.raw_status,
            "outcome": self.outcome,
            "margin_hint": self.t,
            "K_o": self.K_o,
            "K_q": self.K_q,
            "objective": self.objective,
            "solve_time_s": self.solve_time,
            "iterations": self.iterations,
        }


@dataclass(frozen=True)
class DesignResult:
    """Recommended gains and their certificates.

    ``status``: ``"designed"`` (the recommended point is certified),
    ``"infeasible"`` (no swept beta gives a positive margin hint),
    ``"undecided"`` (a point was found but not certified), ``"error"``.
    """

    status: str
    gains: dict[str, Fraction]
    margin: Fraction | None
    penalty: float
    sweep: tuple[BetaStep, ...]
    point: CertificationResult | None
    box: Bounds | None
    box_half_width: float
    box_result: CertificationResult | None
    ranges: Bounds
    elapsed: float
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        g = list(self.gains)
        return {
            "status": self.status,
            "reason": self.reason,
            "gains": {k: float(v) for k, v in self.gains.items()},
            "gains_exact": {k: str(v) for k, v in self.gains.items()},
            "certified_margin": None if self.margin is None else float(self.margin),
            "penalty": self.penalty,
            "ranges": {k: [float(lo), float(hi)] for k, (lo, hi) in zip(g, self.ranges)}
            if g else {},
            "largest_certified_box": None
            if self.box is None
            else {k: [float(lo), float(hi)] for k, (lo, hi) in zip(g, self.box)},
            "box_relative_half_width": self.box_half_width,
            "sweep": [s.to_dict() for s in self.sweep],
            "point_certificate": None if self.point is None else self.point.to_dict(),
            "box_certificate": None if self.box_result is None else self.box_result.to_dict(),
            "elapsed_s": self.elapsed,
        }


def _affine_split(st: Any, gains: tuple[str, ...]) -> None:
    # the first two box gains are optimized, the third is swept (liang2016: K_o, K_q; beta)
    ko, kq = 0, 1
    if len(gains) != 3:
        raise DerivationError(f"expected three box gains (two optimized, one swept), received {gains}")
    for b in st.blocks:
        for e in b.exps:
            if e[ko] + e[kq] > 1:
                raise DerivationError(
                    f"expected every family affine in ({gains[0]}, {gains[1]}) for fixed "
                    f"{gains[2]}, received a term with exponents {dict(zip(gains, e))}"
                )


def _sdp_at_beta(st: Any, gains: tuple[str, ...], beta: Fraction, rko: tuple, rkq: tuple,
                 penalty: float) -> BetaStep:
    import cvxpy as cp

    iko, ikq, ib = 0, 1, 2  # the optimized pair and the swept gain (see _affine_split)
    ko = cp.Variable()
    kq = cp.Variable()
    t = cp.Variable()
    bf = float(beta)
    cons = [ko >= float(rko[0]), ko <= float(rko[1]), kq >= float(rkq[0]), kq <= float(rkq[1])]

    def weight(e: tuple[int, ...], c: Fraction) -> Any:
        w: Any = float(c) * bf ** e[ib]
        if e[iko]:
            w = w * ko
        if e[ikq]:
            w = w * kq
        return w

    for b in st.blocks:
        ws = [weight(e, c) for e, c in zip(b.exps, b.coefs)]
        if b.pencil is not None:
            p = b.pencil
            pencil_spectrum(p)
            a = sum(w * float(al) for w, al in zip(ws, p.alphas))
            bb = sum(w * float(be) for w, be in zip(ws, p.betas))
            for mu in (float(p.mu_lo), float(p.mu_hi)):
                cons.append(a + bb * mu >= t)
        else:
            expr: Any = cp.Constant(np.zeros((b.size, b.size)))
            for w, m in zip(ws, b.mats):
                expr = expr + w * np.asarray(m, dtype=float)
            if b.size == 1:
                cons.append(expr[0, 0] >= t)
            else:
                sym = (expr + expr.T) / 2
                cons.append(sym - t * np.eye(b.size) >> 0)
    obj = t - penalty * (ko / float(rko[1]) + kq / float(rkq[1]))
    prob = cp.Problem(cp.Maximize(obj), cons)
    t0 = time.perf_counter()
    try:
        prob.solve(solver=cp.CLARABEL, **CLARABEL_OPTIONS)
        raw = str(prob.status)
    except cp.error.SolverError:
        raw = "solver_error"
    el = time.perf_counter() - t0
    outcome = STATUS_MAP.get(raw, "error")
    stats = getattr(prob, "solver_stats", None)
    ok = outcome in ("ok", "inaccurate") and t.value is not None
    return BetaStep(
        beta=beta,
        raw_status=raw,
        outcome=outcome,
        t=float(np.asarray(t.value)) if ok else None,
        K_o=float(np.asarray(ko.value)) if ok else None,
        K_q=float(np.asarray(kq.value)) if ok else None,
        objective=float(prob.value) if ok else None,
        solve_time=float(getattr(stats, "solve_time", None) or el),
        iterations=getattr(stats, "num_iters", None),
    )


def _nice(x: float, lo: Fraction, hi: Fraction) -> Fraction:
    """A short rational near ``x`` inside ``[lo, hi]``."""
    for den in (100, 1000, 10000, 10**6):
        q = Fraction(round(x * den), den)
        if lo <= q <= hi:
            return q
    return min(max(Fraction(x), lo), hi)


def _design_agent_conditions(conditions: Any, ranges: Any, *, design: Any = None, grid: int = 4) -> Any:
    """The agent gain design (:func:`~formsync_design.certify.agent.design_agent`: the grid
    point of ``ranges`` with the largest certified margin, multipliers searched, and the
    largest certified box around it) of agent ``conditions``; ``design`` default: the shipped
    design the conditions name."""
    from formsync_design.certify.agent import design_agent
    from formsync_design.gains import GainBox

    if design is None:
        from formsync_design.resources import design_names
        from formsync_design.spec.loader import load_design

        name = getattr(conditions, "design", None)
        if not isinstance(name, str) or name not in design_names():
            raise InputError(f"expected design= for the conditions of the unshipped design "
                             f"{name!r} (its multipliers' ranges), received none")
        design = load_design(name)
    box = ranges if isinstance(ranges, GainBox) else GainBox.parse(ranges)
    return design_agent(design, conditions, box, grid=grid)


def design_gains(
    conditions: Any,
    ranges: Any,
    *,
    betas: int | Sequence[Any] = 11,
    penalty: float = 0.0,
    margin: Any = 0,
    hold: Sequence[str] = (),
    design: Any = None,
) -> DesignResult:
    """Recommend ``(K_o, K_q, beta)`` maximizing the certified margin.

    An agent design's conditions (:func:`~formsync_design.derive.agent.agent_conditions`)
    are designed by :func:`~formsync_design.certify.agent.design_agent` (the point of a
    ``betas``-per-axis grid with the largest certified margin, multipliers searched, and the
    largest certified box around it; ``design``: the agent design, default the shipped one
    the conditions name); it returns an
    :class:`~formsync_design.certify.agent.AgentGainDesign`.

    For another design the first two box gains play ``K_o, K_q`` (optimized by the
    SDP, the families must be affine in them) and the third ``beta`` (swept); a gain
    named in ``hold`` (a design's multiplier) keeps its recommended value when the
    largest certified box is grown around the point.

    Parameters
    ----------
    conditions : LyapunovConditions
    ranges : box of user ranges (see :func:`~formsync_design.certify.engine.as_box`)
    betas : int or sequence
        Number of beta values on a uniform grid of the beta range (a point
        range gives one), or explicit values.
    penalty : float
        Weight ``rho >= 0`` on ``K_o / K_o_hi + K_q / K_q_hi`` (gain size).
    margin : number
        Margin required of the final boxes.

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> d = design_gains(derive_conditions("ring:6"),
    ...                  {"K_o": (0.1, 3), "K_q": (0.1, 3), "beta": (0.05, 0.5)}, betas=4)
    >>> d.status, str(d.point.status)
    ('designed', 'certified')
    """
    if str(getattr(conditions, "source", "")).startswith("agent"):
        grid = int(betas) if isinstance(betas, (int, np.integer)) and betas > 1 else 4
        return _design_agent_conditions(conditions, ranges, design=design, grid=grid)
    if isinstance(ranges, Mapping) and any(n not in ranges for n in conditions.gains):
        # a multiplier not given: swept over its declared range and held (as formsync design)
        mult = agent_multiplier_ranges(conditions, ranges, design)
        ranges = {**ranges, **{n: (r.lo, r.hi) for n, r in mult.items()}}
        hold = tuple(hold) + tuple(n for n in mult if n not in hold)
    t0 = time.perf_counter()
    gains = tuple(conditions.gains)
    rng = as_box(ranges, gains).bounds
    if not (np.isfinite(penalty) and penalty >= 0):
        raise InputError(f"expected a non-negative finite penalty, received {penalty!r}")
    st = analyze(conditions.families)
    _affine_split(st, gains)
    ib = 2
    blo, bhi = rng[ib]
    if isinstance(betas, (int, np.integer)) and not isinstance(betas, bool):
        if betas < 1:
            raise InputError(f"expected at least one beta value, received {betas}")
        if blo == bhi or betas == 1:
            bl = [blo if blo == bhi else (blo + bhi) / 2]
        else:
            bl = [blo + (bhi - blo) * Fraction(i, betas - 1) for i in range(betas)]
    else:
        bl = [as_box({**{g: rng[k] for k, g in enumerate(gains)}, gains[ib]: b}, gains).bounds[ib][0]
              for b in cast(Sequence[Any], betas)]
        for b in bl:
            if not blo <= b <= bhi:
                raise InputError(
                    f"expected beta values in [{float(blo):g}, {float(bhi):g}], received {float(b):g}"
                )
    rko, rkq = rng[0], rng[1]
    sweep = tuple(_sdp_at_beta(st, gains, b, rko, rkq, penalty) for b in bl)
    good = [s for s in sweep if s.outcome == "ok" and s.objective is not None]
    if any(s.outcome == "error" for s in sweep) and not good:
        return DesignResult("error", {}, None, penalty, sweep, None, None, 0.0, None, rng,
                            time.perf_counter() - t0, "unknown solver status")
    if not good or max(s.t for s in good if s.t is not None) <= float(margin):
        return DesignResult("infeasible", {}, None, penalty, sweep, None, None, 0.0, None, rng,
                            time.perf_counter() - t0,
                            "no swept beta gives a positive margin within the ranges")
    best = max(good, key=lambda s: (s.objective, -float(s.beta)))
    assert best.K_o is not None and best.K_q is not None
    gk = {
        gains[0]: _nice(best.K_o, *rko),
        gains[1]: _nice(best.K_q, *rkq),
        gains[2]: best.beta,
    }
    pt = {g: gk[g] for g in gains}
    res = certify_box(conditions, pt, margin=margin)
    if not res.certified:
        return DesignResult("undecided", pt, None, penalty, sweep, res, None, 0.0, None, rng,
                            time.perf_counter() - t0,
                            f"the rounded optimum is {res.status}: {res.reason}")
    grow = tuple((pt[g], pt[g]) if g in hold else r for g, r in zip(gains, rng))
    bx, s, bres = largest_certified_box(conditions, pt, grow, margin=margin)
    return DesignResult(
        status="designed",
        gains=pt,
        margin=res.margin_lower_bound,
        penalty=penalty,
        sweep=sweep,
        point=res,
        box=bx,
        box_half_width=s,
        box_result=bres,
        ranges=rng,
        elapsed=time.perf_counter() - t0,
    )
