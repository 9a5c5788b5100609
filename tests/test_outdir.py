"""One writer per output folder, atomic result files (formsync_design.outdir)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from formsync_design import outdir
from formsync_design.cli.main import main
from formsync_design.errors import InputError

_HOLDER = textwrap.dedent("""
    import sys
    from formsync_design.outdir import locked
    with locked(sys.argv[1], "formsync holder-test"):
        print("held", flush=True)
        sys.stdin.readline()          # hold until the test says go
        if len(sys.argv) > 2:         # then finish a real sweep under the same (reentrant) lock
            from formsync_design.sweep import run_sweep
            from formsync_design.sweep.campaign import campaign_from_dict
            camp = campaign_from_dict({"campaign": {"name": "ring", "graphs": ["ring:4..5"]},
                                       "region": {"resolution": 2}, "design": {"betas": 2}})
            run_sweep(camp, sys.argv[1], n_workers=0)
        print("done", flush=True)
""")


def _holder(folder: Path, *extra: str) -> subprocess.Popen[str]:
    p = subprocess.Popen([sys.executable, "-c", _HOLDER, str(folder), *extra], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout is not None
    assert p.stdout.readline().strip() == "held"
    return p


def _release(p: subprocess.Popen[str]) -> str:
    out, _ = p.communicate("go\n", timeout=600)
    assert p.returncode == 0
    return out


def test_lock_refuses_another_process_and_names_it(tmp_path: Path) -> None:
    d = tmp_path / "out"
    p = _holder(d)
    try:
        with pytest.raises(outdir.FolderBusyError) as e:
            outdir.acquire(d)
        msg = str(e.value)
        assert str(d) in msg and f"pid {p.pid}" in msg and "holder-test" in msg
        assert "\n" not in msg
        assert isinstance(e.value, InputError)
    finally:
        _release(p)
    with outdir.locked(d) as lk:  # free again once the holder ended
        assert json.loads(lk.lock_file.read_text())["pid"] == os.getpid()
    assert not (d / outdir.LOCK_NAME).exists()


def test_lock_left_by_a_killed_process_is_taken_over(tmp_path: Path) -> None:
    d = tmp_path / "out"
    d.mkdir()
    (d / outdir.LOCK_NAME).write_text('{"pid": 999999999, "host": "h", "command": "dead"}\n')
    with outdir.locked(d, "me") as lk:
        assert json.loads(lk.lock_file.read_text())["command"] == "me"


def test_lock_is_reentrant_and_removes_the_folder_it_created_when_empty(tmp_path: Path) -> None:
    d = tmp_path / "a" / "b"
    with outdir.locked(d):
        with outdir.locked(d):
            assert d.is_dir()
        assert (d / outdir.LOCK_NAME).exists()
    assert not (tmp_path / "a").exists()
    with pytest.raises(InputError, match="file"):
        (tmp_path / "f").write_text("x")
        outdir.acquire(tmp_path / "f" / "sub")


def test_atomic_write_keeps_the_old_file_when_the_writer_crashes(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    p = tmp_path / "summary.json"
    p.write_text("old\n")

    class Boom(Exception):
        pass

    class Fig:  # a figure whose savefig dies half-way through its output
        def savefig(self, fh: object, **kw: object) -> None:
            fh.write(b"partial")  # type: ignore[attr-defined]
            raise Boom

    with pytest.raises(Boom):
        outdir.save_figure(Fig(), p)
    assert p.read_text() == "old\n"
    real = os.fsync

    def crash(fd: int) -> None:  # the disk fails after the bytes went out, before the rename
        real(fd)
        raise OSError(5, "I/O error")

    monkeypatch.setattr(os, "fsync", crash)
    with pytest.raises(OSError):
        outdir.write_text(p, "new\n")
    monkeypatch.undo()
    assert p.read_text() == "old\n"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["summary.json"]
    outdir.write_text(p, "new\n")
    assert p.read_text() == "new\n"


def test_simulate_refused_while_another_writer_holds_out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "sim"
    p = _holder(d)
    try:
        rc = main(["simulate", "--tf", "1", "--figures", "none", "--out", str(d)])
        err = capsys.readouterr().err
        assert rc == 2
        assert err.count("\n") == 1 and str(d) in err and f"pid {p.pid}" in err
        assert sorted(x.name for x in d.iterdir()) == [outdir.LOCK_NAME]  # nothing written
    finally:
        _release(p)


def test_simulate_does_not_replace_another_runs_results(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "sim"
    assert main(["simulate", "--tf", "1", "--figures", "none", "--out", str(d)]) in (0, 1)
    first = {x.name: x.read_bytes() for x in d.iterdir()}
    assert set(first) == {"summary.json", "trajectory.npz"}  # the lock file is gone
    capsys.readouterr()
    rc = main(["simulate", "--tf", "1", "--figures", "none", "--gain", "K_o=1.2", "--out", str(d)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "--overwrite" in err and "summary.json" in err
    assert {x.name: x.read_bytes() for x in d.iterdir()} == first
    assert main(["simulate", "--tf", "1", "--figures", "none", "--gain", "K_o=1.2", "--out", str(d),
                 "--overwrite"]) in (0, 1)
    assert json.loads((d / "summary.json").read_text())["gains"]["K_o"] == 1.2


def test_refused_simulate_leaves_no_folder(tmp_path: Path) -> None:
    d = tmp_path / "new"
    assert main(["simulate", "--tf", "-1", "--out", str(d)]) == 2
    assert not d.exists()


def test_concurrent_sweeps_one_proceeds_other_refused(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "sweep"
    p = _holder(d, "sweep")  # holds d, then runs the ring campaign to completion
    try:
        rc = main(["sweep", "--graphs", "star:4..5", "--resolution", "2", "--design-betas", "2",
                   "--workers", "0",
                   "--out", str(d)])
        err = capsys.readouterr().err
        assert rc == 2 and err.count("\n") == 1 and f"pid {p.pid}" in err and str(d) in err
    finally:
        assert _release(p).strip().endswith("done")
    from formsync_design.sweep.store import read_results

    rows = read_results(d / "results.csv")
    assert sorted(r["graph"] for r in rows) == ["ring:4", "ring:5"]
    man = json.loads((d / "manifest.json").read_text())
    assert man["campaign"]["name"] == "ring" and man["tasks"] == 2
    assert not (d / outdir.LOCK_NAME).exists() and not (d / "journal.jsonl").exists()


def test_sweep_journal_exists_when_the_first_task_runs(tmp_path: Path) -> None:
    from formsync_design.sweep import run_sweep
    from formsync_design.sweep.campaign import campaign_from_dict
    from formsync_design.sweep.tasks import run_task

    d = tmp_path / "sw"
    seen = []

    def task(t: dict) -> dict:
        seen.append(((d / "journal.jsonl").is_file(), (d / "manifest.json").is_file()))
        return run_task(t)

    camp = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]},
                               "region": {"resolution": 2}, "design": {"betas": 2}})
    run_sweep(camp, d, n_workers=0, task_fn=task)
    assert seen == [(True, True)]
