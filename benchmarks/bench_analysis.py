"""Benchmark of the issue-15 certificates (prints times; no assertions).

    .venv/bin/python benchmarks/bench_analysis.py [--quick]

Per graph of N = 500 spacecraft (ring, star, complete, path): one Laplacian
eigen-decomposition (N x N, never 3N x 3N), then the exact, searched and
spectral certificates of a gain box (searched: the LMIs are solved per eigenvalue
cluster, not seeded with the paper's V), a certified decay rate and a delay margin;
last, the time to regenerate the comparison report (ring:8, star:8, complete:8).
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

from formsync_design.analysis import certified_decay_rate, certify, delay_margin, laplacian_spectrum


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="N = 100 and no report")
    a = ap.parse_args()
    n = 100 if a.quick else 500
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; N = {n}")
    for name in (f"ring:{n}", f"star:{n}", f"complete:{n}", f"path:{n}"):
        t0 = time.perf_counter()
        spec = laplacian_spectrum(name)
        ts = time.perf_counter() - t0
        lmax = float(spec.lambda_max_hi)
        box = {"K_o": (1.0, 2.0), "K_q": (0.2, 1.0), "beta": (0.5 / lmax, 0.9 / lmax)}
        row = [f"{name:>13}: spectrum {ts:6.2f} s ({len(spec.clusters)} clusters, {spec.method})"]
        for c, seed in (("exact", True), ("searched", False), ("spectral", True)):
            t0 = time.perf_counter()
            r = certify(name, box, c, spectrum=spec, seed_with_paper=seed)
            row.append(f"{c} {time.perf_counter() - t0:6.2f} s ({r.status.value})")
        t0 = time.perf_counter()
        d = certified_decay_rate(name, {k: v[0] for k, v in box.items()}, "exact")
        row.append(f"decay {time.perf_counter() - t0:5.2f} s (alpha {float(d.alpha):.3g})")
        t0 = time.perf_counter()
        m = delay_margin(name, (1.5, 0.5, 0.5 / lmax))
        row.append(f"delay {time.perf_counter() - t0:5.2f} s (margin {m.margin:.3g} s)")
        print(", ".join(row))
    if not a.quick:
        os.environ.setdefault("MPLBACKEND", "Agg")
        from formsync_design.analysis.report import write_certificates_report

        with tempfile.TemporaryDirectory() as td:
            t0 = time.perf_counter()
            write_certificates_report(Path(td))
            print(f"comparison report (3 graphs x 512 cells x 4 certificates): {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
