"""DAG-aware SymPy traversals (formsync_design.spec.dag) and the engine paths that use them:
deeply composed agent laws load and compile, the bridge translates Max/Min (the 'sat' switch)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from formsync_design.spec import dag


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


def _deep(x, depth, evaluate=True):
    """``e <- e e / (1 + e e) + x``: a DAG of ~5 depth nodes, a tree of ~4**depth."""
    e = x
    for _ in range(depth):
        ee = sp.Mul(e, e, evaluate=evaluate)
        e = sp.Add(sp.Mul(ee, sp.Pow(sp.Add(1, ee, evaluate=evaluate), -1, evaluate=evaluate),
                          evaluate=evaluate), x, evaluate=evaluate)
    return e


def test_dag_traversals_agree_with_sympy_on_a_small_expression():
    x, y, z = sp.symbols("x y z")
    e = _deep(x, 4) + sp.sin(y) * sp.Abs(z - x)
    assert dag.free_symbols(e) == e.free_symbols
    assert sp.simplify(dag.xreplace(e, {x: y + 1}) - e.xreplace({x: y + 1})) == 0
    r = dag.replace_function(e, sp.sin, sp.cos)
    assert r == e.replace(sp.sin, sp.cos)
    M = sp.Matrix([[e, x], [y, 2]])
    assert dag.free_symbols(M) == M.free_symbols
    assert dag.dag_size(e) < sp.count_ops(e, visual=False) + 50


def test_a_deeply_composed_law_loads_and_simulates():
    """Tree of ~2^40 nodes, DAG of ~200: the engine's symbol checks and the switch
    replacement walk the DAG (before, they walked the tree and never finished)."""
    import types

    from formsync_design.graphs import load_graph
    from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
    from formsync_design.sim.formation import Gains
    from formsync_design.spec.agent import agent_design_from_module

    mod = types.ModuleType("deep")

    def controller(v):
        zero = sp.sin(v.w[0]) ** 2 + sp.cos(v.w[0]) ** 2 - 1  # 0, not simplified by SymPy
        return -v.k * v.J * v.w + v.k_s * zero * _deep(v.w[1], 40, evaluate=False) * v.sgn(v.w)

    mod.__dict__.update(FORM="agent", GAINS={"k": {}, "k_s": {}}, controller=controller)
    d = agent_design_from_module(mod, "<deep>", "deep-key", "deep")
    f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
                       np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.1),
                       Gains(k=1.0, k_s=0.1))
    r = simulate_agents(d, f, AgentOptions(tf=2, output_step=0.5, step=0.05, switch="sat"))
    assert abs(r.rates[-1, 0, 0] - 0.1 * np.exp(-2)) < 1e-6


def test_bridge_translates_max_and_min():
    import casadi as ca

    from formsync_design.sim.bridge import sympy_to_casadi

    x = sp.Symbol("x")
    xs = ca.SX.sym("x")
    f = ca.Function("f", [xs], [sympy_to_casadi(sp.Max(-1, sp.Min(1, x / 2)), {x: xs})])
    assert [float(f(v)) for v in (-5.0, 1.0, 5.0)] == [-1.0, 0.5, 1.0]
