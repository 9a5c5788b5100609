"""An agent design's declarations and functions, validated at load: ``PLANT`` and
``ACTUATORS``, the relative-orbit plant's fixed declarations, ``STATES``, ``HOLD``,
``LEADER``, ``MEASURED`` (:func:`parse_agent_declarations`) and which functions the file
must and may define (:func:`check_agent_functions`).  The contract itself is the module
docstring of :mod:`formsync_design.spec.agent`.

>>> d = parse_agent_declarations({"GAINS": {"k": {}}, "REPRESENTATION": "mrp"}, "demo.py")
>>> d.representation, d.plant, d.actuators, d.states
('mrp', 'attitude', 'torque', ())
>>> parse_agent_declarations({"GAINS": {"k": {}}, "PLANT": "orbit"}, "demo.py")
Traceback (most recent call last):
...
formsync_design.errors.DerivationError: demo.py: PLANT: expected one of ['attitude', 'relative-orbit'], received 'orbit'
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from formsync_design.errors import DerivationError
from formsync_design.spec.agent_view import (
    ACTUATORS,
    AGENT_REPRESENTATIONS,
    PLANTS,
    QUANTITIES,
    AgentDeclarations,
    AgentView,
)
from formsync_design.spec.declarations import GainRole, parse_declarations

__all__ = ["FUNCTIONS", "ORBIT_FUNCTIONS", "parse_agent_declarations", "check_agent_functions"]

#: The functions of a design on the attitude plant (:mod:`formsync_design.spec.agent`).
FUNCTIONS = ("controller", "states", "event", "next_interval", "monitors", "hold")

#: The functions of a design on the relative-orbit plant (:mod:`formsync_design.spec.tracking`).
ORBIT_FUNCTIONS = ("controller", "lyapunov", "orbit_controller", "lqr_weights")


def _plant(attrs: Mapping[str, Any], where: str) -> tuple[str, str]:
    """``(PLANT, ACTUATORS)``, validated (module docstring)."""
    plant = attrs.get("PLANT", "attitude")
    if not isinstance(plant, str) or plant not in PLANTS:
        raise DerivationError(f"{where}: PLANT: expected one of {list(PLANTS)}, received "
                              f"{plant!r}")
    actuators = attrs.get("ACTUATORS", "thrusters" if plant == "relative-orbit" else "torque")
    want = "thrusters" if plant == "relative-orbit" else "torque"
    if not isinstance(actuators, str) or actuators not in ACTUATORS or actuators != want:
        raise DerivationError(f"{where}: ACTUATORS: expected {want!r} on the {plant} plant, "
                              f"received {actuators!r}")
    return plant, actuators


def _check_orbit_plant(attrs: Mapping[str, Any], base: Any, where: str) -> None:
    """The declarations the relative-orbit plant's simulator and derivation assume."""
    need = (("REPRESENTATION", base.representation, "mrp"), ("SAMPLING", base.sampling, "periodic"),
            ("GRAPHS", tuple(base.graphs), ()), ("LEADER", attrs.get("LEADER", False), True))
    for name, got, want in need:
        if got != want:
            raise DerivationError(f"{where}: {name}: expected {want!r} on the relative-orbit "
                                  f"plant (one spacecraft tracking its reference), received "
                                  f"{got!r}")
    for name in ("STATES", "HOLD"):
        if attrs.get(name):
            raise DerivationError(f"{where}: {name}: expected none on the relative-orbit plant, "
                                  f"received {attrs[name]!r}")


def parse_agent_declarations(attrs: Mapping[str, Any], where: str) -> AgentDeclarations:
    plant, actuators = _plant(attrs, where)
    base = parse_declarations(attrs, where, weights=plant == "relative-orbit")
    if plant == "relative-orbit":
        _check_orbit_plant(attrs, base, where)
    if base.representation not in AGENT_REPRESENTATIONS:
        raise DerivationError(f"{where}: REPRESENTATION: expected one of "
                              f"{list(AGENT_REPRESENTATIONS)} for an agent design, received "
                              f"{base.representation!r}")
    if base.switching is not None and callable(attrs.get("lagrangian_controller")):
        # the Lagrangian view's per-spacecraft switching gain is one controller gain here
        base = replace(base, gains=tuple(replace(g, role=GainRole.CONTROLLER)
                                         if g.role == GainRole.SWITCHING else g
                                         for g in base.gains))
    if base.switching is not None:
        raise DerivationError(f"{where}: GAINS[{base.switching!r}].role: expected 'controller' or "
                              "'multiplier' in an agent design (a switching gain is a controller "
                              "gain there), received 'switching'")
    taken = {g.name for g in base.gains} | {"q", "q0", "sigma", "R", "w", "J", "t", "b", "z"}
    states = _sized_names(attrs.get("STATES", {}), "STATES", taken, where)
    hold = _sized_names(attrs.get("HOLD", {}), "HOLD", set(), where)
    if hold and base.sampling == "continuous":
        raise DerivationError(f"{where}: HOLD: expected a sampled design (SAMPLING 'event', "
                              "'self-triggered' or 'periodic'), received SAMPLING 'continuous'")
    leader = attrs.get("LEADER", False)
    if not isinstance(leader, bool):
        raise DerivationError(f"{where}: LEADER: expected True or False, received {leader!r}")
    measured = attrs.get("MEASURED", ("attitude", "rate", "reference")
                         if plant == "relative-orbit" else QUANTITIES)
    if isinstance(measured, str) or not isinstance(measured, (list, tuple)) or not all(
            isinstance(m, str) and m in QUANTITIES for m in measured):
        raise DerivationError(f"{where}: MEASURED: expected quantities among {list(QUANTITIES)}, "
                              f"received {measured!r}")
    return AgentDeclarations(representation=base.representation, gains=base.gains,
                             graphs=base.graphs, sampling=base.sampling, states=tuple(states),
                             leader=leader, measured=tuple(measured), hold=tuple(hold),
                             plant=plant, actuators=actuators)


def _sized_names(raw: Any, what: str, taken: set[str], where: str) -> list[tuple[str, int]]:
    """``{name: size}`` of ``STATES`` / ``HOLD``, validated (identifiers, sizes 1..12)."""
    if not isinstance(raw, Mapping):
        raise DerivationError(f"{where}: {what}: expected a dict name -> size, received "
                              f"{type(raw).__name__}")
    out: list[tuple[str, int]] = []
    for n, k in raw.items():
        if not isinstance(n, str) or not n.isidentifier() or n in taken or n.startswith("_"):
            kind = "state names" if what == "STATES" else "names"
            raise DerivationError(f"{where}: {what}: expected {kind} that are identifiers "
                                  f"unlike the gains and the view's quantities, received {n!r}")
        if not isinstance(k, int) or isinstance(k, bool) or not 1 <= k <= 12:
            raise DerivationError(f"{where}: {what}[{n!r}]: expected a size 1..12, received {k!r}")
        out.append((n, k))
    return out


def check_agent_functions(attrs: Mapping[str, Any], decl: AgentDeclarations, where: str) -> dict:
    fns: dict[str, Callable[[AgentView], Any]] = {}
    if decl.plant == "relative-orbit":
        for fn in ORBIT_FUNCTIONS:
            f = attrs.get(fn)
            if not callable(f):
                got = "none" if f is None else f"a {type(f).__name__}"
                raise DerivationError(f"{where}: expected a function {fn}(view) on the "
                                      f"relative-orbit plant, received {got}")
            fns[fn] = f
        other = [fn for fn in FUNCTIONS if fn != "controller" and callable(attrs.get(fn))]
        if other:
            raise DerivationError(f"{where}: expected only {list(ORBIT_FUNCTIONS)} on the "
                                  f"relative-orbit plant, received {other}")
        return fns
    for fn in FUNCTIONS:
        f = attrs.get(fn)
        if f is None:
            continue
        if not callable(f):
            raise DerivationError(f"{where}: expected {fn} to be a function {fn}(view), "
                                  f"received a {type(f).__name__}")
        fns[fn] = f
    if "controller" not in fns:
        raise DerivationError(f"{where}: expected a function controller(view), received none")
    for attr, sized, fn in (("STATES", decl.states, "states"), ("HOLD", decl.hold, "hold")):
        if sized and fn not in fns:
            raise DerivationError(f"{where}: expected a function {fn}(view) for {attr} "
                                  f"{[n for n, _ in sized]}, received none")
        if not sized and fn in fns:
            raise DerivationError(f"{where}: expected {attr} declared for the function "
                                  f"{fn}(view), received none")
    need = {"event": "event", "self-triggered": "next_interval"}.get(decl.sampling)
    if need is not None and need not in fns:
        raise DerivationError(f"{where}: expected a function {need}(view) for SAMPLING "
                              f"{decl.sampling!r}, received none")
    for fn, rule in (("event", "event"), ("next_interval", "self-triggered")):
        if fn in fns and decl.sampling != rule:
            raise DerivationError(f"{where}: expected SAMPLING = {rule!r} with a function "
                                  f"{fn}(view), received SAMPLING = {decl.sampling!r}")
    if decl.states and decl.sampling != "continuous":
        raise DerivationError(f"{where}: expected SAMPLING 'continuous' for a design with "
                              f"controller STATES, received {decl.sampling!r}")
    return fns
