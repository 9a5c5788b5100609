"""A formation whose state goes non-finite is the finding ``diverged`` (exit 1), never exit 3;
options out of their documented range and sizes that cannot fit are refused up front."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from types import SimpleNamespace as NS

import numpy as np
import pytest

from formsync_design.cli.main import main

DATA = Path(__file__).parent / "data"

# positive rate feedback: |w| grows, and with the gyroscopic term it blows up in finite time
UNSTABLE = '''"""Test design: positive rate feedback; it diverges."""

FORM = "agent"
NAME = "agent_unstable"
REPRESENTATION = "quaternion"
GAINS = {"k": {"range": "1:100"}}
GRAPHS = ("weakly-connected",)


def controller(v):
    return v.k * v.J * v.w
'''


@pytest.fixture(autouse=True)
def _vm(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


@pytest.fixture
def unstable_case(tmp_path: Path) -> Path:
    (tmp_path / "agent_unstable.py").write_text(UNSTABLE)
    text = (DATA / "agent_so3_case.toml").read_text()
    text = text.replace('design = "agent_so3.py"', 'design = "agent_unstable.py"')
    text = text.replace("k_R = 0.8", "k = 60").replace("k_w = 1.5\n", "").replace("tf = 30.0", "tf = 5.0")
    p = tmp_path / "unstable.toml"
    p.write_text(text)
    return p


def _trust(case: Path) -> str:
    """The design file the case names (a data file's design code runs only when trusted)."""
    return str(case.with_name("agent_unstable.py"))


def test_agent_run_that_goes_non_finite_is_diverged_with_its_time(unstable_case: Path) -> None:
    from formsync_design.sim.agents import simulate_agents
    from formsync_design.verify.agentcase import load_agent_case

    case = load_agent_case(unstable_case, trust=[_trust(unstable_case)])
    r = simulate_agents(case.design, case.formation(), case.options)
    assert str(r.status) == "diverged"
    assert r.diverged_time is not None and 0 < r.diverged_time <= 5.0
    assert r.convergence_time is None
    assert np.all(np.isfinite(r.quaternions)) and np.all(np.isfinite(r.rates))
    assert float(r.t[-1]) < r.diverged_time  # the trajectory ends at the last finite point
    assert f"diverged at t = {r.diverged_time:g} s" in r.message
    d = r.to_dict()
    assert d["status"] == "diverged" and d["diverged_time"] == r.diverged_time
    json.dumps(d, allow_nan=False)


def test_simulate_diverged_is_exit_1_with_the_time(unstable_case: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["simulate", "--case", str(unstable_case), "--trust-design", _trust(unstable_case), "--figures", "none",
               "--out", str(tmp_path / "o")])
    out = capsys.readouterr()
    assert rc == 1
    status = [ln for ln in out.out.splitlines() if ln.startswith("status:")]
    assert len(status) == 1 and "status: diverged - diverged at t = " in status[0]
    doc = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert doc["status"] == "diverged" and doc["diverged_time"] > 0
    assert main(["simulate", "--case", str(unstable_case), "--trust-design", _trust(unstable_case), "--format", "json", "--figures", "none"]) == 1
    assert json.loads(capsys.readouterr().out)["status"] == "diverged"


def test_montecarlo_counts_diverged_runs_and_goes_on(unstable_case: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["montecarlo", "--case", str(unstable_case), "--trust-design", _trust(unstable_case), "--gain", "k=40:60", "--runs", "3",
            "--max-rate", "0.01", "--no-certify"]
    rc = main([*argv, "--format", "json", "--out", str(tmp_path / "mc")])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and doc["runs"] == 3 and doc["diverged"] == 3 and doc["converged"] == 0
    assert len(doc["failed_seeds"]) == 3
    rows = list(csv.DictReader(open(tmp_path / "mc" / "runs.csv")))
    assert [r["status"] for r in rows] == ["diverged"] * 3
    assert all(float(r["diverged_time"]) > 0 for r in rows)
    rc = main([*argv, "--replay", rows[0]["seed"], "--format", "json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 1 and rep["status"] == "diverged"
    assert math.isclose(rep["diverged_time"], float(rows[0]["diverged_time"]))
    assert main(argv) == 1
    text = capsys.readouterr().out
    assert "diverged: 3 runs" in text and "--replay SEED" in text


@pytest.mark.parametrize("argv, needle", [
    (["montecarlo", "--design", "ma_so3", "--runs", "2", "--max-angle", "200"], "--max-angle in [0, 180)"),
    (["montecarlo", "--runs", "2", "--max-angle", "200"], "--max-angle in [0, 180)"),
    (["montecarlo", "--design", "ma_so3", "--runs", "200000"], "at most 100000"),
    (["montecarlo", "--design", "ma_so3", "--runs", "two"], "--runs: expected an integer"),
    (["montecarlo", "--design", "ma_so3", "--runs", "2", "--max-rate", "-1"], "--max-rate >= 0"),
    (["simulate", "--design", "ma_so3", "--tf", "1e12"], "at most 1000000 output grid points"),
])
def test_out_of_range_options_are_refused_up_front(argv: list[str], needle: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and len(err.strip().splitlines()) == 1


def test_agent_options_name_the_step_limit() -> None:
    from formsync_design.errors import InputError
    from formsync_design.sim.agents import MAX_AGENT_STEPS, AgentOptions

    AgentOptions(tf=100.0, output_step=0.1, step=0.01)
    with pytest.raises(InputError, match="integration steps"):
        AgentOptions(tf=1e5, output_step=1.0, step=1e-5)
    assert MAX_AGENT_STEPS == 10**9


@pytest.mark.parametrize("metric", ["relative_convergence_time", "tail_q_m",
                                    "saturation_end_time", "chatter_end_time"])
def test_a_claim_over_a_diverged_run_is_never_decided_by_it(metric: str) -> None:
    """A diverged run's measurement is unknown (it says why), so a claim over it is
    undecided in either direction: a run that did not finish proves nothing."""
    from formsync_design.verify import metrics_lagrangian  # noqa: F401 (registers them)
    from formsync_design.verify.engine import judge
    from formsync_design.verify.enginecase import ClaimRow
    from formsync_design.verify.metrics import METRICS, MetricContext, check_metric_args
    from formsync_design.verify.predicates import parse_predicate

    t = np.arange(0.0, 3.01, 0.5)
    run = NS(status="diverged", message=lambda: "diverged at t = 3 s", t=t,
             torques=np.zeros((t.size, 2, 3)), quaternions=np.tile([0, 0, 0, 1.0], (t.size, 2, 1)),
             rates=np.zeros((t.size, 2, 3)))
    results = NS(run=lambda formation, scenario, draw=None: run, memo=lambda key, f: f())
    spec = METRICS[metric]
    args = {"q_tol": 1e-4, "omega_tol": 1e-5} if "q_tol" in {a.name for a in spec.args} else {}
    ctx = MetricContext(NS(options=NS(torque_limit=1.0)), "f", "s", spec, results,
                        check_metric_args(spec, args, "metrics[1]"))
    v = spec.fn(ctx)
    assert v.value is None and "diverged" in v.detail
    for op in ("<=", ">="):
        claim = ClaimRow("c", "t", "p", f"m {op} 10", parse_predicate(f"m {op} 10", {"m": "number"}))
        assert judge(claim, {"m": v}).verdict == "undecided"


def test_lagrangian_diverged_result_message_and_summary() -> None:
    from dataclasses import replace

    from formsync_design.sim.lagrangian_outcome import lagrangian_message
    from formsync_design.sim.result import SimStatus
    from formsync_design.sim.simulator import simulate
    from formsync_design.verify.case import load_case

    case = load_case()
    opt = replace(case.options, tf=1.0, compile=False)
    r = simulate(case.formation("ring:8"), opt)
    d = replace(r, status=SimStatus.DIVERGED, diverged_time=0.75, convergence_time=None)
    d = replace(d, message=lagrangian_message(d))
    assert d.stopped_early and not d.converged
    assert d.message.startswith("diverged at t = 0.7500 s") and r.message == lagrangian_message(r)
    assert d.to_dict()["diverged_time"] == 0.75 and r.to_dict()["diverged_time"] is None
