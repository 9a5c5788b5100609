"""Tests of formsync_design.models.relative_reference against independent truth.

* analytic derivatives of phi_r, theta_r and l_r against central finite differences;
* the printed phi_r (exp(-1/P1)) is constant: computed over the simulated span;
* the paper's printed initial angles are recovered from its initial orbits;
* the desired frame: orthonormal, sensor axis on the target, angular velocity and
  acceleration against finite differences of the rotation matrices, and the inertial
  rate against finite differences of R_dT R_TI(t) built from the target's ECI orbit;
* the fly-around plane converges to the 70 deg plane (computed from l_T and l_T');
* singular cases use the documented fallback.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.errors import InputError
from formsync_design.models.orbit import (
    ZHANG2014_CHASER,
    ZHANG2014_TARGET,
    KeplerElements,
    elements_to_state,
    lvlh_matrix,
    mean_motion,
    relative_state,
)
from formsync_design.models.relative_reference import (
    ZHANG2014_FLYAROUND,
    FrameStatus,
    attitude_frame,
    desired_attitude,
    desired_position,
    desired_position_T,
    initial_angles,
    phi_r,
    printed_phi_finding,
    rotation_rT,
    theta_r,
)

P = ZHANG2014_FLYAROUND
TIMES = [0.0, 37.0, 850.0, 3000.0, 12345.0]


def _fd(fun, t, h):
    """Central first difference of fun (array-valued) at t."""
    return (np.asarray(fun(t + h)) - np.asarray(fun(t - h))) / (2 * h)


@pytest.mark.parametrize("t", TIMES)
def test_angle_derivatives_against_finite_differences(t):
    h = 1e-2
    for fun in (lambda s: phi_r(s, P, 3), lambda s: theta_r(s, P, 3)):
        d = fun(t)
        for k in range(3):  # derivative k+1 from a difference of derivative k
            fd = _fd(lambda s, k=k, fun=fun: fun(s)[k], t, h)
            assert abs(fd - d[k + 1]) <= 1e-7 * max(1.0, abs(d[k + 1])) + 1e-12, (k, fd, d[k + 1])


@pytest.mark.parametrize("t", TIMES)
def test_position_derivatives_against_finite_differences(t):
    h = 1e-2
    L = desired_position(t, P, 3)
    assert math.isclose(np.linalg.norm(L[0]), 500.0, rel_tol=1e-12)  # on the sphere
    for k in range(3):
        fd = _fd(lambda s, k=k: desired_position(s, P, 3)[k], t, h)
        scale = max(1e-6, float(np.abs(L[k + 1]).max()))
        assert np.abs(fd - L[k + 1]).max() <= 1e-6 * scale, (k, fd, L[k + 1])
    # second derivative also from a second difference of the position itself
    sd = (desired_position(t + 1.0, P, 0)[0] - 2 * L[0] + desired_position(t - 1.0, P, 0)[0]) / 1.0
    assert np.abs(sd - L[2]).max() <= 1e-5 * max(1e-6, float(np.abs(L[2]).max()))


def test_printed_phi_is_constant_and_never_reaches_the_plane():
    f = printed_phi_finding(P, 18_000.0)
    assert f.printed_span == 0.0
    samples = [phi_r(t, P, 2, "printed") for t in np.linspace(0, 18_000, 7)]
    assert all(s[0] == samples[0][0] and s[1] == 0 and s[2] == 0 for s in samples)
    assert f.printed_start_offset != 0.0  # not even phi_r0
    assert math.degrees(f.printed_final_gap) > 60.0  # stays ~70 deg off the fly-around plane
    assert f.corrected_span > 1.0 and f.corrected_final_gap < 1e-6


def test_paper_initial_angles_are_recovered_from_its_orbits():
    X0 = relative_state(elements_to_state(ZHANG2014_TARGET), elements_to_state(ZHANG2014_CHASER))
    phi0, theta0 = initial_angles(X0[:3], P)
    # the paper prints two decimals
    assert abs(math.degrees(phi0) - 20.13) < 0.005
    assert abs(math.degrees(theta0) - 269.33) < 0.005
    # the opposite tilt would not: the convention of R_rT is pinned by the paper's numbers
    flipped = type(P).from_degrees(**{**_deg(P), "alpha": -70.0})
    assert abs(math.degrees(initial_angles(X0[:3], flipped)[0]) - 20.13) > 100


def _deg(p):
    out = {k: getattr(p, k) for k in ("a", "b", "c", "p1", "p2", "period")}
    out.update(
        {k: math.degrees(getattr(p, k)) for k in ("gamma", "alpha", "beta", "phi0", "theta0")}
    )
    return out


def test_rotation_rT_is_a_rotation_and_3_1_2_order():
    p = type(P).from_degrees(**{**_deg(P), "gamma": 10.0, "beta": -25.0})
    R = rotation_rT(p)
    assert np.allclose(R @ R.T, np.eye(3)) and math.isclose(np.linalg.det(R), 1.0)
    # independent construction: the frame r is T rotated about z by gamma, then about the
    # new x by alpha, then about the new y by beta (rows = r axes in T)
    g, a, b = p.gamma, p.alpha, p.beta

    def axis_rot(axis, ang):  # active rotation (Rodrigues)
        k = np.asarray(axis, float)
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        return np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K

    axes = np.eye(3)
    axes = axis_rot(axes[2], g) @ axes
    axes = axis_rot(axes[:, 0], a) @ axes
    axes = axis_rot(axes[:, 1], b) @ axes
    assert np.allclose(R, axes.T, atol=1e-12)


def test_flyaround_plane_converges_to_70_degrees():
    L = desired_position_T(18_000.0, P, 1)
    normal = np.cross(L[0], L[1])
    tilt = math.degrees(math.acos(normal[2] / np.linalg.norm(normal)))
    assert abs(tilt - 70.0) < 1e-4
    L7 = desired_position_T(7200.0, P, 1)
    n7 = np.cross(L7[0], L7[1])
    assert abs(math.degrees(math.acos(n7[2] / np.linalg.norm(n7))) - 70.0) < 0.5
    # it starts in the target's orbital plane (the paper's "initial plane angle 0")
    L0 = desired_position_T(0.0, P, 0)[0]
    assert abs(L0[2]) / np.linalg.norm(L0) < 0.01
    # and leaves it: half-way through the transition it is well out of that plane
    assert abs(desired_position_T(1000.0, P, 0)[0][2]) > 300.0


@pytest.mark.parametrize("t", TIMES)
def test_desired_frame_geometry_and_rates(t):
    n = mean_motion(ZHANG2014_TARGET.a)
    d = desired_attitude(t, P, n)
    assert d.status is FrameStatus.REGULAR
    R = d.R_dr
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-12) and math.isclose(np.linalg.det(R), 1.0)
    L = desired_position(t, P, 1)
    assert np.allclose(R[0], -L[0] / np.linalg.norm(L[0]))  # sensor axis at the target
    assert abs(R[1] @ L[1]) < 1e-9 * np.linalg.norm(L[1])  # y_d normal to the motion plane
    # omega_dr from finite differences of R_dr: [w]x = -R' R^T
    h = 1e-3
    Rp = _fd(lambda s: desired_attitude(s, P, n).R_dr, t, h)
    W = -Rp @ R.T
    assert np.allclose(W, -W.T, atol=1e-10)
    w_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
    assert np.allclose(w_fd, d.omega_dr, rtol=1e-6, atol=1e-12)
    wd_fd = _fd(lambda s: desired_attitude(s, P, n).omega_dr, t, 1.0)
    assert np.allclose(wd_fd, d.omega_dr_dot, rtol=1e-4, atol=1e-13)


@pytest.mark.parametrize("t", [10.0, 4000.0])
def test_inertial_rate_against_the_target_orbit(t):
    """omega_di against finite differences of R_di(t) = R_dT(t) R_TI(t) (ECI orbit)."""
    a, u0 = ZHANG2014_TARGET.a, ZHANG2014_TARGET.nu
    n = mean_motion(a)

    def r_di(s):
        r, v = elements_to_state(KeplerElements(a=a, e=0.0, i=0.0, nu=u0 + n * s))
        return desired_attitude(s, P, n).R_dT @ lvlh_matrix(r, v)

    h = 1e-2
    R = r_di(t)
    W = -_fd(r_di, t, h) @ R.T
    w_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
    d = desired_attitude(t, P, n)
    assert np.allclose(w_fd, d.omega_di, rtol=1e-6, atol=1e-12)
    wd_fd = _fd(lambda s: desired_attitude(s, P, n).omega_di, t, 1.0)
    assert np.allclose(wd_fd, d.omega_di_dot, rtol=1e-4, atol=1e-14)


def test_singular_cases_use_the_fallback():
    prev = rotation_rT(P)
    fr = attitude_frame([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], previous=prev)
    assert fr.status is FrameStatus.COINCIDENT and np.array_equal(fr.R_dr, prev)
    assert np.array_equal(attitude_frame([[0.0, 0.0, 0.0]]).R_dr, np.eye(3))
    for l_vec, ldot in (([3.0, 4.0, 0.0], [0.0, 0.0, 0.0]), ([0.0, 0.0, 2.0], [0.0, 0.0, -1.0])):
        fr = attitude_frame([l_vec, ldot])
        assert fr.status is FrameStatus.STRAIGHT_LINE
        R = fr.R_dr
        assert np.allclose(R @ R.T, np.eye(3)) and math.isclose(np.linalg.det(R), 1.0)
        assert np.allclose(R[0], -np.asarray(l_vec) / np.linalg.norm(l_vec))
        assert not fr.omega_dr.any()
    # regular circular motion in the x_r y_r plane: the fallback and the regular law agree
    reg = attitude_frame([[3.0, 4.0, 0.0], [-4.0, 3.0, 0.0]])
    line = attitude_frame([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]])
    assert reg.status is FrameStatus.REGULAR and np.allclose(reg.R_dr, line.R_dr)


def test_bad_inputs():
    for call in (
        lambda: phi_r(0.0, P, reading="typo"),
        lambda: desired_position(0.0, P, order=-1),
        lambda: initial_angles([0.0, 0.0, 0.0], P),
        lambda: attitude_frame([[1.0, 2.0]]),
        lambda: type(P).from_degrees(**{**_deg(P), "p1": 0.0}),
    ):
        with pytest.raises(InputError) as exc:
            call()
        assert "\n" not in str(exc.value) and str(exc.value).startswith("expected")
