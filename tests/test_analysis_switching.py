"""Link failures (issue 15, item 4): common Lyapunov function over a graph set."""

from __future__ import annotations

import numpy as np
import pytest

from formsync_design.analysis.switching import (
    certify_switching,
    graphs_minus_links,
    simulate_switching,
)
from formsync_design.graphs import make_graph


def _dense_check(graphs, gains, a, b):
    """Dense (2N x 2N) A^T P + P A < 0 on the disagreement subspace, for every graph."""
    ko, kq, _ = gains
    for g in graphs:
        n = g.n
        lap = g.laplacian.astype(float)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-kq * lap, -ko * np.eye(n)]])
        P = np.kron(np.array([[a, b], [b, 1.0]]), np.eye(n))
        _, U = np.linalg.eigh(lap)
        B = np.kron(np.eye(2), U[:, 1:])  # disagreement of q and of q'
        assert np.linalg.eigvalsh(B.T @ P @ B).min() > 0
        assert np.linalg.eigvalsh(B.T @ (A.T @ P + P @ A) @ B).max() < 0


def test_graph_sets():
    assert len(graphs_minus_links("ring:8", 1)) == 8
    assert graphs_minus_links("ring:8", 2) == []  # two cuts disconnect a ring
    assert len(graphs_minus_links("complete:5", 1)) == 10
    assert all(len(g.edges) == 9 for g in graphs_minus_links("complete:5", 1))


def test_certified_set_converges_under_random_link_drops():
    """Certified common V: checked with dense matrices at random box points, and it never
    increases along simulated random switching among the graphs; the disagreement converges."""
    gs = [make_graph("ring:6"), *graphs_minus_links("ring:6", 1)]
    box = {"K_o": (1.5, 1.7), "K_q": (0.35, 0.45), "beta": 0.3}
    r = certify_switching(gs, box)
    assert r.status.value == "certified"
    a, b = float(r.a), float(r.b)
    rng = np.random.default_rng(17)
    for _ in range(5):
        pt = (rng.uniform(1.5, 1.7), rng.uniform(0.35, 0.45), 0.3)
        _dense_check(gs, pt, a, b)
        t, x, _ = simulate_switching(gs, pt, tf=80, mean_dwell=0.7, seed=int(rng.integers(1000)))
        n = gs[0].n
        P = np.kron(np.array([[a, b], [b, 1.0]]), np.eye(n))
        v = np.einsum("ti,ij,tj->t", x, P, x)
        assert np.all(np.diff(v) <= 1e-12 * v[0])
        d0, d1 = np.linalg.norm(x[0]), np.linalg.norm(x[-1])
        assert d1 < 1e-3 * d0


def test_empty_class_is_undecided_not_certified():
    """Low damping, stiff coupling: the complete graph's set has no function of the class
    (K_o^2 < K_q lambda rules out the a = b K_o choice and the search finds none)."""
    r = certify_switching(graphs_minus_links("complete:6", 1), {"K_o": 0.5, "K_q": 2.0, "beta": 0.3})
    assert r.status.value == "undecided" and r.a is None


@pytest.mark.parametrize("spec,gains", [(None, (1.6, 0.4, 0.3)), ("pd_consensus", (0.4, 1.6))])
def test_certified_set_holds_for_the_nonlinear_formation_under_random_link_drops(spec, gains):
    """The full rigid-body formation (quaternions, Euler's equation, the design's controller with
    K_v = 0) with links dropping and returning at random (exponential) times among the certified
    set: the common V of the disagreement never increases (up to RK4 error) and it converges."""
    from formsync_design.analysis.inertia import simulate_mismatch

    gs = [make_graph("ring:6"), *graphs_minus_links("ring:6", 1)]
    r = certify_switching(gs, dict(zip(("K_o", "K_q", "beta") if spec is None else ("k_p", "k_d"), gains)),
                          spec=spec)
    assert r.status.value == "certified"
    a, b = float(r.a), float(r.b)
    rng = np.random.default_rng(606)
    h = 0.02
    times, k, t = [], [], 0.0
    while t < 40:
        times.append(t)
        k.append(int(rng.integers(len(gs))))
        t += max(h, round(float(rng.exponential(0.7)) / h) * h)
    laps = [g.laplacian.astype(float) for g in gs]

    def topology(s: float) -> np.ndarray:
        return laps[k[int(np.searchsorted(times, s + 1e-9, side="right")) - 1]]

    J = np.array([np.diag([50.0, 55.0, 60.0])] * 6)
    q = rng.normal(size=(6, 3))
    q *= 0.1 / np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(size=(6, 3)) * 0.01
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    ts, qs, ws = simulate_mismatch("ring:6", gains, J, J, att, w, tf=40.0, step=h, output_step=h, spec=spec,
                                   topology=topology)
    qv = qs[..., :3]
    qd = 0.5 * (qs[..., 3:4] * ws + np.cross(qv, ws))
    e = qv - qv.mean(axis=1, keepdims=True)
    ed = qd - qd.mean(axis=1, keepdims=True)
    v = a * (e**2).sum(axis=(1, 2)) + 2 * b * (e * ed).sum(axis=(1, 2)) + (ed**2).sum(axis=(1, 2))
    assert len(set(k)) > 3  # several topologies were visited
    assert np.all(np.diff(v) <= 1e-7 * v[0]), np.diff(v).max() / v[0]
    assert v[-1] < 1e-3 * v[0]
