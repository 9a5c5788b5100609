"""The closed loop of :mod:`tests.numpy_reference`, vectorized over the spacecraft.

The benchmark's honest scipy baseline (issue 16, item 3): what a researcher
fluent in numpy would write - every spacecraft at once with stacked 3x3
products (``einsum``/``matmul`` over an ``(N, 3, 3)`` stack) and one batched
``numpy.linalg.solve``, no Python loop over spacecraft.  Same formulas, same
state layout and options as :func:`tests.numpy_reference.make_rhs` (the readable
per-spacecraft loop stays the oracle; ``tests/test_simulate.py`` checks the two
agree to rounding).
"""

from __future__ import annotations

import numpy as np

from tests.numpy_reference import MU, RE

__all__ = ["make_rhs", "skew_stack"]


def skew_stack(v: np.ndarray) -> np.ndarray:
    """``(N, 3) -> (N, 3, 3)`` cross-product matrices.

    >>> skew_stack(np.array([[1.0, 2.0, 3.0]])) @ np.array([4.0, 5.0, 6.0])
    array([[-3.,  6., -3.]])
    """
    z = np.zeros(v.shape[0])
    return np.stack(
        [
            np.stack([z, -v[:, 2], v[:, 1]], -1),
            np.stack([v[:, 2], z, -v[:, 0]], -1),
            np.stack([-v[:, 1], v[:, 0], z], -1),
        ],
        -2,
    )


def make_rhs(J, L, K_o, K_q, beta, K_v, kind="sat", phi=0.01, disturbance="paper", umax=np.inf):
    """``f(t, x)`` of the closed loop, all spacecraft at once (layout of the simulator)."""
    J = np.asarray(J, float)
    n = len(J)
    Jinv = np.linalg.inv(J)
    L = np.asarray(L, float)
    K_v = np.broadcast_to(np.asarray(K_v, float), (n,)).copy()
    eye = np.eye(3)
    R = RE + 400e3
    m_dist = np.linalg.eigvalsh(J)[:, -1] * 30 * MU / R**3  # (N,) constant part, all components
    n_orb = np.sqrt(MU / R**3)

    def sw(tau: np.ndarray) -> np.ndarray:
        if kind == "sgn":
            return np.sign(tau)
        if kind == "sat":
            return np.clip(tau / phi, -1, 1)
        return np.tanh(tau / phi)

    def f(t, x):
        qb = x[: 4 * n].reshape(n, 4)
        w = x[4 * n :].reshape(n, 3)
        q, q0 = qb[:, :3], qb[:, 3]
        qd = 0.5 * (q0[:, None] * w + np.cross(q, w))  # (q0 I + q^x) w / 2
        s = L @ q
        q0d = -np.einsum("ij,ij->i", q, qd) / q0
        Sq, Sqd = skew_stack(q), skew_stack(qd)
        qq = np.einsum("ij,ik->ijk", q, q)
        r = 1.0 / q0
        Q = 2 * (q0[:, None, None] * eye - Sq + qq * r[:, None, None])
        Qd = 2 * (
            q0d[:, None, None] * eye
            - Sqd
            + (np.einsum("ij,ik->ijk", qd, q) + np.einsum("ij,ik->ijk", q, qd)) * r[:, None, None]
            - qq * (q0d * r * r)[:, None, None]
        )
        QT = Q.transpose(0, 2, 1)
        JQ = J @ Q
        A = QT @ JQ
        JQqd = np.einsum("nij,nj->ni", JQ, qd)
        B = QT @ (J @ Qd) - QT @ skew_stack(JQqd) @ Q
        tau = qd + beta * s
        v = (
            np.einsum("nij,nj->ni", B - K_o * A, qd)
            - K_q * np.einsum("nij,nj->ni", A, s)
            - K_v[:, None] * np.einsum("nij,nj->ni", A, sw(tau))
        )
        u = np.clip(np.linalg.solve(QT, v[..., None])[..., 0], -umax, umax)
        if disturbance == "paper":
            un = np.array([np.sin(t / 5), np.cos(t / 10), np.sin(t / 10) * np.cos(t / 5)])
            ud = m_dist[:, None] * (1.0 + un / 5)
        elif disturbance == "gravity-gradient":
            RI = R * np.array([np.cos(n_orb * t), np.sin(n_orb * t), 0.0])
            qn = np.einsum("ij,ij->i", q, q)
            C_IB = (q0**2 - qn)[:, None, None] * eye + 2 * qq + 2 * q0[:, None, None] * Sq
            RB = np.einsum("nji,j->ni", C_IB, RI)
            ud = 3 * MU / R**5 * np.cross(RB, np.einsum("nij,nj->ni", J, RB))
        else:
            ud = np.zeros((n, 3))
        Jw = np.einsum("nij,nj->ni", J, w)
        wd = np.einsum("nij,nj->ni", Jinv, -np.cross(w, Jw) + u + ud)
        dx = np.empty_like(x)
        dq = dx[: 4 * n].reshape(n, 4)
        dq[:, :3] = qd
        dq[:, 3] = -0.5 * np.einsum("ij,ij->i", q, w)
        dx[4 * n :] = wd.ravel()
        return dx

    return f
