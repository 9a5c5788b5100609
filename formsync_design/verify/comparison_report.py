"""Report, figures and JSON of an ``agent-comparison`` verification
(:mod:`formsync_design.verify.comparison`).

Figures follow the paper's: Euler angles of case 1 (Figs. 2-4) and case 2 (Figs. 7-9), the
torque of spacecraft 5 (Figs. 5, 10), ``Qa`` of the three methods (Fig. 6), ``R_23`` in case 2
(Fig. 11); plus the singularity monitors of case 2 and the Monte-Carlo times.  Every figure is
a :class:`matplotlib.figure.Figure` saved without timestamps (byte-reproducible).
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from formsync_design.gains import json_number
from formsync_design.outdir import write_text
from formsync_design.sim.figures import save_figure
from formsync_design.verify.theoremcheck import cycle_figure

__all__ = ["comparison_figures", "comparison_markdown", "comparison_json",
           "write_comparison_report"]

_ANG = ("pitch", "yaw", "roll")


def _euler_figure(run: Any, title: str) -> Figure:
    fig = Figure(figsize=(7.5, 7.0))
    axs = fig.subplots(3, 1, sharex=True)
    for k, ax in enumerate(axs):
        for i in range(run.angles.shape[1]):
            ax.plot(run.t, run.angles[:, i, k], lw=1.0, label=f"S/C{i + 1}")
        ax.set_ylabel(f"{_ANG[k]} (deg)")
        ax.grid(True, alpha=0.3)
    axs[0].set_title(title)
    axs[0].legend(ncol=5, fontsize=7)
    axs[-1].set_xlabel("t (s)")
    fig.tight_layout()
    return fig


def _torque_figure(run: Any, sc: int, title: str) -> Figure:
    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.subplots()
    for k in range(3):
        ax.plot(run.t, run.torques[:, sc - 1, k], lw=1.0, label=f"M_{k + 1}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(f"torque of S/C{sc} (N m)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig


def _qa_figure(runs: Any, thr: float) -> Figure:
    fig = Figure(figsize=(7.5, 4.0))
    ax = fig.subplots()
    for r in runs:
        ax.semilogy(r.t, np.maximum(r.qa, 1e-6), lw=1.2, label=r.label)
    ax.axhline(thr, color="k", lw=0.8, ls="--")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("Qa (deg)")
    ax.set_title("Fig. 6: attitude error Qa, case 1")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _r23_figure(run: Any) -> Figure:
    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.subplots()
    for i in range(run.r23.shape[1]):
        ax.plot(run.t, run.r23[:, i], lw=1.0, label=f"S/C{i + 1}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("R_23")
    ax.set_title("Fig. 11: element R_23 of each attitude, case 2")
    ax.grid(True, alpha=0.3)
    ax.legend(ncol=5, fontsize=7)
    fig.tight_layout()
    return fig


def _monitor_figure(run: Any) -> Figure:
    fig = Figure(figsize=(7.5, 5.0))
    axs = fig.subplots(2, 1, sharex=True)
    for name, ax, lab in (("det_E", axs[0], "det E(R_d^T R)"), ("cmd", axs[1], "command conditioning")):
        v = run.monitor_series.get(name)
        if v is None:
            continue
        for i in range(v.shape[1]):
            ax.plot(run.t, v[:, i], lw=1.0, label=f"S/C{i + 1}")
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3)
    axs[0].set_title("Where the law would be singular, case 2 (det E = 0: 90 or 180 deg)")
    axs[0].legend(ncol=5, fontsize=7)
    axs[1].set_xlabel("t (s)")
    fig.tight_layout()
    return fig


def _mc_figure(res: Any) -> Figure:
    mc = res.montecarlo
    fig = Figure(figsize=(7.5, 3.8))
    ax = fig.subplots()
    labels = [m.label for m in res.methods]
    for k, m in enumerate(res.methods):
        ts = np.array([np.nan if t is None else t for t in mc["times"][m.key]])
        ax.plot(np.full(ts.shape, k) + np.linspace(-0.2, 0.2, ts.size), ts, "o", ms=3)
    for m, k in zip(res.methods, range(len(labels))):
        if m.paper_time is not None:
            ax.plot([k - 0.3, k + 0.3], [m.paper_time] * 2, "k-", lw=2)
    ax.set_xticks(range(len(labels)), [lab.split(" (")[0] for lab in labels], fontsize=8)
    ax.set_ylabel("time to Qa <= 1 deg (s)")
    ax.set_title(f"Sensitivity: {mc['runs']} random initial conditions (bars: the paper's times)")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def comparison_figures(res: Any) -> dict[str, Figure]:
    """The report's figures by file stem."""
    sc = int(res.case.claims.get("torque_spacecraft", res.case.n))
    c1, c2 = res.case1[0], res.case2[0]
    return {
        "fig02-04_euler_case1": _euler_figure(c1, "Figs. 2-4: Euler angles, case 1 (SO(3) design)"),
        "fig05_torque_case1": _torque_figure(c1, sc, f"Fig. 5: control torque of S/C{sc}, case 1"),
        "fig06_qa": _qa_figure(res.case1, res.settings["threshold"]),
        "fig07-09_euler_case2": _euler_figure(c2, "Figs. 7-9: Euler angles, case 2 (SO(3) design)"),
        "fig10_torque_case2": _torque_figure(c2, sc, f"Fig. 10: control torque of S/C{sc}, case 2"),
        "fig11_r23_case2": _r23_figure(c2),
        "monitors_case2": _monitor_figure(c2),
        "montecarlo_times": _mc_figure(res),
        **({"theorem_cycles": fig} if res.theorem is not None
           and (fig := cycle_figure(res.theorem)) is not None else {}),
    }


def _t(t: Any) -> str:
    return "not reached" if t is None else f"{t:.2f}"


def _g(x: Any) -> str:
    return "-" if x is None else f"{x:.3g}"


def _summary_stats(ts: list[Any]) -> str:
    v = np.array([t for t in ts if t is not None], float)
    miss = sum(t is None for t in ts)
    if not v.size:
        return f"none reached ({miss} runs)"
    return (f"median {np.median(v):.2f}, min {v.min():.2f}, max {v.max():.2f}"
            + (f"; {miss} not reached" if miss else ""))


def comparison_markdown(res: Any, fig_dir: str, command: str) -> str:
    """The report text (figures referenced under ``fig_dir``)."""
    from formsync_design.verify.output import display_path, report_marker

    case = res.case
    L: list[str] = [report_marker(display_path(case.path))]
    L += [f"# {case.title}", "", f"Generated by `{command}` (case file `verification/"
          f"{Path(case.path).name}`, sha256 `{case.digest[:16]}`).", "",
          f"Source: {case.source}.", ""]
    L += ["## Claims", "", "| claim | paper | measured here | verdict | semantics |",
          "| --- | --- | --- | --- | --- |"]
    for c in res.claims:
        L.append(f"| {c.text} | {c.paper} | {c.measured} | **{c.verdict}** | {c.note} |")
    L += ["", "## Paper versus ours: time for Qa to reach 1 deg (case 1)", "",
          "| method | paper (s) | ours (s) | largest principal angle <= 1 deg (s) | peak torque "
          "(N m) | effort int |u|^2 dt | max &#124;R^T R - I&#124; |",
          "| --- | --- | --- | --- | --- | --- | --- |"]
    for m, r in zip(res.methods, res.case1):
        L.append(f"| {m.label} | {_g(m.paper_time)} | {_t(r.time_to_qa)} | {_t(r.time_to_angle)} "
                 f"| {r.peak_torque:.3g} | {r.effort:.4g} | {r.orthonormality:.1e} |")
    L += ["", "The initial conditions and inertias are reconstructions (the paper's tables were "
          "lost): the times are judged for their order and rough size, not tuned to the "
          "published ones.", ""] + _linear_note(res) + [""]
    L += [f"![Fig. 6]({fig_dir}/fig06_qa.png)", "",
          f"![Figs. 2-4]({fig_dir}/fig02-04_euler_case1.png)", "",
          f"![Fig. 5]({fig_dir}/fig05_torque_case1.png)", ""]
    mc = res.montecarlo
    L += ["## Sensitivity of the ordering (Monte-Carlo)", "",
          f"{mc['runs']} initial conditions (seed {mc['seed']}): each Euler angle uniform in "
          f"+-{mc['max_euler_deg']:g} deg, each rate component uniform in +-{mc['max_rate']:g} "
          f"rad/s, inertias of case 1, horizon {mc['tf']:g} s.", "",
          "| method | time to Qa <= 1 deg (s) |", "| --- | --- |"]
    for m in res.methods:
        L.append(f"| {m.label} | {_summary_stats(mc['times'][m.key])} |")
    L += ["", f"The paper's ordering (SO(3) < quaternion < MRP) holds in **{mc['ordered']} of "
          f"{mc['runs']}** runs.", "", f"![Monte-Carlo]({fig_dir}/montecarlo_times.png)", ""]
    L += ["## Case 2: large attitudes far apart", "",
          "| method | status | time to Qa <= 1 deg (s) | final disagreement (deg) | peak torque (N m) |",
          "| --- | --- | --- | --- | --- |"]
    for r in res.case2:
        L.append(f"| {r.label} | {r.status} | {_t(r.time_to_qa)} | {r.final_angle:.3g} | "
                 f"{r.peak_torque:.3g} |")
    L += ["", f"![Figs. 7-9]({fig_dir}/fig07-09_euler_case2.png)", "",
          f"![Fig. 10]({fig_dir}/fig10_torque_case2.png)", "",
          f"![Fig. 11]({fig_dir}/fig11_r23_case2.png)", "",
          f"![monitors]({fig_dir}/monitors_case2.png)", ""]
    L += ["## Side by side with Liang et al.'s controller and the PD baseline", "",
          "Case 1 on the paper's digraph (Liang et al.'s theorem needs an undirected graph: "
          "outside it here); the Lagrangian designs run in the classic simulator with their own "
          "gains (Liang: K_o 1.6, K_q 0.4, beta 0.3, K_v 0.01, sat switch; PD: k_p 0.4, k_d 1.6). "
          "Time to 1 deg = the largest pairwise principal angle stays <= 1 deg.", "",
          "| controller | status | time to 1 deg (s) | final angle (deg) | peak torque (N m) | "
          "effort int &#124;u&#124;^2 dt | note |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for row in res.baselines:
        L.append(_row(row))
    near = res.case.claims.get("near180", {})
    L += ["", f"Near 180 deg: spacecraft 2..{case.n} start {near.get('angle_deg', 175)} deg from "
          "spacecraft 1 (about x, y, z, x+y in turn), at rest.", "",
          "| controller | status | time to 1 deg (s) | final angle (deg) | peak torque (N m) | "
          "effort int &#124;u&#124;^2 dt | note |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for row in res.near180:
        L.append(_row(row))
    if res.equal_torque is not None:
        L += _equal_torque_section(res)
    if res.theorem is not None:
        L += ["", "## Theorem 1 checked on graph families (formation-level certificate)", ""]
        L += res.theorem.markdown()
        L += ["", f"![cycles]({fig_dir}/theorem_cycles.png)"]
    L += ["", "## Certificates of (K1, K2, P1, P2) on digraph families", "",
          "Scope: design-conditions. The families are the sliding-surface Lyapunov conditions "
          "derived below (the tracking loop of Theorem 1's first part, the command taken as "
          "given: graph-independent, never a formation verdict); the graph enters only through "
          "the theorem's class (a directed spanning tree), which the section above checks. A "
          "graph outside the class is refused: a finding, reported with the reason.", ""]
    for box, rows in res.certificates:
        L += [f"Box {_box(box)}:", "", "| graph | spanning tree | strongly connected | verdict | "
              "margin | multiplier | reason |", "| --- | --- | --- | --- | --- | --- | --- |"]
        for g in rows:
            mult = ", ".join(f"{k} = {v:g}" for k, v in (g.multipliers or {}).items()) or "-"
            L.append(f"| {g.graph} | {g.properties.get('spanning-tree')} | "
                     f"{g.properties.get('strongly-connected')} | **{g.status}** | {_g(g.margin)} "
                     f"| {mult} | {g.reason} |")
        L.append("")
    L += ["Simulated on each graph (case 1, the paper's gains):", "",
          "| graph | status | time to 1 deg (s) | final disagreement (deg) |", "| --- | --- | --- | --- |"]
    for g in res.graph_runs:
        L.append(f"| {g['graph']} | {g['status']} | {_t(g['time'])} | {g['final']:.3g} |")
    L += [""]
    L += _derivation(res)
    L += ["## Assumptions", ""] + [f"- {a}" for a in case.assumptions] + [""]
    L += ["## Reconstructed equations and their sources (the design files)", ""]
    for m in res.methods:
        doc = inspect.cleandoc(str(m.design.module.get("__doc__") or ""))
        L += [f"### `{m.design.name}`", "", "```text", doc, "```", ""]
    return "\n".join(L).rstrip() + "\n"


def _equal_torque_section(res: Any) -> list[str]:
    """The comparisons at literal gains beside the same at equal peak torque (computed)."""
    from formsync_design.analysis.equal_torque import in_order, ordering

    eq = res.equal_torque
    names = [m.design.name for m in res.methods]
    hold = ", ".join(eq["hold"]) or "none"
    L = ["", "## The comparisons at equal peak torque", "",
         "The comparisons above run every design at its literal gains, whose peak torques on "
         "case 1 differ (" + ", ".join(f"{n} {r.peak_torque:.3g} N m" for n, r in
                                       zip(names, res.case1)) + "). Here every gain of each "
         f"comparison design except {hold} is multiplied by one factor `c`, found by a 1-D "
         "search (bracketing, then bisection in `log c`: `formsync_design/verify/"
         "equal_torque.py`) so that its peak torque on case 1 equals the main design's "
         f"{eq['target']:.4g} N m within {eq['rtol']:g} (relative); every comparison is then "
         "rerun with the scaled gains (the main design's runs are the literal ones).", "",
         "| method | scale factor c | peak torque, case 1 (N m) | relative error | search runs | "
         "scaled gains |", "| --- | --- | --- | --- | --- | --- |"]
    for m in eq["methods"][1:]:
        sr = eq["searches"][m.key]
        gains = ", ".join(f"{k} {float(v[0] if isinstance(v, tuple) else v):.4g}"
                          for k, v in m.gains.as_dict().items())
        L.append(f"| {m.design.name} | {sr.scale:.4g} | {sr.peak:.4g} | {sr.relative_error:.1e} | "
                 f"{sr.evaluations} | {gains} |")
    lit_n = [r["time"] for r in res.near180[:len(names)]]
    eq_n = [r["time"] for r in eq["near180"]]
    rows = [("case 1: time to Qa <= 1 deg", [r.time_to_qa for r in res.case1],
             [r.time_to_qa for r in eq["case1"]]),
            ("case 2: time to Qa <= 1 deg", [r.time_to_qa for r in res.case2],
             [r.time_to_qa for r in eq["case2"]]),
            ("near 180 deg: time to 1 deg", lit_n, eq_n)]
    L += ["", "Which ordering holds (the paper's: " + " < ".join(names) + "):", "",
          "| comparison | literal gains | paper's order | equal peak torque | paper's order |",
          "| --- | --- | --- | --- | --- |"]
    for what, lit, eqt in rows:
        L.append(f"| {what} | {ordering(names, lit)} | {'holds' if in_order(lit) else 'fails'} | "
                 f"{ordering(names, eqt)} | {'holds' if in_order(eqt) else 'fails'} |")
    mc, emc = res.montecarlo, eq["montecarlo"]
    L.append(f"| Monte-Carlo ({mc['runs']} runs): time to Qa <= 1 deg | paper's order in "
             f"{mc['ordered']} of {mc['runs']} | {'holds' if mc['ordered'] == mc['runs'] else 'fails'}"
             f" | paper's order in {emc['ordered']} of {emc['runs']} | "
             f"{'holds' if emc['ordered'] == emc['runs'] else 'fails'} |")
    L += ["", "The scaled designs' runs (the peak torque is equal on case 1 only; on the other "
          "runs it is what the scaled gains give):", "",
          "| method | case 1: time to Qa (s) | effort int &#124;u&#124;^2 dt | case 2: time to Qa "
          "(s) | case 2 peak (N m) | near 180: time to 1 deg (s) | near 180 peak (N m) | "
          "Monte-Carlo time to Qa (s) |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for m, r1, r2, rn in zip(eq["methods"], eq["case1"], eq["case2"], eq["near180"]):
        L.append(f"| {m.design.name}{' (literal)' if m is eq['methods'][0] else ''} | "
                 f"{_t(r1.time_to_qa)} | {r1.effort:.4g} | {_t(r2.time_to_qa)} | "
                 f"{r2.peak_torque:.3g} | {_t(rn['time'])} | {rn['peak']:.3g} | "
                 f"{_summary_stats(emc['times'][m.key])} |")
    return L


def _linear_note(res: Any) -> list[str]:
    """Why the SO(3) times are what they are: the tracking loop linearised at consensus."""
    g = res.case.gains.as_dict()
    try:
        k1, k2, p1, eps = (float(np.mean(g[k])) for k in ("K1", "K2", "P1", "eps"))
    except KeyError:
        return []
    k1e = k1 + 1.5 * p1 / np.sqrt(eps)
    ev = np.linalg.eigvals(np.array([[-k1e, 1.0], [-1.0, -k2]]))
    slow = float(-np.max(ev.real))
    return [f"Near consensus (E ~ I, |e_R| < eps) the tracking loop of each spacecraft is "
            f"e_R' = s - (K1 + 3 P1 / (2 sqrt eps)) e_R, s' = -e_R - K2 s (the linear parts of "
            f"the derived V' families): eigenvalues {', '.join(f'{z:.3g}' for z in ev)}, a "
            f"slowest decay rate {slow:.3g} 1/s (time constant {1 / slow:.2f} s) per tracking "
            "stage, and the command itself moves with the neighbours: a formation starting "
            "100-200 deg apart in Qa needs several time constants per stage of the digraph."]


def _row(row: dict[str, Any]) -> str:
    return (f"| {row['label']} | {row['status']} | {_t(row['time'])} | {row['final']:.3g} | "
            f"{row['peak']:.3g} | {row['effort']:.4g} | {row['note']} |")


def _box(box: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in box.items())


def _derivation(res: Any) -> list[str]:
    der = res.derivation
    if der is None:
        return []
    sl = der["sliding"]
    L = ["## Derivation (SymPy, along the closed loop)", "",
         "The tracking loop (the command as a reference) is closed by the engine and "
         "differentiated by `time_derivative`; each identity is checked in exact arithmetic at "
         "seeded random rational points, rotations written exactly orthogonal "
         "(`formsync_design/derive/so3_sliding.py`).", "",
         "| identity | where | holds |", "| --- | --- | --- |"]
    for name, where, ok in sl.checks:
        L.append(f"| `{name}` | {where} | {ok} |")
    L += ["", "V' in the reduced symbols (x = e_R, s, b = beta(x), z = sig^{1/2}(s), per axis): "
          f"`{sl.vdot}`", "", "Families (positive definite on the whole gain box):", ""]
    for name, M, labels in sl.families:
        L.append(f"- `{name}` ({', '.join(labels)}): `{M.tolist()}`")
    de = der["det_E"]
    L += ["", f"`det E = (tr(Rt)^2 - 1)/8` for every rotation: {de['identity']}; with "
          f"`cos th = (tr Rt - 1)/2`, `det E = cos th (1 + cos th)/2`: {de['cos_form']}. "
          "So **E is singular at 90 deg as well as at 180 deg** (the paper names only 180 deg): "
          f"for Rt = Rz(90 deg), det E = {de['at_90']['det']} with kernel {de['at_90']['kernel']}; "
          f"for Rt = Rz(180 deg), det E = {de['at_180']['det']} with kernel "
          f"{de['at_180']['kernel']}. A virtual control with E^-1 is undefined on both sets; "
          "the reconstruction never inverts E.", "",
          "Properties of the second surface's power function beta (exact, per branch): "
          + "; ".join(f"{k}: {v}" for k, v in der["lemmas"].items()) + ".", ""]
    return L


def comparison_json(res: Any) -> dict[str, Any]:
    """The verification as a JSON document (numbers through :func:`json_number`)."""
    def num(x: Any) -> Any:
        return None if x is None else json_number(float(x))

    return {
        "case": res.case.name, "kind": "agent-comparison", "all_hold": res.all_hold,
        "claims": [{"key": c.key, "text": c.text, "paper": c.paper, "measured": c.measured,
                    "verdict": c.verdict, "note": c.note} for c in res.claims],
        "case1": [{"method": r.label, "time_to_qa": num(r.time_to_qa),
                   "time_to_angle": num(r.time_to_angle), "peak_torque": num(r.peak_torque),
                   "effort": num(r.effort), "orthonormality": num(r.orthonormality)}
                  for r in res.case1],
        "montecarlo": {"runs": res.montecarlo["runs"], "seed": res.montecarlo["seed"],
                       "ordered": res.montecarlo["ordered"],
                       "times": {k: [num(t) for t in v]
                                 for k, v in res.montecarlo["times"].items()}},
        "baselines": [{k: (num(v) if isinstance(v, float) else v) for k, v in row.items()}
                      for row in res.baselines],
        "near180": [{k: (num(v) if isinstance(v, float) else v) for k, v in row.items()}
                    for row in res.near180],
        "certificates": [{"box": {k: str(v) for k, v in box.items()},
                          "graphs": [g.to_dict() for g in rows]} for box, rows in res.certificates],
        "equal_torque": None if res.equal_torque is None else {
            "target_peak": num(res.equal_torque["target"]),
            "scales": {k: {"scale": num(e.scale), "peak": num(e.peak), "runs": e.evaluations}
                       for k, e in res.equal_torque["searches"].items()},
            "case1": [{"method": r.label, "time_to_qa": num(r.time_to_qa),
                       "peak_torque": num(r.peak_torque)} for r in res.equal_torque["case1"]],
            "case2": [{"method": r.label, "time_to_qa": num(r.time_to_qa)}
                      for r in res.equal_torque["case2"]],
            "near180": [{"method": r["label"], "time": num(r["time"])}
                        for r in res.equal_torque["near180"]],
            "montecarlo_ordered": res.equal_torque["montecarlo"]["ordered"]},
        "theorem": None if res.theorem is None else res.theorem.to_dict(),
    }


def write_comparison_report(res: Any, out: str, stem: str, command: str) -> tuple[Path, list[Path]]:
    """Write ``<out>/<stem>-verification.md`` and its figures under
    ``<out>/figures/<stem>-verification/``."""
    od = Path(out)
    fd = od / "figures" / f"{stem}-verification"
    fd.mkdir(parents=True, exist_ok=True)
    figs = []
    for name, fig in comparison_figures(res).items():
        figs.append(save_figure(fig, fd / f"{name}.png"))
    md = od / f"{stem}-verification.md"
    write_text(md, comparison_markdown(res, f"figures/{stem}-verification", command))
    return md, figs
