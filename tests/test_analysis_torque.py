"""Certified peak-torque bound (issue 15, item 2).

Independent truth: scipy's Lyapunov solver for the per-mode ``P_k``; the CasADi
simulator (:func:`formsync_design.sim.simulator.simulate`) for the controller's
torque and for the peak torques actually reached from the initial set.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from scipy.linalg import solve_continuous_lyapunov

from formsync_design.analysis.modes import LAMBDA
from formsync_design.analysis.torque import controller_torque, mode_lyapunov, peak_torque_bound
from formsync_design.errors import InputError
from formsync_design.graphs import make_graph
from formsync_design.models.disturbances import no_disturbance
from formsync_design.sim.formation import Formation, Gains, SimOptions, unpack_state
from formsync_design.sim.simulator import simulate

J0 = np.diag([50.0, 55.0, 60.0])


@pytest.mark.parametrize("gains", [(1.6, 0.4, 0.3), (0.7, 2.0, 0.1)])
def test_mode_lyapunov_matches_scipy(gains) -> None:
    d = mode_lyapunov(gains)
    ko, kq = gains[0], gains[1]
    for lam in (0.5, 2.0, 7.3):
        a = np.array([[0.0, 1.0], [-kq * lam, -ko]])
        p = solve_continuous_lyapunov(a.T, -np.eye(2))
        pinv = np.linalg.inv(p)
        got = {k: float(d[k].subs(LAMBDA, sp.Rational(str(lam)))) for k in ("trace", "inv00", "inv11")}
        assert got["trace"] == pytest.approx(np.trace(p), rel=1e-9)
        assert got["inv00"] == pytest.approx(pinv[0, 0], rel=1e-9)
        assert got["inv11"] == pytest.approx(pinv[1, 1], rel=1e-9)


def _initial(rng: np.random.Generator, n: int, r0: float, w0: float, extreme: bool):
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= r0 if extreme else r0 * rng.uniform(0, 1, size=(n, 1))
    w = rng.normal(size=(n, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    w *= w0 if extreme else w0 * rng.uniform(0, 1, size=(n, 1))
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    return att, w


def _sim(graph: str, gains, inertias, att, w, tf: float = 40.0):
    g = make_graph(graph)
    f = Formation(g, inertias, att, w, Gains(*gains, (0.0,) * g.n), no_disturbance(g.n))
    return simulate(f, SimOptions(tf=tf, compile=False))


def test_controller_structure_matches_simulator_torque() -> None:
    g, gains = make_graph("ring:4"), (1.6, 0.4, 0.3)
    J = np.array([np.diag([50.0, 55.0, 60.0]), [[40, 2, 1], [2, 45, 0], [1, 0, 50]]] * 2, dtype=float)
    att, w = _initial(np.random.default_rng(3), 4, 0.3, 0.05, True)
    r = _sim("ring:4", gains, J, att, w, tf=5.0)
    lap = g.laplacian.astype(float)
    for k in (0, 7, 30):
        quat, om = unpack_state(r.x[k], 4)
        q = quat[:, :3]
        qd = np.array([0.5 * (quat[i, 3] * np.eye(3) + np.array(
            [[0, -q[i, 2], q[i, 1]], [q[i, 2], 0, -q[i, 0]], [-q[i, 1], q[i, 0], 0]])) @ om[i] for i in range(4)])
        s = lap @ q
        for i in range(4):
            a = -gains[0] * qd[i] - gains[1] * s[i]
            u = controller_torque(q[i], qd[i], J[i], a)
            assert np.allclose(u, r.u[k].reshape(4, 3)[i], rtol=1e-6, atol=1e-9)  # quaternion-norm drift


@pytest.mark.parametrize("graph", ["ring:6", "star:6", "complete:6"])
def test_simulated_peak_torque_never_exceeds_the_bound(graph: str) -> None:
    gains, r0, w0 = (1.6, 0.4, 0.3), 0.15, 0.02
    tb = peak_torque_bound(graph, gains, J0, r0, w0)
    assert tb.status.value == "certified"
    rng = np.random.default_rng(11)
    worst = 0.0
    for trial in range(4):
        att, w = _initial(rng, make_graph(graph).n, r0, w0, extreme=trial % 2 == 0)
        r = _sim(graph, gains, np.array([J0] * make_graph(graph).n), att, w)
        u = r.u.reshape(len(r.t), -1, 3)
        peak = np.linalg.norm(u, axis=2).max(axis=0)
        assert np.all(peak <= np.array(tb.bound)), (peak, tb.bound)
        q = unpack_state(r.x, make_graph(graph).n)[0][..., :3]
        assert np.linalg.norm(q, axis=2).max() <= tb.q_max
        worst = max(worst, float(peak.max()))
    # a bound, but not a vacuous one: within a stated factor (here 500) of the simulated peak
    assert tb.peak <= 500 * worst


def test_bound_refuses_what_it_cannot_prove() -> None:
    # initial attitudes near 180 degrees: the attitude bound cannot exclude q0 = 0
    tb = peak_torque_bound("ring:8", (1.6, 0.4, 0.3), J0, 0.9, 0.1)
    assert tb.status.value == "undecided" and "q0 = 0" in tb.reason and tb.peak == float("inf")
    with pytest.raises(InputError):
        peak_torque_bound("ring:8", (1.6, 0.4, 0.3), J0, 1.2, 0.1)
    with pytest.raises(InputError):
        peak_torque_bound("ring:8", (1.6, 0.4, 0.3), np.zeros((3, 3, 3)), 0.1, 0.1)


def test_bound_is_monotone_in_the_initial_set() -> None:
    a = peak_torque_bound("ring:6", (1.6, 0.4, 0.3), J0, Fraction(1, 10), Fraction(1, 100))
    b = peak_torque_bound("ring:6", (1.6, 0.4, 0.3), J0, Fraction(1, 5), Fraction(1, 100))
    assert a.peak < b.peak


def test_gains_must_be_positive() -> None:
    # the paper's nominal loop is stable for every positive gain; non-positive gains are bad input
    with pytest.raises(InputError):
        peak_torque_bound("ring:6", (1.6, -0.4, 0.3), J0, 0.1, 0.01)
