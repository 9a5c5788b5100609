"""``formsync verify``: verify a published design's parameters and claims."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from formsync_design.cli.options import EXIT_NEGATIVE, EXIT_OK, add_format_option
from formsync_design.errors import InputError

__all__ = ["add_parser", "run", "resolve_case"]

_HELP = """\
Verify a published design: re-derive the conditions, certify the published
gains with the derived and with the printed conditions, simulate the nonlinear
formation on every candidate topology, judge each published claim (holds /
fails / depends on topology), and run the sensitivity study (boundary layer
against accuracy and chattering, torque limit against convergence).

CASE is a case name (liang2016 = verification/liang2016.toml) or a TOML file
with a [claims] table (see formsync_design/verify/verification.py for the format).

Writes <out>/<case>-verification.md, its figures under <out>/figures/, and the
derivation report it links to.

Exit status: 0 when the verification ran to completion (the verdicts are in
the report), 1 with --strict if any claim does not hold, 2 on bad input.

examples:
  formsync verify liang2016
  formsync verify liang2016 --format json --strict
  formsync verify my_case.toml --out /tmp/verification
"""


def add_parser(sub: Any) -> None:
    p = sub.add_parser("verify", help="verify a published design's parameters and claims",
                       description=_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("case", nargs="?", default="liang2016",
                   help="case name or TOML file (default: liang2016)")
    p.add_argument("--out", default="reports", help="output directory (default: reports)")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 if any claim does not hold on every candidate topology")
    add_format_option(p)
    p.set_defaults(func=run)


def resolve_case(name: str) -> Path:
    """A case name (``liang2016``) or a path to a TOML file."""
    p = Path(name)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            raise InputError(f"expected an existing case TOML file, received {name!r}")
        return p
    from formsync_design.resources import case_file, case_names

    if name not in case_names():
        raise InputError(f"expected a case name in {case_names()} or a .toml file, received {name!r}")
    return case_file(name)


def run(args: argparse.Namespace) -> int:
    from formsync_design.derive.report import write_derivation_report
    from formsync_design.verify.verification import (
        verification_json,
        verify_case,
        write_verification_report,
    )

    path = resolve_case(args.case)

    def say(msg: str) -> None:
        sys.stderr.write(f"verify: {msg}\n")
        sys.stderr.flush()

    res = verify_case(path, progress=say)
    say("write reports")
    g0 = res.topologies[0].graph
    write_derivation_report(
        g0, args.out,
        command="formsync derive" + (f" --graph {g0}" if g0 != "ring:8" else "")
        + (f" --out {args.out}" if args.out != "reports" else ""),
    )
    cmd = "formsync verify " + (args.case if args.case == "liang2016" else str(path))
    if args.out != "reports":
        cmd += f" --out {args.out}"
    md, figs = write_verification_report(res, args.out, command=cmd)
    if args.format == "json":
        sys.stdout.write(verification_json(res) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        for c in res.claims:
            sys.stdout.write(f"  {c.verdict:20s} {c.spec.text}\n")
    if args.strict and not res.all_hold:
        return EXIT_NEGATIVE
    return EXIT_OK
