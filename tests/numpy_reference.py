"""An independent, straightforward numpy closed loop (tests and benchmark baseline).

Written by hand from the paper's formulas, deliberately *not* through the
sympy -> CasADi bridge, so that agreement with :mod:`formsync_design.sim.simulator`
is evidence and not a tautology:

* ``Q = 2 (q0 I - q^x + q q^T / q0)`` (closed form of ``E^{-1}``),
* ``Q' = 2 (q0' I - q'^x + (q' q^T + q q'^T)/q0 - q q^T q0'/q0^2)``, ``q0' = -q.q'/q0``,
* ``A = Q^T J Q``, ``B = Q^T J Q' - Q^T (J Q q')^x Q``,
* ``u = Q^{-T} ((B - K_o A) q' - K_q A s - K_v A sw(q' + beta s))`` via ``numpy.linalg.solve``,
* ``q' = (q0 I + q^x) omega / 2``, ``q0' = -q.omega/2``, ``J omega' = -omega x J omega + u + u_d``,
* paper disturbance ``u_mg + u_un`` with ``|u_mg| = lambda_max(J) 30 mu/R^3`` (all signs +).
"""

from __future__ import annotations

import numpy as np

MU = 3.986004418e14
RE = 6378137.0


def skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def switch(kind: str, tau: np.ndarray, phi: float) -> np.ndarray:
    if kind == "sgn":
        return np.sign(tau)
    if kind == "sat":
        return np.clip(tau / phi, -1, 1)
    return np.tanh(tau / phi)


def paper_disturbance(J: np.ndarray, t: float, altitude: float = 400e3) -> np.ndarray:
    R = RE + altitude
    m = np.linalg.eigvalsh(J)[-1] * 30 * MU / R**3 * np.ones(3)
    un = m / 5 * np.array([np.sin(t / 5), np.cos(t / 10), np.sin(t / 10) * np.cos(t / 5)])
    return m + un


def gravity_gradient(J: np.ndarray, q: np.ndarray, q0: float, t: float, altitude: float = 400e3) -> np.ndarray:
    R = RE + altitude
    n = np.sqrt(MU / R**3)
    RI = R * np.array([np.cos(n * t), np.sin(n * t), 0.0])
    # body -> inertial rotation of q_bar = (q, q0) with q_bar' = q_bar (x) (omega, 0)/2
    C_IB = (q0**2 - q @ q) * np.eye(3) + 2 * np.outer(q, q) + 2 * q0 * skew(q)
    RB = C_IB.T @ RI
    return 3 * MU / R**5 * np.cross(RB, J @ RB)


def make_rhs(J, L, K_o, K_q, beta, K_v, kind="sat", phi=0.01, disturbance="paper", umax=np.inf):
    """``f(t, x)`` of the closed loop in the simulator's state layout."""
    J = np.asarray(J, float)
    n = len(J)
    Jinv = np.linalg.inv(J)
    L = np.asarray(L, float)
    K_v = np.broadcast_to(np.asarray(K_v, float), (n,))

    def f(t, x):
        qb = x[: 4 * n].reshape(n, 4)
        w = x[4 * n :].reshape(n, 3)
        q, q0 = qb[:, :3], qb[:, 3]
        qd = np.empty((n, 3))
        for i in range(n):
            qd[i] = 0.5 * (q0[i] * np.eye(3) + skew(q[i])) @ w[i]
        s = L @ q
        dx = np.empty_like(x)
        for i in range(n):
            qi, q0i, qdi = q[i], q0[i], qd[i]
            Q = 2 * (q0i * np.eye(3) - skew(qi) + np.outer(qi, qi) / q0i)
            q0d = -qi @ qdi / q0i
            Qd = 2 * (q0d * np.eye(3) - skew(qdi) + (np.outer(qdi, qi) + np.outer(qi, qdi)) / q0i
                      - np.outer(qi, qi) * q0d / q0i**2)
            A = Q.T @ J[i] @ Q
            B = Q.T @ J[i] @ Qd - Q.T @ skew(J[i] @ Q @ qdi) @ Q
            tau = qdi + beta * s[i]
            v = (B - K_o * A) @ qdi - K_q * A @ s[i] - K_v[i] * A @ switch(kind, tau, phi)
            u = np.clip(np.linalg.solve(Q.T, v), -umax, umax)
            if disturbance == "paper":
                ud = paper_disturbance(J[i], t)
            elif disturbance == "gravity-gradient":
                ud = gravity_gradient(J[i], qi, q0i, t)
            else:
                ud = np.zeros(3)
            dx[4 * i : 4 * i + 3] = qdi
            dx[4 * i + 3] = -0.5 * qi @ w[i]
            dx[4 * n + 3 * i : 4 * n + 3 * i + 3] = Jinv[i] @ (-np.cross(w[i], J[i] @ w[i]) + u + ud)
        return dx

    return f


def metrics(x: np.ndarray, n: int) -> tuple[float, float]:
    """``(Omega_m, Q_m)`` with the paper's quaternion product, by the definition."""
    qb = x[: 4 * n].reshape(n, 4)
    w = x[4 * n :].reshape(n, 3)
    so = sq = 0.0
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            qa, q0a = -qb[j, :3], qb[j, 3]  # conjugate of q_j
            qbv, q0b = qb[i, :3], qb[i, 3]
            vec = q0a * qbv + q0b * qa + np.cross(qa, qbv)
            sq += vec @ vec
            so += (w[i] - w[j]) @ (w[i] - w[j])
    return float(np.sqrt(so / (n * (n - 1)))), float(np.sqrt(sq / (n * (n - 1))))
