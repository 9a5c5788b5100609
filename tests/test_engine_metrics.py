"""The metric registry of the verification engine against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.errors import InputError
from formsync_design.graphs import load_graph
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Gains
from formsync_design.spec.agent import agent_design_from_functions
from formsync_design.verify.metrics import (
    METRICS,
    MetricArg,
    MetricContext,
    MetricValue,
    check_metric_args,
    register_metric,
)
from formsync_design.verify.predicates import Interval


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


class _Case:
    def __init__(self, design, tf):
        self.design = design
        self.options = AgentOptions(tf=tf)


class _Results:
    def __init__(self, run):
        self._run = run

    def run(self, formation, scenario, draw=None):
        return self._run

    def certificate(self, formation, scenario):
        return "no certificate in this test"

    def montecarlo(self, formation, scenario):
        raise AssertionError("not used")


def _axis_angle(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    h = math.radians(deg) / 2
    return [*(math.sin(h) * a), math.cos(h)]


def _qmul(p, q):
    """Hamilton product of (x, y, z, w) quaternions."""
    pv, pw, qv, qw = np.asarray(p[:3]), p[3], np.asarray(q[:3]), q[3]
    return np.array([*(pw * qv + qw * pv + np.cross(pv, qv)), pw * qw - pv @ qv])


def _angle_deg(qa, qb):
    """Principal angle of q_a^* q_b by atan2 (no arccos): an independent formula."""
    conj = np.array([-qa[0], -qa[1], -qa[2], qa[3]])
    r = _qmul(conj, qb)
    return math.degrees(2 * math.atan2(float(np.linalg.norm(r[:3])), abs(float(r[3]))))


@pytest.fixture(scope="module")
def damped_run():
    """Three free bodies with rate damping u = -k J w: the attitudes stay apart (tens of
    degrees), so the final pairwise error is far from 0 and known from the quaternions."""
    d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    att = np.array([_axis_angle([1, 0, 0], 10), _axis_angle([0, 1, 1], 50),
                    _axis_angle([1, -1, 0.5], 35)])
    f = AgentFormation(load_graph("ring:3"), np.array([np.diag([50.0, 55, 60])] * 3), att,
                       np.array([[0.02, 0, 0], [0, -0.01, 0.01], [0.005, 0.005, 0]]), Gains(k=0.5))
    with pytest.MonkeyPatch.context() as mp:  # no compiler for this run only (not a global leak)
        mp.setenv("FORMSYNC_NO_COMPILE", "1")
        r = simulate_agents(d, f, AgentOptions(tf=6, output_step=0.5, step=0.05))
    return d, r


def _ctx(name, d, r, tf=6.0, **args):
    spec = METRICS[name]
    return MetricContext(_Case(d, tf), "f", "s", spec, _Results(r),
                         check_metric_args(spec, args, "metrics[1]"))


def test_final_attitude_error_matches_the_quaternions(damped_run):
    d, r = damped_run
    Q = r.quaternions[-1]
    want = max(_angle_deg(Q[i], Q[j]) for i in range(3) for j in range(i + 1, 3))
    for to in ("auto", "pairwise"):
        v = METRICS["final_attitude_error_deg"].fn(_ctx("final_attitude_error_deg", d, r, to=to))
        assert v.unit == "deg" and v.evidence == "simulation" and v.bound == "exact"
        assert v.value == pytest.approx(want, abs=1e-9)
    assert want > 20  # the case is not trivial
    # no leader: the error to the reference is unknown, said why
    v = METRICS["final_attitude_error_deg"].fn(_ctx("final_attitude_error_deg", d, r, to="reference"))
    assert v.value is None and "no reference" in v.detail


def test_peak_torque_and_effort_match_the_torques(damped_run):
    d, r = damped_run
    U = r.torques
    assert METRICS["peak_torque"].fn(_ctx("peak_torque", d, r)).value == pytest.approx(
        float(np.abs(U).max()), rel=1e-12)
    v2 = METRICS["peak_torque"].fn(_ctx("peak_torque", d, r, spacecraft=2))
    assert v2.value == pytest.approx(float(np.abs(U[:, 1, :]).max()), rel=1e-12)
    sq = (U ** 2).sum(axis=2)
    trap = sum(0.5 * (sq[k] + sq[k + 1]) * (r.t[k + 1] - r.t[k]) for k in range(len(r.t) - 1))
    v = METRICS["control_effort"].fn(_ctx("control_effort", d, r))
    assert v.value == pytest.approx(float(trap.sum()), rel=1e-12)
    assert METRICS["control_effort"].fn(_ctx("control_effort", d, r, spacecraft=4)).value is None


def test_convergence_time_not_reached_is_a_lower_bound(damped_run):
    d, r = damped_run
    v = METRICS["convergence_time"].fn(_ctx("convergence_time", d, r))
    assert r.convergence_time is None  # attitudes stay apart
    assert (v.value, v.bound) == (6.0, "lower")
    assert v.interval() == Interval(6.0, math.inf)
    assert v.text() == ">= 6"
    t = METRICS["time_to_angle"].fn(_ctx("time_to_angle", d, r, angle_deg=90))
    assert (t.value, t.bound) == (0.0, "exact")


def test_certificate_metrics_without_a_certificate_are_unknown(damped_run):
    d, r = damped_run
    v = METRICS["certified_decay_rate"].fn(_ctx("certified_decay_rate", d, r))
    assert v.value is None and v.interval() is None
    c = METRICS["formation_certificate"].fn(_ctx("formation_certificate", d, r))
    assert c.value is None and c.evidence == "certificate" and c.detail.startswith("undecided")


def test_metric_arguments_are_typed_and_range_checked():
    spec = METRICS["time_to_angle"]
    with pytest.raises(InputError, match="required"):
        check_metric_args(spec, {}, "metrics[1]")
    with pytest.raises(InputError, match="magnitude"):
        check_metric_args(spec, {"angle_deg": 1e9}, "metrics[1]")
    with pytest.raises(InputError, match=">= 0"):
        check_metric_args(spec, {"angle_deg": -1}, "metrics[1]")
    with pytest.raises(InputError, match="unknown"):
        check_metric_args(spec, {"angle_deg": 1, "colour": 2}, "metrics[1]")
    with pytest.raises(InputError, match="integer"):
        check_metric_args(METRICS["peak_torque"], {"spacecraft": 1.5}, "metrics[1]")
    with pytest.raises(InputError, match="one of"):
        check_metric_args(METRICS["final_attitude_error_deg"], {"to": "moon"}, "metrics[1]")


def test_register_a_metric(damped_run):
    d, r = damped_run

    @register_metric("test_mean_final_rate", unit="rad/s", evidence="simulation",
                     doc="mean |w_i(tf)|", args=(MetricArg("scale", "number", 1.0),))
    def _mean(ctx):
        return ctx.value(float(np.linalg.norm(ctx.run().rates[-1], axis=1).mean())
                         * ctx.args["scale"])

    try:
        v = METRICS["test_mean_final_rate"].fn(_ctx("test_mean_final_rate", d, r, scale=2.0))
        assert v.value == pytest.approx(2 * np.linalg.norm(r.rates[-1], axis=1).mean())
        with pytest.raises(InputError, match="once"):
            register_metric("test_mean_final_rate", unit="1", evidence="simulation",
                            doc="x")(lambda ctx: ctx.value(0.0))
        with pytest.raises(InputError):
            register_metric("Bad Name", unit="1", evidence="simulation", doc="x")
        with pytest.raises(InputError):
            register_metric("x_y", unit="1", evidence="proof", doc="x")
    finally:
        METRICS.pop("test_mean_final_rate", None)


def test_metric_value_checks():
    with pytest.raises(InputError):
        MetricValue(1.0, "s", "simulation", bound="upper")
    with pytest.raises(InputError):
        MetricValue(1.0, "s", "guess")
    assert MetricValue("certified", "verdict", "certificate").interval() == "certified"


def test_a_copied_design_file_registers_its_metric_again_a_different_one_is_refused(tmp_path):
    """A user's copy of a design file (another path, the same metric text) loads beside the
    shipped one; a different function under a registered name is refused in one line."""
    from formsync_design.errors import InputError
    from formsync_design.verify.metrics import METRICS

    src = ('from formsync_design.verify.metrics import register_metric\n'
           '@register_metric("test_copied_metric", unit="1", evidence="simulation", doc="d")\n'
           'def m(ctx):\n    return ctx.value({})\n')
    try:
        for folder in ("shipped", "mine"):
            path = tmp_path / folder / "design.py"
            exec(compile(src.format(1.0), str(path), "exec"), {})  # noqa: S102 (test code)
        first = METRICS["test_copied_metric"].fn
        assert first.__code__.co_filename.endswith("shipped/design.py")  # the first is kept
        with pytest.raises(InputError, match="registered once"):
            exec(compile(src.format(2.0), str(tmp_path / "other.py"), "exec"), {})  # noqa: S102
    finally:
        METRICS.pop("test_copied_metric", None)


def test_a_copy_whose_metric_calls_a_changed_helper_is_refused_not_run_as_the_first(tmp_path):
    """The same metric text calling a helper of its file that differs in the copy is another
    metric: refused in one line (before, the first file's metric ran for the copy)."""
    from formsync_design.errors import InputError
    from formsync_design.verify.metrics import METRICS

    src = ('from formsync_design.verify.metrics import register_metric\n'
           'SCALE = {scale}\n'
           'def helper(x):\n    return {body}\n'
           '@register_metric("test_helper_metric", unit="1", evidence="simulation", doc="d")\n'
           'def m(ctx):\n    return ctx.value(helper(1.0))\n')
    try:
        exec(compile(src.format(scale=1, body="x * SCALE"), str(tmp_path / "a" / "d.py"),
                     "exec"), {})  # noqa: S102 (test code)
        # an identical copy elsewhere: accepted, the first kept
        exec(compile(src.format(scale=1, body="x * SCALE"), str(tmp_path / "b" / "d.py"),
                     "exec"), {})  # noqa: S102
        assert "/a/" in METRICS["test_helper_metric"].fn.__code__.co_filename
        for scale, body in ((1, "x * SCALE + 1"), (2, "x * SCALE")):  # helper or its constant
            with pytest.raises(InputError, match="registered once") as e:
                exec(compile(src.format(scale=scale, body=body), str(tmp_path / "c" / "d.py"),
                             "exec"), {})  # noqa: S102
            assert "\n" not in str(e.value)
    finally:
        METRICS.pop("test_helper_metric", None)
