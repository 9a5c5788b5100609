"""Trigger functions of sampled agent designs that keep values at their updates (``HOLD``).

A design declaring ``HOLD = {name: size}`` computes ``hold(v)`` at each of its own updates
and its ``event(v)`` / ``next_interval(v)`` read the kept values ``v.kept[name]``
(:mod:`formsync_design.spec.agent`).  This module translates those three functions once per
in-degree ``m`` from SymPy to CasADi through the one numeric bridge
:func:`~formsync_design.sim.bridge.sympy_to_casadi`, with the inputs of the kernel's trigger
functions (:func:`~formsync_design.sim.agent_kernel.agent_law`) plus ``kept`` (the kept
values in declaration order):

``(own, held, kept, J, t, nbrs, a, b, ref, gains, phi) -> hold | g | tau``

``own`` is the attitude entries and rate (``held``: the last broadcast), ``nbrs`` one
column per in-neighbour (attitude entries, rate), ``ref`` the reference's attitude entries,
rate and rate derivative, ``gains`` the controller gains in kernel order
(:func:`~formsync_design.sim.agent_kernel.gain_vector`).

>>> from formsync_design.spec.agent import agent_design_from_functions
>>> d = agent_design_from_functions(
...     lambda v: -v.k * v.w, gains={"k": {}}, sampling="event", hold={"w0": 3},
...     hold_fn=lambda v: {"w0": v.w}, event=lambda v: ((v.w - v.kept["w0"]).T
...     * (v.w - v.kept["w0"]))[0, 0] - v.k**2)
>>> f = kept_trigger_functions(d, 0)
>>> float(f.hold(own=[0, 0, 0, 1, 1, 2, 3])["hold"][2])
3.0
>>> float(f.event(own=[0, 0, 0, 1, 2, 2, 3], kept=[1, 2, 3], gains=[0.5])["g"])
0.75
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca

from formsync_design.sim.agent_kernel import law_inputs
from formsync_design.spec.agent import AgentDesign
from formsync_design.spec.agent_view import AgentView

__all__ = ["KeptTriggers", "kept_trigger_functions", "kept_size"]


@dataclass(frozen=True)
class KeptTriggers:
    """The translated functions of one in-degree: ``hold`` (output ``hold``, the kept values
    stacked), ``event`` (``g``) and ``next_interval`` (``tau``), ``None`` when absent."""

    m: int
    hold: ca.Function
    event: ca.Function | None
    next_interval: ca.Function | None


def kept_size(design: AgentDesign) -> int:
    """Entries of the kept values per spacecraft."""
    return sum(k for _, k in design.decl.hold)


_CACHE: dict[tuple[str, int, str], KeptTriggers] = {}


def kept_trigger_functions(design: AgentDesign, m: int, switch: str = "sgn") -> KeptTriggers:
    """The kept-value trigger functions of a spacecraft with ``m`` in-neighbours (cached by
    the design's key)."""
    ck = (design.key, m, switch)
    hit = _CACHE.get(ck)
    if hit is not None:
        return hit
    li = law_inputs(design, m)
    ex = li.expressions
    v: AgentView = ex["view"]
    bind = li.bind
    kept = ca.SX.sym("kept", max(kept_size(design), 1))
    off = 0
    for name, size in design.decl.hold:
        for k in range(size):
            bind[v.kept[name][k]] = kept[off + k]
        off += size
    memo: dict = {}

    def cas(e: Any) -> Any:
        return li.translate(e, switch, memo)

    ins = [li.own, li.held, kept, li.J, li.t, li.nbrs, li.a, li.b, li.ref, li.gains, li.phi]
    names = ["own", "held", "kept", "J", "t", "nbrs", "a", "b", "ref", "gains", "phi"]
    hold_out = ca.vertcat(*[cas(ex["hold"][n]) for n, _ in design.decl.hold]) \
        if design.decl.hold else ca.SX.zeros(1)
    out = KeptTriggers(
        m=m,
        hold=ca.Function(f"agent_hold_{m}", ins, [hold_out], names, ["hold"]),
        event=ca.Function(f"agent_kept_event_{m}", ins, [cas(ex["event"])], names, ["g"])
        if "event" in ex else None,
        next_interval=ca.Function(f"agent_kept_tau_{m}", ins, [cas(ex["next_interval"])], names,
                                  ["tau"]) if "next_interval" in ex else None,
    )
    _CACHE[ck] = out
    return out
