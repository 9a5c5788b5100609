"""Certificates whose Lyapunov candidate has multipliers: parameters of the
certificate, not of the controller, chosen per gain box.

A design may declare *multipliers* (``GAINS = {..., "eps": {"role": "multiplier"}}``):
the candidate ``V`` depends on them and the controller does not.  A gain box is
certified when **one** value of the multipliers makes every family positive
definite on the whole box (then that ``V`` is a Lyapunov function for every gain in
the box).  A multiplier value for which the families fail refutes only that
candidate, never the design: without a certified value the verdict is
``undecided``, and the reason names the values tried.

The values tried are a fixed geometric grid over the multiplier's declared range
(exact decimals with 3 significant digits, endpoints included), so every run is
reproducible.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import replace
from fractions import Fraction
from typing import Any

from formsync_design.certify.engine import as_box, certify_box
from formsync_design.certify.results import CertificationResult, KvCheck, Status
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, GainRange

__all__ = ["multiplier_grid", "certify_with_multipliers", "agent_multiplier_ranges", "GRID_POINTS"]

#: Values tried per multiplier.
GRID_POINTS = 13


def _decimal3(x: float) -> Fraction:
    """``x`` rounded to 3 significant decimal digits, exactly."""
    if x == 0:
        return Fraction(0)
    e = math.floor(math.log10(abs(x))) - 2
    return Fraction(round(x / 10.0**e)) * Fraction(10) ** e


def multiplier_grid(r: GainRange, points: int = GRID_POINTS) -> list[Fraction]:
    """A geometric grid over ``[lo, hi]`` (exact, endpoints included, inside the range).

    >>> [str(v) for v in multiplier_grid(GainRange("eps", Fraction(1, 100), 1), 3)]
    ['1/100', '1/10', '1']
    """
    if r.is_point:
        return [r.lo]
    if points < 2:
        raise InputError(f"expected at least 2 grid points, received {points}")
    lo, hi = float(r.lo), float(r.hi)
    out = [r.lo]
    for k in range(1, points - 1):
        v = _decimal3(lo * (hi / lo) ** (k / (points - 1)))
        if r.lo < v < r.hi and v not in out:
            out.append(v)
    out.append(r.hi)
    return out


def certify_with_multipliers(
    conditions: Any,
    box: Any,
    multipliers: Mapping[str, GainRange],
    *,
    margin: Any = 0,
    kv: KvCheck | None = None,
    use_sdp: bool = True,
    points: int = GRID_POINTS,
) -> CertificationResult:
    """Certify ``box`` (controller gains) for some value of the multipliers.

    Parameters
    ----------
    conditions : LyapunovConditions
        Families in the controller gains and the multipliers.
    box : GainBox or mapping
        Ranges of the gains not in ``multipliers`` (a multiplier given here as a
        range or value is used as given: no search).
    multipliers : mapping
        ``name -> GainRange``: the declared range each searched multiplier is taken from.

    Returns
    -------
    CertificationResult
        Certified: its box holds the multiplier value that certifies (the
        evidence).  Otherwise ``undecided`` (the candidate class is not refuted
        by one value) with the values tried in the reason; an ``error`` status
        is passed through.

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> from formsync_design.spec.loader import load_spec
    >>> d = load_spec("pd_consensus").decl
    >>> c = derive_conditions("ring:6", "pd_consensus")
    >>> r = certify_with_multipliers(c, {"k_p": (0.5, 2), "k_d": (1, 3)},
    ...                              {"eps": d.gain("eps").range}, use_sdp=False)
    >>> str(r.status), float(r.box["eps"].lo) > 0
    ('certified', True)
    """
    names = tuple(conditions.gains)
    given: dict[str, Any] = ({r.name: r for r in box.ranges} if isinstance(box, GainBox)
                             else dict(box))
    search = [n for n in names if n in multipliers and n not in given]
    missing = [n for n in names if n not in given and n not in search]
    if missing:
        raise InputError(f"expected a range for every gain {names}, missing {missing}")
    if not search:
        return certify_box(conditions, as_box(given, names), margin=margin, kv=kv, use_sdp=use_sdp)
    grids = [multiplier_grid(multipliers[n], points) for n in search]
    last: CertificationResult | None = None
    best: tuple[Fraction, CertificationResult, tuple[Fraction, ...]] | None = None
    total = math.prod(len(g) for g in grids)
    for values in itertools.product(*grids):
        full = dict(given)
        full.update(zip(search, values))
        r = certify_box(conditions, as_box(full, names), margin=margin, kv=kv, use_sdp=use_sdp)
        if r.status == Status.CERTIFIED:
            lb = r.margin_lower_bound
            key = lb if lb is not None else Fraction(0)
            if best is None or key > best[0]:
                best = (key, r, values)
            continue
        if r.status == Status.ERROR:
            return r
        if kv is not None and not kv.holds:
            return r  # the K_v check refutes whatever the multiplier
        last = r
    if best is not None:
        _, r, values = best
        chosen = ", ".join(f"{n} = {float(v):g}" for n, v in zip(search, values))
        note = (f"certified with the multiplier {chosen}, the grid value with the largest "
                f"certified margin ({total} grid values tried)")
        return replace(r, reason=f"{note}; {r.reason}" if r.reason else note)
    assert last is not None
    ranges = "; ".join(f"{n} in {multipliers[n]} ({len(g)} values)" for n, g in zip(search, grids))
    return replace(
        last,
        status=Status.UNDECIDED,
        witness=None,
        reason=(f"no multiplier value tried certifies the box ({ranges}); a failing value "
                "refutes that Lyapunov candidate only, not the design"),
    )


def agent_multiplier_ranges(conditions: Any, given: Any, design: Any = None) -> dict[str, Any]:
    """The multipliers of ``conditions`` not in ``given`` (``name -> GainRange``): the
    declared ranges of ``design`` (default: the shipped design the conditions name)."""
    gains = tuple(conditions.gains)
    missing = [n for n in gains if n not in given]
    if not missing:
        return {}
    if design is None:
        from formsync_design.resources import design_names
        from formsync_design.spec.loader import load_design

        name = getattr(conditions, "design", getattr(conditions, "spec_name", None))
        if not isinstance(name, str) or name not in design_names():
            raise InputError(f"expected a range for every gain of the conditions "
                             f"({', '.join(gains)}) or design= (whose multipliers are searched), "
                             f"received none for {missing}")
        design = load_design(name)
    out = {}
    for n in missing:
        g = design.decl.gain(n)
        if str(g.role) != "multiplier" or g.range is None:
            raise InputError(f"expected a value or range for the gain {n} of design "
                             f"{design.name}, received none")
        out[n] = g.range
    return out
