"""The certificate-comparison report (``reports/liang2016-certificates.md`` + figure).

Written by ``verification/analysis_report.py``; deterministic (no timings, no
dates; the PNG is written without a software stamp), so it regenerates byte
for byte.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.analysis.certificates import certify
from formsync_design.analysis.compare import (
    ORDER,
    RegionComparison,
    compare_regions,
    plot_comparison,
)
from formsync_design.analysis.spectrum import laplacian_spectrum
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph
from formsync_design.outdir import save_figure as save_atomic_figure, write_text

__all__ = ["DEFAULT_BOX", "PAPER_GAINS", "write_certificates_report", "design_section"]

#: The box of ``formsync region`` in the README.
DEFAULT_BOX = {"K_o": ("0.05", "5"), "K_q": ("0.05", "5"), "beta": ("0.01", "1")}
#: Liang et al.'s gains (section 3).
PAPER_GAINS = {"K_o": "1.6", "K_q": "0.4", "beta": "0.3"}


def _pct(q: Fraction) -> str:
    return f"{100 * float(q):.1f} %"


def _lam(x: Fraction) -> str:
    return f"{float(x):.6g}"


def write_certificates_report(
    root: Path,
    graphs: Sequence[str] = ("ring:8", "star:8", "complete:8"),
    *,
    resolution: int = 8,
    box: Any = None,
    extra_sections: Sequence[str] = (),
) -> Path:
    """Compute the comparison and write ``reports/liang2016-certificates.md`` and its figure.

    Returns the path of the markdown file.
    """
    import matplotlib

    root = Path(root)
    b = GainBox.parse(box if box is not None else DEFAULT_BOX, ("K_o", "K_q", "beta"))
    comps: list[RegionComparison] = [compare_regions(g, b, resolution) for g in graphs]
    figdir = root / "reports" / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    fig = plot_comparison(comps, beta_index=1)
    figpath = figdir / "liang2016-certificates-ko-kq.png"
    with matplotlib.rc_context({"svg.hashsalt": "formsync"}):
        save_atomic_figure(fig, figpath, dpi=110, metadata={"Software": None})
    lines = [
        "# Four certificates, one comparison (Liang et al. 2016, controller (4))",
        "",
        "Regenerate with `python verification/analysis_report.py` (deterministic).",
        "",
        f"Gain box {b} split into {resolution}^3 = {resolution ** 3} equal cells; each certificate",
        "decides each **cell** (every gain in it, exact rational arithmetic over rigorous",
        "Laplacian-eigenvalue enclosures), so a certified fraction is a lower bound of the",
        "fraction of the box where that certificate holds.",
        "",
        "| certificate | what it decides |",
        "|---|---|",
        "| paper | the paper's per-spacecraft test: every `Theta_i > 0` and `Pi > 0` (today's `formsync certify`) |",
        "| exact | the paper's own `V` on the whole graph: `V > 0` on the disagreement subspace and `V' < 0`, per Laplacian mode |",
        "| searched | the best quadratic `V` whose gradient in `q_i'` is the switching argument `q_i' + beta s_i` (vertex LMIs, cvxpy + Clarabel, exact re-check; exact dual certificate when none exists) |",
        "| spectral | the true stability region of the nominal linear loop `q'' = -K_o q' - K_q L q`: every mode's characteristic polynomial Hurwitz (derived, Routh-Hurwitz) |",
        "",
        "## Certified volume fractions",
        "",
        "| graph | lambda_max(L) | max degree | paper | exact | searched | spectral | nesting violations |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for rc in comps:
        s = laplacian_spectrum(rc.graph)
        top = max(s.clusters, key=lambda c: c.hi)
        lam = _lam(top.lo) if top.is_point else f"[{_lam(top.lo)}, {_lam(top.hi)}]"
        dmax = max(make_graph(rc.graph).degrees)
        lines.append(f"| {rc.graph} | {lam} | {dmax} | " + " | ".join(_pct(rc.fractions[c]) for c in ORDER)
                     + f" | {rc.nesting_violations} |")
    lines += [
        "",
        "Refuted fractions (a cell with a point where the certificate fails, exact witness):",
        "",
        "| graph | paper | exact | searched | spectral |",
        "|---|---|---|---|---|",
    ]
    for rc in comps:
        fr = rc.to_dict()["refuted_fraction"]
        lines.append(f"| {rc.graph} | " + " | ".join(_pct(Fraction(str(fr[str(c)]))) for c in ORDER) + " |")
    lines += ["", f"![K_o-K_q slices](figures/{figpath.name})", "",
              "## The paper's gains (K_o, K_q, beta) = (1.6, 0.4, 0.3)", "",
              "| graph | paper | exact | searched | spectral |", "|---|---|---|---|---|"]
    for g in graphs:
        st = [certify(g, PAPER_GAINS, c, use_sdp=False).status.value for c in ORDER]
        lines.append(f"| {make_graph(g).name} | " + " | ".join(st) + " |")
    lines += [
        "",
        "## What the comparison shows",
        "",
        "* **paper -> exact.** The per-spacecraft test asks `K_q + beta K_o > 2 m_i beta^2` for every",
        "  spacecraft; the paper's `V` on the whole graph only needs `K_q + beta K_o > beta^2 lambda_k`",
        "  and `K_o > beta lambda_k` per mode, and the second implies the first. The gap is",
        "  zero where `lambda_max = 2 max m_i` (bipartite regular graphs such as the ring) and",
        "  positive on the star and the complete graph.",
        "* **exact = searched (for this design).** Per mode the class has",
        "  `A^T P + P A = [[-2 beta K_q lambda^2, p - (K_q + beta K_o) lambda], [., 2 (beta lambda - K_o)]]`:",
        "  the free entry `p` cannot reach the diagonal, so `K_o <= beta lambda_max` at any point is",
        "  refuted for the *whole class* by the exact dual certificate `Z = e_2 e_2^T`; per-spacecraft",
        "  scalings `D` of the gradient do not help (`v^T (beta (D L + L D) - 2 K_o D) v = 2 (beta",
        "  lambda_max - K_o) v^T D v` for the top eigenvector `v`). Where `K_o > beta lambda_max` the",
        "  paper's own `V` is a member that works. The searched LMIs therefore certify exactly",
        "  the paper's-`V` region.",
        "* **searched -> spectral.** The nominal linear loop is stable for every positive gain on a",
        "  connected graph, so the remaining gap (`K_o <= beta lambda_max`) is where no quadratic",
        "  function keeps the switching term dissipative. Closing it needs a non-quadratic",
        "  function, or a boundary-layer / ultimate-boundedness argument in which the switching",
        "  term is treated as a bounded input of the exponentially stable linear loop",
        "  (not implemented here).",
        "",
    ]
    lines += list(extra_sections)
    md = root / "reports" / "liang2016-certificates.md"
    write_text(md, "\n".join(lines).rstrip() + "\n")
    return md


def _fractions(counts: dict[str, int], total: int) -> str:
    return " / ".join(f"{100 * counts.get(k, 0) / total:.0f} %" for k in ("certified", "refuted", "undecided"))


def design_section(spec: str = "pd_consensus", graphs: Sequence[str] = ("ring:8", "star:8", "complete:8"), *,
                   box: Any = None, resolution: int = 8, point: tuple[str, str] = ("0.4", "1.6"),
                   req_box: Any = None, req_resolution: int = 5) -> list[str]:
    """Markdown lines: the certificates on a second design in its own gains (default the PD
    baseline): the four regions, performance at a point, and a requirement map."""
    import math

    import numpy as np

    from formsync_design.analysis.celldelay import delay_cell_check
    from formsync_design.analysis.delay import delay_margin
    from formsync_design.analysis.modes import mode_model
    from formsync_design.analysis.performance import certified_decay_rate, spectral_decay_rate
    from formsync_design.analysis.requirements import Requirements, certify_requirements
    from formsync_design.analysis.switching import certify_switching, graphs_minus_links
    from formsync_design.analysis.torque import initial_torque_witness, peak_torque_bound

    mm = mode_model(spec)
    names = mm.names
    b = GainBox.parse(box if box is not None else {n: ("0.05", "5") for n in names}, names)
    rb = GainBox.parse(req_box if req_box is not None else {"k_p": ("0.1", "2"), "k_d": ("0.5", "3")}, names)
    pt = dict(zip(names, point))
    J = np.diag([50.0, 55.0, 60.0])
    tau, alpha, limit, r0, w0 = 0.5, Fraction(1, 20), 60.0, Fraction(1, 20), Fraction(1, 100)
    cs = ", ".join(f"{x} = {sym}" for x, sym in (("c_qd", mm.c_qd), ("c_s", mm.c_s)))
    import sympy as sp

    from formsync_design.analysis.modes import LAMBDA

    char = f"s^2 + ({mm.charpoly[1]}) s + ({sp.expand(mm.charpoly[2] / LAMBDA)}) lambda"
    lines = [f"## A second design: {spec} in its own gains ({', '.join(names)})", "",
             f"The same certificates on `derivations/{spec}.py`, computed from its derived closed loop",
             f"({cs}; per Laplacian mode `{char}`) and its own Lyapunov candidate, whose",
             "multiplier is chosen per box from its declared range"
             + (" (no switching term: the searched class is every quadratic V per mode)." if not mm.switching
                else "."), "",
             f"Four certificates on the box {b}, {resolution}^{len(names)} cells (certified volume fractions):", "",
             "| graph | paper | exact | searched | spectral | nesting violations |", "|---|---|---|---|---|---|"]
    full = True
    for gspec in graphs:
        rc = compare_regions(gspec, b, resolution, spec=spec)
        full = full and all(rc.fractions[c] == 1 for c in ORDER)
        lines.append(f"| {rc.graph} | " + " | ".join(_pct(rc.fractions[c]) for c in ORDER)
                     + f" | {rc.nesting_violations} |")
    lines.append("")
    fd = mm.vdot(mm.p_paper)
    fstr = "[[" + "], [".join(", ".join(str(fd[i, j]) for j in range(2)) for i in range(2)) + "]]"
    if full:  # decided by the fractions just computed
        lines += ["Every cell is certified by all four certificates on every graph: per mode the candidate",
                  f"gives `A^T P + P A = {fstr}` (derived), negative definite for a small",
                  "enough multiplier (for the PD baseline, by hand: `eps lambda_max < k_d` and `eps^2 lambda_max <",
                  "k_p + eps k_d`, checked against the engine in `tests/test_analysis_designs.py`), so on this box",
                  "the per-spacecraft test loses nothing for this design.", ""]
    else:
        lines += ["The certificates differ on this box (fractions above); nesting is checked cell by cell.", ""]
    lines += [f"At ({', '.join(f'{n} = {v}' for n, v in pt.items())}): decay rates (the searched class against the",
              "true rate of the nominal loop), the processing-delay margin against the closed form",
              "`atan(k_d / w) / w`, `w^4 + k_d^2 w^2 = (k_p lambda_max)^2` (computed here independently), the",
              "transmission-delay margin (regular graphs), the one-link-failure set, and the peak torque from",
              f"|q_i(0)| <= {float(r0):g}, |omega_i(0)| <= {float(w0):g} rad/s with J = diag(50, 55, 60) kg m^2.", "",
              "| graph | alpha (own V) | alpha (searched) | true rate | processing delay margin | closed form "
              "| transmission margin | one link lost | torque bound (N m) | initial-torque witness (N m) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    kp, kd = (float(Fraction(x)) for x in point)
    for gname in graphs:
        g = make_graph(gname)
        ex = certified_decay_rate(g, pt, "exact", spec=spec)
        se = certified_decay_rate(g, pt, "searched", spec=spec)
        true = spectral_decay_rate(g, [Fraction(x) for x in point], spec=spec)
        dm = delay_margin(g, point, "processing", spec=spec)
        lam = float(max(np.linalg.eigvalsh(g.laplacian.astype(float))))
        w = math.sqrt((-kd**2 + math.sqrt(kd**4 + 4 * (kp * lam) ** 2)) / 2)
        hand = math.atan(kd / w) / w
        if len(set(g.degrees)) == 1:
            tm = delay_margin(g, point, "transmission", spec=spec).margin
            ts = "inf (delay-independent)" if math.isinf(tm) else f"{tm:.4g} s"
        else:
            ts = "not decoupled"
        subs = graphs_minus_links(g, 1)
        link = certify_switching([g, *subs], pt, spec=spec).status.value if subs else "- (disconnects)"
        tb = peak_torque_bound(g, point, J, r0, w0, spec=spec)
        wt = initial_torque_witness(g, point, J, r0, spec=spec)
        lines.append(f"| {g.name} | {float(ex.alpha):.4g} | {float(se.alpha):.4g} | {true:.4g} | {dm.margin:.4g} s | "
                     f"{hand:.4g} s | {ts} | {link} | {tb.peak:.4g} | {wt['torque_N_m']:.4g} |")
    req = Requirements(decay=alpha, torque_limit=limit, inertias=J, att_radius=r0, rate_radius=w0)
    lines += ["", f"Requirement map on the box {rb}, {req_resolution}^{len(names)} cells, each decided for every gain",
              f"of the cell (`formsync region --design {spec} --certificate exact --decay {float(alpha):g} --delay {tau:g}",
              f"--torque-limit {limit:g} --att0 {float(r0):g} --rate0 {float(w0):g}`): decay rate >= {float(alpha):g} 1/s (the",
              f"design's own V), processing-delay margin > {tau:g} s (proven monotone in `(c_qd, c_s)`), peak torque <=",
              f"{limit:g} N m (the bound valid over the cell; refuted by a state of the set that needs more at t = 0).",
              "Fractions of cells certified / refuted / undecided (a refuted cell holds a gain that violates the",
              "requirement, with an exact witness; the requirements pull apart: a fast decay needs a large `k_p`,",
              "the delay margin and the torque limit a small one):", "",
              "| graph | decay | delay | torque | all three |", "|---|---|---|---|---|"]
    edges = [[r.lo + (r.hi - r.lo) * Fraction(i, req_resolution) for i in range(req_resolution + 1)] for r in rb.ranges]
    for gname in graphs:
        g = make_graph(gname)
        spectrum = laplacian_spectrum(g)
        counts: dict[str, dict[str, int]] = {k: {} for k in ("decay", "delay", "torque", "all")}
        for i in range(req_resolution):
            for j in range(req_resolution):
                cell = {names[0]: (edges[0][i], edges[0][i + 1]), names[1]: (edges[1][j], edges[1][j + 1])}
                r = certify_requirements(g, cell, "exact", req, spec=spec, spectrum=spectrum, use_sdp=False)
                st = {c.name: c.status.value for c in r.checks}
                dc = delay_cell_check(g, cell, tau, spec=spec).status.value
                st["delay"] = dc
                worst = max(st.values(), key=lambda v: {"certified": 0, "undecided": 1, "refuted": 2, "error": 3}[v])
                for k, v in (*st.items(), ("all", worst if r.base.certified else r.base.status.value)):
                    counts[k][v] = counts[k].get(v, 0) + 1
        total = req_resolution ** len(names)
        lines.append(f"| {g.name} | " + " | ".join(_fractions(counts[k], total)
                                                  for k in ("decay", "delay", "torque", "all")) + " |")
    lines.append("")
    return lines
