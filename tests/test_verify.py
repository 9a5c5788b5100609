"""``formsync verify`` of small engine cases of the liang2016 design: output safety (all
before any computation), verdicts against direct runs of the classic Lagrangian simulator (a
second implementation) and the exact Π matrix, horizons too short to decide a claim, and the
report named after the case file."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.cli.main import main
from formsync_design.derive.conditions import derive_conditions
from formsync_design.errors import InputError
from formsync_design.sim.simulator import simulate
from formsync_design.verify.case import load_case
from formsync_design.verify.output import check_output, display_path, report_marker

DATA = Path(__file__).parent / "data"
SMALL = DATA / "small_case.toml"
SHORT = DATA / "case_short_horizon.toml"


# ---------------------------------------------------------------------------
# output safety (all before any computation)
# ---------------------------------------------------------------------------
@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if the verification starts computing."""
    import formsync_design.verify.engine as engine

    def boom(*a, **k):
        raise AssertionError("the verification ran although the input was bad")

    monkeypatch.setattr(engine, "verify_engine_case", boom)
    monkeypatch.setattr(engine, "run_engine", boom)


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


def test_bad_design_or_case_leaves_no_output_folder(tmp_path, capsys):
    out = tmp_path / "new" / "out"
    assert main(["verify", str(SMALL), "--out", str(out), "--design", str(tmp_path / "nope.py")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "new").exists()
    assert main(["verify", "no-such-case", "--out", str(out)]) == 2
    assert "expected a case name" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()
    # a simulation case (no [case] kind) is not a verification case: one line, exit 2
    assert main(["verify", str(DATA / "case_with_spec.toml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'kind = "engine"' in err[0]
    assert not (tmp_path / "new").exists()


def test_display_paths(tmp_path):
    assert display_path(SMALL) == "tests/data/small_case.toml"
    assert display_path(tmp_path / "x" / "mine.toml") == "mine.toml"


# ---------------------------------------------------------------------------
# end to end on small cases
# ---------------------------------------------------------------------------
def test_small_case_verdicts_agree_with_a_second_simulator_and_the_exact_pi(tmp_path):
    ver = fs.verify_case(SMALL)
    values = {m.id: v for m, v in ver.metrics}
    case = load_case(SMALL)  # the same case read as a formation case (classic simulator)
    for g, name in (("ring:3", "ring3"), ("path:3", "path3")):
        r = simulate(case.formation(g), case.options)
        assert r.convergence_time is not None
        # the agent kernel (RK4) against the classic DOPRI5 simulator: same first output time
        # to within one output step
        assert values[f"t_{name}"].value == pytest.approx(r.convergence_time, abs=0.11)
        lam = min(np.linalg.eigvalsh(derive_conditions(g).pi.evaluate((1.6, 0.4, 0.3))))
        assert values[f"pi_{name}"].value == ("certified" if lam > 0 else "refuted")
    sat = simulate(case.formation("ring:3"), replace(case.options, torque_limit=2.0))
    assert sat.saturation_end_time is not None
    assert values["sat_ring3"].value == pytest.approx(sat.saturation_end_time, abs=0.11)
    verdicts = {c.claim.id: c.verdict for c in ver.claims}
    assert verdicts["saturation"] == ("holds" if sat.saturation_end_time <= 10 else "fails")
    assert verdicts["pi_pd"] == "holds"
    assert {c.claim.id: c.basis for c in ver.claims}["pi_pd"] == "proof"
    assert not ver.all_hold and verdicts["saturation"] == "fails"


def test_horizon_too_short_is_undecided_then_decided_by_a_longer_run(tmp_path):
    ver = fs.verify_case(SHORT)                                # tf = 5 s
    assert {c.claim.id: c.verdict for c in ver.claims} == {
        "convergence": "undecided", "accuracy": "undecided", "late": "holds"}
    t = dict((m.id, v) for m, v in ver.metrics)["tconv"]
    assert t.bound == "lower" and t.value == pytest.approx(5.0)
    assert not ver.all_hold
    longer = tmp_path / "short_longer.toml"
    longer.write_text(SHORT.read_text().replace("tf = 5.0", "tf = 20.0"))
    case = load_case(longer)
    direct = simulate(case.formation(), case.options)
    assert direct.convergence_time is not None and 5.0 < direct.convergence_time <= 15.0
    ver2 = fs.verify_case(longer)
    t2 = dict((m.id, v) for m, v in ver2.metrics)["tconv"]
    assert t2.bound == "exact" and t2.value == pytest.approx(direct.convergence_time, abs=0.11)
    assert {c.claim.id: c.verdict for c in ver2.claims}["convergence"] == "holds"


def test_cli_names_output_after_the_case_file_and_strict(tmp_path, capsys):
    # a case whose [case] name is "liang2016" must not write liang2016-verification.md
    mine = tmp_path / "cases" / "my_case.toml"
    mine.parent.mkdir()
    mine.write_text(SHORT.read_text().replace('name = "short3"', 'name = "liang2016"'))
    out = tmp_path / "out"
    rc = main(["verify", str(mine), "--out", str(out), "--format", "json", "--strict"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and not doc["all_hold"]                     # undecided is not a pass
    assert (out / "my_case-verification.md").is_file()
    assert not (out / "liang2016-verification.md").exists()
    assert "- case: `my_case.toml`" in (out / "my_case-verification.md").read_text()
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
