"""Benchmark: how long a command takes to end after Ctrl-C (issue 24 item 4, issue 34 item 7).

The promise "Ctrl-C ends every long command within a second" is a timing: it is measured
here and printed, not asserted in the tests (``tests/test_interrupts.py`` and the Dask sweep
test of ``tests/test_cli_sweep.py`` check only *what* an interrupted command does, and wait
for states, with hang guards of minutes).

Each command runs in a fresh interpreter with ``FORMSYNC_READY_FILE`` set
(:func:`formsync_design.progress.mark_ready`); SIGINT is sent once the command marks the
state named below (to the whole process group, as a terminal's Ctrl-C, for the sweeps), and
the time from the signal to the process's exit is printed with its exit status and the
1-minute load average (on this shared 2-core machine other work stretches it: a compiled
kernel call in flight is finished before Python sees the signal).

* ``montecarlo --design liang2016 --runs 5000``: after its first batch (the Lagrangian
  batches are sized to about 0.25 s of wall time);
* ``montecarlo --design ma_so3 --runs 5000``: after its first batch (an agent design's runs
  are advanced 64 at a time in one kernel call per 200 output intervals: the latency is one
  such call, seconds under load);
* ``sweep --workers 2``: while its local cluster starts (the signal is held, then raised);
* ``sweep --workers 2``: once two rows are in the journal.

Run: ``.venv/bin/python benchmarks/bench_interrupts.py [--repeat 3] [--only NAME]``
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXE = [sys.executable, "-m", "formsync_design"]
SWEEP = ["sweep", "--graphs", "atlas:2..6", "--resolution", "2", "--design-betas", "2",
         "--no-progress", "--workers", "2"]

#: name, arguments (``{out}`` the output folder), the state waited for, signal the group
CASES: list[tuple[str, list[str], str, bool]] = [
    ("montecarlo-liang2016", ["montecarlo", "--design", "liang2016", "--runs", "5000",
                              "--no-certify", "--out", "{out}"], "montecarlo", False),
    ("montecarlo-ma_so3", ["montecarlo", "--design", "ma_so3", "--runs", "5000",
                           "--no-certify", "--out", "{out}"], "montecarlo", False),
    ("sweep-cluster-start", [*SWEEP, "--out", "{out}"], "sweep: local cluster starting", True),
    ("sweep-running", [*SWEEP, "--out", "{out}"], "journal:2", True),
]
GUARD = 600.0


def _reached(state: str, ready: Path, out: Path) -> bool:
    if state.startswith("journal:"):
        j = out / "journal.jsonl"
        return j.is_file() and j.read_bytes().count(b"\n") >= int(state.split(":")[1])
    return ready.is_file() and state in ready.read_text().splitlines()


def once(argv: list[str], state: str, group: bool) -> tuple[float, int | None]:
    """Seconds from SIGINT to exit, and the exit status."""
    with tempfile.TemporaryDirectory() as td:
        ready, out = Path(td, "ready"), Path(td, "out")
        proc = subprocess.Popen([*EXE, *(a.replace("{out}", str(out)) for a in argv)],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                env={**os.environ, "FORMSYNC_READY_FILE": str(ready)},
                                start_new_session=group)
        try:
            deadline = time.monotonic() + GUARD
            while proc.poll() is None and not _reached(state, ready, out):
                if time.monotonic() > deadline:
                    raise SystemExit(f"no state {state!r} within {GUARD:g} s")
                time.sleep(0.01)
            if proc.poll() is not None:
                raise SystemExit(f"ended (exit {proc.returncode}) before the state {state!r}")
            t0 = time.perf_counter()
            if group:
                os.killpg(proc.pid, signal.SIGINT)
            else:
                proc.send_signal(signal.SIGINT)
            proc.wait(timeout=GUARD)
            return time.perf_counter() - t0, proc.returncode
        finally:
            if proc.poll() is None:
                if group:
                    os.killpg(proc.pid, signal.SIGKILL)
                else:
                    proc.kill()
                proc.wait()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=[c[0] for c in CASES], action="append")
    args = ap.parse_args()
    print(f"# Ctrl-C to exit, seconds (load {os.getloadavg()[0]:.2f}, {os.cpu_count()} CPUs); "
          "target: under 1 s on an idle machine")
    for name, argv, state, group in CASES:
        if args.only and name not in args.only:
            continue
        times, codes = [], set()
        for _ in range(max(1, args.repeat)):
            dt, rc = once(argv, state, group)
            times.append(dt)
            codes.add(rc)
        print(f"{name:24s} best {min(times):6.2f}  median {statistics.median(times):6.2f}  "
              f"max {max(times):6.2f}  exit {sorted(codes)}  "
              f"(load {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
