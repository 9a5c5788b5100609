"""The reconstructed SO(3) sliding-mode design of seed paper 002 (derivations/ma_so3.py), its
comparison designs, certificate and verification case, against independent truths: an
independent NumPy law with rotation matrices integrated directly (tests/numpy_so3_sliding.py),
finite differences, exact orthogonality."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from formsync_design.graphs.digraph_io import digraph_from_edges
from formsync_design.models.euler import quats_to_matrices
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Gains
from formsync_design.spec.loader import load_design
from tests import numpy_so3_sliding as ref

PAPER002 = [(1, 4, "0.58"), (2, 3, "0.33"), (2, 5, "0.11"), (3, 2, "0.25"), (4, 1, "0.21"),
            (4, 3, "0.4"), (5, 1, "0.37")]
GAINS = dict(K1=1.15, K2=0.15, P1=0.03, P2=0.03, eps=0.01)


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


@pytest.fixture(scope="module")
def design():
    return load_design("ma_so3")


def _rot(rng):
    q = rng.normal(size=4)
    return quats_to_matrices(q / np.linalg.norm(q))


def _lambdify_command(design, m):
    from formsync_design.spec.agent_view import AgentView

    v = AgentView(design.decl, m)
    Rd, Wd, Wdd, cond = design.module["command"]([(n.a, n.R, n.w) for n in v.nbrs])
    import casadi as ca

    from formsync_design.sim.bridge import sympy_to_casadi

    syms = [s for n in v.nbrs for s in (n.a, *n.R, *n.w)]
    x = ca.SX.sym("x", len(syms))  # the bridge walks the DAG (lambdify prints the tree)
    bind = {s: x[k] for k, s in enumerate(syms)}
    memo: dict = {}
    f = ca.Function("cmd", [x], [sympy_to_casadi(M, bind, memo) for M in (Rd, Wd, Wdd)])

    def call(nbrs):
        args = [x for a, R, w in nbrs for x in (a, *np.asarray(R).ravel(), *w)]
        Rd_, Wd_, Wdd_ = (np.asarray(o, float) for o in f(args))
        return [Rd_.reshape(3, 3), Wd_.ravel(), Wdd_.ravel()]
    return call


def test_command_is_a_rotation_for_random_neighbour_sets(design):
    rng = np.random.default_rng(4)
    for m in (1, 2, 3):
        cmd = _lambdify_command(design, m)
        for _ in range(20):
            nb = [(rng.uniform(0.05, 1), _rot(rng), rng.normal(size=3)) for _ in range(m)]
            Rd = cmd(nb)[0]
            assert np.abs(Rd.T @ Rd - np.eye(3)).max() < 1e-12
            assert abs(np.linalg.det(Rd) - 1) < 1e-12
        # neighbours that agree command their common attitude
        R = _rot(rng)
        assert np.abs(cmd([(0.3 + k, R, np.zeros(3)) for k in range(m)])[0] - R).max() < 1e-12


def test_command_rates_against_the_closed_form_and_finite_differences(design):
    """W_d and W_d' (SymPy-differentiated) against the independent closed form and against
    central differences of R_d along neighbours spinning at constant body rates (A8)."""
    rng = np.random.default_rng(7)
    cmd = _lambdify_command(design, 2)
    nb = [(rng.uniform(0.1, 1), _rot(rng), 0.5 * rng.normal(size=3)) for _ in range(2)]
    Rd, Wd, Wdd = cmd(nb)
    R2, W2, Wdd2 = ref.command(nb)
    assert np.abs(Rd - R2).max() < 1e-12 and np.abs(Wd - W2).max() < 1e-10
    assert np.abs(Wdd - Wdd2).max() < 1e-9
    from formsync_design.models.so3 import exp_so3

    def at(t):
        return ref.command([(a, R @ exp_so3(t * w), w) for a, R, w in nb])

    h = 1e-5
    dR = (at(h)[0] - at(-h)[0]) / (2 * h)
    assert np.abs(ref._vee_skew(Rd.T @ dR) - Wd).max() < 1e-7
    assert np.abs((at(h)[1] - at(-h)[1]) / (2 * h) - Wdd).max() < 1e-6


def test_error_dynamics_against_finite_differences():
    """e_R' = E(Rt) e_W and Psi' = e_R . e_W along smooth motions of R and R_d."""
    from formsync_design.models.so3 import exp_so3

    rng = np.random.default_rng(1)
    for _ in range(5):
        R0, D0 = _rot(rng), _rot(rng)
        w, wd = rng.normal(size=3), rng.normal(size=3)

        def err(t, R0=R0, D0=D0, w=w, wd=wd):
            R, Rd = R0 @ exp_so3(t * w), D0 @ exp_so3(t * wd)
            Rt = Rd.T @ R
            return ref._vee_skew(Rt), np.trace(np.eye(3) - Rt) / 2, Rt

        h = 1e-6
        eR, _, Rt = err(0.0)
        eW = w - Rt.T @ wd
        E = 0.5 * (np.trace(Rt) * np.eye(3) - Rt.T)
        assert np.abs((err(h)[0] - err(-h)[0]) / (2 * h) - E @ eW).max() < 1e-8
        assert abs((err(h)[1] - err(-h)[1]) / (2 * h) - eR @ eW) < 1e-8


def test_second_surface_power_function():
    from formsync_design.spec.sliding import dfpow, fpow

    x, eps = sp.Symbol("x", real=True), sp.Rational(1, 100)
    f = sp.lambdify(x, fpow(x, eps).doit())
    df = sp.lambdify(x, dfpow(x, eps).doit())
    for v in (-0.3, -0.01, -0.004, 0.0002, 0.009999, 0.01, 0.05):
        h = 1e-7
        if abs(abs(v) - 0.01) > 1e-6:
            assert abs((f(v + h) - f(v - h)) / (2 * h) - df(v)) < 1e-5
        assert abs(f(v) - ref.beta(np.array(v), 0.01)) < 1e-15
        assert f(v) * v >= 0
    assert abs(f(0.01 + 1e-12) - f(0.01 - 1e-12)) < 1e-9  # continuous at eps


@pytest.mark.parametrize("tf, step", [(1.0, 0.005), pytest.param(4.0, 0.002, marks=pytest.mark.slow)])
def test_reaching_law_simulation_against_an_independent_numpy_loop(design, tf, step):
    """The engine (unit quaternions, RK4, SymPy -> CasADi law) against the NumPy law with
    rotation matrices integrated directly (DOP853) on the paper's digraph; the engine's
    rotations stay on the group."""
    rng = np.random.default_rng(12)
    g = digraph_from_edges(PAPER002, name="paper002")
    J = np.array([np.diag(rng.uniform(40, 60, 3)) for _ in range(5)])
    Q = np.array([[*(math.sin(a / 2) * ax / np.linalg.norm(ax)), math.cos(a / 2)]
                  for a, ax in zip(rng.uniform(0.2, 1.2, 5), rng.normal(size=(5, 3)))])
    W = 0.1 * rng.normal(size=(5, 3))
    r = simulate_agents(design, AgentFormation(g, J, Q, W, Gains(**GAINS)),
                        AgentOptions(tf=tf, output_step=0.25, step=step))
    Rk = quats_to_matrices(r.quaternions)
    Rn, Wn = ref.simulate(quats_to_matrices(Q), W, J, g.adjacency,
                          (1.15, 0.15, 0.03, 0.03, 0.01), r.t, rtol=1e-10, atol=1e-11)
    assert np.abs(Rk - Rn).max() < 1e-6
    assert np.abs(r.rates - Wn).max() < 1e-6
    orth = np.abs(np.einsum("...ki,...kj->...ij", Rk, Rk) - np.eye(3)).max()
    assert orth < 1e-10
    # the monitors: det E = (tr^2 - 1)/8 of the error to the command, recomputed
    Rd = ref.command([(g.adjacency[0, 3], Rn[-1][3], Wn[-1][3])])[0]
    tr = np.trace(Rd.T @ Rn[-1][0])
    assert abs(r.monitors["det_E"][-1, 0] - (tr**2 - 1) / 8) < 1e-6


def test_certificate_families_are_derived_and_certified(design):
    from formsync_design.certify.agentgraphs import certify_agent_graphs
    from formsync_design.derive.agent import agent_conditions

    ac = agent_conditions(design, digraph_from_edges(PAPER002, name="paper002"))
    fams = {f.name: f for f in ac.families}
    assert set(fams) == {"Vdot_quadratic", "Vdot_power", "V_positive"}
    rows = certify_agent_graphs(design, [digraph_from_edges(PAPER002, name="p"),
                                         digraph_from_edges([(2, 1), (3, 1), (5, 4)], n=5,
                                                            name="two-roots")],
                                {"K1": "0.5:2", "K2": "0.05:0.5", "P1": "0.01:0.1",
                                 "P2": "0.01:0.1", "eps": "1/100"})
    assert [r.status for r in rows] == ["certified", "refused"]
    assert "spanning-tree" in rows[1].reason


def test_the_derivation_detects_a_wrong_law(design):
    """Drop gamma (the command's feed-forward) from the law: the reaching-law identity fails."""
    from formsync_design.derive.so3_sliding import derive_sliding

    law = design.module["tracking_law"]

    def wrong(R, W, J, Rd, Wd, Wdd, g, **kw):
        return law(R, W, J, Rd, Wd, Wdd * 0, g, **kw)

    der = derive_sliding(wrong, design.module["errors"], design.module["GAINS"])
    checks = {n: ok for n, _, ok in der.checks}
    assert checks["e_R' = E(Rt) e_W"] and not checks["s' = -K2 s - P2 sig(s) - e_R + J^-1 d"]


def test_det_E_vanishes_at_90_and_180_degrees():
    from formsync_design.derive.so3_sliding import det_E_factorisation

    d = det_E_factorisation()
    assert d["identity"] and d["cos_form"]
    assert d["at_90"]["det"] == 0 and d["at_180"]["det"] == 0


def test_comparison_designs_follow_their_reaching_laws():
    """Along short runs, s' of each comparison design (finite differences of the output)
    equals its reaching law."""
    rng = np.random.default_rng(3)
    g = digraph_from_edges(PAPER002, name="paper002")
    J = np.array([np.diag(rng.uniform(40, 60, 3)) for _ in range(5)])
    Q = np.array([[*(math.sin(0.4) * ax / np.linalg.norm(ax)), math.cos(0.4)]
                  for ax in rng.normal(size=(5, 3))])
    W = 0.05 * rng.normal(size=(5, 3))
    d = load_design("ma_quat_smc")
    r = simulate_agents(d, AgentFormation(g, J, Q, W, Gains(K1=1.15, K2=0.15, P2=0.03)),
                        AgentOptions(tf=1, output_step=0.001, step=0.001, switch="tanh", phi=0.01))
    A = g.adjacency
    q = r.quaternions

    def s_of(k, i):
        eps = np.zeros(3)
        for j in range(5):
            if A[i, j]:
                qi, qj = q[k, i], q[k, j]
                eps += A[i, j] * (qj[3] * qi[:3] - qi[3] * qj[:3] - np.cross(qj[:3], qi[:3]))
        return r.rates[k, i] + 1.15 * eps

    for k in (200, 600):
        for i in range(5):
            sd = (s_of(k + 1, i) - s_of(k - 1, i)) / 0.002
            s = s_of(k, i)
            assert np.abs(sd - (-0.15 * s - 0.03 * np.tanh(s / 0.01))).max() < 2e-4
    dm = load_design("ma_mrp_ft")
    rm = simulate_agents(dm, AgentFormation(g, J, Q, W, Gains(**GAINS)),
                         AgentOptions(tf=0.5, output_step=0.1, step=0.005))
    assert rm.monitors["sigma_norm"].max() < 1


def test_case_and_claims_configuration():
    from formsync_design.errors import InputError
    from formsync_design.resources import case_file
    from formsync_design.tomlio import load_toml
    from formsync_design.verify.agentcase import euler321_to_quat, load_agent_case
    from formsync_design.verify.enginecase import load_engine_case, parse_engine_case

    c = load_agent_case(case_file("ma_so3"))
    assert c.kind == "engine" and c.n == 5
    e = load_engine_case(case_file("ma_so3"))
    assert [(s.name, s.run_design.name) for s in e.scenarios[:5]] == [
        ("so3", "ma_so3"), ("quat", "ma_quat_smc"), ("mrp", "ma_mrp_ft"),
        ("quat_eq", "ma_quat_smc"), ("mrp_eq", "ma_mrp_ft")]
    assert e.scenario("quat").case.options.switch == "tanh"
    assert e.scenario("mrp_eq").torque_matching["hold"] == ["eps"]
    two = e.case_for("case2", "so3")
    assert np.allclose(two.attitudes[1], euler321_to_quat(100, -75, -120), atol=0, rtol=0)
    assert np.array_equal(two.rates, c.rates) and two.options.tf == 80.0
    near = e.case_for("near180", "quat")
    assert near.options.tf == 120.0 and near.options.switch == "tanh"
    ang = [2 * np.degrees(np.arccos(min(1.0, abs(q[3])))) for q in near.attitudes[1:]]
    assert np.allclose(ang, 175.0)
    data = load_toml(case_file("ma_so3"), "case")
    data["scenarios"][1]["gains"] = {"K1": 1.0}
    with pytest.raises(InputError, match="gain"):
        parse_engine_case(data, "x.toml")


@pytest.mark.slow
def test_formsync_verify_ma_so3(tmp_path, monkeypatch):
    monkeypatch.delenv("FORMSYNC_NO_COMPILE")
    from formsync_design.cli.main import main

    assert main(["verify", "ma_so3", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "ma_so3-verification.md").read_text()
    assert "| consensus | every spacecraft converges to a common attitude (case 1) |" in text
    assert "| ordering |" in text and "| scale_quat_eq | gain_scale |" in text
    assert (tmp_path / "figures" / "ma_so3-verification").is_dir()


@pytest.mark.slow
def test_the_case_stays_on_the_group(monkeypatch):
    """Case 1 of verification/ma_so3.toml over its whole horizon, every method: |R^T R - I|
    < 1e-10."""
    monkeypatch.delenv("FORMSYNC_NO_COMPILE")
    from formsync_design.models.euler import quats_to_matrices
    from formsync_design.resources import case_file
    from formsync_design.verify.engine import EngineResults
    from formsync_design.verify.enginecase import load_engine_case

    res = EngineResults(load_engine_case(case_file("ma_so3")))
    for s in ("so3", "quat", "mrp"):
        R = quats_to_matrices(res.run("case1", s).quaternions)
        assert np.abs(np.einsum("...ki,...kj->...ij", R, R) - np.eye(3)).max() < 1e-10, s
