"""The ``searched`` certificate: a quadratic Lyapunov function of the design's class, common
over a gain box (vertex LMIs, cvxpy + Clarabel, exact re-check), or an exact refutation.

Class (:attr:`~.modes.ModeModel.p_class`, per Laplacian mode): with a switching term the
gradient in ``q_i'`` is the controller's switching argument, ``P_k = [[p, rho_s lambda],
[rho_s lambda, rho_qd]]``, free ``p``; without one (e.g. the PD baseline) every quadratic
``V`` of the mode, ``P_k = [[p, r], [r, 1]]``, free ``p`` and ``r``.  Each free entry is
``lambda`` times a multi-affine function of the box's free gains (one coefficient per
vertex monomial), solved per eigenvalue cluster; the matrices are then multi-affine in the
gains, so the vertices decide the box.  The solver's coefficients are rounded to
rationals and every vertex LMI is re-checked exactly over the eigenvalue enclosure.

Refutations (exact): a diagonal entry of ``A_k^T P_k + P_k A_k`` that no free entry
reaches is ``>= 0`` at a vertex (``Z = e_i e_i^T`` is a dual certificate: ``<F, Z> >= 0``
for every member), or a fixed entry of ``P_k`` is ``<= 0``; or the nominal loop is not
asymptotically stable at a vertex (a Routh-Hurwitz condition fails on the whole
enclosure), so no Lyapunov function of any class exists there.
"""

from __future__ import annotations

from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.analysis.modecheck import (
    check_pd_coeffs,
    entry_coeffs,
    gain_subs,
    hurwitz_conditions,
    lam_dict,
    multi_affine,
    vertex_dict,
)
from formsync_design.analysis.modes import LAMBDA, ModeModel
from formsync_design.analysis.results import Verdict
from formsync_design.analysis.spectrum import LaplacianSpectrum, poly_range
from formsync_design.gains import GainBox

__all__ = ["monomials", "monomial_value", "lp_coeffs", "with_p", "SearchedLMI", "class_dual",
           "unstable_vertex", "certify_searched", "free_values"]


def monomials(box: GainBox) -> list[tuple[int, ...]]:
    """Exponent vectors of the multi-affine monomials over the box's free axes.

    >>> monomials(GainBox.parse({"a": (1, 2), "b": 1}, ["a", "b"]))
    [(0, 0), (1, 0)]
    """
    free = [not r.is_point for r in box.ranges]
    out: list[tuple[int, ...]] = [()]
    for fr in free:
        out = [e + (0,) for e in out] + ([e + (1,) for e in out] if fr else [])
    return out


def monomial_value(e: tuple[int, ...], v: tuple[Any, ...]) -> Any:
    r: Any = 1
    for k, x in zip(e, v):
        if k:
            r = r * x
    return r


def lp_coeffs(expr: sp.Expr, sub: dict, free: tuple[sp.Symbol, ...]) -> dict[tuple[int, ...], Fraction]:
    """Exact coefficients of an entry in ``(lambda, *free)`` at rational gains."""
    return dict(_lp_coeffs_cached(sp.sympify(expr), tuple(sub.items()), free))


@lru_cache(maxsize=65536)
def _lp_coeffs_cached(expr: sp.Expr, items: tuple, free: tuple[sp.Symbol, ...]) -> tuple:
    sub = dict(items)
    e = sp.expand(sp.sympify(expr).xreplace({k: sp.Rational(v.numerator, v.denominator) for k, v in sub.items()}))
    if e == 0:
        return ()
    return tuple((tuple(int(i) for i in ex), Fraction(int(sp.Rational(c).p), int(sp.Rational(c).q)))
                 for ex, c in sp.Poly(e, LAMBDA, *free).terms())


def with_p(d: dict[tuple[int, ...], Fraction], values: tuple[Fraction, ...]) -> list[Fraction]:
    """Coefficients in ``lambda`` after each free entry ``= lambda * value``.

    >>> with_p({(0, 1): Fraction(1), (1, 0): Fraction(2)}, (Fraction(3),))   # p + 2 lambda
    [Fraction(0, 1), Fraction(5, 1)]
    """
    deg = max((sum(ex) for ex in d), default=0)
    out = [Fraction(0)] * (deg + 1)
    for ex, c in d.items():
        term = c
        for j, pi in zip(ex[1:], values):
            term *= pi**j
        out[sum(ex)] += term
    return out


def free_values(coeffs: list[list[Fraction]], monos: list[tuple[int, ...]], v: tuple[Any, ...]) -> tuple[Fraction, ...]:
    """The free entries over ``lambda`` at a vertex: ``sum_e c_e g^e`` per free entry."""
    return tuple(sum((qj * monomial_value(e, v) for qj, e in zip(q, monos)), Fraction(0)) for q in coeffs)


def class_dual(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox) -> dict | None:
    """An exact diagonal dual certificate refuting the searched class, if one exists."""
    f = mm.vdot(mm.p_class)
    fixed = [i for i in range(2) if not any(f[i, i].has(x) for x in mm.free)]
    pfixed = [i for i in range(2) if not any(mm.p_class[i, i].has(x) for x in mm.free)]
    for v in box.vertices():
        sub = gain_subs(mm, v)
        for c in spec_.clusters:
            for i in pfixed:
                rng = poly_range(entry_coeffs(mm.p_class[i, i], sub), c.lo, c.hi)
                if rng[1] <= 0:
                    return {"gains": vertex_dict(mm.names, v), "lambda": lam_dict(c),
                            "condition": f"P_{i + 1}{i + 1} > 0", "Z": f"W = e_{i + 1} e_{i + 1}^T",
                            "value_upper_bound": rng[1]}
            for i in fixed:
                lo, _ = poly_range(entry_coeffs(f[i, i], sub), c.lo, c.hi)
                if lo >= 0:
                    return {"gains": vertex_dict(mm.names, v), "lambda": lam_dict(c), "condition": "V' < 0",
                            "Z": f"e_{i + 1} e_{i + 1}^T", "F_entry": str(f[i, i]),
                            "value_lower_bound": lo}
    return None


def unstable_vertex(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox) -> dict | None:
    """A vertex and mode where a Routh-Hurwitz condition of the nominal loop is ``<= 0`` on the
    whole eigenvalue enclosure (exact): the loop is not asymptotically stable there, so no
    Lyapunov function of any class exists."""
    conds = hurwitz_conditions(mm.charpoly)
    for v in box.vertices():
        sub = gain_subs(mm, v)
        for c in spec_.clusters:
            for e in conds:
                _, hi = poly_range(entry_coeffs(e, sub), c.lo, c.hi)
                if hi <= 0:
                    return {"gains": vertex_dict(mm.names, v), "lambda": lam_dict(c),
                            "condition": f"{e} > 0", "upper_bound": hi}
    return None


class SearchedLMI:
    """The vertex LMIs of the searched class for one box, built once (cvxpy DPP).

    Unknowns: coefficients ``c_e`` of each free entry ``lambda * sum_e c_e g^e`` (the
    multi-affine monomials of the box's free gains).  :meth:`solve` maximises
    ``t`` subject to, at every vertex, ``T P T >= t I`` and ``-T F T >= t I``
    with ``T = diag(1/lambda, 1)`` (a congruence, for conditioning), for one
    eigenvalue.  The answer is a *hint*: the certificates round it and
    re-check it exactly.
    """

    def __init__(self, mm: ModeModel, box: GainBox) -> None:
        import cvxpy as cp

        self.monos = monomials(box)
        self.vertices = box.vertices()
        self.nfree = len(mm.free)
        f = mm.vdot(mm.p_class)
        zero = {x: 0 for x in mm.free}
        mats = [mm.p_class.subs(zero), *[mm.p_class.diff(x) for x in mm.free],
                f.subs(zero), *[f.diff(x) for x in mm.free]]
        self._fns = [sp.lambdify((LAMBDA, *mm.gains), m, "numpy") for m in mats]
        self.c = [cp.Variable(len(self.monos)) for _ in mm.free]
        self.t = cp.Variable()
        self.t_value = float("nan")
        self.params: list[list[Any]] = []
        cons = [self.t <= 1, *[cp.abs(c) <= 1e4 for c in self.c]]
        k = self.nfree
        for v in self.vertices:
            ps = [cp.Parameter((2, 2), symmetric=True) for _ in range(2 * (k + 1))]
            self.params.append(ps)
            pv = [sum(c[j] * float(monomial_value(e, v)) for j, e in enumerate(self.monos)) for c in self.c]
            pmat = ps[0] + sum(pv[m] * ps[1 + m] for m in range(k))
            fmat = ps[k + 1] + sum(pv[m] * ps[k + 2 + m] for m in range(k))
            cons += [pmat - self.t * np.eye(2) >> 0, -fmat - self.t * np.eye(2) >> 0]
        self.problem = cp.Problem(cp.Maximize(self.t), cons)

    def solve(self, lam: float, alpha: float = 0.0) -> tuple[str, list[list[float]] | None]:
        """Solve for one eigenvalue: ``(cvxpy status, coefficients per free entry or None)``.

        ``alpha > 0`` asks for the decay rate ``V' <= -2 alpha V``; the status
        is then ``"optimal"`` with ``t > 0`` only when that rate is feasible
        (:attr:`t_value` holds the optimum).
        """
        import cvxpy as cp

        from formsync_design.certify.sdp import CLARABEL_OPTIONS

        k = self.nfree
        tm = np.diag([1.0 / lam, 1.0])
        for v, ps in zip(self.vertices, self.params):
            g = [float(x) for x in v]
            ms = []
            for idx, fn in enumerate(self._fns):
                m = tm @ np.array(fn(lam, *g), dtype=float) @ tm
                if idx not in (0, k + 1):
                    m = m * lam  # each free entry = lambda * sum c_e g^e
                ms.append((m + m.T) / 2)
            for m in range(k + 1):  # F + 2 alpha P (decay rate)
                ms[k + 1 + m] = ms[k + 1 + m] + 2 * alpha * ms[m]
            for par, m in zip(ps, ms):
                par.value = m
        try:
            self.problem.solve(solver=cp.CLARABEL, **CLARABEL_OPTIONS)
        except (cp.error.SolverError, ValueError) as exc:  # pragma: no cover - solver failure
            return f"solver_error: {exc}", None
        st = str(self.problem.status)
        self.t_value = float(self.t.value) if self.t.value is not None else float("nan")
        values = [c.value for c in self.c]
        if st not in ("optimal", "optimal_inaccurate") or any(v is None for v in values):
            return st, None
        return st, [[float(x) for x in np.asarray(v)] for v in values]


def certify_searched(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox,
                     member: tuple[Verdict, str, Any, dict] | None = None) -> tuple[Verdict, str, Any, dict]:
    """Decide ``box`` with the searched class (module docstring).

    ``member``: the ``exact`` certificate's verdict on the box when the specification's own
    ``V`` is a member of the class (then a certified member needs no search).
    """
    if not multi_affine([mm.a, mm.p_class.subs({x: 0 for x in mm.free})], mm.gains):
        return Verdict.UNDECIDED, "the closed loop is not multi-affine in the gains", None, {}
    bad = unstable_vertex(mm, spec_, box)
    if bad is not None:
        return (Verdict.REFUTED, "the nominal loop is not asymptotically stable at a vertex of the box "
                "(a Routh-Hurwitz condition fails, exact): no Lyapunov function of any class exists there",
                bad, {"dual": "unstable"})
    dual = class_dual(mm, spec_, box)
    if dual is not None:
        what = "with the switching structure " if mm.switching else ""
        return (Verdict.REFUTED, f"an exact dual certificate shows that no quadratic V {what}exists at a "
                "vertex of the box", dual, {"dual": True})
    if member is not None and member[0] is Verdict.CERTIFIED:
        return (Verdict.CERTIFIED, "the specification's own V is a member of the class and passes the exact "
                "re-check (no search needed)", None, {"member": "paper V", **member[3]})
    monos = monomials(box)
    statuses: dict[str, int] = {}
    coeffs_out = []
    f = mm.vdot(mm.p_class)
    lmi = SearchedLMI(mm, box)
    ij = ((0, 0), (0, 1), (1, 1))
    ents = {v: [(name, [lp_coeffs(mat[i, j], gain_subs(mm, v), mm.free) for i, j in ij])
                for name, mat in (("V > 0", mm.p_class), ("V' < 0", -f))] for v in box.vertices()}
    for c in spec_.clusters:
        status, coeffs = lmi.solve(c.mid)
        statuses[status] = statuses.get(status, 0) + 1
        if coeffs is None:
            return (Verdict.UNDECIDED, f"the LMI solve for the mode lambda ~ {c.mid:g} ended "
                    f"'{status}' and no dual certificate was found", None, {"solver": statuses})
        q = [[Fraction(x).limit_denominator(10**8) for x in co] for co in coeffs]
        coeffs_out.append({"lambda": lam_dict(c), "coefficients": q if len(q) > 1 else q[0]})
        for v in box.vertices():
            pv = free_values(q, monos, v)
            for name, ent in ents[v]:
                ok, _, _ = check_pd_coeffs(with_p(ent[0], pv), with_p(ent[1], pv), with_p(ent[2], pv), c)
                if ok <= 0:
                    return (Verdict.UNDECIDED, f"the searched V (rounded) fails the exact re-check of "
                            f"{name} for the mode lambda ~ {c.mid:g}; no dual certificate either",
                            None, {"solver": statuses})
    what = "with the switching structure" if mm.switching else "(the design has no switching term: every quadratic V of the mode)"
    return (Verdict.CERTIFIED, f"a quadratic V {what}, multi-affine in the gains, passes the exact re-check at "
            "every vertex and mode", None,
            {"solver": statuses, "p_over_lambda": coeffs_out if len(coeffs_out) <= 8 else coeffs_out[:8],
             "free": [str(x) for x in mm.free],
             "monomials": ["*".join(g for g, k in zip(mm.names, e) if k) or "1" for e in monos]})
