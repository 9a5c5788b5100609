"""Figures and the region report of the admissible-region maps.

Plot functions return figures and never choose a matplotlib backend (a
notebook shows them inline); :func:`write_region` saves them as
byte-reproducible PNGs; :func:`region_report` writes
``reports/liang2016-region.md``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.certify.region import closed_form_agreement, region_map
from formsync_design.certify.subdivision import RegionMap, map_to_dict, rasterize
from formsync_design.errors import InputError
from formsync_design.outdir import save_figure as save_atomic_figure, write_text

__all__ = ["plot_slices", "plot_3d", "write_region", "region_report"]


# ---------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------
_COLORS = {1: "#4daf4a", -1: "#e41a1c", 0: "#ffbf00"}
_LABEL = {"K_o": r"$K_o$", "K_q": r"$K_q$", "beta": r"$\beta$"}


def _cmap() -> Any:
    from matplotlib.colors import ListedColormap

    return ListedColormap([_COLORS[-1], _COLORS[0], _COLORS[1]])


def _slice(m: RegionMap, axes: tuple[int, int], fixed_axis: int, value: float) -> np.ndarray:
    ras = rasterize(m)
    lo, hi = (float(v) for v in m.ranges[fixed_axis])
    r = max(m.resolution[fixed_axis], 1)
    if not lo <= value <= hi:
        raise InputError(
            f"expected a slice value of {m.gains[fixed_axis]} in [{lo:g}, {hi:g}], received {value:g}"
        )
    c = 0 if hi == lo else min(int((value - lo) / (hi - lo) * r), r - 1)
    sl = np.take(ras, c, axis=fixed_axis)
    # sl has the remaining axes in increasing order; transpose to (axes[1], axes[0]) for imshow
    rem = [a for a in range(3) if a != fixed_axis]
    if rem != list(axes):
        sl = sl.T
    return sl.T  # rows = axes[1], cols = axes[0]


def plot_slices(
    maps: Sequence[RegionMap],
    *,
    axes: tuple[str, str] = ("K_o", "K_q"),
    fixed: str = "beta",
    values: Sequence[float] = (),
    overlay: Sequence[RegionMap] | None = None,
    conditions: Sequence[Any] | None = None,
) -> Any:
    """Slices of one or more maps (rows: maps/graphs; columns: slice values).

    ``overlay`` (same length as ``maps``): a second map (e.g. the paper's
    printed conditions) whose certified region is outlined in black.
    ``conditions``: the maps' conditions, to draw the closed-form boundaries
    (dashed) from :func:`~formsync_design.derive.closed_form.closed_form_conditions`.
    Returns the figure (never shown).
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    if not maps:
        raise InputError("expected at least one region map, received none")
    g = maps[0].gains
    ax_i = (g.index(axes[0]), g.index(axes[1]))
    fa = g.index(fixed)
    vals = list(values) or [float(sum(maps[0].ranges[fa])) / 2]
    nr, nc = len(maps), len(vals)
    fig, axs = plt.subplots(nr, nc, figsize=(3.6 * nc + 0.6, 3.2 * nr + 0.6), squeeze=False)
    for r, m in enumerate(maps):
        ex = [float(m.ranges[ax_i[0]][0]), float(m.ranges[ax_i[0]][1]),
              float(m.ranges[ax_i[1]][0]), float(m.ranges[ax_i[1]][1])]
        for c, v in enumerate(vals):
            ax = axs[r][c]
            img = _slice(m, ax_i, fa, v)
            ax.imshow(img, origin="lower", extent=ex, aspect="auto", cmap=_cmap(), vmin=-1, vmax=1,
                      interpolation="nearest")
            if overlay is not None and overlay[r] is not None:
                o = overlay[r]
                oi = _slice(o, ax_i, fa, v)
                xs = np.linspace(ex[0], ex[1], oi.shape[1])
                ys = np.linspace(ex[2], ex[3], oi.shape[0])
                if (oi == 1).any() and (oi != 1).any():
                    ax.contour(xs, ys, (oi == 1).astype(float), levels=[0.5], colors="k",
                               linewidths=1.2)
            if conditions is not None and conditions[r] is not None:
                _draw_closed_forms(ax, conditions[r], g, ax_i, fa, v, ex)
            ax.set_xlabel(_LABEL.get(g[ax_i[0]], g[ax_i[0]]))
            ax.set_ylabel(_LABEL.get(g[ax_i[1]], g[ax_i[1]]))
            ax.set_title(f"{m.graph} ({m.source}), {_LABEL.get(g[fa], g[fa])}={v:g}", fontsize=9)
    handles = [Patch(color=_COLORS[1], label="certified"), Patch(color=_COLORS[-1], label="refuted"),
               Patch(color=_COLORS[0], label="undecided (boundary)")]
    if overlay is not None:
        handles.append(Patch(facecolor="none", edgecolor="k", label="paper's printed: certified"))
    if conditions is not None:
        handles.append(Patch(facecolor="none", edgecolor="b", linestyle="--",
                             label="closed-form boundary"))
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def _draw_closed_forms(ax: Any, conds: Any, g: tuple[str, ...], ax_i: tuple[int, int], fa: int,
                       v: float, ex: list[float]) -> None:
    import sympy as sp

    from formsync_design.derive.closed_form import closed_form_conditions
    from formsync_design.spec.loader import gain_symbols

    syms = gain_symbols()
    xs = np.linspace(ex[0], ex[1], 200)
    ys = np.linspace(ex[2], ex[3], 200)
    X, Y = np.meshgrid(xs, ys)
    args: list[Any] = [None, None, None]
    args[ax_i[0]], args[ax_i[1]], args[fa] = X, Y, np.full_like(X, v)
    for c in closed_form_conditions(conds):
        f = sp.lambdify(syms, c.substituted(), "numpy")
        Z = np.broadcast_to(np.asarray(f(*args), dtype=float), X.shape)
        if Z.min() < 0 < Z.max():
            ax.contour(X, Y, Z, levels=[0.0], colors="b", linestyles="--", linewidths=1.0)


def plot_3d(maps: Sequence[RegionMap], *, max_voxels: int = 20) -> Any:
    """3-D view: the certified region of each map as voxels (downsampled so that
    a voxel is shown only if all its cells are certified).  Returns the figure."""
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(4.2 * len(maps), 4.2))
    for k, m in enumerate(maps):
        ax = fig.add_subplot(1, len(maps), k + 1, projection="3d")
        ras = rasterize(m)
        f = [max(1, int(np.ceil(s / max_voxels))) for s in ras.shape]
        sh = [s // ff for s, ff in zip(ras.shape, f)]
        r = ras[: sh[0] * f[0], : sh[1] * f[1], : sh[2] * f[2]]
        r = r.reshape(sh[0], f[0], sh[1], f[1], sh[2], f[2])
        cert = (r == 1).all(axis=(1, 3, 5))
        edges = [np.linspace(float(m.ranges[a][0]), float(m.ranges[a][1]), sh[a] + 1) for a in range(3)]
        X, Y, Z = np.meshgrid(*edges, indexing="ij")
        ax.voxels(X, Y, Z, cert, facecolors=_COLORS[1] + "99", edgecolor="#2d6a2b", linewidth=0.2)
        ax.set_xlim(edges[0][0], edges[0][-1])
        ax.set_ylim(edges[1][0], edges[1][-1])
        ax.set_zlim(edges[2][0], edges[2][-1])
        ax.set_xlabel(_LABEL.get(m.gains[0], m.gains[0]))
        ax.set_ylabel(_LABEL.get(m.gains[1], m.gains[1]))
        ax.set_zlabel(_LABEL.get(m.gains[2], m.gains[2]))
        ax.set_title(f"{m.graph} ({m.source}): certified", fontsize=9)
        ax.view_init(elev=22, azim=-60)
    fig.tight_layout()
    return fig


def _save(fig: Any, path: Path) -> None:
    import matplotlib.pyplot as plt

    save_atomic_figure(fig, path, dpi=110, metadata={"Software": None})
    plt.close(fig)


def write_region(
    out: str | Path,
    maps: Sequence[RegionMap],
    *,
    overlay: Sequence[RegionMap] | None = None,
    conditions: Sequence[Any] | None = None,
    beta_values: Sequence[float] = (),
    kq_values: Sequence[float] = (),
    stem: str = "region",
    timing: bool = True,
    boxes: bool = True,
) -> list[Path]:
    """Write ``<stem>.json`` and the figures (PNG, byte-reproducible) to ``out``.

    Returns the written paths.
    """
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    paths = []
    doc = {"maps": [map_to_dict(m, timing=timing, boxes=boxes) for m in maps]}
    if overlay is not None:
        doc["overlay"] = [map_to_dict(m, timing=timing, boxes=boxes) for m in overlay if m is not None]
    p = d / f"{stem}.json"
    write_text(p, json.dumps(doc, indent=1, allow_nan=False) + "\n")
    paths.append(p)
    m0 = maps[0]
    gi = m0.gains
    if all(r > 0 for r in m0.resolution):
        bvals = list(beta_values) or _default_values(m0, gi.index("beta"))
        kvals = list(kq_values) or _default_values(m0, gi.index("K_q"))
        fig = plot_slices(maps, axes=("K_o", "K_q"), fixed="beta", values=bvals,
                          overlay=overlay, conditions=conditions)
        p = d / f"{stem}-ko-kq.png"
        _save(fig, p)
        paths.append(p)
        fig = plot_slices(maps, axes=("beta", "K_o"), fixed="K_q", values=kvals,
                          overlay=overlay, conditions=conditions)
        p = d / f"{stem}-beta-ko.png"
        _save(fig, p)
        paths.append(p)
        fig = plot_3d(maps)
        p = d / f"{stem}-3d.png"
        _save(fig, p)
        paths.append(p)
    return paths


def _default_values(m: RegionMap, axis: int) -> list[float]:
    lo, hi = (float(v) for v in m.ranges[axis])
    return [lo + (hi - lo) * f for f in (0.1, 0.3, 0.6)]


# ---------------------------------------------------------------------------
# the report
# ---------------------------------------------------------------------------
def region_report(
    root: str | Path = ".",
    *,
    graphs: Sequence[str] = ("ring:8", "star:8", "complete:8"),
    ranges: Any = None,
    resolution: int = 32,
    point: Any = None,
) -> Path:
    """Write ``reports/liang2016-region.md`` and ``reports/figures/liang2016-region-*``.

    Region maps (derived and printed conditions) for ``graphs`` over
    ``ranges`` (default ``K_o, K_q in [0.05, 5]``, ``beta in [0.01, 1]``),
    agreement with the closed-form conditions, the certificate of the paper's
    gains (``point``, default ``K_o=1.6, K_q=0.4, beta=0.3``) and a gain
    design.  Deterministic: running it twice gives identical files.
    """
    import sympy as sp

    from formsync_design.certify.design import design_gains
    from formsync_design.certify.engine import certify_box
    from formsync_design.derive.closed_form import closed_form_conditions
    from formsync_design.derive.conditions import derive_conditions, paper_conditions

    root = Path(root)
    rep = root / "reports"
    fig_dir = rep / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    rng = ranges or {"K_o": ("0.05", "5"), "K_q": ("0.05", "5"), "beta": ("0.01", "1")}
    pt = point or {"K_o": "1.6", "K_q": "0.4", "beta": "0.3"}
    derived = [derive_conditions(g) for g in graphs]
    printed = [paper_conditions(g) for g in graphs]
    dmaps = [region_map(c, rng, resolution=resolution) for c in derived]
    pmaps = [region_map(c, rng, resolution=resolution) for c in printed]
    paths = write_region(fig_dir, dmaps, overlay=pmaps, conditions=derived,
                         beta_values=(0.1, 0.3, 0.6), kq_values=(0.4, 1.0, 3.0),
                         stem="liang2016-region", timing=False, boxes=False)
    # JSON stays next to the figures; the markdown references relative paths
    lines: list[str] = []
    w = lines.append
    w("# Liang et al. 2016: certified gain regions")
    w("")
    w("Generated by `verification/region_report.py` (`formsync_design.certify.plots.region_report`); "
      "do not edit by hand.")
    w("")
    w("## Why finitely many computations certify a whole box")
    w("")
    w("Every `Theta_i` and `Pi` produced by the derivation is a symmetric matrix "
      "`F(p) = sum_k c_k p^{e_k} G_k` whose monomials have degree at most one in each of "
      "`K_o`, `K_q`, `beta` (checked: `MatrixFamily.is_multiaffine`). For fixed `x`, "
      "`x^T F(p) x` is affine in each gain separately, so its minimum over a box is attained "
      "at a vertex, and `min_box lambda_min(F) = min_vertices lambda_min(F(v))`. A box is "
      "certified when every distinct diagonal block is shown PD at each of its 8 vertices "
      "in exact rational `LDL^T` or by a floating-point Cholesky with a rigorous a-posteriori "
      "bound (Higham Thm 10.3: `lambda_min >= sigma - gamma_{n+1} ||R||_F^2 - assembly error`); "
      "`Pi`'s `qdot` block `a(p) I + b(p) M` is handled through a rigorous enclosure of the "
      "spectrum of `M` (the Laplacian, or the adjacency matrix for the printed `M`). A box is "
      "refuted only when one integer vector `x` gives `x^T F(v) x <= 0` in exact rationals at "
      "every vertex, hence (same multi-affinity) at every point of the box. The re-check starts "
      "from LAPACK's eigenvalues at the vertices; only when that leaves a block undecided does "
      "`formsync certify` solve `max t s.t. F_b(v) >= t I` with cvxpy + Clarabel for a candidate "
      "margin, which is then re-checked the same way (the solver's levels are a hint, never a "
      "verdict). The maps below use the re-check alone.")
    w("")
    w("## Closed-form conditions (from `derive.closed_form_conditions`)")
    w("")
    w("Each expression must be `> 0`:")
    w("")
    w("| graph | conditions | matrix | expression | constants | how |")
    w("|---|---|---|---|---|---|")
    for conds_list, label in ((derived, "derived"), (printed, "paper")):
        for g, c in zip(graphs, conds_list):
            for cf in closed_form_conditions(c):
                consts = ", ".join(f"{k} = {v:g}" for k, v in cf.constants.items())
                w(f"| {g} | {label} | {cf.family} | `{sp.sstr(cf.expression)}` | {consts} | {cf.how} |")
    w("")
    w(f"## Region maps (resolution {resolution} per axis)")
    w("")
    w("Ranges: " + ", ".join(f"`{k}` in [{float(Fraction(v[0])):g}, {float(Fraction(v[1])):g}]"
                             for k, v in rng.items()) + ".")
    w("")
    w("| graph | conditions | certified | refuted | undecided (boundary) | boxes | vertices | "
      "closed-form checks | disagreements |")
    w("|---|---|---|---|---|---|---|---|---|")
    for m, c in list(zip(dmaps, derived)) + list(zip(pmaps, printed)):
        ag = closed_form_agreement(m, c)
        f = m.fractions
        w(f"| {m.graph} | {m.source} | {f['certified']:.4f} | {f['refuted']:.4f} | "
          f"{f['undecided']:.4f} | {len(m.boxes)} | {m.vertices_evaluated} | {ag['checked']} | "
          f"{ag['disagree']} |")
    w("")
    w("Volume fractions of the gain box. A disagreement would be a certified box with a point "
      "violating a closed-form condition, or a refuted box with a point satisfying all of them.")
    w("")
    for p in paths[1:]:
        w(f"![{p.stem}](figures/{p.name})")
        w("")
    w("Fill: derived conditions (green certified, red refuted, amber boundary boxes). Black "
      "outline: certified region of the paper's printed `Theta_i`, `M`, `N`. Dashed blue: "
      "closed-form boundaries of the derived conditions.")
    w("")
    w("## Where the paper's printed conditions and the derivation disagree")
    w("")
    w("Share of the gain box (finest cells) by class under the derived and the printed "
      "conditions:")
    w("")
    w("| graph | paper certified, derived refuted | derived certified, paper refuted | "
      "both certified | both refuted |")
    w("|---|---|---|---|---|")
    for dm, pm in zip(dmaps, pmaps):
        rd, rp = rasterize(dm), rasterize(pm)
        tot = rd.size
        w(f"| {dm.graph} | {np.sum((rp == 1) & (rd == -1)) / tot:.4f} | "
          f"{np.sum((rd == 1) & (rp == -1)) / tot:.4f} | {np.sum((rd == 1) & (rp == 1)) / tot:.4f} | "
          f"{np.sum((rd == -1) & (rp == -1)) / tot:.4f} |")
    w("")
    w("The printed `M` has diagonal `K_o - beta` and off-diagonals `beta/2` (adjacency) where "
      "the derivation gives `K_o I - beta L`; gains in the first column are accepted by the "
      "printed Theorem 1 but violate the derived `Pi > 0`.")
    w("")
    w("## The paper's gains")
    w("")
    w("| graph | conditions | status | certified margin | witness |")
    w("|---|---|---|---|---|")
    for conds_list in (derived, printed):
        for c in conds_list:
            r = certify_box(c, pt)
            mlb = r.margin_lower_bound
            wit = ""
            if r.witness is not None:
                wv = r.witness
                wit = (f"{wv.family}, x on ({', '.join(wv.rows[:4])}{', ...' if len(wv.rows) > 4 else ''}), "
                       f"x^T F x / x^T x = {float(wv.rayleigh):.4g}")
            w(f"| {r.graph} | {r.source} | {r.status} | "
              f"{'' if mlb is None else f'{float(mlb):.6g}'} | {wit} |")
    w("")
    w("## Gain design (derived conditions)")
    w("")
    w("| graph | penalty | K_o | K_q | beta | certified margin | largest certified box (relative half-width s) |")
    w("|---|---|---|---|---|---|---|")
    for pen in (0.0, 0.1):
        for g, c in zip(graphs, derived):
            d = design_gains(c, {"K_o": (0.05, 5), "K_q": (0.05, 5), "beta": (0.01, 1)},
                             betas=9, penalty=pen)
            gk = d.gains
            w(f"| {g} | {pen:g} | {float(gk['K_o']):.4g} | {float(gk['K_q']):.4g} | "
              f"{float(gk['beta']):.4g} | {'' if d.margin is None else f'{float(d.margin):.4g}'} | "
              f"{float(d.box_half_width):.3g} |")
    w("")
    w("Ranges `K_o, K_q in [0.05, 5]`, `beta in [0.01, 1]` (9 beta values). Without a penalty "
      "the margin grows with the gains until `Theta_i`'s `1/2` entry caps it, so the optimum "
      "sits at the upper ends; the penalty `rho (K_o/5 + K_q/5)` trades margin for gain size. "
      "The box is `g (1 +- s)` clipped to the ranges, certified with `certify_box`.")
    w("")
    md = rep / "liang2016-region.md"
    w("Regenerate: `.venv/bin/python verification/region_report.py` (about a minute).")
    w("")
    write_text(md, "\n".join(lines))
    return md
