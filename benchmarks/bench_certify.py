"""Benchmark of box certification and region maps (prints numbers; no assertions).

    .venv/bin/python benchmarks/bench_certify.py [--quick]

1. The full region map for ring:8 over K_o in [0.05, 5], K_q in [0.05, 5],
   beta in [0.01, 1] at resolution 64 with every re-check (target < 10 s on
   2 cores), against the naive alternative: per-point dense eigenvalue
   evaluation of every Theta_i (x) I3 and Pi (x) I3 on the same 65^3 grid
   (timed on a random sample of grid points and extrapolated; note that the
   naive grid certifies nothing between its points).
2. certify_box time against N for ring, star and random graphs up to N = 500
   (derivation time shown separately; it is not part of certification).
"""

from __future__ import annotations

import os

# Single-threaded BLAS unless the caller says otherwise: on a shared 2-core machine
# OpenBLAS threads contend (a 500x500 Cholesky varies 0.01-0.3 s with threads).
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from formsync_design.certify.engine import certify_box  # noqa: E402
from formsync_design.certify.region import region_map  # noqa: E402
from formsync_design.derive.conditions import derive_conditions  # noqa: E402
from formsync_design.errors import GraphError  # noqa: E402
from formsync_design.graphs.build import make_graph  # noqa: E402

RANGES = {"K_o": ("0.05", "5"), "K_q": ("0.05", "5"), "beta": ("0.01", "1")}


def bench_region(resolution: int, naive_samples: int) -> None:
    conds = derive_conditions("ring:8")
    region_map(conds, RANGES, resolution=4)  # warm-up (imports, structure cache)
    times = []
    for _ in range(2):  # best of 2: the machine may be shared
        t0 = time.perf_counter()
        m = region_map(conds, RANGES, resolution=resolution)
        times.append(time.perf_counter() - t0)
    t_map = min(times)
    f = m.fractions
    print(f"region map ring:8, resolution {resolution}: {t_map:.2f} s (best of "
          f"{', '.join(f'{t:.2f}' for t in times)} s) "
          f"({len(m.boxes)} boxes, {m.vertices_evaluated} grid vertices decided, re-checks "
          + ", ".join(f"{k} {v}" for k, v in m.recheck.items() if v) + ")")
    print(f"  certified {f['certified']:.4f}, refuted {f['refuted']:.4f}, "
          f"undecided {f['undecided']:.4f} of the volume")
    # naive: dense eigenvalues of every family (x) I3 at every grid point
    npts = (resolution + 1) ** 3
    rng = np.random.default_rng(0)
    lo = np.array([0.05, 0.05, 0.01])
    hi = np.array([5.0, 5.0, 1.0])
    idx = rng.integers(0, resolution + 1, size=(naive_samples, 3))
    pts = lo + (hi - lo) * idx / resolution
    eye3 = np.eye(3)
    t0 = time.perf_counter()
    for p in pts:
        for fam in conds.families:
            np.linalg.eigvalsh(np.kron(fam.evaluate(p), eye3))
    t_s = time.perf_counter() - t0
    t_naive = t_s / naive_samples * npts
    print(f"naive dense per-point evaluation of the same {npts} grid points: "
          f"{t_s:.2f} s for {naive_samples} sampled points -> {t_naive:.1f} s extrapolated")
    print(f"  ratio naive / certified map: {t_naive / t_map:.1f}x "
          "(and the map covers every gain in the box, the grid only its points)")


def _graph(kind: str, n: int) -> str:
    if kind != "random":
        return f"{kind}:{n}"
    p = min(1.0, 8.0 / n)
    for seed in range(100):
        spec = f"random:{n}:{p:g}:{seed}"
        try:
            make_graph(spec)
            return spec
        except GraphError:
            continue
    raise RuntimeError(f"no connected random graph for N={n}")


def bench_scale(sizes: list[int]) -> None:
    box = {"K_o": ("1.44", "1.76"), "K_q": ("0.36", "0.44"), "beta": ("0.02", "0.03")}
    print("certify_box over K_o in [1.44, 1.76], K_q in [0.36, 0.44], beta in [0.02, 0.03] "
          "(SDP + every re-check):")
    print("  (first call includes the structure analysis, cached afterwards; repeat = median of 3)")
    print(f"  {'graph':<22} {'N':>4} {'derive s':>9} {'certify s':>10} {'repeat s':>9} {'SDP s':>8}"
          "  status     distinct blocks (largest)")
    for kind in ("ring", "star", "random"):
        for n in sizes:
            spec = _graph(kind, n)
            t0 = time.perf_counter()
            conds = derive_conditions(spec)
            t_der = time.perf_counter() - t0
            t0 = time.perf_counter()
            r = certify_box(conds, box)
            t_cert = time.perf_counter() - t0
            rep = []
            for _ in range(3):
                t0 = time.perf_counter()
                certify_box(conds, box)
                rep.append(time.perf_counter() - t0)
            struct = r.argument.split("structure: ")[-1].split(";")[0]
            print(f"  {spec:<22} {n:>4} {t_der:>9.2f} {t_cert:>10.3f} {sorted(rep)[1]:>9.3f} "
                  f"{r.solver.solve_time:>8.3f}  {r.status:<10} {struct.split('-> ')[-1]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smaller sizes (smoke run)")
    a = ap.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.2f}, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}, "
          f"python {platform.python_version()}, "
          f"numpy {np.__version__}")
    import cvxpy  # noqa: F401 - import once here so that no timing below includes it
    bench_region(16 if a.quick else 64, 300 if a.quick else 3000)
    bench_scale([8, 50] if a.quick else [8, 50, 100, 200, 500])


if __name__ == "__main__":
    main()
