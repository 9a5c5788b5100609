"""Progress of long work (issue 25, item 6): a bar on a terminal, silent anywhere else.

Independent truths: what is written to a stream that says it is a terminal (and to one
that does not), a real pseudo-terminal for the command line (``pty``), and ``json.loads``
of the ``--format json`` output; the Monte-Carlo's batches, which move the bar, give the
same runs as one batch.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from formsync_design import progress as pg

ROOT = Path(__file__).resolve().parents[1]


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _terminal(monkeypatch: pytest.MonkeyPatch) -> FakeTerminal:
    """stderr a terminal for the rest of the test (set in the test body: pytest's capture
    installs its own stderr after the fixtures)."""
    monkeypatch.delenv("FORMSYNC_NO_PROGRESS", raising=False)
    fake = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", fake)
    return fake


def test_one_progress_mechanism() -> None:
    import importlib
    import pkgutil

    import formsync_design.cli as cli

    mods = [importlib.import_module(f"formsync_design.cli.{m.name}")
            for m in pkgutil.iter_modules(cli.__path__)]
    users = [m for m in mods if hasattr(m, "Progress")]
    assert users and all(m.Progress is pg.Progress for m in users)


def test_silent_when_stderr_is_not_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    plain = io.StringIO()
    monkeypatch.setattr(sys, "stderr", plain)
    p = pg.Progress(4, "region", unit="cell")
    for _ in range(4):
        p.update()
    p.close()
    with pg.activity("verify liang2016") as a:
        a.note("simulate ring:8")
    assert (p.done, p.enabled, a.enabled, plain.getvalue()) == (4, False, False, "")


def test_a_bar_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    terminal = _terminal(monkeypatch)
    p = pg.Progress(3, "montecarlo", unit="run")
    assert p.enabled
    p.update(2)
    p.update()  # the last step clears the bar
    text = terminal.getvalue()
    assert "montecarlo" in text and "/3" in text and "run" in text
    assert not p.enabled  # closed after the last step


def test_disabled_by_the_caller_or_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    terminal = _terminal(monkeypatch)
    pg.Progress(2, "json output", enabled=False).update(2)
    monkeypatch.setenv("FORMSYNC_NO_PROGRESS", "1")
    pg.Progress(2, "switched off").update(2)
    assert terminal.getvalue() == ""


def test_activity_keeps_printed_lines_clean(monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    terminal = _terminal(monkeypatch)
    with pg.activity("verify liang2016") as a:
        a.note("certify")
        print("claims: 12 hold")
    assert capsys.readouterr().out == "claims: 12 hold\n"
    assert "verify liang2016" in terminal.getvalue() and "certify" in terminal.getvalue()


def test_montecarlo_batches_move_the_bar_and_give_the_same_runs() -> None:
    from formsync_design.sim import MonteCarloSettings, SimOptions, run_montecarlo
    from formsync_design.verify.case import load_case

    f = load_case().formation()
    opt = SimOptions(tf=5.0, step=0.1, output_step=0.5, norm_tol=1e-5, compile=False)
    st = MonteCarloSettings(runs=3, seed=4)
    calls: list[int] = []
    small = run_montecarlo(f, settings=st, options=opt, certify=False, batch=2,
                           progress=calls.append)
    whole = run_montecarlo(f, settings=st, options=opt, certify=False)
    assert calls == [2, 1]
    assert [r.to_dict() for r in small.runs] == [r.to_dict() for r in whole.runs]


def test_agent_montecarlo_reports_each_finished_run_once() -> None:
    """An agent design's campaign calls ``progress`` with the runs finished since the last
    call, as the batch path does (a bar's ``update``), also through ``fs.monte_carlo``."""
    import numpy as np

    import formsync_design as fs
    from formsync_design.spec.agent import agent_design_from_functions

    d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    f = fs.AgentFormation(fs.load_graph("path:2"), np.array([np.eye(3)] * 2),
                          np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3)), fs.Gains(k=1.0))
    calls: list[int] = []
    res = fs.monte_carlo(f, {"k": "0.5:1"}, fs.MonteCarloSettings(runs=3, max_angle_deg=0),
                         fs.AgentOptions(tf=2, output_step=0.5, step=0.05, rate_tol=1.0),
                         certify=False, spec=d, progress=calls.append)
    assert calls == [1, 1, 1] and sum(calls) == len(res.runs)


def _on_a_pty(*argv: str) -> tuple[int, str, str]:
    """Run ``python -m formsync_design ARGV`` with stderr on a pseudo-terminal of 120 columns."""
    pty = pytest.importorskip("pty")
    import fcntl
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    env = {**os.environ, "COLUMNS": "120"}
    env.pop("FORMSYNC_NO_PROGRESS", None)
    proc = subprocess.Popen([sys.executable, "-m", "formsync_design", *argv], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=slave, text=True)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    out = proc.stdout.read() if proc.stdout else ""
    rc = proc.wait(timeout=600)
    os.close(master)
    return rc, out, b"".join(chunks).decode("utf-8", "replace")


@pytest.mark.skipif(sys.platform == "win32", reason="needs a POSIX pseudo-terminal")
def test_montecarlo_shows_a_bar_on_a_terminal_and_none_with_json() -> None:
    args = ("montecarlo", "--runs", "4", "--tf", "5", "--no-certify")
    rc, out, err = _on_a_pty(*args)
    assert rc in (0, 1), err
    assert "montecarlo:" in err and "/4 [" in err and "Monte-Carlo:" in out
    rc, out, err = _on_a_pty(*args, "--format", "json")
    assert rc in (0, 1), err
    assert json.loads(out)["settings"]["runs"] == 4
    assert "montecarlo:" not in err and "%|" not in err
