"""Benchmark of ``formsync sweep`` executors (prints numbers and ratios; no assertions).

    .venv/bin/python benchmarks/bench_sweep.py [--quick] [--design pd_consensus]

The same campaign (connected atlas graphs, the design's standard box, region
resolution 8, 5 values of the swept gain; liang2016 by default, any design with
--design) is run serially in this process and on a local Dask
cluster of 1 and 2 worker processes (cluster start included); the rows are
checked to be byte-identical and the wall-time ratios against the serial run
are printed.  On a 2-core machine shared with other work the ratio mostly
measures the load; run it on an idle machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

from formsync_design.sweep import campaign_from_dict, run_sweep


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="atlas:2..4 instead of atlas:2..5")
    ap.add_argument("--design", default="liang2016", help="the design swept (default liang2016)")
    a = ap.parse_args()
    graphs = "atlas:2..4" if a.quick else "atlas:2..5"
    camp = campaign_from_dict({"campaign": {"name": "bench", "graphs": [graphs], "design": a.design},
                               "region": {"resolution": 8}, "design": {"betas": 5}})
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; campaign {graphs}, "
          f"design {a.design}")
    with tempfile.TemporaryDirectory() as td:
        runs = [("serial", 0), ("dask, 1 worker", 1), ("dask, 2 workers", 2)]
        base = None
        csv0 = None
        for label, w in runs:
            out = Path(td) / label.replace(" ", "_").replace(",", "")
            t0 = time.perf_counter()
            res = run_sweep(camp, out, n_workers=w, timeout=60)
            dt = time.perf_counter() - t0
            csv = (out / "results.csv").read_bytes()
            csv0 = csv0 or csv
            base = base or dt
            print(f"{label:16s} {res.tasks} tasks {dt:7.2f} s  {res.tasks / dt:6.2f} tasks/s  "
                  f"ratio vs serial {dt / base:5.2f}  rows identical: {csv == csv0}")


if __name__ == "__main__":
    main()
