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
defined up to a positive factor).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cache
from typing import Any

import sympy as sp

from formsync_design.derive.closed_loop import derive_closed_loop, resolve_spec, spec_cache_key
from formsync_design.derive.templates import derive_local_template
from formsync_design.errors import DerivationError
from formsync_design.spec.loader import gain_symbols

__all__ = ["LAMBDA", "P_FREE", "ModeModel", "mode_model", "poly_coeffs_in_lambda", "sym_to_fraction"]

#: The Laplacian eigenvalue symbol of the mode reduction.
LAMBDA = sp.Symbol("lambda", positive=True)
#: The free (1,1) entry of the searched class.
P_FREE = sp.Symbol("p")


@dataclass(frozen=True)
class ModeModel:
    """One Laplacian mode of the nominal loop and of the Lyapunov candidate (per axis).

    Attributes
    ----------
    spec_name : str
    gains : tuple of sympy.Symbol
        ``(K_o, K_q, beta)``.
    a : sympy.Matrix
        ``A_k`` (2x2) in ``LAMBDA`` and the gains.
    p_paper : sympy.Matrix
        ``P_k`` of the specification's own ``V``.
    p_class : sympy.Matrix
        ``P_k`` of the searched class (free ``P_FREE``).
    rho : (sympy.Expr, sympy.Expr)
        Switching-argument coefficients ``(rho_qd, rho_s)``.
    aligned : bool
        Whether the specification's ``V`` already has the switching structure.
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

    def vdot(self, p: sp.Matrix) -> sp.Matrix:
        """``A_k^T P + P A_k`` (the per-mode ``V'`` matrix), expanded."""
        return (self.a.T * p + p * self.a).applyfunc(sp.expand)


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
    qd = sp.Matrix(sp.symbols("x1 x2 x3"))
    s = sp.Matrix(sp.symbols("y1 y2 y3"))
    arg = cl.switch_argument_explicit(qd, s)
    if arg is None:
        rho = (sp.Integer(1), sp.Integer(0))
    else:
        rho = (sp.expand(arg[0].coeff(qd[0])), sp.expand(arg[0].coeff(s[0])))
        if (arg - (rho[0] * qd + rho[1] * s)).applyfunc(sp.expand) != sp.zeros(3, 1):
            raise DerivationError(f"expected a switching argument linear in q' and s, received {arg.T}")
    aligned = sp.simplify(th00 * rho[1] - th01 * rho[0]) == 0
    p_class = sp.Matrix([[P_FREE, sp.expand(rho[1] * lam)], [sp.expand(rho[1] * lam), rho[0]]])
    s_ = sp.Symbol("s")
    cp = sp.Poly((s_ * sp.eye(2) - a).det(), s_).all_coeffs()
    return ModeModel(
        spec_name=spec.name,
        gains=gain_symbols(),
        a=a,
        p_paper=p_paper,
        p_class=p_class,
        rho=rho,
        aligned=bool(aligned),
        charpoly=tuple(sp.expand(c) for c in cp),
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
