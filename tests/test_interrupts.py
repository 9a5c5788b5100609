"""Ctrl-C ends every long command with exit 130 and one line, its --out intact.

The tests send SIGINT once the run has started and only bound the wait by a generous hang
guard (no timing assertion: the time to exit is measured by hand, well under a second).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from formsync_design.outdir import LOCK_NAME

EXE = [sys.executable, "-c",
       "import sys; from formsync_design.cli.main import main; sys.exit(main(sys.argv[1:]))"]


def _wait_for(path: Path, proc: subprocess.Popen[bytes], seconds: float = 120) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and proc.poll() is None and not path.exists():
        time.sleep(0.02)
    assert proc.poll() is None, "the command ended before it could be interrupted"
    assert path.exists()


def _interrupt(proc: subprocess.Popen[bytes], *, group: bool = False) -> str:
    if group:
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=20)  # a hang guard, not a timing assertion
    text = err.decode()
    assert proc.returncode == 130, text
    assert text.count("\n") == 1 and "interrupted" in text and "Traceback" not in text, text
    return text


@pytest.mark.parametrize("design", ["liang2016", "ma_so3"])
def test_ctrl_c_on_a_long_montecarlo_is_exit_130(tmp_path: Path, design: str) -> None:
    out = tmp_path / "mc"
    proc = subprocess.Popen([*EXE, "montecarlo", "--design", design, "--runs", "5000",
                             "--no-certify", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _wait_for(out / LOCK_NAME, proc)  # the command holds its --out: it has started
    time.sleep(3.0)
    _interrupt(proc)
    assert not out.exists()  # nothing was written: the folder the lock created is gone


def test_ctrl_c_while_the_dask_cluster_starts_is_not_lost(tmp_path: Path) -> None:
    """A Ctrl-C during the local cluster's start is held and raised once it is up."""
    out = tmp_path / "sw"
    proc = subprocess.Popen([*EXE, "sweep", "--graphs", "atlas:2..6", "--resolution", "2",
                             "--design-betas", "2", "--no-progress", "--workers", "2",
                             "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    _wait_for(out / LOCK_NAME, proc)  # folder locked: the campaign is checked, the cluster starts
    err = _interrupt(proc, group=True)
    assert "--resume" in err
    j = out / "journal.jsonl"
    if j.exists():  # the cluster came up before the signal was seen: the journal is intact
        data = j.read_bytes()
        assert data == b"" or data.endswith(b"\n")
        for line in data.splitlines():
            json.loads(line)
        assert (out / "manifest.json").is_file()
    # the folder is free for the next writer: a lock file a Ctrl-C left behind (the race
    # with the cluster's start) holds no flock, and a new claim takes it and removes it
    from formsync_design.outdir import claim

    claim(out).release()
    assert not (out / LOCK_NAME).exists()
