"""Euler angles in a paper's convention, the Euler-angle error measure ``Qa`` and jump
detection (angles are a display of the attitude; their ranges make them jump).

Convention :data:`PITCH_YAW_ROLL` (the Chinese flight-control textbook convention the SO(3)
paper's ref. [30] uses, body axes x forward, y up, z right): pitch ``theta`` about ``z``,
yaw ``psi`` about ``y``, roll ``phi`` about ``x``, ``R = Rz(theta) Ry(psi) Rx(phi)`` (body to
inertial), pitch and roll in ``(-180, 180]``, yaw in ``[-90, 90]``.  In the agent case files'
``euler_deg = [phi, theta, psi]`` (``R = Rz(psi) Ry(theta) Rx(phi)``) the same attitude is
``[roll, yaw, pitch]``.

>>> import numpy as np
>>> from formsync_design.verify.agentcase import euler321_to_quat
>>> from formsync_design.models.quaternion import quat_to_matrix
>>> q = euler321_to_quat(10, -20, 30)          # roll 10, yaw -20, pitch 30
>>> R = quat_to_matrix(np.array([q[3], *q[:3]]))
>>> [round(float(a), 9) for a in pitch_yaw_roll(R)]
[30.0, -20.0, 10.0]
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["PITCH_YAW_ROLL", "pitch_yaw_roll", "quats_to_matrices", "qa_error", "jumps"]

PITCH_YAW_ROLL = "pitch about z, yaw about y, roll about x: R = Rz(pitch) Ry(yaw) Rx(roll)"


def pitch_yaw_roll(R: Any) -> np.ndarray:
    """``(pitch, yaw, roll)`` in degrees of rotation matrices ``R`` (``..., 3, 3``)."""
    R = np.asarray(R, dtype=float)
    yaw = np.degrees(np.arcsin(np.clip(-R[..., 2, 0], -1.0, 1.0)))
    pitch = np.degrees(np.arctan2(R[..., 1, 0], R[..., 0, 0]))
    roll = np.degrees(np.arctan2(R[..., 2, 1], R[..., 2, 2]))
    pitch = np.where(pitch <= -180.0, pitch + 360.0, pitch)
    roll = np.where(roll <= -180.0, roll + 360.0, roll)
    return np.stack([pitch, yaw, roll], axis=-1)


def quats_to_matrices(Q: Any) -> np.ndarray:
    """Rotation matrices (body to inertial) of quaternions ``(..., 4)`` ordered ``(q1, q2, q3, q0)``.

    >>> quats_to_matrices(np.array([0, 0, 0, 1.0])).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    Q = np.asarray(Q, dtype=float)
    Q = Q / np.linalg.norm(Q, axis=-1, keepdims=True)
    v, q0 = Q[..., :3], Q[..., 3]
    I3 = np.eye(3)
    vv = np.einsum("...i,...j->...ij", v, v)
    H = np.zeros(Q.shape[:-1] + (3, 3))
    H[..., 0, 1], H[..., 0, 2], H[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    H[..., 1, 0], H[..., 2, 0], H[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    s = (q0**2 - np.sum(v * v, axis=-1))[..., None, None]
    return s * I3 + 2 * vv + 2 * q0[..., None, None] * H


def qa_error(angles: Any) -> np.ndarray:
    """``Qa = sqrt(sum_{i >= 2} |r_i - r_1|^2)`` (deg) per sample, ``angles`` ``(T, N, 3)``;
    each difference wrapped to ``(-180, 180]``.

    >>> qa_error(np.array([[[0, 0, 0], [3, 4, 0]]]))
    array([5.])
    """
    A = np.asarray(angles, dtype=float)
    d = A[:, 1:, :] - A[:, :1, :]
    d = (d + 180.0) % 360.0 - 180.0
    return np.sqrt(np.sum(d * d, axis=(1, 2)))


def jumps(series: Any, threshold: float = 90.0) -> list[tuple[int, int]]:
    """``(sample, column)`` where a series ``(T, ...)`` changes by more than ``threshold``
    between consecutive samples (a jump of the angle display).

    >>> jumps(np.array([[170.0], [178.0], [-176.0]]))
    [(2, 0)]
    """
    S = np.asarray(series, dtype=float).reshape(len(series), -1)
    d = np.abs(np.diff(S, axis=0))
    k, c = np.nonzero(d > threshold)
    return [(int(a) + 1, int(b)) for a, b in zip(k, c)]
