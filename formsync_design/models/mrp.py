"""Modified Rodrigues parameters (MRP): kinematics, conversions, shadow set, composition.

Convention (consistent with :mod:`formsync_design.models.quaternion`)
--------------------------------------------------------------------
The MRP of a unit quaternion ``q = (q0, q_v)`` (scalar first) is
``sigma = q_v / (1 + q0)``; ``q`` and ``-q`` give the two MRP sets of one
attitude, ``sigma`` and its *shadow* ``sigma^s = -sigma / |sigma|^2``.
``|sigma| <= 1`` is the short set (rotation angle at most 180 degrees).
``R(sigma)`` maps body to inertial coordinates,

    ``R(sigma) = I + (8 (sigma^x)^2 + 4 (1 - |sigma|^2) sigma^x) / (1 + |sigma|^2)^2``,

and the body-rate kinematics are ``sigma' = G(sigma) omega`` with

    ``G(sigma) = 1/4 [(1 - |sigma|^2) I + 2 sigma^x + 2 sigma sigma^T]``,
    ``G(sigma)^{-1} = 16 / (1 + |sigma|^2)^2 G(sigma)^T``.

``sigma`` grows without bound as the rotation angle approaches 360 degrees;
:func:`integrate_mrp` therefore switches to the shadow set whenever
``|sigma|`` crosses 1 (the switching surface, where ``sigma^s = -sigma``).

Forms provided
--------------
* SymPy: :func:`mrp_kinematics_matrix`, :func:`mrp_inverse_kinematics_matrix`
  (for a design's derivation, like ``E``/``Q`` of the quaternion model);
* generic arithmetic (floats, SymPy, CasADi ``SX``/``MX``): :func:`mrp_rhs_terms`,
  and a compiled-friendly :func:`mrp_casadi_function`;
* numpy: :func:`mrp_rate_matrix`, :func:`mrp_rhs`, conversions, shadow set,
  :func:`mrp_compose`, :func:`mrp_relative`, and :func:`integrate_mrp`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.errors import InputError, SimulationError
from formsync_design.models.attitude import skew
from formsync_design.models.quaternion import (
    as_vector,
    cross_matrix,
    matrix_to_quat,
    quat_multiply,
    quat_normalize,
)

__all__ = [
    "mrp_kinematics_matrix",
    "mrp_inverse_kinematics_matrix",
    "mrp_rhs_terms",
    "mrp_casadi_function",
    "mrp_rate_matrix",
    "mrp_rhs",
    "mrp_from_quat",
    "mrp_to_quat",
    "mrp_to_quat_array",
    "mrp_to_matrix",
    "mrp_from_matrix",
    "mrp_shadow",
    "mrp_switch",
    "mrp_compose",
    "mrp_relative",
    "MrpTrajectory",
    "integrate_mrp",
]

RateFunction = Callable[[float, np.ndarray, np.ndarray], tuple[Any, Any]]


# ---------------------------------------------------------------- symbolic / generic
def _sym3(sigma: Any) -> sp.Matrix:
    m = sp.Matrix(sigma)
    if m.shape != (3, 1):
        raise InputError(f"expected sigma as a 3-vector, received shape {m.shape[0]}x{m.shape[1]}")
    return m


def mrp_kinematics_matrix(sigma: Any) -> sp.Matrix:
    """SymPy ``G(sigma)`` of ``sigma' = G(sigma) omega`` (module docstring).

    >>> s = sp.Matrix(sp.symbols("s1 s2 s3"))
    >>> mrp_kinematics_matrix(s)[0, 1]
    s1*s2/2 - s3/2
    >>> mrp_kinematics_matrix([0, 0, 0])
    Matrix([
    [1/4,   0,   0],
    [  0, 1/4,   0],
    [  0,   0, 1/4]])
    """
    s = _sym3(sigma)
    n2 = (s.T * s)[0, 0]
    return ((1 - n2) * sp.eye(3) + 2 * skew(s) + 2 * s * s.T) / 4


def mrp_inverse_kinematics_matrix(sigma: Any) -> sp.Matrix:
    """SymPy ``G(sigma)^{-1} = 16 G(sigma)^T / (1 + |sigma|^2)^2`` (so ``omega = G^{-1} sigma'``).

    >>> s = sp.Matrix(sp.symbols("s1 s2 s3"))
    >>> sp.simplify(mrp_inverse_kinematics_matrix(s) * mrp_kinematics_matrix(s))
    Matrix([
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1]])
    """
    s = _sym3(sigma)
    n2 = (s.T * s)[0, 0]
    return 16 * mrp_kinematics_matrix(s).T / (1 + n2) ** 2


def mrp_rhs_terms(sigma: Any, omega: Any) -> list[Any]:
    """``G(sigma) omega`` as three expressions, using only ``+ - *`` (any arithmetic type).

    Works on floats, SymPy symbols and CasADi ``SX``/``MX`` elements alike.

    >>> mrp_rhs_terms([0.0, 0.0, 0.0], [4.0, 0.0, -8.0])
    [1.0, 0.0, -2.0]
    """
    s1, s2, s3 = sigma[0], sigma[1], sigma[2]
    w1, w2, w3 = omega[0], omega[1], omega[2]
    c = 1 - (s1 * s1 + s2 * s2 + s3 * s3)
    d = s1 * w1 + s2 * w2 + s3 * w3
    return [
        (c * w1 + 2 * (s2 * w3 - s3 * w2) + 2 * s1 * d) / 4,
        (c * w2 + 2 * (s3 * w1 - s1 * w3) + 2 * s2 * d) / 4,
        (c * w3 + 2 * (s1 * w2 - s2 * w1) + 2 * s3 * d) / 4,
    ]


def mrp_casadi_function(name: str = "mrp_rhs") -> Any:
    """A :class:`casadi.Function` ``(sigma[3], omega[3]) -> sigma'[3]`` (SX graph, codegen-ready).

    >>> f = mrp_casadi_function()
    >>> [float(v) for v in f([0, 0, 0], [4, 0, -8]).full().ravel()]
    [1.0, 0.0, -2.0]
    """
    import casadi as ca

    s = ca.SX.sym("sigma", 3)
    w = ca.SX.sym("omega", 3)
    return ca.Function(name, [s, w], [ca.vertcat(*mrp_rhs_terms(s, w))], ["sigma", "omega"], ["sigma_dot"])


# ---------------------------------------------------------------- numpy
def mrp_rate_matrix(sigma: Any) -> np.ndarray:
    """Numeric ``G(sigma)`` (3x3).

    >>> mrp_rate_matrix([0, 0, 0])
    array([[0.25, 0.  , 0.  ],
           [0.  , 0.25, 0.  ],
           [0.  , 0.  , 0.25]])
    """
    s = as_vector(sigma, 3, "sigma")
    sx = cross_matrix(s)
    return ((1.0 - s @ s) * np.eye(3) + 2.0 * sx + 2.0 * np.outer(s, s)) / 4.0


def mrp_rhs(sigma: Any, omega: Any) -> np.ndarray:
    """Numeric ``sigma' = G(sigma) omega``.

    >>> mrp_rhs([0, 0, 0], [4, 0, -8])
    array([ 1.,  0., -2.])
    """
    s = as_vector(sigma, 3, "sigma")
    w = as_vector(omega, 3, "omega")
    return np.array(mrp_rhs_terms(s, w), dtype=float)


def mrp_from_quat(q: Any) -> np.ndarray:
    """The short-set MRP (``|sigma| <= 1``) of a quaternion (sign of ``q`` chosen so ``q0 >= 0``).

    >>> mrp_from_quat([0, 0, 0, 1])
    array([0., 0., 1.])
    >>> mrp_from_quat([-1, 0, 0, 0]) + 0.0
    array([0., 0., 0.])
    """
    q = quat_normalize(q)
    if q[0] < 0:
        q = -q
    return q[1:] / (1.0 + q[0])


def mrp_to_quat(sigma: Any) -> np.ndarray:
    """Unit quaternion ``((1 - |s|^2), 2 s) / (1 + |s|^2)`` of an MRP.

    >>> mrp_to_quat([0, 0, 1])
    array([0., 0., 0., 1.])
    """
    s = as_vector(sigma, 3, "sigma")
    n2 = float(s @ s)
    return np.concatenate(([1.0 - n2], 2.0 * s)) / (1.0 + n2)


def mrp_to_quat_array(sigma: Any) -> np.ndarray:
    """Unit quaternions (scalar first) of MRPs ``(..., 3)``, shape ``(..., 4)``:
    :func:`mrp_to_quat` row by row (the same formula), vectorized.

    >>> mrp_to_quat_array([[0, 0, 1], [0, 0, 0]])
    array([[0., 0., 0., 1.],
           [1., 0., 0., 0.]])
    """
    s = np.asarray(sigma, dtype=float)
    if s.shape[-1:] != (3,):
        raise InputError(f"expected MRPs as an array (..., 3), received shape {s.shape}")
    n2 = np.sum(s * s, axis=-1, keepdims=True)
    return np.concatenate([1.0 - n2, 2.0 * s], axis=-1) / (1.0 + n2)


def mrp_to_matrix(sigma: Any) -> np.ndarray:
    """Rotation matrix ``R(sigma)`` (body to inertial, module docstring).

    >>> np.round(mrp_to_matrix([0, 0, np.tan(np.pi / 8)]), 12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    s = as_vector(sigma, 3, "sigma")
    n2 = float(s @ s)
    sx = cross_matrix(s)
    return np.eye(3) + (8.0 * sx @ sx + 4.0 * (1.0 - n2) * sx) / (1.0 + n2) ** 2


def mrp_from_matrix(R: Any) -> np.ndarray:
    """Short-set MRP of a rotation matrix (via Shepperd's quaternion).

    >>> mrp_from_matrix(np.diag([1.0, -1.0, -1.0]))
    array([1., 0., 0.])
    """
    return mrp_from_quat(matrix_to_quat(R))


def mrp_shadow(sigma: Any) -> np.ndarray:
    """The shadow MRP ``-sigma / |sigma|^2`` (same attitude; undefined at ``sigma = 0``).

    >>> mrp_shadow([0, 2, 0])
    array([-0. , -0.5, -0. ])
    >>> mrp_shadow([0, 0, 0])
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a nonzero MRP (the shadow of 0 is at infinity), received (0, 0, 0)
    """
    s = as_vector(sigma, 3, "sigma")
    n2 = float(s @ s)
    if n2 == 0.0:
        raise InputError("expected a nonzero MRP (the shadow of 0 is at infinity), received (0, 0, 0)")
    return -s / n2


def mrp_switch(sigma: Any) -> np.ndarray:
    """``sigma`` if ``|sigma| <= 1``, else its shadow (the switching rule).

    >>> mrp_switch([0, 0, 0.5]), mrp_switch([0, 0, 4])
    (array([0. , 0. , 0.5]), array([-0.  , -0.  , -0.25]))
    """
    s = as_vector(sigma, 3, "sigma")
    return mrp_shadow(s) if float(s @ s) > 1.0 else s


def mrp_compose(a: Any, b: Any) -> np.ndarray:
    """Short-set MRP of ``R(a) R(b)`` (quaternion ``q_a (x) q_b``).

    Closed form ``((1-|a|^2) b + (1-|b|^2) a + 2 a x b) / (1 + |a|^2|b|^2 - 2 a.b)``;
    where that denominator is small (composition near 360 degrees) the
    quaternion product is used instead.

    >>> t = np.tan(np.pi / 16)
    >>> bool(np.allclose(mrp_compose([0, 0, t], [0, 0, t]), [0, 0, np.tan(np.pi / 8)]))
    True
    """
    a = as_vector(a, 3, "a")
    b = as_vector(b, 3, "b")
    na, nb = float(a @ a), float(b @ b)
    den = 1.0 + na * nb - 2.0 * float(a @ b)
    if den < 1e-3 * (1.0 + na * nb):
        return mrp_from_quat(quat_multiply(mrp_to_quat(a), mrp_to_quat(b)))
    s = ((1.0 - na) * b + (1.0 - nb) * a + 2.0 * np.cross(a, b)) / den
    return mrp_switch(s) if float(s @ s) > 0.0 else s


def mrp_relative(sigma_i: Any, sigma_j: Any) -> np.ndarray:
    """Short-set MRP of ``R_j^T R_i``: attitude of body ``i`` seen from body ``j``.

    >>> mrp_relative([0, 0, 0.2], [0, 0, 0.2])
    array([0., 0., 0.])
    """
    return mrp_compose(-as_vector(sigma_j, 3, "sigma_j"), sigma_i)


# ---------------------------------------------------------------- integration
@dataclass(frozen=True)
class MrpTrajectory:
    """Result of :func:`integrate_mrp`.

    Attributes
    ----------
    t : numpy.ndarray
        Output times (``t_eval``).
    sigma : numpy.ndarray
        ``len(t) x 3`` MRPs, always in the short set ``|sigma| <= 1``.
    x : numpy.ndarray
        ``len(t) x m`` companion states (for example body rates).
    switch_times : tuple of float
        Times at which the integration switched to the shadow set.
    """

    t: np.ndarray
    sigma: np.ndarray
    x: np.ndarray
    switch_times: tuple[float, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (numbers by :func:`formsync_design.gains.json_number`).

        >>> MrpTrajectory(np.zeros(1), np.zeros((1, 3)), np.zeros((1, 0)), (0.5,)).to_dict()
        {'samples': 1, 'switches': 1, 'switch_times': [0.5]}
        """
        from formsync_design.gains import json_number

        return {
            "samples": int(len(self.t)),
            "switches": len(self.switch_times),
            "switch_times": [json_number(v) for v in self.switch_times],
        }


def integrate_mrp(
    rate: RateFunction,
    sigma0: Any,
    t_eval: Any,
    x0: Any = (),
    *,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    method: str = "DOP853",
    max_switches: int = 100000,
) -> MrpTrajectory:
    """Integrate ``sigma' = G(sigma) omega`` with shadow switching at ``|sigma| = 1``.

    Parameters
    ----------
    rate : callable
        ``rate(t, sigma, x) -> (omega, x_dot)``: body rate and the derivative
        of the companion state ``x`` (for example Euler's equation).
    sigma0 : array_like
        Initial MRP (switched to the short set first).
    t_eval : array_like
        Increasing output times; the first is the initial time.
    x0 : array_like
        Initial companion state (empty by default).
    rtol, atol, method
        Passed to :func:`scipy.integrate.solve_ivp`.
    max_switches : int
        Safety cap on the number of shadow switches.

    Examples
    --------
    A constant spin of 2 rad/s about z for 4 s (8 rad, more than a turn):

    >>> tr = integrate_mrp(lambda t, s, x: ([0, 0, 2.0], []), [0, 0, 0], [0.0, 4.0])
    >>> len(tr.switch_times), round(float(tr.switch_times[0]), 6)
    (1, 1.570796)
    >>> bool(np.allclose(mrp_to_matrix(tr.sigma[-1]), mrp_to_matrix([0, 0, np.tan(2.0)]), atol=1e-8))
    True
    """
    from scipy.integrate import solve_ivp

    s0 = mrp_switch(as_vector(sigma0, 3, "sigma0"))
    xs = np.asarray(x0, dtype=float).ravel()
    m = xs.size
    ts = np.asarray(t_eval, dtype=float).ravel()
    if ts.size < 1 or not np.all(np.isfinite(ts)) or np.any(np.diff(ts) <= 0):
        raise InputError(f"expected increasing finite output times, received {ts.size} values")

    def f(t: float, y: np.ndarray) -> np.ndarray:
        w, xd = rate(t, y[:3], y[3:])
        w = np.asarray(w, dtype=float).ravel()
        return np.concatenate((mrp_rhs_terms(y[:3], w), np.asarray(xd, dtype=float).ravel()))

    def crossing(t: float, y: np.ndarray) -> float:
        return float(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]) - 1.0

    crossing.terminal = True  # type: ignore[attr-defined]
    crossing.direction = 1.0  # type: ignore[attr-defined]

    out = np.empty((ts.size, 3 + m))
    out[0] = np.concatenate((s0, xs))
    y = out[0].copy()
    t = float(ts[0])
    k = 1  # next output index
    switches: list[float] = []
    while k < ts.size:
        sol = solve_ivp(f, (t, float(ts[-1])), y, method=method, t_eval=ts[k:], events=crossing, rtol=rtol, atol=atol)
        if sol.status < 0 or not np.all(np.isfinite(sol.y)):
            raise SimulationError(f"MRP integration failed at t={t:g} ({sol.message}); try a looser rtol or a smaller time span")
        n_out = int(np.asarray(sol.t).size)
        if n_out:
            out[k : k + n_out] = np.asarray(sol.y).T
        k += n_out
        if sol.status != 1:
            break
        t = float(sol.t_events[0][0])
        ye = sol.y_events[0][0]
        y = np.concatenate((mrp_shadow(ye[:3]), ye[3:]))
        switches.append(t)
        if len(switches) > max_switches:
            raise SimulationError(f"more than {max_switches} MRP shadow switches by t={t:g}; check the body rates or raise max_switches")
    sig = np.array([mrp_switch(s) for s in out[:, :3]])
    return MrpTrajectory(t=ts, sigma=sig, x=out[:, 3:], switch_times=tuple(switches))
