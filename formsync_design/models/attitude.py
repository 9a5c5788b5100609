"""Symbolic attitude model of one spacecraft (paper section 1.1).

Derives, with SymPy, the Lagrangian form ``A q'' + B q' = Q^T u + Q^T u_d``
(paper eq. 3) from the quaternion kinematics (eq. 1) and Euler's equation
(eq. 2), for a general symmetric inertia ``J``.

Symbol order (carried by :class:`AttitudeModel`)
------------------------------------------------
* ``q  = (q1, q2, q3)``      vector part of the unit quaternion
* ``q0``                       scalar part, a symbol constrained by
  ``q0**2 + q.q = 1`` and ``q0 > 0``; its rate is ``q0' = -q.q'/q0``
* ``qd = (qd1, qd2, qd3)``   ``q'``
* ``J = [[J11, J12, J13], [J12, J22, J23], [J13, J23, J33]]``

``Q = E^{-1}`` with ``E = (q0 I + q^x)/2`` (so ``omega = Q q'``);
``A = Q^T J Q``; ``B = Q^T J Q' - Q^T (J Q q')^x Q``.  ``B`` is not unique
(only ``B q'`` is); this factorization is the one for which ``A' - 2B`` is
skew-symmetric, the standard Euler-Lagrange property.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import sympy as sp

__all__ = ["AttitudeModel", "derive_attitude_model", "skew", "reduce_unit", "quat_rate_matrix"]


def skew(v: sp.Matrix) -> sp.Matrix:
    """Cross-product matrix ``v^x`` with ``v^x w = v x w``.

    >>> a, b, c = sp.symbols("a b c")
    >>> skew(sp.Matrix([a, b, c]))
    Matrix([
    [ 0, -c,  b],
    [ c,  0, -a],
    [-b,  a,  0]])
    """
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def quat_rate_matrix(q: sp.Matrix, q0: sp.Expr) -> sp.Matrix:
    """``E = (q0 I + q^x)/2`` of the kinematics ``q' = E omega`` (eq. 1)."""
    return (q0 * sp.eye(3) + skew(q)) / 2


def reduce_unit(expr: sp.Expr, q: sp.Matrix, q0: sp.Symbol) -> sp.Expr:
    """Reduce a rational expression modulo the unit constraint ``q0^2 + q.q = 1``.

    The numerator is reduced as a polynomial (eliminating ``q0**2``) after
    bringing the expression over a common denominator.
    """
    expr = sp.together(sp.expand(expr))
    num, den = sp.fraction(expr)
    rule = {q0**2: 1 - q[0] ** 2 - q[1] ** 2 - q[2] ** 2}
    num = sp.expand(num)
    # repeatedly replace even powers of q0
    poly = sp.Poly(num, q0)
    out = 0
    for (k,), c in poly.terms():
        out += c * (rule[q0**2] ** (k // 2)) * q0 ** (k % 2)
    return sp.expand(out) / den if den != 1 else sp.expand(out)


@dataclass(frozen=True)
class AttitudeModel:
    """The derived single-spacecraft Lagrangian attitude model.

    Attributes
    ----------
    q, qd : sympy.Matrix
        ``(q1, q2, q3)`` and ``(qd1, qd2, qd3)``.
    q0 : sympy.Symbol
        Scalar part (see module docstring for its constraint and rate).
    J : sympy.Matrix
        Symmetric inertia with entries ``J11 ... J33``.
    E, Q : sympy.Matrix
        ``E = (q0 I + q^x)/2`` and its inverse ``Q``, in closed form
        ``Q = 2 (q0 I - q^x + q q^T / q0)``.
    Qdot : sympy.Matrix
        Time derivative of ``Q`` along ``q' = qd``.
    A, B : sympy.Matrix
        ``A = Q^T J Q`` and ``B = Q^T J Qdot - Q^T (J Q qd)^x Q``.
    coriolis_vector : sympy.Matrix
        ``Q^T (J Qdot qd + omega x J omega)``, the velocity term as it
        comes out of Euler's equation (``B qd`` must equal it).
    """

    q: sp.Matrix
    q0: sp.Symbol
    qd: sp.Matrix
    J: sp.Matrix
    E: sp.Matrix
    Q: sp.Matrix
    Qdot: sp.Matrix
    A: sp.Matrix
    B: sp.Matrix
    coriolis_vector: sp.Matrix
    q0_rate: sp.Expr

    @property
    def state_symbols(self) -> tuple[sp.Symbol, ...]:
        """``(q1, q2, q3, q0, qd1, qd2, qd3)`` in this order."""
        return (*self.q, self.q0, *self.qd)

    @property
    def inertia_symbols(self) -> tuple[sp.Symbol, ...]:
        """``(J11, J12, J13, J22, J23, J33)`` in this order."""
        J = self.J
        return (J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2])

    def time_derivative(self, expr: sp.Expr) -> sp.Expr:
        """``d/dt`` of an expression in ``q, q0`` along ``q' = qd`` (no ``qd'`` terms)."""
        out = sum(sp.diff(expr, self.q[k]) * self.qd[k] for k in range(3))
        return out + sp.diff(expr, self.q0) * self.q0_rate


@cache
def derive_attitude_model(suffix: str = "") -> AttitudeModel:
    """Derive the Lagrangian attitude model (paper eq. 3) from eqs. (1)-(2).

    Parameters
    ----------
    suffix : str
        Appended to every symbol name (e.g. ``"_1"`` for spacecraft 1).

    Returns
    -------
    AttitudeModel

    Examples
    --------
    >>> m = derive_attitude_model()
    >>> m.state_symbols
    (q1, q2, q3, q0, qd1, qd2, qd3)
    >>> sp.simplify(m.Q[0, 0] - 2 * (m.q0 + m.q[0] ** 2 / m.q0))
    0
    """
    q = sp.Matrix(sp.symbols(f"q1{suffix} q2{suffix} q3{suffix}", real=True))
    q0 = sp.Symbol(f"q0{suffix}", positive=True)
    qd = sp.Matrix(sp.symbols(f"qd1{suffix} qd2{suffix} qd3{suffix}", real=True))
    j11, j12, j13, j22, j23, j33 = sp.symbols(
        f"J11{suffix} J12{suffix} J13{suffix} J22{suffix} J23{suffix} J33{suffix}", real=True
    )
    J = sp.Matrix([[j11, j12, j13], [j12, j22, j23], [j13, j23, j33]])

    E = quat_rate_matrix(q, q0)
    # Q = E^{-1}: invert symbolically, then reduce with the unit constraint to
    # the closed form 2 (q0 I - q^x + q q^T / q0); the reduction is checked.
    Q_closed = 2 * (q0 * sp.eye(3) - skew(q) + q * q.T / q0)
    Q_inv = E.inv()
    for i in range(3):
        for k in range(3):
            if reduce_unit(Q_inv[i, k] - Q_closed[i, k], q, q0) != 0:
                # the closed form must agree with the symbolic inverse on the unit sphere
                raise AssertionError("closed form of Q disagrees with E^{-1}")  # pragma: no cover
    Q = Q_closed
    # scalar-part kinematics q0' = -q^T omega / 2 with omega = Q qd
    q0_rate_raw = (-(q.T * Q * qd)[0, 0] / 2)
    q0_rate = -(q.T * qd)[0, 0] / q0
    if reduce_unit(q0_rate_raw - q0_rate, q, q0) != 0:  # pragma: no cover
        raise AssertionError("q0 rate reduction failed")

    def ddt(expr: sp.Expr) -> sp.Expr:
        out = sum(sp.diff(expr, q[k]) * qd[k] for k in range(3))
        return out + sp.diff(expr, q0) * q0_rate

    Qdot = Q.applyfunc(ddt)
    omega = Q * qd
    # Euler (2): J omega' = -omega^x J omega + u + u_d, omega' = Q q'' + Qdot q'.
    # Premultiplying by Q^T: Q^T J Q q'' + Q^T (J Qdot q' + omega^x J omega) = Q^T (u + u_d)
    A = Q.T * J * Q
    coriolis_vector = Q.T * (J * Qdot * qd + skew(omega) * J * omega)
    B = Q.T * J * Qdot - Q.T * skew(J * Q * qd) * Q
    return AttitudeModel(
        q=q, q0=q0, qd=qd, J=J, E=E, Q=Q, Qdot=Qdot, A=A, B=B,
        coriolis_vector=coriolis_vector, q0_rate=q0_rate,
    )
