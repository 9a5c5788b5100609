"""Design with constraints (issue 15, item 6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.analysis.design import design_with_constraints
from formsync_design.analysis.switching import graphs_minus_links
from formsync_design.graphs import make_graph
from tests.test_analysis_certificates import _full_loop


@pytest.mark.slow
def test_recommended_gains_meet_constraints():
    """Delay margin by the closed form, decay below the dense loop's true rate, and the
    certified box inside K_o > beta lambda_max (the searched class's exact region)."""
    g = make_graph("ring:6")
    d = design_with_constraints(g, {"K_o": (0.5, 3), "K_q": (0.1, 1.5), "beta": (0.05, 0.5)},
                                min_delay=0.8, graph_set=graphs_minus_links(g, 1), resolution=2)
    assert d.status.value == "certified"
    ko, kq, beta = (float(x) for x in d.gains)
    lmax = g.laplacian_spectral_radius
    b = kq * lmax
    w = math.sqrt((-ko**2 + math.sqrt(ko**4 + 4 * b**2)) / 2)
    assert math.atan(ko / w) / w >= 0.8
    ev = np.linalg.eigvals(_full_loop(g, (ko, kq, beta)))
    ev = sorted(ev, key=abs)[1:]
    k = int(np.argmin([abs(e + ko) for e in ev]))
    true = -max(e.real for i, e in enumerate(ev) if i != k)
    assert 0 < float(d.alpha) <= true
    bx = d.box
    assert bx["K_o"].lo > bx["beta"].hi * lmax  # worst corner of the box
    assert bx.contains((d.gains[0], d.gains[1], d.gains[2]))


def test_infeasible_constraints_are_reported():
    d = design_with_constraints("star:6", {"K_o": (0.5, 1), "K_q": (0.5, 1), "beta": (0.1, 0.2)},
                                min_delay=100.0, resolution=2)
    assert d.status.value == "undecided" and d.gains is None


def test_design_box_meets_delay_at_random_points():
    """The certified box around the recommended gains keeps the processing-delay margin above
    min_delay at every gain: checked by the closed-form margin (eigvalsh of the Laplacian, all
    modes) at seeded random points inside the box, including its worst corner."""
    g = make_graph("ring:6")
    tau = 1.0
    d = design_with_constraints(g, {"K_o": (1, 3), "K_q": (0.2, 1), "beta": (0.1, 0.3)},
                                min_delay=tau, resolution=2)
    assert d.status.value == "certified" and d.box is not None
    lam = np.linalg.eigvalsh(g.laplacian.astype(float))[1:]

    def margin(ko: float, kq: float) -> float:
        out = math.inf
        for lk in lam:
            w = math.sqrt((-ko**2 + math.sqrt(ko**4 + 4 * (kq * lk) ** 2)) / 2)
            out = min(out, math.atan2(ko, w) / w)
        return out

    bx = d.box
    rng = np.random.default_rng(6)
    pts = [(float(bx["K_o"].lo), float(bx["K_q"].hi))]
    pts += [(rng.uniform(float(bx["K_o"].lo), float(bx["K_o"].hi)),
             rng.uniform(float(bx["K_q"].lo), float(bx["K_q"].hi))) for _ in range(40)]
    assert all(margin(ko, kq) > tau for ko, kq in pts)
    # the delay check is what stopped the box growing: its worst corner sits just above tau
    assert margin(float(bx["K_o"].lo), float(bx["K_q"].hi)) < 1.05 * tau
