"""Notebook-native results (issue 25, item 5): ``to_pandas()`` holds the result's own arrays,
``_repr_html_`` escapes every text and shows the status, ``_repr_markdown_`` the same
headline; without pandas ``to_pandas()`` says how to install it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.sim.agent_montecarlo import run_agent_montecarlo
from formsync_design.spec.agent import agent_design_from_functions

pd = pytest.importorskip("pandas")

DATA = Path(__file__).parent / "data"
ODD = "<b>odd & name</b>"  # a design name an HTML view must escape


@pytest.fixture(scope="module")
def agent_run() -> tuple:
    design = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}}, name=ODD)
    f = fs.AgentFormation(fs.load_graph("path:2"), np.array([np.eye(3)] * 2),
                          np.array([[0, 0, 0, 1.0]] * 2), np.array([[0.1, 0, 0], [0, -0.1, 0]]),
                          fs.Gains(k=1.0))
    return design, f, fs.simulate_agents(design, f, fs.AgentOptions(tf=4, output_step=0.5,
                                                                     step=0.05, rate_tol=1e-2))


def _check_views(res: object, status: str) -> None:
    h = res._repr_html_()  # type: ignore[attr-defined]
    md = res._repr_markdown_()  # type: ignore[attr-defined]
    assert h.startswith("<table>") and status in h
    assert "<b>odd" not in h.replace("<caption><b>", "")
    assert status in md and md.startswith("**")


def test_agent_result_frame_is_its_time_series_and_html_escapes(agent_run: tuple) -> None:
    _, _, r = agent_run
    df = r.to_pandas()
    assert list(df.columns[:3]) == ["t", "attitude_error_deg", "rate_error"]
    assert np.array_equal(df["t"].to_numpy(), r.t)
    assert np.array_equal(df["rate_error"].to_numpy(), r.rate_error)
    assert np.array_equal(df["u2_1"].to_numpy(), r.torques[:, 0, 1])
    h = r._repr_html_()
    assert "&lt;b&gt;odd &amp; name&lt;/b&gt;" in h and ODD not in h
    _check_views(r, str(r.status))
    assert "\\|" not in r._repr_markdown_() or "|" in ODD


def test_agent_montecarlo_frame_has_one_row_per_run(agent_run: tuple) -> None:
    design, f, _ = agent_run
    res = run_agent_montecarlo(design, f, fs.GainBox.parse({"k": "0.5:1"}),
                               fs.MonteCarloSettings(runs=3, max_angle_deg=0, max_rate=0.001),
                               fs.AgentOptions(tf=2, output_step=0.5, step=0.05, rate_tol=1.0))
    df = res.to_pandas()
    assert list(df["seed"]) == [r.seed for r in res.runs]
    assert list(df["status"]) == [r.status for r in res.runs]
    assert "3/3" in res._repr_html_() and "&lt;b&gt;odd" in res._repr_html_()
    _check_views(res, "all converged")


def test_simulation_and_montecarlo_views() -> None:
    case = fs.load_case(DATA / "small_case.toml")
    f = case.formation()
    r = fs.simulate(f, fs.SimOptions(tf=5.0))
    df = r.to_pandas()
    assert np.array_equal(df["q_m"].to_numpy(), r.q_m)
    assert np.array_equal(df["omega_m"].to_numpy(), r.omega_m)
    assert np.array_equal(df["u3_2"].to_numpy(), r.u[:, 5])
    assert len(df.columns) == 3 + 3 * r.n
    _check_views(r, str(r.status))
    mc = fs.monte_carlo(f, None, fs.MonteCarloSettings(runs=2, seed=1),
                        fs.SimOptions(tf=5.0, step=0.1, output_step=0.5), certify=False)
    mdf = mc.to_pandas()
    assert list(mdf["seed"]) == [run.seed for run in mc.runs]
    assert "Q_m &lt;= " in mc._repr_html_()  # the criterion, escaped
    _check_views(mc, "all converged" if mc.all_converged else "failed")


def test_certificate_and_region_views() -> None:
    conds = fs.derive_conditions("ring:4")
    res = fs.certify_box(conds, {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    df = res.to_pandas()
    assert list(df["family"]) == [f.name for f in res.families]
    assert list(df["certified_lower_bound"]) == [float(f.lower) for f in res.families]
    _check_views(res, "certified")
    assert f"{float(res.margin_lower_bound):.6g}" in res._repr_html_()
    refuted = fs.certify_box(fs.derive_conditions("star:8"), {"K_o": 1.6, "K_q": 0.4,
                                                             "beta": 0.3})
    assert "refuted" in refuted._repr_markdown_() and "witness" in refuted._repr_html_()
    m = fs.region_map(conds, {"K_o": (0.05, 5), "K_q": (0.05, 5), "beta": 0.3}, resolution=2)
    rdf = m.to_pandas()
    assert len(rdf) == len(m.boxes)
    assert list(rdf["status"]) == [b.cls for b in m.boxes]
    assert list(rdf["K_o_lo"]) == [float(b.lo[0]) for b in m.boxes]
    _check_views(m, f"{m.fractions['certified']:.1%}")


def test_verification_view_has_one_row_per_claim() -> None:
    v = fs.verify_case(DATA / "case_short_horizon.toml")
    df = v.to_pandas()
    assert list(df["id"]) == [c.claim.id for c in v.claims] == ["convergence", "accuracy", "late"]
    assert list(df["verdict"]) == [c.verdict for c in v.claims]
    assert list(df["verdict"]) == ["undecided", "undecided", "holds"]
    assert list(df["predicate"]) == [c.claim.predicate for c in v.claims]
    _check_views(v, "not every claim holds")
    assert "short3" in v._repr_html_() and "ring:3" in v._repr_markdown_()


def test_to_pandas_without_pandas_says_how_to_install_it(agent_run: tuple,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ModuleNotFoundError, match=r"formsync-design\[notebook\]"):
        agent_run[2].to_pandas()
    assert "status" in agent_run[2]._repr_html_()  # the rich view needs no pandas
