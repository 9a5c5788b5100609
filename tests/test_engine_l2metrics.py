"""The L2-gain, measurement and scope metrics (verify/metrics_l2.py, metrics_sensors.py,
metrics_scope.py) on the lv2012_small engine case, against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.resources import case_file
from formsync_design.verify.engine import EngineResults
from formsync_design.verify.enginecase import load_engine_case
from formsync_design.verify.metrics import METRICS, MetricContext, check_metric_args


@pytest.fixture(scope="module")
def res():
    return EngineResults(load_engine_case(case_file("lv2012_small")))


def _metric(res, name, scenario="perfect", **args):
    spec = METRICS[name]
    ctx = MetricContext(res.case.case_for("case", scenario), "case", scenario, spec, res,
                        check_metric_args(spec, args, "test"),
                        graph=res.case.formation("case").graph)
    return spec.fn(ctx)


def test_certified_gamma_is_the_analysis_result(res):
    from formsync_design.analysis.l2gain import certify_gamma
    from formsync_design.derive.linearize import linearize_agents

    c = res.case.scenario("perfect").case
    lin = linearize_agents(c.design, c.graph(), c.inertias)
    direct = certify_gamma(lin, c.gains.as_dict())
    v = _metric(res, "certified_l2_gain")
    assert direct.certified and v.value == float(direct.gamma)
    # the numerical H-infinity norm of the standard realisation does not exceed gamma
    A, B, C = lin.standard({k: float(x) for k, x in c.gains.as_dict().items()})
    w = np.linspace(0, 1, 201)
    peak = max(np.linalg.norm(C @ np.linalg.solve(1j * x * np.eye(A.shape[0]) - A, B), 2)
               for x in w)
    assert peak <= v.value
    assert _metric(res, "certified_l2_gain", method="sdp").value == pytest.approx(v.value,
                                                                                  rel=1e-3)


def test_steady_bound_by_hand():
    from formsync_design.verify.metrics_l2 import steady_bound_deg

    h = np.zeros((2, 3, 6))
    h[0, :, 0] = (3e-3, 0.0, 4e-3)          # constants only: sum_nu |U_nu| = |c| = 5e-3
    assert steady_bound_deg(40.0, h) == pytest.approx(math.degrees(2 * math.asin(0.2)))
    h[1, 1, 1] = 2e-3                        # + 2e-3 sin(0.1 t) sin(0.3 t): 1e-3 at 0.2 and 0.4
    h[1, 1, 2], h[1, 1, 4] = 0.1, 0.3
    assert steady_bound_deg(40.0, h) == pytest.approx(math.degrees(2 * math.asin(0.28)))
    assert steady_bound_deg(1e6, h) == 180.0


def test_steady_bound_metric_reads_the_certified_gamma(res):
    from formsync_design.analysis.l2gain import harmonic_steady_bound

    g = _metric(res, "certified_l2_gain").value
    dist = res.initial("case", "perfect").disturbance
    v = _metric(res, "l2_steady_bound_deg").value
    assert v == pytest.approx(math.degrees(2 * math.asin(harmonic_steady_bound(g, dist.harmonic))))
    assert _metric(res, "l2_steady_bound_deg", scenario="nodist").value == 0.0  # no disturbance


def test_torque_bound_is_the_formula(res):
    # k_p (b_i + deg_i) + k_d a_f on path:3 with b = (1, 0, 0): max over i is k_p * 2
    v = _metric(res, "torque_bound").value
    assert v == pytest.approx(1.65 * 2 + 14.4 * 0.117)


def test_box_refutation_has_an_exact_witness(res):
    v = _metric(res, "l2_box_certificate", box="k_p = 1.635:1.665, k_d = 14.25:14.55, "
                "a_f = 0.1158:0.1182", gamma=3.0)
    assert v.value == "refuted" and "exact witness" in v.detail


def test_measurement_metrics(res):
    assert _metric(res, "rate_free_law").value == "rate-free"
    assert _metric(res, "local_measurements").value == "local"
    assert _metric(res, "rate_free_law", scenario="cmp_perfect").value == "reads-rate"
    assert _metric(res, "run_difference", scenario="failed", versus="perfect").value == 0.0
    # controller (4) reads its gyro: a failed gyro changes its run
    assert _metric(res, "run_difference", scenario="cmp_failed", versus="cmp_perfect").value > 1e-3
    r = res.run("case", "perfect")
    tail = np.asarray(r.attitude_error)[np.asarray(r.t) >= r.t[-1] * 0.8 - 1e-9]
    assert _metric(res, "tail_disagreement_deg", fraction=0.2).value == float(tail.max())


def test_large_angle_scope_short_horizon_is_local(res):
    v = _metric(res, "large_angle_scope", scenario="nodist", angles="170", signs="-", seed=3,
                tf=20.0)
    assert v.value == "local" and "not converged" in v.detail
