"""A fly-around whose state goes non-finite is a finding (status ``diverged`` with its time),
never an exception; its measurements are nan, its metrics have no value (the reason names
the divergence time), the claims that read them are undecided, and ``formsync verify
--strict`` exits 1.

The diverging variant is the shipped case with a plant of almost no inertia (the law keeps
the printed inertia, so its torques spin the plant up without bound).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.resources import case_file
from formsync_design.sim import tracking as F
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.verify.tracking_case import load_flyaround_case
from formsync_design.verify.tracking_measures import METRICS, diverged_time, run_metrics

CASE = load_flyaround_case()
TINY = replace(CASE.scenario, inertia=1e-3 * np.eye(3), law_inertia=CASE.scenario.inertia)
SHORT = replace(CASE.options, tf=200.0)


@pytest.fixture(scope="module")
def diverged() -> SimResult:
    return F.simulate_flyaround(TINY, SHORT, CASE.spec)


def test_a_non_finite_state_is_the_status_diverged_with_its_time(diverged) -> None:
    r = diverged
    assert r.status == SimStatus.DIVERGED and str(r.status) == "diverged"
    dt = SHORT.sample_period
    assert 0 < r.diverged_time < SHORT.tf
    # the run ends at the last finite state, one sample before the divergence time
    assert r.orbit.states.shape == (r.t.size + 1, 12) and np.isfinite(r.orbit.states).all()
    assert math.isclose(r.diverged_time, (r.t.size + 1) * dt)
    assert all(v.shape[0] == r.t.size for v in r.orbit.outputs.values())
    assert "diverged at t = " in r.message and r.convergence_time is None
    d = r.to_dict()
    assert d["status"] == "diverged" and d["diverged_time"] == r.diverged_time
    # independent of the truncation: the same loop stopped at the last finite state
    # completes, with the same trajectory; one sample more is not finite
    upto = F.simulate_flyaround(TINY, replace(SHORT, tf=r.t.size * dt), CASE.spec)
    assert not upto.stopped_early and upto.diverged_time is None
    assert np.array_equal(upto.orbit.states, r.orbit.states)
    more = F.simulate_flyaround(TINY, replace(SHORT, tf=(r.t.size + 1) * dt), CASE.spec)
    assert more.status == "diverged" and more.diverged_time == r.diverged_time


def test_the_lp_allocation_run_diverges_the_same_way(diverged) -> None:
    r = F.simulate_flyaround(TINY, replace(SHORT, allocation="lp"), CASE.spec)
    assert r.status == "diverged" and np.isfinite(r.orbit.states).all()
    assert r.orbit.states.shape[0] == r.t.size + 1
    assert math.isclose(r.diverged_time, (r.t.size + 1) * SHORT.sample_period)


def test_a_diverged_run_measures_nothing(diverged) -> None:
    tdiv = diverged_time(diverged)
    assert tdiv == diverged.diverged_time
    m = run_metrics(diverged, CASE.steady_from)
    assert set(m) == set(METRICS) and all(math.isnan(v) for v in m.values())


def test_a_completed_run_measures_every_metric() -> None:
    run = F.simulate_flyaround(CASE.scenario, replace(CASE.options, tf=160.0), CASE.spec)
    assert not run.stopped_early and diverged_time(run) is None
    m = run_metrics(run, 120.0)
    assert list(m) == list(METRICS) and math.isfinite(m["fuel_kg"])


def test_verify_of_a_diverging_case_is_undecided_saying_diverged(tmp_path, capsys) -> None:
    text = case_file("zhang2014_flyaround").read_text()
    text = text[:text.index("# ----------------------------------------------------------------"
                            " scenarios")]
    text = text.replace("tf = 18000.0", "tf = 200.0").replace("steady_from = 1000.0",
                                                               "steady_from = 120.0")
    old = "inertia = [[3256.0, 0.0, 0.0], [0.0, 2922.0, 0.0], [0.0, 0.0, 3505.0]]"
    assert old in text
    text = text.replace(old, "inertia = [[0.001, 0.0, 0.0], [0.0, 0.001, 0.0], "
                             "[0.0, 0.0, 0.001]]")
    text += "\n".join(["[[metrics]]", 'id = "dv"', 'metric = "delta_v"', "[[metrics]]",
                       'id = "point"', 'metric = "pointing_error"', "[[claims]]", 'id = "cheap"',
                       'text = "little fuel"', 'predicate = "dv < 100"', "[[claims]]",
                       'id = "pointing"', 'text = "pointed"', 'predicate = "point <= 1"', ""])
    p = tmp_path / "div.toml"
    p.write_text(text)
    rc = main(["verify", str(p), "--out", str(tmp_path / "o")])
    out = capsys.readouterr().out
    assert rc == 0  # the verification ran; its verdicts are in the report
    assert "holds" not in out and out.count("undecided") == 2
    md = (tmp_path / "o" / "div-verification.md").read_text()
    assert md.count("the run diverged at t = ") == 2 and "0 hold, 0 fail, 2 undecided." in md
    assert main(["verify", str(p), "--out", str(tmp_path / "o"), "--strict"]) == 1
