"""Lyapunov-Krasovskii delay certificate (issue 15, item 3) against independent truth: the exact
per-mode quasi-polynomial margin on regular graphs (the LK margin must not exceed it) and the
simulated delayed loop (fixed-step DDE integrator) on irregular graphs."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from formsync_design.analysis.delay import delay_margin, simulate_delayed_loop
from formsync_design.analysis.lk import LKStatus, lk_check_exact, lk_delay_margin, lk_delay_system
from formsync_design.graphs import make_graph


def test_delay_system_matches_delayed_loop_at_zero_delay():
    """At tau = 0 the (e, v) system is the undelayed loop: F's spectrum equals that of
    [[0, I], [c_s L, c_qd I]] without its zero eigenvalue (consensus position), checked with
    numpy on an irregular graph."""
    g = make_graph("star:5")
    f, b, n = lk_delay_system(g, (1.6, 0.4, 0.3), "transmission")
    fa = np.array([[float(x) for x in row] for row in f])
    # the closed-loop coefficients at these gains, read back from F: v_i' = c_qd v_i + ...
    cqd = fa[n - 1, n - 1]
    lap = g.laplacian.astype(float)
    cs = fa[n - 1, 0] / lap[0, 0]
    full = np.block([[np.zeros((n, n)), np.eye(n)], [cs * lap, cqd * np.eye(n)]])
    ev_full = sorted(np.linalg.eigvals(full), key=lambda z: (round(z.real, 8), round(z.imag, 8)))
    ev_full.pop(int(np.argmin(np.abs(ev_full))))
    ev_f = sorted(np.linalg.eigvals(fa), key=lambda z: (round(z.real, 8), round(z.imag, 8)))
    assert np.allclose(sorted(np.abs(ev_f)), sorted(np.abs(ev_full)), atol=1e-9)
    assert max(z.real for z in ev_f) < 0


@pytest.mark.parametrize("graph,gains,model", [
    ("ring:6", (0.5, 2.0, 0.3), "transmission"),
    ("complete:6", (0.5, 2.0, 0.3), "transmission"),
    ("ring:8", (1.6, 0.4, 0.3), "processing"),
    ("star:6", (1.6, 0.4, 0.3), "processing"),
])
def test_lk_margin_below_exact_margin(graph, gains, model):
    """Where the loop decouples per mode, the sufficient LK margin is positive and never above
    the exact quasi-polynomial margin."""
    exact = delay_margin(graph, gains, model)
    assert exact.method == "quasi-polynomial" and math.isfinite(exact.margin)
    cert = lk_delay_margin(graph, gains, model)
    assert cert.status is LKStatus.CERTIFIED
    assert 0 < cert.margin <= exact.margin


@pytest.mark.parametrize("graph", ["star:6", "path:5", "random:7:0.4:3"])
def test_lk_margin_on_irregular_graphs_converges_in_simulation(graph):
    """Transmission delay on irregular graphs: the certified delay is positive and the
    simulated delayed loop (seeded) converges at it, so the delay at which simulation diverges
    is above the certificate."""
    g = make_graph(graph)
    assert len(set(g.degrees)) > 1
    gains = (1.6, 0.4, 0.3)
    dm = delay_margin(g, gains, "transmission")
    assert dm.method == "lyapunov-krasovskii" and dm.margin > 0
    h = 0.005
    tau = math.floor(dm.margin / h) * h
    assert tau > 0
    t, d = simulate_delayed_loop(g, gains, tau, "transmission", tf=120, h=h, seed=4)
    half = len(t) // 2
    assert d[-1] < 0.5 * d[half] and d[-1] < 0.05 * d[0]


def test_exact_check_rejects_bad_certificates():
    """The exact re-check decides: an indefinite P, a non-symmetric P, and a delay far beyond
    the true margin (no P, R can pass there) are all rejected."""
    f, b, n = lk_delay_system("star:4", (1.6, 0.4, 0.3), "transmission")
    m = len(f)
    eye_m = [[Fraction(int(i == j)) for j in range(m)] for i in range(m)]
    eye_n = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    neg = [row[:] for row in eye_m]
    neg[0][0] = Fraction(-1)
    assert not lk_check_exact(f, b, n, neg, eye_n, Fraction(1, 10))
    asym = [row[:] for row in eye_m]
    asym[0][1] = Fraction(1, 3)
    assert not lk_check_exact(f, b, n, asym, eye_n, Fraction(1, 10))
    cert = lk_delay_margin("star:4", (1.6, 0.4, 0.3), tau_max=4.0, iterations=6)
    assert cert.status is LKStatus.CERTIFIED
    assert all(ok for tau, ok in cert.tested if tau <= cert.margin)
    assert cert.to_dict()["status"] == "certified"
