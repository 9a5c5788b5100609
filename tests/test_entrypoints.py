"""How the command line is reached and how fast it starts (issue 25, items 1 and 7).

``python -m formsync_design ...`` is the same command line as ``formsync ...`` (the
``[project.scripts]`` entry point); both are run here in a fresh interpreter.  Start-up:
``formsync --version``/``--help`` build the parser without importing a numeric stage, and
``import formsync_design`` imports none (checked in ``sys.modules`` of a subprocess, never
by a timer: ``benchmarks/bench_startup.py`` measures the times).
"""

from __future__ import annotations

import argparse
import importlib
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import formsync_design as fs
from formsync_design.cli import choices

ROOT = Path(__file__).resolve().parents[1]
#: Stages whose import costs a second or more, and numpy (a tenth of one).
HEAVY = ("numpy", "scipy", "sympy", "casadi", "cvxpy", "clarabel", "matplotlib", "dask",
         "distributed", "networkx")
SUBCOMMANDS = ("derive", "certify", "region", "design", "simulate", "montecarlo", "sweep", "verify")


def _run(*argv: str, code: str | None = None) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-c", code] if code is not None else [sys.executable, *argv]
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    env.pop("FORMSYNC_TRACEBACK", None)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)


def _script() -> Path:
    """The installed ``formsync`` script of this interpreter."""
    path = Path(sysconfig.get_path("scripts")) / ("formsync.exe" if os.name == "nt" else "formsync")
    if not path.exists():
        pytest.skip("the formsync script is not installed next to this interpreter")
    return path


def _loaded(code: str) -> list[str]:
    probe = (f"{code}; import sys; "
             f"print('loaded:', *(m for m in {HEAVY!r} if m in sys.modules))")
    proc = _run(code=probe)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split("loaded:")[-1].split()


# -- python -m formsync_design ------------------------------------------------------------------

def test_python_m_prints_the_version_like_the_script() -> None:
    mod = _run("-m", "formsync_design", "--version")
    assert (mod.returncode, mod.stdout, mod.stderr) == (0, f"formsync {fs.__version__}\n", "")
    script = subprocess.run([str(_script()), "--version"], capture_output=True, text=True,
                            timeout=120)
    assert (script.returncode, script.stdout) == (mod.returncode, mod.stdout)


def test_python_m_help_lists_every_subcommand() -> None:
    proc = _run("-m", "formsync_design", "--help")
    assert proc.returncode == 0 and proc.stdout.startswith("usage: formsync ")
    for name in SUBCOMMANDS:
        assert name in proc.stdout


@pytest.mark.parametrize("argv, words", [
    ((), "the following arguments are required"),
    (("no-such-command",), "invalid choice"),
    (("certify", "--graph", "ring:8", "--ko", "-1", "--kq", "0.4", "--beta", "0.3"), "K_o"),
    (("derive", "--graph", "no/such/edges.txt"), "no/such/edges.txt"),
])
def test_python_m_bad_input_is_exit_2_and_one_line(argv: tuple[str, ...], words: str) -> None:
    proc = _run("-m", "formsync_design", *argv)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines[-1].startswith("formsync") and words in lines[-1], proc.stderr
    assert "Traceback" not in proc.stderr


def test_python_m_runs_a_command_with_its_exit_status() -> None:
    """A refuted box is exit 1 (a negative finding), the same as ``formsync certify``."""
    proc = _run("-m", "formsync_design", "certify", "--graph", "star:8", "--ko", "1.6",
                "--kq", "0.4", "--beta", "0.3", "--format", "json")
    assert proc.returncode == 1, proc.stderr
    assert '"status": "refuted"' in proc.stdout


def test_main_module_runs_main_only_as_a_script() -> None:
    """Importing ``formsync_design.__main__`` (pytest, doc tools) runs no command."""
    mod = importlib.import_module("formsync_design.__main__")
    assert mod.main is importlib.import_module("formsync_design.cli.main").main


# -- start-up ------------------------------------------------------------------------------------

def test_import_formsync_design_imports_no_numeric_stage() -> None:
    assert _loaded("import formsync_design") == []


def test_building_the_parser_imports_no_numeric_stage() -> None:
    """What ``formsync --version``, ``--help`` and ``SUBCOMMAND --help`` run before exiting."""
    code = ("import importlib; m = importlib.import_module('formsync_design.cli.main'); "
            "m.build_parser()")
    assert _loaded(code) == []
    assert _loaded("from formsync_design.cli.main import main; main(['--version'])") == []


def test_every_public_name_resolves_lazily() -> None:
    """Every name of ``fs.__all__`` is an attribute, also in a fresh interpreter."""
    code = ("import formsync_design as fs; missing = [n for n in fs.__all__ if getattr(fs, n, None) "
            "is None]; assert not missing, missing; assert sorted(fs.__all__) == dir(fs)")
    proc = _run(code=code)
    assert proc.returncode == 0, proc.stderr


def test_parser_vocabularies_are_the_stages_own() -> None:
    """The names the parser shows (``formsync_design.cli.choices``) equal the stages'."""
    from formsync_design.graphs.build import GRAPH_SPEC_HELP
    from formsync_design.models.disturbances import DISTURBANCES
    from formsync_design.sim.bridge import SWITCHES
    from formsync_design.sim.formation import INTEGRATORS
    from formsync_design.sim.montecarlo_data import MAX_RUNS

    assert choices.GRAPH_SPEC_HELP == GRAPH_SPEC_HELP
    assert choices.DISTURBANCES == DISTURBANCES
    assert choices.SWITCHES == SWITCHES
    assert choices.INTEGRATORS == INTEGRATORS
    assert choices.MAX_RUNS == MAX_RUNS


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = importlib.import_module("formsync_design.cli.main").build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_subcommand_help_stays_informative(name: str) -> None:
    """Each subcommand's help still names its options, choices and defaults."""
    text = " ".join(_subparsers()[name].format_help().split())
    assert text.startswith(f"usage: formsync {name}")
    assert "--format" in text or name == "sweep"
    if name in ("simulate", "montecarlo"):
        assert "{sgn,sat,tanh}" in text and "{paper,gravity-gradient,none}" in text
        assert "ring:N | path:N" in text
    if name == "simulate":
        assert "{auto,rk4,dopri5,cvodes}" in text
    if name == "montecarlo":
        assert f"at most {choices.MAX_RUNS}" in text
    if name == "certify":
        assert "certificates (--certificate" in text and "ring:N | path:N" in text
