"""The fly-around run is a :class:`SimResult` of one spacecraft with an :class:`OrbitRecord`
(issue 23, item 2), checked against independent truth: the truth MRPs of the loop's state,
the tracking error angle ``4 atan|sigma_sd|`` and the desired attitude of the numpy reference
model, the thruster impulses summed by hand, the divergence time of the diverging variant,
and the stated convergence criterion (``angle_tol``, ``position_tol``) recomputed here.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.errors import InputError
from formsync_design.models.mrp import mrp_from_quat
from formsync_design.models.quaternion import quat_to_matrix
from formsync_design.models.relative_reference import desired_attitude
from formsync_design.sim.orbit_record import GRAPH, OrbitRecord, orbit_of
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.sim.tracking import simulate_flyaround
from formsync_design.sim.tracking_scenario import FlyaroundOptions
from formsync_design.verify.tracking_case import load_flyaround_case

CASE = load_flyaround_case()
SHORT = replace(CASE.options, tf=200.0)


@pytest.fixture(scope="module")
def run() -> SimResult:
    return simulate_flyaround(CASE.scenario, SHORT, CASE.spec)


def _scalar_first(q: np.ndarray) -> np.ndarray:
    return np.array([q[3], q[0], q[1], q[2]])


def test_one_result_type_and_no_flyaround_run_type_left(run: SimResult) -> None:
    assert type(run) is SimResult and isinstance(run.orbit, OrbitRecord)
    assert type(fs.simulate(CASE.scenario, replace(SHORT, tf=2.0))) is SimResult
    assert not hasattr(fs, "FlyaroundRun") and not hasattr(fs, "FlyaroundStatus")
    assert fs.OrbitRecord is OrbitRecord
    k = run.t.size
    assert k == SHORT.samples and run.n == 1 and run.graph == GRAPH
    assert run.design == "zhang2014_flyaround" and run.options is SHORT
    assert run.quaternions.shape == (k, 1, 4) and run.rates.shape == (k, 1, 3)
    assert run.torques.shape == (k, 1, 3) and run.states.shape == (k, 1, 0)
    assert run.reference is not None and run.reference.shape == (k, 4)
    assert run.orbit.states.shape == (k + 1, 12) and np.array_equal(run.orbit.t, run.t)
    with pytest.raises(InputError, match="fly-around run"):
        orbit_of(replace(run, orbit=None))


def test_the_attitude_is_the_truth_state(run: SimResult) -> None:
    x = run.orbit.states
    for k in range(0, run.t.size, 37):
        q = run.quaternions[k, 0]
        assert abs(np.linalg.norm(q) - 1) < 1e-14 and q[3] >= 0
        # the quaternion maps back to the loop's MRP (short set: |sigma| <= 1 after the switch)
        assert np.allclose(mrp_from_quat(_scalar_first(q)), x[k, 6:9], rtol=0, atol=1e-14)
        assert np.array_equal(run.rates[k, 0], x[k, 9:12])
    # the applied torque is the one the PWM pulses realise, averaged over the sample
    assert np.array_equal(run.torques[:, 0], run.orbit.outputs["wrench_pwm"][:, 3:6])
    assert np.allclose(run.peak_torque[0], np.abs(run.orbit.outputs["wrench_pwm"][:, 3:6]).max(0))
    want = sum(float(u @ u) for u in run.orbit.outputs["wrench_pwm"][:, 3:6]) * SHORT.sample_period
    assert run.effort[0] == pytest.approx(want, rel=1e-12)


def test_the_errors_are_those_of_sigma_sd_and_omega_sd(run: SimResult) -> None:
    o = run.orbit.outputs
    assert run.reference_error is not None
    for k in range(0, run.t.size, 23):
        s = o["sigma_sd"][k]
        angle = math.degrees(4 * math.atan(math.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2)))
        assert run.reference_error[k] == pytest.approx(angle, rel=1e-12, abs=1e-13)
        w = o["omega_sd"][k]
        assert run.rate_error[k] == pytest.approx(math.sqrt(w @ w), rel=1e-12, abs=1e-16)
    assert np.all(run.attitude_error == 0.0)  # one spacecraft: no pair


def test_the_reference_is_the_desired_attitude_of_the_numpy_model(run: SimResult) -> None:
    sc = CASE.scenario
    n = sc.mean_motion
    assert run.reference is not None
    assert np.all(run.orbit.outputs["frame_status"][:200] == 0)  # regular frames
    for k in (0, 1, 57, 199):
        t = float(run.t[k])
        d = desired_attitude(t, sc.reference, n, SHORT.reading)
        u = sc.target.argp + sc.target.nu + n * t
        c_ti = np.array([[math.cos(u), math.sin(u), 0.0], [-math.sin(u), math.cos(u), 0.0],
                         [0.0, 0.0, 1.0]])
        r_desired = (d.R_dT @ c_ti).T  # desired to inertial
        got = quat_to_matrix(_scalar_first(run.reference[k]))
        assert np.allclose(got, r_desired, rtol=0, atol=1e-9), k
        # the angle between the truth and the desired attitude: the tracking error
        r_body = quat_to_matrix(_scalar_first(run.quaternions[k, 0]))
        c = (np.trace(r_desired.T @ r_body) - 1) / 2
        angle = math.degrees(math.acos(min(1.0, c)))
        assert run.reference_error[k] == pytest.approx(angle, abs=1e-5)


def test_fuel_and_velocity_increments_from_the_pulses_by_hand(run: SimResult) -> None:
    lay = CASE.scenario.layout
    on = run.orbit.outputs["on_time"]
    impulse = 0.0
    for k in range(run.t.size):
        for i in range(lay.count):
            impulse += lay.thrust * float(on[k, i])
    assert impulse > 0 and np.all(on[:, lay.count:] == 0)
    assert run.orbit.fuel == pytest.approx(impulse / SHORT.exhaust_velocity, rel=1e-12)
    assert run.orbit.delta_v == pytest.approx(impulse / CASE.scenario.mass, rel=1e-12)
    assert run.orbit.delta_v_net <= run.orbit.delta_v
    d = run.to_dict()
    assert d["orbit"] == {"samples": run.t.size, "fuel_kg": run.orbit.fuel,
                          "delta_v_m_s": run.orbit.delta_v,
                          "delta_v_net_m_s": run.orbit.delta_v_net,
                          "allocation": "pinv-shift", "lp_fallbacks": 0}


def test_every_run_keeps_one_schema(run: SimResult) -> None:
    other = replace(run, orbit=None)  # the fields of a run without an orbit record
    assert list(run.to_dict()) == list(other.to_dict()) and other.to_dict()["orbit"] is None
    md = run._repr_markdown_()
    assert md.startswith("**Fly-around simulation**") and "| fuel |" in md
    frame = run.to_pandas()
    assert list(frame.columns) == ["t", "reference_error_deg", "rate_error", "position_error_m",
                                   "u1_1", "u2_1", "u3_1"]
    assert np.array_equal(frame["position_error_m"], np.linalg.norm(
        run.orbit.outputs["dX"][:, :3], axis=1))


def test_a_diverged_run_is_the_status_diverged_with_its_time() -> None:
    tiny = replace(CASE.scenario, inertia=1e-3 * np.eye(3), law_inertia=CASE.scenario.inertia)
    r = simulate_flyaround(tiny, SHORT, CASE.spec)
    assert r.status == SimStatus.DIVERGED and r.stopped_early and r.convergence_time is None
    # the first non-finite state is the one after the last kept sample's end state
    assert math.isclose(r.diverged_time, (r.t.size + 1) * SHORT.sample_period)
    assert np.isfinite(r.quaternions).all() and np.isfinite(r.orbit.states).all()
    assert r.message.startswith(f"diverged at t = {r.diverged_time:g} s")
    assert r.to_dict()["diverged_time"] == r.diverged_time
    # the trajectory ends at the last finite state: one sample after the last output time
    last = (r.orbit.states.shape[0] - 1) * SHORT.sample_period
    assert r.stop_time == r.to_dict()["tf"] == last < r.diverged_time


def test_a_completed_run_ends_at_the_horizon(run: SimResult) -> None:
    """The outputs are at the control instants (the last one tf - dt); the run's end, in
    stop_time and the summary's tf, is the horizon, where its last state is."""
    assert math.isclose(run.t[-1], SHORT.tf - SHORT.sample_period)
    assert run.stop_time == run.to_dict()["tf"] == SHORT.tf


def test_converged_and_not_converged_follow_the_stated_tolerances(run: SimResult) -> None:
    # recompute the criterion: the last sample that violates it, then the next one
    o = run.orbit.outputs
    ang = np.degrees(4 * np.arctan(np.linalg.norm(o["sigma_sd"], axis=1)))
    pos = np.linalg.norm(o["dX"][:, :3], axis=1)
    bad = np.flatnonzero((ang > SHORT.angle_tol) | (pos > SHORT.position_tol))
    assert run.status == SimStatus.CONVERGED and run.converged
    assert run.convergence_time == run.t[bad[-1] + 1] and run.convergence_time > 0
    # 1 s: the initial attitude error (1.7 deg) is still above angle_tol = 1 deg, the
    # position error (0.4 to 0.6 m) within position_tol = 1 m
    assert ang[:5].min() > 1.0 and ang[:5].max() < 2.0
    assert pos[:5].min() > 0.1 and pos[:5].max() < 1.0
    one = replace(SHORT, tf=1.0)
    short = simulate_flyaround(CASE.scenario, one, CASE.spec)
    assert short.status == SimStatus.NOT_CONVERGED and short.convergence_time is None
    assert "without converging" in short.message
    # the same second with angle_tol = 2 deg: within both tolerances from the start
    loose = simulate_flyaround(CASE.scenario, replace(one, angle_tol=2.0), CASE.spec)
    assert loose.status == SimStatus.CONVERGED and loose.convergence_time == 0.0
    # and a position tolerance below the position error: not converged again
    tight = simulate_flyaround(CASE.scenario, replace(one, angle_tol=2.0, position_tol=0.1),
                               CASE.spec)
    assert tight.status == SimStatus.NOT_CONVERGED


def test_the_tolerances_are_checked() -> None:
    for bad in ({"angle_tol": 0.0}, {"position_tol": -1.0}, {"angle_tol": math.nan}):
        with pytest.raises(InputError, match="expected"):
            FlyaroundOptions(**bad)
