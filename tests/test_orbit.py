"""Tests of formsync_design.models.orbit against independent truth.

* the nonlinear relative dynamics against a two-body propagation of both
  spacecraft in ECI (scipy DOP853, tight tolerances), paper's initial conditions;
* CW against the nonlinear model: the error scales with the square of the separation;
* the CW closed form against numerical integration and the matrix exponential;
* the LQR gain against an independent Riccati solution (Hamiltonian eigenvectors);
* the margin check can fail (a non-LQR gain is flagged).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp
from scipy.signal import place_poles

from formsync_design.errors import InputError
from formsync_design.models.orbit import (
    MU_EARTH,
    ZHANG2014_CHASER,
    ZHANG2014_TARGET,
    KeplerElements,
    LQRDesign,
    MarginStatus,
    cw_matrices,
    cw_transition,
    elements_to_state,
    lqr_design,
    lqr_margins,
    lvlh_matrix,
    mean_motion,
    relative_nonlinear_rhs,
    relative_state,
    two_body_rhs,
)

TIGHT = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-9}


def _paper_states():
    rt, vt = elements_to_state(ZHANG2014_TARGET)
    rc, vc = elements_to_state(ZHANG2014_CHASER)
    return np.concatenate([rt, vt]), np.concatenate([rc, vc])


def test_elements_to_state_energy_and_momentum():
    el = KeplerElements.from_degrees(a=8.0e6, e=0.3, i=40.0, u=123.0, raan=20.0, argp=75.0)
    r, v = elements_to_state(el)
    # vis-viva and |h| = sqrt(mu p), both independent of the rotation used
    assert math.isclose(
        v @ v / 2 - MU_EARTH / np.linalg.norm(r), -MU_EARTH / (2 * el.a), rel_tol=1e-12
    )
    h = np.cross(r, v)
    assert math.isclose(
        np.linalg.norm(h), math.sqrt(MU_EARTH * el.a * (1 - el.e**2)), rel_tol=1e-12
    )
    assert math.isclose(math.acos(h[2] / np.linalg.norm(h)), el.i, rel_tol=1e-12)


def test_paper_initial_separation_is_the_500m_sphere():
    X0 = relative_state(*(np.split(s, 2) for s in _paper_states()))
    assert abs(np.linalg.norm(X0[:3]) - 500.0) < 1.0
    # the chaser's orbit is 2 m lower: radial offset -2 m (to rounding of the elements)
    assert abs(X0[0] + 2.0) < 0.01


@pytest.mark.parametrize("u", [np.zeros(3), np.array([2e-4, -1e-4, 3e-4])])
def test_relative_dynamics_match_two_body_propagation(u):
    """Relative truth model == difference of two ECI two-body propagations (paper's case)."""
    yt0, yc0 = _paper_states()
    r0 = ZHANG2014_TARGET.a
    t_end = 6 * 3600.0 if not u.any() else 3600.0
    ts = np.linspace(0.0, t_end, 13)

    def chaser_rhs(t, y, yt_sol):
        # the same specific force, fixed in the target's LVLH frame, applied in ECI
        yt = yt_sol(t)
        c = lvlh_matrix(yt[:3], yt[3:])
        acc = two_body_rhs(t, y)
        acc[3:] += c.T @ u
        return acc

    tgt = solve_ivp(two_body_rhs, (0, t_end), yt0, dense_output=True, **TIGHT)
    chs = solve_ivp(chaser_rhs, (0, t_end), yc0, t_eval=ts, args=(tgt.sol,), **TIGHT)
    X0 = relative_state(np.split(yt0, 2), np.split(yc0, 2))
    rel = solve_ivp(relative_nonlinear_rhs, (0, t_end), X0, t_eval=ts, args=(r0, u), **TIGHT)
    assert tgt.success and chs.success and rel.success
    for k, t in enumerate(ts):
        yt = tgt.sol(t)
        X_eci = relative_state(np.split(yt, 2), np.split(chs.y[:, k], 2))
        assert np.abs(X_eci[:3] - rel.y[:3, k]).max() < 1e-4, t
        assert np.abs(X_eci[3:] - rel.y[3:, k]).max() < 1e-8, t
    # the motion is not trivial: the separation changed by more than a metre
    assert np.abs(rel.y[:3, -1] - X0[:3]).max() > 1.0


def test_cw_error_scales_quadratically_with_separation():
    r0 = ZHANG2014_TARGET.a
    n = mean_motion(r0)
    t_end = 3 * 3600.0
    direction = np.array([0.3, -1.0, 0.4, 1e-4, 0.0, -2e-4])
    errors = []
    for scale in (100.0, 1000.0, 10000.0):
        X0 = direction * scale
        nl = solve_ivp(relative_nonlinear_rhs, (0, t_end), X0, args=(r0,), **TIGHT).y[:, -1]
        lin = cw_transition(n, t_end) @ X0
        errors.append(np.linalg.norm(nl[:3] - lin[:3]))
    ratios = [errors[1] / errors[0], errors[2] / errors[1]]
    assert all(70 < r < 130 for r in ratios), ratios  # quadratic: x10 separation -> x100 error
    assert errors[0] < 1e-3  # 100 m: CW is good to a millimetre over 3 h at GEO


def test_cw_closed_form_matches_integration_and_expm():
    n = mean_motion(7.0e6)
    A, _ = cw_matrices(n)
    X0 = np.array([10.0, -20.0, 5.0, 0.01, -0.02, 0.03])
    for t in (0.0, 100.0, 2345.0, 9000.0):
        sol = solve_ivp(lambda _t, x: A @ x, (0, t), X0, **TIGHT).y[:, -1] if t else X0
        phi = cw_transition(n, t)
        assert np.allclose(phi @ X0, sol, rtol=0, atol=1e-6)
        assert np.allclose(phi, scipy.linalg.expm(A * t), rtol=1e-9, atol=1e-9)
    assert np.allclose(
        cw_transition(n, 1000.0) @ cw_transition(n, 700.0), cw_transition(n, 1700.0), atol=1e-9
    )


def _care_hamiltonian(A, B, Q, R):
    """Independent Riccati solution: the stable invariant subspace of the Hamiltonian."""
    n = A.shape[0]
    H = np.block([[A, -B @ np.linalg.solve(R, B.T)], [-Q, -A.T]])
    w, v = np.linalg.eig(H)
    stable = v[:, w.real < 0]
    assert stable.shape[1] == n
    return np.real(stable[n:] @ np.linalg.inv(stable[:n]))


@pytest.mark.parametrize(
    "q,r",
    [
        (np.eye(6), np.eye(3)),
        (np.diag([1.0, 1.0, 1.0, 1e3, 1e3, 1e3]), 1e5 * np.eye(3)),
        (np.diag([1e-2, 4.0, 1.0, 10.0, 1.0, 1e2]), np.diag([1e3, 1e4, 1e5])),
    ],
)
def test_lqr_against_independent_riccati_and_hurwitz(q, r):
    A, B = cw_matrices(mean_motion(ZHANG2014_TARGET.a))
    d = lqr_design(A, B, q, r)
    P_ind = _care_hamiltonian(A, B, q, r)
    assert np.allclose(d.P, P_ind, rtol=1e-6, atol=1e-9 * np.abs(P_ind).max())
    res = A.T @ d.P + d.P @ A - d.P @ B @ np.linalg.solve(r, B.T) @ d.P + q
    assert np.abs(res).max() <= 1e-8 * max(1.0, np.abs(q).max())
    assert np.allclose(d.K, np.linalg.solve(r, B.T @ d.P))
    assert np.linalg.eigvalsh((d.P + d.P.T) / 2).min() > 0
    assert np.linalg.eigvals(A - B @ d.K).real.max() < 0
    m = lqr_margins(A, B, d, r)
    assert m.status is MarginStatus.HOLD
    assert m.gain_margin_low <= 0.5 and m.phase_margin_deg >= 60.0
    # the closed loop with the gain halved is stable (computed here, independently)
    assert np.linalg.eigvals(A - 0.5 * B @ d.K).real.max() < 0


def test_margin_check_flags_a_non_lqr_gain():
    A, B = cw_matrices(mean_motion(7.0e6))
    poles = [-0.02, -0.021, -0.022, -0.03, -0.031, -0.032]
    K = place_poles(A, B, poles).gain_matrix
    K[:, 3:] *= 0.05  # badly damped: stable but with a small gain-reduction margin
    eig = np.linalg.eigvals(A - B @ K)
    if eig.real.max() >= 0:  # keep the premise honest: the modified loop must be stable
        pytest.skip("modified gain not stabilizing")
    fake = LQRDesign(K, np.eye(6), 0.0, eig)
    m = lqr_margins(A, B, fake, np.eye(3))
    assert m.status is MarginStatus.VIOLATED
    assert m.min_return_difference < 1.0


def test_bad_inputs_raise_one_line_input_errors():
    for call in (
        lambda: KeplerElements(a=-1.0, e=0.0, i=0.0),
        lambda: KeplerElements(a=7e6, e=1.2, i=0.0),
        lambda: cw_matrices(0.0),
        lambda: lqr_design(np.eye(2), np.ones((3, 1)), np.eye(2), np.eye(1)),
        lambda: lqr_design(np.eye(2), np.ones((2, 1)), -np.eye(2), np.eye(1)),
    ):
        with pytest.raises(InputError) as exc:
            call()
        assert "\n" not in str(exc.value) and str(exc.value).startswith("expected")
