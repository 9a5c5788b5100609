"""Regenerate reports/liang2016-region.md and reports/figures/liang2016-region-*
(certified gain regions of the paper's controller; run from anywhere).

    .venv/bin/python verification/region_report.py [--resolution R]

Deterministic: two runs give byte-identical files.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    # a report writer: figures go to files, so a non-interactive backend unless one is chosen
    os.environ.setdefault("MPLBACKEND", "Agg")
    from formsync_design.certify.plots import region_report

    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--resolution", type=int, default=64, help="cells per axis (default 64)")
    a = ap.parse_args(argv)
    md = region_report(ROOT, graphs=("ring:8", "star:8", "complete:8"), resolution=a.resolution)
    print(f"wrote {md.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
