"""Certified peak-torque bound (issue 15, item 2), at gain points and over whole gain cells.

Independent truth: the CasADi simulator (:func:`formsync_design.sim.simulator.simulate`, the
design's compiled controller, not the bound's formulas) for the controller's torque and for
the peak torques actually reached from the initial set, at seeded random gains inside the
certified cells (not the corners the bound used); the per-mode energy argument against
dense matrix exponentials of the linear mode.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy.linalg import expm

from formsync_design.analysis.torque import (
    controller_torque,
    initial_torque_witness,
    peak_torque_bound,
    torque_limit_check,
)
from formsync_design.errors import InputError
from formsync_design.graphs import make_graph
from formsync_design.models.disturbances import no_disturbance
from formsync_design.sim.formation import Formation, Gains, SimOptions, unpack_state
from formsync_design.sim.simulator import simulate

J0 = np.diag([50.0, 55.0, 60.0])


def _initial(rng: np.random.Generator, n: int, r0: float, w0: float, kind: int):
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(size=(n, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    if kind == 0:       # a corner of the set: every |q_i| = r0, every |omega_i| = w0
        q *= r0
        w *= w0
    elif kind == 1:     # the interior
        q *= r0 * rng.uniform(0, 1, size=(n, 1))
        w *= w0 * rng.uniform(0, 1, size=(n, 1))
    else:               # antipodal neighbours along one axis (the refutation's construction)
        e = q[0]
        q = np.array([-r0 * e] * n)
        q[int(rng.integers(n))] *= -1
        w *= w0
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    return att, w


def _sim(graph: str, gains: dict, inertias, att, w, spec: str | None = None, tf: float = 40.0):
    g = make_graph(graph)
    kv = (0.0,) * g.n if spec is None else ()
    f = Formation(g, inertias, att, w, Gains(gains, kv), no_disturbance(g.n))
    return simulate(f, SimOptions(tf=tf, compile=False), spec=spec)


def test_controller_structure_matches_simulator_torque() -> None:
    g, gains = make_graph("ring:4"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    J = np.array([np.diag([50.0, 55.0, 60.0]), [[40, 2, 1], [2, 45, 0], [1, 0, 50]]] * 2, dtype=float)
    att, w = _initial(np.random.default_rng(3), 4, 0.3, 0.05, 0)
    r = _sim("ring:4", gains, J, att, w, tf=5.0)
    lap = g.laplacian.astype(float)
    for k in (0, 7, 30):
        quat, om = unpack_state(r.x[k], 4)
        q = quat[:, :3]
        qd = np.array([0.5 * (quat[i, 3] * np.eye(3) + np.array(
            [[0, -q[i, 2], q[i, 1]], [q[i, 2], 0, -q[i, 0]], [-q[i, 1], q[i, 0], 0]])) @ om[i] for i in range(4)])
        s = lap @ q
        for i in range(4):
            a = -gains["K_o"] * qd[i] - gains["K_q"] * s[i]
            u = controller_torque(q[i], qd[i], J[i], a)
            assert np.allclose(u, r.u[k].reshape(4, 3)[i], rtol=1e-6, atol=1e-9)  # quaternion-norm drift


def test_mode_energies_never_increase() -> None:
    """The per-mode inequalities of the bound against exact matrix exponentials of the mode
    (including the sigma bound |x| <= |y0| / d of the response to an initial rate)."""
    rng = np.random.default_rng(7)
    for _ in range(40):
        d, b = rng.uniform(0.05, 4), rng.uniform(0.01, 6)
        x0, y0 = rng.normal(), rng.normal()
        a0 = -(b * x0 + d * y0)
        A = np.array([[0.0, 1.0], [-b, -d]])
        for t in np.linspace(0, 30, 61):
            x, y = expm(A * t) @ [x0, y0]
            a = -(b * x + d * y)
            assert x * x <= x0 * x0 + y0 * y0 / b + 1e-9
            assert y * y <= b * x0 * x0 + y0 * y0 + 1e-9
            assert a * a <= b * y0 * y0 + a0 * a0 + 1e-9
            xs, _ = expm(A * t) @ [0.0, y0]   # the response to the initial rate alone
            assert abs(xs) <= abs(y0) / d + 1e-9


CELLS = [
    ("ring:6", None, {"K_o": (1.2, 1.8), "K_q": (0.3, 0.6), "beta": (0.1, 0.3)}),
    ("star:5", None, {"K_o": (0.8, 1.2), "K_q": (0.2, 0.5), "beta": (0.05, 0.2)}),
    ("complete:5", "pd_consensus", {"k_p": (0.2, 0.6), "k_d": (1.0, 2.0)}),
    ("path:5", "pd_consensus", {"k_p": (0.5, 1.5), "k_d": (0.3, 0.8)}),
]


@pytest.mark.parametrize("graph,spec,cell", CELLS)
def test_simulated_peaks_in_a_certified_cell_never_exceed_the_cell_bound(graph, spec, cell) -> None:
    """Seeded random gains inside the cell and initial states from the set (corners,
    interior, antipodal): the simulated peak torque and attitude stay below the bound valid
    for the whole cell, and the bound is within a stated factor (6) of the worst seen."""
    r0, w0 = 0.1, 0.02
    n = make_graph(graph).n
    tb = peak_torque_bound(graph, cell, J0, r0, w0, spec=spec)
    assert tb.status.value == "certified"
    rng = np.random.default_rng(2016)
    worst = 0.0
    for trial in range(3):
        gains = {k: float(lo + (hi - lo) * rng.random()) for k, (lo, hi) in cell.items()}
        att, w = _initial(rng, n, r0, w0, trial % 3)
        r = _sim(graph, gains, np.array([J0] * n), att, w, spec=spec, tf=30.0)
        peak = np.linalg.norm(r.u.reshape(len(r.t), n, 3), axis=2).max(axis=0)
        assert np.all(peak <= np.array(tb.bound)), (peak, tb.bound)
        q = unpack_state(r.x, n)[0][..., :3]
        assert np.linalg.norm(q, axis=2).max() <= tb.q_max
        worst = max(worst, float(peak.max()))
    assert tb.peak <= 6 * worst, (tb.peak, worst)


def test_cell_bound_covers_its_points_and_the_witness_is_a_lower_bound() -> None:
    cell = {"K_o": (1.2, 1.8), "K_q": (0.3, 0.6), "beta": (0.1, 0.3)}
    cb = peak_torque_bound("star:6", cell, J0, 0.1, 0.01)
    for pt in [(1.2, 0.6, 0.1), (1.5, 0.45, 0.2), (1.8, 0.3, 0.3)]:
        assert peak_torque_bound("star:6", pt, J0, 0.1, 0.01).peak <= cb.peak
    w = initial_torque_witness("star:6", cell, J0, 0.1)
    assert w["gains"]["K_q"] == Fraction(3, 5) and w["spacecraft"] == 1  # largest |c_s|, the hub
    # the witness's torque is the simulator's torque at t = 0 from that state
    q = np.array([-0.1 * np.array(w["axis"])] * 6)
    q[0] *= -1
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    gains = {k: float(v) for k, v in w["gains"].items()}
    r = _sim("star:6", gains, np.array([J0] * 6), att, np.zeros((6, 3)), tf=0.1)
    assert np.linalg.norm(r.u[0].reshape(6, 3)[0]) == pytest.approx(w["torque_N_m"], rel=1e-9)
    assert w["torque_N_m"] <= cb.peak


def test_limit_check_certifies_refutes_and_leaves_the_gap_undecided() -> None:
    cell = {"k_p": (0.2, 0.6), "k_d": (1.0, 2.0)}
    tb = peak_torque_bound("ring:6", cell, J0, 0.1, 0.01, spec="pd_consensus")
    w = initial_torque_witness("ring:6", cell, J0, 0.1, spec="pd_consensus")
    assert w["torque_N_m"] < tb.peak
    check = lambda u: torque_limit_check("ring:6", cell, u, J0, 0.1, 0.01, spec="pd_consensus").status.value  # noqa: E731
    assert check(tb.peak * 1.001) == "certified"
    assert check((tb.peak + w["torque_N_m"]) / 2) == "undecided"
    assert check(w["torque_N_m"] * 0.999) == "refuted"


def test_bound_refuses_what_it_cannot_prove() -> None:
    # initial attitudes near 180 degrees: the attitude bound cannot exclude q0 = 0
    tb = peak_torque_bound("ring:8", (1.6, 0.4, 0.3), J0, 0.9, 0.1)
    assert tb.status.value == "undecided" and "q0 = 0" in tb.reason and tb.peak == float("inf")
    with pytest.raises(InputError):
        peak_torque_bound("ring:8", (1.6, 0.4, 0.3), J0, 1.2, 0.1)
    with pytest.raises(InputError):
        peak_torque_bound("ring:8", (1.6, 0.4, 0.3), np.zeros((3, 3, 3)), 0.1, 0.1)
    with pytest.raises(InputError):
        peak_torque_bound("ring:6", (1.6, -0.4, 0.3), J0, 0.1, 0.01)   # gains must be positive


def test_bound_is_monotone_in_the_initial_set_and_the_cell() -> None:
    a = peak_torque_bound("ring:6", (1.6, 0.4, 0.3), J0, Fraction(1, 10), Fraction(1, 100))
    b = peak_torque_bound("ring:6", (1.6, 0.4, 0.3), J0, Fraction(1, 5), Fraction(1, 100))
    c = peak_torque_bound("ring:6", {"K_o": (1.5, 1.7), "K_q": (0.35, 0.45), "beta": 0.3}, J0,
                          Fraction(1, 10), Fraction(1, 100))
    assert a.peak < b.peak and a.peak < c.peak


@pytest.mark.slow
def test_monte_carlo_no_certified_cell_violates_its_torque_promise() -> None:
    """Seeded Monte-Carlo: random graphs, random cells of either design, random inertias, 6 runs
    per cell (random gains inside the cell, initial states from corners, interior and antipodal
    configurations of the set): every simulated peak torque and attitude stays below the
    cell's certified bound."""
    from tests.test_analysis_certificates import _random_graph

    rng = np.random.default_rng(15015)
    checked = 0
    for trial in range(8):
        g = _random_graph(rng, int(rng.integers(4, 8)))
        spec = "pd_consensus" if trial % 2 else None
        names = ("k_p", "k_d") if spec else ("K_o", "K_q", "beta")
        lo = {"K_o": 0.5, "K_q": 0.1, "beta": 0.05, "k_p": 0.1, "k_d": 0.5}
        cell = {n: (x := lo[n] * float(rng.uniform(1, 4)), x * float(rng.uniform(1.05, 1.5))) for n in names}
        J = np.diag(rng.uniform(30, 80, 3))
        r0, w0 = float(rng.uniform(0.02, 0.2)), float(rng.uniform(0, 0.05))
        tb = peak_torque_bound(g, cell, J, r0, w0, spec=spec)
        if tb.status.value != "certified":
            continue
        for run in range(6):
            gains = {k: float(a + (b - a) * rng.random()) for k, (a, b) in cell.items()}
            att, w = _initial(rng, g.n, r0, w0, run % 3)
            res = _sim(g, gains, np.array([J] * g.n), att, w, spec=spec, tf=40.0)
            peak = np.linalg.norm(res.u.reshape(len(res.t), g.n, 3), axis=2).max(axis=0)
            assert np.all(peak <= np.array(tb.bound)), (trial, run, peak, tb.bound)
            q = unpack_state(res.x, g.n)[0][..., :3]
            assert np.linalg.norm(q, axis=2).max() <= tb.q_max
            checked += 1
    assert checked >= 30
