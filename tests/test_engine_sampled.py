"""The engine's sampling scenarios, paired Monte-Carlo draws and the metrics of sampled designs
(formsync_design/verify/metrics_sampled.py, metrics_design.py, enginedraws.py), each against
an independent computation from the runs themselves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.errors import DerivationError, InputError
from formsync_design.verify.engine import aggregate, run_engine
from formsync_design.verify.enginecase import parse_engine_case
from formsync_design.verify.metrics import MetricValue

SC = [([[30, 0, 1], [0, 32, 0], [1, 0, 35]], [0.01, -0.005, 0.0], [0.1, 0.05, -0.02]),
      ([[31, 0.5, 0], [0.5, 33, 0], [0, 0, 34]], [0.0, 0.004, 0.006], [-0.05, 0.1, 0.03]),
      ([[29, 0, 0], [0, 30, 0.4], [0, 0.4, 33]], [-0.006, 0.0, 0.004], [0.02, -0.08, 0.06])]


def _doc(**extra):
    doc = {
        "case": {"kind": "engine", "design": "selftrigger_mrp", "name": "st3"},
        "graph": {"arcs": [[2, 1, 1], [3, 2, 1], [3, 1, 0.5], [1, 0, 1], [2, 0, 0.5]]},
        "gains": {"r": 0.5, "m_f": 1.5, "delta": 0.05, "eps": 0.01, "alpha": 0.1, "eta0": 0.05},
        "reference": {"attitude": [0, 0, 0, 1], "rate": ["0.01", "0", "0.02*exp(-t/10)"]},
        "disturbance": {"model": "none"},
        "simulation": {"tf": 4.0, "output_step": 0.25},
        "spacecraft": [{"inertia": J, "rate": w, "q": q} for J, w, q in SC],
        "scenarios": [{"name": "self"}, {"name": "event", "sampling": "event"},
                      {"name": "peq", "sampling": "periodic", "period_matching": "self"}],
        "montecarlo": {"runs": 2, "seed": 5, "tf": 3.0, "draws": "about-reference",
                       "max_angle": 20.0, "rate_sigma": 0.005},
        "metrics": [
            {"id": "tx", "metric": "transmissions"},
            {"id": "ev", "metric": "trigger_evaluations", "scenario": "event"},
            {"id": "epb", "metric": "evaluations_per_broadcast", "stat": "max"},
            {"id": "txr", "metric": "transmissions_ratio", "versus": "event"},
            {"id": "evr", "metric": "evaluations_ratio", "scenario": "event", "versus": "self"},
            {"id": "acc", "metric": "tail_reference_angle_deg", "fraction": 0.5},
            {"id": "accr", "metric": "tail_angle_ratio", "versus": "peq", "fraction": 0.5},
            {"id": "T", "metric": "sampling_period", "scenario": "peq"},
            {"id": "tau", "metric": "certified_interevent_bound"},
            {"id": "ie_mc", "metric": "min_inter_event_time", "montecarlo": "min"},
            {"id": "txr_mc", "metric": "transmissions_ratio", "montecarlo": "max",
             "versus": "event"},
        ],
        "claims": [{"id": "zeno", "text": "no Zeno", "predicate": "ie_mc >= tau - 1e-9"}],
    }
    doc.update(extra)
    return doc


@pytest.fixture(scope="module")
def ver():
    import os

    os.environ["FORMSYNC_NO_COMPILE"] = "1"
    try:
        return run_engine(parse_engine_case(_doc(), "st3.toml"))
    finally:
        os.environ.pop("FORMSYNC_NO_COMPILE", None)


def _v(ver, mid):
    return next(v for m, v in ver.metrics if m.id == mid)


def _angle_to(q, qd):
    """Principal angle (deg) between unit quaternions, recomputed from the states."""
    return np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(q * qd, axis=-1)), 0, 1)))


def test_sampled_metrics_against_the_runs(ver):
    res = ver.results
    self_run, ev_run = res.run("case", "self"), res.run("case", "event")
    rec_s, rec_e = res.record("case", "self"), res.record("case", "event")
    tx_s, tx_e = np.sum(self_run.transmissions), np.sum(ev_run.transmissions)
    assert _v(ver, "tx").value == tx_s
    assert _v(ver, "ev").value == np.sum(rec_e["trigger_evaluations"])
    # a self-trigger evaluates its rule once per broadcast
    assert np.array_equal(rec_s["trigger_evaluations"], self_run.transmissions)
    assert _v(ver, "epb").value == 1.0
    assert _v(ver, "txr").value == pytest.approx(tx_s / tx_e, rel=1e-15)
    assert _v(ver, "evr").value == pytest.approx(
        np.sum(rec_e["trigger_evaluations"]) / np.sum(rec_s["trigger_evaluations"]), rel=1e-15)
    # accuracy: the largest principal angle to the leader over the last half, from quaternions
    t = self_run.t
    tail = t >= t[-1] / 2 - 1e-9
    ang = _angle_to(self_run.quaternions[tail], self_run.reference[tail][:, None, :]).max()
    assert _v(ver, "acc").value == pytest.approx(ang, abs=1e-6)
    pe = res.run("case", "peq")
    ang_p = _angle_to(pe.quaternions[tail], pe.reference[tail][:, None, :]).max()
    assert _v(ver, "accr").value == pytest.approx(ang / ang_p, rel=1e-6)


def test_period_matching_and_the_interevent_bound(ver):
    res = ver.results
    k = round(float(np.mean(res.run("case", "self").transmissions)))
    T = 4.0 / k
    assert _v(ver, "T").value == pytest.approx(T, rel=1e-12)
    tt = res.run("case", "peq").trigger_times
    assert all(np.allclose(np.diff(x), T) for x in tt)
    assert _v(ver, "tau").value == pytest.approx(0.2)  # min(eps/delta, (m-1)/m^2, 1/alpha)


def test_montecarlo_rows_pair_the_draws(ver):
    res = ver.results
    ies, ratios = [], []
    for d in range(2):
        a, b = res.run("case", "self", d), res.run("case", "event", d)
        assert np.array_equal(a.quaternions[0], b.quaternions[0])  # the same draw
        assert a.t[-1] == pytest.approx(3.0)
        ies.append(np.nanmin(a.min_interevent))
        ratios.append(np.sum(a.transmissions) / np.sum(b.transmissions))
    assert _v(ver, "ie_mc").value == min(ies)
    assert _v(ver, "ie_mc").evidence == "montecarlo"
    assert _v(ver, "txr_mc").value == pytest.approx(max(ratios), rel=1e-15)
    assert ver.claims[0].verdict == "holds" and ver.claims[0].basis == "evidence"


def test_reference_draws_rotate_about_the_leader():
    from formsync_design.resources import case_file
    from formsync_design.verify.agentcase import load_agent_case
    from formsync_design.verify.enginedraws import quaternion_product, reference_draws

    c = load_agent_case(case_file("selftrigger_mrp"))
    a = reference_draws(c.formation(), c.reference, 3, 9, 30.0, 0.01)
    b = reference_draws(c.formation(), c.reference, 3, 9, 30.0, 0.01)
    assert all(np.array_equal(x.attitudes, y.attitudes) for x, y in zip(a, b))
    qd = np.array(c.reference.attitude, float)
    qd_inv = np.array([-qd[0], -qd[1], -qd[2], qd[3]])
    for f in a:
        rel = np.array([quaternion_product(qd_inv, q) for q in f.attitudes])
        assert np.all(np.degrees(2 * np.arccos(np.abs(rel[:, 3]))) <= 30.0 + 1e-9)
        assert np.all(f.attitudes[:, 3] >= 0)
    assert not np.array_equal(a[0].attitudes, a[1].attitudes)


def test_aggregate_semantics():
    ex = [MetricValue(2.0, "s", "simulation"), MetricValue(5.0, "s", "simulation")]
    assert aggregate(ex, "max", False, "s").value == 5.0
    low = ex + [MetricValue(1.0, "s", "simulation", bound="lower")]
    m = aggregate(low, "min", False, "s")
    assert m.value == 1.0 and m.bound == "lower"  # the minimum may be the lower bound's
    unk = ex + [MetricValue(None, "s", "simulation", "outside")]
    assert aggregate(unk, "min", False, "s").value is None
    s = aggregate(unk, "min", True, "s")
    assert s.value == 2.0 and "left out" in s.detail
    assert math.isinf(aggregate([MetricValue(3.0, "s", "simulation", bound="lower")], "max",
                                False, "s").interval().hi)


@pytest.mark.parametrize("change, match", [
    ({"scenarios": [{"name": "p", "sampling": "periodic"}]}, "simulation.period or period_matching"),
    ({"scenarios": [{"name": "p", "sampling": "sometimes"}]}, "sampling among"),
    ({"scenarios": [{"name": "p", "sampling": "periodic", "period_matching": "p"}]},
     "naming another scenario"),
    ({"scenarios": [{"name": "s"}, {"name": "p", "sampling": "event", "period_matching": "s"}]},
     "period_matching with sampling"),
    ({"montecarlo": {"runs": 2, "draws": "about-reference", "max_rate": 0.1}}, "rate_sigma"),
    ({"metrics": [{"id": "x", "metric": "certified_interevent_bound", "montecarlo": "max"}]},
     "on a simulation metric"),
    ({"metrics": [{"id": "x", "metric": "mc_converged_fraction"}]}, "draws = \"box\""),
    ({"metrics": [{"id": "x", "metric": "transmissions_ratio", "versus": "nobody"}]},
     "versus among"),
    ({"metrics": [{"id": "x", "metric": "family_margin"}]}, "a \\[families\\] table"),
])
def test_refused_in_one_line(change, match):
    with pytest.raises(InputError, match=match):
        parse_engine_case(_doc(**change), "st3.toml")


def test_rule_variant_needs_the_rule_function():
    from formsync_design.spec.agent import agent_design_from_functions, rule_variant
    from formsync_design.spec.loader import load_design

    d = load_design("selftrigger_mrp")
    assert rule_variant(d, "periodic").decl.sampling == "periodic"
    with pytest.raises(DerivationError, match="expected a sampling rule"):
        rule_variant(d, "sometimes")
    damper = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    with pytest.raises(DerivationError):
        rule_variant(damper, "event")


def test_family_metrics_against_the_families_in_closed_form():
    """threshold = m - 1 and surface = r (1 - rho^2) - 6 rho wbar are affine in the gains: their
    exact minima over the box are at a vertex (m = 1.3; r = 0.45, rho = 3/5, wbar = 1/20), and a
    certified margin is a lower bound within rounding of them."""
    doc = _doc(families={"box": {"r": "0.45:0.55", "m_f": "1.3:1.5", "delta": 0.05,
                                 "eps": 0.01, "alpha": 0.1, "eta0": 0.05}},
               metrics=[{"id": "fam", "metric": "family_certificate"},
                        {"id": "thr", "metric": "family_margin", "family": "threshold"},
                        {"id": "srf", "metric": "family_margin", "family": "surface"},
                        {"id": "all", "metric": "family_margin"}],
               claims=[{"id": "c", "text": "certified", "predicate": 'fam == "certified"'}])
    ver = run_engine(parse_engine_case(doc, "st3.toml"))
    thr, srf, low = (_v(ver, k).value for k in ("thr", "srf", "all"))
    assert 0.3 - 1e-12 <= thr <= 0.3
    truth = 0.45 * (1 - 0.36) - 6 * 0.6 * 0.05
    assert truth - 1e-12 <= srf <= truth
    assert low <= min(thr, srf)
    assert ver.claims[0].verdict == "holds" and ver.claims[0].basis == "proof"
