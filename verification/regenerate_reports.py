"""Regenerate every committed report under reports/ (run from the repository root).

    python verification/regenerate_reports.py

Each report is written by the same library function its subcommand uses, with
the same command line printed inside the report, so the output is byte-identical
to what the documented subcommands produce.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    from formsync_design.cli import main as formsync

    jobs = [
        ["derive"],
    ]
    for argv in jobs:
        print("formsync " + " ".join(argv), flush=True)
        rc = formsync(argv)
        if rc not in (0, 1):
            return rc
    return 0


if __name__ == "__main__":
    import os

    os.chdir(ROOT)
    sys.exit(main())
