"""Monte-Carlo draws of an agent design advanced together in the compiled kernel
(``sim/agents.simulate_agents_batch``, used by every agent campaign): each run must equal its
single run (``simulate_agents``) bitwise, a diverging run must end alone, and what cannot be
batched must run one by one."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from formsync_design.gains import GainBox
from formsync_design.graphs import load_graph
from formsync_design.resources import case_file
from formsync_design.sim.agent_montecarlo import agent_run_formation, run_agent_montecarlo
from formsync_design.sim.agents import (
    AgentFormation,
    AgentOptions,
    simulate_agents,
    simulate_agents_batch,
)
from formsync_design.sim.formation import Gains
from formsync_design.sim.montecarlo_data import MonteCarloSettings
from formsync_design.spec.agent import agent_design_from_functions
from formsync_design.spec.loader import load_design
from formsync_design.verify.agentcase import load_agent_case

FIELDS = ("t", "quaternions", "rates", "states", "torques", "attitude_error", "rate_error",
          "peak_torque", "effort")


def _equal(a, b) -> None:
    assert str(a.status) == str(b.status) and a.convergence_time == b.convergence_time
    assert a.diverged_time == b.diverged_time and a.message == b.message
    for name in FIELDS:
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for k in b.monitors:
        assert np.array_equal(a.monitors[k], b.monitors[k], equal_nan=True), k


@pytest.fixture(scope="module")
def ma_so3():
    case = load_agent_case(case_file("ma_so3"))
    design = load_design("ma_so3")
    base = case.formation()
    box = GainBox.parse({"K1": "1:1.3", "K2": "0.1:0.2", "P1": 0.03, "P2": 0.03, "eps": 0.01})
    settings = MonteCarloSettings(runs=5, seed=7, max_angle_deg=60.0).resolved_for("agent")
    drawn = [agent_run_formation(design, base, box, settings, s) for s in settings.run_seeds()]
    return design, drawn, replace(case.options, tf=12.0)


def test_each_batched_run_equals_its_single_run(ma_so3) -> None:
    design, drawn, opt = ma_so3
    for threads in (1, 2):
        batch = simulate_agents_batch(design, drawn, opt, threads=threads)
        assert len(batch) == len(drawn)
        for r, f in zip(batch, drawn, strict=True):
            _equal(r, simulate_agents(design, f, opt))


def test_a_diverging_run_ends_alone() -> None:
    """u = -k J w with RK4: stable for k h < 2.78, an exponential blow-up far beyond (the
    run with k = 1000 and h = 0.05 overflows within 5 s); its neighbours in the batch decay
    as the closed form exp(-k t) says."""
    d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    fl = [AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
                         np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.1), Gains(k=k))
          for k in (1.0, 1000.0, 0.5)]
    opt = AgentOptions(tf=5, output_step=0.5, step=0.05)
    batch = simulate_agents_batch(d, fl, opt)
    assert [str(r.status) for r in batch][1] == "diverged"
    for r, f in zip(batch, fl, strict=True):
        _equal(r, simulate_agents(d, f, opt))
    for r, k in ((batch[0], 1.0), (batch[2], 0.5)):
        assert abs(float(r.rates[-1, 0, 0]) - 0.1 * np.exp(-k * 5)) < 1e-7


def test_what_cannot_be_batched_runs_one_by_one(ma_so3) -> None:
    design, drawn, opt = ma_so3
    cv = replace(opt, integrator="cvodes", tf=4.0)
    for r, f in zip(simulate_agents_batch(design, drawn[:2], cv), drawn[:2], strict=True):
        _equal(r, simulate_agents(design, f, cv))
    # two graph structures: one kernel each, run one by one
    other = replace(drawn[1], graph=load_graph("ring:5"))
    mixed = simulate_agents_batch(design, [drawn[0], other], opt)
    _equal(mixed[1], simulate_agents(design, other, opt))


def test_a_campaign_records_the_single_runs(ma_so3) -> None:
    design, drawn, opt = ma_so3
    case = load_agent_case(case_file("ma_so3"))
    box = GainBox.parse({"K1": "1:1.3", "K2": "0.1:0.2", "P1": 0.03, "P2": 0.03, "eps": 0.01})
    settings = MonteCarloSettings(runs=5, seed=7, max_angle_deg=60.0)
    res = run_agent_montecarlo(design, case.formation(), box, settings, opt, certify=False)
    for run, f in zip(res.runs, drawn, strict=True):
        single = simulate_agents(design, f, opt)
        assert run.final_attitude_error == float(single.attitude_error[-1])
        assert run.peak_torque == float(single.peak_torque.max())
        assert run.convergence_time == single.convergence_time
