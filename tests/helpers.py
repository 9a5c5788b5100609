"""Numeric helpers shared by the tests (independent of the library's formulas)."""

from __future__ import annotations

import numpy as np
import sympy as sp

from formsync_design.models.attitude import derive_attitude_model


def cross(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def random_quaternion(rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Random unit quaternion with q0 > 0.1, as (vector part, q0)."""
    while True:
        x = rng.normal(size=4)
        x /= np.linalg.norm(x)
        if x[3] < 0:
            x = -x
        if x[3] > 0.1:
            return x[:3], float(x[3])


def random_inertia(rng: np.random.Generator) -> np.ndarray:
    M = rng.normal(size=(3, 3))
    return 40 * np.eye(3) + 5 * (M + M.T) / 2 + 10 * np.diag(rng.random(3))


_lamb: dict = {}


def model_numeric():
    """Lambdified derived A, B, Q, E as functions of (q, q0, qd, J)."""
    if not _lamb:
        m = derive_attitude_model()
        args = (*m.q, m.q0, *m.qd, *m.inertia_symbols)
        for name in ("A", "B", "Q", "E"):
            _lamb[name] = sp.lambdify(args, getattr(m, name), "numpy")

    def ev(name, q, q0, qd, J):
        return np.array(
            _lamb[name](*q, q0, *qd, J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2]),
            dtype=float,
        )

    return ev
