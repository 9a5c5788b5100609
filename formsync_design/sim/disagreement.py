"""Disagreement of a formation's trajectory, per output time: the principal angle between two
attitudes, the largest one over every pair of spacecraft, the largest pairwise body-rate
difference, and the first time from which a condition holds to the end.

Shared by every producer of :class:`~formsync_design.sim.result.SimResult` (the Lagrangian
simulator and the agent designs' drivers), below both of them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["principal_angles", "attitude_disagreement", "rate_disagreement", "settle_time"]


def principal_angles(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """Principal angle (rad) between attitudes (``..., 4`` quaternions, scalar last), double
    cover removed: ``2 atan2(|vec(qa* qb)|, |qa . qb|)``, accurate to a relative rounding
    error at every angle (``2 arccos|qa . qb|`` loses every digit below about 3e-8 rad).
    The norm of the relative quaternion's vector part, ``|w_a v_b - w_b v_a + v_a x v_b|``,
    is the same in either product convention (the cross product is orthogonal to the rest).

    >>> import math
    >>> round(float(principal_angles(np.array([0, 0, 0, 1.0]),
    ...                              np.array([0, 0, math.sin(0.5), math.cos(0.5)]))), 12)
    1.0
    >>> float(principal_angles(np.array([0, 0, 0, 1.0]), np.array([1e-12, 0, 0, 1.0])))
    2e-12
    """
    qa = qa / np.linalg.norm(qa, axis=-1, keepdims=True)
    qb = qb / np.linalg.norm(qb, axis=-1, keepdims=True)
    va, wa = qa[..., :3], qa[..., 3:]
    vb, wb = qb[..., :3], qb[..., 3:]
    s = np.linalg.norm(wa * vb - wb * va + np.cross(va, vb), axis=-1)
    c = np.abs(np.sum(qa * qb, axis=-1))
    return 2.0 * np.arctan2(s, c)


def attitude_disagreement(Q: np.ndarray) -> np.ndarray:
    """Largest principal angle (deg) between two spacecraft, per sample (``Q``: (T, N, 4)).

    >>> import math
    >>> Q = np.array([[[0, 0, 0, 1.0], [0, 0, math.sin(0.25), math.cos(0.25)]]])
    >>> round(float(attitude_disagreement(Q)[0]), 10) == round(math.degrees(0.5), 10)
    True
    """
    T, N, _ = Q.shape
    out = np.zeros(T)
    for i in range(N - 1):
        out = np.maximum(out, principal_angles(Q[:, i:i + 1, :], Q[:, i + 1:, :]).max(axis=1))
    return np.degrees(out)


def rate_disagreement(W: np.ndarray) -> np.ndarray:
    """Largest pairwise body-rate difference ``max_ij |w_i - w_j|`` (rad/s), per sample
    (``W``: (T, N, 3)).

    >>> float(rate_disagreement(np.array([[[0.0, 0, 0], [0, 3, 4], [0, 0, 1]]]))[0])
    5.0
    """
    out = np.linalg.norm(W - W, axis=2).max(axis=1)  # i = j: zero, or nan at a non-finite rate
    for i in range(W.shape[1] - 1):  # pair by pair: no (T, N, N, 3) array
        out = np.maximum(out, np.linalg.norm(W[:, i:i + 1, :] - W[:, i + 1:, :], axis=2).max(axis=1))
    return out


def settle_time(t: np.ndarray, ok: np.ndarray) -> float | None:
    """First time of ``t`` from which ``ok`` holds to the end (None when it fails at the end).

    >>> settle_time(np.arange(4.0), np.array([True, False, True, True]))
    2.0
    """
    if not ok.size or not ok[-1]:
        return None
    bad = np.nonzero(~ok)[0]
    return float(t[0]) if bad.size == 0 else float(t[bad[-1] + 1])
