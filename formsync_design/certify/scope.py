"""The scope of a verdict: which system, which property, under which assumptions.

Every certificate the toolbox prints says what it is about, in one vocabulary:

* ``system``: ``formation`` (the N spacecraft on the given graph, closed through the graph)
  or ``tracking-loop`` (one spacecraft tracking its command, the command taken as an
  exogenous signal: the graph does not enter) or ``design-conditions`` (the design's own
  ``conditions(c)`` families, whatever system its author wrote them for: never a formation
  verdict by itself);
* ``property``: ``global-exponential``, ``almost-global``, ``local-exponential``,
  ``asymptotic`` (Lyapunov, non-strict), ``ultimate-bound`` (with the bound), or
  ``conditions`` (positive definiteness of the families, no dynamic property claimed);
* ``target``: what converges (``consensus`` of the full state, the ``reference``, the
  ``sliding surface``);
* ``assumptions``: what the proof takes as given (the boundary layer, the equilibrium,
  the operating region, the disturbance bound, a theorem's graph class);
* ``covers``: what part of the law the verdict is about (e.g. the linear part at the
  equilibrium, with the switching function realised as ``sat(x/phi)``);
* ``basis``: ``proof`` (exact or rigorously rounded re-check) or ``evidence``
  (simulation: never a proof).

>>> s = Scope(System.FORMATION, Property.LOCAL_EXPONENTIAL, "consensus", graph="ring:4", n=4,
...           assumptions=("sgn realised as sat(x/phi), phi = 1/100",))
>>> s.text()
'formation on ring:4 (N = 4): local-exponential stability of consensus [proof]; assumes: sgn realised as sat(x/phi), phi = 1/100'
>>> s.to_dict()["system"]
'formation'
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

__all__ = ["System", "Property", "Basis", "Scope"]


class System(enum.StrEnum):
    """Which system a verdict is about."""

    FORMATION = "formation"
    TRACKING_LOOP = "tracking-loop"
    DESIGN_CONDITIONS = "design-conditions"


class Property(enum.StrEnum):
    """Which property a verdict states."""

    GLOBAL_EXPONENTIAL = "global-exponential"
    ALMOST_GLOBAL = "almost-global"
    LOCAL_EXPONENTIAL = "local-exponential"
    ASYMPTOTIC = "asymptotic"
    ULTIMATE_BOUND = "ultimate-bound"
    CONDITIONS = "conditions"


class Basis(enum.StrEnum):
    """What decided it."""

    PROOF = "proof"
    EVIDENCE = "evidence"


@dataclass(frozen=True)
class Scope:
    """The scope of one verdict (module docstring)."""

    system: System
    property: Property
    target: str
    graph: str | None = None
    n: int | None = None
    assumptions: tuple[str, ...] = ()
    covers: str = ""
    basis: Basis = Basis.PROOF
    bound: str = ""

    def text(self) -> str:
        """One line: system, property, target, basis, then assumptions and coverage."""
        where = str(self.system)
        if self.system == System.FORMATION and self.graph is not None:
            where = f"formation on {self.graph} (N = {self.n})"
        prop = (f"{self.property} of the {self.target}" if self.property == Property.CONDITIONS
                else f"{self.property} stability of {self.target}")
        if self.property == Property.ULTIMATE_BOUND:
            prop = f"ultimate bound {self.bound} of {self.target}"
        out = f"{where}: {prop} [{self.basis}]"
        if self.covers:
            out += f"; covers: {self.covers}"
        if self.assumptions:
            out += "; assumes: " + "; ".join(self.assumptions)
        return out

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"system": str(self.system), "property": str(self.property),
                               "target": self.target, "basis": str(self.basis),
                               "assumptions": list(self.assumptions), "covers": self.covers}
        if self.graph is not None:
            out.update(graph=self.graph, n=self.n)
        if self.bound:
            out["bound"] = self.bound
        return out
