"""Agent designs (FORM = "agent"): loading, validation, and simulation against independent truth.

Independent truths used here: the Lagrangian PD consensus simulated by the classic kernel
(same closed loop, other formulas), NumPy right-hand sides in the designs' own coordinates
(rotation matrices integrated directly; MRP with shadow-set switching events) integrated by
SciPy's DOP853 at tight tolerances, a first-principles sample-and-hold loop for the sampled
designs, and analytic solutions.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from formsync_design.errors import DerivationError, InputError
from formsync_design.graphs.digraph_io import digraph_from_edges
from formsync_design.models.disturbances import no_disturbance
from formsync_design.sim.agents import AgentFormation, AgentOptions, Reference, simulate_agents
from formsync_design.sim.formation import Formation, Gains, SimOptions
from formsync_design.spec.agent import agent_design_from_functions
from formsync_design.spec.loader import load_design, load_spec
from tests.helpers import cross

DATA = Path(__file__).parent / "data"
PAPER002 = [(1, 4, "0.58"), (2, 3, "0.33"), (2, 5, "0.11"), (3, 2, "0.25"), (4, 1, "0.21"),
            (4, 3, "0.4"), (5, 1, "0.37")]


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    """The CasADi VM (no gcc run) keeps these small runs fast; one test compiles."""
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


def _quat_to_R(q):
    v, q0 = q[:3] / np.linalg.norm(q), q[3] / np.linalg.norm(q)
    return (q0 * q0 - v @ v) * np.eye(3) + 2 * np.outer(v, v) + 2 * q0 * cross(v)


def _random_attitudes(rng, n, spread=1.0):
    out = []
    for _ in range(n):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        ang = spread * rng.random()
        out.append([*(math.sin(ang / 2) * axis), math.cos(ang / 2)])
    return np.array(out)


def _inertias(rng, n):
    out = []
    for _ in range(n):
        M = rng.normal(size=(3, 3))
        out.append(np.diag(20 + 10 * rng.random(3)) + 0.5 * (M + M.T))
    return np.array(out)


# --------------------------------------------------------------------- loading and validation


def test_load_design_returns_agent_designs_and_load_spec_refuses_them():
    d = load_design(DATA / "agent_so3.py")
    assert d.form == "agent" and d.representation == "so3" and d.gains == ("k_R", "k_w")
    with pytest.raises(DerivationError, match="agent design 'agent_so3'.*formsync simulate"):
        load_spec(DATA / "agent_so3.py")
    assert load_design("pd_consensus").name == "pd_consensus"


def test_measured_quantities_are_checked_symbolically():
    d = load_design(DATA / "agent_filter.py")
    assert d.decl.measured == ("attitude", "neighbour-attitude")
    with pytest.raises(DerivationError, match=r"MEASURED quantities.*uses \['rate'\]"):
        agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}},
                                    measured=("attitude",))
    with pytest.raises(DerivationError, match=r"uses \['neighbour-rate'\]"):
        agent_design_from_functions(lambda v: -v.k * sum((n.w for n in v.nbrs), v.q * 0),
                                    gains={"k": {}}, measured=("attitude", "rate"))


@pytest.mark.parametrize("kw, msg", [
    ({"representation": "orbit"}, "REPRESENTATION: expected one of"),
    ({"states": {"x": 3}}, "expected a function states"),
    ({"sampling": "event"}, r"expected a function event\(view\)"),
    ({"gains": {"k": {}, "K_v": {"role": "switching"}}}, "expected 'controller' or 'multiplier'"),
    ({"states": {"w": 3}, "states_fn": lambda v: {"w": v.w}}, "STATES: expected state names"),
])
def test_bad_agent_declarations_are_one_line_errors(kw, msg):
    kw.setdefault("gains", {"k": {}})
    with pytest.raises(DerivationError, match=msg) as e:
        agent_design_from_functions(lambda v: -v.k * v.w, **kw)
    assert "\n" not in str(e.value)


def test_wrong_shape_and_unknown_symbols_are_refused():
    import sympy as sp

    with pytest.raises(DerivationError, match="expected an explicit 3x1"):
        agent_design_from_functions(lambda v: v.J, gains={"k": {}})
    with pytest.raises(DerivationError, match="unknown symbols"):
        agent_design_from_functions(lambda v: v.w * sp.Symbol("zeta"), gains={"k": {}})
    with pytest.raises(DerivationError, match=r"view\.Rd"):
        agent_design_from_functions(lambda v: v.Rd * v.w, gains={"k": {}}, representation="so3")


# ------------------------------------------------------------------ continuous simulation


def test_agent_pd_matches_the_lagrangian_pd_consensus():
    """The same closed loop written in two forms, simulated by two kernels."""
    import formsync_design as fs

    rng = np.random.default_rng(3)
    g = fs.make_graph("ring:4")
    J, Q, W = _inertias(rng, 4), _random_attitudes(rng, 4, 1.0), 0.02 * rng.normal(size=(4, 3))
    Q[Q[:, 3] < 0] *= -1
    ra = simulate_agents(load_design(DATA / "agent_pd.py"),
                         AgentFormation(g, J, Q, W, Gains(k_p=0.4, k_d=1.6)),
                         AgentOptions(tf=20, output_step=0.1, step=0.01))
    rc = fs.simulate(Formation(g, J, Q, W, Gains(k_p=0.4, k_d=1.6), no_disturbance(4)),
                     SimOptions(tf=20, output_step=0.1, step=0.01), spec="pd_consensus")
    xa = np.concatenate([ra.quaternions.reshape(len(ra.t), -1), ra.rates.reshape(len(ra.t), -1)],
                        axis=1)
    assert xa.shape == rc.x.shape
    assert np.abs(xa - rc.x).max() < 1e-8
    assert ra.state_names[:4] == ("q1_1", "q2_1", "q3_1", "q0_1")


def _so3_numpy(R0, W, J, A, k_R, k_w, tf, t_eval):
    n = len(R0)

    def f(t, y):
        R = y[: 9 * n].reshape(n, 3, 3)
        w = y[9 * n:].reshape(n, 3)
        dR, dw = np.empty_like(R), np.empty_like(w)
        for i in range(n):
            e = np.zeros(3)
            for j in range(n):
                if A[i, j]:
                    M = R[j].T @ R[i] - R[i].T @ R[j]
                    e += A[i, j] * 0.5 * np.array([M[2, 1], M[0, 2], M[1, 0]])
            u = np.cross(w[i], J[i] @ w[i]) - J[i] @ (k_R * e + k_w * w[i])
            dR[i] = R[i] @ cross(w[i])
            dw[i] = np.linalg.solve(J[i], -np.cross(w[i], J[i] @ w[i]) + u)
        return np.concatenate([dR.ravel(), dw.ravel()])

    y0 = np.concatenate([np.asarray(R0).ravel(), np.asarray(W).ravel()])
    sol = solve_ivp(f, (0, tf), y0, method="DOP853", rtol=1e-12, atol=1e-13, t_eval=t_eval)
    return sol.y.T[:, : 9 * n].reshape(-1, n, 3, 3)


def test_so3_design_on_the_paper_digraph_against_rotation_matrices_integrated_directly():
    rng = np.random.default_rng(11)
    g = digraph_from_edges(PAPER002, name="paper002")
    n = 5
    J, Q, W = _inertias(rng, n), _random_attitudes(rng, n, 2.5), 0.05 * rng.normal(size=(n, 3))
    d = load_design(DATA / "agent_so3.py")
    r = simulate_agents(d, AgentFormation(g, J, Q, W, Gains(k_R=0.8, k_w=1.5)),
                        AgentOptions(tf=10, output_step=0.5, step=0.005, angle_tol=1.0))
    Rn = _so3_numpy([_quat_to_R(q) for q in Q], W, J, g.adjacency, 0.8, 1.5, 10, r.t)
    Rk = np.array([[_quat_to_R(q) for q in row] for row in r.quaternions])
    assert np.abs(Rk - Rn).max() < 1e-7
    # on the group: |R^T R - I| of every sample
    orth = max(np.abs(R.T @ R - np.eye(3)).max() for row in Rk for R in row)
    assert orth < 1e-10
    tr = r.monitors["trace"]
    assert tr.shape == (len(r.t), n) and np.all(np.abs(tr) <= 3 + 1e-12)


def _mrp_numpy(S0, W, J, A, b, K, k_d, k_s, phi, w_ref, tf, t_eval):
    """MRP in its own coordinates with shadow switching (|sigma| = 1 events); reference
    spinning from identity at the constant body rate w_ref (sigma_ref integrated too)."""
    n = len(S0)

    def G(s):
        return 0.25 * ((1 - s @ s) * np.eye(3) + 2 * cross(s) + 2 * np.outer(s, s))

    def f(t, y):
        S = y[: 3 * n].reshape(n, 3)
        w = y[3 * n: 6 * n].reshape(n, 3)
        sr = y[6 * n:]
        dS, dw = np.empty_like(S), np.empty_like(w)
        for i in range(n):
            chi = b[i] * (S[i] - sr)
            for j in range(n):
                if A[i, j]:
                    chi += A[i, j] * (S[i] - S[j])
            e = w[i] - w_ref
            u = np.cross(w[i], J[i] @ w[i]) - J[i] @ (K * chi + k_d * e + k_s * np.tanh(e / phi))
            dS[i] = G(S[i]) @ w[i]
            dw[i] = np.linalg.solve(J[i], -np.cross(w[i], J[i] @ w[i]) + u)
        return np.concatenate([dS.ravel(), dw.ravel(), G(sr) @ w_ref])

    def crossing(k):
        at = 3 * k if k < n else 6 * n

        def ev(t, y):
            s = y[at: at + 3]
            return s @ s - 1.0 - 1e-9
        ev.terminal, ev.direction = True, 1
        return ev

    events = [crossing(k) for k in range(n + 1)]  # spacecraft 0..n-1 and the reference (n)
    y = np.concatenate([np.asarray(S0).ravel(), np.asarray(W).ravel(), np.zeros(3)])
    t0, ts, ys, switches = 0.0, [], [], 0
    grid = list(t_eval)
    while True:
        sol = solve_ivp(f, (t0, tf), y, method="DOP853", rtol=1e-12, atol=1e-13, events=events,
                        dense_output=True)
        t1 = sol.t[-1]
        while grid and grid[0] <= t1 + 1e-12:
            ts.append(grid[0])
            ys.append(sol.sol(min(grid.pop(0), t1)))
        if sol.status != 1:
            break
        y = sol.y[:, -1].copy()
        for k in range(n + 1):
            sl = slice(3 * k, 3 * k + 3) if k < n else slice(6 * n, 6 * n + 3)
            s = y[sl]
            if s @ s > 1.0:
                y[sl] = -s / (s @ s)
                switches += 1
        t0 = t1
    return np.array(ts), np.array(ys), switches


def test_mrp_leader_design_against_mrp_coordinates_with_shadow_switching():
    rng = np.random.default_rng(5)
    g = digraph_from_edges([(2, 1, 1), (3, 2, "0.5"), (3, 1, "0.5"), (1, 0, 2)], n=3,
                           name="leader3")
    n = 3
    J = _inertias(rng, n)
    Q = _random_attitudes(rng, n, 2.0)
    Q[Q[:, 3] < 0] *= -1
    W = 0.05 * rng.normal(size=(n, 3))
    w_ref = np.array([0.0, 0.0, 0.5])  # 0.5 rad/s: the reference passes 180 deg at 2*pi s
    d = load_design(DATA / "agent_mrp_leader.py")
    f = AgentFormation(g, J, Q, W, Gains(K=(0.5, 0.6, 0.7), k_d=1.5, k_s=0.01),
                       reference=Reference((0, 0, 0, 1), ("0", "0", "0.5")))
    r = simulate_agents(d, f, AgentOptions(tf=12, output_step=0.5, step=0.001, switch="tanh",
                                           phi=0.05))
    from formsync_design.models.mrp import mrp_from_quat

    S0 = np.array([mrp_from_quat(np.array([q[3], *q[:3]])) for q in Q])
    ts, ys, switches = _mrp_numpy(S0, W, J, g.adjacency, np.array([2.0, 0, 0]),
                                  np.array([0.5, 0.6, 0.7]), 1.5, 0.01, 0.05, w_ref, 12, r.t)
    assert switches >= 2  # the reference and the pinned spacecraft crossed the switching surface
    Sk = np.array([[mrp_from_quat(np.array([q[3], *q[:3]])) for q in row] for row in r.quaternions])
    Sn = ys[:, : 3 * n].reshape(-1, n, 3)
    # before the reference's first switch (at 2 pi s) both agree to the integrators' accuracy;
    # the law jumps with sigma_ref at a switch, where fixed-step RK4 is first order (h = 1e-3)
    before = r.t < 2 * math.pi - 0.5
    assert np.abs(Sk[before] - Sn[before]).max() < 1e-9
    assert np.abs(Sk - Sn).max() < 1e-4
    assert r.reference_error is not None and r.reference is not None


def test_filter_states_realise_the_first_order_filter():
    """Attitude-only feedback: x' = -lam (x - q) integrated with the plant (checked against
    the closed form of the filter driven by the simulated q, by quadrature)."""
    rng = np.random.default_rng(2)
    import formsync_design as fs

    g = fs.make_graph("path:3")
    J, Q, W = _inertias(rng, 3), _random_attitudes(rng, 3, 0.6), np.zeros((3, 3))
    Q[Q[:, 3] < 0] *= -1
    d = load_design(DATA / "agent_filter.py")
    x0 = 0.1 * rng.normal(size=(3, 3))
    r = simulate_agents(d, AgentFormation(g, J, Q, W, Gains(k_p=0.5, k_d=2.0, lam=4.0),
                                          states={"x": x0}),
                        AgentOptions(tf=30, output_step=0.01, step=0.005))
    lam, t = 4.0, r.t
    qv = r.quaternions[:, :, :3]
    # x(t) = e^{-lam t} x0 + int_0^t lam e^{-lam (t - s)} q(s) ds (Simpson on a fine grid)
    k = len(t) - 1
    integrand = lam * np.exp(-lam * (t[k] - t))[:, None, None] * qv
    from scipy.integrate import simpson

    xk = np.exp(-lam * t[k]) * x0 + simpson(integrand, x=t, axis=0)
    assert np.abs(r.states[k] - xk).max() < 1e-7
    assert r.attitude_error[-1] < r.attitude_error[0]


def test_compiled_kernel_matches_the_virtual_machine(monkeypatch):
    rng = np.random.default_rng(8)
    g = digraph_from_edges(PAPER002, name="paper002")
    J, Q, W = _inertias(rng, 5), _random_attitudes(rng, 5, 1.5), 0.02 * rng.normal(size=(5, 3))
    d = load_design(DATA / "agent_so3.py")
    f = AgentFormation(g, J, Q, W, Gains(k_R=1.0, k_w=1.0))
    opt = AgentOptions(tf=4, output_step=0.2, step=0.02)
    vm = simulate_agents(d, f, opt)
    monkeypatch.delenv("FORMSYNC_NO_COMPILE")
    cc = simulate_agents(d, f, opt)
    assert np.abs(vm.quaternions - cc.quaternions).max() < 1e-13


def test_cvodes_agrees_with_rk4():
    rng = np.random.default_rng(9)
    import formsync_design as fs

    g = fs.make_graph("ring:3")
    J, Q, W = _inertias(rng, 3), _random_attitudes(rng, 3, 1.0), 0.02 * rng.normal(size=(3, 3))
    d = load_design(DATA / "agent_so3.py")
    f = AgentFormation(g, J, Q, W, Gains(k_R=1.0, k_w=1.0))
    a = simulate_agents(d, f, AgentOptions(tf=5, output_step=0.5, step=0.005))
    b = simulate_agents(d, f, AgentOptions(tf=5, output_step=0.5, integrator="cvodes",
                                           rtol=1e-11, atol=1e-13))
    assert np.abs(a.quaternions - b.quaternions).max() < 1e-8


def test_formation_input_errors():
    import formsync_design as fs

    d = load_design(DATA / "agent_mrp_leader.py")
    g = fs.make_graph("path:2")
    J, Q, W = np.array([np.eye(3)] * 2), np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3))
    with pytest.raises(InputError, match="expected a reference"):
        simulate_agents(d, AgentFormation(g, J, Q, W, Gains(K=1.0, k_d=1.0, k_s=0.1)))
    with pytest.raises(InputError, match="pinning gains"):
        simulate_agents(d, AgentFormation(g, J, Q, W, Gains(K=1.0, k_d=1.0, k_s=0.1),
                                          reference=Reference()))
    d2 = load_design(DATA / "agent_so3.py")
    with pytest.raises(InputError, match="expected the gains k_R, k_w"):
        simulate_agents(d2, AgentFormation(g, J, Q, W, Gains(k=1.0)))
    with pytest.raises(InputError, match="step to divide output_step"):
        AgentOptions(output_step=0.1, step=0.03)


# --------------------------------------------------------------------- sampled simulation


def _zoh_loop(law, tau_of, g_of, x0, J, nbrs, tf, t_eval):
    """First-principles sample-and-hold loop: rigid bodies in quaternions, per-agent updates
    (broadcast, recompute the own torque from the neighbours' last broadcasts), held torques;
    self-triggered next times from tau_of, or static events g_of >= 0 located by solve_ivp."""
    n = len(x0)

    def f(t, y, u):
        X = y.reshape(n, 7)
        out = np.empty_like(X)
        for i in range(n):
            v, q0, w = X[i, :3], X[i, 3], X[i, 4:]
            out[i, :3] = 0.5 * (q0 * w + np.cross(v, w))
            out[i, 3] = -0.5 * v @ w
            out[i, 4:] = np.linalg.solve(J[i], -np.cross(w, J[i] @ w) + u[i])
        return out.ravel()

    held = np.array(x0, float)
    u = np.array([law(i, held[i], held) for i in range(n)])
    times = [[0.0] for _ in range(n)]
    nxt = [tau_of(i, held[i], held) if tau_of else None for i in range(n)]
    t, y = 0.0, held.ravel().copy()
    samples = {}
    grid = list(t_eval)
    while t < tf - 1e-12:
        if tau_of:
            t_next = min(min(nxt), tf)
            sol = solve_ivp(f, (t, t_next), y, args=(u,), method="DOP853", rtol=1e-12,
                            atol=1e-14, dense_output=True)
            fired = [i for i in range(n) if abs(nxt[i] - t_next) < 1e-12]
            t_hit = t_next
        else:
            evs = []
            for i in range(n):
                def ev(tt, yy, uu, i=i):
                    return g_of(i, yy.reshape(n, 7)[i], held)
                ev.terminal, ev.direction = True, 1
                evs.append(ev)
            sol = solve_ivp(f, (t, tf), y, args=(u,), method="DOP853", rtol=1e-12, atol=1e-14,
                            dense_output=True, events=evs)
            fired = [i for i in range(n) if sol.t_events[i].size]
            t_hit = sol.t[-1]
        while grid and grid[0] <= t_hit + 1e-12:
            tk = grid.pop(0)
            samples[tk] = sol.sol(min(tk, t_hit))
        t, y = t_hit, sol.y[:, -1].copy()
        if t >= tf - 1e-12:
            break
        X = y.reshape(n, 7)
        for i in fired:
            held[i] = X[i]
            times[i].append(t)
        for i in fired:
            u[i] = law(i, X[i], held)
            if tau_of:
                nxt[i] = t + tau_of(i, X[i], held)
    return np.array([samples[tk] for tk in t_eval]), times


def test_self_triggered_design_against_an_independent_sample_and_hold_loop():
    rng = np.random.default_rng(4)
    g = digraph_from_edges([(1, 2), (2, 1), (2, 3), (3, 2, "0.5")], name="path3-weighted")
    n = 3
    J, Q, W = _inertias(rng, n), _random_attitudes(rng, n, 0.8), 0.01 * rng.normal(size=(n, 3))
    Q[Q[:, 3] < 0] *= -1
    k_p, k_d, tau0 = 0.5, 2.0, 0.3
    d = load_design(DATA / "agent_selftrig.py")
    r = simulate_agents(d, AgentFormation(g, J, Q, W, Gains(k_p=k_p, k_d=k_d, tau0=tau0)),
                        AgentOptions(tf=6, output_step=0.5))
    A = g.adjacency

    def law(i, xi, held):
        s = sum((A[i, j] * (xi[:3] - held[j, :3] / np.linalg.norm(held[j, :4]))
                 for j in range(n) if A[i, j]), np.zeros(3))
        return -J[i] @ (k_p * s + k_d * xi[4:])

    def tau(i, xi, held):
        return tau0 / (1 + np.linalg.norm(xi[4:]))

    x0 = np.concatenate([Q, W], axis=1)
    ys, times = _zoh_loop(law, tau, None, x0, J, None, 6.0, r.t)
    assert r.transmissions is not None and r.trigger_times is not None
    for i in range(n):
        assert np.allclose(r.trigger_times[i], times[i], atol=1e-9)
    xk = np.concatenate([r.quaternions, r.rates], axis=2).reshape(len(r.t), -1)
    assert np.abs(xk - ys).max() < 1e-8
    assert int(r.transmissions.sum()) == sum(len(t) for t in times)


def test_event_triggered_design_against_an_independent_loop():
    rng = np.random.default_rng(6)
    import formsync_design as fs

    g = fs.make_graph("path:2")
    J, Q, W = _inertias(rng, 2), _random_attitudes(rng, 2, 0.8), 0.01 * rng.normal(size=(2, 3))
    Q[Q[:, 3] < 0] *= -1
    k_p, k_d, delta = 0.5, 2.0, 0.02
    d = load_design(DATA / "agent_event.py")
    r = simulate_agents(d, AgentFormation(g, J, Q, W, Gains(k_p=k_p, k_d=k_d, delta=delta)),
                        AgentOptions(tf=8, output_step=0.5))
    A = g.adjacency

    def law(i, xi, held):
        s = sum((A[i, j] * (xi[:3] - held[j, :3]) for j in range(2) if A[i, j]), np.zeros(3))
        return -J[i] @ (k_p * s + k_d * xi[4:])

    def gfun(i, xi, held):
        e = xi[:3] / np.linalg.norm(xi[:4]) - held[i, :3] / np.linalg.norm(held[i, :4])
        return e @ e - delta**2

    ys, times = _zoh_loop(law, None, gfun, np.concatenate([Q, W], axis=1), J, None, 8.0, r.t)
    assert r.trigger_times is not None and sum(len(t) for t in times) > 4
    for i in range(2):
        assert np.allclose(r.trigger_times[i], times[i], atol=1e-7)
    xk = np.concatenate([r.quaternions, r.rates], axis=2).reshape(len(r.t), -1)
    assert np.abs(xk - ys).max() < 1e-7


def test_periodic_sampling_needs_a_period():
    d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}},
                                    sampling="periodic")
    import formsync_design as fs

    f = AgentFormation(fs.make_graph("path:2"), np.array([np.eye(3)] * 2),
                       np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.1), Gains(k=1.0))
    with pytest.raises(InputError, match="sampling period"):
        simulate_agents(d, f, AgentOptions(tf=1, output_step=0.5))
    r = simulate_agents(d, f, AgentOptions(tf=1, output_step=0.5, period=0.25))
    # u = -k J w held over 0.25 s: w(t_{k+1}) = (1 - k T) w(t_k) exactly (free axis-symmetric)
    assert abs(r.rates[-1, 0, 0] - 0.1 * (1 - 0.25) ** 4) < 1e-10
    assert r.transmissions is not None and r.transmissions.tolist() == [4, 4]


def test_principal_angles_against_rotation_matrices_and_at_tiny_angles():
    """The angle of ``R_a^T R_b`` from its trace (an independent formula) at generic angles,
    and exactly the constructed angle where ``arccos`` of the dot product would give 0."""
    from scipy.spatial.transform import Rotation

    from formsync_design.sim.disagreement import principal_angles

    rng = np.random.default_rng(11)
    ra, rb = Rotation.random(200, random_state=rng), Rotation.random(200, random_state=rng)
    qa, qb = ra.as_quat(), rb.as_quat() * rng.choice([-1.0, 1.0], size=(200, 1))  # scalar last
    rel = np.einsum("kji,kjl->kil", ra.as_matrix(), rb.as_matrix())
    want = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    np.testing.assert_allclose(principal_angles(qa, qb), want, atol=1e-7)
    axis = rng.normal(size=(50, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    theta = 10.0 ** rng.uniform(-14, -6, size=50)
    qa = ra.as_quat()[:50]
    qb = (ra[:50] * Rotation.from_rotvec(axis * theta[:, None])).as_quat()
    # qb itself is rounded to about 1e-16 per component: that is the floor of any formula
    np.testing.assert_allclose(principal_angles(qa, qb), theta, rtol=1e-6, atol=1e-15)
