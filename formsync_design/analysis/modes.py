"""The nominal closed loop and the Lyapunov candidate, reduced to one Laplacian mode.

Derived, not typed: from :func:`~formsync_design.derive.closed_loop.derive_closed_loop`
the per-spacecraft closed loop after model cancellation is

    ``q_i'' = c_qd q_i' + c_s s_i + c_sigma sgn(arg_i) + A_i^-1 Q_i^T u_di``,
    ``s_i = sum_j (q_i - q_j)``, ``arg_i = rho_qd q_i' + rho_s s_i``.

The *nominal linear loop* drops the switching and disturbance terms (they are
handled by the switching-structure constraint below, as in the paper's proof).
In stacked form ``q'' = c_qd q' + c_s (L (x) I3) q``; along an eigenvector
``u_k`` of ``L`` (eigenvalue ``lambda_k``), per axis, ``x = u_k^T q``,
``y = u_k^T q'``:

    ``d/dt (x, y) = A_k (x, y)``,  ``A_k = [[0, 1], [c_s lambda_k, c_qd]]``.

The Lyapunov candidate ``V = sum_i V_i`` of the specification (a quadratic form
per axis in ``q_i'`` and the edges ``e_k = q_i - q_j``, read from
:func:`~formsync_design.derive.templates.derive_local_template`) reduces, when
its coefficients are the same for every neighbour and every degree (checked),
to ``V = theta_00 |q'|^2 + 2 theta_01 q'^T L q + 2 (theta_11 - theta_12) q^T L q
+ theta_12 q^T L^2 q``, i.e. per mode ``V_k = (x, y) P_k (x, y)^T`` with

    ``P_k = [[2 (theta_11 - theta_12) lambda + theta_12 lambda^2, theta_01 lambda],
             [theta_01 lambda, theta_00]]``

(using ``sum_i sum_k |e_k|^2 = 2 q^T L q``, ``sum_i s_i^2 = q^T L^2 q``).  A
test compares this with a brute-force sum of ``V_i`` on random states.

Switching structure: ``dV/dq_i' = 2 (theta_00 q_i' + theta_01 s_i)``; the
switching term ``-K_v arg_i^T sgn(arg_i)`` is dissipative in ``V'`` exactly when
this gradient is a positive multiple of ``arg_i`` (the paper's proof relies on
it).  The *searched* class keeps it: ``P_k = [[p, kappa rho_s lambda],
[kappa rho_s lambda, kappa rho_qd]]`` with free ``p`` (``kappa = 1``; ``V`` is
defined up to a positive factor).  A design without a switching term (``c_sigma = 0``,
e.g. the PD baseline) has no such constraint: its class is the natural
specialisation, every quadratic ``V`` of the mode, ``P_k = [[p, r], [r, 1]]`` with free
``p`` and ``r`` (:attr:`ModeModel.free`).

Any design: everything here is in the design's own controller gains
(:attr:`ModeModel.gains`, e.g. ``(K_o, K_q, beta)`` or ``(k_p, k_d)``); a multiplier of
its Lyapunov candidate (``eps`` of the PD baseline) stays a symbol of
:attr:`ModeModel.p_paper` (:attr:`ModeModel.multipliers`), chosen by the certificate.

Small-gain perturbed modes (:func:`robust_modes`, used by
:mod:`~formsync_design.analysis.inertia`): when the commanded acceleration ``a`` reaches
the plant as ``a + r`` with ``|r| <= theta |a|`` (an unstructured perturbation coupling the
modes), a quadratic ``V = sum_k z_k^T P_k z_k`` decays at ``2 mu`` if every mode satisfies
the Riccati inequality ``A_k^T P_k + P_k A_k + theta P_k e e^T P_k + theta K_k^T K_k +
2 mu P_k <= 0`` (``2 |g| theta |a| <= theta (|g|^2 + |a|^2)``); it is feasible iff
``theta |K_k (sI - A_k - mu I)^-1 e|_inf < 1`` (bounded-real lemma).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cache
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.derive.closed_loop import derive_closed_loop, resolve_spec, spec_cache_key
from formsync_design.derive.templates import derive_local_template
from formsync_design.errors import DerivationError, InputError

__all__ = ["LAMBDA", "P_FREE", "R_FREE", "ModeModel", "mode_model", "poly_coeffs_in_lambda", "sym_to_fraction",
           "RobustModes", "robust_decay_hint", "robust_modes", "poly_mul"]

#: The Laplacian eigenvalue symbol of the mode reduction.
LAMBDA = sp.Symbol("lambda", positive=True)
#: The free (1,1) entry of the searched class.
P_FREE = sp.Symbol("p")
#: The free (1,2) entry of the searched class of a design without a switching term.
R_FREE = sp.Symbol("r")


@dataclass(frozen=True)
class ModeModel:
    """One Laplacian mode of the nominal loop and of the Lyapunov candidate (per axis).

    Attributes
    ----------
    spec_name : str
    gains : tuple of sympy.Symbol
        The design's controller gains (the box dimensions), e.g. ``(K_o, K_q, beta)``.
    names : tuple of str
        Their names.
    multipliers : tuple of sympy.Symbol
        Multipliers of the Lyapunov candidate (symbols of ``p_paper`` only).
    multiplier_ranges : tuple of GainRange
        Their declared ranges (what a certificate may choose from).
    c_qd, c_s : sympy.Expr
        The derived closed-loop coefficients ``q'' = c_qd q' + c_s s + ...``.
    switching : bool
        Whether the closed loop has a switching term (``c_sigma != 0``).
    a : sympy.Matrix
        ``A_k`` (2x2) in ``LAMBDA`` and the gains.
    p_paper : sympy.Matrix
        ``P_k`` of the specification's own ``V``.
    p_class : sympy.Matrix
        ``P_k`` of the searched class (free symbols :attr:`free`).
    free : tuple of sympy.Symbol
        The free entries of ``p_class``: ``(P_FREE,)`` with a switching term, else
        ``(P_FREE, R_FREE)``; each is ``lambda`` times a multi-affine function of the gains.
    rho : (sympy.Expr, sympy.Expr)
        Switching-argument coefficients ``(rho_qd, rho_s)``.
    aligned : bool
        Whether the specification's ``V`` is a member of the searched class (with a
        switching term: it already has the switching structure).
    charpoly : tuple of sympy.Expr
        Coefficients ``(1, a_1, a_2)`` of ``det(s I - A_k)``.
    """

    spec_name: str
    gains: tuple[sp.Symbol, ...]
    a: sp.Matrix
    p_paper: sp.Matrix
    p_class: sp.Matrix
    rho: tuple[sp.Expr, sp.Expr]
    aligned: bool
    charpoly: tuple[sp.Expr, ...]
    names: tuple[str, ...] = ()
    multipliers: tuple[sp.Symbol, ...] = ()
    multiplier_ranges: tuple[Any, ...] = ()
    c_qd: sp.Expr = sp.Integer(0)
    c_s: sp.Expr = sp.Integer(0)
    switching: bool = True
    free: tuple[sp.Symbol, ...] = (P_FREE,)

    def vdot(self, p: sp.Matrix) -> sp.Matrix:
        """``A_k^T P + P A_k`` (the per-mode ``V'`` matrix), expanded."""
        return (self.a.T * p + p * self.a).applyfunc(sp.expand)

    def subs(self, values: Any) -> dict:
        """``{gain symbol: exact value}`` of a gain point (a sequence in :attr:`names` order).

        >>> mode_model().subs((2, 1, "0.1"))
        {K_o: 2, K_q: 1, beta: 1/10}
        """
        from formsync_design.gains import parse_number

        vals = list(values)
        if len(vals) != len(self.names):
            raise InputError(f"expected gains ({', '.join(self.names)}) of design {self.spec_name}, "
                             f"received {len(vals)} values")
        out = {}
        for g, n, v in zip(self.gains, self.names, vals):
            q = v if isinstance(v, Fraction) else parse_number(v, n)
            out[g] = sp.Rational(q.numerator, q.denominator)
        return out

    def coefficients(self, values: Any) -> tuple[Fraction, Fraction]:
        """Exact ``(c_qd, c_s)`` at a gain point.

        >>> mode_model().coefficients((2, 1, "0.1"))
        (Fraction(-2, 1), Fraction(-1, 1))
        """
        sub = self.subs(values)
        return (sym_to_fraction(sp.expand(sp.sympify(self.c_qd).xreplace(sub))),
                sym_to_fraction(sp.expand(sp.sympify(self.c_s).xreplace(sub))))


def _theta_entries(m: int, spec: Any) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
    th = derive_local_template(m, spec).theta
    d0 = {sp.expand(th[0, k]) for k in range(1, m + 1)}
    dd = {sp.expand(th[k, k]) for k in range(1, m + 1)}
    off = {sp.expand(th[k, j]) for k in range(1, m + 1) for j in range(1, m + 1) if k != j} or {None}
    if len(d0) != 1 or len(dd) != 1 or len(off) != 1:
        raise DerivationError(
            "expected V_i to treat every neighbour alike (mode decomposition), received "
            f"per-neighbour coefficients {sorted(map(str, d0 | dd))}"
        )
    o = off.pop()
    return sp.expand(th[0, 0]), d0.pop(), dd.pop(), (sp.Integer(0) if o is None else o)


@cache
def _mode_model(key: str) -> ModeModel:
    from formsync_design.derive.closed_loop import registered_spec

    spec = registered_spec(key)
    cl = derive_closed_loop(spec)
    t2 = _theta_entries(2, spec)
    t3 = _theta_entries(3, spec)
    if t2 != t3:
        raise DerivationError(
            f"expected V_i's coefficients not to depend on the degree, received {t2} and {t3}"
        )
    th00, th01, th11, th12 = t2
    lam = LAMBDA
    a = sp.Matrix([[0, 1], [sp.expand(cl.c_s * lam), sp.expand(cl.c_qd)]])
    p_paper = sp.Matrix(
        [[sp.expand(2 * (th11 - th12) * lam + th12 * lam**2), sp.expand(th01 * lam)],
         [sp.expand(th01 * lam), th00]]
    )
    decl = spec.decl
    names = tuple(decl.controller_gains)
    gains = tuple(decl.gain(n).symbol for n in names)
    mults = tuple(decl.gain(n).symbol for n in decl.multipliers)
    mranges = tuple(decl.gain(n).range for n in decl.multipliers)
    switching = sp.expand(cl.c_sigma) != 0 and cl.switch_argument is not None
    qd = sp.Matrix(sp.symbols("x1 x2 x3"))
    s = sp.Matrix(sp.symbols("y1 y2 y3"))
    if switching:
        arg = cl.switch_argument_explicit(qd, s)
        assert arg is not None
        rho = (sp.expand(arg[0].coeff(qd[0])), sp.expand(arg[0].coeff(s[0])))
        if (arg - (rho[0] * qd + rho[1] * s)).applyfunc(sp.expand) != sp.zeros(3, 1):
            raise DerivationError(f"expected a switching argument linear in q' and s, received {arg.T}")
        aligned = sp.simplify(th00 * rho[1] - th01 * rho[0]) == 0
        p_class = sp.Matrix([[P_FREE, sp.expand(rho[1] * lam)], [sp.expand(rho[1] * lam), rho[0]]])
        free: tuple[sp.Symbol, ...] = (P_FREE,)
    else:
        rho = (sp.Integer(1), sp.Integer(0))
        p_class = sp.Matrix([[P_FREE, R_FREE], [R_FREE, 1]])
        free = (P_FREE, R_FREE)
        # a member when V_22 is a positive constant and V_11, V_12 are lambda times
        # polynomials in the gains and multipliers (the class's parameterization)
        d = sp.expand(th00)
        aligned = bool(d.is_number and d > 0) and all(
            sp.expand(p_paper[0, k] / lam).free_symbols <= set(gains) | set(mults) for k in (0, 1))
    s_ = sp.Symbol("s")
    cp = sp.Poly((s_ * sp.eye(2) - a).det(), s_).all_coeffs()
    extra = (a.free_symbols | p_paper.free_symbols) - set(gains) - set(mults) - {lam}
    if extra:
        raise DerivationError(f"expected the mode model of {spec.name} in its gains "
                              f"{', '.join(names)} only, received {sorted(map(str, extra))}")
    return ModeModel(
        spec_name=spec.name,
        gains=gains,
        a=a,
        p_paper=p_paper,
        p_class=p_class,
        rho=rho,
        aligned=bool(aligned),
        charpoly=tuple(sp.expand(c) for c in cp),
        names=names,
        multipliers=mults,
        multiplier_ranges=mranges,
        c_qd=sp.expand(cl.c_qd),
        c_s=sp.expand(cl.c_s),
        switching=bool(switching),
        free=free,
    )


def mode_model(spec: Any = None) -> ModeModel:
    """The per-mode reduction of a specification (default: the paper's).

    Examples
    --------
    >>> mm = mode_model()
    >>> mm.a
    Matrix([
    [          0,    1],
    [-K_q*lambda, -K_o]])
    >>> mm.charpoly
    (1, K_o, K_q*lambda)
    >>> mm.aligned, mm.rho
    (True, (1, beta))
    >>> pd = mode_model("pd_consensus")
    >>> pd.names, pd.multipliers, pd.switching, pd.charpoly
    (('k_p', 'k_d'), (eps,), False, (1, k_d, k_p*lambda))
    """
    return _mode_model(spec_cache_key(resolve_spec(spec)))


def sym_to_fraction(x: Any) -> Fraction:
    """An exact sympy number as a :class:`Fraction`.

    >>> sym_to_fraction(sp.Rational(3, 4))
    Fraction(3, 4)
    """
    r = sp.Rational(x)
    return Fraction(int(r.p), int(r.q))


def poly_coeffs_in_lambda(expr: sp.Expr, subs: dict) -> list[Fraction]:
    """Exact coefficients (ascending powers of ``LAMBDA``) of ``expr`` after ``subs``.

    >>> from formsync_design.spec.loader import gain_symbols
    >>> K_o, K_q, beta = gain_symbols()
    >>> poly_coeffs_in_lambda(K_o - beta * LAMBDA, {K_o: 2, K_q: 1, beta: sp.Rational(1, 2)})
    [Fraction(2, 1), Fraction(-1, 2)]
    """
    e = sp.expand(sp.sympify(expr).xreplace({k: sp.Rational(v) if not isinstance(v, Fraction)
                                             else sp.Rational(v.numerator, v.denominator)
                                             for k, v in subs.items()}))
    if e.free_symbols - {LAMBDA}:
        raise DerivationError(f"expected an expression in lambda only after substitution, received {e}")
    if e == 0:
        return [Fraction(0)]
    return [sym_to_fraction(c) for c in reversed(sp.Poly(e, LAMBDA).all_coeffs())]


# --- small-gain perturbed modes (inertia uncertainty) -------------------------------------

_UP = 1 + 1e-12


def poly_mul(a: list[Fraction], b: list[Fraction]) -> list[Fraction]:
    """Product of two polynomials given by coefficient lists (lowest degree first), exact.

    >>> poly_mul([Fraction(1), Fraction(1)], [Fraction(-1), Fraction(1)])
    [Fraction(-1, 1), Fraction(0, 1), Fraction(1, 1)]
    """
    out = [Fraction(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        if x:
            for j, y in enumerate(b):
                out[i + j] += x * y
    return out


def _padd(*ps: list[Fraction]) -> list[Fraction]:
    out = [Fraction(0)] * max(len(p) for p in ps)
    for p in ps:
        for i, x in enumerate(p):
            out[i] += x
    return out


def _pmin(p: list[Fraction], lo: Fraction, hi: Fraction) -> Fraction:
    """Exact lower bound of the polynomial ``p`` (ascending coefficients) on ``[lo, hi]``:
    Taylor-shift to the centre ``c``, then ``q_0 - sum_k |q_k| w^k``, ``w = (hi - lo) / 2``.

    >>> _pmin([Fraction(0), Fraction(0), Fraction(1)], Fraction(-1), Fraction(1))  # x^2 on [-1, 1]
    Fraction(-1, 1)
    """
    c, w = (lo + hi) / 2, (hi - lo) / 2
    q = [Fraction(0)] * len(p)
    for k, a in enumerate(p):  # a (c + t)^k
        binom = 1
        for j in range(k + 1):
            q[j] += a * binom * c ** (k - j)
            binom = binom * (k - j) // (j + 1)
    return q[0] - sum(abs(x) * w**k for k, x in enumerate(q) if k)


def _mode_matrices(lam: float, cqd: float, cs: float, dim: int) -> tuple[np.ndarray, np.ndarray]:
    if dim == 1:
        return np.array([[cqd]]), np.array([[cqd]])
    return np.array([[0.0, 1.0], [cs * lam, cqd]]), np.array([[cs * lam, cqd]])


def _riccati_hint(a: np.ndarray, k: np.ndarray, theta: float, mu: float, sigma: float) -> np.ndarray | None:
    """Stabilizing solution of ``(A + mu I)^T P + P (A + mu I) + theta P e e^T P + theta K^T K
    + sigma I = 0`` from the Hamiltonian's stable subspace (None if there is none)."""
    n = a.shape[0]
    am = a + mu * np.eye(n)
    if np.linalg.eigvals(am).real.max() >= 0:
        return None
    e = np.zeros((n, 1))
    e[-1, 0] = 1.0
    qm = theta * (k.T @ k) + sigma * np.eye(n)
    h = np.block([[am, theta * (e @ e.T)], [-qm, -am.T]])
    w, v = np.linalg.eig(h)
    if np.abs(w.real).min() <= 1e-10 * max(1.0, float(np.abs(w).max())):
        return None
    st = v[:, w.real < 0]
    if st.shape[1] != n:
        return None
    p = np.real(st[n:] @ np.linalg.inv(st[:n]))
    p = (p + p.T) / 2
    return p if np.linalg.eigvalsh(p).min() > 0 else None


def _mode_mu_max(a: np.ndarray, k: np.ndarray, theta: float, sigma: float) -> float:
    lo, hi = 0.0, float(-np.linalg.eigvals(a).real.max())
    if _riccati_hint(a, k, theta, 0.0, sigma) is None:
        return 0.0
    for _ in range(24):
        mid = (lo + hi) / 2
        if _riccati_hint(a, k, theta, mid, sigma) is None:
            hi = mid
        else:
            lo = mid
    return lo


def _exact_mode_check(p: np.ndarray, lo: Fraction, hi: Fraction, cqd: Fraction, cs: Fraction,
                      theta: Fraction, mu: Fraction) -> tuple[Fraction, ...] | None:
    """Round the hint ``P`` to rationals and check exactly, for every ``lambda in [lo, hi]``,
    ``P > 0`` and the Riccati inequality (``-M >= 0``: diagonal entries and determinant, as
    polynomials in ``lambda``, bounded below by :func:`_pmin`).  Returns
    ``(trace, det, P_22, (P^-1)_22)`` of the rational ``P``, or None when a check fails."""
    dim = p.shape[0]
    fp = [[Fraction(float(p[i, j])).limit_denominator(10**12) for j in range(dim)] for i in range(dim)]
    fp[0][dim - 1] = fp[dim - 1][0]
    one, zero, lam = [Fraction(1)], [Fraction(0)], [Fraction(0), Fraction(1)]
    if dim == 1:
        am, km = [[[cqd]]], [[[cqd]]]
    else:
        am = [[zero, one], [poly_mul(lam, [cs]), [cqd]]]
        km = [[poly_mul(lam, [cs]), [cqd]]]
    pe = [fp[i][dim - 1] for i in range(dim)]
    mm = [[zero for _ in range(dim)] for _ in range(dim)]
    for i in range(dim):
        for j in range(dim):
            terms = [poly_mul(am[r][i], [fp[r][j]]) for r in range(dim)]          # (A^T P)_ij
            terms += [poly_mul([fp[i][r]], am[r][j]) for r in range(dim)]         # (P A)_ij
            terms += [[theta * pe[i] * pe[j] + 2 * mu * fp[i][j]], poly_mul([theta], poly_mul(km[0][i], km[0][j]))]
            mm[i][j] = [-x for x in _padd(*terms)]                             # -M
    if dim == 1:
        ok = fp[0][0] > 0 and _pmin(mm[0][0], lo, hi) >= 0
        return (fp[0][0], fp[0][0], fp[0][0], 1 / fp[0][0]) if ok else None
    det_p = fp[0][0] * fp[1][1] - fp[0][1] ** 2
    if not (fp[0][0] > 0 and det_p > 0):
        return None
    det_m = _padd(poly_mul(mm[0][0], mm[1][1]), [-x for x in poly_mul(mm[0][1], mm[0][1])])
    if min(_pmin(mm[0][0], lo, hi), _pmin(mm[1][1], lo, hi), _pmin(det_m, lo, hi)) < 0:
        return None
    return fp[0][0] + fp[1][1], det_p, fp[1][1], fp[0][0] / det_p


@dataclass(frozen=True)
class RobustModes:
    """An exactly checked per-mode Riccati certificate of a small-gain perturbed loop
    (:func:`robust_modes`; the floats are rounded outward)."""

    mu: float       # certified V' <= -2 mu V of the linear part (rounded down)
    p_max: float    # max_k lambda_max(P_k)
    p_min: float    # min over the disagreement modes of lambda_min(P_k)
    p_0: float      # the consensus mode's P (scalar)
    big_g: float    # max_k (P_k)_22
    kappa: float    # max_k (P_k^-1)_22


def robust_decay_hint(modes: list[tuple[Fraction, Fraction, int]], cqd: Fraction, cs: Fraction,
             theta: float, sigma: float) -> float:
    """The smallest per-mode largest ``mu`` with a Riccati solution (floating point: a hint).

    >>> from fractions import Fraction as F
    >>> 0 < robust_decay_hint([(F(0), F(0), 1), (F(2), F(2), 2)], F(-8, 5), F(-2, 5), 0.1, 0.01) < 0.8
    True
    """
    return min(_mode_mu_max(*_mode_matrices(float((lo + hi) / 2), float(cqd), float(cs), dim), theta, sigma)
               for lo, hi, dim in modes)


def robust_modes(modes: list[tuple[Fraction, Fraction, int]], cqd: Fraction, cs: Fraction,
                  theta: float, mu_try: float, sigma: float, *, exact: bool = True) -> RobustModes | None:
    """Per-mode Riccati certificate of ``z_k' = A_k z_k + e r_k`` with ``|r| <= theta |a|``,
    ``a_k = K_k z_k`` (see :mod:`formsync_design.analysis.inertia`): for every mode
    ``(lo, hi, dim)`` (``modes[0]`` the consensus mode, ``dim = 1``) a ``P_k`` with
    ``A_k^T P_k + P_k A_k + theta P_k e e^T P_k + theta K_k^T K_k + 2 mu P_k <= 0`` for every
    ``lambda in [lo, hi]``, checked in exact rational arithmetic (the Riccati solution with
    weight ``sigma I`` at the interval's centre is only the hint).  None when a check fails.
    ``exact=False`` returns the floating-point preview of the same numbers (no proof; used
    to skip exact checks that could not close the argument).

    >>> from fractions import Fraction as F
    >>> r = robust_modes([(F(0), F(0), 1), (F(2), F(2), 2)], F(-8, 5), F(-2, 5), 0.1, 0.05, 0.01)
    >>> r is not None and r.mu > 0.04 and r.p_min > 0
    True
    """
    mats = [_mode_matrices(float((lo + hi) / 2), float(cqd), float(cs), dim) for lo, hi, dim in modes]
    if mu_try <= 0:
        return None
    mu = Fraction(mu_try).limit_denominator(10**9)
    th = Fraction(theta)
    p_max, p_min, p_0, big_g, kappa = 0.0, math.inf, 0.0, 0.0, 0.0
    for (lo, hi, dim), (a, k) in zip(modes, mats):
        hint = _riccati_hint(a, k, theta, float(mu), sigma)
        if hint is None:
            return None
        if exact:
            got = _exact_mode_check(hint, lo, hi, cqd, cs, th, mu)
        else:
            f = [Fraction(float(x)) for x in hint.ravel()]
            dt = f[0] * f[-1] - f[1] * f[1] if dim == 2 else f[0]
            got = (f[0] + f[-1], dt, f[-1], f[0] / dt) if dim == 2 else (f[0], f[0], f[0], 1 / f[0])
        if got is None:
            return None
        ftr, fdet, fp22, fpinv22 = got
        tr, det = float(ftr), float(fdet)
        if dim == 1:
            p_0 = tr / _UP
            p_max = max(p_max, tr * _UP)
        else:  # lambda_max = (tr + sqrt(tr^2 - 4 det)) / 2, the discriminant exact (>= 0 for symmetric P)
            top = (tr + math.sqrt(float(ftr * ftr - 4 * fdet))) / 2 * _UP**2
            p_max = max(p_max, top)
            p_min = min(p_min, det / top / _UP)
        big_g, kappa = max(big_g, float(fp22) * _UP), max(kappa, float(fpinv22) * _UP)
    return RobustModes(float(mu) / _UP, p_max, p_min, p_0, big_g, kappa)
