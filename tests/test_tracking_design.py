"""The relative-orbit plant of the one design contract and the attitude-law derivation
(issues 14 and 23).

* the design file loads as an agent design on the relative-orbit plant; malformed designs
  and misplaced declarations are one-line DerivationErrors; the attitude-plant designs are
  unchanged;
* the formation stages refuse a design on the relative-orbit plant (exit 1, one line);
* the derivation's V' = -w^T K_d w and its mismatch term against a numeric closed loop
  (numpy, finite differences of V along the flow) at random states, inertias and rates;
* the linearization (A0, N, d) against a finite-difference Jacobian of the numeric loop.
"""

from __future__ import annotations

import numpy as np
import pytest

from formsync_design.derive.tracking import derive_tracking_attitude, mrp_matrix_symbolic
from formsync_design.errors import DerivationError
from formsync_design.models.mrp import mrp_rate_matrix, mrp_to_matrix
from formsync_design.spec.agent import agent_expressions
from formsync_design.spec.declarations import parse_declarations
from formsync_design.spec.loader import load_design
from formsync_design.spec.tracking import tracking_expressions

DESIGN = load_design("zhang2014_flyaround")


def test_design_loads_on_the_relative_orbit_plant():
    d = DESIGN.decl
    assert DESIGN.form == "agent"
    assert (d.plant, d.actuators, d.representation, d.graphs, d.leader, d.sampling) == (
        "relative-orbit", "thrusters", "mrp", (), True, "periodic")
    assert [g.name for g in d.gains] == ["q_r", "q_v", "r_u", "k_p", "K_d"]
    assert set(DESIGN.functions) == {"controller", "lyapunov", "orbit_controller",
                                     "lqr_weights"}
    ex = tracking_expressions(DESIGN)
    assert ex.Q.shape == (6, 6) and ex.R.shape == (3, 3)
    assert d.to_dict()["plant"] == "relative-orbit"
    # the attitude plant's content keys are unchanged (no plant/actuators keys)
    assert "plant" not in load_design("ma_so3").decl.to_dict()
    assert "kind" not in load_design("liang2016").lagrangian.decl.to_dict()


_GOOD = """
import sympy as sp
FORM = "agent"
PLANT = "relative-orbit"
REPRESENTATION = "mrp"
LEADER = True
GRAPHS = ()
SAMPLING = "periodic"
GAINS = {"k": {}, "w": {"role": "weight"}}
def controller(v): return -v.k * v.track.sigma
def lyapunov(v): return v.track.sigma.dot(v.track.sigma)
def orbit_controller(v): return -v.K * v.dX + v.ff
def lqr_weights(v): return (v.w * sp.eye(6), sp.eye(3))
"""


@pytest.mark.parametrize("edit, needle", [
    (("def orbit_controller(v): return -v.K * v.dX + v.ff\n", ""),
     "expected a function orbit_controller(view) on the relative-orbit plant"),
    (("return -v.k * v.track.sigma", "return v.track.sigma.T"),
     "controller(view): expected an explicit 3x1"),
    (("return -v.k * v.track.sigma", "return v.nothing"), "expected an attribute of the view"),
    # the plant measures the tracking error: the absolute attitude is not in its view
    (("return -v.k * v.track.sigma", "return -v.k * v.sigma"),
     "expected an attribute of the view"),
    (("return -v.K * v.dX + v.ff", "return -v.K * v.dX + v.ff + v.sigma"),
     "orbit_controller(view): expected an attribute of the view"),
    (('REPRESENTATION = "mrp"', 'REPRESENTATION = "so3"'), "REPRESENTATION: expected 'mrp'"),
    (("LEADER = True", "LEADER = False"), "LEADER: expected True"),
    (('SAMPLING = "periodic"', 'SAMPLING = "continuous"'), "SAMPLING: expected 'periodic'"),
    (("GRAPHS = ()", 'GRAPHS = ("undirected",)'), "GRAPHS: expected ()"),
    (('PLANT = "relative-orbit"', 'PLANT = "swarm"'), "PLANT: expected one of"),
    (('PLANT = "relative-orbit"', 'PLANT = "relative-orbit"\nACTUATORS = "torque"'),
     "ACTUATORS: expected 'thrusters'"),
    (('PLANT = "relative-orbit"', 'KIND = "tracking"'), "KIND: expected no KIND"),
    (("return (v.w * sp.eye(6), sp.eye(3))", "return v.w"), "expected a pair (Q, R)"),
    (("def lqr_weights", "def monitors(v): return {}\ndef lqr_weights"),
     "expected only ['controller', 'lyapunov', 'orbit_controller', 'lqr_weights']"),
])
def test_malformed_relative_orbit_design_is_one_line(tmp_path, edit, needle):
    p = tmp_path / "d.py"
    p.write_text(_GOOD.replace(*edit))
    with pytest.raises(DerivationError) as e:
        load_design(str(p))
    assert needle in str(e.value) and "\n" not in str(e.value) and str(p) in str(e.value)


def test_good_relative_orbit_design_and_weight_only_on_that_plant(tmp_path):
    p = tmp_path / "d.py"
    p.write_text(_GOOD)
    assert load_design(str(p)).decl.plant == "relative-orbit"
    with pytest.raises(DerivationError, match="weights .role 'weight'. only on the relative-orbit"):
        parse_declarations({"GAINS": {"k": {}, "w": {"role": "weight"}}}, "x.py")
    # the attitude plant's torque actuators only
    q = tmp_path / "e.py"
    q.write_text('FORM = "agent"\nACTUATORS = "thrusters"\nGAINS = {"k": {}}\n'
                 "def controller(v): return -v.k * v.w\n")
    with pytest.raises(DerivationError, match="ACTUATORS: expected 'torque' on the attitude"):
        load_design(str(q))


def test_formation_stages_refuse_a_relative_orbit_design(capsys, tmp_path):
    from formsync_design.cli.main import main

    with pytest.raises(DerivationError, match="on the relative-orbit plant"):
        agent_expressions(DESIGN, 1)
    # derive applies (V' of the attitude loop); the graph stages do not: exit 1, one line
    assert main(["derive", "--design", "zhang2014_flyaround"]) == 0
    assert "attitude loop derived" in capsys.readouterr().out
    for argv in (["simulate", "--design", "zhang2014_flyaround", "--tf", "1"],
                 ["certify", "--design", "zhang2014_flyaround", "--graph", "ring:4"],
                 ["montecarlo", "--design", "zhang2014_flyaround", "--runs", "2"],
                 ["region", "--design", "zhang2014_flyaround"],
                 ["design", "--design", "zhang2014_flyaround"],
                 ["sweep", "--design", "zhang2014_flyaround"]):
        assert main(argv) == 1, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "not applicable: design zhang2014_flyaround" in err[0], err
    for argv in (["verify", "liang2016", "--design", "zhang2014_flyaround",
                  "--out", str(tmp_path / "v")],
                 ["verify", "zhang2014_flyaround", "--design", "liang2016",
                  "--out", str(tmp_path / "w")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Traceback" not in err[0], err


# ----- the derivation against a numeric closed loop

def _numeric_loop(rng, jhat_equal: bool):
    j = np.diag(rng.uniform(2000, 4000, 3)) + 0.0
    j[0, 1] = j[1, 0] = rng.uniform(-50, 50)
    jh = j if jhat_equal else j + np.diag(rng.uniform(-200, 200, 3))
    kp = rng.uniform(100, 1000)
    kd = np.diag(rng.uniform(100, 2000, 3))
    w_di = rng.normal(size=3) * 1e-2
    a_di = rng.normal(size=3) * 1e-3

    def flow(x):
        sig, w = x[:3], x[3:]
        c_bd = mrp_to_matrix(sig).T
        wd, ad = c_bd @ w_di, c_bd @ a_di
        ws = w + wd
        tc = np.cross(ws, jh @ ws) + jh @ (ad - np.cross(w, wd)) - kp * sig - kd @ w
        f = -np.cross(ws, j @ ws) + tc - j @ (ad - np.cross(w, wd))
        return np.concatenate([mrp_rate_matrix(sig) @ w, np.linalg.solve(j, f)])

    def lyap(x):
        return 0.5 * x[3:] @ j @ x[3:] + 2 * kp * np.log(1 + x[:3] @ x[:3])

    return flow, lyap, j, jh, kp, kd, w_di, a_di


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_vdot_against_finite_differences_along_the_flow(seed):
    rng = np.random.default_rng(seed)
    flow, lyap, j, jh, kp, kd, *_ = _numeric_loop(rng, jhat_equal=True)
    der = derive_tracking_attitude()
    assert der.nominal_holds and der.mismatch_matches
    for _ in range(5):
        x = np.concatenate([rng.normal(size=3) * 0.3, rng.normal(size=3) * 0.02])
        h = 1e-4
        num = (lyap(x + h * flow(x)) - lyap(x - h * flow(x))) / (2 * h)  # = grad V . f
        claim = -x[3:] @ kd @ x[3:]
        assert abs(num - claim) <= 1e-6 * max(1.0, abs(claim)), (num, claim)


def test_linearization_against_a_finite_difference_jacobian():
    rng = np.random.default_rng(5)
    _, _, j, jh, kp, kd, w_di, a_di = _numeric_loop(rng, jhat_equal=False)
    j = np.diag(np.diag(j))  # the linearization is for diagonal inertias
    jh = np.diag(np.diag(jh))
    der = derive_tracking_attitude()
    s = der.symbols
    sub = {s["k_p"]: kp}
    sub.update({k: v for k, v in zip(s["K_d"], np.diag(kd))})
    sub.update({k: v for k, v in zip(s["J"], np.diag(j))})
    sub.update({k: v for k, v in zip(s["J_hat"], np.diag(jh))})
    sub.update({k: v for k, v in zip(s["omega_di"], w_di)})
    sub.update({k: v for k, v in zip(s["omega_di_dot"], a_di)})
    a0 = np.array(der.A0.xreplace(sub), dtype=float)
    n = np.array(der.N.xreplace(sub), dtype=float)
    d = np.array(der.forcing.xreplace(sub), dtype=float).ravel()

    def force(x):  # J omega' of the numeric loop (diagonal inertias)
        sig, w = x[:3], x[3:]
        c_bd = mrp_to_matrix(sig).T
        wd, ad = c_bd @ w_di, c_bd @ a_di
        ws = w + wd
        tc = np.cross(ws, jh @ ws) + jh @ (ad - np.cross(w, wd)) - kp * sig - kd @ w
        return -np.cross(ws, j @ ws) + tc - j @ (ad - np.cross(w, wd))

    h = 1e-6
    jac = np.column_stack([(force(h * e) - force(-h * e)) / (2 * h) for e in np.eye(6)])
    assert np.allclose(force(np.zeros(6)), d, rtol=1e-9, atol=1e-12)
    assert np.allclose(jac, j @ a0[3:] + n, rtol=1e-6, atol=1e-7)
    assert np.allclose(a0[:3, 3:], np.eye(3) / 4) and not a0[:3, :3].any()


def test_symbolic_mrp_matrix_is_the_numeric_one():
    import sympy as sp

    rng = np.random.default_rng(3)
    s = sp.Matrix(sp.symbols("a b c"))
    f = sp.lambdify(list(s), mrp_matrix_symbolic(s), "numpy")
    for _ in range(5):
        v = rng.normal(size=3) * 0.7
        assert np.allclose(f(*v), mrp_to_matrix(v), atol=1e-14)


def test_linearization_of_a_design_without_stiffness_is_refused(tmp_path):
    p = tmp_path / "nokp.py"
    p.write_text(_GOOD.replace('GAINS = {"k": {}, "w": {"role": "weight"}}',
                               'GAINS = {"K_d": {"kind": "diag"}, "w": {"role": "weight"}}')
                 .replace("return -v.k * v.track.sigma",
                          "return -v.K_d * v.track.w + v.track.sigma"))
    with pytest.raises(DerivationError, match="expected the linearized loop"):
        derive_tracking_attitude(str(p))
