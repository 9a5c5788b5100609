"""Long single steps show progress on a terminal (issue 34, second batch: ``random:2000`` ran
``certify`` and ``sweep`` for more than a minute with nothing shown): ``certify`` draws an
activity line (elapsed time and stage, saying up front that it counts no steps), a sweep's bar is
up before its first task ends and its elapsed time moves; silent off a terminal, with
``--format json`` and with ``FORMSYNC_NO_PROGRESS``."""

from __future__ import annotations

import io
import sys
import time
from pathlib import Path

import pytest

from formsync_design import progress as pg
from formsync_design.cli import main


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _terminal(monkeypatch: pytest.MonkeyPatch) -> FakeTerminal:
    monkeypatch.delenv("FORMSYNC_NO_PROGRESS", raising=False)
    fake = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", fake)
    return fake


def test_a_ticking_bar_moves_while_one_step_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    terminal = _terminal(monkeypatch)
    p = pg.Progress(None, "sweep tasks", unit="task", tick=True)
    time.sleep(1.3)  # no update: only the ticker redraws
    p.close()
    text = terminal.getvalue()
    assert "sweep tasks" in text and "00:01" in text, text
    assert not any(t.name == "formsync-progress" for t in __import__("threading").enumerate())


def test_certify_shows_its_activity_on_a_terminal(monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    terminal = _terminal(monkeypatch)
    assert main(["certify", "--graph", "ring:4"]) == 0
    text = terminal.getvalue()
    assert "certify on ring:4 (N = 4; elapsed time, no step count)" in text, text
    assert "deriving the conditions" in text and "deciding the blocks" in text, text
    assert "CERTIFIED" in capsys.readouterr().out


@pytest.mark.parametrize("argv, env", [
    (["certify", "--graph", "ring:4", "--format", "json"], {}),
    (["certify", "--graph", "ring:4"], {"FORMSYNC_NO_PROGRESS": "1"}),
    (["certify", "--design", "ma_so3", "--graph", "cycle:4", "--format", "json"], {}),
])
def test_certify_is_silent_with_json_or_the_switch(monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str],
                                                   argv: list[str], env: dict[str, str]) -> None:
    terminal = _terminal(monkeypatch)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    assert main(argv) == 0
    assert "certify on" not in terminal.getvalue()


def test_an_agent_certificate_shows_its_stages(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    terminal = _terminal(monkeypatch)
    assert main(["certify", "--design", "ma_so3", "--graph", "cycle:4"]) == 0
    text = terminal.getvalue()
    assert "certify on cycle:4 (N = 4;" in text and "the formation certificate" in text, text


def test_a_sweep_bar_is_up_before_the_first_task_ends(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """The bar is drawn when the sweep starts (before, it appeared only once a task ended), its
    count set by the first finished task; cleared at the end; silent with --no-progress."""
    import formsync_design.sweep.runner as runner

    terminal = _terminal(monkeypatch)
    real = runner.execute
    seen: list[str] = []

    def spy(*a: object, **k: object) -> object:
        seen.append(terminal.getvalue())  # what the terminal shows when the tasks start
        return real(*a, **k)  # type: ignore[arg-type]

    monkeypatch.setattr(runner, "execute", spy)
    argv = ["sweep", "--graphs", "ring:3", "--graphs", "path:3", "--resolution", "2",
            "--design-betas", "2", "--workers", "0"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    assert seen and "sweep tasks" in seen[0], seen
    assert "/2" in terminal.getvalue()
    terminal.truncate(0)
    assert main([*argv, "--out", str(tmp_path / "b"), "--no-progress"]) == 0
    assert "sweep tasks" not in terminal.getvalue()
