"""Result types of the paper-versus-derivation comparison, and the exact
coefficient-by-coefficient comparison of two matrix families.

A :class:`Finding` carries the :class:`Computation` that decided it (what was
computed, where, and the value obtained); its verdict is a function of that
value, computed in the same run (see :mod:`.compare`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sps

from formsync_design.derive.families import MatrixFamily
from formsync_design.gains import json_number

__all__ = [
    "Verdict",
    "VERDICTS",
    "ComputationKind",
    "Computation",
    "Finding",
    "FamilyDifference",
    "compare_families",
]


class Verdict(StrEnum):
    """Outcome of one comparison."""

    AGREES = "agrees"  #: the printed expression equals the derived one
    DIFFERS = "differs"  #: they differ; a concrete counterexample is given
    HOLDS = "holds"  #: a printed claim is true of the derived object
    FAILS = "fails"  #: a printed claim is false; a counterexample is given
    SUFFICIENT = "sufficient"  #: a printed rule implies the derived condition but is stricter


VERDICTS: tuple[str, ...] = tuple(v.value for v in Verdict)


class ComputationKind(StrEnum):
    """How a verdict was decided."""

    SYMBOLIC_IDENTITY = "symbolic identity"
    EXACT_EVALUATION = "exact evaluation at a stated point"
    EXACT_COEFFICIENTS = "exact rational coefficients, compared one by one"
    EIGENVALUES = "eigenvalues at a stated point"


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, bool | str) or v is None:
        return v
    if isinstance(v, int | float | Fraction | np.integer | np.floating):
        return json_number(v)
    return str(v)


@dataclass(frozen=True)
class Computation:
    """The computation that decided a verdict.

    Attributes
    ----------
    kind : ComputationKind
    expression : str
        What was computed (plain text, e.g. ``"printed_skew(q) v - q x v"``).
    point : str
        Where it was evaluated (``""`` for an identity in all variables).
    value : Any
        The computed value the verdict follows from (JSON-able).

    Examples
    --------
    >>> c = Computation(ComputationKind.SYMBOLIC_IDENTITY, "x - x", "", "0")
    >>> c.to_dict()["kind"]
    'symbolic identity'
    """

    kind: ComputationKind
    expression: str
    point: str
    value: Any

    def summary(self) -> str:
        """One line: kind, expression, point."""
        at = f" at {self.point}" if self.point else ""
        return f"{self.kind}: {self.expression}{at}"

    def to_dict(self) -> dict:
        """JSON-ready dictionary (numbers by :func:`~formsync_design.gains.json_number`)."""
        return {"kind": str(self.kind), "expression": self.expression, "point": self.point,
                "value": _jsonable(self.value)}


@dataclass(frozen=True)
class Finding:
    """One row of the paper-versus-derived table.

    Attributes
    ----------
    key : str
        Short identifier (``"B-formula"``, ``"Pi-M"``, ...).
    meaning : str
        The question the verdict answers, in one line.
    item : str
        What is compared (Markdown with inline LaTeX).
    paper : str
        The printed expression or claim.
    derived : str
        The derived expression or fact.
    verdict : Verdict
    evidence : str
        Why (the argument around the computation).
    computation : Computation
        What decided the verdict, and the value obtained.
    counterexample : dict
        Numbers a reader can check (empty when the verdict needs none).
    """

    key: str
    meaning: str
    item: str
    paper: str
    derived: str
    verdict: Verdict
    evidence: str
    computation: Computation
    counterexample: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if str(self.verdict) not in VERDICTS:
            raise ValueError(f"expected a verdict in {VERDICTS}, received {self.verdict!r}")
        object.__setattr__(self, "verdict", Verdict(str(self.verdict)))

    def to_dict(self) -> dict:
        """JSON-ready dictionary.

        >>> from formsync_design.derive.compare import model_findings
        >>> model_findings()[0].to_dict()["verdict"]
        'fails'
        """
        return {
            "key": self.key, "meaning": self.meaning, "verdict": str(self.verdict),
            "item": self.item, "paper": self.paper, "derived": self.derived,
            "evidence": self.evidence, "computation": self.computation.to_dict(),
            "counterexample": _jsonable(self.counterexample),
        }


@dataclass(frozen=True)
class FamilyDifference:
    """Result of :func:`compare_families` on a block.

    Attributes
    ----------
    compared : int
        Number of (monomial, row, column) coefficients compared.
    differing : int
        How many of them differ.
    first : tuple
        Up to three differences ``(row label, column label, monomial, a, b)``.
    """

    compared: int
    differing: int
    first: tuple[tuple[str, str, str, Fraction, Fraction], ...]

    @property
    def equal(self) -> bool:
        return self.differing == 0


def _monomial(gains: tuple[str, ...], e: tuple[int, ...]) -> str:
    parts = [g if k == 1 else f"{g}^{k}" for g, k in zip(gains, e) if k]
    return "*".join(parts) or "1"


def _block_sum(f: MatrixFamily, terms: list, den: int, rows: slice, cols: slice) -> Any:
    out = sps.csr_matrix((f.size, f.size), dtype=np.int64)
    for t in terms:
        out = out + sps.csr_matrix(t.matrix, dtype=np.int64) * int(t.coefficient * den)
    return out[rows, cols]


def compare_families(
    a: MatrixFamily, b: MatrixFamily, rows: slice = slice(None), cols: slice = slice(None)
) -> FamilyDifference:
    """Compare two families exactly, coefficient by coefficient, on a block.

    Works on the sparse terms (no dense symbolic matrix), so it scales to
    large graphs: for every monomial in the gains, the rational coefficient
    matrices of ``a`` and ``b`` are scaled to a common integer denominator and
    subtracted.

    Examples
    --------
    >>> from formsync_design.derive.families import family_from_entries
    >>> f = family_from_entries("F", 2, {(0, 0): {(1, 0, 0): Fraction(1, 2)}})
    >>> g = family_from_entries("G", 2, {(0, 0): {(1, 0, 0): Fraction(1, 3)}})
    >>> compare_families(f, f).equal, compare_families(f, g).differing
    (True, 1)
    """
    if a.size != b.size or a.gains != b.gains:
        raise ValueError(f"expected families of one size and gains, received {a.size} and {b.size}")
    monos = sorted({t.exponents for t in a.terms} | {t.exponents for t in b.terms})
    labels = a.row_labels or tuple(str(k) for k in range(a.size))
    r0 = rows.indices(a.size)[0]
    c0 = cols.indices(a.size)[0]
    compared = 0
    differing = 0
    first: list = []
    for mono in monos:
        ta = [t for t in a.terms if t.exponents == mono]
        tb = [t for t in b.terms if t.exponents == mono]
        den = math.lcm(*(t.coefficient.denominator for t in ta + tb))
        bound = sum(abs(int(t.coefficient * den)) * int(np.abs(t.dense()).max(initial=0))
                    for t in ta + tb) if a.size <= 64 else 0
        if bound >= 2**62:  # pragma: no cover - never with the paper's families
            raise ValueError("expected family coefficients below 2^62")
        A = _block_sum(a, ta, den, rows, cols)
        B = _block_sum(b, tb, den, rows, cols)
        compared += len(set(zip(*A.nonzero())) | set(zip(*B.nonzero())))
        D = (A - B).tocoo()
        D.eliminate_zeros()
        differing += D.nnz
        for i, j in sorted(zip(D.row.tolist(), D.col.tolist()))[: 3 - len(first)]:
            first.append((labels[r0 + i], labels[c0 + j], _monomial(a.gains, mono),
                          Fraction(int(A[i, j]), den), Fraction(int(B[i, j]), den)))
    return FamilyDifference(compared=compared, differing=differing, first=tuple(first))
