"""Where ``formsync verify liang2016`` spends its time: one in-process run with the main
stages timed (wall and CPU), warm kernel cache assumed.

Run: ``.venv/bin/python benchmarks/profile_verify.py OUT_DIR`` (``bench_simulate.py
--verify`` calls it).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import Any

T_START = time.perf_counter()
C_START = time.process_time()

from formsync_design.certify import (  # noqa: E402
    engine,
    formation as formation_cert,  # noqa: E402
    multipliers,
)
from formsync_design.cli.main import main as formsync  # noqa: E402
from formsync_design.derive import (  # noqa: E402
    compare,
    conditions,
    report as derive_report,  # noqa: E402
)
from formsync_design.sim import agents  # noqa: E402
from formsync_design.verify import engine_report  # noqa: E402

T_IMPORT = time.perf_counter() - T_START
ACC: dict[str, list[float]] = {}
STACK: list[str] = []


def wrap(mod: Any, name: str, tag: str) -> None:
    """Time calls of ``mod.name`` exclusively (a timed call inside another timed call is
    counted for the inner one only)."""
    fn: Callable[..., Any] = getattr(mod, name)

    def timed(*a: Any, **k: Any) -> Any:
        t, c = time.perf_counter(), time.process_time()
        STACK.append(tag)
        try:
            return fn(*a, **k)
        finally:
            STACK.pop()
            w, cp = time.perf_counter() - t, time.process_time() - c
            e = ACC.setdefault(tag, [0.0, 0.0, 0.0])
            e[0] += w
            e[1] += cp
            e[2] += 1
            if STACK:
                parent = ACC.setdefault(STACK[-1], [0.0, 0.0, 0.0])
                parent[0] -= w
                parent[1] -= cp

    setattr(mod, name, timed)


def main() -> int:
    out = sys.argv[1]
    wrap(agents, "simulate_agents", "simulations (simulate_agents)")
    wrap(formation_cert, "certify_formation", "formation certificates (certify_formation)")
    wrap(compare, "all_findings", "derivation findings (SymPy: derive.compare)")
    wrap(conditions, "derive_conditions", "conditions (derive_conditions)")
    wrap(multipliers, "certify_with_multipliers", "certificates (certify_with_multipliers)")
    wrap(engine, "certify_box", "certificates (certify_box, printed)")
    wrap(derive_report, "write_derivation_report", "derivation report (Markdown + LaTeX)")
    wrap(engine_report, "write_engine_report", "verification report + figures (matplotlib)")
    t0, c0 = time.perf_counter(), time.process_time()
    stdout, sys.stdout = sys.stdout, open(os.devnull, "w")  # noqa: SIM115
    try:
        formsync(["verify", "liang2016", "--out", out, "--overwrite"])
    finally:
        sys.stdout.close()
        sys.stdout = stdout
    total, ctotal = time.perf_counter() - t0, time.process_time() - c0
    print(f"imports before the command {T_IMPORT:.2f} s; the command {total:.2f} s wall, "
          f"{ctotal:.2f} s CPU [load {os.getloadavg()[0]:.2f}]")
    for tag, (w, c, n) in sorted(ACC.items(), key=lambda kv: -kv[1][0]):
        print(f"  {tag}: {w:.2f} s wall, {c:.2f} s CPU ({int(n)} calls)")
    rest = total - sum(v[0] for v in ACC.values())
    print(f"  everything else (case, graphs, metrics, claims, lazy imports): {rest:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
