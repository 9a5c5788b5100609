"""One result type for every attitude-formation run (issue 23, item 2): the Lagrangian
simulator and the agent designs' drivers both return :class:`SimResult` with one
:class:`SimStatus`, checked against independent truth (rotation matrices, the other path's
trajectory, the statuses each path's source can produce)."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
import formsync_design.sim as fsim
from formsync_design.graphs.build import make_graph
from formsync_design.sim import agents as agents_module
from formsync_design.sim.agents import AGENT_STATUSES, AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Formation, Gains, SimOptions, pack_state
from formsync_design.sim.lagrangian_outcome import lagrangian_message
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.sim.simulator import simulate
from formsync_design.spec.loader import load_design
from formsync_design.verify.case import load_case, make_disturbance

SIM = Path(fsim.__file__).parent


def _rotation(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of a quaternion ``(q1, q2, q3, q0)`` (scalar last), normalised."""
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _largest_angle_deg(Q: np.ndarray) -> float:
    """Largest pairwise principal angle (deg) of ``(N, 4)`` attitudes from rotation matrices:
    ``arccos((tr(R_i^T R_j) - 1) / 2)``."""
    R = [_rotation(q) for q in Q]
    best = 0.0
    for i in range(len(R)):
        for j in range(i + 1, len(R)):
            c = (np.trace(R[i].T @ R[j]) - 1) / 2
            best = max(best, float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))))
    return best


@pytest.fixture(scope="module")
def ring4() -> tuple[Formation, AgentFormation]:
    """Spacecraft 1-4 of the paper's case (Table 1) on ring:4 with the paper's disturbance, as
    a Lagrangian formation and as an agent formation."""
    case = load_case()
    J, q, w = case.inertias[:4], case.attitudes[:4], case.rates[:4]
    g = case.gains.as_dict()
    kv = case.gains.K_v[0]
    dist = make_disturbance({"model": "paper"}, J, case.orbit)
    graph = make_graph("ring:4")
    lag = Formation(graph, J, q, w, Gains(g["K_o"], g["K_q"], g["beta"], (kv,) * 4), dist)
    agent = AgentFormation(graph, J, q, w, Gains(K_o=g["K_o"], K_q=g["K_q"], beta=g["beta"], K_v=kv),
                           dist)
    return lag, agent


@pytest.fixture(scope="module")
def both_paths(ring4: tuple[Formation, AgentFormation]) -> tuple[SimResult, SimResult]:
    lag_f, agent_f = ring4
    lag = simulate(lag_f, SimOptions(tf=10.0, switch="sat", phi=0.01, step=0.01, output_step=0.1))
    agent = simulate_agents(load_design("liang2016"), agent_f,
                            AgentOptions(tf=10.0, output_step=0.1, step=0.01, switch="sat", phi=0.01))
    return lag, agent


def test_the_lagrangian_attitude_error_is_the_largest_angle_between_rotation_matrices(
        both_paths: tuple[SimResult, SimResult]) -> None:
    lag, _ = both_paths
    T = len(lag.t)
    for k in (0, 1, T // 4, T // 2, T - 1):
        want = _largest_angle_deg(lag.quaternions[k])
        assert lag.attitude_error[k] == pytest.approx(want, rel=1e-7, abs=1e-5), k
    assert lag.attitude_error[0] > 10  # the case starts far from agreement: a real check
    # the rate error from the rates themselves
    k = T // 3
    W = lag.rates[k]
    want_rate = max(np.linalg.norm(W[i] - W[j]) for i in range(4) for j in range(4))
    assert lag.rate_error[k] == pytest.approx(want_rate, rel=1e-12)


def test_both_paths_return_one_type_with_the_same_keys_and_close_trajectories(
        both_paths: tuple[SimResult, SimResult]) -> None:
    lag, agent = both_paths
    assert type(lag) is SimResult and type(agent) is SimResult
    assert isinstance(lag.status, SimStatus) and isinstance(agent.status, SimStatus)
    dl, da = lag.to_dict(), agent.to_dict()
    assert list(dl) == list(da)
    assert dl["design"] == da["design"] == "liang2016" and dl["graph"] == da["graph"] == "ring:4"
    assert dl["final_q_m"] is not None and da["final_q_m"] is None  # the Lagrangian extras
    assert lag.t.shape == agent.t.shape and np.array_equal(lag.t, agent.t)
    # the same closed loop integrated twice (RK4 h = 0.01 s; the agent kernel renormalises)
    # (observed differences ~1e-10 in the state, ~1e-8 in N m and deg)
    assert np.allclose(lag.quaternions, agent.quaternions, rtol=0, atol=1e-8)
    assert np.allclose(lag.rates, agent.rates, rtol=0, atol=1e-8)
    assert np.allclose(lag.torques, agent.torques, rtol=0, atol=1e-6)
    assert np.allclose(lag.attitude_error, agent.attitude_error, rtol=0, atol=1e-6)
    assert np.allclose(lag.rate_error, agent.rate_error, rtol=0, atol=1e-8)
    assert np.allclose(lag.effort, agent.effort, rtol=1e-8, atol=0)
    assert lag.states.shape == (len(lag.t), 4, 0)
    # x and u in the state order of pack_state, for either producer
    for r in (lag, agent):
        k = len(r.t) // 2
        assert np.array_equal(r.x[k], pack_state(r.quaternions[k], r.rates[k]))
        assert np.array_equal(r.u[k], r.torques[k].ravel())
        assert r.x.shape == (len(r.t), 28) and len(r.names) == 28 and r.n == 4
        assert np.array_equal(r.final_rates, r.rates[-1])


def test_the_lagrangian_message_is_a_field_computed_by_its_path(
        both_paths: tuple[SimResult, SimResult]) -> None:
    lag, agent = both_paths
    assert lag.message == lagrangian_message(lag) and lag.message.startswith(("converged", "not"))
    assert agent.message == ""  # an agent run that ran to the horizon


def test_simstatus_has_exactly_five_members() -> None:
    assert [(m.name, m.value) for m in SimStatus] == [
        ("CONVERGED", "converged"), ("NOT_CONVERGED", "not-converged"),
        ("SINGULAR", "singular"), ("DIVERGED", "diverged"), ("STOPPED", "stopped")]
    assert set(AGENT_STATUSES) == set(SimStatus) - {SimStatus.SINGULAR}


@pytest.mark.parametrize("module, expected", [
    ("simulator.py", {"CONVERGED", "NOT_CONVERGED", "SINGULAR", "DIVERGED"}),
    ("agents.py", {"CONVERGED", "NOT_CONVERGED", "STOPPED", "DIVERGED"}),
])
def test_each_path_only_uses_the_one_status(module: str, expected: set[str]) -> None:
    """Every status a producer writes is a :class:`SimStatus` member (its source names no
    other status type), and each path writes the statuses its docstring promises."""
    src = (SIM / module).read_text()
    used = set(re.findall(r"SimStatus\.([A-Z_]+)", src))
    assert used <= set(SimStatus.__members__)
    assert expected <= used
    assert "StrEnum" not in src and set(re.findall(r"\b([A-Za-z]*Status)\.", src)) == {"SimStatus"}


def test_the_old_agent_result_names_are_gone() -> None:
    for name in ("AgentResult", "AgentStatus"):
        assert not hasattr(agents_module, name)
        assert name not in fsim.__all__ and name not in fs.__all__
        with pytest.raises(AttributeError):
            getattr(fsim, name)


def test_simulate_dispatches_an_agent_design_to_the_same_type(
        ring4: tuple[Formation, AgentFormation]) -> None:
    _, agent_f = ring4
    r = simulate(agent_f, AgentOptions(tf=1.0, output_step=0.5, step=0.01, switch="sat"),
                 spec=load_design("liang2016"))
    assert type(r) is SimResult and r.status in AGENT_STATUSES and r.omega_m is None
    assert r.options.tf == 1.0 and r.spec_key == load_design("liang2016").key


def test_a_diverged_replacement_keeps_the_status_type(
        both_paths: tuple[SimResult, SimResult]) -> None:
    lag, _ = both_paths
    d = replace(lag, status=SimStatus.DIVERGED, diverged_time=0.5, convergence_time=None)
    assert d.stopped_early and d.to_dict()["status"] == "diverged"
    assert np.array_equal(d.attitude_error, lag.attitude_error)


def test_the_lagrangian_measures_computed_on_first_read_are_the_shared_functions(
        ring4: tuple[Formation, AgentFormation]) -> None:
    """The Lagrangian simulator leaves attitude_error, rate_error and effort to the first read:
    the same values as computed eagerly, read-only, and they survive pickling."""
    import pickle

    from formsync_design.sim.disagreement import attitude_disagreement, rate_disagreement

    r = simulate(ring4[0], SimOptions(tf=2.0, step=0.01))
    again = pickle.loads(pickle.dumps(r))
    assert np.array_equal(r.attitude_error, attitude_disagreement(r.quaternions))
    assert np.array_equal(r.rate_error, rate_disagreement(r.rates))
    assert np.array_equal(r.effort, np.trapezoid(np.sum(r.torques**2, axis=2), r.t, axis=0))
    assert not r.attitude_error.flags.writeable and not r.effort.flags.writeable
    assert np.array_equal(again.attitude_error, r.attitude_error)
    assert np.array_equal(again.q_m, r.q_m) and again.message == r.message


def test_the_summary_takes_the_final_disagreement_from_the_last_time_alone(
        ring4: tuple[Formation, AgentFormation]) -> None:
    """to_dict() of a Lagrangian run does not compute the whole O(T N^2) series, and gives the
    series' last values (checked against the series computed afterwards)."""
    f, _ = ring4
    r = simulate(f, SimOptions(tf=20.0))
    d = r.to_dict()
    assert r.__dict__.get("_attitude_error") is None and r.__dict__.get("_rate_error") is None
    assert d["final_attitude_error_deg"] == float(r.attitude_error[-1])
    assert d["final_rate_error"] == float(r.rate_error[-1])


def test_a_triggered_runs_options_name_the_integrator_that_ran(
        ring4: tuple[Formation, AgentFormation]) -> None:
    """A Lagrangian design's triggered run integrates with the hybrid integrator: its summary's
    options say so (and give no fixed step), like its top-level ``integrator``."""
    from formsync_design.sim.sampled import parse_trigger

    f, _ = ring4
    opt = SimOptions(tf=4.0, integrator="dopri5")
    r = simulate(f, opt, trigger=parse_trigger("periodic:0.5"))
    d = r.to_dict()
    assert d["integrator"] == d["options"]["integrator"] == "hybrid-dop853"
    assert d["options"]["step"] is None
    cont = simulate(f, opt).to_dict()  # a continuous run keeps the method it resolved to
    assert cont["options"]["integrator"] == "dopri5" == cont["integrator"]
