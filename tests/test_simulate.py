"""Simulator against independent truth: a numpy RHS + scipy, and an exactly solvable case."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from formsync_design.cli.main import main
from formsync_design.errors import InputError, SimulationError
from formsync_design.graphs.build import make_graph
from formsync_design.models.disturbances import (
    constant_disturbance,
    gravity_gradient_disturbance,
    harmonic_disturbance,
    no_disturbance,
)
from formsync_design.sim.formation import (
    Formation,
    Gains,
    SimOptions,
    pack_state,
    state_names,
    unpack_state,
)
from formsync_design.sim.metrics import convergence_time, formation_metrics
from formsync_design.sim.simulator import simulate
from formsync_design.verify.case import load_case

from . import numpy_reference as R, numpy_vectorized as V


def _Q(q: np.ndarray) -> np.ndarray:
    q0 = np.sqrt(1 - q @ q)
    return 2 * (q0 * np.eye(3) - R.skew(q) + np.outer(q, q) / q0)


@pytest.fixture(scope="module")
def paper():
    return load_case()


def test_state_layout_roundtrip():
    names = state_names(3)
    assert len(names) == 21 and names[3] == "q0_1" and names[12] == "w1_1" and names[-1] == "w3_3"
    rng = np.random.default_rng(0)
    quats, rates = rng.normal(size=(3, 4)), rng.normal(size=(3, 3))
    a, b = unpack_state(pack_state(quats, rates), 3)
    assert np.array_equal(a, quats) and np.array_equal(b, rates)


def _ref_solution_fast(f, tf, kind, phi, disturbance, umax=np.inf, rtol=1e-11):
    rhs = R.make_rhs(f.inertias, f.graph.laplacian, f.gains.K_o, f.gains.K_q, f.gains.beta, f.gains.K_v,
                     kind, phi, disturbance, umax)
    return solve_ivp(rhs, (0, tf), f.initial_state(), method="DOP853", rtol=rtol, atol=rtol * 0.1,
                     dense_output=True)


def test_compiled_kernel_matches_vm(paper):
    """The compiled whole-horizon driver computes what its Python mirror on CasADi's VM
    computes: RK4 to rounding; DOPRI5 to well inside its tolerance (rounding-level
    differences can flip a step-size decision, so the two take nearly the same steps)."""
    f = paper.formation()
    rc = simulate(f, SimOptions(tf=3.0, step=0.05))
    rv = simulate(f, SimOptions(tf=3.0, step=0.05, compile=False))
    assert rc.stats["compiled"] is True and rv.stats["compiled"] is False
    assert np.abs(rc.x - rv.x).max() < 1e-12
    assert np.abs(rc.u - rv.u).max() < 1e-9
    assert rc.stats["events"]["switching"]["count"] == rv.stats["events"]["switching"]["count"] > 0
    ac = simulate(f, SimOptions(tf=3.0))
    av = simulate(f, SimOptions(tf=3.0, compile=False))
    assert ac.stats["integrator"] == av.stats["integrator"] == "dopri5"
    assert np.abs(ac.x - av.x).max() < 1e-7
    assert abs(ac.stats["steps"] - av.stats["steps"]) <= 0.05 * ac.stats["steps"]
    assert ac.stats["events"]["switching"]["count"] == av.stats["events"]["switching"]["count"]


def test_against_numpy_scipy_paper_case(paper):
    """CasADi (bridge-built) closed loop vs a hand-written numpy RHS integrated by DOP853
    (smooth tanh switch, so both integrators reach their nominal order: RK4 error ~ h^4)."""
    f = paper.formation()
    tf = 3.0
    sol = _ref_solution_fast(f, tf, "tanh", 0.05, "paper")
    errs = []
    for h in (0.01, 0.005):
        r = simulate(f, SimOptions(tf=tf, switch="tanh", phi=0.05, step=h, output_step=0.5, compile=False))
        ref = sol.sol(r.t).T
        errs.append(np.abs(r.x - ref).max())
    assert errs[1] < 1e-9
    assert 8 < errs[0] / errs[1] < 32  # fourth order (16x for half the step)
    om, qm = zip(*(R.metrics(x, f.n) for x in ref))
    np.testing.assert_allclose(r.omega_m, om, rtol=1e-7)
    np.testing.assert_allclose(r.q_m, qm, rtol=1e-7)


@pytest.mark.parametrize("kind", ["sat", "tanh", "sgn"])
@pytest.mark.parametrize("disturbance", ["paper", "gravity-gradient", "none"])
def test_vectorized_numpy_rhs_matches_loop_oracle(paper, kind, disturbance):
    """The benchmark's batched numpy RHS equals the per-spacecraft loop to rounding, on
    random states (random attitudes/rates, ring:8 and a random digraph Laplacian)."""
    rng = np.random.default_rng(16)
    f = paper.formation()
    n = f.n
    adj = rng.integers(0, 2, size=(n, n)) * rng.uniform(0.5, 2, size=(n, n))
    np.fill_diagonal(adj, 0.0)
    for L in (f.graph.laplacian, np.diag(adj.sum(1)) - adj):
        Kv = rng.uniform(0.1, 0.5, n)
        args = (f.inertias, L, 1.6, 0.4, 0.3, Kv, kind, 0.01, disturbance, 5.0)
        loop, vec = R.make_rhs(*args), V.make_rhs(*args)
        for _ in range(5):
            qb = rng.normal(size=(n, 4))
            qb /= np.linalg.norm(qb, axis=1, keepdims=True)
            qb[:, 3] = np.abs(qb[:, 3]) + 0.05  # away from the q0 = 0 singularity
            x = np.concatenate([qb.ravel(), rng.normal(scale=0.3, size=3 * n)])
            t = float(rng.uniform(0, 200))
            a, b = loop(t, x), vec(t, x)
            assert np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(a).max())


def test_chunked_kernel_matches_step_by_step_rk4(paper):
    """The compiled multi-interval kernel (``mapaccum`` over output intervals, sub-steps
    inside) equals classical RK4 driven one step at a time from Python on the same
    right-hand side, to rounding; the output grid is decimated inside the kernel."""
    from formsync_design.sim.kernels import get_kernel, pack_params

    f = paper.formation()
    opt = SimOptions(tf=4.0, step=0.05, output_step=0.2)
    r = simulate(f, opt)
    kern = get_kernel(f.n, opt.switch, False, opt.substeps, 100, opt.inverse, True)
    p = pack_params(f, opt)
    h = opt.interval / opt.substeps

    def rhs(x, t):
        return np.asarray(kern.rhs(x, t, p)[0]).ravel()

    x, t, out = f.initial_state(), 0.0, [f.initial_state()]
    for k in range(round(opt.tf / h)):
        k1 = rhs(x, t)
        k2 = rhs(x + h / 2 * k1, t + h / 2)
        k3 = rhs(x + h / 2 * k2, t + h / 2)
        k4 = rhs(x + h * k3, t + h)
        x, t = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), (k + 1) * h
        if (k + 1) % opt.substeps == 0:
            out.append(x)
    assert r.x.shape == (len(out), 7 * f.n)
    assert np.abs(r.x - np.array(out)).max() < 1e-12


@pytest.mark.slow
def test_against_numpy_scipy_paper_case_sat(paper):
    """The paper's sat switch (kinks limit both integrators' order): agreement to 1e-6."""
    f = paper.formation()
    sol = _ref_solution_fast(f, 3.0, "sat", 0.01, "paper")
    r = simulate(f, SimOptions(tf=3.0, step=0.005, output_step=0.5))
    assert np.abs(r.x - sol.sol(r.t).T).max() < 1e-6


def test_against_numpy_gravity_gradient_and_torque_limit(paper):
    f = paper.formation(disturbance="gravity-gradient")
    tf = 3.0
    sol = _ref_solution_fast(f, tf, "tanh", 0.05, "gravity-gradient", umax=20.0, rtol=1e-10)
    r = simulate(f, SimOptions(tf=tf, switch="tanh", phi=0.05, torque_limit=20.0, step=0.005, output_step=0.5,
                               compile=False))
    # the clipping kink of the torque limit costs both integrators their order: 2e-6
    assert np.abs(r.x - sol.sol(r.t).T).max() < 2e-6
    assert r.peak_torque.max() == pytest.approx(20.0)  # the limit is active at the start
    assert r.saturation_end_time is not None and 0 <= r.saturation_end_time <= tf


def test_cvodes_matches_reference(paper):
    f = paper.formation(disturbance="none")
    tf = 5.0
    sol = _ref_solution_fast(f, tf, "tanh", 0.05, "none")
    r = simulate(f, SimOptions(tf=tf, switch="tanh", phi=0.05, integrator="cvodes", rtol=1e-10, atol=1e-12))
    assert np.abs(r.x - sol.sol(r.t).T).max() < 1e-7
    assert r.stats["integrator"] == "cvodes" and r.stats["steps"] > 0


def test_quaternion_norm_preserved(paper):
    r = simulate(paper.formation(), SimOptions(tf=50.0, compile=False))
    norms = np.linalg.norm(r.quaternions, axis=2)
    assert np.abs(norms - 1).max() < 1e-6
    assert r.stats["max_norm_error"] == pytest.approx(np.abs(norms - 1).max())


def _two_spacecraft(q1, q2, qd1, qd2, K_o=1.6, K_q=0.4):
    q = np.array([q1, q2], dtype=float)
    qd = np.array([qd1, qd2], dtype=float)
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    W = np.array([_Q(q[i]) @ qd[i] for i in range(2)])  # omega = Q q'
    J = np.array([[[50.0, 0, 4], [0, 55, 0], [4, 0, 60]], [[52, 1, 0.5], [1, 54, 3], [0.5, 3, 62]]])
    return Formation(make_graph("path:2"), J, att, W, Gains(K_o, K_q, 0.3, (0.0, 0.0)), no_disturbance(2))


def test_two_spacecraft_linear_closed_loop_exact():
    """K_v = 0, u_d = 0: the nonlinear plant under (4) obeys q'' = -K_o q' - K_q (L (x) I3) q exactly,
    so q(t) = expm(F t) (q(0), q'(0)) with F = [[0, I], [-K_q L (x) I3, -K_o I]]."""
    f = _two_spacecraft([0.1, 0.4, -0.3], [-0.2, 0.1, 0.3], [0.05, -0.1, 0.02], [-0.03, 0.04, 0.1])
    r = simulate(f, SimOptions(tf=30.0, step=0.01, output_step=0.5, compile=False))
    L = np.kron(f.graph.laplacian.astype(float), np.eye(3))
    F = np.block([[np.zeros((6, 6)), np.eye(6)], [-0.4 * L, -1.6 * np.eye(6)]])
    z0 = np.concatenate([[0.1, 0.4, -0.3, -0.2, 0.1, 0.3], [0.05, -0.1, 0.02, -0.03, 0.04, 0.1]])
    quats = r.quaternions
    for k in range(0, len(r.t), 10):
        z = scipy.linalg.expm(F * r.t[k]) @ z0
        assert np.abs(quats[k, :, :3].ravel() - z[:6]).max() < 1e-9
    # consensus: both reach the average attitude plus the drift of the mean rate, (q(0) + q'(0)/K_o) mean
    target = (np.array([0.1, 0.4, -0.3]) + np.array([-0.2, 0.1, 0.3])) / 2 + (
        np.array([0.05, -0.1, 0.02]) + np.array([-0.03, 0.04, 0.1])) / 2 / 1.6
    np.testing.assert_allclose(quats[-1, 0, :3], target, atol=1e-4)
    assert r.status == "converged"


def test_singularity_detected_with_spacecraft_and_time():
    """Common rate q' = 1 along x: q_x(t) = 0.5 + (1 - exp(-K_o t))/K_o reaches |q| = 1 (q0 = 0)."""
    f = _two_spacecraft([0.5, 0, 0], [0.5, 0, 0], [1.0, 0, 0], [1.0, 0, 0])
    floor = 0.02
    r = simulate(f, SimOptions(tf=10.0, q0_floor=floor, compile=False))
    t_star = -np.log(1 - 1.6 * (np.sqrt(1 - floor**2) - 0.5)) / 1.6
    assert r.status == "singular"
    assert r.singular_spacecraft in (1, 2)
    assert r.singular_time == pytest.approx(t_star, abs=1e-3)
    assert "singular" in r.message and f"spacecraft {r.singular_spacecraft}" in r.message
    assert r.t[-1] <= t_star  # trajectories stop at the event, never continue through it


def test_blow_up_raises_with_time():
    f = _two_spacecraft([0.1, 0, 0], [-0.1, 0, 0], [0, 0, 0], [0, 0, 0], K_o=5e3)
    with pytest.raises(SimulationError, match=r"at t = 0\.0+ s"):
        simulate(f, SimOptions(tf=5.0, step=0.05, compile=False))


def test_zero_order_hold_holds_the_sampled_control(paper):
    f = paper.formation()
    r = simulate(f, SimOptions(tf=4.0, sample_period=0.2, step=0.05, compile=False))
    assert np.allclose(np.diff(r.t), 0.2)
    rhs_u = []
    for k in range(len(r.t) - 1):
        # independent controller at the sampled state: recover u from the numpy RHS with u_d = 0
        rhs = R.make_rhs(f.inertias, f.graph.laplacian, 1.6, 0.4, 0.3, 0.01, "sat", 0.01, "none")
        xd = rhs(r.t[k], r.x[k])
        w = r.rates[k]
        u = [f.inertias[i] @ xd[4 * f.n + 3 * i: 4 * f.n + 3 * i + 3] + np.cross(w[i], f.inertias[i] @ w[i])
             for i in range(f.n)]
        rhs_u.append(np.concatenate(u))
    # (off the unit sphere by the norm drift, E^T and Q^{-T} differ in the 9th digit)
    np.testing.assert_allclose(r.u[:-1], np.array(rhs_u), rtol=1e-7, atol=1e-8)
    # a fine sample period approaches continuous control
    rc = simulate(f, SimOptions(tf=4.0, step=0.01, output_step=0.2, compile=False))
    rz = simulate(f, SimOptions(tf=4.0, sample_period=0.01, step=0.01, compile=False))
    assert np.abs(rz.x[::20] - rc.x).max() < 5e-3
    assert np.abs(r.x[-1] - rc.x[-1]).max() > np.abs(rz.x[-1] - rc.x[-1]).max()


def test_paper_case_converges_with_metrics(paper):
    r = simulate(paper.formation(), SimOptions(compile=False))
    assert r.status == "converged"
    assert r.final_q_m < 1e-4 and r.final_omega_m < 1e-5
    ct = convergence_time(r.t, r.omega_m, r.q_m, 1e-4, 1e-5)
    assert r.convergence_time == ct and 0 < ct < 200
    assert r.peak_torque.shape == (8, 3) and np.all(r.peak_torque > 0)
    assert np.all(r.min_q0 > 0) and np.all(r.min_q0 <= paper.attitudes[:, 3] + 1e-15)
    # common drift: the paper's disturbance has a nonzero mean, so the formation drifts together
    assert np.linalg.norm(r.common_rate) > 0
    assert np.abs(r.final_rates - r.common_rate).max() < 1e-4


def test_metrics_match_definition():
    rng = np.random.default_rng(5)
    n = 4
    qb = rng.normal(size=(n, 4))
    qb /= np.linalg.norm(qb, axis=1, keepdims=True)
    x = pack_state(qb, rng.normal(size=(n, 3)))
    om, qm = formation_metrics(n, x[None, :])
    ref = R.metrics(x, n)
    assert om[0] == pytest.approx(ref[0], rel=1e-12) and qm[0] == pytest.approx(ref[1], rel=1e-12)


def test_convergence_time_semantics():
    t = np.arange(5.0)
    assert convergence_time(t, np.zeros(5), np.array([1, 1e-5, 1, 1e-5, 1e-5]), 1e-4, 1e-5) == 3.0
    assert convergence_time(t, np.zeros(5), np.array([1e-5] * 4 + [1.0]), 1e-4, 1e-5) is None
    assert convergence_time(t, np.zeros(5), np.zeros(5), 1e-4, 1e-5) == 0.0


def test_user_disturbances_enter(paper):
    base = paper.formation(disturbance="none")
    const = Formation(base.graph, base.inertias, base.attitudes, base.rates, base.gains,
                      constant_disturbance(np.tile([0.5, 0, 0], (8, 1))))
    harm = Formation(base.graph, base.inertias, base.attitudes, base.rates, base.gains,
                     harmonic_disturbance(8, [0.5, 0, 0], [1.0, 1.0, 1.0]))
    opt = SimOptions(tf=1.0, compile=False)
    r0, r1, r2 = simulate(base, opt), simulate(const, opt), simulate(harm, opt)
    # without feedback on the first instants, w_x' gains ~ J^-1 u_d: compare the first output step
    d1 = r1.rates[1] - r0.rates[1]
    assert np.all(d1[:, 0] * np.sign(np.linalg.inv(base.inertias)[:, 0, 0]) > 0)
    assert np.abs(r2.x - r0.x).max() > 0
    assert gravity_gradient_disturbance(8).bound(base.inertias).max() > 0


def test_export_npz_and_csv(paper, tmp_path):
    r = simulate(paper.formation(), SimOptions(tf=2.0, compile=False))
    z = np.load(r.to_npz(tmp_path / "t.npz"))
    assert np.array_equal(z["x"], r.x) and list(z["names"]) == list(r.names)
    data = np.loadtxt(r.to_csv(tmp_path / "t.csv"), delimiter=",", skiprows=1)
    assert data.shape == (len(r.t), 1 + 56 + 24 + 2)
    np.testing.assert_array_equal(data[:, 1:57], r.x)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(tf=-1.0), "tf"),
        (dict(step=0.0), "step"),
        (dict(switch="relay"), "switch"),
        (dict(integrator="euler"), "integrator"),
        (dict(torque_limit=-2.0), "torque_limit"),
        (dict(sample_period=0.1, integrator="cvodes"), "rk4"),
        (dict(rtol=float("nan")), "rtol"),
    ],
)
def test_bad_options(kwargs, match):
    with pytest.raises(InputError, match=match):
        SimOptions(**kwargs)


def test_bad_formations(paper):
    f = paper.formation()
    args = dict(graph=f.graph, inertias=f.inertias, attitudes=f.attitudes, rates=f.rates, gains=f.gains,
                disturbance=f.disturbance)
    att = np.array(f.attitudes)
    att[0] *= 1.01
    with pytest.raises(InputError, match="unit quaternion for spacecraft 1"):
        Formation(**{**args, "attitudes": att})
    att = np.array(f.attitudes)
    att[2] *= -1
    with pytest.raises(InputError, match="q0 > 0 for spacecraft 3"):
        Formation(**{**args, "attitudes": att})
    J = np.array(f.inertias)
    J[4] = np.diag([1.0, -1.0, 1.0])
    with pytest.raises(InputError, match="positive definite inertia for spacecraft 5"):
        Formation(**{**args, "inertias": J})
    with pytest.raises(InputError, match="7 inertias"):
        Formation(**{**args, "graph": make_graph("ring:7")})
    with pytest.raises(InputError, match="tf"):
        simulate(f, SimOptions(tf=0.25, output_step=0.1))


def test_cli_simulate_writes_outputs(tmp_path):
    out = tmp_path / "o"
    rc = main(["simulate", "--tf", "200", "--out", str(out), "--no-compile", "--figures", "png"])
    assert rc == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "converged" and s["graph"] == "ring:8"
    for name in ("omega_m.png", "q_m.png", "torques_1-4.png", "torques_5-8.png", "trajectory.npz"):
        assert (out / name).is_file()


def test_cli_simulate_exit_codes(capsys, tmp_path):
    assert main(["simulate", "--tf", "5", "--no-compile", "--format", "json"]) == 1  # not converged in 5 s
    js = json.loads(capsys.readouterr().out)
    assert js["status"] == "not-converged"
    assert main(["simulate", "--tf", "-3"]) == 2
    assert main(["simulate", "--graph", "ring:2"]) == 2  # (a graph of 5 resizes the case)
    assert main(["simulate", "--boundary-layer", "0"]) == 2
    assert main(["simulate", "--switch", "relay"]) == 2
    assert main(["simulate", "--case", str(tmp_path / "missing.toml")]) == 2
    err = capsys.readouterr().err
    assert "expected" in err


def test_figures_and_reproducible_files(paper, tmp_path):
    from formsync_design.sim.figures import all_figures, save_figure, torque_figures

    r = simulate(paper.formation(), SimOptions(tf=4.0, torque_limit=30.0, compile=False))
    figs = torque_figures(r)
    assert len(figs) == 2 and len(figs[0].axes) == 4
    for fg in figs:
        fg.clf()
    names = sorted(all_figures(r))
    assert names == ["omega_m", "q_m", "torques_1-4", "torques_5-8"]
    a = save_figure(all_figures(r)["q_m"], tmp_path / "a.svg").read_bytes()
    b = save_figure(all_figures(r)["q_m"], tmp_path / "b.svg").read_bytes()
    assert a == b


def test_disturbance_frequencies_must_be_shared():
    from formsync_design.models.disturbances import DisturbanceModel, kernel_parameters

    h = np.zeros((2, 3, 6))
    h[0, 0, 2] = 0.1
    with pytest.raises(InputError, match="common to all spacecraft"):
        kernel_parameters(DisturbanceModel("harmonic", h))
