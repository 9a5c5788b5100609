"""The four certificates side by side: region maps over a grid of gain cells, any design.

A gain box of the design's controller gains is split into ``resolution**dim`` equal cells
(``dim = 3`` for Liang et al., 2 for the PD baseline); each certificate
decides each *cell* (every gain in it), so the certified volume fraction is a
rigorous lower bound of the fraction of the box where the certificate holds.
The nesting ``paper <= exact <= searched <= spectral`` is checked cell by cell
(:attr:`RegionComparison.nesting_violations`, always 0 unless a certificate is
unsound).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.analysis.certificates import certify
from formsync_design.analysis.modecheck import split_box
from formsync_design.analysis.modes import mode_model
from formsync_design.analysis.results import Certificate, Verdict, jsonify
from formsync_design.analysis.spectrum import laplacian_spectrum
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, json_number
from formsync_design.graphs import make_graph

__all__ = ["ORDER", "STATUS_CODE", "RegionComparison", "compare_regions", "plot_comparison"]

ORDER = (Certificate.PAPER, Certificate.EXACT, Certificate.SEARCHED, Certificate.SPECTRAL)
#: Cell codes in :attr:`RegionComparison.cells`.
STATUS_CODE = {Verdict.CERTIFIED: 1, Verdict.REFUTED: -1, Verdict.UNDECIDED: 0, Verdict.ERROR: -2}


@dataclass(frozen=True)
class RegionComparison:
    """Cell-by-cell verdicts of the four certificates on one graph.

    Attributes
    ----------
    graph : str
    n : int
    box : GainBox
    resolution : int
    cells : dict
        Certificate -> int array ``(r,) * dim`` indexed by the box's gains in order
        (``[K_o, K_q, beta]``, ``[k_p, k_d]``) of :data:`STATUS_CODE` values.
    fractions : dict
        Certificate -> certified volume fraction (exact rational).
    nesting_violations : int
        Cells certified by one certificate but not by a later (weaker-assumption) one.
    seconds : dict
        Certificate -> wall time.
    """

    graph: str
    n: int
    box: GainBox
    resolution: int
    cells: dict[Certificate, np.ndarray]
    fractions: dict[Certificate, Fraction]
    nesting_violations: int
    seconds: dict[Certificate, float]

    def to_dict(self, *, timing: bool = False) -> dict[str, Any]:
        out = {
            "graph": self.graph,
            "n": self.n,
            "box": self.box.to_dict(),
            "resolution": self.resolution,
            "certified_fraction": {str(c): json_number(f) for c, f in self.fractions.items()},
            "refuted_fraction": {str(c): json_number(Fraction(int((a == -1).sum()), a.size))
                                 for c, a in self.cells.items()},
            "nesting_violations": self.nesting_violations,
        }
        if timing:
            out["seconds"] = jsonify({str(c): s for c, s in self.seconds.items()})
        return out


def _edges(r: Any, k: int) -> list[Fraction]:
    return [r.lo + (r.hi - r.lo) * Fraction(i, k) for i in range(k + 1)]


def compare_regions(graph: Any, box: Any, resolution: int = 6, *, spec: Any = None,
                    certificates: Any = ORDER) -> RegionComparison:
    """Decide every cell of a ``resolution**3`` grid with the four certificates
    (or the subset ``certificates``, e.g. ``("exact",)`` for one region map).

    Examples
    --------
    >>> rc = compare_regions("star:8", {"K_o": (0.5, 4), "K_q": (0.1, 2), "beta": (0.05, 0.5)}, 2)
    >>> [float(rc.fractions[c]) for c in ORDER], rc.nesting_violations
    ([0.125, 0.25, 0.25, 1.0], 0)
    >>> list(compare_regions("ring:4", {"K_o": 1, "K_q": 1, "beta": 0.1}, 1, certificates=["exact"]).cells)
    [<Certificate.EXACT: 'exact'>]
    >>> pd = compare_regions("star:8", {"k_p": (0.1, 2), "k_d": (0.5, 3)}, 2, spec="pd_consensus")
    >>> [float(pd.fractions[c]) for c in ORDER], pd.cells[ORDER[0]].shape
    ([1.0, 1.0, 1.0, 1.0], (2, 2))
    """
    g = make_graph(graph)
    mm = mode_model(spec)
    b, given = split_box(mm, box)
    if given is not None:
        raise InputError(f"expected a box of the controller gains {mm.names} (multipliers are chosen per "
                         f"cell), received {given}")
    k = int(resolution)
    spec_ = laplacian_spectrum(g)
    edges = [_edges(r, k) for r in b.ranges]
    chosen = tuple(Certificate(str(c)) for c in certificates)
    order = tuple(c for c in ORDER if c in chosen)
    dim = len(b.ranges)
    cells = {c: np.zeros((k,) * dim, dtype=int) for c in order}
    secs = {c: 0.0 for c in order}
    for idx in itertools.product(range(k), repeat=dim):
        cell = {r.name: (edges[a][i], edges[a][i + 1]) for a, (r, i) in enumerate(zip(b.ranges, idx))}
        for c in order:
            t0 = time.perf_counter()
            r = certify(g, cell, c, spec=spec, spectrum=spec_, use_sdp=False)
            secs[c] += time.perf_counter() - t0
            cells[c][idx] = STATUS_CODE[r.status]
    viol = 0
    for a, b2 in zip(order, order[1:]):
        viol += int(((cells[a] == 1) & (cells[b2] != 1)).sum())
    fr = {c: Fraction(int((cells[c] == 1).sum()), k**dim) for c in order}
    return RegionComparison(g.name, g.n, b, k, cells, fr, viol, secs)


def plot_comparison(comps: list[RegionComparison], beta_index: int | None = None) -> Any:
    """Slices of the nested regions in the first two gains (for a third gain, one layer:
    ``beta_index``, default the middle one), one panel per graph.

    Each cell is coloured by the most conservative certificate that certifies
    it (paper, exact/searched, spectral only, none).  Returns a matplotlib figure.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.2 * len(comps), 4.0), layout="constrained")
    axes = fig.subplots(1, len(comps), squeeze=False)[0]
    cmap = ListedColormap(["#f2f2f2", "#fdd49e", "#9ecae1", "#3182bd", "#08519c"])
    for ax, rc in zip(axes, comps):
        dim = len(rc.box.ranges)
        m = rc.resolution // 2 if beta_index is None else beta_index
        level = np.zeros((rc.resolution, rc.resolution), dtype=int)
        for lvl, c in zip((4, 3, 2, 1), ORDER):
            if c not in rc.cells:
                continue
            arr = rc.cells[c]
            sl = (arr[:, :, m] if dim == 3 else arr) == 1
            level = np.where(sl & (level == 0), lvl, level)
        x, y = rc.box.ranges[0], rc.box.ranges[1]
        ax.imshow(level.T, origin="lower", cmap=cmap, vmin=0, vmax=4, aspect="auto",
                  extent=(float(x.lo), float(x.hi), float(y.lo), float(y.hi)))
        if dim == 3:
            be = rc.box.ranges[2]
            blo = be.lo + (be.hi - be.lo) * Fraction(m, rc.resolution)
            bhi = be.lo + (be.hi - be.lo) * Fraction(m + 1, rc.resolution)
            ax.set_title(f"{rc.graph}, {be.name} in [{float(blo):.3g}, {float(bhi):.3g}]")
        else:
            ax.set_title(rc.graph)
        ax.set_xlabel(x.name)
        ax.set_ylabel(y.name)
    from matplotlib.patches import Patch

    labels = ["none", "spectral only", "searched only", "exact (+searched)", "paper (all four)"]
    fig.legend(handles=[Patch(color=cmap(i), label=lab) for i, lab in enumerate(labels)],
               loc="outside lower center", ncols=5, fontsize=8)
    return fig
