"""Region maps of designs whose Lyapunov candidate has multipliers.

For a design with multipliers (see :mod:`formsync_design.certify.multipliers`) a
finest cell of the controller-gain grid is **certified** when one value of the
multipliers certifies the whole cell (that candidate is a Lyapunov function for
every gain in it), and **undecided** otherwise: a cell every tried value refutes is
refuted for those candidates only, never for the design.  The map is the union of
:func:`~formsync_design.certify.subdivision.subdivide` over the multiplier grid of
:func:`~formsync_design.certify.multipliers.multiplier_grid`; each certified box
records the multiplier value that certifies it (``RegionBox.reason``, the evidence).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Mapping
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.certify.multipliers import GRID_POINTS, multiplier_grid
from formsync_design.certify.subdivision import CLASSES, RegionBox, RegionMap, rasterize, subdivide
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, GainRange

__all__ = ["region_with_multipliers"]


def region_with_multipliers(
    conditions: Any,
    ranges: Any,
    multipliers: Mapping[str, GainRange],
    *,
    resolution: int = 32,
    margin: Any = 0,
    points: int = GRID_POINTS,
    progress: Callable[[int], None] | None = None,
) -> RegionMap:
    """Certified region of the controller gains, the multipliers searched per cell.

    Parameters
    ----------
    conditions : LyapunovConditions
        Families in the controller gains and the multipliers (three box dimensions).
    ranges : mapping or GainBox
        The controller gains' ranges (a multiplier given here is used as given).
    multipliers : mapping
        ``name -> GainRange`` of each searched multiplier (its declared range).

    Returns
    -------
    RegionMap
        One box per finest cell: ``certified`` (``reason`` names the multiplier
        value) or ``undecided`` (no value tried certifies it); a multiplier's axis
        spans its searched range with resolution 0.

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> from formsync_design.spec.loader import load_spec
    >>> d = load_spec("pd_consensus").decl
    >>> m = region_with_multipliers(derive_conditions("star:5", "pd_consensus"),
    ...     {"k_p": (0.1, 2), "k_d": (0.1, 2)}, {"eps": d.gain("eps").range}, resolution=4)
    >>> m.fractions["certified"], m.fractions["refuted"]
    (1.0, 0.0)
    """
    t0 = time.perf_counter()
    names = tuple(conditions.gains)
    if len(names) != 3:
        raise InputError(f"expected three box dimensions for a region map, received {names}")
    given: dict[str, Any] = ({r.name: r for r in ranges.ranges} if isinstance(ranges, GainBox)
                             else dict(ranges))
    search = [n for n in names if n in multipliers and n not in given]
    if not search:
        return subdivide(conditions, given, resolution=resolution, margin=margin,
                         progress=progress)
    grids = [multiplier_grid(multipliers[n], points) for n in search]
    combos = list(itertools.product(*grids))
    maps: list[tuple[tuple[Fraction, ...], RegionMap]] = []
    ncell = 0
    for k, values in enumerate(combos):
        full = dict(given)
        full.update(zip(search, values))
        m = subdivide(conditions, full, resolution=resolution, margin=margin)
        maps.append((values, m))
        if k == 0:
            ncell = int(np.prod([max(r, 1) for r in m.resolution]))
    rasters = [rasterize(m) for _, m in maps]
    first = np.full(rasters[0].shape, -1, dtype=np.int64)
    for k, r in enumerate(rasters):
        first[(first < 0) & (r == 1)] = k
    m0 = maps[0][1]
    axes = [m0.grid(a) for a in range(3)]
    sidx = [names.index(n) for n in search]
    boxes: list[RegionBox] = []
    spans = [range(int(first.shape[a])) for a in range(first.ndim)]
    cells: list[tuple[int, ...]] = list(itertools.product(*spans))
    for cell in cells:
        idx: list[int] = []
        lo: list[Fraction] = []
        hi: list[Fraction] = []
        for a, c in enumerate(cell):
            if m0.resolution[a] == 0:
                idx += [0, 0]
                lo.append(axes[a][0])
                hi.append(axes[a][0])
            else:
                idx += [c, c + 1]
                lo.append(axes[a][c])
                hi.append(axes[a][c + 1])
        k = int(first[cell])
        if k >= 0:
            vals = combos[k]
            for a, v in zip(sidx, vals):
                lo[a] = hi[a] = v
            why = ", ".join(f"{n} = {float(v):g}" for n, v in zip(search, vals))
            boxes.append(RegionBox(tuple(idx), tuple(lo), tuple(hi), "certified",  # type: ignore[arg-type]
                                   reason=f"certified with {why}"))
        else:
            for a, n in zip(sidx, search):
                lo[a], hi[a] = multipliers[n].lo, multipliers[n].hi
            boxes.append(RegionBox(tuple(idx), tuple(lo), tuple(hi), "undecided",  # type: ignore[arg-type]
                                   reason=f"no multiplier value of {len(combos)} tried certifies it"))
        if progress:
            progress(1)
    cert = float(np.count_nonzero(first >= 0)) / max(ncell, 1)
    fr = {c: 0.0 for c in CLASSES}
    fr["certified"] = cert
    fr["undecided"] = 1.0 - cert
    rng = tuple((multipliers[n].lo, multipliers[n].hi) if n in search else m0.ranges[a]
                for a, n in enumerate(names))
    recheck: dict[str, int] = {}
    for _, m in maps:
        for key, count in m.recheck.items():
            recheck[key] = recheck.get(key, 0) + count
    return RegionMap(
        graph=m0.graph, n=m0.n,
        source=f"{m0.source}; {', '.join(search)} searched ({len(combos)} values)",
        gains=names, ranges=rng, resolution=m0.resolution, margin=m0.margin,
        boxes=tuple(boxes), fractions=fr,
        vertices_evaluated=sum(m.vertices_evaluated for _, m in maps),
        recheck=recheck, elapsed=time.perf_counter() - t0,
    )
