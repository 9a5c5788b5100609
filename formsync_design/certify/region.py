"""Admissible-region maps of any design: the one entry point :func:`region_map`.

It routes a design's conditions and gain ranges to the map that fits them: the adaptive
subdivision of a three-gain box (:mod:`formsync_design.certify.subdivision`, whose module
docstring states how a box is classified and split), the multiplier search of a design whose
candidate has multipliers (:mod:`formsync_design.certify.multiregion`), and a design with
other than three gains mapped over three axes, the others fixed or padded
(:mod:`formsync_design.certify.reduce`).  Figures and the report:
:mod:`formsync_design.certify.plots`.  :func:`closed_form_agreement` compares a map with the
design's closed-form conditions where it has them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from formsync_design.certify.multipliers import agent_multiplier_ranges
from formsync_design.certify.multiregion import region_with_multipliers
from formsync_design.certify.reduce import three_axes
from formsync_design.certify.subdivision import RegionMap, subdivide
from formsync_design.errors import InputError

__all__ = ["region_map", "closed_form_agreement"]


def _missing_gains(conditions: Any, ranges: Any) -> bool:
    """Whether a mapping of ranges leaves out a gain of the conditions (a multiplier to
    search)."""
    from collections.abc import Mapping

    return isinstance(ranges, Mapping) and any(n not in ranges for n in conditions.gains)


def _bounds(ranges: Any) -> dict[str, Any]:
    from formsync_design.gains import GainBox

    box = ranges if isinstance(ranges, GainBox) else GainBox.parse(ranges)
    return {r.name: (r.lo, r.hi) for r in box.ranges}


def _region_any(conditions: Any, ranges: Any, *, multipliers: Any = None, design: Any = None,
                resolution: int = 32, margin: Any = 0, progress: Any = None) -> Any:
    """A :class:`~formsync_design.certify.subdivision.RegionMap` of ``conditions`` over any gains:
    the free axes of ``ranges`` and the searched ``multipliers`` (default: the design's, for
    the gains ``ranges`` does not give) make at most three axes; point gains are fixed
    (:func:`~formsync_design.certify.reduce.three_axes`), the multipliers searched per cell
    (:func:`~formsync_design.certify.multiregion.region_with_multipliers`)."""
    given = _bounds(ranges)
    mult = dict(multipliers) if multipliers is not None else \
        agent_multiplier_ranges(conditions, given, design)
    full = {**given, **{n: (r.lo, r.hi) for n, r in mult.items()}}
    red, rbox = three_axes(conditions, full)
    fixed = {n: v for n, v in rbox.items() if n not in mult}
    return region_with_multipliers(red, fixed, {n: r for n, r in mult.items() if n in rbox},
                                   resolution=resolution, margin=margin, progress=progress)


def region_map(
    conditions: Any,
    ranges: Any,
    *,
    resolution: int = 32,
    margin: Any = 0,
    progress: Callable[[int], None] | None = None,
    multipliers: Any = None,
    design: Any = None,
) -> RegionMap:
    """Classify a gain box into certified / refuted / undecided sub-boxes.

    Conditions over other gains than three (an agent design's ``conditions(c)`` families,
    a design with multipliers) are mapped over at most three free axes, the point gains
    fixed and the ``multipliers`` (``name -> GainRange``; default: the declared ranges of
    ``design``, or of the shipped design the conditions name, for the gains ``ranges``
    does not give) searched per cell (:func:`~formsync_design.certify.multiregion.region_with_multipliers`).

    Parameters
    ----------
    conditions : LyapunovConditions
    ranges : box (see :func:`~formsync_design.certify.engine.as_box`); an axis with
        ``lo == hi`` is a slice (one grid value)
    resolution : int
        Finest cell = ``1/R`` of each range (``R >= 1``).
    margin : number
        Require ``lambda_min > margin``.
    progress : callable, optional
        Called with the number of finest cells finished (volume units).

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> m = region_map(derive_conditions("ring:4"),
    ...                {"K_o": (0.1, 4), "K_q": (0.1, 4), "beta": 0.3}, resolution=4)
    >>> sorted(m.fractions)
    ['certified', 'refuted', 'undecided']
    >>> round(sum(m.fractions.values()), 12)
    1.0
    """
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
        raise InputError(f"expected a resolution R >= 1 (an integer), received {resolution!r}")
    if (len(tuple(conditions.gains)) != 3 or multipliers is not None or design is not None
            or _missing_gains(conditions, ranges)):
        return _region_any(conditions, ranges, multipliers=multipliers, design=design,
                           resolution=int(resolution), margin=margin, progress=progress)
    return subdivide(conditions, ranges, resolution=int(resolution), margin=margin, progress=progress)


def closed_form_agreement(
    m: RegionMap, conditions: Any, *, samples: int = 4, seed: int = 0
) -> dict[str, int]:
    """Compare the map with :func:`~formsync_design.derive.closed_form.closed_form_conditions`.

    Every certified box must satisfy every closed-form condition at its
    vertices and at ``samples`` random interior points; every refuted box must
    violate one at each such point.  Returns counts of checks and
    disagreements (floating-point evaluation of the closed forms; points on a
    boundary within ``1e-12`` are skipped).

    >>> from formsync_design.derive.conditions import derive_conditions
    >>> c = derive_conditions("ring:4")
    >>> m = region_map(c, {"K_o": (0.1, 4), "K_q": (0.1, 4), "beta": (0.05, 1)}, resolution=4)
    >>> closed_form_agreement(m, c)["disagree"]
    0
    """
    import sympy as sp

    from formsync_design.derive.closed_form import closed_form_conditions
    from formsync_design.spec.loader import gain_symbols

    cfs = closed_form_conditions(conditions)
    syms = gain_symbols()
    fns = [sp.lambdify(syms, c.substituted(), "numpy") for c in cfs]
    rng = np.random.default_rng(seed)
    out = {"checked": 0, "disagree": 0, "near_boundary": 0, "conditions": len(cfs)}
    for b in m.boxes:
        if b.cls == "undecided":
            continue
        lo = np.array([float(v) for v in b.lo])
        hi = np.array([float(v) for v in b.hi])
        corners = np.array(
            [[(lo if (k >> a) & 1 == 0 else hi)[a] for a in range(3)] for k in range(8)]
        )
        pts = np.vstack([corners, lo + (hi - lo) * rng.random((samples, 3))])
        vals = np.array(
            [np.broadcast_to(np.asarray(f(pts[:, 0], pts[:, 1], pts[:, 2]), float), len(pts)) for f in fns]
        )  # (C, P)
        if b.cls == "refuted":
            vals, pts = vals[:, 8:], pts[8:]  # vertices may sit on the boundary
        worst = vals.min(axis=0)
        near = np.abs(worst) < 1e-12
        out["near_boundary"] += int(near.sum())
        if b.cls == "certified":
            bad = (worst <= 0) & ~near
        else:
            bad = (worst > 0) & ~near
        out["checked"] += int((~near).sum())
        out["disagree"] += int(bad.sum())
    return out
