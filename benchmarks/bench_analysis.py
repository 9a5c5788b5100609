"""Benchmark of the issue-15 certificates (prints times; no assertions).

    .venv/bin/python benchmarks/bench_analysis.py [--quick]

Per graph of N = 500 spacecraft (ring, star, complete, path): one Laplacian
eigen-decomposition (N x N, never 3N x 3N), then the exact, searched and
spectral certificates of a gain box (searched: the LMIs are solved per eigenvalue
cluster, not seeded with the paper's V), a certified decay rate, a delay margin and
the cell-level peak-torque bound, for Liang et al.'s design and for the PD baseline
(its own gains k_p, k_d).  Against them, the plain alternative a user would write: the
dense 2N x 2N eigenvalues of the stacked nominal loop at one gain point (numpy), which
decides one point in floating point where the certificates decide a whole box exactly.
Last, the time to regenerate the comparison report (ring:8, star:8, complete:8, four
certificates on 512 cells) and the whole certificates report (every section).
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from formsync_design.analysis import certified_decay_rate, certify, delay_margin, laplacian_spectrum
from formsync_design.analysis.torque import peak_torque_bound
from formsync_design.graphs import make_graph


def _dense_point(name: str, d: float, k: float) -> float:
    """The plain alternative: dense eigenvalues of [[0, I], [-k L, -d I]] at one gain point."""
    lap = make_graph(name).laplacian.astype(float)
    n = lap.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-k * lap, -d * np.eye(n)]])
    t0 = time.perf_counter()
    np.linalg.eigvals(a)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="N = 100 and no report")
    a = ap.parse_args()
    n = 100 if a.quick else 500
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; N = {n}")
    J = np.diag([50.0, 55.0, 60.0])
    for name in (f"ring:{n}", f"star:{n}", f"complete:{n}", f"path:{n}"):
        t0 = time.perf_counter()
        spec = laplacian_spectrum(name)
        ts = time.perf_counter() - t0
        lmax = float(spec.lambda_max_hi)
        box = {"K_o": (1.0, 2.0), "K_q": (0.2, 1.0), "beta": (0.5 / lmax, 0.9 / lmax)}
        pd_box = {"k_p": (0.2, 1.0), "k_d": (1.0, 2.0)}
        print(f"{name:>13}: spectrum {ts:6.2f} s ({len(spec.clusters)} clusters, {spec.method}); "
              f"dense 2N x 2N eigenvalues at one point (numpy) {_dense_point(name, 1.5, 0.5):.2f} s")
        for design, b, pt, ds in (("liang2016", box, (1.5, 0.5, 0.5 / lmax), None),
                                  ("pd_consensus", pd_box, (0.5, 1.5), "pd_consensus")):
            row = [f"{'':>15}{design:<13}"]
            for c, seed in (("exact", True), ("searched", False), ("spectral", True)):
                t0 = time.perf_counter()
                r = certify(name, b, c, spectrum=spec, seed_with_paper=seed, spec=ds)
                row.append(f"{c} {time.perf_counter() - t0:6.2f} s ({r.status.value})")
            t0 = time.perf_counter()
            d = certified_decay_rate(name, {k: v[0] for k, v in b.items()}, "exact", spec=ds)
            row.append(f"decay {time.perf_counter() - t0:5.2f} s (alpha {float(d.alpha):.3g})")
            t0 = time.perf_counter()
            m = delay_margin(name, pt, spec=ds)
            row.append(f"delay {time.perf_counter() - t0:5.2f} s (margin {m.margin:.3g} s)")
            t0 = time.perf_counter()
            tb = peak_torque_bound(name, b, J, 0.01, 0.001, spec=ds, spectrum=spec)
            row.append(f"torque over the box {time.perf_counter() - t0:5.2f} s ({tb.peak:.3g} N m)")
            print(", ".join(row))
    if not a.quick:
        os.environ.setdefault("MPLBACKEND", "Agg")
        from formsync_design.analysis.report import write_certificates_report

        with tempfile.TemporaryDirectory() as td:
            t0 = time.perf_counter()
            write_certificates_report(Path(td))
            print(f"comparison report (3 graphs x 512 cells x 4 certificates): {time.perf_counter() - t0:.1f} s")
        import subprocess
        import sys

        script = Path(__file__).resolve().parents[1] / "verification" / "analysis_report.py"
        with tempfile.TemporaryDirectory() as td:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, str(script), "--root", td], check=True, capture_output=True)
            print(f"whole certificates report (verification/analysis_report.py, every section): "
                  f"{time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
