"""SO(3) helpers, the RKMK4 integrator and the geometric attitude errors against independent truth.

* orthonormality over long torque-free rigid-body runs, and the attitude compared
  with quaternion propagation by scipy DOP853 (an independent integrator and
  representation); the conserved energy and inertial angular momentum;
* the integrator's order (error ratio ~16 when the step halves);
* ``e_R' = E(Rt) e_Omega`` against central finite differences along exact motions;
* ``det E = (tr^2 - 1)/8`` proved symbolically over the Cayley parametrization and
  checked exactly on rational rotations inside and outside the singular set.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from formsync_design.errors import InputError
from formsync_design.models.so3 import (
    angular_velocity_error,
    attitude_error_function,
    attitude_error_vector,
    dexp_inv,
    error_rate_determinant,
    error_rate_matrix,
    error_rate_singular,
    exp_so3,
    hat,
    integrate_so3,
    log_so3,
    orthonormality_error,
    vee,
)

J = np.diag([2.0, 3.0, 4.5])
J[0, 1] = J[1, 0] = 0.2
JI = np.linalg.inv(J)
W0 = np.array([0.4, -0.9, 0.7])
R0 = Rotation.from_rotvec([0.3, -1.1, 2.0]).as_matrix()


def euler(t, R, w):
    return w, -JI @ np.cross(w, J @ w)


def quaternion_reference(t_end: float, t_eval: np.ndarray) -> np.ndarray:
    """Torque-free body by scipy DOP853 on (q, w) with scalar-last quaternions; matrices out."""

    def rhs(t, y):
        q, w = y[:4], y[4:]  # scipy order: x, y, z, w
        v, s = q[:3], q[3]
        qd = 0.5 * np.concatenate((s * w + np.cross(v, w), [-v @ w]))
        return np.concatenate((qd, -JI @ np.cross(w, J @ w)))

    y0 = np.concatenate((Rotation.from_matrix(R0).as_quat(), W0))
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", t_eval=t_eval, rtol=1e-12, atol=1e-12)
    return np.array([Rotation.from_quat(q / np.linalg.norm(q)).as_matrix() for q in sol.y[:4].T])


def check_long_run(t_end: float, dt: float, store_every: int, tol_attitude: float):
    tr = integrate_so3(euler, R0, (0.0, t_end), dt, x0=W0, store_every=store_every)
    assert tr.max_orthonormality_error < 1e-10
    assert all(np.linalg.det(R) > 0 for R in tr.R)
    ref = quaternion_reference(t_end, tr.t)
    assert np.max(np.abs(tr.R - ref)) < tol_attitude
    E = np.array([0.5 * w @ J @ w for w in tr.x])
    H = np.array([R @ J @ w for R, w in zip(tr.R, tr.x)])
    assert np.ptp(E) < 1e-7 and np.max(np.abs(H - H[0])) < 1e-6


def test_rigid_body_50s_stays_on_group_and_matches_quaternions():
    check_long_run(50.0, 0.02, 250, 1e-7)


@pytest.mark.slow
def test_rigid_body_1000s_stays_on_group_and_matches_quaternions():
    check_long_run(1000.0, 0.01, 5000, 1e-7)


def test_rkmk4_is_fourth_order():
    # time-varying body rate, exact reference by scipy DOP853 on quaternions
    def w(t):
        return np.array([math.sin(t), 0.5 * math.cos(2 * t), 0.3 + 0.2 * t])

    def rhs(t, q):
        v, s = q[:3], q[3]
        ww = w(t)
        return 0.5 * np.concatenate((s * ww + np.cross(v, ww), [-v @ ww]))

    ref = solve_ivp(rhs, (0, 2.0), [0, 0, 0, 1.0], method="DOP853", rtol=1e-13, atol=1e-14)
    Rref = Rotation.from_quat(ref.y[:, -1]).as_matrix()
    errs = [
        np.max(np.abs(integrate_so3(lambda t, R, x: (w(t), []), np.eye(3), (0, 2.0), h).R[-1] - Rref))
        for h in (0.1, 0.05, 0.025)
    ]
    ratios = [errs[0] / errs[1], errs[1] / errs[2]]
    assert all(12 < r < 20 for r in ratios), (errs, ratios)


def test_hat_vee_exp_log_dexp():
    rng = np.random.default_rng(3)
    for _ in range(10):
        v, u = rng.normal(size=3), rng.normal(size=3)
        assert np.allclose(hat(v) @ u, np.cross(v, u))
        assert np.allclose(vee(hat(v)), v)
        assert np.allclose(exp_so3(v), Rotation.from_rotvec(v).as_matrix(), atol=1e-13)
        if np.linalg.norm(v) < math.pi:
            assert np.allclose(log_so3(exp_so3(v)), v, atol=1e-12)
        # dexp_inv inverts the derivative of t -> exp(u + t a) (left-trivialized at -u)
        a, h = rng.normal(size=3), 1e-6
        d = (exp_so3(u + h * a) - exp_so3(u - h * a)) / (2 * h)
        omega = vee(exp_so3(u).T @ d, tol=1e-7)  # R' = R omega^
        assert np.allclose(dexp_inv(u, omega), a, atol=1e-7)


def test_error_rate_against_finite_differences():
    rng = np.random.default_rng(17)
    for _ in range(10):
        Ra, Rd = exp_so3(rng.normal(size=3)), exp_so3(rng.normal(size=3))
        W, Wd = rng.normal(size=3), rng.normal(size=3)

        h = 1e-6  # exact motions R' = R W^, Rd' = Rd Wd^ over t = +-h
        e_plus, e_minus = (attitude_error_vector(Ra @ exp_so3(t * W), Rd @ exp_so3(t * Wd)) for t in (h, -h))
        fd = (e_plus - e_minus) / (2 * h)
        model = error_rate_matrix(Rd.T @ Ra) @ angular_velocity_error(Ra, Rd, W, Wd)
        assert np.allclose(fd, model, atol=1e-8)
        # Psi = 1 - cos(angle), e_R = sin(angle) axis
        ang = np.linalg.norm(log_so3(Rd.T @ Ra))
        assert math.isclose(attitude_error_function(Ra, Rd), 1 - math.cos(ang), abs_tol=1e-12)
        assert math.isclose(np.linalg.norm(attitude_error_vector(Ra, Rd)), math.sin(ang), abs_tol=1e-12)


def cayley(s: sp.Matrix) -> sp.Matrix:
    S = sp.Matrix([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    return (sp.eye(3) - S).inv() * (sp.eye(3) + S)


def test_error_matrix_determinant_identity_symbolic():
    s = sp.Matrix(sp.symbols("s1 s2 s3", real=True))
    R = sp.simplify(cayley(s))
    assert sp.simplify(R.T * R - sp.eye(3)) == sp.zeros(3, 3)
    assert sp.simplify(error_rate_matrix(R).det() - error_rate_determinant(R)) == 0


@pytest.mark.parametrize(
    "rotation, singular",
    [
        (cayley(sp.Matrix([1, 0, 0])), True),  # 90 deg about x: tr = 1
        (cayley(sp.Matrix([sp.Rational(3, 5), sp.Rational(4, 5), 0])), True),  # 90 deg, oblique
        (2 * sp.Matrix([3, 4, 0]) * sp.Matrix([[3, 4, 0]]) / 25 - sp.eye(3), True),  # 180 deg
        (cayley(sp.Matrix([sp.Rational(1, 2), 0, 0])), False),  # ~53 deg
        (cayley(sp.Matrix([2, 1, 2])), False),  # ~143 deg
        (sp.eye(3), False),
    ],
)
def test_error_matrix_singular_exactly_at_the_stated_set(rotation, singular):
    assert rotation.T * rotation == sp.eye(3) and rotation.det() == 1
    tr = rotation.trace()
    assert (tr in (1, -1)) is singular
    assert (error_rate_matrix(rotation).det() == 0) is singular
    assert error_rate_singular(rotation) is singular
    Rn = np.array(rotation, dtype=float)
    assert error_rate_singular(Rn, tol=1e-12) is singular
    assert math.isclose(np.linalg.det(error_rate_matrix(Rn)), float(error_rate_determinant(Rn)), abs_tol=1e-14)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: vee(np.ones((2, 2))), "expected a skew-symmetric 3x3 matrix, received shape 2x2"),
        (lambda: attitude_error_function(2 * np.eye(3), np.eye(3)), "expected R as a rotation matrix"),
        (lambda: integrate_so3(euler, np.eye(3), (1.0, 0.0), 0.1), "expected a time span"),
        (lambda: integrate_so3(euler, np.eye(3), (0.0, 1.0), -0.1), "expected a positive step"),
        (lambda: hat([1, 2]), "expected v as a vector of 3 numbers"),
    ],
)
def test_bad_input_one_line(call, match):
    with pytest.raises(InputError, match=match) as e:
        call()
    assert "\n" not in str(e.value)


def test_orthonormality_error_detects_drift():
    assert orthonormality_error(np.eye(3)) == 0.0
    assert orthonormality_error(np.diag([1.0, 1.0, 1.0 + 1e-6])) > 1e-6
