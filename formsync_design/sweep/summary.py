"""Summary of a sweep: figures and ``summary.md``, written from the rows only."""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.sweep.schema import CLASSIC_SCHEMA, SweepSchema
from formsync_design.sweep.store import atomic_write

__all__ = ["plot_fraction", "plot_convergence", "write_summary"]


def _figure(figsize: tuple[float, float]) -> Any:
    """A figure without pyplot: no backend is selected or changed (it renders inline in a
    notebook and saves to PNG anywhere)."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize)


def plot_fraction(rows: Sequence[dict[str, str]], x: str) -> Any:
    """Certified volume fraction of each box against column ``x`` (one marker per
    graph; colour = status of the reference gains).  Returns the figure.

    >>> fig = plot_fraction([{"box": "b", "lambda_max": "4", "frac_certified": "0.5",
    ...                       "ref_status": "certified"}], "lambda_max")
    >>> len(fig.axes)
    1
    """
    boxes = list(dict.fromkeys(r["box"] for r in rows))
    fig = _figure((5.2 * max(len(boxes), 1), 4.0))
    axs = fig.subplots(1, max(len(boxes), 1), squeeze=False)
    colors = {"certified": "tab:green", "refuted": "tab:red", "undecided": "tab:orange",
              "error": "black"}
    label = {"lambda_max": r"$\lambda_{\max}(L)$", "degree_max": "maximum degree",
             "lambda_2": r"$\lambda_2(L)$"}.get(x, x)
    for ax, b in zip(axs[0], boxes):
        sub = [r for r in rows if r["box"] == b]
        for st, col in colors.items():
            pts = [(float(r[x]), float(r["frac_certified"])) for r in sub if r["ref_status"] == st]
            if pts:
                xs, ys = zip(*pts)
                ax.scatter(xs, ys, s=22, c=col, alpha=0.6, edgecolors="none",
                           label=f"reference gains {st} ({len(pts)})")
        ax.set_xlabel(label)
        ax.set_ylabel("certified fraction of the box")
        ax.set_title(f"box {b}")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def plot_convergence(rows: Sequence[dict[str, str]]) -> Any:
    """Median (marker) and maximum (bar top) Monte-Carlo convergence time against
    ``lambda_2``.  Returns the figure."""
    fig = _figure((5.6, 4.0))
    ax = fig.subplots()
    pts = [r for r in rows if r["mc_status"] == "ran" and r["mc_conv_time_median"] != ""]
    for b in dict.fromkeys(r["box"] for r in pts):
        sub = [r for r in pts if r["box"] == b]
        x = [float(r["lambda_2"]) for r in sub]
        med = [float(r["mc_conv_time_median"]) for r in sub]
        mx = [float(r["mc_conv_time_max"]) for r in sub]
        ax.vlines(x, med, mx, colors="0.6", linewidth=0.8)
        ax.scatter(x, med, s=20, label=f"{b}: median (line to max)")
    ax.set_xlabel(r"$\lambda_2(L)$")
    ax.set_ylabel("convergence time (s)")
    ax.grid(True, alpha=0.3)
    if pts:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _save(fig: Any, path: Path) -> None:
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    atomic_write(path, buf.getvalue())


def _table(header: Sequence[str], body: Sequence[Sequence[Any]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return out


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


def _design_line(manifest: dict[str, Any]) -> str | None:
    """The design of the campaign, unless it is the shipped liang2016 (the default)."""
    from formsync_design.spec.loader import load_spec

    sp = manifest["spec"]
    if sp["name"] == "liang2016" and sp["sha256"] == load_spec(None).key:
        return None
    return f"- design: `{sp['name']}` (sha256 `{sp['sha256'][:16]}`)"


def _span(vals: Sequence[str]) -> str:
    xs = sorted(float(v) for v in vals if v != "")
    if not xs:
        return "-"
    return f"{xs[0]:g}" if xs[0] == xs[-1] else f"{xs[0]:g} .. {xs[-1]:g}"


def write_summary(
    out: str | Path, rows: Sequence[dict[str, str]], manifest: dict[str, Any], *, command: str = "",
    schema: SweepSchema = CLASSIC_SCHEMA, compared: Any = None,
) -> list[Path]:
    """Write ``summary.md`` and the figures from the rows (columns of ``schema``, the
    design's gain names) and, with ``compared`` (:class:`~.compare.Compared`), a
    comparison with another sweep's reference statuses; returns the paths."""
    d = Path(out)
    camp = manifest["campaign"]
    paths = []
    fig = plot_fraction(rows, "lambda_max")
    p = d / "fraction-vs-lambda-max.png"
    _save(fig, p)
    paths.append(p)
    fig = plot_fraction(rows, "degree_max")
    p = d / "fraction-vs-max-degree.png"
    _save(fig, p)
    paths.append(p)
    has_mc = any(r["mc_status"] == "ran" for r in rows)
    if has_mc:
        p = d / "convergence-vs-lambda2.png"
        _save(plot_convergence(rows), p)
        paths.append(p)
    ref = camp["reference"]
    L: list[str] = []
    L.append(f"# Sweep `{camp['name']}`" + (f": {camp['title']}" if camp["title"] else ""))
    L.append("")
    L.append("Generated by `formsync sweep` (formsync_design/sweep/summary.py); do not edit by hand.")
    if command:
        L.append(f"Regenerate with `{command}`.")
    L.append("")
    L.append(f"- campaign sha256: `{manifest['sha256']}`")
    dl = _design_line(manifest)
    if dl:
        L.append(dl)
    for c in manifest.get("design_code", []):
        L.append(f"- design code that is not shipped, run on the user's trust: `{c['path']}` "
                 f"(sha256 `{c['sha256']}`)")
    L.append(f"- graph sets: {', '.join('`' + g + '`' for g in camp['graphs'])} "
             f"({len(manifest['graphs'])} graphs, {len(rows)} tasks)")
    if manifest["skipped"]:
        L.append(f"- skipped (listed, not analysed): {', '.join(manifest['skipped'])}")
    if schema.agent:
        L.append(f"- conditions: the agent design's conditions(c) families (each > {camp['margin']})")
        outside = [r["graph"] for r in rows if r["box_index"] == "0" and r["theorem"] != "inside"]
        L.append(f"- graphs outside the design's theorem (column `theorem`; their statuses decide "
                 f"the families only): {', '.join(outside) if outside else 'none'}")
    else:
        L.append(f"- conditions: {camp['conditions']} Lyapunov conditions (Theta_i > "
                 f"{camp['margin']}, Pi > {camp['margin']})")
    L.append("- reference gains: " + ", ".join(f"{g} = {float(Fraction(ref[g])):g}" for g in schema.box))
    for b in camp["boxes"]:
        L.append(f"- box `{b['name']}`: " + " x ".join(
            f"{g} in [{float(Fraction(b[g][0])):g}, {float(Fraction(b[g][1])):g}]" for g in schema.box))
    design = (f"grid of {max(2, camp['design']['betas'])} values per controller gain (as formsync "
              "design --grid)" if schema.agent else
              f"{camp['design']['betas']} {schema.swept} values, penalty {camp['design']['penalty']:g}")
    L.append(f"- region resolution R = {camp['region']['resolution']} per axis; design: {design}")
    if schema.multipliers:
        from formsync_design.certify.multipliers import GRID_POINTS

        L.append("- multipliers of the Lyapunov candidate, searched by every certificate: "
                 + ", ".join(f"{m} ({GRID_POINTS} geometric grid values over its declared range)"
                             for m in schema.multipliers))
    if camp["montecarlo"]:
        m = camp["montecarlo"]
        if m.get("agent"):
            sim = ", ".join(f"{k} = {m[k]:g} s" for k in ("tf", "step", "output_step")
                            if m[k] is not None)
            case = f"case {m['case']}" if m["case"] else "the design's shipped case"
            L.append(f"- Monte-Carlo ({case}, spacecraft data cycled over "
                     f"each graph's spacecraft): {m['runs']} runs per graph at the {m['gains']} "
                     f"gains, seed {m['seed']}, " + (sim + ", the case's other" if sim else
                                                     "the case's")
                     + f" simulation options, initial angle <= {m['max_angle_deg']:g} deg, "
                     f"rates <= {m['max_rate']:g} rad/s")
        else:
            L.append(f"- Monte-Carlo: {m['runs']} runs per graph at the {m['gains']} gains, seed "
                     f"{m['seed']}, tf = {m['tf']:g} s, step {m['step']:g} s, initial angle <= "
                     f"{m['max_angle_deg']:g} deg, rates <= {m['max_rate']:g} rad/s")
    L.append("")
    L.append("Certified / refuted statuses are proofs (rigorous re-check of every vertex of a "
             "multi-affine family); spectral values are floating point and only position the "
             "points in the figures.")
    if schema.multipliers:
        names = ", ".join(schema.multipliers)
        L.append("")
        L.append(f"A box is certified when one value of the multipliers ({names}) makes every "
                 "family positive definite on the whole box; that value is the evidence (columns "
                 + ", ".join(f"`ref_cert_{m}`, `rec_cert_{m}`" for m in schema.multipliers)
                 + "). A value that fails refutes that Lyapunov candidate only, so such boxes are "
                 "undecided, never refuted.")
    L.append("")
    # reference gains by N
    L.append("## Reference gains by formation size")
    L.append("")
    first_box = [r for r in rows if r["box_index"] == "0"]
    ns = sorted({int(r["n"]) for r in first_box})
    body = []
    for n in ns:
        sub = [r for r in first_box if int(r["n"]) == n]
        cnt = {s: sum(r["ref_status"] == s for r in sub) for s in ("certified", "refuted", "undecided", "error")}
        by: dict[str, int] = {}
        for r in sub:
            if r["ref_refuted_by"]:
                fam = (r["ref_refuted_by"] if schema.agent else
                       "Pi" if r["ref_refuted_by"].startswith("Pi") else "Theta_i")
                by[fam] = by.get(fam, 0) + 1
        body.append([n, len(sub), cnt["certified"], cnt["refuted"], cnt["undecided"], cnt["error"],
                     ", ".join(f"{k}: {v}" for k, v in sorted(by.items())) or "-",
                     *[_span([r[f"ref_cert_{m}"] for r in sub]) for m in schema.multipliers]])
    L += _table(["N", "graphs", "certified", "refuted", "undecided", "error", "refuted by",
                 *[f"{m} certifying" for m in schema.multipliers]], body)
    L.append("")
    if compared is not None:
        from formsync_design.sweep.compare import comparison_lines

        L += comparison_lines(rows, manifest, compared)
    # certified fraction by box and max degree
    for bi, b in enumerate(camp["boxes"]):
        sub = [r for r in rows if r["box_index"] == str(bi)]
        L.append(f"## Box `{b['name']}`: certified fraction by maximum degree")
        L.append("")
        body = []
        for dm in sorted({int(r["degree_max"]) for r in sub}):
            s2 = [r for r in sub if int(r["degree_max"]) == dm]
            fr = [float(r["frac_certified"]) for r in s2]
            lm = [float(r["lambda_max"]) for r in s2]
            des = sum(r["design_status"] == "designed" for r in s2)
            body.append([dm, len(s2), f"{min(lm):.4g} .. {max(lm):.4g}", _pct(min(fr)),
                         _pct(sum(fr) / len(fr)), _pct(max(fr)), f"{des}/{len(s2)}"])
        L += _table(["max degree", "graphs", "lambda_max range", "certified min", "mean", "max",
                     "designed"], body)
        L.append("")
    if has_mc:
        L.append("## Monte-Carlo")
        L.append("")
        mc = [r for r in rows if r["mc_status"] == "ran"]
        runs = sum(int(r["mc_runs"]) for r in mc)
        conv = sum(int(r["mc_converged"]) for r in mc)
        L.append(f"{conv} of {runs} runs converged over {len(mc)} tasks; "
                 f"{sum(r['mc_status'].startswith('skipped') for r in rows)} tasks skipped.")
        bad = [r for r in mc if int(r["mc_converged"]) < int(r["mc_runs"])]
        if bad and schema.agent:
            L.append("")
            L += _table(["task", "ref status", "runs", "converged", "not converged", "stopped",
                         "failed seeds"],
                        [[r["task"], r["ref_status"], r["mc_runs"], r["mc_converged"],
                          r["mc_not_converged"], r["mc_stopped"], r["mc_failed_seeds"]]
                         for r in bad])
            L.append("")
            L.append("not converged: attitude or rate disagreement (or the error to the "
                     "reference) above angle_tol / rate_tol at tf; stopped: the hybrid integrator "
                     "stopped (Zeno protection or too many triggers).")
        elif bad:
            L.append("")
            L += _table(["task", "ref status", "runs", "converged", "not converged", "singular",
                         "diverged", "inaccurate", "failed seeds"],
                        [[r["task"], r["ref_status"], r["mc_runs"], r["mc_converged"],
                          r["mc_not_converged"], r["mc_singular"], r["mc_diverged"],
                          r["mc_inaccurate"], r["mc_failed_seeds"]] for r in bad])
            L.append("")
            L.append("not converged: Q_m or Omega_m above tolerance at tf; singular: some q0 reached "
                     "q0_floor; diverged: NaN/inf; inaccurate: quaternion norm drift above 1e-5 "
                     "(integrator step too coarse for the run).")
        L.append("")
    L.append("## Figures")
    L.append("")
    L.append("![certified fraction vs lambda_max](fraction-vs-lambda-max.png)")
    L.append("")
    L.append("![certified fraction vs maximum degree](fraction-vs-max-degree.png)")
    if has_mc:
        L.append("")
        L.append("![convergence time vs lambda_2](convergence-vs-lambda2.png)")
    L.append("")
    L.append("## results.csv columns")
    L.append("")
    doc = schema.doc
    L += _table(["column", "meaning"], [[c, doc[c]] for c in schema.columns])
    L.append("")
    p = d / "summary.md"
    atomic_write(p, ("\n".join(L)).encode("utf-8"))
    paths.append(p)
    return paths
