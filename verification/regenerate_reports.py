"""Regenerate every committed report under reports/ (run from anywhere).

    python verification/regenerate_reports.py

Each report is written by the same code its documented command runs, with that
command printed inside the report, so the output is byte-identical to what the
documented commands produce:

* ``formsync verify liang2016``  -> reports/liang2016-verification.md (+ figures) and,
  by its ``[report] derivation``, the derivation report of the design's Lagrangian view,
  reports/liang2016-derivation-ring8.{md,tex} (the same files ``formsync derive`` writes): an
  engine case, the candidate topologies are formations, the saturation and sensitivity
  studies scenarios;
* ``formsync verify pd_consensus`` -> reports/pd_consensus-verification.md (+ figures) and
  reports/pd_consensus-derivation-ring4.{md,tex}: the PD consensus baseline design end to end
  (an engine case, as liang2016);
* ``formsync verify selftrigger_mrp`` -> reports/selftrigger_mrp-verification.md (+ figures):
  the self-triggered MRP design of seed 001 against its event-triggered and periodic variants
  (an engine case: the variants are scenarios);
* ``formsync verify zhang2014_flyaround`` -> reports/zhang2014_flyaround-verification.md (+
  figures): the fly-around case of Zhang et al. 2014 (a tracking design, an ``engine`` case
  of the tracking form): its claims, the sensitivity study and the allocation comparison as
  scenarios, and its certificates;
* ``formsync verify lv2012`` and ``formsync verify lv2012_small`` ->
  reports/lv2012-verification.md and reports/lv2012_small-verification.md (+ figures): the
  output-feedback design without rate gyros (Lv et al. 2012, reconstructed) on the Liang et al.
  case and on a three-spacecraft chain, against controller (4) with perfect, noisy and failed
  gyros (engine cases: the gyro models and the comparison design are scenarios);
* ``formsync verify ma_so3`` -> reports/ma_so3-verification.md (+ figures): the SO(3)
  sliding-mode design of seed paper 002 against its comparison methods (at their literal
  gains and at equal peak torque) and Liang et al.'s controller, its derivation and its
  certificates on digraph families (an engine case: the methods are scenarios);
* ``formsync verify bai2008_passivity`` -> reports/bai2008_passivity-verification.md (+
  figures): the sixth design (Bai, Arcak, Wen 2008, reconstructed), a design file and an
  ``engine`` case only - formations, Monte-Carlo, metrics and claims declared in the case;
* ``verification/region_report.py`` -> reports/liang2016-region.md (+ figures);
* ``verification/analysis_report.py`` -> reports/liang2016-certificates.md (+ figure): the
  paper's, exact, searched and spectral certificates side by side;
* ``formsync sweep --campaign verification/sweep_atlas6.toml --out reports/sweep-atlas6
  --overwrite`` -> reports/sweep-atlas6/ (all connected graphs with N <= 6); the folder is
  removed first so that a changed campaign definition regenerates cleanly;
* ``formsync sweep --campaign verification/sweep_pd_atlas5.toml --out reports/sweep-pd-atlas5
  --overwrite`` -> reports/sweep-pd-atlas5/ (the PD baseline on the same graphs, compared with
  reports/sweep-atlas6, so it runs after it; also removed first).

The reports hold numbers whose last digits depend on rounding (counts of an adaptive
integrator's trigger evaluations, a Riccati residual, the vertex a degenerate LP picks), and
numpy and OpenBLAS pick their kernels by CPU: AVX-512 kernels sum in another order than AVX2
ones.  So the script runs itself in one numeric environment (:func:`canonical_environment`):
numpy's AVX-512 dispatch targets off, OpenBLAS's core type ``Haswell`` (AVX2 + FMA), so that
x86-64 machines with AVX2 and FMA are meant to write the same bytes (checked once: an AVX-512
machine in this environment reproduced the reports written on a machine whose numpy ran
without AVX-512; without the environment it changed digits in 8 files).  The compiled kernels use ``-march=native``; gcc
contracts to FMA on both classes alike.  A machine without AVX2/FMA, another gcc or glibc may
still differ in such digits.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


_CANONICAL = "FORMSYNC_CANONICAL_NUMERICS"


def canonical_environment(env: dict[str, str]) -> dict[str, str]:
    """``env`` with the numeric environment of the module docstring (idempotent)."""
    try:  # the dispatch tables of this numpy (numpy >= 2: numpy._core)
        import numpy._core._multiarray_umath as um
    except ImportError:  # numpy 1.26
        import numpy.core._multiarray_umath as um  # type: ignore[no-redef]

    out = dict(env)
    found = getattr(um, "__cpu_features__", {})
    dispatch = getattr(um, "__cpu_dispatch__", [])
    off = [f for f in dispatch if found.get(f) and ("512" in f or f == "X86_V4")]
    if off:
        out["NPY_DISABLE_CPU_FEATURES"] = " ".join(off)
    flags = ""
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        pass
    if " avx2" in flags and " fma" in flags:
        out["OPENBLAS_CORETYPE"] = "Haswell"
    out[_CANONICAL] = "1"
    return out


def main() -> int:
    if os.environ.get(_CANONICAL) != "1":
        env = canonical_environment(dict(os.environ))
        print("numeric environment: " + ", ".join(
            f"{k}={env[k]}" for k in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE") if k in env),
            flush=True)
        return subprocess.call([sys.executable, str(Path(__file__).resolve()), *sys.argv[1:]],
                               env=env)
    from formsync_design.cli.main import main as formsync

    os.chdir(ROOT)
    for folder in ("sweep-atlas6", "sweep-pd-atlas5"):
        shutil.rmtree(ROOT / "reports" / folder, ignore_errors=True)
    jobs: list[list[str]] = [
        ["verify", "liang2016"],
        ["verify", "pd_consensus"],
        ["verify", "selftrigger_mrp"],
        ["verify", "zhang2014_flyaround"],
        ["verify", "lv2012"],
        ["verify", "lv2012_small"],
        ["verify", "ma_so3"],
        ["verify", "bai2008_passivity"],
        ["sweep", "--campaign", "verification/sweep_atlas6.toml", "--out", "reports/sweep-atlas6",
         "--overwrite"],
        ["sweep", "--campaign", "verification/sweep_pd_atlas5.toml", "--out",
         "reports/sweep-pd-atlas5", "--overwrite"],
    ]
    for argv in jobs:
        print("formsync " + " ".join(argv), flush=True)
        rc = formsync(argv)
        if rc != 0:
            return rc
    scripts = [[sys.executable, str(ROOT / "verification" / name)]
               for name in ("region_report.py", "analysis_report.py")]
    for cmd in scripts:
        print(" ".join(Path(c).name if i == 0 else c for i, c in enumerate(cmd)), flush=True)
        rc = subprocess.call(cmd, cwd=ROOT)
        if rc != 0:
            return rc
    return 0


if __name__ == "__main__":
    sys.exit(main())
