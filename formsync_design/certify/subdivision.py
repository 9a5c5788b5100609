"""Admissible-region maps: adaptive subdivision of a gain box.

(Figures and the report: :mod:`formsync_design.certify.plots`.)

A 3-D gain box is split on a grid of ``R`` cells per (non-degenerate) axis.
Starting from the whole box, each box is classified from its vertices with
the rigorous vertex decisions of :mod:`.certify` (same re-checks, LAPACK
hints instead of one SDP per box, every grid vertex decided once):

``certified``
    every distinct diagonal block is PD (``> margin``) at every vertex: by
    multi-affinity, at every point of the box;
``refuted``
    one integer vector ``x`` has ``x^T (F(v) - margin I) x <= 0`` exactly at
    every vertex: by multi-affinity, *every* point of the box violates;
``undecided``
    neither, at the finest resolution: ``boundary`` when some vertex is
    refuted and the box straddles the boundary, ``inconclusive`` otherwise.

Boxes that are neither certified nor refuted are split at the middle grid
line of every axis wider than one cell, down to ``1/R`` of each range.
Families that are not multi-affine in the gains are never certified (nor
uniformly refuted) here; use :func:`~formsync_design.certify.engine.certify_box`,
which has an interval argument for them.

The value of a map is :class:`RegionMap`; :func:`~formsync_design.certify.region.region_map` is
the entry point (conditions over any gains, multipliers searched), this module the subdivision
of a three-gain box (:func:`subdivide`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.certify.engine import Bounds, as_box
from formsync_design.certify.structure import analyze
from formsync_design.certify.vertices import evaluate_vertices, uniform_refutation
from formsync_design.errors import InputError
from formsync_design.notebook import NotebookViews

__all__ = [
    "CLASSES",
    "RegionBox",
    "RegionMap",
    "subdivide",
    "map_to_dict",
    "rasterize",
]

CLASSES = ("certified", "refuted", "undecided")
_CODE = {"certified": 1, "refuted": -1, "undecided": 0}


@dataclass(frozen=True)
class RegionBox:
    """One leaf of the subdivision.

    ``index`` = ``(i0, i1, j0, j1, k0, k1)`` grid indices (gain ``a`` of the
    box spans ``grid[a][i0] .. grid[a][i1]``); ``family`` names the refuting
    matrix for a refuted box; ``reason`` is ``boundary``/``inconclusive`` for
    an undecided one.
    """

    index: tuple[int, int, int, int, int, int]
    lo: tuple[Fraction, ...]
    hi: tuple[Fraction, ...]
    cls: str
    family: str = ""
    reason: str = ""


@dataclass(frozen=True)
class RegionMap(NotebookViews):
    """A classified subdivision of a gain box (see module doc)."""

    graph: str
    n: int
    source: str
    gains: tuple[str, ...]
    ranges: Bounds
    resolution: tuple[int, ...]
    margin: Fraction
    boxes: tuple[RegionBox, ...]
    fractions: dict[str, float]
    vertices_evaluated: int
    recheck: dict[str, int]
    elapsed: float


    def grid(self, axis: int) -> list[Fraction]:
        lo, hi = self.ranges[axis]
        r = self.resolution[axis]
        return [lo] if r == 0 else [lo + (hi - lo) * i / r for i in range(r + 1)]


def _split(a0: int, a1: int) -> list[tuple[int, int]]:
    if a1 - a0 <= 1:
        return [(a0, a1)]
    mid = (a0 + a1) // 2
    return [(a0, mid), (mid, a1)]


def subdivide(
    conditions: Any,
    ranges: Any,
    *,
    resolution: int = 32,
    margin: Any = 0,
    progress: Callable[[int], None] | None = None,
) -> RegionMap:
    """The region map of three-gain ``conditions`` over the box ``ranges`` by adaptive
    subdivision (module docstring; the arguments of
    :func:`~formsync_design.certify.region.region_map`, which also takes other gains)."""
    t0 = time.perf_counter()
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
        raise InputError(f"expected a resolution R >= 1 (an integer), received {resolution!r}")
    gains = tuple(conditions.gains)
    rng = as_box(ranges, gains).bounds
    mg = Fraction(margin) if not isinstance(margin, float) else Fraction(repr(margin))
    if mg < 0:
        raise InputError(f"expected a non-negative margin, received {float(mg):g}")
    st = analyze(conditions.families)
    maff = all(b.multiaffine for b in st.blocks)
    res = tuple(0 if lo == hi else int(resolution) for lo, hi in rng)
    grids = [
        [lo] if r == 0 else [lo + (hi - lo) * Fraction(i, r) for i in range(r + 1)]
        for (lo, hi), r in zip(rng, res)
    ]
    nb = len(st.blocks)
    vid: dict[tuple[int, int, int], int] = {}
    pts: list[tuple[Fraction, ...]] = []
    vstat: list[np.ndarray] = [np.zeros(0, dtype=np.int8) for _ in range(nb)]
    vwit: list[dict[int, list[int]]] = [{} for _ in range(nb)]
    recheck: dict[str, int] = {}
    names = [st.groups[b.places[0][0]].names[0] for b in st.blocks]

    def corners(bx: tuple[int, ...]) -> list[tuple[int, int, int]]:
        i0, i1, j0, j1, k0, k1 = bx
        return [
            (i, j, k)
            for i in sorted({i0, i1})
            for j in sorted({j0, j1})
            for k in sorted({k0, k1})
        ]

    leaves: list[RegionBox] = []
    frontier = [(0, res[0], 0, res[1], 0, res[2])]
    while frontier:
        need: list[tuple[int, int, int]] = []
        for bx in frontier:
            for c in corners(bx):
                if c not in vid:
                    vid[c] = len(pts) + len(need)
                    need.append(c)
        if need:
            newpts = [tuple(grids[a][c[a]] for a in range(3)) for c in need]
            vr = evaluate_vertices(st, newpts, mg)
            base = len(pts)
            pts.extend(newpts)
            for b in range(nb):
                vstat[b] = np.concatenate([vstat[b], vr.status[b]])
                for i, x in vr.witness[b].items():
                    vwit[b][base + i] = x
            for k, v in vr.method.items():
                recheck[k] = recheck.get(k, 0) + v
        nxt = []
        for bx in frontier:
            cs = [vid[c] for c in corners(bx)]
            cert = maff and all(bool(np.all(vstat[b][cs] == 1)) for b in range(nb))
            lo = tuple(grids[a][bx[2 * a]] for a in range(3))
            hi = tuple(grids[a][bx[2 * a + 1]] for a in range(3))
            cells = max(bx[1] - bx[0], 1) * max(bx[3] - bx[2], 1) * max(bx[5] - bx[4], 1)
            if cert:
                leaves.append(RegionBox(bx, lo, hi, "certified"))
                if progress:
                    progress(cells)
                continue
            refuted_by = ""
            any_ref = False
            vpts = [pts[i] for i in cs]
            for b in range(nb):
                cand = [vwit[b][i] for i in cs if i in vwit[b]]
                if cand:
                    any_ref = True
                for x in cand[:3]:
                    if uniform_refutation(st.blocks[b], x, vpts, mg):
                        refuted_by = names[b]
                        break
                if refuted_by:
                    break
            if refuted_by:
                leaves.append(RegionBox(bx, lo, hi, "refuted", family=refuted_by))
                if progress:
                    progress(cells)
                continue
            parts = [_split(bx[0], bx[1]), _split(bx[2], bx[3]), _split(bx[4], bx[5])]
            if all(len(p) == 1 for p in parts):
                leaves.append(
                    RegionBox(bx, lo, hi, "undecided", reason="boundary" if any_ref else "inconclusive")
                )
                if progress:
                    progress(cells)
                continue
            for a in parts[0]:
                for b_ in parts[1]:
                    for c3 in parts[2]:
                        nxt.append((a[0], a[1], b_[0], b_[1], c3[0], c3[1]))
        frontier = nxt
    total = 1
    for r in res:
        total *= max(r, 1)
    fr = {c: 0.0 for c in CLASSES}
    for lf in leaves:
        i0, i1, j0, j1, k0, k1 = lf.index
        fr[lf.cls] += max(i1 - i0, 1) * max(j1 - j0, 1) * max(k1 - k0, 1) / total
    g = conditions.graph
    return RegionMap(
        graph=str(getattr(g, "name", "graph")),
        n=int(getattr(g, "n", 0)),
        source=str(getattr(conditions, "source", "?")),
        gains=gains,
        ranges=rng,
        resolution=res,
        margin=mg,
        boxes=tuple(leaves),
        fractions=fr,
        vertices_evaluated=len(pts),
        recheck=recheck,
        elapsed=time.perf_counter() - t0,
    )


def map_to_dict(m: RegionMap, *, timing: bool = True, boxes: bool = True) -> dict[str, Any]:
    """JSON-ready dict: ranges, resolution, boxes (float and index bounds), fractions
    (``timing=False`` omits the run time, for byte-reproducible reports;
    ``boxes=False`` keeps only the summary).

    >>> from formsync_design.derive.conditions import derive_conditions
    >>> m = subdivide(derive_conditions("ring:4"), {"K_o": (0.1, 4), "K_q": 1, "beta": 0.3},
    ...                resolution=4)
    >>> d = map_to_dict(m)
    >>> d["resolution"], sum(d["counts"].values()) == len(d["boxes"])
    ([4, 0, 0], True)
    """
    out = {
        "graph": m.graph,
        "n": m.n,
        "conditions": m.source,
        "gains": list(m.gains),
        "ranges": {g: [float(lo), float(hi)] for g, (lo, hi) in zip(m.gains, m.ranges)},
        "ranges_exact": {g: [str(lo), str(hi)] for g, (lo, hi) in zip(m.gains, m.ranges)},
        "resolution": list(m.resolution),
        "margin": float(m.margin),
        "fractions": dict(m.fractions),
        "counts": {c: sum(1 for b in m.boxes if b.cls == c) for c in CLASSES},
        "vertices_evaluated": m.vertices_evaluated,
        "recheck": dict(m.recheck),
        **({"elapsed_s": m.elapsed} if timing else {}),
        "boxes": [] if not boxes else [
            {
                "class": b.cls,
                "index": list(b.index),
                "lo": [float(v) for v in b.lo],
                "hi": [float(v) for v in b.hi],
                **({"family": b.family} if b.family else {}),
                **({"reason": b.reason} if b.reason else {}),
            }
            for b in m.boxes
        ],
    }
    return out


def rasterize(m: RegionMap) -> np.ndarray:
    """Class code (1 certified, -1 refuted, 0 undecided) of every finest cell,
    shape ``(max(R_0,1), max(R_1,1), max(R_2,1))``.

    >>> from formsync_design.derive.conditions import derive_conditions
    >>> m = subdivide(derive_conditions("ring:4"), {"K_o": (0.1, 4), "K_q": 1, "beta": 0.3},
    ...                resolution=4)
    >>> rasterize(m)[:, 0, 0].tolist()   # K_o > 4 beta = 1.2 is admissible
    [-1, 0, 1, 1]
    """
    shape = tuple(max(r, 1) for r in m.resolution)
    out = np.zeros(shape, dtype=np.int8)
    for b in m.boxes:
        i0, i1, j0, j1, k0, k1 = b.index
        out[i0 : max(i1, i0 + 1), j0 : max(j1, j0 + 1), k0 : max(k1, k0 + 1)] = _CODE[b.cls]
    return out
