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
