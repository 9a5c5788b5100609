"""Regenerate reports/liang2016-certificates.md and reports/figures/liang2016-certificates*
(the four certificates side by side on ring:8, star:8, complete:8, the requirement sections,
and the same certificates on the PD baseline in its own gains; issue 15).

    .venv/bin/python verification/analysis_report.py [--resolution R]

Deterministic: two runs give byte-identical files (< 2 min at the default resolution).
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
    from formsync_design.analysis.delay import delay_section
    from formsync_design.analysis.dwell import dwell_section
    from formsync_design.analysis.inertia import inertia_section
    from formsync_design.analysis.performance import performance_section
    from formsync_design.analysis.report import design_section, write_certificates_report
    from formsync_design.analysis.switching import switching_section
    from formsync_design.analysis.torque import torque_section

    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--resolution", type=int, default=8, help="cells per axis (default 8)")
    ap.add_argument("--root", type=Path, default=ROOT,
                    help="write ROOT/reports/... (default: the repository; the benchmark uses a temporary one)")
    a = ap.parse_args(argv)
    md = write_certificates_report(a.root, resolution=a.resolution,
                                   extra_sections=performance_section() + delay_section()
                                   + switching_section() + dwell_section() + torque_section()
                                   + inertia_section() + design_section())
    print(f"wrote {md.relative_to(ROOT) if md.is_relative_to(ROOT) else md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
