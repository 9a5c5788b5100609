"""Benchmark: start-up and fixed costs of the command line (issue 25, item 7).

Each command runs in a fresh interpreter (``python -m formsync_design ...``, the same
command line as the ``formsync`` script), ``--repeat`` times; the median and the best
wall time and the median CPU time (user + system of the child, ``resource.getrusage``) are
printed beside a baseline of ``python -c pass`` in the same interpreter, with the 1-minute
load average (``os.getloadavg()``: on this shared 2-core machine other work stretches wall
times, far less CPU times; the ratio to the baseline is printed too).  Targets (wall, idle
machine):

* ``formsync --version`` and ``formsync --help``: under 0.3 s;
* ``formsync certify --graph ring:8 --ko 1.6 --kq 0.4 --beta 0.3`` (the paper's case, a
  cold process with warm disk caches): under 1.5 s;
* ``formsync montecarlo`` of the paper's case: 10 runs (the fixed cost before the first
  run) and, with ``--montecarlo``, 1000 runs end to end: under 4 s wall.

``--importtime`` also prints the ten slowest imports of each command
(``python -X importtime``), the place to look when a number regresses.  ``--cold``
also times the 10-run Monte-Carlo with an empty kernel cache (``FORMSYNC_CACHE_DIR`` a
fresh folder: the SymPy derivation, C generation and compilation of the kernel, once per
design), beside the warm run that loads the cached object without them.

Where the time went (the paper's case): ``import cvxpy`` (SciPy's statistics, ~1.3 CPU-s)
is needed only when the re-check of a certificate from LAPACK's eigenvalues leaves a block
undecided, never for the paper's point; the kernel's C source is generated (SymPy) only
when its object is not cached; ``formsync_design.sim`` and ``formsync_design.verify``
import their public names on first use.

The heavy commands (the paper's certificate, the Monte-Carlo campaigns) run at least three
times; the median decides.  ``--bytecode`` times processes that write and reuse ``.pyc``
files, as Python does by default: an environment with ``PYTHONDONTWRITEBYTECODE`` set (this
sandbox's) compiles every imported module in every process (about 0.2 s here), and the
header says which was measured.  On this machine the 1000-run campaign's compiled kernel
alone takes about 2.8-3.0 s of wall time on its two threads, and the VM's CPU speed varies
by about 15 % from run to run: the spread (best, median) is printed, not only one number.

Run: ``.venv/bin/python benchmarks/bench_startup.py [--repeat 5] [--montecarlo] [--cold]
[--importtime] [--bytecode]``
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

PAPER = ("--graph", "ring:8", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3")

#: label, arguments of ``python -m formsync_design``, target (s) or None, heavy (timed once)
COMMANDS: list[tuple[str, tuple[str, ...], float | None, bool]] = [
    ("formsync --version", ("--version",), 0.3, False),
    ("formsync --help", ("--help",), 0.3, False),
    ("formsync certify --help", ("certify", "--help"), None, False),
    ("import formsync_design", (), None, False),
    ("formsync certify (paper case)", ("certify", *PAPER), 1.5, False),
    ("formsync montecarlo --runs 10", ("montecarlo", "--runs", "10"), None, True),
]
MONTECARLO_1000 = ("formsync montecarlo --runs 1000", ("montecarlo", "--runs", "1000"), 4.0, True)


def _argv(args: tuple[str, ...], label: str) -> list[str]:
    if label.startswith("import "):
        return [sys.executable, "-c", "import formsync_design"]
    return [sys.executable, "-m", "formsync_design", *args]


def _cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


#: the environment of the timed processes (``--bytecode`` removes PYTHONDONTWRITEBYTECODE)
CHILD_ENV: dict[str, str] = dict(os.environ)


def _time(argv: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """Wall and CPU seconds of one fresh process."""
    c0, t0 = _cpu(), time.perf_counter()
    r = subprocess.run(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                       env=env if env is not None else CHILD_ENV)
    dt, dc = time.perf_counter() - t0, _cpu() - c0
    if r.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(argv)} failed (exit {r.returncode}): {r.stderr.strip()}")
    return dt, dc


def _line(label: str, times: list[tuple[float, float]], base: float) -> str:
    wall = [w for w, _ in times]
    med = statistics.median(wall)
    cpu = statistics.median(c for _, c in times)
    return (f"  {label:<34} wall median {med:6.3f} s  best {min(wall):6.3f} s  cpu {cpu:6.3f} s  "
            f"({med / base:5.1f}x baseline)  load {os.getloadavg()[0]:.1f}")


def _importtime(argv: list[str], top: int = 10) -> list[str]:
    r = subprocess.run([argv[0], "-X", "importtime", *argv[1:]], cwd=ROOT,
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    rows = []
    for line in r.stderr.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and parts[1].strip().isdigit():
            rows.append((int(parts[1]), parts[2].rstrip()))
    rows.sort(reverse=True)
    return [f"      {us / 1e6:6.3f} s cumulative  {name.strip()}" for us, name in rows[:top]]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5, help="runs per command (default 5)")
    ap.add_argument("--montecarlo", action="store_true", help="also time 1000 Monte-Carlo runs")
    ap.add_argument("--importtime", action="store_true", help="slowest imports of each command")
    ap.add_argument("--cold", action="store_true",
                    help="also time the 10-run Monte-Carlo with an empty kernel cache")
    ap.add_argument("--bytecode", action="store_true",
                    help="let the timed processes write and reuse bytecode (.pyc) as Python does "
                    "by default, when this environment sets PYTHONDONTWRITEBYTECODE")
    a = ap.parse_args(argv)
    if a.bytecode:
        CHILD_ENV.pop("PYTHONDONTWRITEBYTECODE", None)
    caching = "off (PYTHONDONTWRITEBYTECODE: every import compiles)" if CHILD_ENV.get(
        "PYTHONDONTWRITEBYTECODE") else "on (Python's default)"
    env_note = f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, bytecode cache {caching}"
    print(f"start-up of formsync ({env_note}); {a.repeat} fresh processes per command")
    base = [_time([sys.executable, "-c", "pass"]) for _ in range(a.repeat)]
    b_med = statistics.median(w for w, _ in base)
    print(_line("python -c pass (baseline)", base, b_med))
    commands = COMMANDS + ([MONTECARLO_1000] if a.montecarlo else [])
    for label, args, target, heavy in commands:
        cmd = _argv(args, label)
        _time(cmd)  # warm the disk caches (bytecode, derivations, compiled kernels)
        times = [_time(cmd) for _ in range(max(3, a.repeat // 2) if heavy else a.repeat)]
        med = statistics.median(w for w, _ in times)
        verdict = "" if target is None else (
            f"  target < {target:g} s: {'met' if med < target else 'MISSED'}")
        print(_line(label, times, b_med) + verdict)
        if a.importtime:
            print("\n".join(_importtime(cmd)))
    if a.cold:
        with tempfile.TemporaryDirectory() as td:
            env = {**CHILD_ENV, "FORMSYNC_CACHE_DIR": td}
            cmd = _argv(("montecarlo", "--runs", "10"), "montecarlo")
            print(_line("montecarlo --runs 10, cold kernel", [_time(cmd, env)], b_med))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
