"""Rotation matrices on SO(3): hat/vee, exponential map, a Lie-group integrator, geometric errors.

Convention: ``R`` maps body to inertial coordinates and ``R' = R omega^`` for
body rates ``omega`` (the same motion as the quaternion kinematics of
:mod:`formsync_design.models.quaternion`).  ``v^ = hat(v)`` is the
cross-product matrix, ``vee`` its inverse.

Integration (:func:`integrate_so3`) is the Runge-Kutta-Munthe-Kaas method
of order 4 (RKMK4): each step writes ``R(t_n + s) = R_n exp(u(s)^)`` and
integrates the ODE ``u' = dexp_{-u}^{-1}(omega)`` in the Lie algebra with the
classical RK4 tableau, using the closed-form SO(3) ``dexp`` inverse.  Every
step multiplies by an exact exponential (Rodrigues' formula), so ``R`` stays
on the group up to rounding (``|R^T R - I|`` grows like ``sqrt(steps) * eps``,
not with the truncation error).

Attitude errors of geometric control (Lee, Leok, McClamroch), with
``Rt = R_d^T R`` (the attitude relative to the desired one):

* ``Psi(R, R_d) = 1/2 tr(I - R_d^T R)``, in ``[0, 2]`` (``1 - cos(angle)``);
* ``e_R = 1/2 (R_d^T R - R^T R_d)^vee``;
* ``e_Omega = Omega - R^T R_d Omega_d``;
* ``e_R' = E(Rt) e_Omega`` with ``E(Rt) = 1/2 (tr(Rt^T) I - Rt^T)``.

``det E(Rt) = (tr(Rt)^2 - 1) / 8`` (eigenvalues ``cos(angle)`` and
``(1 + exp(+-i angle)) / 2``), so **E is singular exactly when
tr(Rt) = +-1**, i.e. when the relative rotation angle is 90 degrees
(``Psi = 1``) or 180 degrees (``Psi = 2``); ``E`` is invertible on the
sublevel set ``Psi < 1`` used by the local geometric controllers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.errors import InputError, SimulationError
from formsync_design.models.quaternion import (
    as_rotation_input,
    as_vector,
    cross_matrix,
    matrix_to_quat,
)

__all__ = [
    "hat",
    "vee",
    "exp_so3",
    "log_so3",
    "dexp_inv",
    "so3_rhs",
    "So3Trajectory",
    "integrate_so3",
    "orthonormality_error",
    "attitude_error_function",
    "attitude_error_vector",
    "angular_velocity_error",
    "error_rate_matrix",
    "error_rate_determinant",
    "error_rate_singular",
]

RateFunction = Callable[[float, np.ndarray, np.ndarray], tuple[Any, Any]]


def hat(v: Any) -> np.ndarray:
    """Cross-product matrix ``v^`` with ``hat(v) @ w == cross(v, w)``.

    >>> hat([1, 2, 3])
    array([[ 0., -3.,  2.],
           [ 3.,  0., -1.],
           [-2.,  1.,  0.]])
    """
    return cross_matrix(as_vector(v, 3, "v"))


def vee(M: Any, tol: float = 1e-9) -> np.ndarray:
    """Inverse of :func:`hat`: the vector of a skew-symmetric 3x3 matrix.

    >>> vee(hat([1, 2, 3]))
    array([1., 2., 3.])
    >>> vee(np.eye(3))
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a skew-symmetric 3x3 matrix, received |M + M^T| = 3.4641
    """
    a = np.asarray(M, dtype=float)
    if a.shape != (3, 3):
        raise InputError(f"expected a skew-symmetric 3x3 matrix, received shape {'x'.join(map(str, a.shape))}")
    asym = float(np.linalg.norm(a + a.T))
    if not asym <= tol * max(1.0, float(np.linalg.norm(a))):
        raise InputError(f"expected a skew-symmetric 3x3 matrix, received |M + M^T| = {asym:g}")
    return np.array([a[2, 1] - a[1, 2], a[0, 2] - a[2, 0], a[1, 0] - a[0, 1]]) / 2.0


def exp_so3(v: Any) -> np.ndarray:
    """``exp(v^)`` by Rodrigues' formula (rotation by ``|v|`` about ``v``).

    >>> np.round(exp_so3([0, 0, np.pi / 2]), 12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    v = as_vector(v, 3, "v")
    return _exp(v)


def _exp(v: np.ndarray) -> np.ndarray:
    th2 = float(v @ v)
    if th2 < 1e-12:
        a = 1.0 - th2 / 6.0
        b = 0.5 - th2 / 24.0
    else:
        th = math.sqrt(th2)
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
    k = cross_matrix(v)
    return np.eye(3) + a * k + b * (k @ k)


def log_so3(R: Any) -> np.ndarray:
    """Rotation vector ``v`` (``|v| <= pi``) with ``exp_so3(v) = R``.

    >>> bool(np.allclose(log_so3(exp_so3([0.1, -0.2, 0.3])), [0.1, -0.2, 0.3]))
    True
    """
    q = matrix_to_quat(R)
    n = float(np.linalg.norm(q[1:]))
    if n == 0.0:
        return np.zeros(3)
    return 2.0 * math.atan2(n, q[0]) * q[1:] / n


def dexp_inv(u: Any, w: Any) -> np.ndarray:
    """``dexp_{-u}^{-1}(w)``: the Lie-algebra rate ``u'`` of ``R = R_n exp(u^)`` when ``R' = R w^``.

    Closed form ``w + 1/2 u x w + c(|u|) u x (u x w)`` with
    ``c(t) = (1 - (t/2) cot(t/2)) / t^2`` (``1/12`` at ``t = 0``).

    >>> dexp_inv([0, 0, 0], [1, 2, 3])
    array([1., 2., 3.])
    """
    return _dexp_inv(as_vector(u, 3, "u"), as_vector(w, 3, "w"))


def _dexp_inv(u: np.ndarray, w: np.ndarray) -> np.ndarray:
    th2 = float(u @ u)
    if th2 < 1e-6:
        c = 1.0 / 12.0 + th2 / 720.0
    else:
        th = math.sqrt(th2)
        c = (1.0 - 0.5 * th / math.tan(0.5 * th)) / th2
    uw = np.cross(u, w)
    return w + 0.5 * uw + c * np.cross(u, uw)


def so3_rhs(R: Any, omega: Any) -> np.ndarray:
    """``R' = R omega^``.

    >>> so3_rhs(np.eye(3), [0, 0, 1])
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  0.]])
    """
    return as_rotation_input(R, "R") @ hat(omega)


def orthonormality_error(R: Any) -> float:
    """``|R^T R - I|`` (Frobenius norm) of one 3x3 matrix.

    >>> orthonormality_error(np.eye(3))
    0.0
    """
    a = np.asarray(R, dtype=float)
    return float(np.linalg.norm(a.T @ a - np.eye(3)))


@dataclass(frozen=True)
class So3Trajectory:
    """Result of :func:`integrate_so3`.

    Attributes
    ----------
    t : numpy.ndarray
        Stored times.
    R : numpy.ndarray
        ``len(t) x 3 x 3`` rotation matrices.
    x : numpy.ndarray
        ``len(t) x m`` companion states (for example body rates).
    max_orthonormality_error : float
        Largest ``|R^T R - I|`` over *every* step (not only the stored ones).
    """

    t: np.ndarray
    R: np.ndarray
    x: np.ndarray
    max_orthonormality_error: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary.

        >>> So3Trajectory(np.zeros(1), np.eye(3)[None], np.zeros((1, 0)), 0.0).to_dict()
        {'samples': 1, 'max_orthonormality_error': 0.0}
        """
        from formsync_design.gains import json_number

        return {"samples": int(len(self.t)), "max_orthonormality_error": json_number(self.max_orthonormality_error)}


def integrate_so3(
    rate: RateFunction,
    R0: Any,
    t_span: tuple[float, float],
    dt: float,
    x0: Any = (),
    *,
    store_every: int = 1,
) -> So3Trajectory:
    """Integrate ``R' = R omega^`` (plus a companion ODE) with fixed-step RKMK4 (module docstring).

    Parameters
    ----------
    rate : callable
        ``rate(t, R, x) -> (omega, x_dot)``.
    R0 : array_like
        Initial rotation matrix (checked orthonormal to 1e-8).
    t_span : (float, float)
        Start and end time; the step is ``(t1 - t0) / ceil((t1 - t0) / dt)``.
    dt : float
        Largest step.
    x0 : array_like
        Initial companion state (empty by default), advanced with the same RK4 stages.
    store_every : int
        Keep every ``store_every``-th step (the last step is always kept).

    Examples
    --------
    A constant spin of 1 rad/s about z for pi s is a half turn:

    >>> tr = integrate_so3(lambda t, R, x: ([0, 0, 1.0], []), np.eye(3), (0.0, np.pi), 0.1)
    >>> bool(np.allclose(tr.R[-1], np.diag([-1.0, -1.0, 1.0]), atol=1e-12))
    True
    """
    R = as_rotation_input(R0, "R0")
    x = np.asarray(x0, dtype=float).ravel()
    t0, t1 = float(t_span[0]), float(t_span[1])
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"expected a time span t0 < t1, received ({t0:g}, {t1:g})")
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"expected a positive step dt, received {dt:g}")
    if isinstance(store_every, bool) or not isinstance(store_every, int) or store_every < 1:
        raise InputError(f"expected store_every as a positive integer, received {store_every!r}")
    n = max(1, math.ceil((t1 - t0) / dt - 1e-12))
    h = (t1 - t0) / n

    def f(t: float, Rs: np.ndarray, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w, xd = rate(t, Rs, xs)
        return np.asarray(w, dtype=float).ravel(), np.asarray(xd, dtype=float).ravel()

    ts, Rs, xs = [t0], [R.copy()], [x.copy()]
    worst = orthonormality_error(R)
    for k in range(n):
        t = t0 + k * h
        w1, x1 = f(t, R, x)
        k1 = w1
        u = 0.5 * h * k1
        w2, x2 = f(t + 0.5 * h, R @ _exp(u), x + 0.5 * h * x1)
        k2 = _dexp_inv(u, w2)
        u = 0.5 * h * k2
        w3, x3 = f(t + 0.5 * h, R @ _exp(u), x + 0.5 * h * x2)
        k3 = _dexp_inv(u, w3)
        u = h * k3
        w4, x4 = f(t + h, R @ _exp(u), x + h * x3)
        k4 = _dexp_inv(u, w4)
        R = R @ _exp(h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4))
        x = x + h / 6.0 * (x1 + 2.0 * x2 + 2.0 * x3 + x4)
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(x))):
            raise SimulationError(f"SO(3) integration produced NaN/inf at t={t + h:g}; try a smaller dt")
        worst = max(worst, orthonormality_error(R))
        if (k + 1) % store_every == 0 or k + 1 == n:
            ts.append(t0 + (k + 1) * h)
            Rs.append(R.copy())
            xs.append(x.copy())
    return So3Trajectory(np.array(ts), np.array(Rs), np.array(xs).reshape(len(ts), -1), worst)


# ---------------------------------------------------------------- geometric attitude errors
def attitude_error_function(R: Any, R_d: Any) -> float:
    """``Psi = 1/2 tr(I - R_d^T R)`` (0 at ``R = R_d``, 2 at a half turn).

    >>> attitude_error_function(np.eye(3), np.diag([-1.0, -1.0, 1.0]))
    2.0
    """
    Ra, Rb = as_rotation_input(R, "R"), as_rotation_input(R_d, "R_d")
    return float(0.5 * np.trace(np.eye(3) - Rb.T @ Ra))


def attitude_error_vector(R: Any, R_d: Any) -> np.ndarray:
    """``e_R = 1/2 (R_d^T R - R^T R_d)^vee`` (``sin(angle)`` times the axis).

    >>> np.round(attitude_error_vector(exp_so3([0, 0, 0.5]), np.eye(3)), 12)
    array([0.        , 0.        , 0.47942554])
    """
    Ra, Rb = as_rotation_input(R, "R"), as_rotation_input(R_d, "R_d")
    return vee(0.5 * (Rb.T @ Ra - Ra.T @ Rb))


def angular_velocity_error(R: Any, R_d: Any, omega: Any, omega_d: Any) -> np.ndarray:
    """``e_Omega = Omega - R^T R_d Omega_d`` (both rates in their own body frames).

    >>> angular_velocity_error(np.eye(3), np.eye(3), [1, 2, 3], [1, 0, 0])
    array([0., 2., 3.])
    """
    Ra, Rb = as_rotation_input(R, "R"), as_rotation_input(R_d, "R_d")
    return as_vector(omega, 3, "omega") - Ra.T @ Rb @ as_vector(omega_d, 3, "omega_d")


def error_rate_matrix(Rt: Any) -> Any:
    """``E(Rt) = 1/2 (tr(Rt^T) I - Rt^T)`` of ``e_R' = E(Rt) e_Omega`` (``Rt = R_d^T R``).

    Accepts a numpy rotation matrix or a SymPy ``Matrix`` (returned exact).

    >>> error_rate_matrix(np.eye(3))
    array([[1., 0., 0.],
           [0., 1., 0.],
           [0., 0., 1.]])
    >>> error_rate_matrix(sp.diag(-1, -1, 1))
    Matrix([
    [0, 0,  0],
    [0, 0,  0],
    [0, 0, -1]])
    """
    if isinstance(Rt, sp.MatrixBase):
        if Rt.shape != (3, 3):
            raise InputError(f"expected Rt as a 3x3 matrix, received shape {Rt.shape[0]}x{Rt.shape[1]}")
        return (Rt.T.trace() * sp.eye(3) - Rt.T) / 2
    a = as_rotation_input(Rt, "Rt")
    return 0.5 * (np.trace(a) * np.eye(3) - a.T)


def error_rate_determinant(Rt: Any) -> Any:
    """Closed form ``det E(Rt) = (tr(Rt)^2 - 1) / 8`` (module docstring); exact for SymPy input.

    >>> error_rate_determinant(sp.diag(-1, -1, 1))
    0
    >>> error_rate_determinant(np.eye(3))
    1.0
    """
    if isinstance(Rt, sp.MatrixBase):
        return (Rt.trace() ** 2 - 1) / 8
    tr = float(np.trace(as_rotation_input(Rt, "Rt")))
    return (tr * tr - 1.0) / 8.0


def error_rate_singular(Rt: Any, tol: float = 1e-12) -> bool:
    """Whether ``E(Rt)`` is singular: ``|tr(Rt)^2 - 1| <= tol`` (angle 90 or 180 degrees).

    SymPy input is decided exactly (``tol`` ignored).

    >>> error_rate_singular(exp_so3([np.pi / 2, 0, 0])), error_rate_singular(np.eye(3))
    (True, False)
    """
    if isinstance(Rt, sp.MatrixBase):
        return bool(sp.simplify(Rt.trace() ** 2 - 1) == 0)
    tr = float(np.trace(as_rotation_input(Rt, "Rt")))
    return abs(tr * tr - 1.0) <= tol
