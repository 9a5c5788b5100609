"""Verification of published claims: judging rules, horizons, output safety, report, CLI."""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.derive.conditions import derive_conditions
from formsync_design.errors import InputError
from formsync_design.sim.simulator import simulate
from formsync_design.verify.case import load_case
from formsync_design.verify.claims import (
    ClaimSpec,
    Measurement,
    Outcome,
    Verdict,
    chatter_end_time,
    combine,
    judge,
    measure_run,
    parse_claims,
)
from formsync_design.verify.output import check_output, display_path, report_marker
from formsync_design.verify.report import write_verification_report
from formsync_design.verify.verification import verify_case

DATA = Path(__file__).parent / "data"
SMALL = DATA / "small_case.toml"
SHORT = DATA / "case_short_horizon.toml"
ITEM = {"text": "t", "paper": "p", "quantity": "tail_q_m", "op": "<=", "value": 1e-4}
OPS = {"<=": lambda a, b: a <= b, "<": lambda a, b: a < b, ">=": lambda a, b: a >= b,
       ">": lambda a, b: a > b, "==": lambda a, b: a == b}


# ---------------------------------------------------------------------------
# parsing
# ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "table, fragment",
    [
        ({}, "[claims]"),
        ({"topologies": []}, "non-empty"),
        ({"topologies": ["ring:3"]}, "claims.items"),
        ({"topologies": ["ring:3"], "items": {"a": {**ITEM, "quantity": "magic"}}}, "quantity"),
        ({"topologies": ["ring:3"], "items": {"a": {**ITEM, "op": "~"}}}, "op"),
        ({"topologies": ["ring:3"], "items": {"a": {**ITEM, "value": float("nan")}}}, "finite"),
        ({"topologies": ["ring:3"], "items": {"a": {"text": "t"}}}, "missing"),
        ({"topologies": ["ring:3"], "colour": 1, "items": {"a": ITEM}}, "unknown"),
        ({"topologies": ["ring:3"], "tail_fraction": 1.5, "items": {"a": ITEM}}, "tail_fraction"),
        ({"topologies": ["ring:3"], "phi_sweep": [0], "items": {"a": ITEM}}, "phi_sweep"),
        ({"topologies": ["ring:3"], "max_tf": -1, "items": {"a": ITEM}}, "max_tf"),
        ({"topologies": ["ring:3"], "torque_limit_sweep": ["none"], "items": {"a": ITEM}}, "unlimited"),
    ],
)
def test_bad_claims_tables(table, fragment):
    with pytest.raises(InputError, match=fragment.replace("[", r"\[")):
        parse_claims(table)


def test_torque_limit_sweep_words():
    s, _ = parse_claims({"topologies": ["ring:3"], "torque_limit_sweep": ["unlimited", 0, 5],
                         "items": {"a": ITEM}})
    assert s.torque_limit_sweep == (None, None, 5.0)


# ---------------------------------------------------------------------------
# judging rules, against a brute-force reading of what each outcome means
# ---------------------------------------------------------------------------
def _truth_over(values, op, bound):
    """Decided iff every admissible true value gives the same answer."""
    answers = {OPS[op](x, bound) for x in values}
    if len(answers) == 1:
        return Verdict.HOLDS if answers.pop() else Verdict.FAILS
    return Verdict.UNDECIDED


@pytest.mark.parametrize("op", sorted(OPS))
@pytest.mark.parametrize("bound", [5.0, 100.0, 200.0, 250.0])
def test_not_reached_within_horizon_rule(op, bound):
    # the true time lies somewhere beyond the horizon (or never comes)
    horizon = 200.0
    beyond = [horizon + 1e-9, horizon + 0.5, horizon + 49.0, horizon + 50.0, 1e6, math.inf]
    c = ClaimSpec("k", "t", "p", "convergence_time", op, bound, "s")
    assert judge(c, Measurement(Outcome.NOT_REACHED, horizon=horizon)) == _truth_over(beyond, op, bound)


@pytest.mark.parametrize("op", sorted(OPS))
@pytest.mark.parametrize("quantity", ["saturation_end_time", "chatter_end_time"])
def test_never_happened_rule(op, quantity):
    # an event that never happens has its "last time" before any bound
    c = ClaimSpec("k", "t", "p", quantity, op, 10.0, "s")
    assert judge(c, Measurement(Outcome.NEVER)) == _truth_over([-math.inf], op, 10.0)


@pytest.mark.parametrize("op", sorted(OPS))
@pytest.mark.parametrize("quantity", ["convergence_time", "tail_q_m", "saturation_end_time",
                                      "chatter_end_time", "final_abs_rate"])
def test_singular_run_fails_every_claim(op, quantity):
    # the old code scored a singular run +inf, so every ">=" claim held on it
    c = ClaimSpec("k", "t", "p", quantity, op, 1.0)
    assert judge(c, Measurement(Outcome.SINGULAR, note="q0 -> 0")) is Verdict.FAILS


@pytest.mark.parametrize("op", sorted(OPS))
def test_steady_state_not_reached_is_undecided(op):
    c = ClaimSpec("k", "t", "p", "tail_omega_m", op, 1e-5, "rad/s")
    assert judge(c, Measurement(Outcome.NOT_REACHED, horizon=200.0)) is Verdict.UNDECIDED


@pytest.mark.parametrize("op", sorted(OPS))
@pytest.mark.parametrize("x", [0.5, 1.0, 2.0])
def test_measured_rule(op, x):
    c = ClaimSpec("k", "t", "p", "kv_ratio", op, 1.0)
    assert judge(c, Measurement.of(x)) == (Verdict.HOLDS if OPS[op](x, 1.0) else Verdict.FAILS)


def test_undecided_computation_is_undecided():
    for op in OPS:
        c = ClaimSpec("k", "t", "p", "pi_pd", op, 1.0)
        assert judge(c, Measurement(Outcome.UNDECIDED)) is Verdict.UNDECIDED


def test_combine_over_topologies():
    H, F, U = Verdict.HOLDS, Verdict.FAILS, Verdict.UNDECIDED
    assert combine({"a": H, "b": H})[0] is H
    assert combine({"a": F, "b": F})[0] is F
    assert combine({"a": H, "b": F, "c": U})[0] is Verdict.DEPENDS
    v, reason = combine({"a": H, "b": U})
    assert v is U and "undecided on b" in reason
    assert combine({"a": F, "b": U})[0] is U


# ---------------------------------------------------------------------------
# measuring synthetic runs (no simulation)
# ---------------------------------------------------------------------------
def _run(status="converged", tf=100.0, ct=20.0, sat=None, u=None, msg="m"):
    t = np.arange(0.0, tf + 1e-9, 1.0)
    return SimpleNamespace(
        status=status, t=t, u=np.zeros((t.size, 3)) if u is None else u,
        omega_m=np.where(t >= (ct if ct is not None else math.inf), 1e-7, 1.0),
        q_m=np.where(t >= (ct if ct is not None else math.inf), 1e-6, 1.0),
        convergence_time=ct, final_rates=np.full((2, 3), 1e-6), saturation_end_time=sat,
        message=lambda: msg)


def test_measure_converged_run():
    m = measure_run(_run(ct=20.0), 0.2)
    assert m["convergence_time"] == Measurement.of(20.0)
    assert m["tail_q_m"].value == pytest.approx(1e-6)
    assert m["chatter_end_time"].outcome is Outcome.NEVER      # constant torque never chatters
    c = ClaimSpec("c", "chatters briefly", "p", "chatter_end_time", "<=", 20.0, "s")
    assert judge(c, m["chatter_end_time"]) is Verdict.HOLDS


def test_measure_never_saturating_run_holds_a_brief_saturation_claim():
    m = measure_run(_run(sat=None), 0.2, event="saturation")
    c = ClaimSpec("s", "saturates briefly", "p", "saturation_end_time", "<=", 10.0, "s")
    assert m["saturation_end_time"].outcome is Outcome.NEVER
    assert judge(c, m["saturation_end_time"]) is Verdict.HOLDS
    # saturating up to the very end: not over within the horizon, so it fails a 10 s bound
    m = measure_run(_run(sat=100.0), 0.2, event="saturation")["saturation_end_time"]
    assert m.outcome is Outcome.NOT_REACHED and judge(c, m) is Verdict.FAILS


def test_measure_singular_run():
    m = measure_run(_run(status="singular", msg="q0 of spacecraft 2 reached 0.02"), 0.2)
    assert {x.outcome for x in m.values()} == {Outcome.SINGULAR}
    c = ClaimSpec("c", "t", "p", "convergence_time", ">=", 5.0, "s")
    assert judge(c, m["convergence_time"]) is Verdict.FAILS
    assert "spacecraft 2" in m["tail_q_m"].note


def test_measure_late_or_no_convergence_leaves_steady_state_undecided():
    late = measure_run(_run(ct=90.0, tf=100.0), 0.2)          # tail starts at 81 s
    assert late["convergence_time"] == Measurement.of(90.0)
    assert late["tail_q_m"].outcome is Outcome.NOT_REACHED
    never = measure_run(_run(ct=None, status="not-converged"), 0.2)
    assert never["convergence_time"].outcome is Outcome.NOT_REACHED
    assert never["convergence_time"].horizon == 100.0


def test_chatter_measure_on_known_signals():
    t = np.arange(0.0, 20.0, 0.1)
    chat = np.where(t < 6, (-1.0) ** np.arange(t.size), 0.01 * np.exp(-t))
    end = chatter_end_time(t, chat[:, None])
    assert 5.5 <= end < 6.0
    assert chatter_end_time(t, np.exp(-t)[:, None]) is None


# ---------------------------------------------------------------------------
# output safety (all before any computation)
# ---------------------------------------------------------------------------
@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if the verification starts computing."""
    import formsync_design.verify.verification as v

    def boom(*a, **k):
        raise AssertionError("verify_case ran although the input was bad")

    monkeypatch.setattr(v, "verify_case", boom)


def test_out_is_a_file(tmp_path, capsys, no_work):
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert main(["verify", str(SMALL), "--out", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a file" in err[0] and "Errno" not in err[0]
    assert main(["verify", str(SMALL), "--out", str(f / "sub")]) == 2
    assert not (f.parent / "sub").exists()


def test_report_of_another_case_is_not_replaced(tmp_path, capsys, no_work):
    md = tmp_path / "small_case-verification.md"
    md.write_text(report_marker("somewhere/small_case.toml") + "\n# other\n")
    assert main(["verify", str(SMALL), "--out", str(tmp_path)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert md.read_text().endswith("# other\n")
    md.write_text("# my own notes\n")                        # not a verification report
    assert main(["verify", str(SMALL), "--out", str(tmp_path)]) == 2
    figs = tmp_path / "figures" / "small_case-verification"
    md.unlink()
    figs.mkdir(parents=True)
    (figs / "mine.png").write_bytes(b"x")
    assert main(["verify", str(SMALL), "--out", str(tmp_path)]) == 2


def test_same_case_report_may_be_regenerated(tmp_path):
    md = tmp_path / "liang2016-verification.md"
    md.write_text("# Verification\n\nRegenerate with x. Case file: `verification/liang2016.toml`.\n")
    check_output(tmp_path, "liang2016", "verification/liang2016.toml")      # an older report
    with pytest.raises(InputError, match="overwrite"):
        check_output(tmp_path, "liang2016", "elsewhere/liang2016.toml")
    check_output(tmp_path, "liang2016", "elsewhere/liang2016.toml", overwrite=True)


def test_bad_spec_leaves_no_output_folder(tmp_path, capsys, no_work):
    out = tmp_path / "new" / "out"
    assert main(["verify", str(SMALL), "--out", str(out), "--spec", str(tmp_path / "nope.py")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "new").exists()
    assert main(["verify", "no-such-case", "--out", str(out)]) == 2
    assert "expected a case name" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()


def test_display_paths(tmp_path):
    assert display_path(SMALL) == "tests/data/small_case.toml"
    assert display_path(tmp_path / "x" / "mine.toml") == "mine.toml"


# ---------------------------------------------------------------------------
# end to end on small cases
# ---------------------------------------------------------------------------
def test_small_case_verdicts_are_consistent_with_direct_runs(tmp_path):
    res = verify_case(SMALL)
    case = load_case(SMALL)
    by = {t.graph: t for t in res.topologies}
    for g in ("ring:3", "path:3"):
        r = simulate(case.formation(g), case.options)
        m = by[g].quantities["convergence_time"]
        if r.convergence_time is not None:
            assert m == Measurement.of(r.convergence_time)
        lam = min(np.linalg.eigvalsh(derive_conditions(g).pi.evaluate((1.6, 0.4, 0.3))))
        assert by[g].quantities["pi_pd"].value == (1.0 if lam > 0 else 0.0)
    # sensitivity rows: one per swept value, and unlimited torque equals the plain run
    assert [r.parameter for r in res.sensitivity] == ["boundary_layer"] * 2 + ["torque_limit"] * 2
    plain = simulate(case.formation("ring:3"), replace(case.options, torque_limit=None))
    assert res.sensitivity[2].value is None
    assert res.sensitivity[2].convergence_time == plain.convergence_time
    md, figs = write_verification_report(res, tmp_path, command="x")
    text = md.read_text()
    assert md.name == "small_case-verification.md"
    assert text.splitlines()[0] == report_marker("tests/data/small_case.toml")
    assert "## Claims" in text and "## Sensitivity study" in text
    assert "saturation_torque_limit" not in text and "{limit}" not in text
    assert "` -" not in text and "| none |" not in text                 # no stray unit, one word
    assert "torque limit | unlimited |" in text
    assert all(p.is_file() for p in figs)
    doc = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert doc["sensitivity"][2]["value"] == "unlimited"


def test_horizon_too_short_is_undecided_then_decided_by_a_longer_run(tmp_path):
    case = load_case(SHORT)
    direct = simulate(case.formation("ring:3"), replace(case.options, tf=20.0))
    assert direct.convergence_time is not None and 5.0 < direct.convergence_time <= 15.0
    res = verify_case(SHORT)                                   # tf = 5 s, no max_tf
    v = {c.spec.key: c.verdict for c in res.claims}
    assert v == {"convergence": Verdict.UNDECIDED, "accuracy": Verdict.UNDECIDED,
                 "late": Verdict.HOLDS}
    assert not res.all_hold
    # with max_tf the run is lengthened (5 -> 10 -> 20 s) until its steady state is reached
    text = SHORT.read_text().replace("tail_fraction = 0.25", "tail_fraction = 0.25\nmax_tf = 20.0")
    longer = tmp_path / "short_longer.toml"
    longer.write_text(text)
    res2 = verify_case(longer)
    assert res2.topologies[0].horizon == 20.0
    assert res2.claims[0].measured["ring:3"] == Measurement.of(direct.convergence_time)
    assert {c.spec.key: c.verdict for c in res2.claims}["convergence"] is Verdict.HOLDS


def test_cli_names_output_after_the_case_file_and_strict(tmp_path, capsys):
    # a case whose [case] name is "liang2016" must not write liang2016-verification.md
    mine = tmp_path / "cases" / "my_case.toml"
    mine.parent.mkdir()
    mine.write_text(SHORT.read_text().replace('name = "short3"', 'name = "liang2016"'))
    out = tmp_path / "out"
    rc = main(["verify", str(mine), "--out", str(out), "--format", "json", "--strict"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and not doc["all_claims_hold"]               # undecided is not a pass
    assert (out / "my_case-verification.md").is_file()
    assert not (out / "liang2016-verification.md").exists()
    assert "Case file: `my_case.toml`" in (out / "my_case-verification.md").read_text()
    # the same case again is fine; another case with the same file name is refused
    assert main(["verify", str(mine), "--out", str(out)]) == 0
    other = tmp_path / "other" / "my_case.toml"
    other.parent.mkdir()
    shutil.copy(SMALL, other)
    capsys.readouterr()
    assert display_path(other) == display_path(mine)            # both outside the repository
    md = out / "my_case-verification.md"
    md.write_text(md.read_text().replace("case=my_case.toml", "case=cases/my_case.toml"))
    assert main(["verify", str(other), "--out", str(out)]) == 2
    assert "case=cases/my_case.toml" in md.read_text()          # untouched
    capsys.readouterr()
    assert main(["verify", str(mine), "--out", str(out), "--overwrite"]) == 0
    assert md.read_text().splitlines()[0] == report_marker("my_case.toml")


def test_sensitivity_figures_mark_singular_runs():
    from formsync_design.verify.report import sensitivity_figure
    from formsync_design.verify.results import SensitivityRow

    ok = SensitivityRow("boundary_layer", 0.01, "converged", "", 50.0, 1e-6, 1e-7, 1e-5, 2.0, 0, None)
    bad = SensitivityRow("boundary_layer", 0.1, "singular", "q0 -> 0", *([None] * 7))
    fig = sensitivity_figure([ok, bad], "boundary_layer")
    assert all(any("singular" in t.get_text() for t in ax.texts) for ax in fig.axes)
    fig = sensitivity_figure([ok], "boundary_layer")
    assert not any(ax.texts for ax in fig.axes)


@pytest.mark.slow
def test_case_spec_reaches_derivation_and_simulation(tmp_path):
    from formsync_design.spec.loader import load_spec

    spec_case = DATA / "case_with_spec.toml"
    case = load_case(spec_case)
    assert case.spec == str(DATA / "case_spec_fast.py")
    res = verify_case(spec_case)
    paper = verify_case(spec_case, spec=load_spec())
    assert res.spec_name == "case_spec_fast" and paper.spec_name == "liang2016"
    fast = res.topologies[0].sim
    slow = paper.topologies[0].sim
    # independent truth: the variant doubles K_q, i.e. the paper's law at gains (K_o, 2 K_q)
    from formsync_design.sim.formation import Formation, Gains

    f = case.formation("ring:3")
    g = case.gains
    f2 = Formation(f.graph, f.inertias, f.attitudes, f.rates,
                   Gains(g.K_o, 2 * g.K_q, g.beta, g.K_v), f.disturbance)
    ref = simulate(f2, case.options)
    assert fast["convergence_time"] == pytest.approx(ref.convergence_time, abs=0.11)
    assert fast["peak_torque"] != slow["peak_torque"]
