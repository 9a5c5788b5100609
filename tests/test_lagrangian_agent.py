"""The agent form of a Lagrangian design (``spec/lagrangian_agent.py``): the law written per
spacecraft from ``controller(view)`` in ``A``, ``B``, ``Q``, checked against the hand-written
agent controllers of the shipped designs (a second implementation), against the classic
Lagrangian simulator, and run by the verification engine."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.errors import InputError
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Gains
from formsync_design.sim.simulator import simulate
from formsync_design.spec.agent_view import AgentView
from formsync_design.spec.lagrangian_agent import agent_form, agent_of
from formsync_design.spec.loader import load_design, load_spec
from formsync_design.verify.case import load_case

DATA = Path(__file__).parent / "data"


def _random_state(v: AgentView, rng: np.random.Generator) -> dict:
    sub: dict = {}
    for body in (v.own, *v.nbrs):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q[3] = abs(q[3]) + 0.05  # away from q0 = 0, where the model is undefined
        q /= np.linalg.norm(q)
        sub.update({body.q[k]: q[k] for k in range(3)})
        sub[body.q0] = q[3]
    sub.update({v.w[k]: rng.normal(scale=0.3) for k in range(3)})
    J = np.diag([50.0, 55.0, 60.0]) + rng.uniform(-2, 2, (3, 3))
    J = (J + J.T) / 2
    sub.update({v.J[i, j]: J[i, j] for i in range(3) for j in range(3)})
    sub.update({n.a: rng.uniform(0.5, 2.0) for n in v.nbrs})
    sub.update({sym: rng.uniform(0.1, 2.0) for sym in v.gains.values()})
    return sub


@pytest.mark.parametrize("name", ["liang2016", "pd_consensus"])
@pytest.mark.parametrize("m", [1, 2, 3])
def test_the_agent_form_is_the_hand_written_agent_law(name: str, m: int) -> None:
    hand = load_design(name)
    auto = agent_form(load_spec(name))
    assert auto.gains == hand.gains and auto.lagrangian is load_spec(name)
    v = AgentView(hand.decl, m)
    ua, uh = auto.controller(v), hand.controller(v)
    rng = np.random.default_rng(11 + m)
    for _ in range(4):
        sub = _random_state(v, rng)
        a = np.array(ua.xreplace(sub).evalf(), float).ravel()
        h = np.array(uh.xreplace(sub).evalf(), float).ravel()
        assert np.allclose(a, h, rtol=1e-10, atol=1e-9 * np.abs(h).max())


def test_the_agent_form_simulates_like_the_classic_lagrangian_simulator() -> None:
    """A Lagrangian-only design file (the paper's law with K_q doubled): its agent form on the
    agent kernel against the classic Lagrangian simulator of the same file."""
    spec = load_spec(DATA / "case_spec_fast.py")
    case = load_case(DATA / "small_case.toml")
    f = case.formation("ring:3")
    classic = simulate(f, replace(case.options, tf=40.0), spec=spec)
    af = AgentFormation(f.graph, f.inertias, f.attitudes, f.rates,
                        Gains(K_o=1.6, K_q=0.4, beta=0.3, K_v=0.01), f.disturbance)
    run = simulate_agents(agent_form(spec), af, AgentOptions(tf=40.0, output_step=0.1, step=0.01,
                                                            switch="sat", phi=0.01))
    # the same closed loop: the relative attitudes agree along the whole run
    from formsync_design.verify.metrics_lagrangian import relative_measures

    _, qm = relative_measures(run)
    k = min(len(qm), len(classic.q_m))
    assert np.allclose(qm[:k], classic.q_m[:k], rtol=1e-4, atol=1e-7)


def test_the_engine_runs_a_lagrangian_design_file_with_its_view(tmp_path: Path) -> None:
    """``--design`` a Lagrangian-only file: the engine runs its agent form, and the Lagrangian
    metrics read its view.  Independent truth: the file is the paper's law with K_q doubled."""
    small = DATA / "small_case.toml"
    fast = fs.verify_case(small, spec=DATA / "case_spec_fast.py")
    assert fast.case.base.design.lagrangian.name == "case_spec_fast"
    doubled = tmp_path / "doubled.toml"
    doubled.write_text(small.read_text().replace("K_q = 0.4", "K_q = 0.8"))
    ref = fs.verify_case(doubled)
    a = {m.id: v for m, v in fast.metrics}
    b = {m.id: v for m, v in ref.metrics}
    for key in ("t_ring3", "t_path3", "sat_ring3"):
        assert a[key].value == pytest.approx(b[key].value, abs=0.11), key
    # the certificate is of the file's own view: Pi of the doubled law at K_q = 0.4
    assert a["pi_ring3"].value == "certified"


def test_a_design_of_another_kind_is_refused_in_one_line() -> None:
    with pytest.raises(InputError) as e:
        agent_of(load_design("zhang2014_flyaround"), " in the test")
    assert "\n" not in str(e.value) and "relative-orbit plant" in str(e.value)
