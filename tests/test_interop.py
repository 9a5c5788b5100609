"""python-control export of a formation linearisation: its H-infinity norm (a frequency sweep
of the exported system) against the certified L2 gain of lv2012, its poles against the
linearisation the certificates use."""

from __future__ import annotations

import numpy as np
import pytest

from formsync_design.analysis.l2gain import certify_gamma
from formsync_design.derive.linearize import linearize_agents
from formsync_design.interop import to_statespace
from formsync_design.resources import case_file
from formsync_design.verify.agentcase import load_agent_case

control = pytest.importorskip("control")


def _lv2012_small():
    c = load_agent_case(case_file("lv2012_small"))
    return c, c.gains.as_dict()


def test_hinf_norm_of_the_export_is_below_and_near_the_certified_gamma():
    c, gains = _lv2012_small()
    sys = to_statespace(c.design, c.graph(), c.inertias, gains)
    assert isinstance(sys, control.StateSpace) and sys.ninputs == 3 * c.n == sys.noutputs
    w = np.concatenate([[0.0], np.logspace(-4, 2, 1500)])
    sweep = max(float(np.linalg.svd(np.atleast_2d(sys(1j * x)), compute_uv=False)[0]) for x in w)
    gamma = float(certify_gamma(linearize_agents(c.design, c.graph(), c.inertias), gains).gamma)
    assert sweep <= gamma <= 1.06 * sweep


def test_poles_of_the_export_are_the_certificates_linearisation():
    c, gains = _lv2012_small()
    sys = to_statespace(c.design, c.graph(), c.inertias, gains)
    A = linearize_agents(c.design, c.graph(), c.inertias).standard(
        {k: float(v) for k, v in gains.items()})[0]
    p = np.sort_complex(np.asarray(control.poles(sys)))
    q = np.sort_complex(np.linalg.eigvals(A))
    np.testing.assert_allclose(p, q, atol=1e-8)
    assert list(sys.state_labels)[:2] == ["q1_1", "q2_1"]


def test_a_law_not_differentiable_at_consensus_is_refused():
    from formsync_design.errors import InputError
    from formsync_design.spec.loader import load_design

    d = load_design("ma_mrp_ft")
    with pytest.raises(InputError, match="differentiable"):
        to_statespace(d, "ring:3", [np.eye(3)] * 3, {"K1": 1, "K2": 1, "P1": 1, "P2": 1,
                                                     "eps": "1/100"}, switch="sgn")


def _response(sys, w):
    return np.array([np.atleast_2d(sys(1j * x)) for x in w])


def _views(name):
    from formsync_design.spec.loader import load_design, load_spec

    return load_spec(name), load_design(name)


def _assert_same_system(lag, agt):
    assert lag.nstates == agt.nstates
    key = lambda z: (round(z.real, 6), round(z.imag, 6))  # noqa: E731 (repeated pairs)
    np.testing.assert_allclose(sorted(np.asarray(control.poles(lag), dtype=complex), key=key),
                               sorted(np.asarray(control.poles(agt), dtype=complex), key=key),
                               atol=1e-8)
    w = np.logspace(-3, 2, 40)
    np.testing.assert_allclose(_response(lag, w), _response(agt, w), rtol=1e-8, atol=1e-12)


def test_the_two_views_of_liang2016_are_the_same_system():
    """liang2016's Lagrangian view (state (q, q'), controller (4) in A, B, Q) and its agent
    form (state (q, w), the law written in the body rate: a second implementation in one
    design file) give the same system: equal poles and equal frequency responses d -> q at
    the same gains and switching realisation; a different gain in one view is told apart."""
    lag_view, agt_view = _views("liang2016")
    assert lag_view.name == agt_view.name == "liang2016" and agt_view.form == "agent"
    rng = np.random.default_rng(7)
    J = [np.diag(rng.uniform(1, 3, 3)) for _ in range(4)]
    g = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3, "K_v": 0.01}
    lag = to_statespace(lag_view, "ring:4", J, g)
    agt = to_statespace(agt_view, "ring:4", J, g)
    assert lag.nstates == agt.nstates == 24 and list(lag.state_labels)[12] == "qd1_1"
    _assert_same_system(lag, agt)
    other = to_statespace(agt_view, "ring:4", J, {**g, "K_q": 0.41})
    with pytest.raises(AssertionError):  # the check can fail: a view that differs is caught
        _assert_same_system(lag, other)


def test_the_two_views_of_pd_consensus_are_the_same_system():
    """pd_consensus: its agent form (body rate) and its Lagrangian view give the same
    poles and frequency responses; a different gain in one view is told apart."""
    lag_view, agt_view = _views("pd_consensus")
    rng = np.random.default_rng(11)
    J = [np.diag(rng.uniform(1, 3, 3)) for _ in range(5)]
    g = {"k_p": 0.7, "k_d": 1.9}
    lag = to_statespace(lag_view, "path:5", J, g)
    _assert_same_system(lag, to_statespace(agt_view, "path:5", J, g))
    with pytest.raises(AssertionError):
        _assert_same_system(lag, to_statespace(agt_view, "path:5", J, {**g, "k_d": 1.95}))


def test_pd_consensus_poles_are_the_analytic_modes():
    """pd_consensus: q'' = -k_d q' - k_p L q, so the poles are the roots of
    s^2 + k_d s + k_p lambda_k for every Laplacian eigenvalue, three axes each (both views)."""
    from formsync_design.graphs.build import make_graph

    kp, kd = 0.7, 1.9
    lam = np.linalg.eigvalsh(np.asarray(make_graph("path:5").laplacian, dtype=float))
    want = np.concatenate([np.roots([1, kd, kp * x]) for x in lam for _ in range(3)])
    key = lambda z: (round(z.real, 6), round(z.imag, 6))  # noqa: E731 (repeated pairs)
    for view in _views("pd_consensus"):
        sys = to_statespace(view, "path:5", [np.eye(3) * 2.5] * 5, {"k_p": kp, "k_d": kd})
        got = sorted(np.asarray(control.poles(sys), dtype=complex), key=key)
        np.testing.assert_allclose(got, sorted(want.astype(complex), key=key), atol=1e-7)
    # the disturbance enters q'' through A^-1 Q^T = J^-1 / 2 at the identity
    lag = to_statespace(_views("pd_consensus")[0], "path:5", [np.eye(3) * 2.5] * 5,
                        {"k_p": kp, "k_d": kd})
    assert lag.B[15, 0] == pytest.approx(1 / (2 * 2.5))


def test_lagrangian_export_refuses_sgn_missing_gains_and_pinning():
    from formsync_design.errors import InputError

    J = [np.eye(3)] * 3
    g = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3, "K_v": 0.01}
    lag = _views("liang2016")[0]
    with pytest.raises(InputError, match="differentiable"):
        to_statespace(lag, "ring:3", J, g, switch="sgn")
    with pytest.raises(InputError, match="missing \\['K_v'\\]"):
        to_statespace(lag, "ring:3", J, {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    with pytest.raises(InputError, match="no pinning"):
        to_statespace(lag, "ring:3", J, g, pinning=[1, 0, 0])
    with pytest.raises(InputError, match="relative-orbit plant"):
        to_statespace("zhang2014_flyaround", "ring:3", J, g)
