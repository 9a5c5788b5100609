"""Four certificates of a gain box ``(K_o, K_q, beta)``, one comparison.

For a design whose closed loop the engine derives (default: Liang et al. 2016),
:func:`certify` decides a gain box with one of

``paper``
    the paper's per-spacecraft sufficient test (each ``Theta_i > 0`` and
    ``Pi > 0``), by :func:`formsync_design.certify.engine.certify_box` on
    :func:`formsync_design.derive.conditions.derive_conditions` (today's test).
``exact``
    the paper's *own* Lyapunov function ``V = sum_i V_i`` on the whole graph:
    ``V > 0`` on the disagreement subspace and ``V' < 0`` along the nominal
    loop, decided per Laplacian mode (:mod:`.modes`): ``P_k > 0`` and
    ``A_k^T P_k + P_k A_k < 0`` for every eigenvalue ``lambda_k > 0``.  Both
    matrices are multi-affine in the gains (checked symbolically), so for fixed
    ``x`` the quadratic form is multi-affine and its extremes over the box are
    at the vertices: checking the vertices is exact.
``searched``
    a searched quadratic ``V`` with the switching structure: per mode
    ``P_k = [[p_k(g), rho_s lambda], [rho_s lambda, rho_qd]]`` (the gradient in
    ``q_i'`` is the controller's switching argument, so ``-K_v arg^T sgn(arg)``
    stays dissipative), with ``p_k`` multi-affine in the gains (one
    coefficient per vertex monomial).  The class contains the paper's ``V``, so
    ``exact`` certified implies ``searched`` certified.  Vertex LMIs solved with
    cvxpy + Clarabel give a *hint*; the coefficients are rounded to rationals
    and every vertex LMI is re-checked exactly over the eigenvalue enclosure.
    When a diagonal entry of ``A_k^T P_k + P_k A_k`` that the free entry does
    not reach is ``>= 0`` at some vertex, ``Z = e_i e_i^T`` is an exact dual
    certificate: ``<F, Z> >= 0`` for every member of the class, so **no**
    function of the class exists for that gain point (a refutation of the class,
    not of a candidate).  For Liang's design the entry is
    ``2 (beta lambda_max - K_o)``; per-spacecraft scalings ``D`` of the
    gradient do not help either (``vec^T (beta (D L + L D) - 2 K_o D) vec
    = 2 (beta lambda_max - K_o) vec^T D vec`` for the top eigenvector), so the
    remaining gap to ``spectral`` needs a non-quadratic function or a
    boundary-layer ultimate-bound argument that does not rely on the switching
    term being dissipative.
``spectral``
    the true stability region of the nominal linear loop: every
    ``det(s I - A_k)`` (derived) Hurwitz, by the Routh-Hurwitz conditions
    (coefficients and Hurwitz minors positive) with exact interval bounds over
    the box and the eigenvalue enclosure.  The outer bound.

Every verdict is exact rational arithmetic over rigorous eigenvalue enclosures
(:mod:`.spectrum`); a solver's output never decides.
"""

from __future__ import annotations

import time
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.analysis.modes import (
    LAMBDA,
    P_FREE,
    ModeModel,
    mode_model,
    poly_coeffs_in_lambda,
    poly_mul,
)
from formsync_design.analysis.results import Certificate, CertificateResult, Verdict
from formsync_design.analysis.spectrum import (
    LaplacianSpectrum,
    SpectrumCluster,
    laplacian_spectrum,
    poly_range,
)
from formsync_design.errors import InputError
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph

__all__ = ["GAINS", "certify", "check_pd_2x2", "hurwitz_conditions", "box_poly_range", "SearchedLMI",
           "check_pd_coeffs", "entry_coeffs", "lp_coeffs", "with_p", "monomials", "monomial_value",
           "gain_subs"]

GAINS = ("K_o", "K_q", "beta")


def gain_subs(mm: ModeModel, vertex: tuple[Fraction, ...]) -> dict:
    return dict(zip(mm.gains, vertex))


def _psub(a: list[Fraction], b: list[Fraction]) -> list[Fraction]:
    n = max(len(a), len(b))
    return [(a[i] if i < len(a) else Fraction(0)) - (b[i] if i < len(b) else Fraction(0)) for i in range(n)]


def check_pd_coeffs(
    m11: list[Fraction], m12: list[Fraction], m22: list[Fraction], cluster: SpectrumCluster
) -> tuple[int, str, tuple[Fraction, Fraction]]:
    """Decide ``[[m11, m12], [m12, m22]](lambda) > 0`` over the cluster's enclosure.

    Entries are exact coefficient lists in ascending powers of ``lambda``.
    Returns ``(+1 | -1 | 0, which, range)``: ``+1`` certified (``m11 > 0`` and
    ``det > 0`` over the whole enclosure), ``-1`` refuted (one of them ``<= 0``
    over the whole enclosure, hence at the true eigenvalue), ``0`` undecided;
    ``which`` names the deciding quantity and ``range`` its exact enclosure.

    >>> from formsync_design.analysis.spectrum import SpectrumCluster
    >>> c = SpectrumCluster(Fraction(2), Fraction(2), 1)
    >>> one, lam = [Fraction(1)], [Fraction(0), Fraction(1)]
    >>> check_pd_coeffs(lam, one, one, c)
    (1, 'det', (Fraction(1, 1), Fraction(1, 1)))
    >>> check_pd_coeffs(one, lam, one, c)[0]
    -1
    """
    r11 = poly_range(m11, cluster.lo, cluster.hi)
    det = poly_range(_psub(poly_mul(m11, m22), poly_mul(m12, m12)), cluster.lo, cluster.hi)
    if r11[1] <= 0:
        return -1, "M11", r11
    if det[1] <= 0:
        return -1, "det", det
    if r11[0] > 0 and det[0] > 0:
        return 1, "det", det
    return 0, "det" if det[0] <= 0 else "M11", det if det[0] <= 0 else r11


def entry_coeffs(expr: sp.Expr, sub: dict) -> list[Fraction]:
    """Coefficients in ``lambda`` of an entry at rational gains (cached: grid cells share vertices)."""
    return list(_entry_coeffs_cached(sp.sympify(expr), tuple(sub.items())))


@lru_cache(maxsize=65536)
def _entry_coeffs_cached(expr: sp.Expr, items: tuple) -> tuple[Fraction, ...]:
    return tuple(poly_coeffs_in_lambda(expr, dict(items)))


def check_pd_2x2(m: sp.Matrix, subs: dict, cluster: SpectrumCluster) -> tuple[int, str, tuple[Fraction, Fraction]]:
    """:func:`check_pd_coeffs` for a symbolic 2x2 matrix in ``lambda`` at rational gains ``subs``.

    >>> from formsync_design.analysis.spectrum import SpectrumCluster
    >>> c = SpectrumCluster(Fraction(2), Fraction(2), 1)
    >>> check_pd_2x2(sp.Matrix([[LAMBDA, 1], [1, 1]]), {}, c)[0]
    1
    """
    return check_pd_coeffs(entry_coeffs(m[0, 0], subs), entry_coeffs(m[0, 1], subs),
                           entry_coeffs(m[1, 1], subs), cluster)


def _multi_affine(mats: list[sp.Matrix], gains: tuple[sp.Symbol, ...]) -> bool:
    return all(sp.degree(e, g) <= 1 for mat in mats for e in mat for g in gains if e != 0)


def _lam(c: SpectrumCluster) -> dict[str, Any]:
    return {"lo": c.lo, "hi": c.hi, "multiplicity": c.multiplicity}


def _vertex_dict(v: tuple[Fraction, ...]) -> dict[str, Fraction]:
    return dict(zip(GAINS, v))


# ---------------------------------------------------------------------------
# (b) exact: the paper's V on the whole graph
# ---------------------------------------------------------------------------
def _certify_exact(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox) -> tuple[Verdict, str, Any, dict]:
    p = mm.p_paper
    f = mm.vdot(p)
    if not _multi_affine([p, f], mm.gains):
        return (Verdict.UNDECIDED, "the Lyapunov matrices are not multi-affine in the gains; "
                "vertex checks would not be exact", None, {})
    checks = 0
    undecided = None
    for v in box.vertices():
        sub = gain_subs(mm, v)
        polys = [(name, [entry_coeffs(mat[i, j], sub) for i, j in ((0, 0), (0, 1), (1, 1))])
                 for name, mat in (("V > 0", p), ("V' < 0", -f))]
        for c in spec_.clusters:
            for name, ent in polys:
                st, which, rng = check_pd_coeffs(ent[0], ent[1], ent[2], c)
                checks += 1
                if st < 0:
                    w = {"gains": _vertex_dict(v), "lambda": _lam(c), "condition": name,
                         "quantity": which, "upper_bound": rng[1]}
                    return (Verdict.REFUTED, f"the paper's V fails {name} at a vertex for the mode "
                            f"lambda in [{float(c.lo):g}, {float(c.hi):g}]", w, {"checks": checks})
                if st == 0 and undecided is None:
                    undecided = (v, c, name)
    if undecided is not None:
        v, c, name = undecided
        return (Verdict.UNDECIDED, f"{name} could not be decided over the eigenvalue enclosure "
                f"[{float(c.lo):g}, {float(c.hi):g}]", None, {"checks": checks})
    return (Verdict.CERTIFIED, "the paper's V > 0 and V' < 0 on the disagreement subspace at every "
            "vertex and mode (multi-affine in the gains: exact for the box)", None, {"checks": checks})


# ---------------------------------------------------------------------------
# (c) searched: vertex LMIs + exact re-check, or an exact dual certificate
# ---------------------------------------------------------------------------
def monomials(box: GainBox) -> list[tuple[int, ...]]:
    """Exponent vectors of the multi-affine monomials over the box's free axes."""
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


def _class_dual(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox) -> dict | None:
    """An exact diagonal dual certificate refuting the searched class, if one exists."""
    f = mm.vdot(mm.p_class)
    fixed = [i for i in range(2) if not f[i, i].has(P_FREE)]
    pqd = mm.p_class[1, 1]
    for v in box.vertices():
        sub = gain_subs(mm, v)
        for c in spec_.clusters:
            lo22 = poly_range(poly_coeffs_in_lambda(pqd, sub), c.lo, c.hi)
            if lo22[1] <= 0:
                return {"gains": _vertex_dict(v), "lambda": _lam(c), "condition": "P_22 > 0",
                        "Z": "W = e_2 e_2^T", "value_upper_bound": lo22[1]}
            for i in fixed:
                lo, _ = poly_range(poly_coeffs_in_lambda(f[i, i], sub), c.lo, c.hi)
                if lo >= 0:
                    return {"gains": _vertex_dict(v), "lambda": _lam(c), "condition": "V' < 0",
                            "Z": f"e_{i + 1} e_{i + 1}^T", "F_entry": str(f[i, i]),
                            "value_lower_bound": lo}
    return None


class SearchedLMI:
    """The vertex LMIs of the searched class for one box, built once (cvxpy DPP).

    Unknowns: coefficients ``c_e`` of ``p(g) = lambda * sum_e c_e g^e`` (the
    multi-affine monomials of the box's free gains).  :meth:`solve` maximises
    ``t`` subject to, at every vertex, ``T P T >= t I`` and ``-T F T >= t I``
    with ``T = diag(1/lambda, 1)`` (a congruence, for conditioning), for one
    eigenvalue.  The answer is a *hint*: :func:`certify` rounds it and
    re-checks it exactly.
    """

    def __init__(self, mm: ModeModel, box: GainBox) -> None:
        import cvxpy as cp

        self.monos = monomials(box)
        self.vertices = box.vertices()
        f = mm.vdot(mm.p_class)
        mats = [mm.p_class.subs(P_FREE, 0), mm.p_class.diff(P_FREE), f.subs(P_FREE, 0), f.diff(P_FREE)]
        self._fns = [sp.lambdify((LAMBDA, *mm.gains), m, "numpy") for m in mats]
        self.c = cp.Variable(len(self.monos))
        self.t = cp.Variable()
        self.params: list[list[Any]] = []
        cons = [self.t <= 1, cp.abs(self.c) <= 1e4]
        for v in self.vertices:
            ps = [cp.Parameter((2, 2), symmetric=True) for _ in range(4)]
            self.params.append(ps)
            pv = sum(self.c[j] * float(monomial_value(e, v)) for j, e in enumerate(self.monos))
            cons += [ps[0] + pv * ps[1] - self.t * np.eye(2) >> 0,
                     -(ps[2] + pv * ps[3]) - self.t * np.eye(2) >> 0]
        self.problem = cp.Problem(cp.Maximize(self.t), cons)

    def solve(self, lam: float, alpha: float = 0.0) -> tuple[str, list[float] | None]:
        """Solve for one eigenvalue: ``(cvxpy status, coefficients or None)``.

        ``alpha > 0`` asks for the decay rate ``V' <= -2 alpha V``; the status
        is then ``"optimal"`` with ``t > 0`` only when that rate is feasible
        (:attr:`t` holds the optimum).
        """
        import cvxpy as cp

        from formsync_design.certify.engine import CLARABEL_OPTIONS

        tm = np.diag([1.0 / lam, 1.0])
        for v, ps in zip(self.vertices, self.params):
            g = [float(x) for x in v]
            ms = []
            for k, fn in enumerate(self._fns):
                m = tm @ np.array(fn(lam, *g), dtype=float) @ tm
                if k in (1, 3):
                    m = m * lam  # p = lambda * sum c_e g^e
                ms.append((m + m.T) / 2)
            ms[2] = ms[2] + 2 * alpha * ms[0]  # F + 2 alpha P (decay rate)
            ms[3] = ms[3] + 2 * alpha * ms[1]
            for par, m in zip(ps, ms):
                par.value = m
        try:
            self.problem.solve(solver=cp.CLARABEL, **CLARABEL_OPTIONS)
        except (cp.error.SolverError, ValueError) as exc:  # pragma: no cover - solver failure
            return f"solver_error: {exc}", None
        st = str(self.problem.status)
        self.t_value = float(self.t.value) if self.t.value is not None else float("nan")
        if st not in ("optimal", "optimal_inaccurate") or self.c.value is None:
            return st, None
        return st, [float(x) for x in self.c.value]


def lp_coeffs(expr: sp.Expr, sub: dict) -> dict[tuple[int, int], Fraction]:
    """Exact coefficients of an entry in ``(lambda, P_FREE)`` at rational gains."""
    return dict(_lp_coeffs_cached(sp.sympify(expr), tuple(sub.items())))


@lru_cache(maxsize=65536)
def _lp_coeffs_cached(expr: sp.Expr, items: tuple) -> tuple:
    sub = dict(items)
    e = sp.expand(sp.sympify(expr).xreplace({k: sp.Rational(v.numerator, v.denominator) for k, v in sub.items()}))
    if e == 0:
        return ()
    return tuple(((int(i), int(j)), Fraction(int(sp.Rational(c).p), int(sp.Rational(c).q)))
                 for (i, j), c in sp.Poly(e, LAMBDA, P_FREE).terms())


def with_p(d: dict[tuple[int, int], Fraction], pi: Fraction) -> list[Fraction]:
    """Coefficients in ``lambda`` after ``P_FREE = lambda * pi``."""
    deg = max((i + j for i, j in d), default=0)
    out = [Fraction(0)] * (deg + 1)
    for (i, j), c in d.items():
        out[i + j] += c * pi**j
    return out


def _certify_searched(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox,
                      seed_with_paper: bool = True) -> tuple[Verdict, str, Any, dict]:
    if not _multi_affine([mm.a, mm.p_class.subs(P_FREE, 0)], mm.gains):
        return Verdict.UNDECIDED, "the closed loop is not multi-affine in the gains", None, {}
    dual = _class_dual(mm, spec_, box)
    if dual is not None:
        return (Verdict.REFUTED, "an exact dual certificate shows that no quadratic V with the "
                "switching structure exists at a vertex of the box", dual, {"dual": True})
    if seed_with_paper and mm.aligned:
        st, _, _, ev = _certify_exact(mm, spec_, box)
        if st is Verdict.CERTIFIED:
            return (Verdict.CERTIFIED, "the specification's own V is a member of the class and passes "
                    "the exact re-check (no search needed)", None, {"member": "paper V", **ev})
    monos = monomials(box)
    statuses: dict[str, int] = {}
    coeffs_out = []
    f = mm.vdot(mm.p_class)
    lmi = SearchedLMI(mm, box)
    ents = {v: [(name, [lp_coeffs(mat[i, j], gain_subs(mm, v)) for i, j in ((0, 0), (0, 1), (1, 1))])
                for name, mat in (("V > 0", mm.p_class), ("V' < 0", -f))] for v in box.vertices()}
    for c in spec_.clusters:
        status, coeffs = lmi.solve(c.mid)
        statuses[status] = statuses.get(status, 0) + 1
        if coeffs is None:
            return (Verdict.UNDECIDED, f"the LMI solve for the mode lambda ~ {c.mid:g} ended "
                    f"'{status}' and no dual certificate was found", None, {"solver": statuses})
        q = [Fraction(x).limit_denominator(10**8) for x in coeffs]
        coeffs_out.append({"lambda": _lam(c), "coefficients": q})
        for v in box.vertices():
            pv = sum((qj * monomial_value(e, v) for qj, e in zip(q, monos)), Fraction(0))
            for name, ent in ents[v]:
                ok, _, _ = check_pd_coeffs(with_p(ent[0], pv), with_p(ent[1], pv), with_p(ent[2], pv), c)
                if ok <= 0:
                    return (Verdict.UNDECIDED, f"the searched V (rounded) fails the exact re-check of "
                            f"{name} for the mode lambda ~ {c.mid:g}; no dual certificate either",
                            None, {"solver": statuses})
    return (Verdict.CERTIFIED, "a quadratic V with the switching structure, multi-affine in the gains, "
            "passes the exact re-check at every vertex and mode", None,
            {"solver": statuses, "p_over_lambda": coeffs_out if len(coeffs_out) <= 8 else coeffs_out[:8],
             "monomials": ["*".join(g for g, k in zip(GAINS, e) if k) or "1" for e in monos]})


# ---------------------------------------------------------------------------
# (d) spectral: Routh-Hurwitz per mode
# ---------------------------------------------------------------------------
def hurwitz_conditions(charpoly: tuple[sp.Expr, ...]) -> list[sp.Expr]:
    """Routh-Hurwitz conditions (all ``> 0``) of a real polynomial, leading coefficient first.

    The coefficients and the leading principal minors of the Hurwitz matrix.

    >>> s = sp.Symbol("a")
    >>> hurwitz_conditions((1, 2 * s, 3))
    [1, 2*a, 3, 6*a]
    """
    a = list(charpoly)
    n = len(a) - 1
    h = sp.zeros(n, n)
    for i in range(n):
        for j in range(n):
            k = 2 * (j + 1) - (i + 1)
            if 0 <= k <= n:
                h[i, j] = a[k]
    minors = [sp.expand(h[:k, :k].det()) for k in range(1, n + 1)]
    out: list[sp.Expr] = []
    for e in [*a, *minors]:
        e = sp.expand(e)
        if e not in out:
            out.append(e)
    return out


def box_poly_range(expr: sp.Expr, mm: ModeModel, box: GainBox, c: SpectrumCluster) -> tuple[Fraction, Fraction]:
    """Exact enclosure of a polynomial in the gains and ``lambda`` over the box and enclosure.

    All variables are non-negative, so each monomial is monotone in each.
    """
    gens = (*mm.gains, LAMBDA)
    lo_v = [r.lo for r in box.ranges] + [c.lo]
    hi_v = [r.hi for r in box.ranges] + [c.hi]
    poly = sp.Poly(sp.expand(expr), *gens)
    a = b = Fraction(0)
    for exps, coef in poly.terms():
        q = Fraction(int(sp.Rational(coef).p), int(sp.Rational(coef).q))
        m0 = m1 = Fraction(1)
        for e, l_, h_ in zip(exps, lo_v, hi_v):
            m0 *= l_**e
            m1 *= h_**e
        if q > 0:
            a, b = a + q * m0, b + q * m1
        else:
            a, b = a + q * m1, b + q * m0
    return a, b


def _certify_spectral(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox) -> tuple[Verdict, str, Any, dict]:
    conds = hurwitz_conditions(mm.charpoly)
    undecided = None
    for c in spec_.clusters:
        for e in conds:
            lo, _ = box_poly_range(e, mm, box, c)
            if lo > 0:
                continue
            for v in box.vertices():
                pt = GainBox.parse(dict(zip(GAINS, v)), GAINS)
                _, hi = box_poly_range(e, mm, pt, c)
                if hi <= 0:
                    w = {"gains": _vertex_dict(v), "lambda": _lam(c), "condition": f"{e} > 0",
                         "upper_bound": hi}
                    return (Verdict.REFUTED, "a Routh-Hurwitz condition of the nominal loop fails at a "
                            "vertex: the linear loop is not asymptotically stable there", w, {})
            undecided = undecided or (c, e)
    if undecided is not None:
        c, e = undecided
        return (Verdict.UNDECIDED, f"the Routh-Hurwitz condition {e} > 0 is not decided on the whole "
                "box by interval bounds (subdivide)", None, {})
    return (Verdict.CERTIFIED, "every mode's characteristic polynomial is Hurwitz on the whole box "
            "(exact interval bounds)", None, {"conditions": [str(e) for e in conds]})


# ---------------------------------------------------------------------------
# (a) paper + dispatcher
# ---------------------------------------------------------------------------
def _certify_paper(graph: Any, box: GainBox, spec: Any, margin: Any,
                   use_sdp: bool = True) -> tuple[Verdict, str, Any, dict]:
    from formsync_design.certify.engine import certify_box
    from formsync_design.derive.conditions import derive_conditions

    r = certify_box(derive_conditions(graph, spec), box, margin=margin, use_sdp=use_sdp)
    status = {"certified": Verdict.CERTIFIED, "refuted": Verdict.REFUTED,
              "undecided": Verdict.UNDECIDED}.get(str(r.status), Verdict.ERROR)
    w = None
    if status is Verdict.REFUTED and r.witness is not None:
        w = r.witness.to_dict()
    why = f": {r.reason}" if r.reason else f" ({r.status} on the whole box)"
    return status, f"the paper's per-spacecraft test{why}", w, {"argument": r.argument}


def certify(graph: Any, box: Any, certificate: str | Certificate = Certificate.PAPER, *,
            spec: Any = None, margin: Any = 0, spectrum: LaplacianSpectrum | None = None,
            use_sdp: bool = True, seed_with_paper: bool = True) -> CertificateResult:
    """Decide a gain box ``(K_o, K_q, beta)`` with one of the four certificates.

    Parameters
    ----------
    graph : Graph or graph spec (``"ring:8"``)
    box : GainBox or anything :meth:`GainBox.parse` accepts with names ``K_o, K_q, beta``
    certificate : ``paper`` | ``exact`` | ``searched`` | ``spectral``
    spec : specification (default: the paper's)
    margin : number
        Only for ``paper`` (the engine's margin).
    spectrum : LaplacianSpectrum, optional
        Reuse an enclosure (region maps call this many times per graph).
    use_sdp : bool
        ``paper``: take the engine's hints from the SDP (default) or LAPACK
        (same exact re-check; region maps use LAPACK for speed).
    seed_with_paper : bool
        ``searched``: try the specification's own ``V`` (a member of the class
        when it has the switching structure) before solving the LMIs.

    Returns
    -------
    CertificateResult

    Examples
    --------
    >>> box = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    >>> [certify("star:8", box, c).status.value for c in ("paper", "exact", "searched", "spectral")]
    ['refuted', 'refuted', 'refuted', 'certified']
    >>> certify("ring:8", box, "exact").status.value
    'certified'
    """
    t0 = time.perf_counter()
    try:
        cert = Certificate(str(certificate))
    except ValueError:
        raise InputError(f"expected a certificate in {[c.value for c in Certificate]}, "
                         f"received {certificate!r}") from None
    g = make_graph(graph)
    b = GainBox.parse(box, GAINS)
    sp_ = spectrum if spectrum is not None else laplacian_spectrum(g)
    if cert is Certificate.PAPER:
        status, reason, w, ev = _certify_paper(g, b, spec, margin, use_sdp)
    else:
        mm = mode_model(spec)
        if cert is Certificate.EXACT:
            status, reason, w, ev = _certify_exact(mm, sp_, b)
        elif cert is Certificate.SEARCHED:
            status, reason, w, ev = _certify_searched(mm, sp_, b, seed_with_paper)
        else:
            status, reason, w, ev = _certify_spectral(mm, sp_, b)
    return CertificateResult(cert, status, g.name, g.n, b, reason, w, ev, sp_.method,
                             time.perf_counter() - t0)
