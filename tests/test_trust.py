"""The trust model for design code and the containment of misbehaving design code (issue 34,
items 1 and 4): what runs with the user's word, what every such run says, and what design
code that hangs, exits or declares its own proof gets.  The refusals are rows of the
bad-input table (``tests/bad_inputs/trust.py``)."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from formsync_design.cli.main import main
from formsync_design.errors import DerivationError, InputError
from tests.bad_inputs.trust import CASE, TIMEOUT_ROWS
from tests.badinput import PAYLOAD, BadInput, run_bad_input

ROOT = Path(__file__).resolve().parents[1]

#: A rate damper with its own metric that *declares* a certificate and returns a constant.
DECLARING = '''FORM = "agent"
GAINS = {"k": {}}
from formsync_design.verify.metrics import register_metric


def controller(v):
    return -v.k * v.J * v.w


@register_metric("test_trust_declared_proof", unit="1", evidence="certificate",
                 doc="a constant the design file calls a certificate")
def declared(ctx):
    return ctx.value(0.0)
'''

DECLARING_CASE = CASE.replace("k_p = 0.4\nk_d = 1.6", "k = 1.0") + """
[[metrics]]
id = "claimed"
metric = "test_trust_declared_proof"
[[claims]]
id = "proved"
text = "a proof declared by the design file"
predicate = "claimed < 1"
"""


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.fixture
def declaring(tmp_path: Path):
    from formsync_design.verify.metrics import METRICS

    (tmp_path / "damper.py").write_text(DECLARING)
    (tmp_path / "case.toml").write_text(DECLARING_CASE.replace("{design}", "damper.py"))
    yield tmp_path
    METRICS.pop("test_trust_declared_proof", None)


def _in(folder: Path, argv: list[str], capsys) -> tuple[int, str, str]:
    old = Path.cwd()
    os.chdir(folder)
    try:
        capsys.readouterr()
        rc = main(argv)
        out, err = capsys.readouterr()
    finally:
        os.chdir(old)
    return rc, out, err


def test_a_trusted_design_file_runs_and_every_output_names_its_hash(declaring, capsys):
    d = declaring
    sha = _sha(d / "damper.py")
    rc, out, err = _in(d, ["verify", "case.toml", "--out", "o", "--trust-design", "damper.py",
                           "--format", "json"], capsys)
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["design_code"] == [{"path": "damper.py", "sha256": sha}]
    report = (d / "o" / "case-verification.md").read_text()
    assert f"design code that is not shipped, run on the user's trust: `damper.py` (sha256 `{sha}`)" \
        in report
    # text output: one stderr line names the file and its hash
    rc, out, err = _in(d, ["verify", "case.toml", "--out", "o", "--trust-design", "damper.py"],
                       capsys)
    assert rc == 0, err
    assert f"formsync verify: loading design code that is not shipped: damper.py (sha256 {sha})" \
        in err


def test_a_design_files_declared_certificate_is_not_the_engines_proof(declaring, capsys):
    d = declaring
    sha = _sha(d / "damper.py")
    rc, out, err = _in(d, ["verify", "case.toml", "--out", "o", "--trust-design", "damper.py",
                           "--format", "json"], capsys)
    assert rc == 0, err
    doc = json.loads(out)
    claim = next(c for c in doc["claims"] if c["id"] == "proved")
    assert claim["verdict"] == "holds"
    assert claim["basis"] == f"declared by design file damper.py (sha256 {sha})"
    metric = next(m for m in doc["metrics"] if m["id"] == "claimed")
    assert metric["detail"].startswith(f"declared by design file damper.py (sha256 {sha})")
    text = (d / "o" / "case-verification.md").read_text()
    assert f"declared by design file damper.py (sha256 {sha})" in text
    assert "| proof |" not in text


def test_trust_is_by_content_a_file_changed_after_it_was_trusted_is_refused(tmp_path):
    from formsync_design.spec.loader import load_design
    from formsync_design.spec.trust import resolve_design_ref, trusting

    (tmp_path / "case.toml").write_text("")
    mine = tmp_path / "mine.py"
    mine.write_text(DECLARING.split("from formsync")[0] + "\n\ndef controller(v):\n"
                    "    return -v.k * v.J * v.w\n")
    with trusting(mine):
        mine.write_text(mine.read_text() + "# changed after it was trusted\n")
        with pytest.raises(InputError, match="--trust-design"):
            resolve_design_ref("mine.py", tmp_path / "case.toml", "case.design")
    with trusting(mine):  # trusted as it is now: pinned to that content
        target = resolve_design_ref("mine.py", tmp_path / "case.toml", "case.design")
    mine.write_text(mine.read_text() + "# changed after it was resolved\n")
    with pytest.raises(InputError, match="the file changed"):
        load_design(target)


def test_a_symlink_out_of_the_folder_is_refused(tmp_path, capsys):
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "evil.py").write_text(PAYLOAD)
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "link.py").symlink_to(tmp_path / "elsewhere" / "evil.py")
    row = BadInput(id="symlink", argv=("verify", "cases/case.toml", "--out", "o"), exit=2,
                   files={"cases/case.toml": CASE.replace("{design}", "link.py")},
                   stderr=("leads outside that folder",), sentinels=("elsewhere/PWNED", "o"))
    run_bad_input(row, tmp_path, capsys)


def test_a_sweep_worker_loads_the_design_only_with_the_content_checked(tmp_path):
    """A task carries the design file's path and sha256: a worker refuses other content."""
    from formsync_design.resources import design_file
    from formsync_design.sweep import campaign_from_dict, expand_graphs
    from formsync_design.sweep.tasks import build_tasks, run_task

    mine = tmp_path / "mine.py"
    mine.write_text(design_file("pd_consensus").read_text())
    c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]},
                            "region": {"resolution": 2}, "design": {"betas": 2}}, spec=str(mine))
    gs, _ = expand_graphs(c.graphs)
    (task,) = build_tasks(c, gs)
    assert task["spec_sha256"] == _sha(mine)
    mine.write_text(mine.read_text() + "\nimport pathlib\n"
                    "pathlib.Path(__file__).with_name('PWNED').write_text('ran')\n")
    with pytest.raises(InputError, match="the file changed"):
        run_task(task)
    assert not (tmp_path / "PWNED").exists()


@pytest.mark.parametrize("row", TIMEOUT_ROWS, ids=[r.id for r in TIMEOUT_ROWS])
def test_design_code_that_does_not_finish_is_stopped_at_the_limit(row, tmp_path, capsys,
                                                                   monkeypatch):
    monkeypatch.setenv("FORMSYNC_DESIGN_TIMEOUT", "1")
    run_bad_input(row, tmp_path, capsys)


def test_the_time_limit_setting_is_checked(monkeypatch):
    from formsync_design.spec.contain import design_timeout

    monkeypatch.setenv("FORMSYNC_DESIGN_TIMEOUT", "soon")
    with pytest.raises(InputError, match="FORMSYNC_DESIGN_TIMEOUT"):
        design_timeout()
    monkeypatch.setenv("FORMSYNC_DESIGN_TIMEOUT", "0")
    assert design_timeout() == float("inf")


def test_ctrl_c_in_design_code_still_interrupts(tmp_path, capsys):
    (tmp_path / "ki.py").write_text("raise KeyboardInterrupt\n")
    rc, _, err = _in(tmp_path, ["simulate", "--design", "ki.py"], capsys)
    assert rc == 130, err


def test_a_metric_of_a_design_file_that_exits_is_one_line(declaring, capsys):
    d = declaring
    (d / "damper.py").write_text(DECLARING.replace("return ctx.value(0.0)", "raise SystemExit(0)"))
    rc, _, err = _in(d, ["verify", "case.toml", "--out", "o", "--trust-design", "damper.py"],
                     capsys)
    lines = [ln for ln in err.splitlines() if "error" in ln]
    assert rc == 2 and len(lines) == 1, err
    assert "damper.py" in lines[0] and "SystemExit(0)" in lines[0]


def _run(tmp_path: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "formsync_design", *argv], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_os_exit_in_design_code_is_reported_and_leaves_no_lock_that_blocks(tmp_path):
    """``os._exit`` at import is reported (exit 2), the output folder's lock is released; a
    lock file left by a process that died holding it does not block the next run."""
    (tmp_path / "bye.py").write_text("import os\nos._exit(0)\n")
    r = _run(tmp_path, "verify", "liang2016", "--design", "bye.py", "--out", "o")
    assert r.returncode == 2, r.stderr
    assert "os._exit(0)" in r.stderr and "bye.py" in r.stderr
    assert not (tmp_path / "o" / ".formsync.lock").exists()
    # a holder that died with the lock (its file left behind, with its pid) does not block
    (tmp_path / "o").mkdir(exist_ok=True)
    holder = subprocess.run(
        [sys.executable, "-c", "import os, sys; sys.path.insert(0, sys.argv[1]);"
         "from formsync_design.outdir import acquire; acquire('o'); os._exit(0)", str(ROOT)],
        cwd=tmp_path, timeout=120)
    assert holder.returncode == 0 and (tmp_path / "o" / ".formsync.lock").exists()
    from formsync_design.outdir import locked

    with locked(tmp_path / "o"):
        pass
    assert not (tmp_path / "o" / ".formsync.lock").exists()


def test_every_shipped_case_resolves_its_designs_with_no_flag():
    """Shipped designs are trusted by name: every shipped case (and its scenarios) loads with
    no --trust-design, and names no design code that is not shipped."""
    from formsync_design.resources import case_file, case_names
    from formsync_design.spec.trust import code_session
    from formsync_design.verify.dispatch import resolve_case
    from formsync_design.verify.enginecase import load_engine_case

    with code_session() as found:
        for name in case_names():
            load_engine_case(resolve_case(name))
        assert case_file("liang2016").is_file()
    assert found == []


def test_contain_reports_a_systemexit_from_validation(tmp_path):
    from formsync_design.spec.loader import load_design

    p = tmp_path / "bad.py"
    p.write_text('FORM = "agent"\nGAINS = {"k": {}}\n\n\ndef controller(v):\n'
                 "    raise SystemExit(0)\n")
    with pytest.raises(DerivationError, match=r"bad.py: expected the design code to return"):
        load_design(p)
