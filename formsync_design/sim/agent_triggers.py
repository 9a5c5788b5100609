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
import sympy as sp

from formsync_design.sim.agent_kernel import ATTITUDE_SIZE
from formsync_design.sim.bridge import sympy_to_casadi
from formsync_design.spec.agent import AgentDesign, AgentView, agent_expressions, sgn
from formsync_design.spec.declarations import GainKind, GainRole

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
    ex = agent_expressions(design, m)
    v: AgentView = ex["view"]
    na = ATTITUDE_SIZE[design.representation]
    own = ca.SX.sym("own", na + 3 + design.decl.state_size)
    held = ca.SX.sym("held", na + 3)
    kept = ca.SX.sym("kept", max(kept_size(design), 1))
    J = ca.SX.sym("J", 3, 3)
    t = ca.SX.sym("t")
    nb = ca.SX.sym("nbrs", na + 3 + design.decl.state_size, max(m, 1))
    a = ca.SX.sym("a", max(m, 1))
    b = ca.SX.sym("b")
    ref = ca.SX.sym("ref", na + 6)
    gsyms: list[sp.Symbol] = []
    for g in design.decl.gains:
        if g.role == GainRole.CONTROLLER:
            gsyms += (list(sp.symbols(f"{g.name}_1:4", positive=True)) if g.kind == GainKind.DIAG
                      else [g.symbol])
    gains = ca.SX.sym("gains", max(len(gsyms), 1))
    phi = ca.SX.sym("phi")
    phi_s = sp.Symbol("phi", positive=True)
    bind: dict[Any, Any] = {v.t: t, phi_s: phi}
    for k, s in enumerate(gsyms):
        bind[s] = gains[k]
    for i in range(3):
        for j in range(3):
            bind[v.J[i, j]] = J[i, j]

    def bind_state(sym: Any, vec: Any) -> None:
        for k, s in enumerate(sym.attitude_symbols()):
            bind[s] = vec[k]
        for k in range(3):
            bind[sym.w[k]] = vec[na + k]

    bind_state(v.own, own)
    bind_state(v.held, held)
    for k, n in enumerate(v.nbrs):
        bind_state(n, nb[:, k])
        bind[n.a] = a[k]
    if design.decl.leader:
        bind[v.b] = b
        for k, s in enumerate(v.ref.attitude_symbols()):
            bind[s] = ref[k]
        for k in range(3):
            bind[v.ref.w[k]] = ref[na + k]
            bind[v.ref.wdot[k]] = ref[na + 3 + k]
    off = 0
    for name, size in design.decl.hold:
        for k in range(size):
            bind[v.kept[name][k]] = kept[off + k]
        off += size
    memo: dict = {}

    def cas(e: Any) -> Any:
        e = sp.sympify(e)
        e = e.replace(sgn, sp.sign) if switch == "sgn" else e.replace(
            sgn, (lambda x: sp.Max(-1, sp.Min(1, x / phi_s))) if switch == "sat"
            else (lambda x: sp.tanh(x / phi_s)))
        return sympy_to_casadi(e, bind, memo)

    ins = [own, held, kept, J, t, nb, a, b, ref, gains, phi]
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
