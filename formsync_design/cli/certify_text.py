"""The text ``formsync certify`` prints: a
:class:`~formsync_design.certify.results.CertificationResult` (statuses, lower bounds, the exact
witness) and a :class:`~formsync_design.analysis.requirements.RequirementResult`."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

__all__ = ["format_result", "format_requirement_result"]


def _num(x: Any) -> str:
    if x is None:
        return "-"
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(_num(v) for v in x) + "]"
    if isinstance(x, str):
        return x
    return f"{float(x):.6g}"


def format_requirement_result(res: Any) -> str:
    """Human-readable report of a :class:`~formsync_design.analysis.requirements.RequirementResult`.

    >>> from formsync_design.analysis.requirements import Requirements, certify_requirements
    >>> r = certify_requirements("star:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}, "spectral", Requirements())
    >>> print(format_requirement_result(r).splitlines()[0])
    CERTIFIED: star:8 (N=8), spectral certificate, K_o=1.6, K_q=0.4, beta=0.3
    """
    b = res.base
    box = ", ".join(f"{r.name}={float(r.lo):g}" if r.is_point else
                    f"{r.name} in [{float(r.lo):g}, {float(r.hi):g}]" for r in b.box)
    lines = [f"{str(res.status).upper()}: {b.graph} (N={b.n}), {b.certificate} certificate, {box}",
             f"  {b.certificate} certificate: {b.status}; {b.reason}"]
    if b.witness:
        w = b.witness
        lines.append("  witness: " + "; ".join(f"{k} = {_num(v) if not isinstance(v, dict) else _wd(v)}"
                                               for k, v in w.items()))
    for c in res.checks:
        lines.append(f"  {c.name}: {c.status} (required {_num(c.required)}, certified {_num(c.value)}); "
                     f"{c.reason}")
    if b.spectrum_method:
        lines.append(f"  Laplacian spectrum: {b.spectrum_method}")
    return "\n".join(lines)


def _wd(d: dict) -> str:
    return "{" + ", ".join(f"{k}={_num(v) if not isinstance(v, dict) else _wd(v)}" for k, v in d.items()) + "}"


def _g(q: Fraction | None) -> str:
    """``q`` to 6 significant digits, also beyond the float range (exact witnesses).

    >>> _g(Fraction(10**400, 3)), _g(None), _g(Fraction(1, 3))
    ('3.33333e+399', '-', '0.333333')
    """
    if q is None:
        return "-"
    try:
        return f"{float(q):.6g}"
    except OverflowError:
        from decimal import Context, Decimal

        ctx = Context(prec=12, Emax=10**9, Emin=-(10**9))
        return f"{ctx.divide(Decimal(q.numerator), Decimal(q.denominator)):.6g}"


def format_result(res: Any) -> str:
    """Human-readable report of a :class:`~formsync_design.certify.results.CertificationResult`."""
    lines = []
    box = ", ".join(
        f"{r.name}={float(r.lo):g}" if r.is_point else f"{r.name} in [{float(r.lo):g}, {float(r.hi):g}]"
        for r in res.box
    )
    lines.append(f"{str(res.status).upper()}: {res.graph} (N={res.n}), {res.source} conditions, {box}")
    if res.margin:
        lines.append(f"  required: lambda_min > {float(res.margin):g}")
    if res.reason:
        lines.append(f"  reason: {res.reason}")
    mlb = res.margin_lower_bound  # None unless certified
    if res.certified and mlb is not None:
        lines.append(f"  certified margin: min over box of lambda_min >= {float(mlb):.6g}")
    lines.append("  matrix                           size  status      lower bound   min-vertex hint")
    for f in res.families:
        lines.append(
            f"  {f.name[:32]:<32} {f.size:>4}  {str(f.status):<10}  {_g(f.lower):>12}  {f.hint:>14.6g}"
        )
    w = res.witness
    if w is not None:
        pt = ", ".join(f"{k}={float(v):g}" for k, v in w.point.items())
        sc = f", spacecraft {w.spacecraft}" if w.spacecraft is not None else ""
        lines.append(f"  witness: {w.family}{sc} at {pt}")
        nz = [(lab, v) for lab, v in zip(w.rows, [v for v in w.x if v != 0])]
        long = any(len(str(abs(v))) > 16 for _, v in nz)
        shown = ", ".join(f"{lab}: {_g(Fraction(v)) if long else v}" for lab, v in nz[:8]) + (
            " ..." if len(nz) > 8 else "")
        lines.append(f"    x (integer, nonzero entries{', rounded here; exact in --format json' if long else ''})"
                     f" = {shown}")
        lines.append(
            f"    x^T (M - {float(res.margin):g} I) x = {_g(w.value)} <= 0 (exact rational); "
            f"x^T M x / x^T x = {_g(w.rayleigh)}"
        )
        if w.covers_box:
            lines.append("    the same x refutes every gain in the box")
    if res.kv is not None:
        kv = res.kv
        lines.append(
            f"  K_v check ({'holds' if kv.holds else 'FAILS'}): required K_vi >= "
            f"{max(kv.required):.6g} (max over spacecraft), given {float(min(kv.kv)):g}"
            + (f"; failing spacecraft {list(kv.failing)}" if kv.failing else "")
            + (f"; {kv.note}" if kv.note else "")
        )
    s = res.solver
    it = "" if s.iterations is None else f", {s.iterations} iterations"
    lines.append(f"  solver: {s.solver} {s.raw_status} -> {s.outcome} ({s.solve_time * 1e3:.1f} ms{it})"
                 + (f"; {s.note}" if s.note else ""))
    lines.append("  re-check: " + ", ".join(f"{k} x{v}" for k, v in res.recheck.items()))
    lines.append(f"  argument: {res.argument}")
    return "\n".join(lines)
