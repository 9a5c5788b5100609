"""The self-triggered MRP design (seed 001) and its case kind, against independent truth:
quaternion propagation for the MRP kinematics and shadow switching, first-principles NumPy
sample-and-hold loops with the same trigger rules, the certified inter-event bound against
every measured interval of a seeded Monte-Carlo, and random sampling for the surface bound.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from formsync_design.analysis.triggering import interevent_bound
from formsync_design.errors import DerivationError
from formsync_design.graphs.digraph_io import digraph_from_edges
from formsync_design.models.disturbances import no_disturbance
from formsync_design.models.mrp import integrate_mrp, mrp_rate_matrix
from formsync_design.sim.agent_sampled import attitude_entries_np
from formsync_design.sim.agents import (
    AgentFormation,
    AgentOptions,
    Reference,
    simulate_agents_sampled,
)
from formsync_design.sim.formation import Gains
from formsync_design.spec.agent import agent_design_from_functions, rule_variant
from formsync_design.spec.agent_view import mrp_G
from formsync_design.spec.loader import load_design


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


@pytest.fixture(scope="module")
def designs():
    d = load_design("selftrigger_mrp")
    return {"self-triggered": d, "event": rule_variant(d, "event"),
            "periodic": rule_variant(d, "periodic")}


def run_scheme(designs, f, opt, scheme):
    """One run under a scheme with the design's own measurements (the engine's path: the
    scenario's rule_variant, the sampled simulator's record, sliding_measurements)."""
    from types import SimpleNamespace

    rec = {}
    res = simulate_agents_sampled(designs[scheme], f, opt, record=rec)
    d = designs["self-triggered"]
    ms = d.module["sliding_measurements"](d, f, opt, res, rec, 0.2)
    return SimpleNamespace(result=res, evaluations=np.asarray(rec["trigger_evaluations"]),
                           transmissions=np.asarray(res.transmissions), **ms)


GAINS = {"r": 0.5, "m_f": 1.5, "delta": 0.05, "eps": 0.01, "alpha": 0.1, "eta0": 0.05}
W_REF = np.array([0.0, 0.0, 0.04])


def _qmul(p, q):
    pv, p0, qv, q0 = p[:3], p[3], q[:3], q[3]
    return np.concatenate([p0 * qv + q0 * pv + np.cross(pv, qv), [p0 * q0 - pv @ qv]])


def _formation(rng, disturbance=None):
    g = digraph_from_edges([(2, 1, 1), (3, 2, 1), (3, 1, "0.5"), (1, 0, 1), (2, 0, "0.5")], n=3,
                           name="leader3")
    J = np.array([np.diag(20 + 10 * rng.random(3)) + 0.3 * (M + M.T)
                  for M in rng.normal(size=(3, 3, 3))])
    Q = []
    for _ in range(3):
        ax = rng.normal(size=3)
        ax /= np.linalg.norm(ax)
        a = 1.2 * rng.random()
        Q.append([*(math.sin(a / 2) * ax), math.cos(a / 2)])
    W = 0.01 * rng.normal(size=(3, 3))
    return AgentFormation(g, J, np.array(Q), W, Gains(**GAINS),
                          disturbance or no_disturbance(3),
                          Reference((0, 0, 0, 1), tuple(str(x) for x in W_REF)))


# ----------------------------------------------------------- MRP kinematics and shadow set


def test_mrp_seen_by_the_design_against_quaternion_propagation_with_shadow_switching():
    """A tumbling asymmetric body: quaternion + Euler integrated by SciPy, mapped to the short
    set as the engine hands it to the design, against the MRP kinematics with shadow
    switching (``integrate_mrp``); the design's symbolic G against finite differences."""
    J = np.diag([10.0, 15.0, 22.0]) + 0.5 * np.array([[0, 1, 0], [1, 0, 0.4], [0, 0.4, 0]])
    w0 = np.array([0.9, 0.2, 1.3])
    t = np.linspace(0, 12, 241)

    def f(tt, x):
        v, q0, w = x[:3], x[3], x[4:]
        return np.concatenate([0.5 * (q0 * w + np.cross(v, w)), [-0.5 * v @ w],
                               np.linalg.solve(J, -np.cross(w, J @ w))])

    sol = solve_ivp(f, (0, 12), [0, 0, 0, 1, *w0], t_eval=t, rtol=1e-12, atol=1e-13)
    S_q = np.array([attitude_entries_np("mrp", x[:4]) for x in sol.y.T])
    tr = integrate_mrp(lambda tt, s, w: (w, np.linalg.solve(J, -np.cross(w, J @ w))),
                       [0, 0, 0], t, w0, rtol=1e-12, atol=1e-13)
    assert len(tr.switch_times) >= 2  # the body turned through 180 degrees twice or more
    assert np.abs(S_q - tr.sigma).max() < 1e-8
    assert np.all(np.linalg.norm(S_q, axis=1) <= 1 + 1e-12)
    # sigma' = G(sigma) w with the design's symbolic G, by central differences off the switches
    s = sp.Matrix(sp.symbols("s1:4"))
    G = sp.lambdify(list(s), mrp_G(s), "numpy")
    h = t[1] - t[0]
    far = [k for k in range(1, len(t) - 1)
           if min(abs(t[k] - ts) for ts in tr.switch_times) > 3 * h]
    for k in far[::10]:
        fd = (S_q[k + 1] - S_q[k - 1]) / (2 * h)
        an = np.asarray(G(*S_q[k]), float) @ sol.y[4:, k]
        assert np.abs(fd - an).max() < 2e-3 * (1 + np.abs(an).max())
        assert np.allclose(np.asarray(G(*S_q[k]), float), mrp_rate_matrix(S_q[k]), atol=1e-15)


# ----------------------------------------------------------- independent sample-and-hold loop


def _ref(t):
    nw = np.linalg.norm(W_REF)
    return np.concatenate([math.sin(nw * t / 2) * W_REF / nw, [math.cos(nw * t / 2)]])


def _mrp(q):
    return attitude_entries_np("mrp", q)


def _numpy_loop(f, scheme, tf, t_eval):
    """Rigid bodies in quaternions; at an update the spacecraft broadcasts (sigma, w), keeps
    s_i and c_i, computes u_i from the law written out here and holds it; the self-trigger's
    next time from its state, or the event rule by solve_ivp events."""
    n, J, A = f.n, f.inertias, f.graph.adjacency
    b = f.graph.pinning_matrix.diagonal()
    D = A.sum(axis=1) + b
    r, m, delta, eps, alpha, eta0 = (GAINS[k] for k in ("r", "m_f", "delta", "eps", "alpha", "eta0"))

    def parts(i, x, held, t):
        sig, w = _mrp(x[:4]), x[4:]
        sd, wd = _mrp(_ref(t)), W_REF
        chi1 = b[i] * (sig - sd)
        chi2 = b[i] * (w - wd)
        c = np.zeros(3)
        for j in range(n):
            if A[i, j]:
                sj, wj = _mrp(held[j, :4]), held[j, 4:]
                chi1 += A[i, j] * (sig - sj)
                chi2 += A[i, j] * (w - wj)
                c += A[i, j] * (r * sj + wj)
        s = r * chi1 + chi2
        ups = r * (D[i] * mrp_rate_matrix(sig) @ w - b[i] * mrp_rate_matrix(sd) @ wd)
        return s, c, ups, r * sig + w, r * sd + wd

    def law(i, x, held, t):
        s, c, ups, _, _ = parts(i, x, held, t)
        w = x[4:]
        return np.cross(w, J[i] @ w) - J[i] @ (ups + m * s) / D[i], s, c

    def tau(i, x, held, t):
        s = parts(i, x, held, t)[0]
        h = eta0 * math.exp(-alpha * t)
        return ((1 - 1 / m) * np.linalg.norm(s) + eps + h) / (m * np.linalg.norm(s) + delta + alpha * h)

    def g_ev(i, x, t, sk, ck):
        sig, w = _mrp(x[:4]), x[4:]
        sbar = D[i] * (r * sig + w) - ck - b[i] * (r * _mrp(_ref(t)) + W_REF)
        e = sk - sbar
        thr = (1 - 1 / m) * np.linalg.norm(sk) + eps + eta0 * math.exp(-alpha * t)
        return e @ e - thr**2

    def rhs(t, y, u):
        X = y.reshape(n, 7)
        out = np.empty_like(X)
        for i in range(n):
            v, q0, w = X[i, :3], X[i, 3], X[i, 4:]
            out[i, :3] = 0.5 * (q0 * w + np.cross(v, w))
            out[i, 3] = -0.5 * v @ w
            out[i, 4:] = np.linalg.solve(J[i], -np.cross(w, J[i] @ w) + u[i])
        return out.ravel()

    held = np.concatenate([f.attitudes, f.rates], axis=1)
    u, sk, ck = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    for i in range(n):
        u[i], sk[i], ck[i] = law(i, held[i], held, 0.0)
    times = [[0.0] for _ in range(n)]
    nxt = [tau(i, held[i], held, 0.0) for i in range(n)]
    t, y = 0.0, held.ravel().copy()
    samples: dict[float, np.ndarray] = {}
    grid = list(t_eval)
    while t < tf - 1e-12:
        if scheme == "self-triggered":
            t_hit = min(min(nxt), tf)
            sol = solve_ivp(rhs, (t, t_hit), y, args=(u,), method="DOP853", rtol=1e-12,
                            atol=1e-14, dense_output=True)
            fired = [i for i in range(n) if abs(nxt[i] - t_hit) < 1e-12]
        else:
            evs = []
            for i in range(n):
                def ev(tt, yy, uu, i=i):
                    return g_ev(i, yy.reshape(n, 7)[i], tt, sk[i], ck[i])
                ev.terminal, ev.direction = True, 1
                evs.append(ev)
            sol = solve_ivp(rhs, (t, tf), y, args=(u,), method="DOP853", rtol=1e-12, atol=1e-14,
                            dense_output=True, events=evs)
            fired = [i for i in range(n) if sol.t_events[i].size]
            t_hit = float(sol.t[-1])
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
            u[i], sk[i], ck[i] = law(i, X[i], held, t)
            if scheme == "self-triggered":
                nxt[i] = t + tau(i, X[i], held, t)
    return np.array([samples[tk] for tk in t_eval]), times


@pytest.mark.parametrize("scheme", ["self-triggered", "event"])
def test_hybrid_simulation_against_an_independent_numpy_loop(designs, scheme):
    f = _formation(np.random.default_rng(11))
    opt = AgentOptions(tf=8, output_step=0.5, rtol=1e-11, atol=1e-13)
    run = run_scheme(designs, f, opt, scheme)
    ys, times = _numpy_loop(f, scheme, 8.0, run.result.t)
    tt = run.result.trigger_times
    assert tt is not None and sum(len(x) for x in times) >= 12
    for i in range(3):
        assert len(tt[i]) == len(times[i])
        assert np.allclose(tt[i], times[i], atol=1e-7)
    xk = np.concatenate([run.result.quaternions, run.result.rates], axis=2).reshape(len(run.result.t), -1)
    assert np.abs(xk - ys).max() < 1e-7
    if scheme == "self-triggered":  # one evaluation of the rule per broadcast, none in between
        assert np.array_equal(run.evaluations, run.transmissions)
    else:
        assert np.all(run.evaluations > 10 * run.transmissions)
    assert run.e_ratio <= 1 + 1e-6  # the trigger kept |e_i| below its threshold


def test_trigger_times_are_reproducible(designs):
    f = _formation(np.random.default_rng(3))
    opt = AgentOptions(tf=4, output_step=0.5)
    a = run_scheme(designs, f, opt, "event").result.trigger_times
    b = run_scheme(designs, f, opt, "event").result.trigger_times
    assert a is not None and b is not None
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


# ----------------------------------------------------------- the certified inter-event bound


def test_interevent_bound_is_derived_from_the_rule_and_below_every_measured_interval(designs):
    d = designs["self-triggered"]
    fr = {k: Fraction(v).limit_denominator(10**6) for k, v in GAINS.items()}
    bnd = interevent_bound(d, fr)
    th = 1 - 1 / fr["m_f"]
    assert bnd.value == min(th / fr["m_f"], fr["eps"] / fr["delta"], 1 / fr["alpha"])
    tau = float(bnd.value)
    rng = np.random.default_rng(2024)
    from formsync_design.models.disturbances import constant_disturbance

    inside = 0
    for _ in range(3):
        f = _formation(rng, constant_disturbance(2e-3 * rng.normal(size=(3, 3))))
        for scheme in ("self-triggered", "event"):
            run = run_scheme(designs, f, AgentOptions(tf=6, output_step=0.5), scheme)
            gaps = np.concatenate([np.diff(t) for t in run.result.trigger_times])
            assert gaps.size > 10
            if scheme == "self-triggered" or run.f_ratio <= 1:
                inside += 1
                assert gaps.min() >= tau * (1 - 1e-9), (scheme, gaps.min(), tau)
    assert inside == 6  # the delta assumption held in every event run: the check is not vacuous


# ----------------------------------------------------------- derivation and certificate


def test_surface_bound_holds_on_random_points():
    """|e^T (G(sigma) - G(sigma_d)) w_d| <= 3/2 rho |w_d| |e|^2 for |sigma|, |sigma_d| <= rho."""
    rng = np.random.default_rng(0)
    rho = 0.6
    for _ in range(20000):
        a, b = rng.normal(size=3), rng.normal(size=3)
        a *= rho * rng.random() ** (1 / 3) / np.linalg.norm(a)
        b *= rho * rng.random() ** (1 / 3) / np.linalg.norm(b)
        w = rng.normal(size=3)
        e = a - b
        lhs = abs(e @ (mrp_rate_matrix(a) - mrp_rate_matrix(b)) @ w)
        assert lhs <= 1.5 * rho * np.linalg.norm(w) * (e @ e) * (1 + 1e-12) + 1e-15


def test_certificate_families_and_a_law_that_does_not_cancel_is_refused():
    from formsync_design.certify.agent import certify_families as certify_design

    d = load_design("selftrigger_mrp")
    g = digraph_from_edges([(2, 1, 1), (3, 2, 1), (3, 1, "0.5"), (1, 0, 1), (2, 0, "0.5")], n=3)
    box = {k: str(v) for k, v in GAINS.items()}
    box["m_f"] = "1.2:1.5"
    assert str(certify_design(d, g, box).status) == "certified"
    box["m_f"] = "1/2:3/4"  # m < 1: no positive relative threshold
    r = certify_design(d, g, box)
    assert str(r.status) != "certified"
    mod = dict(d.module)

    def bad(v):  # drops the gyroscopic cancellation
        p = mod["parts"](v)
        return -v.J * (p["upsilon"] + v.m_f * p["s"]) / p["D"]

    from formsync_design.derive.agent import agent_conditions

    b = agent_design_from_functions(bad, representation="mrp", leader=True,
                                    gains={k: d.module["GAINS"][k] for k in ("r", "m_f", "mu")},
                                    conditions=lambda c: mod["conditions"](c))
    with pytest.raises(DerivationError, match="does not cancel the model"):
        agent_conditions(b, g)


def test_kept_values_are_validated():
    with pytest.raises(DerivationError, match="HOLD.*sampled design"):
        agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}, hold={"a": 3},
                                    hold_fn=lambda v: {"a": v.w})
    with pytest.raises(DerivationError, match="kept values v.kept only"):
        agent_design_from_functions(lambda v: -v.k * v.kept["a"], gains={"k": {}},
                                    sampling="periodic", hold={"a": 3},
                                    hold_fn=lambda v: {"a": v.w})
    with pytest.raises(DerivationError, match="function hold"):
        agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}, sampling="periodic",
                                    hold={"a": 3})
