"""Design with constraints (issue 15, item 6), any design: gains that maximise the certified
decay rate subject to a delay margin, a link-failure set and a torque limit, and the
largest certified box around them.

Method: a grid of candidate gain points over the box (``resolution`` per axis,
cell centres); each candidate is kept when the ``searched`` certificate holds,
its processing-delay margin is at least ``min_delay`` and (if a graph set is
given) a common Lyapunov function over the set exists at that point; the
objective is the certified decay rate (:func:`.performance.certified_decay_rate`,
exact re-check).  Around the winner, the largest box ``g (1 +- s)`` (same
relative half-width ``s`` on every gain, bisection) on which the ``searched``
certificate holds, when a graph set is given the common function too, and
when ``min_delay > 0`` the processing-delay margin exceeds ``min_delay`` for
every gain of the box (:func:`.celldelay.delay_cell_check`, proven
monotonicity).  With ``torque_limit`` (and ``inertias``, ``att_radius``,
``rate_radius``) a candidate is kept only when its certified peak-torque bound
(:func:`.torque.peak_torque_bound`) from that initial set is within the limit, and
the box only when the bound valid for every gain of the box is
(:func:`.torque.torque_limit_check`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from formsync_design.analysis.celldelay import delay_cell_check
from formsync_design.analysis.certificates import certify
from formsync_design.analysis.delay import delay_margin
from formsync_design.analysis.modecheck import split_box
from formsync_design.analysis.modes import mode_model
from formsync_design.analysis.performance import certified_decay_rate
from formsync_design.analysis.results import Verdict, jsonify
from formsync_design.analysis.spectrum import laplacian_spectrum
from formsync_design.analysis.switching import certify_switching
from formsync_design.errors import InputError
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph

__all__ = ["ConstrainedDesign", "design_with_constraints"]


@dataclass(frozen=True)
class ConstrainedDesign:
    """Recommended gains, their certified numbers, and the certified box around them."""

    status: Verdict
    graph: str
    gains: tuple[Fraction, ...] | None
    alpha: Fraction
    delay_margin: float
    box: GainBox | None
    candidates: int
    feasible: int
    reason: str
    names: tuple[str, ...] = ("K_o", "K_q", "beta")
    torque_bound: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"status": str(self.status), "graph": self.graph,
                        "gains": None if self.gains is None else dict(zip(self.names, self.gains)),
                        "alpha": self.alpha, "delay_margin_s": self.delay_margin,
                        "box_torque_bound_N_m": self.torque_bound,
                        "box": None if self.box is None else self.box.to_dict(),
                        "candidates": self.candidates, "feasible": self.feasible, "reason": self.reason})


def _grid(box: GainBox, k: int) -> list[tuple[Fraction, ...]]:
    axes = []
    for r in box.ranges:
        if r.is_point:
            axes.append([r.lo])
        else:
            axes.append([r.lo + (r.hi - r.lo) * Fraction(2 * i + 1, 2 * k) for i in range(k)])
    pts: list[tuple[Fraction, ...]] = [()]
    for ax in axes:
        pts = [p + (x,) for p in pts for x in ax]
    return pts


def design_with_constraints(graph: Any, box: Any, *, min_delay: float = 0.0, graph_set: Any = None,
                            resolution: int = 4, spec: Any = None, torque_limit: float | None = None,
                            inertias: Any = None, att_radius: Any = Fraction(1, 10),
                            rate_radius: Any = Fraction(1, 100)) -> ConstrainedDesign:
    """Recommend gains maximising the certified decay rate under the constraints.

    Examples
    --------
    >>> d = design_with_constraints("ring:6", {"K_o": (1, 3), "K_q": (0.2, 1), "beta": (0.1, 0.3)},
    ...                             min_delay=0.5, resolution=2)
    >>> d.status.value, d.delay_margin >= 0.5, d.box is not None
    ('certified', True, True)
    >>> pd = design_with_constraints("ring:6", {"k_p": (0.2, 1), "k_d": (1, 3)}, min_delay=0.5, resolution=2,
    ...                              spec="pd_consensus")
    >>> pd.names, pd.status.value, pd.delay_margin >= 0.5
    (('k_p', 'k_d'), 'certified', True)
    """
    g = make_graph(graph)
    mm = mode_model(spec)
    b, given = split_box(mm, box)
    if given is not None:
        raise InputError(f"expected a box of the controller gains {mm.names} (the searched certificate has "
                         f"no multiplier), received {given}")
    names = mm.names
    if min_delay < 0 or not math.isfinite(min_delay):
        raise InputError(f"expected a non-negative finite delay, received {min_delay:g}")
    if torque_limit is not None and inertias is None:
        raise InputError("expected inertias with a torque limit, received none")
    spectrum = laplacian_spectrum(g)
    gs = None if graph_set is None else [make_graph(x) for x in graph_set]
    best: tuple[Fraction, tuple[Fraction, ...], float] | None = None
    pts = _grid(b, int(resolution))
    feasible = 0

    def torque_ok(gains: Any) -> tuple[bool, float | None]:
        if torque_limit is None:
            return True, None
        from formsync_design.analysis.torque import torque_limit_check

        tc = torque_limit_check(g, gains, torque_limit, inertias, att_radius, rate_radius, spec=spec,
                                spectrum=spectrum)
        return tc.status is Verdict.CERTIFIED, tc.bound.peak

    for p in pts:
        pt = dict(zip(names, p))
        if certify(g, pt, "searched", spec=spec, spectrum=spectrum).status is not Verdict.CERTIFIED:
            continue
        dm = delay_margin(g, p, "processing", spec=spec).margin
        if dm < min_delay:
            continue
        if gs is not None and certify_switching(gs, pt, spec=spec).status is not Verdict.CERTIFIED:
            continue
        if not torque_ok(p)[0]:
            continue
        feasible += 1
        a = certified_decay_rate(g, pt, "searched", spec=spec).alpha
        if best is None or a > best[0]:
            best = (a, p, dm)
    if best is None:
        # a finite grid finding nothing is no proof that nothing exists: undecided, not refuted
        return ConstrainedDesign(Verdict.UNDECIDED, g.name, None, Fraction(0), 0.0, None, len(pts), 0,
                                 "no candidate gain point meets every constraint (refine the grid or "
                                 "relax the constraints)", names)
    a, p, dm = best

    def ok(s: Fraction) -> tuple[GainBox, float | None] | None:
        bx = GainBox.parse({n: (x * (1 - s), x * (1 + s)) for n, x in zip(names, p)}, names)
        if certify(g, bx, "searched", spec=spec, spectrum=spectrum).status is not Verdict.CERTIFIED:
            return None
        if gs is not None and certify_switching(gs, bx, spec=spec).status is not Verdict.CERTIFIED:
            return None
        # every gain of the box, not only its centre: the delay margin by proven monotonicity
        if min_delay > 0 and delay_cell_check(g, bx, min_delay, "processing",
                                              spec=spec).status is not Verdict.CERTIFIED:
            return None
        # and the torque bound valid for every gain of the box
        good, peak = torque_ok(bx)
        return (bx, peak) if good else None

    lo, hi = Fraction(0), Fraction(1, 2)
    found = ok(lo)
    for _ in range(10):
        mid = (lo + hi) / 2
        got = ok(mid)
        if got is not None:
            lo, found = mid, got
        else:
            hi = mid
    return ConstrainedDesign(Verdict.CERTIFIED, g.name, p, a, dm, None if found is None else found[0],
                             len(pts), feasible,
                             f"best certified decay rate over {feasible} feasible of {len(pts)} candidates; "
                             f"certified box = gains x (1 +- {float(lo):.3g})", names,
                             None if found is None else found[1])
