"""Designs as plug-ins: the declarations contract, a second design (PD consensus) through
derive and certify, multipliers, diagonal gains, and the command line.

Independent truths: the PD closed loop recomputed numerically from random model matrices;
the PD coupling matrix against the hand-derived formula ``diag(k_d I - eps L, eps k_p I)``;
the brute-force symbolic V' (a second derivation); family eigenvalues at sampled points.
"""

from __future__ import annotations

import json
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from formsync_design.certify.engine import certify_box
from formsync_design.certify.multipliers import certify_with_multipliers, multiplier_grid
from formsync_design.certify.results import Status
from formsync_design.derive.closed_loop import derive_closed_loop
from formsync_design.derive.conditions import brute_force_vdot, derive_conditions
from formsync_design.errors import DerivationError, InputError
from formsync_design.gains import GainRange
from formsync_design.graphs import make_graph
from formsync_design.spec.declarations import CLASSIC, GainKind, GainRole, parse_declarations
from formsync_design.spec.loader import Spec, load_spec

PD = "pd_consensus"


def _formsync(*args: str) -> subprocess.CompletedProcess:
    exe = str(Path(sys.executable).with_name("formsync"))
    cmd = [exe] if Path(exe).exists() else [sys.executable, "-c",
                                             "import sys; from formsync_design.cli.main import main; "
                                             "sys.exit(main())"]
    return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=300)


# --------------------------------------------------------------------------- contract
def test_shipped_designs_declare_their_parts():
    liang = load_spec("liang2016")
    assert liang.decl == CLASSIC and liang.gains == ("K_o", "K_q", "beta")
    pd = load_spec(PD)
    assert pd.gains == ("k_p", "k_d", "eps")
    assert pd.decl.multipliers == ("eps",) and pd.decl.switching is None
    assert pd.decl.gain("eps").role == GainRole.MULTIPLIER
    assert pd.decl.gain("k_p").range == GainRange("k_p", Fraction(1, 10), Fraction(2))


@pytest.mark.parametrize("attrs, part", [
    ({"GAINS": {"k": {}, "A": {}}}, "GAINS['A']"),
    ({"GAINS": {"k": {"role": "boss"}}}, "GAINS['k'].role"),
    ({"GAINS": {"k": {"kind": "full"}}}, "GAINS['k'].kind"),
    ({"GAINS": {"k": {"range": "2:1"}}}, "GAINS['k'].range"),
    ({"GAINS": {"k": {"range": "-1:1"}}}, "GAINS['k'].range"),
    ({"GAINS": {"k": {"color": 1}}}, "GAINS['k']"),
    ({"GAINS": {"e": {"role": "multiplier", "range": "0.1:1"}}}, "GAINS"),
    ({"GAINS": {"k": {}, "e": {"role": "multiplier"}}}, "GAINS['e'].range"),
    ({"GAINS": ["a", "a"]}, "GAINS"),
    ({"GAINS": "k_p"}, "GAINS"),
    ({"REPRESENTATION": "euler"}, "REPRESENTATION"),
    ({"GRAPHS": ("connected-ish",)}, "GRAPHS"),
    ({"SAMPLING": "sometimes"}, "SAMPLING"),
])
def test_bad_declarations_are_one_line_errors_naming_the_part(attrs, part):
    with pytest.raises(DerivationError) as e:
        parse_declarations(attrs, "my_design.py")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"my_design.py: {part}") and "expected" in msg


def _write(tmp_path, body: str, name: str = "d.py"):
    p = tmp_path / name
    p.write_text(body)
    return p


_PD_BODY = '''
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3"%s},
         "eps": {"role": "multiplier", "range": "0.001:1"}}
def controller(v):
    return v.Q.I.T * (%s)
def lyapunov(v):
    c = (v.k_p + v.eps * v.k_d) / 4
    return c * sum((e.dot(e) for e in v.edges), 0) + v.qd.dot(v.qd) / 2 + v.eps * sum(
        (e.dot(v.qd) for e in v.edges), 0)
'''


def test_design_file_using_an_undeclared_quantity_is_refused(tmp_path):
    p = _write(tmp_path, _PD_BODY % ("", "(v.B - v.K_o * v.A) * v.qd - v.k_p * v.A * v.s"))
    with pytest.raises(DerivationError) as e:
        load_spec(str(p))
    assert str(p) in str(e.value) and "view.K_o" in str(e.value)
    r = _formsync("derive", "--design", str(p), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and r.stderr.count(": error: ") == 1 and "view.K_o" in r.stderr


def test_design_file_without_lyapunov_is_refused(tmp_path):
    p = _write(tmp_path, "GAINS = ['k']\ndef controller(v):\n    return -v.k * v.qd\n")
    r = _formsync("certify", "--design", str(p), "--graph", "ring:4", "--gain", "k=1")
    assert r.returncode == 2 and "expected a function lyapunov(view)" in r.stderr


def test_unknown_design_name_is_input_error():
    with pytest.raises(InputError, match="expected a design name"):
        load_spec("no_such_design")


# --------------------------------------------------------------------------- PD derivation
def test_pd_closed_loop_matches_numeric_model_cancellation():
    cl = derive_closed_loop(PD)
    kp, kd = sp.symbols("k_p k_d", positive=True)
    assert sp.simplify(cl.c_qd + kd) == 0 and sp.simplify(cl.c_s + kp) == 0 and cl.c_sigma == 0
    # independent: numeric A, B, Q (random, invertible), u from the printed law, q'' from the model
    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3)) + 4 * np.eye(3)
    B = rng.normal(size=(3, 3))
    Q = rng.normal(size=(3, 3)) + 3 * np.eye(3)
    qd, s = rng.normal(size=3), rng.normal(size=3)
    k_p, k_d = 0.7, 1.9
    u = np.linalg.solve(Q.T, (B - k_d * A) @ qd - k_p * A @ s)
    qdd = np.linalg.solve(A, Q.T @ u - B @ qd)
    np.testing.assert_allclose(qdd, -k_d * qd - k_p * s, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("graph", ["ring:6", "star:5", "random:7:0.5:3", "path:4"])
def test_pd_pi_equals_hand_formula(graph):
    g = make_graph(graph)
    c = derive_conditions(g, PD)
    L = np.asarray(g.laplacian, dtype=float)
    n = g.n
    rng = np.random.default_rng(11)
    for _ in range(3):
        kp, kd, eps = rng.uniform(0.1, 3, size=3)
        want = np.zeros((2 * n, 2 * n))
        want[:n, :n] = kd * np.eye(n) - eps * L
        want[n:, n:] = eps * kp * np.eye(n)
        np.testing.assert_allclose(c.pi.evaluate((kp, kd, eps)), want, atol=1e-12)


def test_pd_brute_force_vdot_agrees_with_assembled_form():
    b, a = brute_force_vdot("path:3", PD)
    assert sp.expand(b - a) == 0


# --------------------------------------------------------------------------- certification
def test_pd_certified_on_star_and_complete_where_liang_is_refuted():
    pd = load_spec(PD)
    mult = {"eps": pd.decl.gain("eps").range}
    for graph in ("star:8", "complete:8"):
        r = certify_with_multipliers(derive_conditions(graph, PD), {"k_p": (0.2, 2), "k_d": (1, 3)},
                                     mult)
        assert r.status == Status.CERTIFIED, (graph, r.reason)
        eps = r.box["eps"].lo
        assert eps in multiplier_grid(mult["eps"])
        # independent: the hand-derived conditions hold at the box's vertices with that eps
        lam = max(np.linalg.eigvalsh(np.asarray(make_graph(graph).laplacian, dtype=float)))
        m = max(make_graph(graph).degrees)
        for kp in (0.2, 2):
            for kd in (1, 3):
                c = (kp + float(eps) * kd) / 4
                assert kd - float(eps) * lam > 0 and c / 2 - m * float(eps) ** 2 / 4 > 0


def test_pd_fixed_multiplier_refutes_with_exact_witness_but_search_does_not_refute():
    c = derive_conditions("star:8", PD)
    r = certify_box(c, {"k_p": 1, "k_d": "0.5", "eps": 1})
    assert r.status == Status.REFUTED and r.witness is not None
    # exact re-check of the witness: x^T F x <= 0 at the witness point
    fam = next(f for f in c.families if f.name == r.witness.family)
    F = fam.to_sympy(sp.symbols("k_p k_d eps", positive=True))
    pt = {sp.Symbol(k, positive=True): sp.Rational(str(v)) for k, v in r.witness.point.items()}
    x = sp.Matrix([sp.Rational(v) for v in r.witness.x])
    assert (x.T * F.subs(pt) * x)[0, 0] <= 0
    # a grid of multipliers none of which works: undecided, never refuted
    r2 = certify_with_multipliers(c, {"k_p": 1, "k_d": "0.5"},
                                  {"eps": GainRange("eps", Fraction(9, 10), Fraction(1))})
    assert r2.status == Status.UNDECIDED and r2.witness is None and "not the design" in r2.reason


def test_multiplier_grid_is_exact_inside_and_reproducible():
    r = GainRange("eps", Fraction(1, 1000), Fraction(1))
    g = multiplier_grid(r)
    assert g[0] == r.lo and g[-1] == r.hi and g == sorted(g) and len(set(g)) == len(g)
    assert all(isinstance(v, Fraction) and r.lo <= v <= r.hi for v in g)
    assert g == multiplier_grid(r)


# --------------------------------------------------------------------------- diagonal gains
_DIAG_OK = "v.B * v.qd - v.A * v.k_d * v.qd - v.k_p * v.A * v.s"
_DIAG_BAD = "v.B * v.qd - v.k_d * v.A * v.qd - v.k_p * v.A * v.s"


def test_diagonal_gain_acting_after_cancellation_is_per_axis(tmp_path):
    spec = load_spec(str(_write(tmp_path, _PD_BODY % (', "kind": "diag"', _DIAG_OK))))
    assert spec.decl.gain("k_d").kind == GainKind.DIAG
    cl = derive_closed_loop(spec)
    assert cl.c_qd == -sp.Symbol("k_d", positive=True)
    # the per-axis families are those of the scalar design
    a = derive_conditions("ring:5", spec).pi.evaluate((0.7, 1.3, 0.2))
    b = derive_conditions("ring:5", PD).pi.evaluate((0.7, 1.3, 0.2))
    np.testing.assert_allclose(a, b)


def test_diagonal_gain_before_the_model_is_refused(tmp_path):
    spec = load_spec(str(_write(tmp_path, _PD_BODY % (', "kind": "diag"', _DIAG_BAD))))
    with pytest.raises(DerivationError, match="diagonal gain must act after"):
        derive_closed_loop(spec)


def test_from_functions_with_declared_gains():
    def controller(v):
        return v.Q.I.T * ((v.B - v.kd * v.A) * v.qd - v.kp * v.A * v.s)

    def lyapunov(v):
        return v.qd.dot(v.qd) / 2 + v.kp / 4 * sum((e.dot(e) for e in v.edges), 0)

    s = Spec.from_functions(controller, lyapunov, name="pd0", gains=["kp", "kd"])
    assert s.gains == ("kp", "kd")
    assert s.key != Spec.from_functions(controller, lyapunov, name="pd0", gains=["kp", "kd", "z"]).key


# --------------------------------------------------------------------------- command line
def test_cli_certify_pd_searches_the_multiplier_and_spec_is_an_alias():
    r = _formsync("certify", "--design", PD, "--graph", "star:8", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["status"] == "certified" and "multiplier eps" in doc["reason"]
    r2 = _formsync("certify", "--spec", PD, "--graph", "star:8", "--gain", "k_p=1",
                   "--gain", "k_d=0.5", "--gain", "eps=1")
    assert r2.returncode == 1 and r2.stdout.startswith("REFUTED")
    assert "with the given multiplier eps only" in r2.stdout


@pytest.mark.parametrize("args, needle", [
    (["--design", PD, "--ko", "1"], "--ko (K_o)"),
    (["--design", PD, "--gain", "k_q=1"], "received ['k_q']"),
    (["--gain", "K_v=1", "--ko", "1", "--kq", "1", "--beta", "1"], "switching gain K_v"),
    (["--kq", "1", "--beta", "1"], "expected a value for gain K_o"),
    (["--design", PD, "--gain", "k_p"], "expected --gain NAME=X"),
    (["--design", PD, "--gain", "k_p=1", "--gain", "k_p=2"], "twice"),
])
def test_cli_gain_errors_are_one_line(args, needle):
    r = _formsync("certify", "--graph", "ring:4", *args)
    assert r.returncode == 2 and needle in r.stderr and r.stderr.count("\n") == 1, r.stderr


def test_cli_derive_pd_numeric_and_report(tmp_path):
    r = _formsync("derive", "--design", PD, "--graph", "ring:4", "--gain", "k_p=1",
                  "--gain", "k_d=2", "--gain", "eps=0.1", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["gains"] == {"k_p": 1.0, "k_d": 2.0, "eps": 0.1} and doc["specification"] == PD
    r = _formsync("derive", "--design", PD, "--graph", "ring:4", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    md = (tmp_path / "pd_consensus-derivation-ring4.md").read_text()
    assert "## Design declarations" in md and "agrees identically" in md
    assert "no switching term" in md


def test_cli_simulate_pd_and_gain_errors():
    r = _formsync("simulate", "--design", PD, "--graph", "star:8", "--gain", "k_p=0.5",
                  "--gain", "k_d=1.5", "--tf", "60", "--format", "json")
    assert r.returncode in (0, 1), r.stderr
    doc = json.loads(r.stdout)
    assert doc["gains"] == {"k_p": 0.5, "k_d": 1.5} and doc["specification"] == PD
    # on the paper's case (which has no gain k_d) a missing gain is an error; --design alone
    # takes the design's shipped case, which has k_d (issue 25)
    for extra, needle in ((["--gain", "k_p=0.5"], "expected --gain k_d=X"),
                          (["--gain", "k_p=0.5", "--gain", "k_d=1:2"], "single value"),
                          (["--gain", "k_p=0.5", "--gain", "k_d=1", "--gain", "K_o=1"],
                           "received ['K_o']")):
        r = _formsync("simulate", "--design", PD, "--case", "liang2016", "--graph", "star:8",
                      *extra)
        assert r.returncode == 2 and needle in r.stderr and r.stderr.count("\n") == 1, r.stderr


def test_pd_simulation_matches_the_linear_closed_loop_exactly():
    """Independent truth: after the model cancellation the PD loop is exactly
    q'' = -k_d q' - k_p (L (x) I3) q (no disturbance), solved by a matrix exponential."""
    from scipy.linalg import expm

    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim import Formation, Gains, SimOptions, simulate

    g = make_graph("star:5")
    n = g.n
    rng = np.random.default_rng(5)
    q = rng.uniform(-0.2, 0.2, size=(n, 3))
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    w = rng.uniform(-0.02, 0.02, size=(n, 3))
    J = np.array([np.diag(rng.uniform(40, 70, 3)) for _ in range(n)])
    kp, kd = 0.4, 1.1
    f = Formation(g, J, att, w, Gains(k_p=kp, k_d=kd), no_disturbance(n))
    r = simulate(f, SimOptions(tf=20, step=0.01), spec=load_spec(PD))
    # q' = E(q) w with E = (q0 I + q^x)/2
    qd0 = np.array([0.5 * (a[3] * wi + np.cross(a[:3], wi)) for a, wi in zip(att, w)])
    L = np.asarray(g.laplacian, dtype=float)
    M = np.block([[np.zeros((n, n)), np.eye(n)], [-kp * L, -kd * np.eye(n)]])
    for k in (50, 100, 200):
        z = expm(M * r.t[k]) @ np.vstack([q, qd0])  # per axis in columns
        sim_q = r.x[k, : 4 * n].reshape(n, 4)[:, :3]
        np.testing.assert_allclose(sim_q, z[:n], atol=1e-8)


# --------------------------------------------------------------------------- verification
def test_verify_pd_case_judges_every_claim_by_computation():
    from formsync_design.resources import case_file
    from formsync_design.verify.engine import run_engine
    from formsync_design.verify.enginecase import load_engine_case

    case = load_engine_case(case_file("pd_consensus"))
    ver = run_engine(case)
    v = {row.id: val for row, val in ver.metrics}
    assert case.base.design.name == PD
    for f in ("ring4", "path4", "star4", "complete4"):  # every claim measured on this design
        assert v[f"theta_{f}"].value == "certified" and v[f"pi_{f}"].value == "certified"
        assert isinstance(v[f"t_{f}"].value, float) and v[f"t_{f}"].bound == "exact"
    assert {c.claim.id: c.verdict for c in ver.claims}["rates_to_zero"] == "holds"


def test_case_gains_follow_the_design(tmp_path):
    from formsync_design.resources import case_file
    from formsync_design.verify.case import load_case

    text = case_file("pd_consensus").read_text()
    c = load_case(case_file("pd_consensus"))
    assert c.gains.as_dict() == {"k_p": 0.4, "k_d": 1.6} and c.spec == PD
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("\nk_d = 1.6\n", "\nk_d = 1.6\nK_v = 0.01\n"))
    with pytest.raises(InputError, match=r"received unknown \['K_v'\]"):
        load_case(bad)
    bad.write_text(text.replace("\nk_d = 1.6\n", "\n"))
    with pytest.raises(InputError, match="expected gains.k_d"):
        load_case(bad)
    kv_metric = text + '\n[[metrics]]\nid = "kv"\nmetric = "switching_gain_ratio"\n'
    bad.write_text(kv_metric)
    r = _formsync("verify", str(bad), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "no switching gain" in r.stderr


# --------------------------------------------------------------------------- region
@pytest.mark.parametrize("graph", ["ring:6", "star:6", "random:7:0.5:4"])
def test_pd_region_equals_the_hand_conditions_cell_by_cell(graph):
    """Independent truth: Theta(m) > 0 iff (k_p + eps k_d)/8 > m eps^2/4, Pi > 0 iff
    k_d > eps lambda_max(L) (and eps k_p > 0); the families are multi-affine, so a cell is
    certified for a given eps iff the conditions hold at its four corners."""
    from formsync_design.certify.multiregion import region_with_multipliers
    from formsync_design.certify.subdivision import rasterize

    g = make_graph(graph)
    eps_range = GainRange("eps", Fraction(1, 20), Fraction(2))
    R = 8
    m = region_with_multipliers(derive_conditions(g, PD), {"k_p": (0.05, 1), "k_d": (0.05, 1)},
                                {"eps": eps_range}, resolution=R)
    lam = float(max(np.linalg.eigvalsh(np.asarray(g.laplacian, dtype=float))))
    mmax = max(g.degrees)
    grid = np.linspace(0.05, 1, R + 1)

    def ok(kp, kd, e):
        return (kp + e * kd) / 8 - mmax * e**2 / 4 > 1e-12 and kd - e * lam > 1e-12

    ras = rasterize(m)[:, :, 0]
    for i in range(R):
        for j in range(R):
            want = any(all(ok(kp, kd, float(e)) for kp in grid[i:i + 2] for kd in grid[j:j + 2])
                       for e in multiplier_grid(eps_range))
            assert (ras[i, j] == 1) == want, (i, j)
    assert m.fractions["refuted"] == 0.0 and 0 < m.fractions["certified"] < 1


# --------------------------------------------------------------------------- sampled control
def _pd_torque_first_principles(q, q0, w, J, s, kp, kd):
    """u = Q^-T[(B - k_d A) q' - k_p A s] rewritten with A = Q^T J Q, B q' = Q^T(J Q' q' + w x J w),
    Q = E^-1, Q' q' = -Q E' w (quaternion kinematics only; no library model)."""
    def skew(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    E = 0.5 * (q0 * np.eye(3) + skew(q))
    Q = np.linalg.inv(E)
    qd, q0d = E @ w, -0.5 * q @ w
    Ed = 0.5 * (q0d * np.eye(3) + skew(qd))
    return -J @ Q @ Ed @ w + np.cross(w, J @ w) - kd * J @ w - kp * J @ Q @ s


def test_sampled_pd_matches_an_independent_zoh_loop():
    from scipy.integrate import solve_ivp

    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim import Formation, Gains, SimOptions
    from formsync_design.sim.sampled import parse_trigger, simulate_sampled

    g = make_graph("path:4")
    n, kp, kd, T, tf = 4, 0.6, 1.4, 0.5, 20.0
    rng = np.random.default_rng(17)
    q = rng.uniform(-0.2, 0.2, size=(n, 3))
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    w0 = rng.uniform(-0.02, 0.02, size=(n, 3))
    J = np.array([np.diag(rng.uniform(40, 70, 3)) + 0.5 for _ in range(n)])
    f = Formation(g, J, att, w0, Gains(k_p=kp, k_d=kd), no_disturbance(n))
    r = simulate_sampled(f, SimOptions(tf=tf), parse_trigger(f"periodic:{T}"), PD)
    A = np.asarray(g.adjacency)
    x = np.column_stack([att, w0])  # (q1..3, q0, w1..3)
    for k in range(int(tf / T)):
        held = x.copy()
        U = np.array([_pd_torque_first_principles(
            held[i, :3], held[i, 3], held[i, 4:], J[i],
            sum((held[i, :3] - held[j, :3] for j in np.flatnonzero(A[i])), np.zeros(3)), kp, kd)
            for i in range(n)])

        def rhs(t, y, U=U):
            X = y.reshape(n, 7)
            out = np.empty_like(X)
            for i in range(n):
                qi, q0i, wi = X[i, :3], X[i, 3], X[i, 4:]
                out[i, :3] = 0.5 * (q0i * wi + np.cross(qi, wi))
                out[i, 3] = -0.5 * qi @ wi
                out[i, 4:] = np.linalg.solve(J[i], -np.cross(wi, J[i] @ wi) + U[i])
            return out.ravel()

        sol = solve_ivp(rhs, (k * T, (k + 1) * T), x.ravel(), method="DOP853", rtol=1e-12,
                        atol=1e-14)
        x = sol.y[:, -1].reshape(n, 7)
    # the one SimResult of a formation run: (q1..3, q0) and rates at the final time
    np.testing.assert_allclose(np.column_stack([r.quaternions[-1], r.rates[-1]]), x, atol=1e-8)
    assert r.transmissions.tolist() == [int(tf / T)] * n
    assert type(r).__name__ == "SimResult" and r.integrator == "hybrid-dop853"
    # the held torques: each spacecraft's torque is constant between its broadcasts
    k = int(round(0.25 / 0.1))  # inside the first hold interval [0, T)
    np.testing.assert_array_equal(r.torques[k], r.torques[0])


def test_event_triggered_pd_transmits_less_and_still_synchronizes():
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim import Formation, Gains, SimOptions
    from formsync_design.sim.sampled import parse_trigger, simulate_sampled

    g = make_graph("ring:4")
    q = np.array([[0.2, 0.0, 0.1], [-0.1, 0.1, 0.0], [0.0, -0.2, 0.1], [0.1, 0.1, -0.2]])
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    f = Formation(g, np.array([np.diag([50.0, 55, 60])] * 4), att, np.zeros((4, 3)),
                  Gains(k_p=0.5, k_d=1.5), no_disturbance(4))
    opt = SimOptions(tf=80, q_tol=1e-3, omega_tol=1e-4)
    per = simulate_sampled(f, opt, parse_trigger("periodic:0.1"), PD)
    record: dict = {}
    ev = simulate_sampled(f, opt, parse_trigger("event:0.05:1e-5"), PD, record=record)
    assert per.converged and ev.converged
    assert ev.transmissions.sum() < per.transmissions.sum()
    assert [len(ts) for ts in ev.trigger_times] == ev.transmissions.tolist()
    # every event after the first broadcast happened because the error reached at least
    # the floor of its threshold (the rule was monitored, not a clock)
    for states in record["hybrid"].trigger_states:
        S = np.asarray(states)
        assert len(S) > 1
        assert (np.linalg.norm(np.diff(S[:, :3], axis=0), axis=1) >= 1e-5 * (1 - 1e-6)).all()


def test_cli_simulate_trigger_reports_transmissions():
    r = _formsync("simulate", "--case", "pd_consensus", "--trigger", "periodic:0.5",
                  "--tf", "100", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["transmissions"] == [200] * 4 and doc["trigger"] == "periodic:0.5"
    r = _formsync("simulate", "--case", "pd_consensus", "--trigger", "event:0:0")
    assert r.returncode == 2 and "SIGMA > 0 or FLOOR > 0" in r.stderr


def test_cli_sweep_takes_the_design_s_gains_only(tmp_path):
    # the sweep of the PD design itself is tested in tests/test_cli_sweep.py
    r = _formsync("sweep", "--graphs", "ring:4..5", "--design", PD, "--ko", "1:2",
                  "--out", str(tmp_path / "s"))
    assert r.returncode == 2 and "controller gains of design pd_consensus (k_p, k_d)" in r.stderr
    assert not (tmp_path / "s").exists()


def test_a_representation_the_engine_cannot_derive_is_refused(tmp_path):
    p = _write(tmp_path, 'REPRESENTATION = "mrp"\n' + _PD_BODY % ("", "(v.B - v.k_d * v.A) * v.qd - v.k_p * v.A * v.s"))
    spec = load_spec(str(p))  # the declarations are valid: mrp is in the model library
    assert spec.representation == "mrp"
    for args in (["derive", "--design", str(p), "--out", str(tmp_path / "o")],
                 ["certify", "--design", str(p), "--graph", "ring:4"],
                 ["simulate", "--design", str(p), "--gain", "k_p=1", "--gain", "k_d=1"]):
        r = _formsync(*args)
        assert r.returncode == 2 and "REPRESENTATION" in r.stderr and "'mrp'" in r.stderr, r.stderr


def test_cli_region_for_the_pd_design(tmp_path):
    r = _formsync("region", "--design", PD, "--graph", "star:6", "--gain", "k_p=0.01:2",
                  "--gain", "k_d=0.001:2", "--resolution", "8", "--out", str(tmp_path),
                  "--format", "json", "--no-progress")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    f = doc["maps"][0]["fractions"]
    assert f["refuted"] == 0 and 0.8 < f["certified"] < 1  # the cell at k_d -> 0 stays undecided
    assert (tmp_path / "region.json").is_file() and (tmp_path / "pd_consensus-region-k_p-k_d.png").is_file()
    r = _formsync("region", "--design", PD, "--graph", "star:6", "--out", str(tmp_path / "b"),
                  "--beta-slices", "0.1")
    assert r.returncode == 2 and "--beta-slices" in r.stderr


def test_cli_design_for_the_pd_design_holds_the_multiplier_in_the_box():
    r = _formsync("design", "--design", PD, "--graph", "star:6", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["status"] == "designed" and set(doc["gains"]) == {"k_p", "k_d", "eps"}
    lo, hi = doc["largest_certified_box"]["eps"]
    assert lo == hi == doc["gains"]["eps"]  # one Lyapunov candidate for the whole box
    assert doc["box_certificate"]["status"] == "certified"
    # the constrained design takes the PD design's own gains (issue 15: any design)
    r = _formsync("design", "--design", PD, "--graph", "star:6", "--min-delay", "0.1", "--grid", "2",
                  "--format", "json")
    assert r.returncode == 0, r.stderr
    assert set(json.loads(r.stdout)["gains"]) == {"k_p", "k_d"}
