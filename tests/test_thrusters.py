"""Tests of formsync_design.models.thrusters against independent truth.

* positive spanning: each exact combination re-verified here with numpy; the
  separating vector of a non-spanning layout re-verified;
* allocation reproduces the commanded wrench within the thrust limits or reports the
  shortfall, and the LP's fuel and shortfall agree with a second solver (cvxpy + Clarabel);
* LP fuel <= pseudo-inverse (+ null-space shift) fuel on seeded random commands;
* PWM: impulse equals the commanded impulse within one minimum pulse; with carry the
  long-run impulse matches;
* fuel: Tsiolkovsky against a numerical integration of the mass flow.
"""

from __future__ import annotations

import math

import cvxpy as cp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from formsync_design.errors import InputError
from formsync_design.models.pwm import fuel_mass, pwm, rocket_fuel
from formsync_design.models.thrusters import (
    MIN_PULSE_S,
    SAMPLE_PERIOD_S,
    THRUST_N,
    AllocationStatus,
    SpanStatus,
    ThrusterLayout,
    check_positive_spanning,
    cube_pairs_layout,
    lp_allocation,
    pinv_allocation,
    positive_null_vector,
)

LAYOUT = cube_pairs_layout()
A = LAYOUT.matrix


def _random_wrenches(seed: int, count: int, scale: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, size=(count, 6)) * scale


def test_layout_positively_spans_with_exact_evidence():
    res = check_positive_spanning(LAYOUT)
    assert res.status is SpanStatus.SPANNING
    assert res.rank == 6 == np.linalg.matrix_rank(A)
    assert len(res.combinations) == 12
    for j, combo in enumerate(res.combinations):
        k, sign = divmod(j, 2)
        f = np.zeros(LAYOUT.count)
        for i, v in combo.items():
            assert v >= 0
            f[i] = float(v)
        target = np.zeros(6)
        target[k] = 1.0 if sign == 0 else -1.0
        assert np.allclose(A @ f, target, atol=1e-15)
    z = positive_null_vector(LAYOUT)
    assert z.min() > 0 and np.abs(A @ z).max() < 1e-12


def test_non_spanning_layout_is_refuted_with_a_separating_vector():
    keep = [0, 1, 4, 5, 8, 9, 12, 13, 2, 3]  # +x, +y, +z pushers and two -x: no -y force
    sub = ThrusterLayout(LAYOUT.positions[keep], LAYOUT.directions[keep])
    res = check_positive_spanning(sub)
    assert res.status is SpanStatus.NOT_SPANNING
    y = np.array([float(v) for v in res.separating])
    assert (y @ sub.matrix >= -1e-15).all()  # every thruster has y^T a_i >= 0 ...
    k = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz").index(res.failed_target[1:])
    target = np.zeros(6)
    target[k] = 1.0 if res.failed_target[0] == "+" else -1.0
    assert y @ target < 0  # ... but the failed target has y^T b < 0: unreachable
    with pytest.raises(InputError):
        positive_null_vector(sub)


def _cvxpy_min_fuel(w):
    f = cp.Variable(LAYOUT.count)
    s = cp.Variable(6)
    stage1 = cp.Problem(cp.Minimize(cp.norm1(s)), [A @ f + s == w, f >= 0, f <= THRUST_N])
    stage1.solve(solver=cp.CLARABEL)
    return float(stage1.value), f.value


@pytest.mark.parametrize("seed", [3, 17])
def test_allocation_reproduces_feasible_commands_and_lp_beats_pinv(seed):
    # forces up to 20 N, torques up to 20 N m: inside the capacity of this layout
    for w in _random_wrenches(seed, 25, 20.0):
        lp = lp_allocation(LAYOUT, w)
        assert lp.status is AllocationStatus.EXACT
        assert lp.thrusts.min() >= 0 and lp.thrusts.max() <= THRUST_N
        assert np.allclose(A @ lp.thrusts, w, atol=1e-7)
        shift = pinv_allocation(LAYOUT, w, "shift")
        assert shift.status is AllocationStatus.EXACT  # within bounds after the shift
        assert np.allclose(A @ shift.thrusts, w, atol=1e-7)
        assert shift.thrusts.min() >= 0 and shift.thrusts.max() <= THRUST_N
        assert lp.total_thrust <= shift.total_thrust + 1e-7
        raw = pinv_allocation(LAYOUT, w, "none")
        assert abs(raw.thrusts.sum()) < 1e-9  # 1^T A^+ = 0 for opposed twins
        assert raw.raw_min < 0
        # second implementation of the minimum fuel: cvxpy + Clarabel
        f = cp.Variable(LAYOUT.count)
        prob = cp.Problem(cp.Minimize(cp.sum(f)), [A @ f == w, f >= 0, f <= THRUST_N])
        prob.solve(solver=cp.CLARABEL)
        assert prob.status == cp.OPTIMAL
        assert math.isclose(lp.total_thrust, prob.value, rel_tol=1e-6, abs_tol=1e-6)


def test_clipping_loses_part_of_the_wrench():
    w = np.array([10.0, -3.0, 2.0, 1.0, -4.0, 5.0])
    clip = pinv_allocation(LAYOUT, w, "clip")
    assert clip.status is AllocationStatus.SHORTFALL
    assert np.allclose(clip.achieved + clip.shortfall, w)
    assert np.allclose(A @ clip.thrusts, clip.achieved)
    shift = pinv_allocation(LAYOUT, w, "shift")
    assert shift.status is AllocationStatus.EXACT
    cached = pinv_allocation(LAYOUT, w, "shift", null_vector=positive_null_vector(LAYOUT))
    assert np.allclose(cached.thrusts, shift.thrusts)
    with pytest.raises(InputError):
        pinv_allocation(LAYOUT, w, "shift", null_vector=np.ones(3))


@pytest.mark.parametrize("seed", [5])
def test_out_of_range_commands_report_the_minimal_shortfall(seed):
    for w in _random_wrenches(seed, 10, 200.0):
        lp = lp_allocation(LAYOUT, w)
        assert lp.thrusts.min() >= 0 and lp.thrusts.max() <= THRUST_N
        assert np.allclose(lp.achieved + lp.shortfall, w)
        best, _ = _cvxpy_min_fuel(w)
        assert math.isclose(np.abs(lp.shortfall).sum(), best, rel_tol=1e-6, abs_tol=1e-6)
        if best > 1e-6:
            assert lp.status is AllocationStatus.SHORTFALL
        sh = pinv_allocation(LAYOUT, w, "shift")
        assert sh.thrusts.max() <= THRUST_N and sh.thrusts.min() >= 0
        assert np.abs(sh.shortfall).sum() >= best - 1e-6


def test_pwm_impulse_within_one_minimum_pulse():
    rng = np.random.default_rng(11)
    dt, pulse = SAMPLE_PERIOD_S, THRUST_N * MIN_PULSE_S
    for w in _random_wrenches(23, 30, 15.0):
        alloc = lp_allocation(LAYOUT, w)
        res = pwm(alloc.thrusts, dt)
        demand = alloc.thrusts * dt
        assert (np.abs(res.impulses - demand) <= pulse / 2 + 1e-12).all()
        on = res.on_times
        assert ((on == 0) | ((on >= MIN_PULSE_S - 1e-15) & (on <= dt + 1e-15))).all()
        assert np.allclose(res.start_times + on / 2, dt / 2)
        # wrench impulse: within one minimum pulse of each thruster's column
        err = A @ res.impulses - w * dt
        bound = np.abs(A).sum(axis=1) * pulse
        assert (np.abs(err) <= bound + 1e-12).all()
    # small thrusts: with carry the long-run impulse matches the demand
    f = rng.uniform(0.0, 3.0, size=16)
    carry, total = None, np.zeros(16)
    steps = 500
    for _ in range(steps):
        r = pwm(f, dt, carry=carry)
        carry, total = r.carry, total + r.impulses
    assert (np.abs(total - f * dt * steps) <= pulse / 2 + 1e-9).all()


def test_pwm_saturates_and_flags():
    r = pwm([40.0, 10.0])
    assert r.saturated.tolist() == [True, False]
    assert r.on_times[0] == SAMPLE_PERIOD_S
    assert math.isclose(r.carry[0], (40.0 - THRUST_N) * SAMPLE_PERIOD_S)


def test_fuel_against_integrated_mass_flow():
    m0, ve, thrust = 2000.0, 2900.0, 50.0

    def rhs(t, y):  # y = (velocity, mass)
        return [thrust / y[1], -thrust / ve]

    t_end = 600.0
    sol = solve_ivp(rhs, (0, t_end), [0.0, m0], method="DOP853", rtol=1e-12, atol=1e-12)
    dv, used = sol.y[0, -1], m0 - sol.y[1, -1]
    assert math.isclose(rocket_fuel(dv, m0, ve), used, rel_tol=1e-9)
    assert math.isclose(fuel_mass(thrust * t_end, ve), used, rel_tol=1e-12)


def test_bad_inputs():
    for call in (
        lambda: ThrusterLayout(np.zeros((2, 3)), np.ones((2, 3))),
        lambda: lp_allocation(LAYOUT, [1.0, 2.0]),
        lambda: pinv_allocation(LAYOUT, np.zeros(6), "round"),
        lambda: pwm([1.0], dt=0.01, min_pulse=0.03),
        lambda: rocket_fuel(1.0, -5.0),
    ):
        with pytest.raises(InputError) as exc:
            call()
        assert "\n" not in str(exc.value) and str(exc.value).startswith("expected")
