"""The verifier of the classic formation case kind (``[case] kind = "formation"``).

Re-derives and certifies the case's design, simulates every candidate topology, judges
the claims (:func:`~formsync_design.verify.verification.verify_case`), and writes the
verification report with the derivation report it links to.
"""

from __future__ import annotations

import sys

from formsync_design.verify.kinds import VerifyRequest

__all__ = ["verify_formation_case"]


def verify_formation_case(req: VerifyRequest) -> int:
    """Run ``formsync verify`` on a formation case (exit status: module docstring of
    :mod:`formsync_design.verify.kinds`)."""
    from formsync_design.derive.report import write_derivation_report
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.case import load_case
    from formsync_design.verify.output import display_path
    from formsync_design.verify.report import write_verification_report
    from formsync_design.verify.verification import verification_json, verify_case

    path = req.path
    case_display = display_path(path)
    case = load_case(path)
    spec_arg = req.design if req.design is not None else case.spec
    spec = load_spec(spec_arg) if spec_arg is not None else None
    if spec is not None and spec.decl.kind != "formation":
        from formsync_design.errors import InputError

        raise InputError(f"expected a formation design for the formation case {case_display}, "
                         f"received {spec.name} (a {spec.decl.kind} design)")

    res = verify_case(path, spec=spec, progress=req.progress)
    req.progress("write reports")
    g0 = res.topologies[0].graph
    spec_opt = f" --spec {res.spec_source}" if spec is not None else ""
    out_opt = f" --out {req.out}" if req.out != "reports" else ""
    write_derivation_report(
        g0, req.out, spec=spec,
        command="formsync derive" + (f" --graph {g0}" if g0 != "ring:8" else "") + spec_opt + out_opt,
    )
    cmd = req.command(spec_opt if req.design is not None else "")
    md, figs = write_verification_report(res, req.out, command=cmd)
    if req.format == "json":
        sys.stdout.write(verification_json(res) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        for c in res.claims:
            sys.stdout.write(f"  {c.verdict:28s} {c.spec.text}\n")
    if req.strict and not res.all_hold:
        return 1
    return 0
