"""Result objects of the certification stage (frozen dataclasses, ``StrEnum`` statuses).

Every ``to_dict()`` writes numbers with :func:`formsync_design.gains.json_number`:
an exact rational is a JSON number when it round-trips through a float, else
the string ``"p/q"``; ``±inf``/``nan`` are ``"inf"``/``"-inf"``/``"nan"``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from formsync_design.gains import GainBox, json_number
from formsync_design.notebook import NotebookViews

__all__ = [
    "Status",
    "SolverOutcome",
    "STATUS_MAP",
    "solver_outcome",
    "Witness",
    "FamilyMargin",
    "SolverStats",
    "KvCheck",
    "CertificationResult",
]


class Status(enum.StrEnum):
    """Verdict of a certification (of a box, or of one family over it)."""

    CERTIFIED = "certified"  # every block PD at every vertex, re-checked exactly/rigorously
    REFUTED = "refuted"  # an exactly checked witness (or a failing K_v condition)
    UNDECIDED = "undecided"  # inconclusive re-check, not multi-affine
    ERROR = "error"  # unknown solver status and nothing decided by the re-check


class SolverOutcome(enum.StrEnum):
    """What the optimization hint did (it never decides a verdict)."""

    OK = "ok"
    INACCURATE = "inaccurate"
    FAILED = "failed"
    ERROR = "error"
    SKIPPED = "skipped"


#: cvxpy status -> solver outcome.  Anything not listed maps to ``error``.
STATUS_MAP: dict[str, SolverOutcome] = {
    "optimal": SolverOutcome.OK,
    "optimal_inaccurate": SolverOutcome.INACCURATE,
    "infeasible": SolverOutcome.FAILED,
    "infeasible_inaccurate": SolverOutcome.FAILED,
    "unbounded": SolverOutcome.FAILED,
    "unbounded_inaccurate": SolverOutcome.FAILED,
    "infeasible_or_unbounded": SolverOutcome.FAILED,
    "user_limit": SolverOutcome.FAILED,
    "solver_error": SolverOutcome.FAILED,
}


def solver_outcome(raw: str) -> SolverOutcome:
    """Map a raw cvxpy status to a :class:`SolverOutcome` (unknown -> ``error``).

    >>> solver_outcome("optimal"), solver_outcome("something new")
    (<SolverOutcome.OK: 'ok'>, <SolverOutcome.ERROR: 'error'>)
    """
    return STATUS_MAP.get(str(raw), SolverOutcome.ERROR)


@dataclass(frozen=True)
class Witness:
    """An exactly checked counterexample.

    Attributes
    ----------
    point : dict gain -> Fraction
        A gain point of the box (a vertex).
    family : str
        Matrix name (``"Pi"``, ``"Theta_3"``, or ``"K_v"``).
    spacecraft : int or None
        1-based spacecraft (first of ``also`` when several share the matrix).
    also : tuple of int
        All spacecraft whose matrix is identical.
    x : tuple of int
        Vector in the family's row coordinates (scalar, per axis).
    rows : tuple of str
        Labels of the nonzero entries of ``x``.
    value : Fraction
        ``x^T (F(point) - margin I) x`` evaluated exactly (``<= 0``).
    rayleigh : Fraction
        ``x^T F x / x^T x``, an upper bound of ``lambda_min(F(point))``.
    covers_box : bool
        The same ``x`` refutes every point of the box (multi-affinity).
    """

    point: dict[str, Fraction]
    family: str
    spacecraft: int | None
    also: tuple[int, ...]
    x: tuple[int, ...]
    rows: tuple[str, ...]
    value: Fraction
    rayleigh: Fraction
    covers_box: bool

    def to_dict(self) -> dict[str, Any]:
        return {
            "point": {k: json_number(v) for k, v in self.point.items()},
            "family": self.family,
            "spacecraft": self.spacecraft,
            "also_spacecraft": list(self.also),
            "x": list(self.x),
            "rows": list(self.rows),
            "value": json_number(self.value),
            "rayleigh_quotient": json_number(self.rayleigh),
            "covers_box": self.covers_box,
        }


@dataclass(frozen=True)
class FamilyMargin:
    """Certified margin of one distinct family over the box.

    ``lower`` is a rigorous lower bound of ``min_box lambda_min`` (None unless
    the family is certified), ``hint`` the floating-point
    ``min_vertices lambda_min``, ``upper`` an exact upper bound from a witness.
    """

    name: str
    spacecraft: tuple[int, ...]
    size: int
    status: Status
    lower: Fraction | None
    hint: float
    upper: Fraction | None
    worst_vertex: tuple[Fraction, ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "spacecraft": list(self.spacecraft),
            "size": self.size,
            "status": str(self.status),
            "certified_lower_bound": None if self.lower is None else json_number(self.lower),
            "hint_min_lambda": self.hint,
            "upper_bound": None if self.upper is None else json_number(self.upper),
            "worst_vertex": [json_number(v) for v in self.worst_vertex],
        }


@dataclass(frozen=True)
class SolverStats:
    """What the optimization (a hint) did."""

    solver: str
    raw_status: str
    outcome: SolverOutcome
    solve_time: float
    iterations: int | None
    constraints: int
    value: float | None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "solver": self.solver,
            "raw_status": self.raw_status,
            "outcome": str(self.outcome),
            "solve_time_s": self.solve_time,
            "iterations": self.iterations,
            "constraints": self.constraints,
            "value": self.value,
            "note": self.note,
        }


@dataclass(frozen=True)
class KvCheck:
    """The switching-gain condition ``K_vi >= (ubar/2) max_v ||J_i^{-1} v||``."""

    holds: bool
    ubar: Fraction  # largest per-spacecraft bound
    kv: tuple[Fraction, ...]
    required: tuple[float, ...]
    failing: tuple[int, ...]
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "holds": self.holds,
            "ubar": json_number(self.ubar),
            "kv": [json_number(v) for v in self.kv],
            "required_kv": list(self.required),
            "failing_spacecraft": list(self.failing),
            "note": self.note,
        }


@dataclass(frozen=True)
class CertificationResult(NotebookViews):
    """Outcome of :func:`certify_box` (status plus evidence)."""

    status: Status
    gains: tuple[str, ...]
    box: GainBox
    margin: Fraction
    source: str
    graph: str
    n: int
    families: tuple[FamilyMargin, ...]
    witness: Witness | None
    solver: SolverStats
    argument: str
    recheck: dict[str, int]
    reason: str
    kv: KvCheck | None
    elapsed: float


    @property
    def certified(self) -> bool:
        return self.status == Status.CERTIFIED

    @property
    def margin_lower_bound(self) -> Fraction | None:
        """Rigorous lower bound of the smallest eigenvalue over all families and the box.

        ``None`` unless the result is ``certified``: an undecided or refuted box
        has no certified margin.
        """
        if self.status != Status.CERTIFIED:
            return None
        vals = [f.lower for f in self.families]
        if not vals or any(v is None for v in vals):
            return None
        return min(v for v in vals if v is not None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": str(self.status),
            "graph": self.graph,
            "n": self.n,
            "conditions": self.source,
            "box": self.box.to_dict(),
            "margin": json_number(self.margin),
            "certified_margin": None
            if self.margin_lower_bound is None
            else json_number(self.margin_lower_bound),
            "families": [f.to_dict() for f in self.families],
            "witness": None if self.witness is None else self.witness.to_dict(),
            "kv": None if self.kv is None else self.kv.to_dict(),
            "solver": self.solver.to_dict(),
            "argument": self.argument,
            "recheck": dict(self.recheck),
            "reason": self.reason,
            "elapsed_s": self.elapsed,
        }


