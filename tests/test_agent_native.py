"""The compiled formation driver of agent designs (:mod:`formsync_design.sim.agent_native`)
against independent truth: the unrolled CasADi kernel of :mod:`~formsync_design.sim.agent_kernel`
(same law, other code: one SX graph per formation, evaluated in the CasADi virtual machine),
the NumPy disagreement metrics, an analytic solution, and RK4 against DOPRI5.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import formsync_design.sim.agents as agents_mod
from formsync_design.errors import InputError
from formsync_design.graphs import load_graph
from formsync_design.sim import agent_native
from formsync_design.sim.agent_native import native_agents_available, native_disagreement
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.disagreement import attitude_disagreement, rate_disagreement
from formsync_design.sim.formation import Gains
from formsync_design.spec.agent import agent_design_from_functions
from formsync_design.verify.agentcase import load_agent_case

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.skipif(not native_agents_available(), reason="no C compiler")


def _vm_run(monkeypatch, design, f, opt):
    """The same run on the unrolled CasADi kernel in the virtual machine."""
    with monkeypatch.context() as m:
        m.setenv("FORMSYNC_NO_COMPILE", "1")
        m.setattr(agents_mod, "native_agents_available", lambda: False)
        return simulate_agents(design, f, opt)


@pytest.mark.parametrize("name", ["bai2008_passivity", "lv2012", "ma_so3", "pd_consensus",
                                  "liang2016"])
def test_rk4_equals_the_unrolled_kernel(name, monkeypatch):
    """Quaternion, MRP and SO(3) designs, with controller states, a leader with a
    time-varying reference rate, torque limits and the paper's disturbance: every trajectory,
    torque and monitor to rounding."""
    case = load_agent_case(ROOT / "verification" / f"{name}.toml")
    step = case.options.step if case.options.integrator == "rk4" else 0.01
    opt = replace(case.options, tf=min(case.options.tf, 6.0), integrator="rk4", step=step,
                  output_step=step * max(1, round(0.5 / step)))
    f = case.formation()
    a = simulate_agents(case.design, f, opt)
    b = _vm_run(monkeypatch, case.design, f, opt)
    assert a.integrator == b.integrator == "rk4" and a.stats["compiled"] and not b.stats
    for key in ("quaternions", "rates", "states", "torques"):
        x, y = getattr(a, key), getattr(b, key)
        assert x.shape == y.shape
        assert np.allclose(x, y, rtol=1e-9, atol=1e-10), key
    assert set(a.monitors) == set(b.monitors)
    for k in a.monitors:
        assert np.allclose(a.monitors[k], b.monitors[k], rtol=1e-9, atol=1e-10), k
    assert np.allclose(a.attitude_error, b.attitude_error, rtol=1e-9, atol=1e-9)
    assert a.status == b.status


def _damping():
    return agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}},
                                       name="native_damping")


def test_dopri5_against_the_analytic_solution():
    """``u = -k J w`` decays every body rate as ``exp(-k t)`` (the gyroscopic term vanishes
    for ``J = I``); DOPRI5's dense output meets it at every output time."""
    d = _damping()
    w0 = np.array([[0.1, -0.2, 0.05], [0.02, 0.0, -0.3], [0.0, 0.1, 0.1]])
    f = AgentFormation(load_graph("path:3"), np.array([np.eye(3)] * 3),
                       np.array([[0, 0, 0, 1.0]] * 3), w0, Gains(k=0.7))
    r = simulate_agents(d, f, AgentOptions(tf=10, output_step=0.25, integrator="dopri5",
                                           rtol=1e-10, atol=1e-12))
    truth = w0[None] * np.exp(-0.7 * r.t)[:, None, None]
    assert np.abs(r.rates - truth).max() < 1e-9
    assert np.allclose(np.linalg.norm(r.quaternions, axis=2), 1.0, atol=1e-14)
    assert r.stats["integrator"] == "dopri5" and r.stats["steps"] < 200


def test_dopri5_agrees_with_rk4_on_a_weighted_digraph():
    case = load_agent_case(ROOT / "verification" / "bai2008_passivity.toml")
    f = case.formation()
    opt = replace(case.options, tf=30.0, output_step=0.5, step=0.005)
    a = simulate_agents(case.design, f, opt)
    b = simulate_agents(case.design, f, replace(opt, integrator="dopri5", rtol=1e-11, atol=1e-13))
    assert np.abs(a.quaternions - b.quaternions).max() < 1e-8
    assert np.abs(a.rates - b.rates).max() < 1e-8
    assert b.stats["rhs_evaluations"] < a.stats["rhs_evaluations"] / 3


def test_a_new_size_or_horizon_compiles_nothing(monkeypatch):
    """The kernel is per design and in-degree: ring:6 after ring:5 (both in-degree 2), and a
    new horizon and output grid, generate no law and run no compiler."""
    d = agent_design_from_functions(
        lambda v: -v.k * v.w + sum((n.a * (n.q - v.q) for n in v.nbrs), 0 * v.q),
        gains={"k": {}}, name="native_sizes")
    built: list[int] = []
    real = agent_native._law_functions
    monkeypatch.setattr(agent_native, "_law_functions",
                        lambda *a: built.append(a[1]) or real(*a))

    def run(n, tf):
        rng = np.random.default_rng(n)
        q = np.hstack([0.1 * rng.normal(size=(n, 3)), np.ones((n, 1))])
        f = AgentFormation(load_graph(f"ring:{n}"), np.array([np.diag([2.0, 3, 4])] * n),
                           q / np.linalg.norm(q, axis=1, keepdims=True),
                           0.01 * rng.normal(size=(n, 3)), Gains(k=1.0))
        return simulate_agents(d, f, AgentOptions(tf=tf, output_step=0.5, step=0.05))

    run(5, 2.0)
    first = list(built)
    calls: list[object] = []
    real_run = agent_native.build_shared
    monkeypatch.setattr(agent_native, "build_shared",
                        lambda *a, **k: calls.append(a[0]) or real_run(*a, **k))
    import formsync_design.sim.ccompile as cc

    compiler_runs: list[object] = []
    real_sub = cc.subprocess.run
    monkeypatch.setattr(cc.subprocess, "run",
                        lambda *a, **k: compiler_runs.append(a) or real_sub(*a, **k))
    r = run(6, 3.5)
    run(40, 1.0)
    assert built == first  # the in-degree-2 law was made once (or loaded from the disk cache)
    assert compiler_runs == [] and calls == []  # nothing built, nothing looked up again
    assert r.quaternions.shape == (8, 6, 4)


def test_dopri5_refuses_a_sign_switch():
    d = agent_design_from_functions(
        lambda v: -v.k * v.w - v.sgn(v.w), gains={"k": {}}, name="native_sgn")
    f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
                       np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.1), Gains(k=1.0))
    with pytest.raises(InputError, match="expected --switch sat or tanh"):
        simulate_agents(d, f, AgentOptions(tf=1, output_step=0.5, integrator="dopri5"))
    r = simulate_agents(d, f, AgentOptions(tf=1, output_step=0.5, integrator="dopri5",
                                           switch="tanh", phi=0.05))
    assert r.stats["integrator"] == "dopri5"


@pytest.mark.parametrize("integrator", ["rk4", "dopri5"])
def test_a_blow_up_is_a_diverged_finding(integrator):
    """``w' = k w^2`` on each axis (a positive feedback ``u = k J (w*w)``) reaches infinity
    at ``t = 1/(k w0) = 2 s``: the run ends at its last finite output, status diverged
    (RK4: a non-finite state; DOPRI5: its step size underflows at the escape time)."""
    d = agent_design_from_functions(
        lambda v: v.k * v.J * v.w.multiply_elementwise(v.w), gains={"k": {}},
        name="native_blowup")
    f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
                       np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.5), Gains(k=1.0))
    r = simulate_agents(d, f, AgentOptions(tf=5, output_step=0.1, step=0.01,
                                           integrator=integrator))
    assert str(r.status) == "diverged"
    assert r.t[-1] < 2.0 + 1e-9 and r.diverged_time is not None
    assert r.diverged_time <= 2.2
    assert np.isfinite(r.rates).all()


def test_native_disagreement_equals_the_numpy_metrics():
    """The C metrics form their exact values in NumPy's operation order: equal bitwise, at
    large and at rounding-floor spreads, with ties (a cycled case) and a non-finite sample."""
    rng = np.random.default_rng(7)
    for spread, n in ((1.0, 40), (1e-7, 35), (3.0, 60), (0.3, 2), (1e-10, 5), (1.0, 1)):
        Q = np.array([0, 0, 0, 1.0]) + spread * rng.normal(size=(12, n, 4))
        W = spread * rng.normal(size=(12, n, 3))
        att, rate = native_disagreement(Q, W)
        assert np.array_equal(att, attitude_disagreement(Q))
        assert np.array_equal(rate, rate_disagreement(W))
    # repeated spacecraft (a cycled case): many pairs tie for the largest angle
    Q = np.tile(np.array([0, 0, 0, 1.0]) + 0.2 * rng.normal(size=(5, 4, 4)), (1, 30, 1))
    W = np.tile(rng.normal(size=(5, 4, 3)), (1, 30, 1))
    att, rate = native_disagreement(Q, W)
    assert np.array_equal(att, attitude_disagreement(Q))
    assert np.array_equal(rate, rate_disagreement(W))
    Q[2, 7] = np.nan
    W[3, 9, 1] = np.inf
    att, rate = native_disagreement(Q, W)
    assert math.isnan(att[2]) and np.isfinite(np.delete(att, 2)).all()
    assert np.array_equal(att, attitude_disagreement(Q), equal_nan=True)
    assert math.isnan(rate[3]) and np.array_equal(rate, rate_disagreement(W), equal_nan=True)


def test_batch_runs_equal_single_runs_bitwise():
    case = load_agent_case(ROOT / "verification" / "bai2008_passivity.toml")
    base = case.formation()
    rng = np.random.default_rng(3)
    fl = [replace(base, rates=base.rates + 0.01 * rng.normal(size=base.rates.shape))
          for _ in range(3)]
    opt = replace(case.options, tf=5.0, integrator="dopri5")
    both = agents_mod.simulate_agents_batch(case.design, fl, opt, threads=2)
    for r, f in zip(both, fl, strict=True):
        one = simulate_agents(case.design, f, opt)
        assert np.array_equal(r.quaternions, one.quaternions)
        assert np.array_equal(r.torques, one.torques)


def test_cli_integrator_auto_and_the_montecarlo_default(capsys):
    """``--integrator auto`` of an agent design is dopri5 (rk4 with ``--step``); a
    Monte-Carlo campaign integrates with dopri5 at its ``--rtol``/``--atol`` unless
    ``--step`` is given, and says which in its defaults."""
    import json

    from formsync_design.cli.main import main

    def run(*argv):
        code = main(list(argv))
        out, err = capsys.readouterr()
        return code, out, err

    code, out, _ = run("simulate", "--design", "bai2008_passivity", "--tf", "5",
                       "--integrator", "auto", "--format", "json")
    assert code in (0, 1) and json.loads(out)["integrator"] == "dopri5"
    code, out, _ = run("simulate", "--design", "bai2008_passivity", "--tf", "5",
                       "--integrator", "auto", "--step", "0.05", "--format", "json")
    assert json.loads(out)["integrator"] == "rk4"
    code, out, err = run("montecarlo", "--design", "bai2008_passivity", "--runs", "3",
                         "--tf", "5", "--no-certify", "--rtol", "1e-7")
    assert "integrator: dopri5 rtol 1e-07 atol 1e-10 (the Monte-Carlo default" in err + out
    code, out, err = run("montecarlo", "--design", "bai2008_passivity", "--runs", "3",
                         "--tf", "5", "--no-certify", "--step", "0.05")
    assert "integrator: dopri5" not in err + out
