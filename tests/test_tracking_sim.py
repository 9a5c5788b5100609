"""The compiled fly-around simulation and its parts against independent truth (issue 14).

* the compiled closed loop against the numpy/scipy oracle (``tests/tracking_numpy.py``:
  Taylor-mode reference, numpy law, exact pulse segments with DOP853);
* the CasADi reference and desired frame against :mod:`formsync_design.models.relative_reference`,
  the singular-case fallback included; the DCM -> MRP branches against Shepperd's numpy;
* the LQR gain against scipy's Riccati solver and a Hamiltonian eigenvector solution;
* the allocations reproduce the commanded wrench or report the shortfall; the LP's fuel
  equals HiGHS's (the existing LP) and cvxpy + Clarabel's;
* PWM: the delivered impulse equals the commanded one within one minimum pulse (per
  sample; with the carry, cumulatively within half a minimum pulse); the compiled PWM is
  ``thrusters.pwm``;
* MRP shadow switching of the compiled propagation against the analytic spin.
"""

from __future__ import annotations

import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
import scipy.linalg

from formsync_design.models.allocation import BoundedLP, MinFuelAllocator
from formsync_design.models.mrp import mrp_from_matrix, mrp_to_matrix
from formsync_design.models.orbit import cw_matrices
from formsync_design.models.pwm import pwm
from formsync_design.models.relative_reference import attitude_frame, desired_attitude
from formsync_design.models.thrusters import (
    AllocationStatus,
    cube_pairs_layout,
    lp_allocation,
    pinv_allocation,
    positive_null_vector,
)
from formsync_design.sim import tracking as F
from formsync_design.sim.tracking_model import N_THRUSTERS_MAX, dcm_to_mrp_ca
from formsync_design.verify.tracking_case import load_flyaround_case
from tests.tracking_numpy import simulate_numpy

CASE = load_flyaround_case()
LAYOUT = cube_pairs_layout()
ALLOCATOR = MinFuelAllocator(LAYOUT)


def _kernel_and_params(case=CASE, opt=None):
    opt = opt or case.options
    k = F._kernel(case.spec, replace(opt, compile=False))
    lqr = F.lqr_for(case.spec, case.scenario)[0]
    return k, F._params(case.spec, case.scenario, opt, lqr)


def test_compiled_simulation_matches_the_numpy_oracle():
    opt = replace(CASE.options, tf=20.0)
    states, taus, errs = simulate_numpy(CASE.scenario, opt, CASE.spec, opt.samples)
    run = F.simulate_flyaround(CASE.scenario, opt, CASE.spec)
    d = np.abs(states - run.orbit.states).max(axis=0)
    assert d[:3].max() < 1e-7 and d[3:6].max() < 1e-9 and d[6:].max() < 1e-10, d
    assert np.abs(taus - run.orbit.outputs["on_time"][:, :16]).max() < 1e-8
    assert np.abs(errs[:, :6] - run.orbit.outputs["dX"]).max() < 1e-7
    assert np.abs(errs[:, 6:9] - run.orbit.outputs["sigma_sd"]).max() < 1e-10


@pytest.mark.slow
def test_compiled_simulation_matches_the_numpy_oracle_through_partial_pulses():
    opt = replace(CASE.options, tf=120.0)  # the transient and thousands of partial pulses
    states, taus, _ = simulate_numpy(CASE.scenario, opt, CASE.spec, opt.samples)
    run = F.simulate_flyaround(CASE.scenario, opt, CASE.spec)
    assert ((taus > 0) & (taus < opt.sample_period)).sum() > 1000
    d = np.abs(states - run.orbit.states).max(axis=0)
    assert d[:3].max() < 1e-6 and d[6:].max() < 1e-8, d
    assert np.abs(taus - run.orbit.outputs["on_time"][:, :16]).max() < 1e-7


@pytest.mark.parametrize("t", [0.0, 13.0, 950.0, 4321.0, 17000.0])
def test_casadi_reference_matches_the_numpy_reference(t):
    k, p = _kernel_and_params()
    x0, rdr = F.initial_state(CASE.scenario)
    c = np.concatenate([np.zeros(N_THRUSTERS_MAX), rdr.reshape(3, 3).T.ravel()])
    l_t, l_dot, r_dt, w, wd, status, _, _ = (np.asarray(v) for v in k.fns["ref"](t, x0, c, p))
    d = desired_attitude(t, CASE.scenario.reference, CASE.scenario.mean_motion)
    assert float(status.item()) == 0
    assert np.allclose(r_dt, d.R_dT, atol=1e-12)
    assert np.allclose(w.ravel(), d.omega_di, rtol=1e-9, atol=1e-15)
    assert np.allclose(wd.ravel(), d.omega_di_dot, rtol=1e-7, atol=1e-16)


def test_casadi_fallback_frame_matches_the_numpy_fallback():
    # phi0 = 90 deg: at t = 0 the reference is at rest (theta' = phi' = 0): no plane of motion
    ref = replace(CASE.scenario.reference, phi0=math.pi / 2)
    sc = replace(CASE.scenario, reference=ref)
    case = replace(CASE, scenario=sc)
    k, p = _kernel_and_params(case)
    x0, rdr = F.initial_state(sc)
    c = np.concatenate([np.zeros(N_THRUSTERS_MAX), rdr.reshape(3, 3).T.ravel()])
    out = [np.asarray(v) for v in k.fns["ref"](0.0, x0, c, p)]
    d = desired_attitude(0.0, ref, sc.mean_motion)
    assert str(d.status) == "straight-line" and float(out[5].item()) == 1.0
    assert np.allclose(out[2], d.R_dT, atol=1e-12)
    wt = d.R_dT @ np.array([0, 0, sc.mean_motion])  # the held frame turns with T only
    assert np.allclose(out[3].ravel(), wt, atol=1e-15)
    fr = attitude_frame([[1.0, 0, 0], [2.0, 0, 0]])
    assert str(fr.status) == "straight-line"


def test_dcm_to_mrp_matches_shepperd_on_every_branch():
    r = ca.SX.sym("r", 3, 3)
    f = ca.Function("f", [r], [dcm_to_mrp_ca(r)])
    rng = np.random.default_rng(0)
    angles = [0.0, 0.3, 2.0, math.pi - 1e-3, math.pi]
    for ang in angles:
        for axis in (np.eye(3)[0], np.eye(3)[1], np.eye(3)[2], rng.normal(size=3)):
            a = axis / np.linalg.norm(axis)
            s = math.tan(ang / 4) * a
            m = mrp_to_matrix(s)
            got = np.asarray(f(m)).ravel()
            assert np.allclose(mrp_to_matrix(got), m, atol=1e-12)
            assert np.linalg.norm(got) <= 1 + 1e-12
            assert np.allclose(got, mrp_from_matrix(m), atol=1e-9) or ang >= math.pi - 1e-3


def test_lqr_gain_against_scipy_riccati_and_the_hamiltonian():
    design, q, r = F.lqr_for(CASE.spec, CASE.scenario)
    a, b = cw_matrices(CASE.scenario.mean_motion)
    p = scipy.linalg.solve_continuous_are(a, b, q, r)
    assert np.allclose(design.K, np.linalg.solve(r, b.T @ p), rtol=1e-10, atol=1e-14)
    # independent: the stable invariant subspace of the Hamiltonian matrix
    h = np.block([[a, -b @ np.linalg.solve(r, b.T)], [-q, -a.T]])
    w, v = np.linalg.eig(h)
    vs = v[:, w.real < 0]
    ph = np.real(vs[6:] @ np.linalg.inv(vs[:6]))
    assert np.allclose(design.K, np.linalg.solve(r, b.T @ ph), rtol=1e-6)
    assert np.allclose(q, np.diag([1, 1, 1, 400, 400, 400])) and np.allclose(r, 6400 * np.eye(3))
    assert design.max_real_part < 0


@pytest.mark.parametrize("seed", range(3))
def test_allocations_reproduce_the_wrench_or_report_the_shortfall(seed):
    rng = np.random.default_rng(seed)
    al = ALLOCATOR
    a = LAYOUT.matrix
    z = positive_null_vector(LAYOUT)
    for _ in range(15):
        w = rng.normal(size=6) * np.array([8, 8, 8, 5, 5, 5])
        lp = al.allocate(w)
        assert lp.certified and lp.shortfall < 1e-9 and lp.thrusts.min() >= 0
        assert np.allclose(a @ lp.thrusts, w, atol=1e-9)
        ref = lp_allocation(LAYOUT, w)  # HiGHS, the existing LP
        assert abs(ref.total_thrust - lp.fuel_thrust) <= 1e-7 * max(1.0, ref.total_thrust)
        sh = pinv_allocation(LAYOUT, w, "shift", null_vector=z)
        assert sh.status == AllocationStatus.EXACT and sh.total_thrust >= lp.fuel_thrust - 1e-9
        cl = pinv_allocation(LAYOUT, w, "clip")
        assert cl.status == AllocationStatus.SHORTFALL  # the pseudo-inverse needs negatives
        assert np.allclose(cl.achieved + cl.shortfall, w)
    big = np.array([150.0, 0, 0, 0, 0, 40.0])  # beyond four 25 N thrusters
    lpb = al.allocate(big)
    assert lpb.method == "cvxpy" and lpb.thrusts.max() <= LAYOUT.thrust + 1e-9
    ref = lp_allocation(LAYOUT, big)
    assert ref.status == AllocationStatus.SHORTFALL
    assert abs(lpb.shortfall - float(np.abs(big - a @ lpb.thrusts).max())) < 1e-9
    # the same (L1-least) shortfall as HiGHS; the least fuel among all such allocations
    assert abs(np.abs(ref.shortfall).sum() - np.abs(big - a @ lpb.thrusts).sum()) < 1e-4
    assert BoundedLP(LAYOUT).solve(big).fuel_thrust <= ref.total_thrust + 1e-4


def test_pwm_impulse_within_one_minimum_pulse_and_the_compiled_pwm():
    rng = np.random.default_rng(7)
    k, p = _kernel_and_params()
    prop = k.fns["prop"]
    x0, rdr = F.initial_state(CASE.scenario)
    c = np.concatenate([np.zeros(N_THRUSTERS_MAX), rdr.reshape(3, 3).T.ravel()])
    dt, thrust, tmin = 0.2, 25.0, 0.03
    for _ in range(30):
        f = rng.uniform(0, 30, 16) * (rng.random(16) < 0.6)
        ref = pwm(np.minimum(f, thrust), dt, thrust, tmin)
        tau = np.asarray(prop(x0, c, 0.0, p, f, rdr.reshape(3, 3).T.ravel())[2]).ravel()
        assert np.allclose(tau, ref.on_times, atol=1e-15)
        err = np.abs(thrust * tau - np.minimum(f, thrust) * dt)
        assert err.max() <= thrust * tmin + 1e-12  # the "done when" bound
        assert err.max() <= thrust * tmin / 2 + 1e-12  # rounding to the nearer: half of it
    # with the carry the cumulative impulse error stays within half a minimum pulse
    carry = np.zeros(16)
    total_dem, total_del = np.zeros(16), np.zeros(16)
    for _ in range(400):
        f = rng.uniform(0, 2.0, 16)
        r = pwm(f, dt, thrust, tmin, carry)
        carry = r.carry
        total_dem += f * dt
        total_del += r.impulses
    assert np.abs(total_dem - total_del).max() <= thrust * tmin / 2 + 1e-9


def test_compiled_propagation_switches_to_the_shadow_set_like_the_analytic_spin():
    k, p = _kernel_and_params()
    prop = k.fns["prop"]
    spin = 0.5  # rad/s about the principal z axis: R(t) = R_z(spin t)
    x = np.zeros(12)
    x[:3] = [1.0, 2.0, 3.0]
    x[11] = spin
    _, rdr = F.initial_state(CASE.scenario)
    c = np.concatenate([np.zeros(N_THRUSTERS_MAX), rdr.reshape(3, 3).T.ravel()])
    switches = 0
    for step in range(1, 80):  # 16 s: 8 rad, more than one turn
        xn, _, _, _, sw = prop(x, c, 0.0, p, np.zeros(16), c[16:])
        x = np.asarray(xn).ravel()
        switches += int(float(np.asarray(sw).item()))
        th = spin * 0.2 * step
        rz = np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0],
                       [0, 0, 1]])
        assert np.linalg.norm(x[6:9]) <= 1 + 1e-12
        assert np.allclose(mrp_to_matrix(x[6:9]), rz, atol=1e-9), step
    assert switches == 1


def test_lp_run_matches_the_explicit_allocation_and_fuel_bookkeeping():
    opt = replace(CASE.options, tf=6.0, allocation="lp", compile=False)  # the VM: no build
    run = F.simulate_flyaround(CASE.scenario, opt, CASE.spec)
    m = LAYOUT.count
    f = run.orbit.outputs["thrust_cmd"][:, :m]
    assert np.all(f >= 0) and np.all(f <= LAYOUT.thrust + 1e-9)
    assert math.isclose(run.orbit.fuel, run.orbit.total_impulse / 2900.0)
    assert math.isclose(run.orbit.delta_v, run.orbit.total_impulse / 2000.0)
    base = F.simulate_flyaround(CASE.scenario, replace(opt, allocation="pinv-shift"), CASE.spec)
    assert run.orbit.fuel < base.orbit.fuel  # the LP never spends more than the pseudo-inverse
