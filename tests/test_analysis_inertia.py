"""Inertia uncertainty (issue 15, item 5).

Independent truth: the derived Lagrangian model ``A(J), B(J)`` (residual), the CasADi
simulator :func:`formsync_design.sim.simulator.simulate` (mismatch simulator when
true == nominal), and Monte-Carlo over true inertias (the certified promise).
"""

from __future__ import annotations

import numpy as np
import pytest

from formsync_design.analysis.inertia import (
    InertiaBox,
    certify_inertia_uncertainty,
    residual,
    residual_from_model,
    sample_inertias,
    simulate_mismatch,
)
from formsync_design.errors import InputError
from formsync_design.graphs import make_graph
from formsync_design.models.disturbances import no_disturbance
from formsync_design.sim.formation import Formation, Gains, SimOptions, unpack_state
from formsync_design.sim.simulator import simulate

J_HAT = np.diag([50.0, 55.0, 60.0])
GAINS = (1.6, 0.4, 0.3)


def _initial(rng: np.random.Generator, n: int, r0: float, w0: float):
    q = rng.normal(size=(n, 3))
    q *= r0 * rng.uniform(0.5, 1, size=(n, 1)) / np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(size=(n, 3))
    w *= w0 * rng.uniform(0.5, 1, size=(n, 1)) / np.linalg.norm(w, axis=1, keepdims=True)
    return np.column_stack([q, np.sqrt(1 - (q**2).sum(1))]), w


def test_residual_matches_the_derived_model() -> None:
    rng = np.random.default_rng(21)
    box = InertiaBox(J_HAT, 0.2, 3.0)
    for J in sample_inertias(box, 5, rng):
        q = rng.normal(size=3) * 0.3
        qd, a = rng.normal(size=3) * 0.1, rng.normal(size=3)
        r1 = residual(q, qd, J, J_HAT, a)
        r2 = residual_from_model(q, qd, J, J_HAT, a)
        assert np.allclose(r1, r2, rtol=1e-9, atol=1e-12)
        assert np.linalg.norm(r1) > 1e-6  # a mismatch really perturbs the loop
    assert np.allclose(residual(q, qd, J_HAT, J_HAT, a), 0, atol=1e-12)


def test_mismatch_simulator_matches_casadi_when_inertias_agree() -> None:
    g = make_graph("ring:4")
    J = np.array([J_HAT, [[40, 2, 1], [2, 45, 0], [1, 0, 50]], J_HAT, J_HAT], dtype=float)
    att, w = _initial(np.random.default_rng(4), 4, 0.3, 0.05)
    t, qs, ws = simulate_mismatch(g, GAINS, J, J, att, w, tf=10.0, step=0.01)
    f = Formation(g, J, att, w, Gains(*GAINS, (0.0,) * 4), no_disturbance(4))
    r = simulate(f, SimOptions(tf=10.0, compile=False))
    quat, om = unpack_state(r.x, 4)
    assert np.allclose(t, r.t)
    assert np.abs(qs - quat).max() < 1e-6 and np.abs(ws - om).max() < 1e-6


def test_certificate_holds_for_monte_carlo_inertias() -> None:
    graph, r0, w0 = "ring:4", 0.02, 0.002
    box = InertiaBox(J_HAT, 0.02, 0.1)
    c = certify_inertia_uncertainty(graph, GAINS, box, r0, w0)
    assert c.status.value == "certified"
    rng = np.random.default_rng(17)
    n = make_graph(graph).n
    for _trial in range(4):
        J = sample_inertias(box, n, rng)
        att, w = _initial(rng, n, r0, w0)
        t, qs, ws = simulate_mismatch(graph, GAINS, J, np.array([J_HAT] * n), att, w, tf=30.0, step=0.02)
        q = qs[..., :3]
        assert np.linalg.norm(q, axis=2).max() <= c.q_max
        qd = 0.5 * (qs[..., 3:4] * ws + np.cross(q, ws))
        qt = q - q.mean(axis=1, keepdims=True)
        xi = np.sqrt((qt**2).sum(axis=(1, 2)) + (qd**2).sum(axis=(1, 2)))
        assert np.all(xi <= c.xi0 * np.exp(-c.rate * t) * (1 + 1e-9))
        assert xi[-1] < 1e-2 * xi[0]


def test_large_uncertainty_is_not_certified_and_bad_input() -> None:
    c = certify_inertia_uncertainty("ring:4", GAINS, InertiaBox(J_HAT, 0.3, 2.0), 0.02, 0.002)
    assert c.status.value == "undecided" and c.rate == 0
    c = certify_inertia_uncertainty("ring:4", GAINS, InertiaBox(J_HAT, 1.5, 0.0), 0.02, 0.002)
    assert c.status.value == "undecided" and "singular" in c.reason
    with pytest.raises(InputError):
        certify_inertia_uncertainty("ring:4", GAINS, InertiaBox(J_HAT, -0.1), 0.02, 0.002)
    with pytest.raises(InputError):
        certify_inertia_uncertainty("ring:4", GAINS, InertiaBox(J_HAT, 0.1), 1.0, 0.002)


def test_certificate_shrinks_with_the_uncertainty() -> None:
    small = certify_inertia_uncertainty("complete:6", GAINS, InertiaBox(J_HAT, 0.01, 0.05), 0.02, 0.002)
    larger = certify_inertia_uncertainty("complete:6", GAINS, InertiaBox(J_HAT, 0.02, 0.1), 0.02, 0.002)
    assert small.status.value == larger.status.value == "certified"
    assert small.rate > larger.rate and small.q_max <= larger.q_max
