"""Modified Rodrigues parameters against independent truth.

* conversions against :mod:`scipy.spatial.transform` (an independent implementation);
* ``G(sigma)`` against central finite differences of the quaternion -> MRP map
  along exact rotations ``q (x) exp(h e_k / 2)``;
* composition against rotation-matrix products;
* propagation with shadow switching against quaternion propagation (both DOP853),
  compared through rotation matrices.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from formsync_design.errors import InputError
from formsync_design.models.mrp import (
    integrate_mrp,
    mrp_casadi_function,
    mrp_compose,
    mrp_from_matrix,
    mrp_from_quat,
    mrp_inverse_kinematics_matrix,
    mrp_kinematics_matrix,
    mrp_rate_matrix,
    mrp_relative,
    mrp_rhs,
    mrp_shadow,
    mrp_switch,
    mrp_to_matrix,
    mrp_to_quat,
)


def scipy_matrix(q: np.ndarray) -> np.ndarray:
    """Independent R(q): scipy takes scalar-last quaternions."""
    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


def random_quats(count: int, seed: int) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(count, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def exact_step(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """q (x) exp(v/2): rotate by the body-frame rotation vector v (written out independently)."""
    th = float(np.linalg.norm(v))
    d = np.concatenate(([math.cos(th / 2)], math.sin(th / 2) * v / th))
    q0, qv, d0, dv = q[0], q[1:], d[0], d[1:]
    return np.concatenate(([q0 * d0 - qv @ dv], q0 * dv + d0 * qv + np.cross(qv, dv)))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_conversions_match_scipy(seed):
    for q in random_quats(20, seed):
        s = mrp_from_quat(q)
        assert np.linalg.norm(s) <= 1.0 + 1e-15
        assert np.allclose(mrp_to_matrix(s), scipy_matrix(q), atol=1e-13)
        # scipy's own MRP (scalar-last convention, short set) is the same vector
        assert np.allclose(s, Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_mrp(), atol=1e-12)
        qq = mrp_to_quat(s)
        assert np.allclose(qq, q if q[0] >= 0 else -q, atol=1e-13)
        assert np.allclose(mrp_from_matrix(scipy_matrix(q)), s, atol=1e-12)
        # the shadow set describes the same attitude
        assert np.allclose(mrp_to_matrix(mrp_shadow(s)), mrp_to_matrix(s), atol=1e-12)


def test_half_turn_and_switch():
    # 180 degrees about x: |sigma| = 1 exactly, both sets valid
    s = mrp_from_matrix(np.diag([1.0, -1.0, -1.0]))
    assert np.allclose(np.abs(s), [1, 0, 0])
    big = np.array([0.0, 3.0, 4.0])
    assert np.allclose(mrp_switch(big), -big / 25.0)
    assert np.allclose(mrp_to_matrix(mrp_switch(big)), mrp_to_matrix(big), atol=1e-14)


@pytest.mark.parametrize("seed", [11, 12])
def test_rate_matrix_against_finite_differences(seed):
    h = 1e-6
    for q in random_quats(10, seed):
        if q[0] < 0:
            q = -q
        s = mrp_from_quat(q)
        fd = np.column_stack([
            (mrp_from_quat(exact_step(q, h * e)) - mrp_from_quat(exact_step(q, -h * e))) / (2 * h)
            for e in np.eye(3)
        ])
        assert np.allclose(mrp_rate_matrix(s), fd, atol=1e-8)


def test_sympy_numpy_casadi_forms_agree():
    sym = sp.Matrix(sp.symbols("s1 s2 s3"))
    G = mrp_kinematics_matrix(sym)
    # the stated inverse is an inverse (exact identity)
    assert sp.simplify(mrp_inverse_kinematics_matrix(sym) * G - sp.eye(3)) == sp.zeros(3, 3)
    f = mrp_casadi_function()
    rng = np.random.default_rng(5)
    for _ in range(10):
        s, w = rng.normal(size=3) * 0.6, rng.normal(size=3)
        Gn = np.array(G.subs(dict(zip(sym, s))), dtype=float)
        assert np.allclose(Gn, mrp_rate_matrix(s), atol=1e-14)
        assert np.allclose(mrp_rhs(s, w), Gn @ w, atol=1e-14)
        assert np.allclose(np.asarray(f(s, w)).ravel(), Gn @ w, atol=1e-14)


@pytest.mark.parametrize("seed", [21, 22])
def test_composition_matches_matrix_products(seed):
    rng = np.random.default_rng(seed)
    for _ in range(20):
        a, b = mrp_switch(rng.normal(size=3)), mrp_switch(rng.normal(size=3))
        c = mrp_compose(a, b)
        assert np.linalg.norm(c) <= 1.0 + 1e-12
        assert np.allclose(mrp_to_matrix(c), mrp_to_matrix(a) @ mrp_to_matrix(b), atol=1e-12)
        r = mrp_relative(a, b)
        assert np.allclose(mrp_to_matrix(r), mrp_to_matrix(b).T @ mrp_to_matrix(a), atol=1e-12)


def test_composition_near_full_turn_uses_the_robust_branch():
    # two 179.99-degree turns about z: the closed form's denominator vanishes
    t = math.tan(math.radians(179.99) / 4)
    a = np.array([0.0, 0.0, t])
    c = mrp_compose(a, a)
    assert np.allclose(mrp_to_matrix(c), mrp_to_matrix(a) @ mrp_to_matrix(a), atol=1e-12)
    assert np.linalg.norm(c) < 1e-3


def rates(t: float) -> np.ndarray:
    return np.array([1.5 * math.sin(0.7 * t), 0.8 + 0.5 * math.cos(1.3 * t), 2.0 * math.cos(0.4 * t)])


def test_propagation_with_shadow_switching_matches_quaternions():
    t_eval = np.linspace(0.0, 30.0, 121)
    s0 = np.array([0.3, -0.2, 0.5])
    tr = integrate_mrp(lambda t, s, x: (rates(t), []), s0, t_eval, rtol=1e-12, atol=1e-13)
    assert len(tr.switch_times) >= 3  # the test exercises switching
    assert np.all(np.linalg.norm(tr.sigma, axis=1) <= 1.0 + 1e-9)

    def quat_rhs(t, q):  # q' = 1/2 q (x) (0, w), written out independently
        w = rates(t)
        return 0.5 * np.concatenate(([-q[1:] @ w], q[0] * w + np.cross(q[1:], w)))

    def scalar_part(t, q):
        return q[0]

    q0 = mrp_to_quat(s0)
    ref = solve_ivp(
        quat_rhs, (0.0, 30.0), q0, method="DOP853", t_eval=t_eval, events=scalar_part, rtol=1e-12, atol=1e-13
    )
    for k in range(t_eval.size):
        assert np.allclose(mrp_to_matrix(tr.sigma[k]), scipy_matrix(ref.y[:, k]), atol=1e-8)
    # the short set switches exactly when the continuous quaternion's scalar part
    # crosses zero (rotation angle through 180 degrees)
    assert np.allclose(tr.switch_times, ref.t_events[0], atol=1e-7)
    assert tr.to_dict()["switches"] == len(tr.switch_times)


def test_propagation_with_companion_state_rigid_body():
    J = np.diag([1.0, 2.0, 3.0])
    Ji = np.linalg.inv(J)

    def rate(t, s, w):
        return w, -Ji @ np.cross(w, J @ w)

    w0 = np.array([0.1, 2.0, 0.1])
    tr = integrate_mrp(rate, [0.0, 0.0, 0.0], np.linspace(0, 20, 41), x0=w0)
    # torque-free invariants: kinetic energy and inertial angular momentum
    E = [0.5 * w @ J @ w for w in tr.x]
    H = [mrp_to_matrix(s) @ J @ w for s, w in zip(tr.sigma, tr.x)]
    assert np.ptp(E) < 1e-8 and np.max(np.abs(np.array(H) - H[0])) < 1e-7
    assert tr.switch_times


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: mrp_rate_matrix([1, 2]), "expected sigma as a vector of 3 numbers, received shape 2"),
        (lambda: mrp_shadow([0, 0, 0]), "expected a nonzero MRP"),
        (lambda: mrp_rhs([0, 0, float("nan")], [0, 0, 0]), "expected finite numbers in sigma"),
        (lambda: integrate_mrp(lambda t, s, x: ([0, 0, 1], []), [0, 0, 0], [1.0, 0.0]), "expected increasing"),
        (lambda: mrp_kinematics_matrix([1, 2]), "expected sigma as a 3-vector"),
    ],
)
def test_bad_input_one_line(call, match):
    with pytest.raises(InputError, match=match) as e:
        call()
    assert "\n" not in str(e.value)
