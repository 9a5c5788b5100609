"""The derived Lagrangian model against Euler's equation and Euler-Lagrange, numerically."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from formsync_design.models.attitude import derive_attitude_model, reduce_unit, skew

from .helpers import cross, model_numeric, random_inertia, random_quaternion

ev = model_numeric()


@pytest.mark.parametrize("seed", range(6))
def test_lagrangian_model_matches_euler_equation(seed):
    rng = np.random.default_rng(seed)
    q, q0 = random_quaternion(rng)
    w = rng.normal(size=3)
    J = random_inertia(rng)
    u = rng.normal(size=3)
    # independent: Euler's equation and quaternion kinematics
    wdot = np.linalg.solve(J, -np.cross(w, J @ w) + u)
    E = 0.5 * (q0 * np.eye(3) + cross(q))
    qd = E @ w
    q0d = -0.5 * q @ w
    Edot = 0.5 * (q0d * np.eye(3) + cross(qd))
    qdd = Edot @ w + E @ wdot
    A, B, Q = ev("A", q, q0, qd, J), ev("B", q, q0, qd, J), ev("Q", q, q0, qd, J)
    resid = A @ qdd + B @ qd - Q.T @ u
    assert np.max(np.abs(resid)) < 1e-9 * max(1.0, np.max(np.abs(Q.T @ u)))
    assert np.allclose(Q @ E, np.eye(3), atol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_b_matches_euler_lagrange_of_kinetic_energy(seed):
    """B qd = Adot qd - dT/dq with T = qd^T A(q) qd / 2, q0 = sqrt(1 - |q|^2) (finite differences)."""
    rng = np.random.default_rng(100 + seed)
    q, q0 = random_quaternion(rng)
    J = random_inertia(rng)
    qd = 0.3 * rng.normal(size=3)

    def A_of(qq):
        return ev("A", qq, np.sqrt(1 - qq @ qq), qd, J)

    h = 1e-6
    Adot = (A_of(q + h * qd) - A_of(q - h * qd)) / (2 * h)
    dTdq = np.array([
        (0.5 * qd @ A_of(q + h * e) @ qd - 0.5 * qd @ A_of(q - h * e) @ qd) / (2 * h)
        for e in np.eye(3)
    ])
    B = ev("B", q, q0, qd, J)
    assert np.allclose(B @ qd, Adot @ qd - dTdq, rtol=1e-6, atol=1e-6)


def test_a_is_positive_definite_and_b_is_not_skew():
    rng = np.random.default_rng(7)
    q, q0 = random_quaternion(rng)
    J = random_inertia(rng)
    qd = rng.normal(size=3)
    A = ev("A", q, q0, qd, J)
    B = ev("B", q, q0, qd, J)
    assert np.linalg.eigvalsh(A)[0] > 0
    assert np.max(np.abs(B + B.T)) > 1e-3


def test_q_closed_form_and_determinant_symbolically():
    m = derive_attitude_model()
    prod = (m.Q * m.E).applyfunc(lambda x: reduce_unit(x, m.q, m.q0))
    assert prod == sp.eye(3)
    assert reduce_unit(m.Q.det(), m.q, m.q0) == 8 / m.q0


def test_skew_is_cross_product():
    a = sp.Matrix(sp.symbols("a1:4"))
    b = sp.Matrix(sp.symbols("b1:4"))
    assert (skew(a) * b - a.cross(b)).applyfunc(sp.expand) == sp.zeros(3, 1)


def test_symbol_order_is_documented():
    m = derive_attitude_model()
    assert [str(s) for s in m.state_symbols] == ["q1", "q2", "q3", "q0", "qd1", "qd2", "qd3"]
    assert [str(s) for s in m.inertia_symbols] == ["J11", "J12", "J13", "J22", "J23", "J33"]


# -- the one inertia validator -----------------------------------------------------------


def test_check_inertia_against_constructed_spectra():
    """Matrices built as R diag(ev) R^T with a random rotation: accepted exactly when every
    constructed eigenvalue is > 0 (independent of the validator's own eigen-solver)."""
    import numpy as np
    import pytest

    from formsync_design.errors import InputError
    from formsync_design.models.inertia import check_inertia, check_inertias

    rng = np.random.default_rng(2024)
    for _ in range(40):
        Rm, _r = np.linalg.qr(rng.normal(size=(3, 3)))
        eig = rng.uniform(0.5, 50, size=3)
        if rng.random() < 0.5:
            eig[rng.integers(3)] *= -1
        J = Rm @ np.diag(eig) @ Rm.T
        J = (J + J.T) / 2
        if (eig > 0).all():
            np.testing.assert_array_equal(check_inertia(J), J)
        else:
            with pytest.raises(InputError, match="positive definite") as ei:
                check_inertia(J, k=3)
            assert "spacecraft 3" in str(ei.value) and "np.float64" not in str(ei.value)
    with pytest.raises(InputError, match="symmetric"):
        check_inertia([[1, 0.5, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(InputError, match="3x3"):
        check_inertia(np.eye(2))
    with pytest.raises(InputError, match="NaN/inf"):
        check_inertia(np.diag([1.0, np.inf, 1.0]))
    with pytest.raises(InputError, match="numeric"):
        check_inertia("heavy")
    with pytest.raises(InputError, match="spacecraft 2 in f.txt"):
        check_inertias([np.eye(3), -np.eye(3)], 2, src="f.txt")
