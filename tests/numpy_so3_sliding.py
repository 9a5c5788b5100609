"""An independent NumPy implementation of the reconstructed SO(3) sliding-mode law
(derivations/ma_so3.py, A1-A8), written from the closed-form derivatives of normalised
vectors instead of SymPy's differentiation, with rotation matrices integrated directly."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from tests.helpers import cross


def _unit(y, yd, ydd):
    n = np.linalg.norm(y)
    c = y / n
    nd = c @ yd
    cd = (yd - c * nd) / n
    ndd = cd @ yd + c @ ydd
    cdd = (ydd - cd * nd - c * ndd) / n - cd * nd / n
    return c, cd, cdd


def _vee_skew(A):
    return 0.5 * np.array([A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1]])


def command(nbrs):
    """``(R_d, W_d, W_d')`` from ``[(a, R_j, W_j)]``, neighbours' rates held (A8)."""
    M0 = sum(a * R for a, R, _ in nbrs)
    M1 = sum(a * R @ cross(w) for a, R, w in nbrs)
    M2 = sum(a * R @ cross(w) @ cross(w) for a, R, w in nbrs)
    c1, c1d, c1dd = _unit(M0[:, 0], M1[:, 0], M2[:, 0])
    m1, m2, m1d, m2d, m1dd, m2dd = M0[:, 0], M0[:, 1], M1[:, 0], M1[:, 1], M2[:, 0], M2[:, 1]
    c3, c3d, c3dd = _unit(np.cross(m1, m2), np.cross(m1d, m2) + np.cross(m1, m2d),
                          np.cross(m1dd, m2) + 2 * np.cross(m1d, m2d) + np.cross(m1, m2dd))
    c2 = np.cross(c3, c1)
    c2d = np.cross(c3d, c1) + np.cross(c3, c1d)
    c2dd = np.cross(c3dd, c1) + 2 * np.cross(c3d, c1d) + np.cross(c3, c1dd)
    Rd = np.column_stack([c1, c2, c3])
    Rdd = np.column_stack([c1d, c2d, c3d])
    Rddd = np.column_stack([c1dd, c2dd, c3dd])
    return Rd, _vee_skew(Rd.T @ Rdd), _vee_skew(Rd.T @ Rddd)


def beta(x, eps):
    r = np.abs(x)
    inner = 1.5 / np.sqrt(eps) * r - r * r / (2 * eps**1.5)
    return np.sign(x) * np.where(r >= eps, np.sqrt(r), inner)


def dbeta(x, eps):
    r = np.abs(x)
    return np.where(r >= eps, 0.5 / np.sqrt(np.maximum(r, eps)), 1.5 / np.sqrt(eps) - r / eps**1.5)


def law(R, W, J, Rd, Wd, Wdd, K1, K2, P1, P2, eps):
    Rt = Rd.T @ R
    eR = _vee_skew(Rt)
    eW = W - Rt.T @ Wd
    E = 0.5 * (np.trace(Rt) * np.eye(3) - Rt.T)
    eRd = E @ eW
    alpha = -K1 * eR - P1 * beta(eR, eps)
    alphad = -K1 * eRd - P1 * dbeta(eR, eps) * eRd
    s = eW - alpha
    gamma = cross(W) @ Rt.T @ Wd - Rt.T @ Wdd
    return np.cross(W, J @ W) - J @ (K2 * s + P2 * np.sqrt(np.abs(s)) * np.sign(s) + eR + gamma
                                    - alphad)


def torques(Rs, Ws, J, A, gains):
    n = len(Rs)
    out = []
    for i in range(n):
        nb = [(A[i, j], Rs[j], Ws[j]) for j in range(n) if A[i, j]]
        if nb:
            Rd, Wd, Wdd = command(nb)
        else:
            Rd, Wd, Wdd = Rs[i], np.zeros(3), np.zeros(3)
        out.append(law(Rs[i], Ws[i], J[i], Rd, Wd, Wdd, *gains))
    return np.array(out)


def simulate(R0, W0, J, A, gains, t_eval, rtol=1e-11, atol=1e-12):
    """Rotation matrices and rates integrated directly (DOP853); returns ``(T, N, 3, 3)``."""
    n = len(R0)

    def f(t, y):
        R = y[: 9 * n].reshape(n, 3, 3)
        W = y[9 * n:].reshape(n, 3)
        U = torques(R, W, J, A, gains)
        dR = np.array([R[i] @ cross(W[i]) for i in range(n)])
        dW = np.array([np.linalg.solve(J[i], -np.cross(W[i], J[i] @ W[i]) + U[i])
                       for i in range(n)])
        return np.concatenate([dR.ravel(), dW.ravel()])

    y0 = np.concatenate([np.asarray(R0).ravel(), np.asarray(W0).ravel()])
    sol = solve_ivp(f, (0, t_eval[-1]), y0, method="DOP853", rtol=rtol, atol=atol, t_eval=t_eval)
    return sol.y.T[:, : 9 * n].reshape(-1, n, 3, 3), sol.y.T[:, 9 * n:].reshape(-1, n, 3)
