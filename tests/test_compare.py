"""Paper-versus-derived verdicts, re-checked independently."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from formsync_design.derive.compare import (
    VERDICTS,
    disagreement_witness,
    lyapunov_findings,
    model_findings,
)
from formsync_design.derive.conditions import required_kv
from formsync_design.derive.printed import load_printed
from formsync_design.graphs.build import make_graph

from .helpers import cross, model_numeric, random_inertia

ev = model_numeric()


def test_model_verdicts():
    v = {f.key: f.verdict for f in model_findings()}
    assert v == {
        "skew-matrix": "fails", "A-definite": "holds", "B-skew": "fails",
        "B-formula": "differs", "B-formula-alt": "differs", "A-dot-minus-2B": "holds",
    }
    assert all(f.verdict in VERDICTS for f in model_findings())


def test_printed_b_counterexample_is_real():
    """Independent: Euler's equation at the example state versus the printed B."""
    f = {f.key: f for f in model_findings()}["B-formula"]
    q = np.array([0.1, 0.4, -0.3])
    q0 = np.sqrt(1 - q @ q)
    w = np.array([0.85, -0.43, 0.77])
    J = np.array([[50.0, 0, 4], [0, 55, 0], [4, 0, 60]])
    E = 0.5 * (q0 * np.eye(3) + cross(q))
    qd = E @ w
    Q = np.linalg.inv(E)
    printed = -(Q.T @ cross(J @ Q @ qd) @ Q) @ qd
    assert np.allclose(printed, f.counterexample["printed B qdot"], rtol=1e-5)
    required = ev("B", q, q0, qd, J) @ qd
    assert np.allclose(required, f.counterexample["required (Euler) B qdot"], rtol=1e-5)
    assert np.linalg.norm(printed - required) > 1.0


def test_lyapunov_verdicts_ring8():
    v = {f.key: f.verdict for f in lyapunov_findings("ring:8")}
    assert v == {
        "Theta": "agrees", "Vdot-quadratic": "agrees", "Vdot-disturbance": "differs",
        "Pi-M": "differs", "Pi-N": "agrees", "K_vi-rule": "sufficient",
    }


@pytest.mark.parametrize("graph", ["ring:8", "star:5", "path:6"])
def test_disagreement_witness_is_exact(graph):
    w = disagreement_witness(make_graph(graph))
    assert w is not None
    assert w["zeta^T Pi_derived zeta"] < 0 < w["zeta^T Pi_printed zeta"]
    assert all(isinstance(x, Fraction) for x in w["zeta_per_axis"])


def test_printed_kv_rule_is_always_sufficient():
    rng = np.random.default_rng(11)
    pr = load_printed()
    for _ in range(50):
        J = random_inertia(rng)
        assert pr.printed_kv(1.0, J) >= required_kv(J, 1.0)
