"""The agent-design paths of formsync simulate, certify and derive (exit codes, outputs)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from formsync_design.cli.main import main

DATA = Path(__file__).parent / "data"
SO3 = str(DATA / "agent_so3.py")
CASE = str(DATA / "agent_so3_case.toml")
TRUST = str(DATA / "agent_so3.py")  # the design file the case names (spec.trust)


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


def test_simulate_an_agent_case_text_json_and_outputs(tmp_path, capsys):
    rc = main(["simulate", "--case", CASE, "--trust-design", TRUST, "--tf", "4",
               "--out", str(tmp_path / "o")])
    out = capsys.readouterr().out
    assert rc == 1  # 4 s is not enough to converge: a negative finding, not an error
    assert "design agent_so3 (so3)" in out and "directed graph" in out and "monitor trace" in out
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == [
        "attitude.png", "rates.png", "summary.json", "torques.png", "trajectory.npz"]
    rc = main(["simulate", "--case", CASE, "--trust-design", TRUST, "--tf", "60", "--format", "json",
               "--figures", "none"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["status"] == "converged" and doc["design"] == "agent_so3"
    assert doc["convergence_time"] is not None and doc["monitors"]["trace"]["max"] <= 3


def test_simulate_agent_design_with_gain_override_and_refused_flags(capsys):
    rc = main(["simulate", "--case", CASE, "--trust-design", TRUST, "--tf", "2", "--gain", "k_R=2",
               "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and doc["gains"] == {"k_R": 2.0, "k_w": 1.5}
    rc = main(["simulate", "--case", CASE, "--trust-design", TRUST, "--trigger", "periodic:0.1"])
    err = capsys.readouterr().err
    errors = [ln for ln in err.strip().splitlines() if "error" in ln]  # after the design-code line
    assert rc == 2 and "--trigger" in err and len(errors) == 1
    rc = main(["simulate", "--case", CASE, "--trust-design", TRUST, "--gain", "k=1"])
    assert rc == 2 and "expected --gain for the controller gains" in capsys.readouterr().err


def test_simulate_agent_design_without_a_case_takes_its_declared_ranges(capsys):
    rc = main(["simulate", "--design", SO3, "--tf", "1"])
    err = capsys.readouterr().err
    assert rc in (0, 1)  # agent_so3 declares k_R in 0.1:2, k_w in 0.5:3: the middles are used
    assert "gains at the middle of their declared ranges: k_R=1.05, k_w=1.75" in err
    rc = main(["simulate", "--design", SO3, "--gain", "k_R=1", "--gain", "k_w=1", "--tf", "1",
               "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and doc["case"].startswith("agent_so3-on-liang2016") and doc["graph"] == "ring:8"


def test_certify_agent_design_certified_refuted_and_bad_flags(capsys):
    assert main(["certify", "--design", SO3, "--graph", "ring:4", "--gain", "k_R=0.5:1",
                 "--gain", "k_w=1:2"]) == 0
    out = capsys.readouterr().out
    assert "formation certificate: certified" in out and "CERTIFIED" in out
    rc = main(["certify", "--design", SO3, "--graph", "ring:4", "--gain", "k_R=3", "--gain",
               "k_w=1", "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    # the design's own families refute its candidate there; the formation itself is decided
    # by the formation certificate, which sets the exit status
    cond = doc["design_conditions"]
    assert cond["status"] == "refuted" and cond["witness"]["family"] == "damping"
    assert cond["scope"]["system"] == "design-conditions"
    assert doc["formation"]["scope"]["system"] == "formation"
    assert rc == (0 if doc["status"] == "certified" else 1)
    rc = main(["certify", "--design", SO3, "--graph", "ring:4", "--ko", "1"])
    assert rc == 2 and "--ko" in capsys.readouterr().err


def test_certify_refuses_a_graph_outside_the_theorem(capsys):
    # two disconnected pairs: no directed spanning tree
    rc = main(["certify", "--design", SO3, "--graph", str(DATA / "two_pairs.txt"), "--gain",
               "k_R=1", "--gain", "k_w=1"])
    err = capsys.readouterr().err
    errors = [ln for ln in err.strip().splitlines() if ": error: " in ln]  # design-code line aside
    assert rc == 2 and "spanning" in err and len(errors) == 1


def test_derive_agent_design_report_and_json(tmp_path, capsys):
    assert main(["derive", "--design", SO3, "--graph", "ring:4", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "agent_so3-derivation-ring-4.md").read_text()
    assert "controller`: attitude, rate, neighbour-attitude" in md and "damping" in md
    capsys.readouterr()
    assert main(["derive", "--design", str(DATA / "agent_filter.py"), "--graph", "path:3",
                 "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["quantities_used"]["controller"] == ["attitude", "neighbour-attitude"]
    assert doc["conditions"] is None


def test_region_of_an_agent_design_matches_its_closed_form(tmp_path, capsys):
    """agent_so3's families are diag(k_R, k_w) > 0 and k_w > k_R / 2: every certified cell lies
    in k_w > k_R / 2 and every refuted one below it (an independent closed form)."""
    rc = main(["region", "--design", SO3, "--graph", "ring:4", "--gain", "k_R=0.5:3", "--gain",
               "k_w=0.5:3", "--resolution", "8", "--out", str(tmp_path), "--format", "json",
               "--no-progress"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and 0 < doc["maps"][0]["fractions"]["certified"] < 1
    boxes = json.loads((tmp_path / "region.json").read_text())["maps"][0]["boxes"]
    for b in boxes:
        (r_lo, w_lo, _), (r_hi, w_hi, _) = b["lo"], b["hi"]
        if b["class"] == "certified":
            assert w_lo > r_hi / 2
        elif b["class"] == "refuted":
            assert w_hi < r_lo / 2
    rc = main(["region", "--design", SO3, "--graph", "ring:4", "--gain", "k_R=3", "--gain",
               "k_w=1", "--out", str(tmp_path / "pt"), "--no-progress"])
    assert rc == 0 and "refuted 100.0%" in capsys.readouterr().out


def test_design_of_an_agent_design_recommends_a_certified_point(capsys):
    rc = main(["design", "--design", SO3, "--graph", "ring:4", "--gain", "k_R=0.5:3", "--gain",
               "k_w=0.5:3", "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["status"] == "recommended"
    from fractions import Fraction

    kr, kw = (Fraction(str(doc["gains"][n])) for n in ("k_R", "k_w"))
    true = min(kr, kw, kw - kr / 2)  # lambda_min of the families, closed form
    lb = Fraction(str(doc["margin"]))  # a rigorous lower bound of it
    assert true - Fraction(1, 10**9) < lb <= true
    assert doc["certified_box_status"] == "certified"
    assert main(["design", "--design", SO3, "--graph", "ring:4", "--gain", "k_R=3", "--gain",
                 "k_w=1"]) == 1


def test_sweep_refuses_agent_designs_without_conditions_in_one_line(capsys):
    rc = main(["sweep", "--design", "ma_quat_smc", "--graphs", "ring:4", "--out", "unused-out"])
    err = capsys.readouterr().err
    assert rc == 2 and "conditions(c)" in err and len(err.strip().splitlines()) == 1
    assert not Path("unused-out").exists()


def test_montecarlo_of_an_agent_design_is_seeded_and_replays(tmp_path, capsys):
    argv = ["montecarlo", "--case", CASE, "--trust-design", TRUST, "--gain", "k_R=0.5:1", "--runs", "3", "--tf", "20",
            "--step", "0.05", "--max-rate", "0.01", "--format", "json"]
    rc = main([*argv, "--out", str(tmp_path / "mc")])
    doc = json.loads(capsys.readouterr().out)
    assert rc in (0, 1) and doc["runs"] == 3 and doc["certificate"] == "certified"
    assert main(argv) == rc
    again = json.loads(capsys.readouterr().out)
    assert {k: v for k, v in again.items() if k != "written"} == \
        {k: v for k, v in doc.items() if k != "written"}
    import csv

    rows = list(csv.DictReader(open(tmp_path / "mc" / "runs.csv")))
    seed = rows[1]["seed"]
    assert main([*argv, "--replay", seed]) == (0 if rows[1]["status"] == "converged" else 1)
    rep = json.loads(capsys.readouterr().out)
    assert rep["status"] == rows[1]["status"]
    assert abs(rep["final_attitude_error_deg"] - float(rows[1]["final_attitude_error_deg"])) < 1e-12
