"""Numeric unit-quaternion helpers shared by the attitude representations.

Convention (the paper's, eq. 1): a unit quaternion is ``q = (q0, q1, q2, q3)``,
scalar first, Hamilton product, and its rotation matrix ``R(q)`` maps body
coordinates to inertial coordinates,

    ``R(q) = (q0^2 - |q_v|^2) I + 2 q_v q_v^T + 2 q0 q_v^x``,

so that the body-rate kinematics ``q' = 1/2 q (x) (0, omega)`` (vector part
``q_v' = 1/2 (q0 I + q_v^x) omega``, paper eq. 1) and ``R' = R omega^`` describe
the same motion.  ``q`` and ``-q`` are the same attitude.

These are plain numpy functions on single 3-vectors/4-vectors and 3x3
matrices (:func:`quat_multiply_array`: on arrays of quaternions); malformed input
raises a one-line :class:`~formsync_design.errors.InputError`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from formsync_design.errors import InputError

__all__ = [
    "as_vector",
    "cross_matrix",
    "as_rotation_input",
    "quat_multiply",
    "quat_multiply_array",
    "quat_conjugate",
    "quat_normalize",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_rate",
    "quat_exp",
]


def _shape(a: np.ndarray) -> str:
    return "x".join(str(d) for d in a.shape) if a.ndim else "a scalar"


def as_vector(value: Any, size: int, name: str) -> np.ndarray:
    """``value`` as a finite float vector of length ``size`` (else one-line :class:`InputError`).

    >>> as_vector([1, 2, 3], 3, "omega")
    array([1., 2., 3.])
    >>> as_vector([1, 2], 3, "omega")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected omega as a vector of 3 numbers, received shape 2
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {name} as a vector of {size} numbers, received {value!r}") from None
    if a.shape != (size,):
        raise InputError(f"expected {name} as a vector of {size} numbers, received shape {_shape(a)}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"expected finite numbers in {name}, received a NaN or infinity")
    return a


def cross_matrix(v: np.ndarray) -> np.ndarray:
    """``v^x`` (``v^x w = v x w``) of an already-validated float 3-vector (no checks: inner loops).

    >>> cross_matrix(np.array([1.0, 2.0, 3.0]))
    array([[ 0., -3.,  2.],
           [ 3.,  0., -1.],
           [-2.,  1.,  0.]])
    """
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def as_rotation_input(value: Any, name: str, tol: float = 1e-8) -> np.ndarray:
    """``value`` as a 3x3 float rotation matrix, checked ``|R^T R - I| <= tol`` and ``det R > 0``.

    >>> as_rotation_input(np.eye(3), "R").shape
    (3, 3)
    >>> as_rotation_input(2 * np.eye(3), "R")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected R as a rotation matrix (|R^T R - I| <= 1e-08, det R = 1), received |R^T R - I| = 5.19615
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {name} as a 3x3 rotation matrix, received {value!r}") from None
    if a.shape != (3, 3):
        raise InputError(f"expected {name} as a 3x3 rotation matrix, received shape {_shape(a)}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"expected finite numbers in {name}, received a NaN or infinity")
    dev = float(np.linalg.norm(a.T @ a - np.eye(3)))
    if dev > tol or np.linalg.det(a) <= 0:
        shown = f"|R^T R - I| = {dev:g}" if dev > tol else f"det R = {float(np.linalg.det(a)):g}"
        raise InputError(
            f"expected {name} as a rotation matrix (|R^T R - I| <= {tol:g}, det R = 1), received {shown}"
        )
    return a


def quat_multiply(p: Any, q: Any) -> np.ndarray:
    """Hamilton product ``p (x) q`` (scalar first); ``R(p (x) q) = R(p) R(q)``.

    >>> quat_multiply([0, 1, 0, 0], [0, 0, 1, 0])
    array([0., 0., 0., 1.])
    """
    p = as_vector(p, 4, "p")
    q = as_vector(q, 4, "q")
    p0, pv = p[0], p[1:]
    q0, qv = q[0], q[1:]
    return np.concatenate(([p0 * q0 - pv @ qv], p0 * qv + q0 * pv + np.cross(pv, qv)))


def quat_multiply_array(p: Any, q: Any) -> np.ndarray:
    """Hamilton products ``p (x) q`` of quaternion arrays ``(..., 4)`` (scalar first, shapes
    broadcast): :func:`quat_multiply` row by row, vectorized and without its checks.

    >>> quat_multiply_array([[0, 1, 0, 0], [1, 0, 0, 0]], [0, 0, 1, 0])
    array([[0., 0., 0., 1.],
           [0., 0., 1., 0.]])
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if p.shape[-1:] != (4,) or q.shape[-1:] != (4,):
        raise InputError(f"expected quaternion arrays (..., 4), received shapes {_shape(p)} and "
                         f"{_shape(q)}")
    p0, pv = p[..., :1], p[..., 1:]
    q0, qv = q[..., :1], q[..., 1:]
    return np.concatenate([p0 * q0 - np.sum(pv * qv, axis=-1, keepdims=True),
                           p0 * qv + q0 * pv + np.cross(pv, qv)], axis=-1)


def quat_conjugate(q: Any) -> np.ndarray:
    """``q* = (q0, -q_v)``, the inverse of a unit quaternion.

    >>> quat_conjugate([1, 2, 3, 4])
    array([ 1., -2., -3., -4.])
    """
    q = as_vector(q, 4, "q")
    return np.concatenate(([q[0]], -q[1:]))


def quat_normalize(q: Any) -> np.ndarray:
    """``q / |q|`` (a nonzero 4-vector).

    >>> quat_normalize([2, 0, 0, 0])
    array([1., 0., 0., 0.])
    """
    q = as_vector(q, 4, "q")
    n = float(np.linalg.norm(q))
    if n == 0.0:
        raise InputError("expected a nonzero quaternion, received (0, 0, 0, 0)")
    return q / n


def quat_to_matrix(q: Any) -> np.ndarray:
    """Rotation matrix (body to inertial) of a quaternion, normalized first.

    >>> np.round(quat_to_matrix([math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)]), 12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    q = quat_normalize(q)
    q0, v = q[0], q[1:]
    return (q0 * q0 - v @ v) * np.eye(3) + 2.0 * np.outer(v, v) + 2.0 * q0 * cross_matrix(v)


def matrix_to_quat(R: Any) -> np.ndarray:
    """Unit quaternion with ``q0 >= 0`` of a rotation matrix (Shepperd's method).

    >>> matrix_to_quat(np.eye(3))
    array([1., 0., 0., 0.])
    """
    R = as_rotation_input(R, "R", tol=1e-6)
    tr = float(np.trace(R))
    d = [tr, R[0, 0], R[1, 1], R[2, 2]]
    k = int(np.argmax(d))
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = np.array([s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    else:
        i = k - 1
        j, m = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + 2.0 * R[i, i] - tr)
        q = np.zeros(4)
        q[0] = (R[m, j] - R[j, m]) / s
        q[1 + i] = s / 4
        q[1 + j] = (R[j, i] + R[i, j]) / s
        q[1 + m] = (R[m, i] + R[i, m]) / s
    q = q / np.linalg.norm(q)
    return -q if q[0] < 0 else q


def quat_rate(q: Any, omega: Any) -> np.ndarray:
    """``q' = 1/2 q (x) (0, omega)`` for body rates ``omega`` (paper eq. 1).

    >>> quat_rate([1, 0, 0, 0], [2, 0, 0])
    array([0., 1., 0., 0.])
    """
    w = as_vector(omega, 3, "omega")
    return 0.5 * quat_multiply(q, np.concatenate(([0.0], w)))


def quat_exp(v: Any) -> np.ndarray:
    """Unit quaternion of the rotation vector ``v`` (angle ``|v|`` about ``v/|v|``).

    >>> float(quat_exp([0, 0, math.pi])[3])
    1.0
    """
    v = as_vector(v, 3, "v")
    th = float(np.linalg.norm(v))
    if th < 1e-8:
        return quat_normalize(np.concatenate(([1.0 - th * th / 8], 0.5 * v)))
    return np.concatenate(([math.cos(th / 2)], math.sin(th / 2) / th * v))
