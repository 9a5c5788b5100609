"""The whole-horizon compiled kernels (issue 16) against independent truth: the step-by-step
RK4 of the formation-level CasADi function, analytic event times, a numpy oracle
integrated by scipy, the pairwise metrics, one-at-a-time simulations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from formsync_design.errors import InputError
from formsync_design.graphs.build import make_graph
from formsync_design.graphs.digraph_io import make_digraph
from formsync_design.models.disturbances import constant_disturbance, no_disturbance
from formsync_design.sim import native
from formsync_design.sim.formation import Formation, Gains, SimOptions
from formsync_design.sim.kernels import get_kernel, pack_params
from formsync_design.sim.metrics import formation_metrics, linear_metrics
from formsync_design.sim.montecarlo import mc_box, replay, run_montecarlo
from formsync_design.sim.montecarlo_data import MonteCarloSettings
from formsync_design.sim.simulator import simulate
from formsync_design.spec.loader import load_spec
from formsync_design.verify.case import load_case

from . import numpy_vectorized as V


@pytest.fixture(scope="module")
def paper():
    return load_case()


def test_whole_horizon_rk4_equals_the_step_by_step_kernels(paper):
    """One call of the compiled driver over the whole horizon equals, to rounding, the
    CasADi multi-interval kernel (``chunk``: RK4 sub-steps, mapaccum over intervals) called
    interval block by interval block - continuous control and zero-order hold."""
    f = paper.formation()
    for opt in (SimOptions(tf=6.0, step=0.05, output_step=0.2),
                SimOptions(tf=6.0, step=0.05, sample_period=0.2)):
        r = simulate(f, opt)
        assert r.stats["compiled"] and r.stats["integrator"] == "rk4"
        kern = get_kernel(f.n, opt.switch, opt.sample_period is not None, opt.substeps, 10,
                          opt.inverse, False)
        p = pack_params(f, opt)
        xa = np.concatenate([f.initial_state(), [0.0]])
        X, U = [xa[:-1]], []
        for _ in range(3):
            XA, Uc, _, _ = (a.full().T for a in kern.chunk(xa, opt.interval / opt.substeps, p))
            X += list(XA[:, :-1])
            U += list(Uc)
            xa = XA[-1]
        assert np.abs(r.x - np.array(X)).max() < 1e-13
        assert np.abs(r.u[:-1] - np.array(U)).max() < 1e-10


def _straight(q: float, rate: float) -> Formation:
    """Two identical spacecraft, no disturbance, K_v = 0: L q = 0 and the closed loop is
    q'' = -K_o q' exactly, so q(t) = q(0) + q'(0) (1 - exp(-K_o t)) / K_o along x."""
    qv = np.array([[q, 0, 0], [q, 0, 0]])
    att = np.column_stack([qv, np.sqrt(1 - (qv**2).sum(1))])
    # omega = Q q' with q' = (rate, 0, 0): Q e_x = 2 (q0 + q^2 / q0) e_x along x
    q0 = np.sqrt(1 - q * q)
    w = np.array([[2 * (q0 + q * q / q0) * rate, 0, 0]] * 2)
    return Formation(make_graph("path:2"), np.array([np.diag([50.0, 55, 60])] * 2), att, w,
                     Gains(1.6, 0.4, 0.3, (0.0,)), no_disturbance(2))


@pytest.mark.parametrize("compile", [True, False])
def test_q0_event_located_to_the_stated_tolerance(compile):
    floor, q, rate, K_o = 0.02, 0.5, 1.0, 1.6
    t_star = -np.log(1 - K_o * (np.sqrt(1 - floor**2) - q) / rate) / K_o
    f = _straight(q, rate)
    r = simulate(f, SimOptions(tf=10.0, q0_floor=floor, rtol=1e-10, atol=1e-13, event_tol=1e-10,
                               compile=compile))
    assert r.status == "singular" and r.stats["integrator"] == "dopri5"
    assert abs(r.singular_time - t_star) < 1e-8  # event tolerance + integration error
    assert r.t[-1] < r.singular_time <= r.t[-1] + r.options.interval  # the grid stops before it
    assert r.min_q0.min() == pytest.approx(floor)
    # RK4 (cubic Hermite interpolant) on a smooth crossing, q0 = 1/2: near q0 = 0 the solution
    # goes like sqrt(t* - t) and a fixed step, not the location, limits the accuracy
    floor = 0.5
    t_half = -np.log(1 - K_o * (np.sqrt(1 - floor**2) - q) / rate) / K_o
    r4 = simulate(f, SimOptions(tf=2.0, q0_floor=floor, step=0.01, event_tol=1e-10, compile=compile))
    assert r4.status == "singular" and abs(r4.singular_time - t_half) < 1e-8


def _tau_oracle(f: Formation, t: float, x: np.ndarray) -> np.ndarray:
    """The switching argument tau_i = q_i' + beta s_i from the state (hand-written)."""
    n = f.n
    qb = x[: 4 * n].reshape(n, 4)
    w = x[4 * n :].reshape(n, 3)
    q, q0 = qb[:, :3], qb[:, 3]
    qd = 0.5 * (q0[:, None] * w + np.cross(q, w))
    return (qd + f.gains.beta * (f.graph.laplacian @ q)).ravel()


def test_switching_events_located_against_a_numpy_oracle(paper):
    """The first and the last crossing of the boundary layer |tau| = phi (the kinks of sat)
    agree with the crossings of a hand-written numpy closed loop integrated by scipy
    DOP853 at rtol 1e-12 (root found by brentq on its dense output)."""
    f = paper.formation()
    tf = 1.5
    r = simulate(f, SimOptions(tf=tf, rtol=1e-10, atol=1e-13, event_tol=1e-10))
    ev = r.stats["events"]["switching"]
    assert ev["count"] > 5 and ev["last"] > 1.0 and r.stats["events"]["tolerance"] == 1e-10
    g = f.gains
    rhs = V.make_rhs(f.inertias, f.graph.laplacian, g.K_o, g.K_q, g.beta, g.K_v, "sat", 0.01, "paper")
    sol = solve_ivp(rhs, (0, tf), f.initial_state(), method="DOP853", rtol=1e-12, atol=1e-14,
                    dense_output=True)

    def gvec(t: float) -> np.ndarray:
        return np.abs(_tau_oracle(f, t, sol.sol(t))) - 0.01

    for t_ev in (ev["first"], ev["last"]):
        a, b = t_ev - 1e-5, t_ev + 1e-5
        ga, gb = gvec(a), gvec(b)
        j = int(np.argmin(np.abs(gvec(t_ev))))
        assert np.sign(ga[j]) != np.sign(gb[j])
        t_true = brentq(lambda t, j=j: float(gvec(t)[j]), a, b, xtol=1e-14)
        assert abs(t_true - t_ev) < 1e-8
    # no kink is stepped over: the default run is as accurate as the oracle's tight run
    rd = simulate(f, SimOptions(tf=tf))
    assert np.abs(rd.x[-1] - sol.sol(tf)).max() < 1e-8


def test_torque_limit_events_and_the_python_mirror(paper):
    """Torque-limit crossings are counted and located; the compiled driver and its Python
    mirror on CasADi's VM count the same events at nearly the same times."""
    f = paper.formation()
    opt = SimOptions(tf=4.0, torque_limit=10.0)
    rc, rv = simulate(f, opt), simulate(f, SimOptions(tf=4.0, torque_limit=10.0, compile=False))
    for key in ("switching", "torque_limit"):
        a, b = rc.stats["events"][key], rv.stats["events"][key]
        assert a["count"] == b["count"] > 0
        assert abs(a["first"] - b["first"]) < 1e-6 and abs(a["last"] - b["last"]) < 1e-6
    assert np.abs(rc.x - rv.x).max() < 1e-7  # rounding can flip a step-size decision
    # the last located exit from the limit lies between the last grid point at the limit
    # (saturation_end_time) and the next one
    r = simulate(f, SimOptions(tf=12.0, torque_limit=10.0))
    last = r.stats["events"]["torque_limit"]["last"]
    assert r.saturation_end_time is not None and 5 < r.saturation_end_time < 11
    assert r.saturation_end_time <= last < r.saturation_end_time + r.options.interval


def test_linear_metrics_equal_the_pairwise_definition():
    rng = np.random.default_rng(3)
    for n in (2, 5, 16):
        for spread in (1.0, 1e-3, 1e-6):
            base = np.array([0.1, -0.2, 0.3, 0.9])
            qb = base + spread * rng.normal(size=(4, n, 4))
            qb /= np.linalg.norm(qb, axis=2, keepdims=True)
            w = 0.2 + spread * rng.normal(size=(4, n, 3))
            X = np.concatenate([qb.reshape(4, -1), w.reshape(4, -1)], axis=1)
            (oa, qa), (ob, qbm) = formation_metrics(n, X), linear_metrics(X, n)
            np.testing.assert_allclose(ob, oa, rtol=1e-12)
            np.testing.assert_allclose(qbm, qa, rtol=1e-8)  # both: rounding of |q_ij| ~ 1e-16
    # the compiled driver's metrics (computed in C with the same formula)
    f = load_case().formation()
    r = simulate(f, SimOptions(tf=2.0))
    om, qm = formation_metrics(f.n, r.x)
    np.testing.assert_allclose(r.omega_m, om, rtol=1e-12)
    np.testing.assert_allclose(r.q_m, qm, rtol=1e-10)


def test_one_kernel_for_every_size_and_weighted_digraphs(paper):
    """The compiled kernel does not depend on N or the graph (s = L q runs through the
    Laplacian's nonzeros in C): the same object serves N = 3 and 8, and on a weighted
    digraph it equals the VM's dense-Laplacian formation function to rounding."""
    native.clear_native_cache()
    dg = make_digraph(np.array([[0, 1.5, 0], [0.5, 0, 2.0], [1.0, 0, 0]]))
    J = paper.inertias[:3]
    f3 = Formation(dg, J, paper.attitudes[:3], paper.rates[:3], Gains(1.6, 0.4, 0.3, (0.01,)),
                   constant_disturbance(np.full((3, 3), 1e-3)))
    opt = SimOptions(tf=3.0, step=0.05)
    a = simulate(f3, opt)
    b = simulate(f3, SimOptions(tf=3.0, step=0.05, compile=False))
    assert np.abs(a.x - b.x).max() < 1e-13
    simulate(paper.formation(), SimOptions(tf=0.5))
    assert len(native._NATIVE) == 1


def test_batched_montecarlo_equals_one_at_a_time(paper):
    """Every run of a batch (2 threads) equals the single simulation of its replayed seed,
    and the batch on 1 thread gives identical records."""
    base = paper.formation()
    box = mc_box({"K_o": "1.4:1.8", "K_q": "0.35:0.45", "beta": "0.25:0.3", "K_v": "0.01:0.02"})
    st = MonteCarloSettings(runs=6, seed=4)
    opt = SimOptions(tf=60.0, output_step=0.5, rtol=1e-6, atol=1e-10, norm_tol=1e-5)
    res = run_montecarlo(base, box, st, opt, threads=2, certify=False)
    assert res.counts["converged"] + res.counts["not-converged"] == 6
    for run in res.runs:
        r = simulate(replay(base, box, st, run.seed), opt)
        assert r.status == run.status and r.convergence_time == run.convergence_time
        assert r.final_q_m == pytest.approx(run.final_q_m, rel=1e-12)
        assert r.final_omega_m == pytest.approx(run.final_omega_m, rel=1e-12)
        assert float(r.min_q0.min()) == run.min_q0
        assert float(r.peak_torque.max()) == run.peak_torque
        assert r.stats["max_norm_error"] == pytest.approx(run.norm_error, rel=1e-9, abs=1e-15)
    one = run_montecarlo(base, box, st, opt, threads=1, certify=False)
    assert [r.to_dict() for r in one.runs] == [r.to_dict() for r in res.runs]


def test_batched_singular_runs_equal_one_at_a_time(paper):
    base = paper.formation()
    f = Formation(base.graph, base.inertias, base.attitudes, base.rates, Gains(1.6, 0.4, 0.3, (0.0,)),
                  constant_disturbance(np.tile([40.0, 0, 0], (8, 1))))
    st = MonteCarloSettings(runs=3, seed=2, phases=False)
    box = mc_box({"K_o": 1.6, "K_q": 0.4, "beta": 0.3, "K_v": 0})
    opt = SimOptions(tf=20.0, output_step=0.5, rtol=1e-6, atol=1e-10, norm_tol=1e-5)
    res = run_montecarlo(f, box, st, opt, certify=False)
    assert res.counts["singular"] == 3
    for run in res.runs:
        r = simulate(replay(f, box, st, run.seed), opt)
        assert r.status == "singular" and r.singular_time == run.event_time


def test_integrator_options():
    assert SimOptions().method == "dopri5" and SimOptions(step=0.02).method == "rk4"
    assert SimOptions(switch="sgn").method == "rk4" and SimOptions(sample_period=0.2).method == "dopri5"
    with pytest.raises(InputError, match="sgn"):
        SimOptions(switch="sgn", integrator="dopri5")
    with pytest.raises(InputError, match="max_step"):
        SimOptions(integrator="dopri5", step=0.05)
    with pytest.raises(InputError, match="adaptive"):
        SimOptions(step=0.05, max_step=1.0)
    with pytest.raises(InputError, match="event_tol"):
        SimOptions(event_tol=0.0)


def test_zero_order_hold_adaptive_matches_rk4(paper):
    """Under ZOH every sample interval is its own DOPRI5 segment: it agrees with a fine RK4
    on the same held torques."""
    f = paper.formation()
    a = simulate(f, SimOptions(tf=4.0, sample_period=0.2))
    b = simulate(f, SimOptions(tf=4.0, sample_period=0.2, step=0.005))
    assert a.stats["integrator"] == "dopri5" and np.allclose(np.diff(a.t), 0.2)
    assert np.abs(a.x - b.x).max() < 1e-9
    assert np.abs(a.u - b.u).max() < 1e-7


def test_max_step_is_honoured(paper):
    f = paper.formation()
    a = simulate(f, SimOptions(tf=20.0))
    b = simulate(f, SimOptions(tf=20.0, max_step=0.01))
    assert b.stats["steps"] >= 2000 > a.stats["steps"]
    assert np.abs(a.x - b.x).max() < 1e-8


def test_native_kernel_is_keyed_by_the_specification(tmp_path):
    from pathlib import Path

    variant = load_spec(Path(__file__).parent / "data" / "controller_variant_spec.py")
    k1 = native.get_native(load_spec(None), "sat", "E")
    k2 = native.get_native(variant, "sat", "E")
    assert k1 is not None and k2 is not None and k1.path != k2.path
    assert k1.spec_key == load_spec(None).key and k2.spec_key == variant.key


def test_warm_kernel_skips_the_source_and_the_key_follows_design_switch_generator(
        monkeypatch, tmp_path):
    """A cached object is loaded without generating its C source (no SymPy derivation);
    the cache key changes with the design, the switch and the generator's code."""
    from pathlib import Path

    monkeypatch.setenv("FORMSYNC_CACHE_DIR", str(tmp_path))
    spec = load_spec(None)
    variant = load_spec(Path(__file__).parent / "data" / "controller_variant_spec.py")
    native.clear_native_cache()
    calls: list[str] = []
    real = native.native_source

    def counted(s, switch, inverse):
        calls.append(switch)
        return real(s, switch, inverse)

    monkeypatch.setattr(native, "native_source", counted)
    try:
        cold = native.get_native(spec, "sat", "E")
        assert cold is not None and calls == ["sat"] and cold.path.parent.parent == tmp_path
        native.clear_native_cache()  # a new process: the object on disk, nothing in memory
        warm = native.get_native(spec, "sat", "E")
        assert warm is not None and warm.path == cold.path and calls == ["sat"]
        # the warm object runs like the cold one
        assert warm.ngains == cold.ngains
    finally:
        native.clear_native_cache()
    keys = {native.native_key(spec, "sat", "E"), native.native_key(spec, "sgn", "E"),
            native.native_key(variant, "sat", "E"), native.native_key(spec, "sat", "solve")}
    assert len(keys) == 4
    # an edited generator (here: its digest) gives another key, hence another object
    before = native.native_key(spec, "sat", "E")
    monkeypatch.setattr(native, "generator_digest", lambda: "0" * 64)
    assert native.native_key(spec, "sat", "E") != before


def test_generator_digest_covers_the_generating_code() -> None:
    from pathlib import Path

    root = Path(native.__file__).resolve().parents[1]
    for rel in native.GENERATOR_CODE:
        assert (root / rel).exists(), rel
    assert {"sim/native_c.py", "sim/bridge.py", "sim/kernels.py", "models"} <= set(native.GENERATOR_CODE)
