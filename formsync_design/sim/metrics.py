"""The paper's formation metrics (section 3) and the convergence time."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

__all__ = ["metrics_expr", "formation_metrics", "linear_metrics", "convergence_time"]


def metrics_expr(x: Any, n: int) -> Any:
    """``(Omega_m, Q_m)`` (paper section 3) as CasADi expressions of the state.

    ``q_ij`` = vector part of ``q_bar_j^* (x) q_bar_i`` (paper's product):
    ``q0_j q_i - q0_i q_j - q_j x q_i``; ``omega_ij = omega_i - omega_j`` (body
    components, as in the paper's objective ``omega_i -> omega_j``).  Sums run
    over ordered pairs ``i != j`` and are normalised by ``n(n-1)``.
    """
    sw: Any = 0
    sq: Any = 0
    for i in range(n):
        qi, q0i = x[4 * i : 4 * i + 3], x[4 * i + 3]
        wi = x[4 * n + 3 * i : 4 * n + 3 * i + 3]
        for j in range(i + 1, n):
            qj, q0j = x[4 * j : 4 * j + 3], x[4 * j + 3]
            wj = x[4 * n + 3 * j : 4 * n + 3 * j + 3]
            qij = q0j * qi - q0i * qj - ca.cross(qj, qi)
            sq = sq + ca.sumsqr(qij)
            sw = sw + ca.sumsqr(wi - wj)
    # ordered pairs: each unordered pair twice (|q_ji| = |q_ij|)
    norm = n * (n - 1)
    return ca.vertcat(ca.sqrt(2 * sw / norm), ca.sqrt(2 * sq / norm))


def linear_metrics(X: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(Omega_m, Q_m)`` of :func:`metrics_expr` at every row of ``X`` in O(N) per row.

    ``sum_{i<j} |w_i - w_j|^2 = N sum_i |w_i - w_bar|^2``, and with ``p_i = r* (x) qb_i``
    (``r`` the normalised mean quaternion; left multiplication by a unit quaternion is
    orthogonal, so every ``qb_i . qb_j`` is kept and the ``p_i`` cluster around the scalar
    axis) ``|q_ij|^2 = |p_i|^2 |p_j|^2 - (p_i . p_j)^2``, whose sum over pairs is
    ``((tr P)^2 - |P|_F^2) / 2`` with ``P = sum_i p_i p_i^T``, evaluated as
    ``(A^2 - |V|_F^2) + 2 (A B - |c|^2)`` (``V = sum v_i v_i^T``, ``A = tr V``, ``c = sum
    s_i v_i``, ``B = sum s_i^2``; both parts are non-negative and free of cancellation
    near consensus).  The compiled driver evaluates the same formula.

    >>> x = np.array([[0, 0, 0, 1, 0.6, 0, 0, 0.8, 0, 0, 0, 0, 0, 0.0]])
    >>> [round(float(v[0]), 12) for v in linear_metrics(x, 2)]
    [0.0, 0.6]
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    if n < 2:
        z = np.zeros(X.shape[0])
        return z, z.copy()
    qb = X[:, : 4 * n].reshape(-1, n, 4)
    w = X[:, 4 * n :].reshape(-1, n, 3)
    r = qb.sum(axis=1)
    nr = np.linalg.norm(r, axis=1, keepdims=True)
    r = np.where(nr > 0, r / np.where(nr > 0, nr, 1.0), np.array([0.0, 0, 0, 1]))
    rv, r0 = r[:, None, :3], r[:, None, 3:4]
    qv, q0 = qb[..., :3], qb[..., 3:4]
    v = r0 * qv - q0 * rv - np.cross(rv, qv)
    s = (r0 * q0)[..., 0] + np.einsum("tik,tik->ti", np.broadcast_to(rv, qv.shape), qv)
    V = np.einsum("tij,tik->tjk", v, v)
    A = np.trace(V, axis1=1, axis2=2)
    c = np.einsum("ti,tij->tj", s, v)
    B = np.einsum("ti,ti->t", s, s)
    minors = (V[:, 0, 0] * V[:, 1, 1] - V[:, 0, 1] ** 2) + (V[:, 0, 0] * V[:, 2, 2] - V[:, 0, 2] ** 2) \
        + (V[:, 1, 1] * V[:, 2, 2] - V[:, 1, 2] ** 2)
    quad = 2 * minors + 2 * (A * B - np.einsum("tj,tj->t", c, c))
    d = w - w.mean(axis=1, keepdims=True)
    om = np.sqrt(2 * np.einsum("tij,tij->t", d, d) / (n - 1))
    qm = np.sqrt(np.maximum(quad, 0.0) / (n * (n - 1)))
    return om, qm


def formation_metrics(kernel_or_n: Any, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Omega_m, Q_m)`` at every row of ``X`` (shape ``(T, 7N)``), via the CasADi metric.

    ``kernel_or_n``: a :class:`~formsync_design.sim.kernels.Kernel` (its ``metrics``) or ``N``.

    >>> x = np.array([[0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0.0]])
    >>> [float(v[0]) for v in formation_metrics(2, x)]
    [0.0, 0.0]
    """
    if isinstance(kernel_or_n, (int, np.integer)):
        x = ca.SX.sym("x", 7 * int(kernel_or_n))
        mf = ca.Function("fs_metrics", [x], [metrics_expr(x, int(kernel_or_n))])
    else:
        mf = kernel_or_n.metrics
    X = np.atleast_2d(X)
    out = mf.map(X.shape[0])(X.T).full()
    return out[0], out[1]


def convergence_time(t: np.ndarray, omega_m: np.ndarray, q_m: np.ndarray, q_tol: float, omega_tol: float) -> float | None:
    """First grid time after which ``Q_m <= q_tol`` and ``Omega_m <= omega_tol`` hold to the end.

    ``None`` if the last sample violates either bound.

    >>> convergence_time(np.arange(4.0), np.array([1, 0, 1, 0.0]), np.zeros(4), 1e-4, 1e-5)
    3.0
    """
    ok = (np.asarray(q_m) <= q_tol) & (np.asarray(omega_m) <= omega_tol)
    if ok.size == 0 or not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    k = 0 if bad.size == 0 else int(bad[-1]) + 1
    return float(t[k])
