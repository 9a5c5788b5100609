"""Certified decay rates (issue 15, item 2) against simulation and dense eigenvalues."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from formsync_design.analysis.performance import (
    certified_decay_rate,
    settling_time,
    spectral_decay_rate,
)
from formsync_design.graphs import make_graph
from tests.test_analysis_certificates import _full_loop, _paper_v_matrix, _random_graph


def _disagreement_basis(graph):
    n = graph.n if hasattr(graph, "n") else make_graph(graph).n
    lap = make_graph(graph).laplacian.astype(float)
    _, U = np.linalg.eigh(lap)
    return U, n


def test_certified_decay_never_faster_than_true_rate():
    """alpha(exact) <= alpha(searched) <= the dense loop's slowest disagreement mode."""
    rng = np.random.default_rng(4242)
    checked = 0
    for _ in range(6):
        g = _random_graph(rng, int(rng.integers(4, 7)))
        lmax = g.laplacian_spectral_radius
        beta = float(rng.uniform(0.05, 0.4))
        pt = (round(beta * lmax + float(rng.uniform(0.1, 2.0)), 3), round(float(rng.uniform(0.1, 2.0)), 3),
              round(beta, 3))
        box = dict(zip(("K_o", "K_q", "beta"), pt))
        ex = certified_decay_rate(g, box, "exact")
        se = certified_decay_rate(g, box, "searched")
        ev = np.linalg.eigvals(_full_loop(g, pt))
        ev = sorted(ev, key=abs)[1:]  # drop the consensus eigenvalue 0
        # the consensus velocity mode -K_o is not a disagreement mode
        k = int(np.argmin([abs(e + pt[0]) for e in ev]))
        dis = [e for i, e in enumerate(ev) if i != k]
        true = -max(e.real for e in dis)
        assert spectral_decay_rate(g, pt) == pytest.approx(true, rel=1e-6, abs=1e-9)
        assert ex.status.value == "certified" and se.status.value == "certified"
        assert 0 < float(ex.alpha) <= float(se.alpha) * (1 + 1e-9)
        assert float(se.alpha) <= true * (1 + 1e-9)
        checked += 1
    assert checked == 6


def test_linear_trajectories_respect_certified_rate():
    """V(x(t)) <= V(x(0)) exp(-2 alpha t) along exact (expm) trajectories, with the
    paper's V built from the specification (brute force, dense)."""
    g, pt = "ring:6", (1.9, 0.5, 0.25)
    r = certified_decay_rate(g, dict(zip(("K_o", "K_q", "beta"), pt)), "exact")
    a = float(r.alpha)
    A = _full_loop(g, pt)
    P = _paper_v_matrix(g, pt)
    U, n = _disagreement_basis(g)
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = U[:, 1:] @ rng.normal(size=n - 1)
        w = rng.normal(size=n)
        w -= w.mean()
        x0 = np.concatenate([q, w])
        v0 = x0 @ P @ x0
        for t in np.linspace(0.5, 30, 25):
            x = expm(A * t) @ x0
            assert x @ P @ x <= v0 * np.exp(-2 * a * t) * (1 + 1e-9)


@pytest.mark.slow
def test_nonlinear_simulation_settles_within_certified_time():
    """Full nonlinear formation (K_v = 0, no disturbance: the nominal loop): the disagreement
    of (q, q') reaches eps before the certified settling time, and its simulated decay rate
    is not slower than the certified alpha."""
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.formation import Formation, Gains, SimOptions, unpack_state
    from formsync_design.sim.simulator import simulate

    graph = make_graph("ring:4")
    pt = (1.6, 0.4, 0.3)
    dec = certified_decay_rate(graph, dict(zip(("K_o", "K_q", "beta"), pt)), "searched")
    rng = np.random.default_rng(8)
    qv = rng.uniform(-0.2, 0.2, size=(4, 3))
    att = np.hstack([qv, np.sqrt(1 - (qv**2).sum(axis=1))[:, None]])
    rates = rng.uniform(-0.02, 0.02, size=(4, 3))
    J = np.array([np.diag([20.0, 25.0, 30.0])] * 4)
    f = Formation(graph, J, att, rates, Gains(*pt, (0.0,) * 4), no_disturbance(4))
    res = simulate(f, SimOptions(tf=60.0, step=0.01, output_step=0.05, compile=False))
    quat, _ = unpack_state(res.x, 4)
    q = quat[..., :3]  # (T, N, 3)
    t = res.t
    qd = np.gradient(q, t, axis=0)
    U, n = _disagreement_basis(graph)
    proj = U[:, 1:] @ U[:, 1:].T
    dis = np.sqrt(np.einsum("tna,tna->t", np.einsum("mn,tna->tma", proj, q), np.einsum("mn,tna->tma", proj, q))
                  + np.einsum("tna,tna->t", np.einsum("mn,tna->tma", proj, qd), np.einsum("mn,tna->tma", proj, qd)))
    r0, eps = float(dis[0]), 1e-3
    T = settling_time(dec.alpha, dec.kappa, r0, eps)
    assert np.isfinite(T) and T < t[-1], T
    if T < t[-1]:
        assert dis[t >= T].max() <= eps
    # simulated rate over the tail (log-slope) at least the certified one
    tail = (t > 5) & (t < 30)
    slope = -np.polyfit(t[tail], np.log(dis[tail]), 1)[0]
    assert slope >= float(dec.alpha) * 0.999, (slope, float(dec.alpha))


def test_settling_time_and_refusal():
    assert settling_time(0, 2.0, 1.0, 0.1) == float("inf")
    assert settling_time(1, 1.0, 0.05, 0.1) == 0.0
    r = certified_decay_rate("star:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}, "exact")
    assert r.status.value == "refuted" and r.alpha == 0
