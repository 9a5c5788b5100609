"""The issue-15 certificates on a second design: the PD baseline (``derivations/pd_consensus.py``).

Independent truth, derived by hand (not by the engine): after the model cancellation the PD
loop is ``q'' = -k_d q' - k_p L q``, per Laplacian mode ``s^2 + k_d s + k_p lambda`` (stable for
all positive gains on a connected graph); the candidate ``V_i = (k_p + eps k_d)/4 sum |e|^2 +
|q_i'|^2/2 + eps sum e^T q_i'`` gives per mode ``P = [[(k_p + eps k_d) lambda, eps lambda],
[eps lambda, 1]] / 2`` and ``A^T P + P A = diag(-k_p eps lambda^2, eps lambda - k_d)``, so the
exact certificate holds iff ``eps lambda_max < k_d`` and ``eps^2 lambda_max < k_p + eps k_d`` at
every vertex; the processing-delay margin is ``atan(k_d / w) / w`` with ``w^4 + k_d^2 w^2 =
(k_p lambda)^2``; dense eigenvalues of the stacked loop; simulations.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from formsync_design.analysis.certificates import certify
from formsync_design.analysis.delay import delay_margin, simulate_delayed_loop
from formsync_design.analysis.inertia import (
    InertiaBox,
    certify_inertia_uncertainty,
    sample_inertias,
    simulate_mismatch,
)
from formsync_design.analysis.modes import LAMBDA, mode_model
from formsync_design.analysis.performance import certified_decay_rate
from formsync_design.analysis.switching import (
    certify_switching,
    graphs_minus_links,
    simulate_switching,
)
from formsync_design.graphs import make_graph
from formsync_design.graphs.build import Graph

PD = "pd_consensus"
ORDER = ("paper", "exact", "searched", "spectral")


def _random_graph(rng: np.random.Generator, n: int) -> Graph:
    edges = {(int(rng.integers(0, i)), i) for i in range(1, n)}
    for _ in range(int(rng.integers(0, n))):
        i, j = sorted(int(x) for x in rng.choice(n, 2, replace=False))
        edges.add((i, j))
    return Graph(n, tuple(sorted(edges)), name=f"random:{n}")


def _random_box(rng: np.random.Generator) -> dict:
    out = {}
    for name, (lo, hi) in {"k_p": (0.05, 2.0), "k_d": (0.1, 3.0)}.items():
        a = Fraction(int(rng.integers(int(lo * 100), int(hi * 100))), 100)
        out[name] = (a, a + Fraction(int(rng.integers(0, 60)), 100))
    return out


def _full_loop(graph: Graph, kp: float, kd: float) -> np.ndarray:
    lap = graph.laplacian.astype(float)
    n = graph.n
    return np.block([[np.zeros((n, n)), np.eye(n)], [-kp * lap, -kd * np.eye(n)]])


def _true_rate(graph: Graph, kp: float, kd: float) -> float:
    lam = np.linalg.eigvalsh(graph.laplacian.astype(float))[1:]
    return min(-np.roots([1.0, kd, kp * lk]).real.max() for lk in lam)


def test_pd_mode_model_is_the_hand_derivation() -> None:
    mm = mode_model(PD)
    k_p, k_d = mm.gains
    (eps,) = mm.multipliers
    assert mm.names == ("k_p", "k_d") and not mm.switching and mm.aligned
    assert mm.charpoly == (1, k_d, k_p * LAMBDA)
    hand_p = sp.Matrix([[(k_p + eps * k_d) * LAMBDA, eps * LAMBDA], [eps * LAMBDA, 1]]) / 2
    assert (mm.p_paper - hand_p).applyfunc(sp.expand) == sp.zeros(2, 2)
    hand_f = sp.diag(-k_p * eps * LAMBDA**2, eps * LAMBDA - k_d)
    assert (mm.vdot(mm.p_paper) - hand_f).applyfunc(sp.expand) == sp.zeros(2, 2)


def test_pd_exact_certificate_is_the_hand_condition() -> None:
    """With a given eps: certified iff eps lambda_max < k_d and eps^2 lambda_max < k_p + eps k_d
    at every vertex (exact rationals); refuted otherwise (a failing vertex and mode)."""
    rng = np.random.default_rng(1507)
    seen = {"certified": 0, "refuted": 0}
    for graph in ("ring:6", "star:6", "complete:5", "path:5"):
        lmax = Fraction(round(make_graph(graph).laplacian_spectral_radius * 10**6), 10**6)
        exact_lmax = {"ring:6": Fraction(4), "star:6": Fraction(6), "complete:5": Fraction(5)}.get(graph)
        for _ in range(5):
            box = _random_box(rng)
            eps = Fraction(int(rng.integers(1, 120)), 100)
            r = certify(graph, {**box, "eps": eps}, "exact", spec=PD)
            kp, kd = box["k_p"][0], box["k_d"][0]
            if exact_lmax is not None:
                hand = eps * exact_lmax < kd and eps**2 * exact_lmax < kp + eps * kd
                assert r.status.value == ("certified" if hand else "refuted"), (graph, box, eps)
            else:  # path: lambda_max irrational, compare away from the boundary
                margin = min(kd - eps * lmax, kp + eps * kd - eps**2 * lmax)
                if abs(margin) > Fraction(1, 1000):
                    assert r.status.value == ("certified" if margin > 0 else "refuted")
            seen[r.status.value] = seen.get(r.status.value, 0) + 1
    assert seen["certified"] >= 3 and seen["refuted"] >= 3, seen


def test_pd_nesting_on_random_graphs_and_boxes() -> None:
    """(a) => (b) => (c) => (d) for the PD baseline; (d) always certified (all positive gains);
    certified V's checked with dense matrices at random interior points."""
    from formsync_design.analysis.modecheck import EXACT_GRID_POINTS
    from formsync_design.certify.multipliers import GRID_POINTS, multiplier_grid

    rng_eps = mode_model(PD).multiplier_ranges[0]  # paper's grid within exact's: (a) => (b) by construction
    assert set(multiplier_grid(rng_eps, GRID_POINTS)) <= set(multiplier_grid(rng_eps, EXACT_GRID_POINTS))
    rng = np.random.default_rng(771)
    seen = {c: 0 for c in ORDER}
    for trial in range(4):
        graph = _random_graph(rng, int(rng.integers(4, 7)))
        box = _random_box(rng)
        res = {c: certify(graph, box, c, spec=PD, seed_with_paper=False, use_sdp=False) for c in ORDER}
        st = [res[c].status.value for c in ORDER]
        for i in range(3):
            if st[i] == "certified":
                assert st[i + 1] == "certified", (trial, graph.edges, box, st)
        assert st[3] == "certified"
        for c in ORDER:
            seen[c] += st[ORDER.index(c)] == "certified"
        for _ in range(3):
            kp, kd = (float(lo + (hi - lo) * Fraction(int(rng.integers(0, 11)), 10)) for lo, hi in box.values())
            ev = sorted(np.linalg.eigvals(_full_loop(graph, kp, kd)), key=abs)[1:]  # drop the eigenvalue 0
            assert max(e.real for e in ev) < 0
            if st[1] == "certified":
                eps = float(res["exact"].evidence["multipliers"]["eps"])
                lam = np.linalg.eigvalsh(graph.laplacian.astype(float))[1:]
                assert np.all(eps * lam < kd) and np.all(eps**2 * lam < kp + eps * kd)
    assert seen["exact"] >= 3 and seen["searched"] >= 3, seen


def test_pd_decay_never_faster_than_the_true_rate() -> None:
    rng = np.random.default_rng(99)
    for _ in range(3):
        g = _random_graph(rng, int(rng.integers(4, 7)))
        kp, kd = round(float(rng.uniform(0.1, 2)), 3), round(float(rng.uniform(0.3, 3)), 3)
        pt = {"k_p": kp, "k_d": kd}
        ex = certified_decay_rate(g, pt, "exact", spec=PD)
        se = certified_decay_rate(g, pt, "searched", spec=PD)
        true = _true_rate(g, kp, kd)
        assert ex.status.value == se.status.value == "certified"
        assert 0 < float(ex.alpha) <= true * (1 + 1e-9)
        assert 0 < float(se.alpha) <= true * (1 + 1e-9)
        assert float(se.alpha) >= 0.9 * true  # the searched class is (nearly) the true rate per mode


@pytest.mark.parametrize("graph", ["ring:8", "star:6", "path:5"])
def test_pd_processing_delay_margin_closed_form(graph: str) -> None:
    rng = np.random.default_rng(len(graph))
    for _ in range(3):
        kp, kd = float(rng.uniform(0.1, 2)), float(rng.uniform(0.2, 3))
        lam = np.linalg.eigvalsh(make_graph(graph).laplacian.astype(float))[1:]
        hand = math.inf
        for lk in lam:
            b = kp * lk
            w = math.sqrt((-kd**2 + math.sqrt(kd**4 + 4 * b * b)) / 2)
            hand = min(hand, math.atan(kd / w) / w)
        dm = delay_margin(graph, (kp, kd), spec=PD)
        assert dm.margin == pytest.approx(hand, rel=1e-7) and dm.margin <= hand


def test_pd_transmission_delay_independence_is_the_hand_condition() -> None:
    """Regular graph of degree m: no crossing frequency (delay-independent) iff
    w^4 + (k_d^2 - 2 k_p m) w^2 + k_p^2 (m^2 - (m - lambda)^2) has no positive root."""
    g = make_graph("ring:6")  # m = 2, lambda in {1, 3, 4}
    assert math.isinf(delay_margin(g, (0.5, 1.5), "transmission", spec=PD).margin)  # 2.25 >= 2
    dm = delay_margin(g, (2.0, 0.5), "transmission", spec=PD)  # 0.25 < 8: a crossing at lambda = 4
    assert math.isfinite(dm.margin) and dm.critical_lambda == pytest.approx(4.0)


@pytest.mark.parametrize("graph,gains,model", [
    ("star:6", (0.6, 1.2), "processing"),
    pytest.param("ring:6", (2.0, 0.5), "transmission", marks=pytest.mark.slow),
])
def test_pd_delay_margin_against_simulation(graph, gains, model) -> None:
    """Converges at 0.8 x the certified margin, diverges at 1.25 x (within a factor 1.25)."""
    dm = delay_margin(graph, gains, model, spec=PD)
    h = 0.01
    for factor, converges in ((0.8, True), (1.25, False)):
        tau = round(factor * dm.margin / h) * h
        t, d = simulate_delayed_loop(graph, gains, tau, model, tf=80.0, h=h, seed=3, spec=PD)
        tail = d[t > 65].max()
        assert (tail < 0.5 * d[0]) == converges, (factor, tail, d[0])


def test_pd_link_failure_set_converges_under_random_drops() -> None:
    gs = [make_graph("ring:6"), *graphs_minus_links("ring:6", 1)]
    box = {"k_p": (0.35, 0.45), "k_d": (1.5, 1.7)}
    r = certify_switching(gs, box, spec=PD)
    assert r.status.value == "certified"
    a, b = float(r.a), float(r.b)
    rng = np.random.default_rng(5)
    for _ in range(2):
        pt = (rng.uniform(0.35, 0.45), rng.uniform(1.5, 1.7))
        t, x, _ = simulate_switching(gs, pt, tf=80, mean_dwell=0.7, seed=int(rng.integers(1000)), spec=PD)
        n = gs[0].n
        P = np.kron(np.array([[a, b], [b, 1.0]]), np.eye(n))
        v = np.einsum("ti,ij,tj->t", x, P, x)
        assert np.all(np.diff(v) <= 1e-12 * v[0])
        assert np.linalg.norm(x[-1]) < 1e-3 * np.linalg.norm(x[0])


def test_pd_inertia_certificate_holds_for_monte_carlo_inertias() -> None:
    J = np.diag([50.0, 55.0, 60.0])
    box = InertiaBox(J, 0.1, 1.0)
    c = certify_inertia_uncertainty("ring:4", (0.4, 1.6), box, 0.02, 0.002, spec=PD)
    assert c.status.value == "certified"
    rng = np.random.default_rng(41)
    for _ in range(1):
        Jt = sample_inertias(box, 4, rng)
        q = rng.normal(size=(4, 3))
        q *= 0.02 / np.linalg.norm(q, axis=1, keepdims=True)
        w = rng.normal(size=(4, 3))
        w *= 0.002 / np.linalg.norm(w, axis=1, keepdims=True)
        att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
        t, qs, ws = simulate_mismatch("ring:4", (0.4, 1.6), Jt, np.array([J] * 4), att, w, tf=30.0,
                                      step=0.02, spec=PD)
        qv = qs[..., :3]
        qd = 0.5 * (qs[..., 3:4] * ws + np.cross(qv, ws))
        qt = qv - qv.mean(axis=1, keepdims=True)
        xi = np.sqrt((qt**2).sum(axis=(1, 2)) + (qd**2).sum(axis=(1, 2)))
        assert np.all(xi <= c.xi0 * np.exp(-c.rate * t) * (1 + 1e-9))
        assert np.linalg.norm(qv, axis=2).max() <= c.q_max


def test_pd_nonlinear_simulation_settles_within_the_certified_time() -> None:
    """The full nonlinear PD formation (CasADi simulator, no disturbance): the disagreement of
    (q, q') is within the certified envelope sqrt(kappa) |x0| exp(-alpha t) and its simulated
    decay rate is not slower than the certified alpha (exact class: the design's own V)."""
    from formsync_design.analysis.performance import settling_time
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.formation import Formation, Gains, SimOptions, unpack_state
    from formsync_design.sim.simulator import simulate

    graph = make_graph("ring:4")
    dec = certified_decay_rate(graph, {"k_p": 0.4, "k_d": 1.6}, "exact", spec=PD)
    rng = np.random.default_rng(8)
    qv = rng.uniform(-0.2, 0.2, size=(4, 3))
    att = np.hstack([qv, np.sqrt(1 - (qv**2).sum(axis=1))[:, None]])
    rates = rng.uniform(-0.02, 0.02, size=(4, 3))
    f = Formation(graph, np.array([np.diag([20.0, 25.0, 30.0])] * 4), att, rates, Gains(k_p=0.4, k_d=1.6),
                  no_disturbance(4))
    res = simulate(f, SimOptions(tf=50.0, step=0.01, output_step=0.05, compile=False), spec=PD)
    quat, om = unpack_state(res.x, 4)
    q = quat[..., :3]
    qd = 0.5 * (quat[..., 3:4] * om + np.cross(q, om))
    proj = np.eye(4) - np.ones((4, 4)) / 4
    dq, dqd = np.einsum("mn,tna->tma", proj, q), np.einsum("mn,tna->tma", proj, qd)
    dis = np.sqrt((dq**2).sum(axis=(1, 2)) + (dqd**2).sum(axis=(1, 2)))
    t = res.t
    assert np.all(dis <= math.sqrt(dec.kappa) * dis[0] * np.exp(-float(dec.alpha) * t) * (1 + 1e-6))
    T = settling_time(dec.alpha, dec.kappa, float(dis[0]), 1e-3)
    assert T < t[-1] and dis[t >= T].max() <= 1e-3
    tail = (t > 5) & (t < 40)
    slope = -np.polyfit(t[tail], np.log(dis[tail]), 1)[0]
    assert slope >= float(dec.alpha) * 0.999, (slope, float(dec.alpha))
