"""The hybrid simulator (:mod:`formsync_design.sim.hybrid`) against independent truth.

Truths used: an independent fixed-step RK4 loop with bisection event location (written
here, sharing no code with the simulator); the exact discretization of a linear system
(matrix exponential); closed-form trigger times; the geometric accumulation of a Zeno rule;
Girard's (2015) invariant ``eta >= 0`` of the dynamic trigger.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.linalg import expm

from formsync_design.errors import InputError
from formsync_design.sim.hybrid import (
    HybridOptions,
    HybridStatus,
    dynamic_event,
    event,
    periodic,
    self_triggered,
    simulate_hybrid,
)

# ---------------------------------------------------------------- double-integrator consensus
ADJ = np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]], dtype=float)  # path 1-2-3
DAMP = 0.3


def di_dynamics(t, x, u):
    """p' = v, v' = u - DAMP v for each agent; x rows (p, v), u rows (u,)."""
    return np.column_stack([x[:, 1], u[:, 0] - DAMP * x[:, 1]])


def di_law(t, i, xi, held):
    own = held[i]
    return np.array(
        [-sum(ADJ[i, j] * ((own[0] - held[j][0]) + (own[1] - held[j][1])) for j in range(3))]
    )


def di_g(t, i, xi, held):
    return float(np.linalg.norm(xi - held[i]) - (0.02 + 0.1 * math.exp(-t)))


def numpy_loop(x0, t_end, recompute, h=1e-3):
    """Independent reference: RK4 with fixed step h, bisection to locate each crossing."""
    x = np.array(x0, dtype=float)
    held = x.copy()
    n = len(x)
    u = np.array([di_law(0.0, i, x[i], held)[0] for i in range(n)])
    trig = [[0.0] for _ in range(n)]

    def f(xx, uu):
        return np.column_stack([xx[:, 1], uu - DAMP * xx[:, 1]])

    def rk4(xx, s):
        k1 = f(xx, u)
        k2 = f(xx + s / 2 * k1, u)
        k3 = f(xx + s / 2 * k2, u)
        k4 = f(xx + s * k3, u)
        return xx + s / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def g(i, t, xx):
        return np.linalg.norm(xx[i] - held[i]) - (0.02 + 0.1 * math.exp(-t))

    t = 0.0
    while t < t_end - 1e-12:
        s_max = min(h, t_end - t)
        x_new = rk4(x, s_max)
        roots = {}
        for i in range(n):
            if g(i, t + s_max, x_new) >= 0:
                lo, hi = 0.0, s_max
                for _ in range(80):
                    mid = 0.5 * (lo + hi)
                    if g(i, t + mid, rk4(x, mid)) >= 0:
                        hi = mid
                    else:
                        lo = mid
                roots[i] = hi
        if not roots:
            x, t = x_new, t + s_max
            continue
        s_star = min(roots.values())
        firing = sorted(i for i, s in roots.items() if s - s_star < 1e-9)
        x, t = rk4(x, s_star), t + s_star
        for i in firing:
            held[i] = x[i]
            trig[i].append(t)
        upd = set(firing)
        if recompute:
            upd |= {j for j in range(n) for i in firing if ADJ[j, i]}
        for j in sorted(upd):
            u[j] = di_law(t, j, x[j], held)[0]
    return trig


@pytest.mark.parametrize("recompute", [False, True])
def test_event_triggered_consensus_matches_numpy_loop(recompute):
    rng = np.random.default_rng(20261123)
    x0 = rng.uniform(-1.0, 1.0, size=(3, 2))
    t_end = 4.0
    res = simulate_hybrid(
        di_dynamics,
        di_law,
        [event(di_g)] * 3,
        x0,
        (0.0, t_end),
        np.linspace(0.0, t_end, 41),
        adjacency=ADJ,
        options=HybridOptions(recompute_on_receive=recompute),
    )
    assert res.status is HybridStatus.COMPLETED
    ref = numpy_loop(x0, t_end, recompute)
    for i in range(3):
        assert len(res.trigger_times[i]) == len(ref[i]) > 3
        np.testing.assert_allclose(res.trigger_times[i], ref[i], atol=1e-9)
    assert res.transmissions.tolist() == [len(r) for r in ref]
    gaps = [np.diff(r) for r in ref]
    np.testing.assert_allclose(res.min_interevent, [gp.min() for gp in gaps], atol=2e-9)
    np.testing.assert_allclose(res.mean_interevent, [gp.mean() for gp in gaps], atol=2e-9)
    # the run reaches consensus-ish: the spread shrinks
    assert np.ptp(res.x[-1, :, 0]) < np.ptp(x0[:, 0])


# ---------------------------------------------------------------- periodic vs exact discretization
A_S, B_S, K_S = 0.7, 1.3, 2.0


def scalar_dynamics(t, x, u):
    return A_S * x + B_S * u


def test_periodic_matches_exact_discretization():
    periods = [0.3, 0.45]
    x0 = np.array([[1.0], [-2.0]])
    t_eval = np.linspace(0.0, 3.0, 61)
    res = simulate_hybrid(
        scalar_dynamics,
        lambda t, i, xi, held: -K_S * xi,
        [periodic(T) for T in periods],
        x0,
        (0.0, 3.0),
        t_eval,
    )
    assert res.status is HybridStatus.COMPLETED
    m = np.array([[A_S, B_S], [0.0, 0.0]])
    for i, T in enumerate(periods):
        # exact: z = (x, u) evolves by expm(m s) between samples, u_k = -K x(t_k)
        expected = []
        tk, xk = 0.0, x0[i, 0]
        k = 0
        for t in t_eval:
            while t >= (k + 1) * T - 1e-12 and (k + 1) * T < 3.0 - 1e-12:
                xk = (expm(m * ((k + 1) * T - tk)) @ [xk, -K_S * xk])[0]
                k += 1
                tk = k * T
            expected.append((expm(m * (t - tk)) @ [xk, -K_S * xk])[0])
        np.testing.assert_allclose(res.x[:, i, 0], expected, rtol=1e-8, atol=1e-10)
        n_expected = len([k for k in range(100) if k * T < 3.0 - 1e-12])
        assert res.transmissions[i] == n_expected
        np.testing.assert_allclose(
            res.trigger_times[i], [k * T for k in range(n_expected)], atol=1e-12
        )
    # control effort: sum over samples of u_k^2 * (length of the hold interval)
    states = res.trigger_states[0][:, 0]
    holds = np.diff(list(res.trigger_times[0]) + [3.0])
    assert res.control_effort[0] == pytest.approx(
        float(np.sum((K_S * states) ** 2 * holds)), rel=1e-12
    )


# ---------------------------------------------------------------- self-triggered times = formula
def tau_formula(xk):
    return 0.1 + 0.2 / (1.0 + xk**2)


def test_self_triggered_times_follow_formula_and_reproduce():
    def run():
        return simulate_hybrid(
            lambda t, x, u: -0.5 * x + u,
            lambda t, i, xi, held: -xi,
            [self_triggered(lambda t, i, xi, held: tau_formula(float(xi[0])))],
            [[2.0]],
            (0.0, 2.0),
            [2.0],
        )

    res = run()
    # exact: x_{k+1} = expm(M tau_k) (x_k, -x_k), tau_k from the formula
    m = np.array([[-0.5, 1.0], [0.0, 0.0]])
    times, xk, t = [], 2.0, 0.0
    while t < 2.0:
        times.append(t)
        tau = tau_formula(xk)
        xk = (expm(m * tau) @ [xk, -xk])[0]
        t += tau
    np.testing.assert_allclose(res.trigger_times[0], times, rtol=0, atol=1e-9)
    assert run().trigger_times == res.trigger_times  # bit-for-bit reproducible


# ---------------------------------------------------------------- event location accuracy
def test_event_location_closed_form():
    rel = 0.2

    def g(t, i, xi, held):
        return abs(xi[0] - held[i][0]) - rel * abs(held[i][0])

    res = simulate_hybrid(
        lambda t, x, u: -x + u,
        lambda t, i, xi, held: -0.5 * xi,
        [event(g)],
        [[1.0]],
        (0.0, 5.0),
        [5.0],
    )
    assert res.status is HybridStatus.COMPLETED
    # x(s) = u + (x_k - u) e^-s with u = -x_k/2: |x - x_k| = 0.2|x_k| at s = ln(1.5/1.3)
    s_exact = math.log(1.5 / 1.3)
    ts = np.array(res.trigger_times[0])
    assert len(ts) == math.floor(5.0 / s_exact) + 1
    np.testing.assert_allclose(np.diff(ts), s_exact, atol=1e-11)
    xs = res.trigger_states[0][:, 0]
    np.testing.assert_allclose(xs[1:] / xs[:-1], 1 - rel, atol=1e-10)
    residuals = [abs(g(0.0, 0, xs[k : k + 1], {0: xs[k - 1 : k]})) for k in range(1, len(xs))]
    assert max(residuals) < 1e-10


# ---------------------------------------------------------------- Zeno protection
def zeno_g(t, i, xi, held):
    return abs(xi[0] - held[i][0]) - 0.5 * (1.0 - t)


def zeno_run(**opts):
    return simulate_hybrid(
        lambda t, x, u: u,
        lambda t, i, xi, held: np.array([1.0]),
        [event(zeno_g)],
        [[0.0]],
        (0.0, 2.0),
        [0.0, 2.0],
        options=HybridOptions(**opts),
    )


def test_zeno_rule_stopped_by_min_interevent():
    res = zeno_run(min_interevent=1e-6)
    assert res.status is HybridStatus.ZENO
    assert "min_interevent" in res.message and "agent 1" in res.message
    # trigger times accumulate geometrically at t = 1: 1 - t_k = (1/(1+c))^k with c = 0.5
    ts = np.array(res.trigger_times[0])
    np.testing.assert_allclose(1 - ts, (1 / 1.5) ** np.arange(len(ts)), atol=1e-10)
    assert 0.99 < res.stop_time < 1.0
    assert len(res.t) == 1  # the output at t = 2 was never reached


def test_zeno_rule_stopped_by_trigger_cap():
    res = zeno_run(min_interevent=0.0, max_triggers=20)
    assert res.status is HybridStatus.MAX_TRIGGERS
    assert res.transmissions[0] == 21  # the initial broadcast plus the cap


def test_zero_threshold_fires_again_at_once_and_is_reported():
    res = simulate_hybrid(
        lambda t, x, u: u,
        lambda t, i, xi, held: np.array([1.0]),
        [event(lambda t, i, xi, held: abs(xi[0] - held[i][0]))],
        [[0.0]],
        (0.0, 1.0),
        [1.0],
    )
    assert res.status is HybridStatus.ZENO


# ---------------------------------------------------------------- dynamic trigger (Girard 2015)
def test_dynamic_event_keeps_eta_nonnegative_and_transmits_less_than_static():
    rng = np.random.default_rng(7)
    x0 = rng.uniform(-1.0, 1.0, size=(3, 2))
    t_eval = np.linspace(0.0, 4.0, 201)
    static = simulate_hybrid(di_dynamics, di_law, [event(di_g)] * 3, x0, (0.0, 4.0), t_eval)
    dyn = simulate_hybrid(
        di_dynamics,
        di_law,
        [dynamic_event(di_g, beta=1.0, theta=1.0, eta0=0.05)] * 3,
        x0,
        (0.0, 4.0),
        t_eval,
    )
    assert dyn.status is HybridStatus.COMPLETED
    assert np.nanmin(dyn.eta) > -1e-9  # eta' >= -(beta + 1/theta) eta between events
    assert np.all(np.isnan(static.eta))
    assert dyn.transmissions.sum() <= static.transmissions.sum()


# ---------------------------------------------------------------- outputs and bad input
def test_to_dict_is_json_ready():
    res = simulate_hybrid(
        lambda t, x, u: u,
        lambda t, i, xi, held: -xi,
        [periodic(0.4), periodic(5.0)],
        [[1.0], [1.0]],
        (0.0, 1.0),
        [0.0, 1.0],
    )
    d = json.loads(json.dumps(res.to_dict()))
    assert d["status"] == "completed"
    assert d["transmissions"] == [3, 1]
    assert d["min_interevent"][1] == "nan"


def test_bad_input_raises_input_error():
    with pytest.raises(InputError, match="expected 2 trigger rules"):
        simulate_hybrid(
            lambda t, x, u: u,
            lambda t, i, xi, held: -xi,
            [periodic(1.0)],
            [[1.0], [1.0]],
            (0.0, 1.0),
            [1.0],
        )
    with pytest.raises(InputError, match="period > 0"):
        periodic(-1.0)


# ---------------------------------------------------------------- an MRP plant (representation-agnostic)
def test_mrp_plant_with_self_triggered_rate_damping_matches_closed_form():
    """Rows (sigma, omega) of spherical spacecraft, u_i = -k omega_i(t_k): about a fixed
    axis a, omega stays along a, omega(t) = omega_k (1 - k s / j) between triggers and
    sigma = tan(phi / 4) a with phi' = |omega| (the MRP of a rotation by phi about a)."""
    from formsync_design.models.mrp import mrp_rate_matrix

    j, k = 2.0, 1.5
    axes = np.array([[1.0, 2.0, 2.0], [0.0, -3.0, 4.0]])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    phi0, w0 = np.array([0.3, -0.8]), np.array([0.4, 0.25])

    def plant(t, x, u):
        sig_dot = np.array([mrp_rate_matrix(row[:3]) @ row[3:] for row in x])
        return np.hstack([sig_dot, u / j])

    def tau(t, i, xi, held):
        return 0.2 / (1.0 + float(np.linalg.norm(xi[3:])))

    x0 = np.hstack([np.tan(phi0 / 4)[:, None] * axes, w0[:, None] * axes])
    res = simulate_hybrid(
        plant,
        lambda t, i, xi, held: -k * xi[3:],
        [self_triggered(tau)] * 2,
        x0,
        (0.0, 3.0),
        [3.0],
    )
    assert res.status is HybridStatus.COMPLETED
    for i in range(2):
        t, w, phi, times = 0.0, w0[i], phi0[i], []
        while t < 3.0:
            times.append(t)
            s = min(0.2 / (1.0 + abs(w)), 3.0 - t)
            phi += w * s - k * w * s**2 / (2 * j)
            w *= 1 - k * s / j
            t += s
        np.testing.assert_allclose(res.trigger_times[i], times, atol=1e-9)
        np.testing.assert_allclose(res.x[-1, i, 3:], w * axes[i], atol=1e-9)
        np.testing.assert_allclose(res.x[-1, i, :3], math.tan(phi / 4) * axes[i], atol=1e-9)


def test_simultaneous_triggers_apply_all_broadcasts_first():
    """Three agents x' = u on a path, all periodic with the same T, u_i = -sum_j a_ij
    (held_i - held_j): with all broadcasts of an instant applied before any control is
    recomputed, x_{k+1} = (I - T L) x_k exactly (L the path Laplacian)."""
    lap = np.diag(ADJ.sum(axis=1)) - ADJ
    T = 0.25

    def law(t, i, xi, held):
        return np.array([-(lap[i] @ held[:, 0])])

    x0 = np.array([[1.0], [-0.5], [2.0]])
    t_eval = T * np.arange(9)
    res = simulate_hybrid(lambda t, x, u: u, law, [periodic(T)] * 3, x0, (0.0, 2.0), t_eval)
    expected = [x0[:, 0]]
    for _ in range(8):
        expected.append((np.eye(3) - T * lap) @ expected[-1])
    np.testing.assert_allclose(res.x[:, :, 0], expected, atol=1e-12)
    assert res.trigger_times[0] == res.trigger_times[1] == res.trigger_times[2]
