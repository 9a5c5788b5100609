"""Ctrl-C ends every long command with exit 130 and one line, its --out intact.

A test interrupts a command once it is in the state the test is about (its long work runs,
its local cluster starts), read from the marker file ``FORMSYNC_READY_FILE``
(:func:`formsync_design.progress.mark_ready`), never after a guessed number of seconds.
Waits are bounded only by a generous hang guard (minutes: a loaded machine is slow, not
wrong), which no test measures; how fast a command stops is a benchmark
(``benchmarks/bench_interrupts.py``), not an assertion.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from formsync_design.outdir import LOCK_NAME
from formsync_design.progress import READY_ENV

EXE = [sys.executable, "-c",
       "import sys; from formsync_design.cli.main import main; sys.exit(main(sys.argv[1:]))"]

#: The longest any wait lasts (s): a hang guard, not a timing assertion.
HANG_GUARD = 600.0


class Child:
    """A ``formsync`` process with its marker file; killed (its group) if a test fails."""

    def __init__(self, argv: list[str], ready: Path, *, group: bool = False) -> None:
        self.ready = ready
        self.group = group
        self.proc = subprocess.Popen([*EXE, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     env={**os.environ, READY_ENV: str(ready)},
                                     start_new_session=group)

    def wait_for(self, what: str) -> None:
        """Until the command marks ``what`` as running (asserts that it still runs then)."""
        deadline = time.monotonic() + HANG_GUARD
        while self.proc.poll() is None and time.monotonic() < deadline:
            if self.ready.is_file() and what in self.ready.read_text().splitlines():
                break
            time.sleep(0.02)
        if self.proc.poll() is not None:
            _, err = self.proc.communicate()
            raise AssertionError(f"the command ended (exit {self.proc.returncode}) before it "
                                 f"marked {what!r}: {err.decode()[-2000:]}")
        assert what in self.ready.read_text().splitlines(), f"hang guard: no {what!r} marked"

    def interrupt(self) -> str:
        """SIGINT (to the whole group, as a terminal's Ctrl-C, when started as one); the
        command must end with exit 130 and one line on stderr."""
        if self.group:
            os.killpg(self.proc.pid, signal.SIGINT)
        else:
            self.proc.send_signal(signal.SIGINT)
        _, err = self.proc.communicate(timeout=HANG_GUARD)  # a hang guard, not a measurement
        text = err.decode()
        assert self.proc.returncode == 130, text
        assert text.count("\n") == 1 and "interrupted" in text and "Traceback" not in text, text
        return text

    def kill(self) -> None:
        if self.proc.poll() is None:
            try:
                if self.group:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                else:
                    self.proc.kill()
            except ProcessLookupError:
                pass
            self.proc.communicate()


@pytest.fixture
def start(tmp_path: Path) -> Iterator:
    children: list[Child] = []

    def run(argv: list[str], *, group: bool = False) -> Child:
        c = Child(argv, tmp_path / f"ready-{len(children)}", group=group)
        children.append(c)
        return c

    yield run
    for c in children:
        c.kill()


@pytest.mark.parametrize("design", ["liang2016", "ma_so3"])
def test_ctrl_c_on_a_long_montecarlo_is_exit_130(tmp_path: Path, start, design: str) -> None:
    out = tmp_path / "mc"
    # 5000 runs: many batches (minutes of work), so the campaign cannot finish between the
    # marker of its first finished batch and the signal
    child = start(["montecarlo", "--design", design, "--runs", "5000", "--no-certify",
                   "--out", str(out)])
    child.wait_for("montecarlo")  # the first batch of runs is done: the campaign runs
    assert (out / LOCK_NAME).exists()  # the command holds its --out
    child.interrupt()
    assert not out.exists()  # nothing was written: the folder the lock created is gone


def test_ctrl_c_while_the_dask_cluster_starts_is_not_lost(tmp_path: Path, start) -> None:
    """A Ctrl-C during the local cluster's start is held and raised once it is up."""
    out = tmp_path / "sw"
    child = start(["sweep", "--graphs", "atlas:2..6", "--resolution", "2",
                   "--design-betas", "2", "--no-progress", "--workers", "2",
                   "--out", str(out)], group=True)
    child.wait_for("sweep: local cluster starting")  # SIGINT is held from here on
    err = child.interrupt()
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


def test_the_ready_marker_is_written_only_when_asked(tmp_path: Path, monkeypatch) -> None:
    """``FORMSYNC_READY_FILE`` unset: no file; set: one line per distinct mark, in order."""
    from formsync_design import progress

    monkeypatch.setattr(progress, "_READY", [])
    monkeypatch.delenv(READY_ENV, raising=False)
    before = sorted(tmp_path.iterdir())
    progress.Progress(3, "work").update()
    assert sorted(tmp_path.iterdir()) == before
    f = tmp_path / "ready"
    monkeypatch.setenv(READY_ENV, str(f))
    p = progress.Progress(3, "montecarlo")
    p.update(0)
    assert not f.exists()  # no step finished yet
    p.update()
    p.update()
    progress.mark_ready("sweep: local cluster starting")
    assert f.read_text() == "montecarlo\nsweep: local cluster starting\n"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["ready"]  # no temporary left
