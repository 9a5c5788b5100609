"""The paper's formation metrics (section 3) and the convergence time."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

__all__ = ["metrics_expr", "formation_metrics", "convergence_time"]


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
