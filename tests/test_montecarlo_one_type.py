"""One Monte-Carlo result type for both paths (issue 23, item 2): ``fs.monte_carlo`` of a
Lagrangian and of an agent design returns a :class:`MonteCarloResult` of
:class:`MonteCarloRun` s from one :class:`MonteCarloSettings`; every run record equals a
direct single simulation of its seed, ``to_dict`` writes the keys each path wrote before the
types were merged, and the settings resolve to each path's former defaults."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.errors import InputError
from formsync_design.sim.agent_montecarlo import agent_run_formation, monte_carlo_agents
from formsync_design.sim.agents import simulate_agents
from formsync_design.sim.montecarlo import point_box, replay
from formsync_design.sim.montecarlo_data import (
    RUN_STATUSES,
    MonteCarloResult,
    MonteCarloRun,
    MonteCarloSettings,
    RunStatus,
)
from formsync_design.spec.agent import agent_design_from_functions

DATA = Path(__file__).parent / "data"

# the keys of a run's to_dict on main before the merge (sim/montecarlo_data.MonteCarloRun
# and sim/agent_montecarlo.AgentRun), the gains written between seed and status
LAGRANGIAN_RUN_KEYS = ["index", "seed", "K_o", "K_q", "beta", "K_v", "status", "convergence_time",
                       "final_q_m", "final_omega_m", "min_q0", "peak_torque", "norm_error",
                       "event_time"]
AGENT_RUN_KEYS = ["seed", "gain_k", "status", "diverged_time", "convergence_time",
                  "final_attitude_error_deg", "final_rate_error", "peak_torque", "effort",
                  "transmissions", "min_interevent"]
# ... and of the campaign's to_dict (MonteCarloResult.summary, AgentMonteCarloResult.to_dict)
LAGRANGIAN_RESULT_KEYS = ["runs", "counts", "convergence_time", "worst_final_q_m",
                          "worst_final_omega_m", "min_q0", "max_peak_torque", "box", "settings",
                          "options", "failures", "certification", "wall_seconds", "build_seconds"]
AGENT_RESULT_KEYS = ["design", "graph", "box", "runs", "seed", "max_angle_deg", "max_rate",
                     "converged", "diverged", "failed_seeds", "convergence_time_max",
                     "convergence_time_median", "peak_torque_max", "certificate",
                     "certificate_reason"]

LAG_OPT = fs.SimOptions(tf=5.0, step=0.1, output_step=0.5, norm_tol=1e-5, compile=False)
AGENT_OPT = fs.AgentOptions(tf=3, output_step=0.5, step=0.05, rate_tol=1e-2)


@pytest.fixture(scope="module")
def lagrangian() -> tuple:
    base = fs.load_case(DATA / "small_case.toml").formation()
    st = MonteCarloSettings(runs=3, seed=1)
    return base, st, fs.monte_carlo(base, None, st, LAG_OPT, certify=False)


@pytest.fixture(scope="module")
def agent() -> tuple:
    design = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}}, name="damp")
    base = fs.AgentFormation(fs.load_graph("path:2"), np.array([np.eye(3)] * 2),
                             np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3)), fs.Gains(k=1.0))
    box = fs.GainBox.parse({"k": "0.5:1"})
    st = MonteCarloSettings(runs=3, seed=2, max_angle_deg=30.0)
    return design, base, box, st, monte_carlo_agents(design, base, box, st, AGENT_OPT,
                                                     certify=False)


def test_lagrangian_runs_equal_a_single_simulation_of_their_seed(lagrangian: tuple) -> None:
    base, st, res = lagrangian
    assert isinstance(res, MonteCarloResult) and not res.is_agent
    box = point_box(base.gains)
    assert res.box == box
    assert len(res.runs) == 3 and [r.index for r in res.runs] == [0, 1, 2]
    seeds = np.random.SeedSequence(1).generate_state(3, dtype=np.uint64) >> np.uint64(1)
    assert [r.seed for r in res.runs] == [int(s) for s in seeds]
    for run in res.runs:
        assert isinstance(run, MonteCarloRun) and not run.is_agent
        f = replay(base, box, st, run.seed)
        r = fs.simulate(f, LAG_OPT)
        assert run.status == r.status and run.convergence_time == r.convergence_time
        assert run.final_q_m == pytest.approx(r.final_q_m, rel=1e-12)
        assert run.final_omega_m == pytest.approx(r.final_omega_m, rel=1e-12)
        assert run.min_q0 == float(r.min_q0.min())
        assert run.peak_torque == float(r.peak_torque.max())
        assert run.norm_error == pytest.approx(r.stats["max_norm_error"], rel=1e-9, abs=1e-15)
        assert run.event_time is None
        assert run.gains == (("K_o", f.gains.K_o), ("K_q", f.gains.K_q), ("beta", f.gains.beta),
                             ("K_v", f.gains.K_v[0]))
        assert run.K_o == f.gains.K_o
        assert (run.final_attitude_error, run.final_rate_error, run.effort, run.transmissions,
                run.min_interevent, run.diverged_time) == (None,) * 6


def test_agent_runs_equal_a_single_simulation_of_their_seed(agent: tuple) -> None:
    design, base, box, st, res = agent
    assert isinstance(res, MonteCarloResult) and res.is_agent
    assert (res.design, res.graph, res.box) == ("damp", "path:2", box)
    assert [r.seed for r in res.runs] == st.run_seeds()
    for run in res.runs:
        assert isinstance(run, MonteCarloRun) and run.is_agent
        f = agent_run_formation(design, base, box, st, run.seed)
        r = simulate_agents(design, f, AGENT_OPT)
        assert run.status == str(r.status) and isinstance(run.status, RunStatus)
        assert run.convergence_time == r.convergence_time
        assert run.final_attitude_error == float(r.attitude_error[-1])
        assert run.final_rate_error == float(r.rate_error[-1])
        assert run.peak_torque == float(r.peak_torque.max())
        assert run.effort == float(np.sum(r.effort))
        assert run.transmissions is None and r.transmissions is None
        assert run.min_interevent is None and run.diverged_time == r.diverged_time
        assert dict(run.gains) == f.gains.as_dict() and run.k == f.gains.k
        assert (run.index, run.final_q_m, run.final_omega_m, run.min_q0, run.norm_error,
                run.event_time) == (None,) * 6


def test_fs_monte_carlo_of_an_agent_design_gives_the_one_result_type(agent: tuple) -> None:
    design, base, box, st, res = agent
    via = fs.monte_carlo(base, box, st, AGENT_OPT, certify=False, spec=design)
    assert type(via) is MonteCarloResult
    assert [r.to_dict() for r in via.runs] == [r.to_dict() for r in res.runs]


def test_run_to_dict_keys_are_those_of_each_path_before(lagrangian: tuple, agent: tuple) -> None:
    for run in lagrangian[2].runs:
        assert list(run.to_dict()) == LAGRANGIAN_RUN_KEYS
    for run in agent[4].runs:
        assert list(run.to_dict()) == AGENT_RUN_KEYS
    assert list(lagrangian[2].to_dict()) == LAGRANGIAN_RESULT_KEYS
    assert list(lagrangian[2].summary()) == LAGRANGIAN_RESULT_KEYS
    assert list(lagrangian[2].to_dict()["settings"]) == ["runs", "seed", "max_angle_deg",
                                                         "max_rate", "phases"]
    assert list(lagrangian[2].to_dict()["counts"]) == list(RUN_STATUSES) == [
        "converged", "not-converged", "singular", "diverged", "inaccurate"]
    assert list(agent[4].to_dict()) == AGENT_RESULT_KEYS
    d = agent[4].runs[0].to_dict()
    assert d["seed"] == agent[4].runs[0].seed and isinstance(d["status"], str)


def test_settings_resolve_to_each_paths_former_defaults() -> None:
    # the defaults on main: MonteCarloSettings (Lagrangian) and AgentMonteCarloSettings
    lag = MonteCarloSettings().resolved_for("lagrangian")
    assert (lag.runs, lag.seed, lag.max_angle_deg, lag.max_rate, lag.phases) == (
        1000, 0, 100.0, 0.9, True)
    ag = MonteCarloSettings().resolved_for("agent")
    assert (ag.runs, ag.seed, ag.max_angle_deg, ag.max_rate) == (100, 0, 90.0, 0.01)
    assert lag.resolved_for("lagrangian") == lag and ag.resolved_for("agent") == ag
    given = MonteCarloSettings(runs=7, seed=3, max_angle_deg=12.0, max_rate=0.2, phases=False)
    assert given.resolved_for("agent") == given == given.resolved_for("lagrangian")
    # the agent path's seeds: one spawned child per run (the first k independent of runs)
    ss = np.random.SeedSequence(5)
    assert MonteCarloSettings(runs=4, seed=5).run_seeds() == [
        int(c.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1)) for c in ss.spawn(4)]
    assert len(MonteCarloSettings(seed=5).run_seeds()) == 100
    with pytest.raises(InputError):
        MonteCarloSettings(max_angle_deg=180).resolved_for("lagrangian")
    with pytest.raises(InputError):
        MonteCarloSettings().resolved_for("other")  # type: ignore[arg-type]
    with pytest.raises(InputError):
        MonteCarloSettings().numbers()


def test_fs_monte_carlo_of_an_agent_design_takes_the_agent_defaults(agent: tuple) -> None:
    design, base, box, _, _ = agent
    res = fs.monte_carlo(base, box, MonteCarloSettings(runs=1), AGENT_OPT, certify=False,
                         spec=design)
    assert (res.settings.max_angle_deg, res.settings.max_rate) == (90.0, 0.01)
