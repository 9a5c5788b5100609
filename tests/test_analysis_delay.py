"""Delay margins (issue 15, item 3): quasi-polynomial margins against closed forms and
against simulation of the delayed loop (fixed-step DDE integrator, checked analytically)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.analysis.delay import delay_margin, simulate_dde, simulate_delayed_loop
from formsync_design.errors import InputError


def test_dde_integrator_against_method_of_steps():
    """x' = -x(t-1), x = 1 on [-1, 0]: piecewise polynomials by the method of steps."""
    t, x = simulate_dde(lambda x, xd: -xd, None, 1.0, 0.01, 3.0, np.array([1.0]))

    def exact(s: float) -> float:
        if s <= 1:
            return 1 - s
        if s <= 2:
            return 1 - s + (s - 1) ** 2 / 2
        return 1 - s + (s - 1) ** 2 / 2 - (s - 2) ** 3 / 6

    err = max(abs(x[k, 0] - exact(tk)) for k, tk in enumerate(t))
    assert err < 1e-8
    with pytest.raises(InputError):
        simulate_dde(lambda x, xd: -xd, None, 0.015, 0.01, 1.0, np.array([1.0]))


@pytest.mark.parametrize("graph,gains", [("ring:8", (1.6, 0.4, 0.3)), ("star:8", (1.6, 0.4, 0.3)),
                                         ("path:5", (0.8, 1.2, 0.2))])
def test_processing_margin_closed_form(graph, gains):
    """Processing delay: s^2 + K_o s + K_q lambda e^{-s tau}; the crossing frequency solves
    w^4 + K_o^2 w^2 = (K_q lambda)^2 and tau = atan(K_o / w) / w, worst at lambda_max."""
    from formsync_design.graphs import make_graph

    ko, kq, _ = gains
    lam = make_graph(graph).laplacian_spectral_radius
    b = kq * lam
    w = math.sqrt((-ko**2 + math.sqrt(ko**4 + 4 * b**2)) / 2)
    tau = math.atan(ko / w) / w
    dm = delay_margin(graph, gains, "processing")
    assert dm.margin == pytest.approx(tau, rel=1e-7)
    assert dm.margin <= tau


@pytest.mark.parametrize("graph,gains,model", [
    ("ring:8", (1.6, 0.4, 0.3), "processing"),
    ("star:8", (1.6, 0.4, 0.3), "processing"),
    ("complete:6", (0.5, 2.0, 0.3), "transmission"),
    ("ring:6", (0.5, 2.0, 0.3), "transmission"),
])
def test_margin_never_above_simulated_divergence(graph, gains, model):
    """At 0.8 x the certified margin the delayed loop converges; at 1.25 x it diverges (so
    the margin is within a factor 1.25 of the simulated divergence delay).  Near the margin
    the growth/decay is slow, hence the factors."""
    dm = delay_margin(graph, gains, model)
    assert math.isfinite(dm.margin) and dm.margin > 0
    h = 0.005
    below = math.floor(0.8 * dm.margin / h) * h
    above = math.ceil(1.25 * dm.margin / h) * h
    t, d = simulate_delayed_loop(graph, gains, below, model, tf=120, h=h, seed=1)
    half = len(t) // 2
    assert d[-1] < 0.5 * d[half] and d[half] < d[0]
    t, d = simulate_delayed_loop(graph, gains, above, model, tf=120, h=h, seed=1)
    assert d[-1] > d[half] > d[0]


def test_transmission_delay_independent_and_errors():
    """K_o^2 >= 2 K_q m: no crossing frequency, stable for every delay (Atay 2013);
    simulation at a long delay converges.  Non-regular graphs get the Lyapunov-Krasovskii
    lower bound (tests/test_analysis_lk.py); an unknown model is refused."""
    dm = delay_margin("ring:8", (1.6, 0.4, 0.3), "transmission")
    assert dm.margin == math.inf
    t, d = simulate_delayed_loop("ring:8", (1.6, 0.4, 0.3), 5.0, "transmission", tf=200, h=0.01, seed=2)
    assert d[-1] < 0.05 * d[0]
    irregular = delay_margin("star:8", (1.6, 0.4, 0.3), "transmission")
    assert irregular.method == "lyapunov-krasovskii" and irregular.margin > 0
    with pytest.raises(InputError):
        delay_margin("star:8", (1.6, 0.4, 0.3), "nonsense")
