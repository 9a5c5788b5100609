"""``formsync verify``: verify a published design's parameters and claims."""

from __future__ import annotations

import argparse
from typing import Any

from formsync_design.cli.options import add_format_option, add_trust_option

__all__ = ["add_parser", "run"]

_HELP = """\
Verify a published design on its case: the case file declares the formations
(graphs and spacecraft), the scenarios and variants, the Monte-Carlo draws,
the comparison designs, the metrics (named measurements from one registry:
convergence time, errors, torque, effort, fuel, transmissions, measured L2
gain, certified margins and bounds, ...) and the published claims as
predicates over them.  Every metric is computed (simulations are evidence,
certificates are proof), every claim is judged holds, fails or undecided
(when neither the simulated horizon nor the certificate decides it), and one
report is written.  Case format and semantics: docs/engine.md and
formsync_design/verify/enginecase.py.

CASE is a shipped case's name (liang2016 = verification/liang2016.toml) or a
case TOML file ([case] kind = "engine").  --design replaces the case file's
[case] design (a shipped design's name or a design .py file; a Lagrangian
design file runs in its agent form, its own Theta_i/Pi conditions certified).
A design file the case names (a .py path beside it, [case] or [[scenarios]]
design) is code: it runs only with --trust-design FILE, and the run names it
and its sha256 (stderr, JSON key design_code, the report).

Writes <out>/<CASE file stem>-verification.md, its figures under
<out>/figures/<CASE file stem>-verification/, and the derivation report it
links to.  --out is checked before any work; an existing report of a
different case is not replaced without --overwrite.

Exit status: 0 when the verification ran to completion (the verdicts are in
the report); 1 with --strict unless every claim holds (undecided is not a
pass); 2 on bad input (case, design, --out); 3 on a failure that is not the
input (solver, compiler).

examples:
  formsync verify liang2016
  formsync verify zhang2014_flyaround --format json
  formsync verify liang2016 --format json --strict
  formsync verify my_case.toml --out /tmp/verification
  formsync verify my_case.toml --design my_design.py --out /tmp/variant --overwrite
  formsync verify my_case.toml --trust-design my_design.py
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
                   "file's [case] design; --spec is the old name)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing report of a different case in --out")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 unless every claim holds (undecided is not a pass)")
    add_format_option(p)
    add_trust_option(p)
    p.set_defaults(func=run)


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
    from formsync_design.verify.dispatch import resolve_case
    from formsync_design.verify.engine import verify_engine_case
    from formsync_design.verify.output import check_output, display_path
    from formsync_design.verify.request import VerifyRequest

    # everything the user gave is checked before any computation (nothing is written yet)
    if args.case is None:
        args.case, args.spec = _default_case(args.spec)
    path = resolve_case(args.case)
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
        return verify_engine_case(req)
