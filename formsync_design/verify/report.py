"""The verification report: Markdown, the paper-style figures and the sensitivity figures.

Figures are built on :class:`matplotlib.figure.Figure` (no pyplot state, no
backend change), so this module is safe to call from a notebook.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from matplotlib.figure import Figure

from formsync_design.outdir import write_text
from formsync_design.verify.claims import (
    EVENT_QUANTITIES,
    QUANTITIES,
    STEADY_QUANTITIES,
    ClaimSpec,
    Measurement,
    Outcome,
    Verdict,
)
from formsync_design.verify.output import report_marker, report_paths
from formsync_design.verify.results import UNLIMITED, SensitivityRow

if TYPE_CHECKING:
    from formsync_design.verify.results import VerificationResult

__all__ = ["write_verification_report", "format_measurement", "sensitivity_figure"]

_MARK = {Verdict.HOLDS: "✓", Verdict.FAILS: "✗", Verdict.UNDECIDED: "?"}


def _num(v: float, unit: str = "") -> str:
    """Three significant digits; times (s) to 0.1 s up to 9999 s."""
    return (f"{v:.4g}" if unit == "s" else f"{v:.3g}") + (f" {unit}" if unit else "")


def _limit(v: float | None) -> str:
    return UNLIMITED if v is None else f"{v:g} N m"


def format_measurement(m: Measurement, spec: ClaimSpec) -> str:
    """A measurement as a report cell.

    >>> c = ClaimSpec("k", "t", "p", "convergence_time", "<=", 150.0, "s")
    >>> format_measurement(Measurement(Outcome.NOT_REACHED, horizon=200.0), c)
    'not within 200 s'
    >>> format_measurement(Measurement.of(57.7), c)
    '57.7 s'
    """
    if m.outcome is Outcome.SINGULAR:
        return "stopped at q0 → 0"
    if m.outcome is Outcome.DIVERGED:
        return "diverged"
    if m.outcome is Outcome.NEVER:
        return "never"
    if m.outcome is Outcome.UNDECIDED:
        return "undecided"
    if m.outcome is Outcome.NOT_REACHED:
        h = m.horizon if m.horizon is not None else math.nan
        if spec.quantity in STEADY_QUANTITIES:
            return f"no steady state within {h:g} s"
        if spec.quantity in EVENT_QUANTITIES:
            return f"still on at {h:g} s"
        return f"not within {h:g} s"
    assert m.value is not None
    return _num(m.value, spec.unit)


def _settings_text(text: str, res: VerificationResult) -> str:
    """Replace ``{saturation_torque_limit}`` / ``{limit}`` by the value with its unit."""
    lim = _limit(res.saturation_torque_limit)
    return text.replace("{saturation_torque_limit}", lim).replace("{limit}", lim)


def _cell(v: float | None, unit: str = "", none: str = "never") -> str:
    return none if v is None else _num(v, unit)


def sensitivity_figure(rows: list[SensitivityRow], parameter: str) -> Figure:
    """The sensitivity figure of one swept parameter; singular runs are marked, not left empty.

    >>> r = SensitivityRow("torque_limit", 5.0, "singular", "q0 -> 0", *([None] * 7))
    >>> fig = sensitivity_figure([r], "torque_limit")
    >>> [t.get_text() for t in fig.axes[0].texts]
    ['singular (q0 → 0)']
    """
    fig = Figure(figsize=(9, 3.4))
    ax = fig.subplots(1, 2)
    sing_kw: dict[str, Any] = {"color": "tab:red", "ha": "center", "va": "bottom", "fontsize": 7,
                               "rotation": 90}
    if parameter == "boundary_layer":
        ok = [r for r in rows if not r.singular]
        xs = [r.value for r in ok]
        ax[0].loglog(xs, [r.tail_q_m for r in ok], "o-", label="tail Q_m")
        ax[0].loglog(xs, [r.tail_omega_m for r in ok], "s-", label="tail Omega_m (rad/s)")
        ax[0].loglog(xs, [r.final_abs_rate for r in ok], "^-", label="final |omega_i| (rad/s)")
        ax[0].set_xlabel("boundary layer phi")
        ax[0].set_title("steady-state accuracy")
        ax[1].semilogx(xs, [r.chatter_end_time if r.chatter_end_time is not None else 0.0 for r in ok],
                       "o-")
        ax[1].set_xlabel("boundary layer phi")
        ax[1].set_ylabel("chattering ends (s; 0 = never)")
        ax[1].set_title("chattering")
        for r in rows:
            if r.singular:
                for a in ax:
                    a.axvline(r.value, color="tab:red", ls=":")
                    a.text(r.value, 0.02, "singular (q0 → 0)", transform=a.get_xaxis_transform(),
                           **sing_kw)
        ax[0].legend(fontsize=7)
    else:
        labels = [UNLIMITED if r.value is None else f"{r.value:g}" for r in rows]
        pos = list(range(len(rows)))
        conv = [r.convergence_time if r.convergence_time is not None else 0.0 for r in rows]
        sat = [r.saturation_end_time if r.saturation_end_time is not None else 0.0 for r in rows]
        ax[0].bar(pos, conv)
        ax[0].set_ylabel("convergence time (s)")
        ax[1].bar(pos, sat)
        ax[1].set_ylabel("saturation ends (s)")
        for a, ylab in ((ax[0], "conv"), (ax[1], "sat")):
            a.set_xticks(pos, labels)
            a.set_xlabel("torque limit (N m)")
            for p, r in zip(pos, rows, strict=True):
                if r.singular:
                    a.text(p, 0.02, "singular (q0 → 0)", transform=a.get_xaxis_transform(), **sing_kw)
                elif ylab == "conv" and r.convergence_time is None:
                    a.text(p, 0.02, "not converged", transform=a.get_xaxis_transform(), **sing_kw)
                elif ylab == "sat" and r.value is None:
                    a.text(p, 0.02, "n/a", transform=a.get_xaxis_transform(),
                           **{**sing_kw, "color": "0.4"})
                elif ylab == "sat" and r.saturation_end_time is None:
                    a.text(p, 0.02, "never saturates", transform=a.get_xaxis_transform(),
                           **{**sing_kw, "color": "0.4"})
    fig.tight_layout()
    return fig


def _observations(res: VerificationResult) -> list[str]:
    """Plain-language trends read off the sensitivity rows (no numbers typed in)."""
    out = []
    bl = [r for r in res.sensitivity if r.parameter == "boundary_layer" and not r.singular]
    if len(bl) >= 2:
        a, b = bl[0], bl[-1]
        out.append(
            f"Widening the boundary layer from {a.value:g} to {b.value:g} changes the steady-state "
            f"relative attitude Q_m from {_cell(a.tail_q_m)} to {_cell(b.tail_q_m)}, the relative rate "
            f"Omega_m from {_cell(a.tail_omega_m)} to {_cell(b.tail_omega_m)} rad/s and the absolute "
            f"rate left at the end from {_cell(a.final_abs_rate)} to {_cell(b.final_abs_rate)} rad/s "
            "(inside the boundary layer the switching term no longer cancels the disturbance, "
            "so the formation keeps a common drift); chattering ends at "
            f"{_cell(a.chatter_end_time, 's')} and {_cell(b.chatter_end_time, 's')} respectively."
        )
    tl = [r for r in res.sensitivity if r.parameter == "torque_limit"]
    ok = [r for r in tl if not r.singular and r.value is not None]
    if ok:
        lo = min(ok, key=lambda r: r.value if r.value is not None else math.inf)
        out.append(f"The smallest swept torque limit with which the case completes is "
                   f"{_limit(lo.value)} (convergence: "
                   f"{_cell(lo.convergence_time, 's', 'not within the horizon')}).")
    for r in tl:
        if r.singular:
            out.append(f"Torque limit {_limit(r.value)}: {r.message}.")
    return out


def write_verification_report(
    res: VerificationResult, out_dir: str | Path = "reports",
    command: str = "formsync verify liang2016",
) -> tuple[Path, tuple[Path, ...]]:
    """Write ``<case file stem>-verification.md`` and its figures under ``out_dir``.

    Call :func:`formsync_design.verify.output.check_output` first when the
    folder may hold a report of another case (the CLI does).

    Returns
    -------
    (Path, tuple of Path)
        The Markdown file and the figures.
    """
    from formsync_design.sim.figures import all_figures, save_figure

    out = Path(out_dir)
    md, figdir = report_paths(out, res.report_name)
    figdir.mkdir(parents=True, exist_ok=True)
    figs: list[Path] = []
    if res.default_sim is not None:
        for name, fig in all_figures(res.default_sim).items():
            figs.append(save_figure(fig, figdir / f"{name}.png"))
    for param in ("boundary_layer", "torque_limit"):
        rows = [r for r in res.sensitivity if r.parameter == param]
        if rows:
            figs.append(save_figure(sensitivity_figure(rows, param), figdir / f"sensitivity-{param}.png"))

    L: list[str] = []
    w = L.append
    w(report_marker(res.case_path))
    w(f"# Verification of {res.case_name}: parameters and claims")
    w("")
    w(f"Regenerate with `{command}`. Case file: `{res.case_path}`. Specification: "
      f"`{res.spec_source}` ({res.spec_name}). The verification re-derives the conditions, "
      + ("certifies the published gains with the derived and with the printed conditions, "
         if any(t.paper_status != "n/a" for t in res.topologies) else
         "certifies the published gains with the derived conditions, ")
      + "simulates the nonlinear formation on every candidate topology, and judges each "
      "published claim.")
    w("")
    w("## Assumptions")
    w("")
    for a in res.assumptions:
        w(f"- {a}")
    w(f"- the saturation claim is judged with a per-axis torque limit of "
      f"{_limit(res.saturation_torque_limit)}: the paper shows saturation but does not print its "
      "limit (see the sensitivity study for other limits)")
    extended = res.max_tf > res.tf
    w(f"- horizon {res.tf:g} s"
      + (f"; a run that has not reached its steady state by then is simulated again with the "
         f"horizon doubled, up to {res.max_tf:g} s" if extended else "")
      + "; what the horizon cannot decide is reported as undecided, never as failed")
    w("")
    w("## Candidate topologies")
    w("")
    w(res.topology_note)
    w("")
    w("| graph | λ_max(L) | max degree | certified (derived conditions) | margin | "
      "certified (printed conditions) | simulation | horizon | convergence time |")
    w("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for t in res.topologies:
        ct = t.sim["convergence_time"]
        conv = _num(ct, "s") if ct is not None else (
            "stopped at q0 → 0" if t.sim["status"] == "singular" else
            "diverged" if t.sim["status"] == "diverged" else f"not within {t.horizon:g} s")
        margin = "n/a" if t.derived_margin is None else _num(t.derived_margin)
        w(f"| `{t.graph}` | {t.lambda_max:.4g} | {t.max_degree} | {t.derived_status} | "
          f"{margin} | {t.paper_status} | {t.sim['status']} | {t.horizon:g} s | {conv} |")
    w("")
    w("## Claims")
    w("")
    w("Each claim is judged per topology (✓ holds, ✗ fails, ? undecided). "
      "A run stopped at the q0 → 0 singularity fails every claim judged on it; an event that "
      "never happens satisfies an upper bound on its end time; a time beyond the horizon decides "
      "a claim only when the bound lies within the horizon, else the claim is undecided; steady-state "
      "quantities are measured only once the run has converged before its steady-state tail; an "
      "undecided certificate leaves its claim undecided "
      "(rules: `formsync_design/verify/claims.py`).")
    w("")
    heads = " | ".join(f"`{t.graph}`" for t in res.topologies)
    w(f"| claim | paper | criterion | {heads} | verdict |")
    w("| --- | --- | --- | " + " | ".join("---" for _ in res.topologies) + " | --- |")
    for c in res.claims:
        s = c.spec
        cells = " | ".join(
            f"{format_measurement(c.measured[t.graph], s)} {_MARK[c.verdicts[t.graph]]}"
            for t in res.topologies)
        w(f"| {s.text} | {s.paper} | `{s.criterion}` | {cells} | **{c.verdict}** |")
    w("")
    w("Reasons and readings:")
    w("")
    for c in res.claims:
        note = _settings_text(c.spec.note, res)
        w(f"- **{c.spec.key}** ({c.verdict}: {c.reason}). {note} "
          f"Quantity: {_settings_text(QUANTITIES[c.spec.quantity][0], res)}.")
    w("")
    if res.kv_used:
        w("## Disturbance bound and K_vi")
        w("")
        w("| spacecraft | ū_d (N m) | K_vi* derived | K_vi used |")
        w("| --- | --- | --- | --- |")
        for i, (u, kr, k) in enumerate(zip(res.ubar, res.kv_required, res.kv_used, strict=True),
                                       start=1):
            w(f"| {i} | {u:.4g} | {kr:.4g} | {k:g} |")
        w("")
    else:
        w("## Disturbance bound")
        w("")
        if any(u > 0 for u in res.ubar):
            w("The design has no switching term, so no K_vi condition applies; the disturbance "
              "bound per spacecraft is " + ", ".join(f"{u:.4g}" for u in res.ubar) + " N m (the "
              "formation is at best ultimately bounded under it).")
        else:
            w("The case has no disturbance and the design no switching term: no K_vi condition "
              "applies.")
        w("")
    if res.derivation_verdicts:
        w("## Derivation verdicts")
        w("")
        w(f"From the derivation report [`{res.derivation_report}`]({res.derivation_report}) "
          "(paper versus derivation):")
        w("")
        for key, verdict, meaning in res.derivation_verdicts:
            w(f"- `{key}` ({meaning}): **{verdict}**")
        w("")
    w(f"## Figures (default topology `{res.topologies[0].graph}`, mirroring the paper's Figs. 3-6)")
    w("")
    for p in figs:
        w(f"![{p.stem}]({p.relative_to(out).as_posix()})")
        w("")
    w("## Sensitivity study")
    w("")
    if any(r.parameter == "boundary_layer" for r in res.sensitivity):
        w("The paper notes that widening the saturation function's boundary layer removes "
          "chattering but lowers accuracy, and that the control saturates at the start; it does "
          f"not quantify either. On the default topology, horizon {res.tf:g} s (n/a: not "
          "applicable):")
    else:
        w(f"Torque limits on the default topology, horizon {res.tf:g} s (n/a: not applicable):")
    w("")
    w("| parameter | value | status | convergence time | tail Q_m | tail Ω_m (rad/s) | "
      "final abs. rate (rad/s) | chattering ends | reversals in tail | saturation ends |")
    w("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in res.sensitivity:
        val = f"{r.value:g}" if r.value is not None else UNLIMITED
        val += " N m" if r.parameter == "torque_limit" and r.value is not None else ""
        name = r.parameter.replace("_", " ")
        if r.singular:
            w(f"| {name} | {val} | stopped at q0 → 0 | n/a | n/a | n/a | n/a | n/a | n/a | n/a |")
            continue
        sat = ("n/a" if r.parameter != "torque_limit" or r.value is None
               else _cell(r.saturation_end_time, "s"))
        w(f"| {name} | {val} | {r.status} | "
          f"{_cell(r.convergence_time, 's', f'not within {res.tf:g} s')} | {_cell(r.tail_q_m)} | "
          f"{_cell(r.tail_omega_m)} | {_cell(r.final_abs_rate)} | {_cell(r.chatter_end_time, 's')} | "
          f"{r.chatter_reversals_tail} | {sat} |")
    w("")
    for line in _observations(res):
        w(f"- {line}")
    w("")
    write_text(md, "\n".join(L) + "\n")  # atomically: an interrupted run keeps the old report
    return md, tuple(figs)
