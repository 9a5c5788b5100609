"""``formsync verify``: verify a published design's parameters and claims."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from formsync_design.cli.options import add_format_option
from formsync_design.errors import InputError

__all__ = ["add_parser", "run", "resolve_case"]

_HELP = """\
Verify a published design: re-derive the conditions, certify the published
gains with the derived and with the printed conditions, simulate the nonlinear
formation on every candidate topology, judge each published claim (holds /
fails / undecided, when neither the simulated horizon nor the certificate
decides it; a classic formation case also says "depends on topology"), and run
the sensitivity study (boundary layer against accuracy and chattering, torque
limit against convergence).  The shipped cases are engine cases
(docs/engine.md).

CASE is a case name (liang2016 = verification/liang2016.toml) or a TOML file
with a [claims] table (format: formsync_design/verify/verification.py; judging
rules: formsync_design/verify/claims.py).  The specification is --spec, else
the case file's [case] spec, else the paper's; the derivation and every
simulation use it.

The case file's [case] kind picks the verifier: "formation" (the default,
above) or "engine" (any agent design: the case declares formations,
scenarios, Monte-Carlo draws, metrics from the registry and claims as
predicates over them; format and semantics: formsync_design/verify/enginecase.py,
docs/engine.md; a tracking design such as zhang2014_flyaround has its own
form of the tables: formsync_design/verify/engine_tracking.py, its scenarios
the sensitivity study and the pseudo-inverse / LP allocation comparison).

Writes <out>/<CASE file stem>-verification.md, its figures under
<out>/figures/<CASE file stem>-verification/, and the derivation report it
links to.  --out is checked before any work; an existing report of a
different case is not replaced without --overwrite.

Exit status: 0 when the verification ran to completion (the verdicts are in
the report); 1 with --strict unless every claim holds (undecided is not a
pass); 2 on bad input (case, spec, --out); 3 on a failure that is not the
input (solver, compiler).

examples:
  formsync verify liang2016
  formsync verify zhang2014_flyaround --format json
  formsync verify liang2016 --format json --strict
  formsync verify my_case.toml --out /tmp/verification
  formsync verify my_case.toml --spec my_design.py --out /tmp/variant --overwrite
"""


def add_parser(sub: Any) -> None:
    p = sub.add_parser("verify", help="verify a published design's parameters and claims",
                       description=_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("case", nargs="?", default=None,
                   help="case name or TOML file (default: the shipped case of --design, else "
                   "liang2016)")
    p.add_argument("--out", default="reports", help="output directory (default: reports)")
    p.add_argument("--design", "--spec", dest="spec", default=None, metavar="NAME|FILE",
                   help="the design: a shipped design's name or a design .py (default: the case "
                   "file's [case] spec, else liang2016; --spec is the old name)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing report of a different case in --out")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 unless every claim holds on every candidate topology "
                        "(undecided is not a pass)")
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


def _default_case(design_arg: Any) -> tuple[str, Any]:
    """``(case, design)`` of ``formsync verify`` without a case: the shipped case of
    ``--design`` (the case where it is the comparison design: that case, verified as it is),
    else liang2016 with the design; said on stderr."""
    if design_arg is None:
        return "liang2016", None
    from formsync_design.spec.loader import lagrangian_view, load_design
    from formsync_design.verify.defaults import Defaults, case_source

    design = load_design(design_arg)
    design = lagrangian_view(design) or design  # a design with a Lagrangian view: its case
    src = case_source(design)
    defaults = Defaults()
    if src is None:
        defaults.add(f"case liang2016 (no shipped case names design {design.name}), with "
                     f"design {design.name}")
        defaults.emit("verify")
        return "liang2016", design_arg
    if src.role == "comparison":
        defaults.add(f"case {src.label}, where design {design.name} is a comparison design "
                     "(verified there with the comparison's gains, beside the case's design)")
        defaults.emit("verify")
        return src.path.stem, None
    defaults.add(f"case {src.label} (the shipped case of design {design.name})")
    defaults.emit("verify")
    from formsync_design.resources import design_names

    # the shipped design the case names: the case's own (the report is the case's, unchanged)
    return src.path.stem, (None if str(design_arg) in design_names() else design_arg)


def run(args: argparse.Namespace) -> int:
    from formsync_design.progress import activity
    from formsync_design.tomlio import load_toml
    from formsync_design.verify.kinds import VerifyRequest, case_kind, verifier
    from formsync_design.verify.output import check_output, display_path

    # everything the user gave is checked before any computation (nothing is written yet)
    if args.case is None:
        args.case, args.spec = _default_case(args.spec)
    path = resolve_case(args.case)
    kind = case_kind(load_toml(path, "case TOML file"), display_path(path))
    from formsync_design.outdir import claim

    check_output(args.out, path.stem, display_path(path), overwrite=args.overwrite)
    # one writer per folder: a concurrent writer into --out is refused (exit 2); checked
    # again under the lock, so the report found above is still the one we may replace
    claim(args.out)
    check_output(args.out, path.stem, display_path(path), overwrite=args.overwrite)

    with activity(f"verify {path.stem}", enabled=args.format == "text") as bar:
        req = VerifyRequest(path=path, case_arg=args.case, out=args.out, design=args.spec,
                            overwrite=args.overwrite, strict=args.strict, format=args.format,
                            progress=bar.note)  # each stage after the elapsed time
        return verifier(kind)(req)
