"""``simulate`` is the one entry point of simulation (issue 23, item 2): the formation's type
chooses the path (Lagrangian view, agent form, the relative-orbit plant's fly-around) and the
design its law.

Each path reached through ``simulate`` is checked against the path's own worker called
directly (the same arrays, bitwise: ``simulate`` only routes), and a design given by its
Lagrangian view on an agent formation against its agent form built independently
(``spec/lagrangian_agent.agent_form``) and against the classic Lagrangian simulator."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.errors import InputError
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Gains, SimOptions
from formsync_design.sim.result import SimResult
from formsync_design.sim.sensors import RateSensors
from formsync_design.sim.simulator import simulate
from formsync_design.sim.tracking import simulate_flyaround
from formsync_design.spec.lagrangian_agent import agent_form
from formsync_design.spec.loader import load_design, load_spec
from formsync_design.verify.case import load_case

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def small() -> tuple[object, AgentFormation]:
    case = load_case(DATA / "small_case.toml")
    f = case.formation("ring:3")
    af = AgentFormation(f.graph, f.inertias, f.attitudes, f.rates,
                        Gains(K_o=1.6, K_q=0.4, beta=0.3, K_v=0.01), f.disturbance)
    return case, af


OPT = AgentOptions(tf=20.0, output_step=0.1, step=0.01, switch="sat", phi=0.01)


def _same(a: SimResult, b: SimResult) -> None:
    assert type(a) is type(b) is SimResult
    assert str(a.status) == str(b.status) and a.convergence_time == b.convergence_time
    for name in ("t", "quaternions", "rates", "torques", "attitude_error", "rate_error"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_an_agent_formation_runs_the_designs_agent_form(small) -> None:
    _, af = small
    # a shipped design with a Lagrangian view, by name: its agent form (load_design)
    _same(simulate(af, OPT, spec="liang2016"), simulate_agents(load_design("liang2016"), af, OPT))
    # the default design is the paper's
    _same(simulate(af, OPT), simulate_agents(load_design("liang2016"), af, OPT))
    # a Lagrangian-only design file: its agent form, built by spec/lagrangian_agent
    spec = load_spec(DATA / "case_spec_fast.py")
    _same(simulate(af, OPT, spec=spec), simulate_agents(agent_form(spec), af, OPT))
    _same(simulate(af, OPT, spec=DATA / "case_spec_fast.py"),
          simulate_agents(agent_form(spec), af, OPT))


def test_the_agent_form_of_a_view_simulates_like_its_lagrangian_run(small) -> None:
    """Independent truth: the classic Lagrangian simulator of the same file."""
    case, af = small
    spec = load_spec(DATA / "case_spec_fast.py")
    classic = simulate(case.formation("ring:3"), replace(case.options, tf=20.0), spec=spec)
    run = simulate(af, OPT, spec=spec)
    k = min(len(run.t), len(classic.t))
    assert np.allclose(run.t[:k], classic.t[:k])
    assert np.allclose(run.attitude_error[:k], classic.attitude_error[:k], rtol=1e-4, atol=1e-6)


def test_sensors_and_torque_inputs_reach_the_agent_kernel(small) -> None:
    _, af = small
    opt = replace(OPT, integrator="rk4")
    n = af.n
    gyro = RateSensors(np.full((n, 3), 1e-3), np.full(n, 1e-4), np.array([np.inf, 5.0, np.inf]), 3)
    _same(simulate(af, opt, sensors=gyro), simulate_agents(load_design("liang2016"), af, opt,
                                                           sensors=gyro))
    steps = int(round(opt.tf / opt.step))
    push = np.zeros((steps, n, 3))
    push[:100, 0, 0] = 0.5
    pushed = simulate(af, opt, torque_input=push)
    _same(pushed, simulate_agents(load_design("liang2016"), af, opt, torque_input=push))
    assert not np.array_equal(pushed.rates, simulate(af, opt).rates)  # the input acts


def test_a_trigger_runs_the_lagrangian_view_sampled() -> None:
    from formsync_design.sim.sampled import parse_trigger, simulate_sampled

    case = load_case(DATA / "small_case.toml")
    f = case.formation("ring:3")
    opt = replace(case.options, tf=20.0)
    a = simulate(f, opt, trigger="event:0.05:1e-4")
    b = simulate_sampled(f, opt, parse_trigger("event:0.05:1e-4"), None)
    _same(a, b)
    assert np.array_equal(a.transmissions, b.transmissions) and a.integrator == "hybrid-dop853"
    assert np.array_equal(a.q_m, b.q_m)


def test_a_flyaround_scenario_runs_the_tracking_design() -> None:
    case = fs.load_flyaround_case()
    opt = replace(case.options, tf=20.0)
    a = simulate(case.scenario, opt)
    b = simulate_flyaround(case.scenario, opt, case.spec)
    assert type(a) is type(b) and str(a.status) == str(b.status)
    assert np.array_equal(a.orbit.states, b.orbit.states) and np.array_equal(a.t, b.t)
    for k in b.orbit.outputs:
        assert np.array_equal(a.orbit.outputs[k], b.orbit.outputs[k]), k


def test_what_a_path_cannot_take_is_refused_in_one_line(small) -> None:
    case, af = small
    f = case.formation("ring:3")
    gyro = RateSensors(np.zeros((3, 3)), np.zeros(3), np.full(3, np.inf))
    with pytest.raises(InputError, match="AgentFormation for sensors"):
        simulate(f, case.options, sensors=gyro)
    with pytest.raises(InputError, match="AgentFormation for the agent design ma_so3"):
        simulate(f, case.options, spec="ma_so3")
    with pytest.raises(InputError, match="expected AgentOptions"):
        simulate(af, SimOptions(tf=10.0))
    for form in (af, f):  # a design on the relative-orbit plant flies a fly-around scenario
        with pytest.raises(InputError, match="FlyaroundScenario for a design on the relative-orbit"):
            simulate(form, OPT, spec="zhang2014_flyaround")
    with pytest.raises(InputError, match="Formation, an AgentFormation or a FlyaroundScenario"):
        simulate("ring:3", None)
    with pytest.raises(InputError, match="trigger rule only for a Formation"):
        simulate(af, OPT, trigger="periodic:0.5")
    with pytest.raises(InputError, match="periodic:T or event"):
        simulate(f, case.options, trigger="sometimes")
    fly = fs.load_flyaround_case()
    with pytest.raises(InputError, match="fly-around"):
        simulate(fly.scenario, None, sensors=gyro)
