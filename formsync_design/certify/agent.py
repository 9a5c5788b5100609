"""Certificates of an agent design (``FORM = "agent"``): the reference box, the region map
and the gain design of its ``conditions(c)`` families.

The functions ``formsync certify``, ``formsync region``, ``formsync design`` and
``formsync sweep`` share for an agent design
(:mod:`formsync_design.cli.agent_commands`, :mod:`formsync_design.sweep.tasks`): the box
is a :class:`~formsync_design.gains.GainBox` over the design's controller gains (a
multiplier it holds is fixed at that value), the multipliers it does not hold are searched
over their declared ranges (:func:`agent_multipliers`).

Examples
--------
>>> from formsync_design.derive.agent import agent_conditions
>>> from formsync_design.gains import GainBox
>>> from formsync_design.spec.loader import load_design
>>> d = load_design("lv2012")
>>> conds = agent_conditions(d, "path:3")
>>> box = GainBox.parse({"k_p": "1", "k_d": "10", "a_f": "1/2"})
>>> str(certify_agent(d, conds, box).status)
'certified'
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

__all__ = ["agent_multipliers", "certify_agent", "certify_families", "region_agent",
           "AgentGainDesign", "design_agent"]


def agent_multipliers(design: Any, box: Any) -> dict[str, Any]:
    """The multipliers of ``design`` that ``box`` does not hold, with their declared ranges
    (every certificate searches them).

    >>> from formsync_design.gains import GainBox
    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("ma_so3")
    >>> {n: str(r) for n, r in agent_multipliers(d, GainBox.parse({"K1": 1})).items()}
    {'mu': '0.1:10'}
    """
    return {n: design.decl.gain(n).range for n in design.decl.multipliers if n not in box}


def certify_agent(design: Any, conditions: Any, box: Any, *, margin: Any = 0) -> Any:
    """Decide the families ``conditions`` (:func:`~formsync_design.derive.agent.agent_conditions`)
    over ``box``, the multipliers it does not hold searched
    (:func:`~formsync_design.certify.multipliers.certify_with_multipliers`; without any,
    :func:`~formsync_design.certify.engine.certify_box`).  Returns the
    :class:`~formsync_design.certify.results.CertificationResult`."""
    from formsync_design.certify.engine import certify_box
    from formsync_design.certify.multipliers import certify_with_multipliers

    mult = agent_multipliers(design, box)
    if mult:
        return certify_with_multipliers(conditions, box, mult, margin=margin)
    return certify_box(conditions, box, margin=margin)


def certify_families(design: Any, graph: Any, box: Any, *, points: int = 25) -> Any:
    """The design's ``conditions(c)`` families on ``graph`` decided over ``box`` (a gain ->
    ``"lo:hi"``/number mapping over every controller gain), the multipliers searched over
    their declared ranges on a grid of ``points`` values with exact re-checks (no SDP): a
    :class:`~formsync_design.certify.results.CertificationResult` (tested in
    ``tests/test_selftrigger.py``)."""
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.derive.agent import agent_conditions

    ac = agent_conditions(design, graph)
    mult = {g.name: g.range for g in design.decl.gains
            if str(g.role) == "multiplier" and g.range is not None}
    return certify_with_multipliers(ac, dict(box), mult, use_sdp=False, points=points)


def region_agent(design: Any, conditions: Any, box: Any, *, resolution: int,
                 margin: Any = 0) -> tuple[Any, Any, dict[str, Any]]:
    """The region map of ``box`` (at most three free axes counting the searched
    multipliers: :func:`~formsync_design.certify.reduce.three_axes`), multipliers searched
    per cell (:func:`~formsync_design.certify.multiregion.region_with_multipliers`).

    Returns ``(map, reduced conditions, box over the three axes)``.

    >>> from formsync_design.derive.agent import agent_conditions
    >>> from formsync_design.gains import GainBox
    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("lv2012")
    >>> m, _, rbox = region_agent(d, agent_conditions(d, "path:3"),
    ...                           GainBox.parse({"k_p": "1:2", "k_d": "5:10", "a_f": "1/2"}), resolution=2)
    >>> m.fractions["certified"]
    1.0
    """
    from formsync_design.certify.multiregion import region_with_multipliers
    from formsync_design.certify.reduce import three_axes
    from formsync_design.gains import GainBox, GainRange

    mult = agent_multipliers(design, box)
    full = GainBox(tuple(box.ranges) + tuple(GainRange(n, r.lo, r.hi) for n, r in mult.items()))
    red, rbox = three_axes(conditions, {r.name: (r.lo, r.hi) for r in full.ranges})
    given = {n: v for n, v in rbox.items() if n not in mult}
    m = region_with_multipliers(red, given, {n: r for n, r in mult.items() if n in rbox},
                                resolution=resolution, margin=margin)
    return m, red, rbox


@dataclass(frozen=True)
class AgentGainDesign:
    """The result of :func:`design_agent`.

    ``status``: ``"recommended"`` (a grid point is certified) or ``"not-found"``;
    ``gains``: the point with the largest certified margin ``margin``; ``multipliers``:
    the values of the searched multipliers that certify it; ``box``: the largest certified
    box around it (``None`` when none), relative half width ``scale``, its certificate
    ``box_result``; ``grid`` values per axis, ``points`` grid points tried.
    """

    status: str
    grid: int
    points: int
    gains: dict[str, Fraction]
    multipliers: dict[str, Fraction]
    margin: Fraction | None = None
    box: tuple[tuple[Fraction, Fraction], ...] | None = None
    scale: float = 0.0
    box_result: Any = None


def design_agent(design: Any, conditions: Any, box: Any, *, grid: int = 4) -> AgentGainDesign:
    """The point of a ``grid``-per-axis grid over ``box`` with the largest certified margin
    (multipliers searched, exact re-check, no SDP) and the largest certified box around it
    (:func:`~formsync_design.certify.growbox.largest_certified_box`, the multipliers held at
    their certifying values).

    >>> from formsync_design.derive.agent import agent_conditions
    >>> from formsync_design.gains import GainBox
    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("lv2012")
    >>> r = design_agent(d, agent_conditions(d, "path:3"),
    ...                  GainBox.parse({"k_p": "1:2", "k_d": "5:10", "a_f": "1/2"}), grid=2)
    >>> r.status, isinstance(r, AgentGainDesign)
    ('recommended', True)
    """
    from formsync_design.certify.growbox import largest_certified_box
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.certify.reduce import fix_gains

    mult = agent_multipliers(design, box)
    k = max(2, int(grid))
    axes = []
    for r in box.ranges:
        lo, hi = Fraction(r.lo), Fraction(r.hi)
        axes.append([lo] if lo == hi else [lo + (hi - lo) * Fraction(i, k - 1) for i in range(k)])
    best: tuple[Fraction, dict[str, Fraction], Any] | None = None
    points = 0
    for pt in itertools.product(*axes):
        points += 1
        point = dict(zip(box.names, pt))
        r = certify_with_multipliers(conditions, {n: (v, v) for n, v in point.items()}, mult,
                                     use_sdp=False)
        lb = r.margin_lower_bound
        if r.certified and lb is not None and (best is None or lb > best[0]):
            best = (lb, point, r)
    if best is None:
        return AgentGainDesign("not-found", k, points, {}, {})
    lb, point, res = best
    chosen = {n: Fraction(res.box[n].lo) for n in mult}
    fixed = fix_gains(conditions, chosen) if chosen else conditions
    ranges = tuple((Fraction(r.lo), Fraction(r.hi)) for r in box.ranges)
    cbox, s, cres = largest_certified_box(fixed, point, ranges)
    return AgentGainDesign("recommended", k, points, point, chosen, Fraction(lb), cbox, s, cres)
