"""The report of an lv2012 verification (Markdown + figures + JSON), from computed outcomes.

Written by :func:`write_lv2012_report` to ``<out>/<case>-verification.md`` with the figures in
``<out>/figures/<case>-verification/``; every number and verdict comes from the
:class:`~formsync_design.verify.lv2012.CaseOutcome` objects of the run (numbers printed with a
few significant digits, so a rerun on the same machine is byte-identical).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.gains import json_number
from formsync_design.outdir import write_text

__all__ = ["write_lv2012_report", "outcome_json", "figures"]


def _f(x: Any, d: int = 4) -> str:
    if x is None:
        return "never"
    x = float(x)
    if not np.isfinite(x):
        return str(x)
    return f"{x:.{d}g}"


def _gains(g: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {_f(v)}" for k, v in g.items())


def figures(outcomes: list[Any]) -> dict[str, Any]:
    """Name -> matplotlib Figure (never shown; the caller saves them)."""
    from matplotlib.figure import Figure

    figs: dict[str, Any] = {}
    for o in outcomes:
        fig = Figure(figsize=(9, 6.5))
        ax1, ax2 = fig.subplots(2, 1, sharex=False)
        for key, style in (("nodist", "-"), ("of_perfect", "--")):
            r = o.runs[key]
            ax1.semilogy(r.t, np.maximum(r.attitude_error, 1e-8), style,
                         label=f"lv2012 {r.label}: disagreement")
            if r.reference_error is not None:
                ax1.semilogy(r.t, np.maximum(r.reference_error, 1e-8), style,
                             label=f"lv2012 {r.label}: error to q_r")
        ax1.set_ylabel("attitude (deg)")
        ax1.set_xlabel("t (s)")
        ax1.set_title(f"{o.name}: output feedback (no gyro)")
        ax1.legend(fontsize=7)
        for key in ("cmp_perfect", "cmp_noisy", "cmp_failed"):
            r = o.runs[key]
            ax2.semilogy(r.t, np.maximum(r.attitude_error, 1e-8), label=r.label)
        r = o.runs["of_failed"]
        ax2.semilogy(r.t[r.t <= o.runs["cmp_perfect"].t[-1]],
                     np.maximum(r.attitude_error, 1e-8)[r.t <= o.runs["cmp_perfect"].t[-1]], "k:",
                     label="lv2012, failed gyro (unchanged)")
        ax2.set_ylabel("disagreement (deg)")
        ax2.set_xlabel("t (s)")
        ax2.legend(fontsize=7)
        fig.tight_layout()
        figs[f"{o.name}-attitude"] = fig

        fig = Figure(figsize=(9, 3.5))
        ax = fig.subplots()
        for key in ("of_perfect", "cmp_perfect", "cmp_noisy", "cmp_failed"):
            r = o.runs[key]
            ax.semilogy(r.t, np.maximum(r.torque_norm, 1e-9), label=f"{r.design}: {r.label}")
        ax.axhline(o.torque_bound, color="k", ls=":", label="lv2012 certified torque bound")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("max_i |u_i| (N m)")
        ax.legend(fontsize=7)
        fig.tight_layout()
        figs[f"{o.name}-torque"] = fig

        fig = Figure(figsize=(7, 3.5))
        ax = fig.subplots()
        kinds = sorted({k for k, _ in o.l2})
        for i, k in enumerate(kinds):
            vals = [v for kk, v in o.l2 if kk == k]
            ax.plot([i] * len(vals), vals, "o", label=k)
        ax.axhline(float(o.gamma.gamma), color="r", label="certified gamma")
        ax.axhline(o.gamma.hinf, color="k", ls=":", label="numerical H-inf norm")
        ax.set_xticks(range(len(kinds)), kinds, fontsize=8)
        ax.set_ylabel("measured L2 gain (1/(N m))")
        ax.set_title(f"{o.name}: disturbance -> attitude errors")
        ax.legend(fontsize=7)
        fig.tight_layout()
        figs[f"{o.name}-l2"] = fig
    return figs


def _case_section(o: Any, figdir: str) -> list[str]:
    c = o.case
    L: list[str] = [f"## Case `{o.name}`: {c.title}", ""]
    L += [f"Case file `{Path(o.path).name}`, design `{c.design.name}`, graph `{c.graph().name}` "
          f"({c.n} spacecraft, pinning b = {[float(b) for b in c.graph().pinning]}), gains "
          f"{_gains(c.gains.as_dict())}.", "", "Assumptions (with their sources):", ""]
    L += [f"* {a}" for a in c.assumptions] + [""]
    L += ["### Claims", "", "| claim | source | verdict | evidence |", "| --- | --- | --- | --- |"]
    L += [f"| {x.text} | {x.source} | **{x.verdict}** | {x.evidence} |" for x in o.claims]
    if o.theorem is not None:
        L += ["", "### The theorem's graph class, checked on graph families", ""]
        L += o.theorem.markdown()
    L += ["", "### Derivation", ""]
    L += [f"* Nonlinear storage `V` (design docstring): `V' = sum_i (w_i.d_i - k_d |y_i|^2)` "
          f"checked symbolically for every in-degree {sorted(o.rate_free)}; its families "
          f"({', '.join(f.name for f in o.storage.families)}) on the design's gain ranges: "
          f"**{o.storage.status}**.",
          f"* The law's free symbols contain no body rate (own or neighbours'): "
          f"{all(o.rate_free.values())}; MEASURED = {list(o.measured)}.",
          f"* Lead filter, computed from the design's expressions: `y(s)/e(s) = {o.filter_tf}` "
          f"(each axis; the stated `a_f s/(s + a_f)`: {o.filter_ok}).",
          f"* Linearisation at the commanded attitude: {o.linearisation.nx} states "
          f"(`q`, `w`, filter), {o.linearisation.nw} disturbance inputs, descriptor form "
          f"`T xi' = F xi + G d` with `F` exact in the gains.", ""]
    g = o.gamma
    L += ["### Certified L2 gain", "",
          f"* At the case's gains: **gamma = {_f(g.gamma)}** ({g.status}, storage by "
          f"{g.method}, certified margin of `-M` {_f(g.margin, 3)}); numerical H-infinity norm "
          f"{_f(g.hinf, 6)} at {_f(g.peak_frequency, 3)} rad/s."]
    if o.gamma_sdp is not None:
        s = o.gamma_sdp
        L += [f"* The same by the SDP `min gamma^2` (cvxpy): **{_f(s.gamma)}** ({s.status})."]
    d = o.design
    L += [f"* Gain design within the torque budget {_f(d.budget)} N m ({d.evaluations} "
          f"evaluations): {_gains(d.gains)}, torque bound {_f(d.torque_bound)} N m, certified "
          f"**gamma = {_f(d.certificate.gamma)}** ({d.certificate.status}).",
          f"* Global torque bound of the case's gains: {_f(o.torque_bound)} N m "
          f"(largest simulated torque {_f(max(o.runs[k].peak_torque for k in o.runs if k.startswith(('of_', 'nodist'))))} N m)."]
    if o.box is not None:
        b = o.box
        L += [f"* Gain box {b.box.to_dict()}: gamma = {_f(b.gamma)} **{b.status}** "
              f"({len(b.certification)} storage(s) by the SDP over the vertices, exact "
              f"re-check; largest vertex norm {_f(b.hinf)})."]
    if o.refute is not None:
        r = o.refute
        w = r.witness
        extra = ""
        if w is not None:
            extra = (f": exact witness at {_gains(w.point)}, frequency {_f(w.omega, 6)} rad/s, "
                     f"`|z|^2 / |u|^2 = {_f(w.z_norm2 / w.u_norm2, 8)}` > gamma^2 = "
                     f"{_f(w.gamma ** 2, 8)} (exact rationals; gain {_f(w.gain)})")
        L += [f"* Same box, gamma = {_f(r.gamma)}: **{r.status}**{extra}."]
    L += ["", "### Simulations", "",
          f"Disturbance: {c.disturbance.get('model', 'none')} model; gyro models: perfect, bias "
          f"{_f(c.claims.get('gyro_bias', 0))} rad/s per axis + white noise "
          f"{_f(c.claims.get('gyro_noise', 0))} rad/s per sample at the step, failed (S/C"
          f"{c.claims['failed_gyro']} reads zero from t = {_f(c.claims.get('failed_at', 0))} s).",
          "Steady state = the last "
          f"{_f(100 * float(c.claims.get('tail_fraction', 0.2)))} % of each run.", "",
          "| run | design | converged at (s) | steady disagreement (deg) | steady error to q_r "
          "(deg) | steady rate disagreement (rad/s) | peak torque (N m) | effort (N^2 m^2 s) |",
          "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in o.runs.values():
        L.append(f"| {r.label} | {r.design} | {_f(r.convergence_time)} | {_f(r.tail_attitude_deg, 3)}"
                 f" | {_f(r.tail_reference_deg, 3) if r.tail_reference_deg is not None else '-'} | "
                 f"{_f(r.tail_rate, 3)} | {_f(r.peak_torque, 3)} | {_f(r.effort, 3)} |")
    L += ["", f"![attitude]({figdir}/{o.name}-attitude.png)", "",
          f"![torque]({figdir}/{o.name}-torque.png)", "",
          "### Measured L2 gains", "",
          f"From the commanded attitude at rest, {len(o.l2)} disturbance signals of RMS "
          f"{_f(c.claims.get('l2_rms', 1e-3))} N m per axis over "
          f"{_f(c.claims.get('l2_tf', 400))} s (seed {c.claims.get('l2_seed', 0)}):", "",
          "| signal | runs | smallest | largest | certified gamma |", "| --- | --- | --- | --- | --- |"]
    for k in sorted({k for k, _ in o.l2}):
        v = [x for kk, x in o.l2 if kk == k]
        L.append(f"| {k} | {len(v)} | {_f(min(v))} | {_f(max(v))} | {_f(o.gamma.gamma)} |")
    L += ["", f"![l2]({figdir}/{o.name}-l2.png)", ""]
    if o.scope is not None:
        L += _scope_section(o.scope)
    return L


def _scope_section(sc: Any) -> list[str]:
    """The large-angle runs (:mod:`formsync_design.verify.large_angle`) and their verdict."""
    L = ["### Scope: global or local?", "",
         "The certified L2 gain and exponential stability are of the linearisation at the "
         "commanded attitude: their scope is **local**.  The nonlinear storage gives convergence "
         "to *an* equilibrium from every state (LaSalle), not to the command.  Seeded runs without "
         "disturbance, from rest, every spacecraft rotated by the initial angle about its own "
         "random axis, with either sign of `q0(0)` (the law reads `vec(q_r^* q_i)`, so `q` and "
         f"`-q` differ), over {_f(sc.tf)} s (`formsync_design/verify/large_angle.py`):", "",
         "| seed | initial angle (deg) | sign of q0(0) | converged | at (s) | final error to q_r "
         "(deg) | final disagreement (deg) |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in sc.runs:
        L.append(f"| {r.seed} | {r.angle_deg:g} | {'+' if r.q0_sign > 0 else '-'} | "
                 f"{'yes' if r.converged else 'no'} | {_f(r.convergence_time)} | "
                 f"{_f(r.final_error_deg, 3)} | {_f(r.final_disagreement_deg, 3)} |")
    L += ["", f"Verdict (computed from these runs): **{sc.summary}**; the certificates' scope: "
          "local (the linearisation at the commanded attitude).", ""]
    return L


def write_lv2012_report(outcomes: list[Any], out: str | Path, stem: str, case_display: str,
                        command: str) -> tuple[Path, list[Path]]:
    """Write the report and its figures; returns ``(markdown path, figure paths)``."""
    from formsync_design.sim.figures import save_figure
    from formsync_design.verify.output import report_marker, report_paths

    md, figdir = report_paths(out, stem)
    figdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fig in figures(outcomes).items():
        paths.append(save_figure(fig, figdir / f"{name}.png"))
    rel = f"figures/{figdir.name}"
    L = [report_marker(case_display), "",
         "# Output feedback without rate gyros (Lv, Hu, Ma, Zhang 2012): verification", "",
         f"Generated by `{command}` (regenerate every report: "
         "`python verification/regenerate_reports.py`).", "",
         "Lv et al. (Aircraft Eng. Aerosp. Technol. 84(5), 2012) coordinate a formation's attitude "
         "without angular-velocity measurement: a lead filter synthesises a virtual rate, a "
         "Lyapunov argument gives asymptotic stability without disturbance and an L2-gain "
         "condition ultimate boundedness with it.  Only the abstract, introduction and model "
         "survived the extraction; the design judged here is the reconstruction of "
         "`derivations/lv2012.py` (sources in its docstring and in each case's assumptions):", "",
         "    u_i = -k_p (b_i e_i + sum_j a_ij vec(q_j^* q_i)) - k_d E(q_ei)^T y_i,",
         "    x_i' = a_f (e_i - x_i),   y_i = a_f (e_i - x_i)   (y = a_f s/(s + a_f) e),", "",
         "with `(e_i, eta_i) = q_r^* q_i` and `E(q_e)^T = (eta I - e^)/2`.", "",
         "**What the certificates cover.** The nonlinear storage `V` (kinetic energy, quaternion "
         "potentials `2 k_p (1 - eta)` to the command and along the edges, filter energy) has "
         "`V' = sum w.d - k_d |y|^2` along the full nonlinear loop, for every positive gain on "
         "an undirected graph: without disturbance every trajectory converges to an equilibrium "
         "(LaSalle; the commanded attitude at rest is one, the quaternion double cover and "
         "other critical points of the potential are others).  The L2 gain `gamma` from the "
         "disturbance torques to the attitude errors `z = (e_1..e_N)` and the exponential "
         "stability are certified on the **linearisation at the commanded attitude** (a "
         "quadratic storage, exact re-check); the nonlinear loop's gain tends to it as the "
         "disturbance goes to zero.  Simulations measure the nonlinear loop against it; they "
         "are comparisons, not certificates.", ""]
    L += ["## Summary", "", "| case | claim | verdict |", "| --- | --- | --- |"]
    for o in outcomes:
        L += [f"| {o.name} | {c.text} | **{c.verdict}** |" for c in o.claims]
    L.append("")
    for o in outcomes:
        L += _case_section(o, rel)
    text = "\n".join(L).rstrip() + "\n"
    write_text(md, text)
    return md, paths


def outcome_json(outcomes: list[Any]) -> str:
    """The verification as one JSON document (numbers by :func:`json_number`)."""
    doc = []
    for o in outcomes:
        doc.append({
            "case": o.name,
            "claims": [{"key": c.key, "text": c.text, "verdict": c.verdict,
                        "evidence": c.evidence} for c in o.claims],
            "gamma": o.gamma.to_dict(),
            "gamma_sdp": None if o.gamma_sdp is None else o.gamma_sdp.to_dict(),
            "design": o.design.to_dict(),
            "box": None if o.box is None else o.box.to_dict(),
            "refute": None if o.refute is None else o.refute.to_dict(),
            "torque_bound": json_number(o.torque_bound),
            "measured_l2": [{"signal": k, "gain": json_number(v)} for k, v in o.l2],
            "scope": None if o.scope is None else o.scope.to_dict(),
            "theorem": None if o.theorem is None else o.theorem.to_dict(),
            "runs": {k: {"label": r.label, "design": r.design, "status": r.status,
                         "convergence_time": None if r.convergence_time is None
                         else json_number(r.convergence_time),
                         "tail_attitude_deg": json_number(r.tail_attitude_deg),
                         "tail_reference_deg": None if r.tail_reference_deg is None
                         else json_number(r.tail_reference_deg),
                         "peak_torque": json_number(r.peak_torque)}
                     for k, r in o.runs.items()},
        })
    return json.dumps(doc, indent=2)
