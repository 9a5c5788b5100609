"""Gain-parametrized symmetric matrix families, the interface between
derivation and certification.

A :class:`MatrixFamily` is a symmetric matrix valued polynomial in the gains,
stored exactly as

    F(p) = sum_k  c_k * p^{e_k} * G_k ,      full matrix = F(p) (x) I_b

with ``c_k`` a rational scalar, ``p^{e_k}`` a monomial in the gains (exponent
tuple ``e_k``), ``G_k`` an integer matrix (dense ``numpy.int64`` or
``scipy.sparse``), and ``b = block_size`` the Kronecker block (3 for the
x, y, z axes, which decouple in the paper's closed loop).  Because the
certification only needs eigenvalues, ``F`` (not ``F (x) I_b``) is what is
checked; ``row_labels`` name the rows of ``F`` in order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sp

__all__ = ["GAIN_NAMES", "FamilyTerm", "MatrixFamily", "family_from_sympy", "family_from_entries"]

#: Canonical gain order used throughout the toolbox.
GAIN_NAMES: tuple[str, ...] = ("K_o", "K_q", "beta")


@dataclass(frozen=True)
class FamilyTerm:
    """One term ``coefficient * prod(gain**exponent) * matrix``."""

    exponents: tuple[int, ...]
    coefficient: Fraction
    matrix: Any  # np.ndarray[int64] or scipy.sparse matrix with integer entries

    def dense(self) -> np.ndarray:
        m = self.matrix
        return np.asarray(m.todense() if sp.issparse(m) else m, dtype=np.int64)


@dataclass(frozen=True)
class MatrixFamily:
    """A symmetric matrix that is a polynomial in the gains (see module doc).

    Parameters
    ----------
    name : str
        ``"Theta_i"`` (1-based spacecraft) or ``"Pi"`` or similar.
    gains : tuple of str
        Gain names, the order of every exponent tuple and evaluation point.
    terms : tuple of FamilyTerm
    size : int
        Order of the scalar matrix ``F``.
    block_size : int
        Kronecker block ``b``: the full matrix is ``F (x) I_b``.
    row_labels : tuple of str
        Names of the rows of ``F`` (e.g. ``"qdot_1"``, ``"s_1"``).
    spacecraft : int or None
        1-based spacecraft this family belongs to, if any.

    Examples
    --------
    >>> import numpy as np
    >>> from fractions import Fraction
    >>> f = MatrixFamily("F", ("K_o", "K_q", "beta"),
    ...     (FamilyTerm((1, 0, 0), Fraction(1), np.eye(2, dtype=np.int64)),
    ...      FamilyTerm((0, 0, 1), Fraction(-1), np.array([[1, -1], [-1, 1]]))), 2)
    >>> f.evaluate((2.0, 0.0, 0.5)).tolist()
    [[1.5, 0.5], [0.5, 1.5]]
    >>> f.is_multiaffine
    True
    """

    name: str
    gains: tuple[str, ...]
    terms: tuple[FamilyTerm, ...]
    size: int
    block_size: int = 3
    row_labels: tuple[str, ...] = field(default=())
    spacecraft: int | None = None

    def __post_init__(self) -> None:
        for t in self.terms:
            if len(t.exponents) != len(self.gains):
                raise ValueError(
                    f"expected exponent tuples of length {len(self.gains)}, received {t.exponents}"
                )
            if t.matrix.shape != (self.size, self.size):
                raise ValueError(
                    f"expected {self.size}x{self.size} term matrices, received {t.matrix.shape}"
                )

    # -- structure -------------------------------------------------------
    @property
    def is_multiaffine(self) -> bool:
        """True when every gain appears with degree at most 1 in every term.

        For a multi-affine family, ``x^T F(p) x`` is multi-affine in ``p`` for
        every fixed ``x`` and so attains its minimum over a box at a vertex.
        """
        return all(max(t.exponents, default=0) <= 1 for t in self.terms)

    @property
    def degree(self) -> tuple[int, ...]:
        """Maximum exponent of each gain."""
        return tuple(
            max((t.exponents[k] for t in self.terms), default=0) for k in range(len(self.gains))
        )

    def _point(self, point: Sequence[Any] | Mapping[str, Any]) -> tuple[Any, ...]:
        if isinstance(point, Mapping):
            missing = [g for g in self.gains if g not in point]
            if missing:
                raise ValueError(f"expected values for gains {self.gains}, missing {missing}")
            return tuple(point[g] for g in self.gains)
        pt = tuple(point)
        if len(pt) != len(self.gains):
            raise ValueError(f"expected {len(self.gains)} gain values {self.gains}, received {len(pt)}")
        return pt

    def coefficients(self, point: Sequence[Any] | Mapping[str, Any], exact: bool = False) -> list[Any]:
        """The scalar weight ``c_k p^{e_k}`` of every term at ``point``."""
        pt = self._point(point)
        out = []
        for t in self.terms:
            w: Any = t.coefficient if exact else float(t.coefficient)
            for v, e in zip(pt, t.exponents):
                if e:
                    w = w * (Fraction(v) if exact else float(v)) ** e
            out.append(w)
        return out

    def evaluate(self, point: Sequence[Any] | Mapping[str, Any]) -> np.ndarray:
        """Dense floating-point ``F(p)`` (size x size)."""
        out = np.zeros((self.size, self.size))
        for w, t in zip(self.coefficients(point), self.terms):
            if w != 0.0:
                out += w * t.dense()
        return out

    def evaluate_sparse(self, point: Sequence[Any] | Mapping[str, Any]) -> Any:
        """``F(p)`` as a scipy CSR matrix (for large graphs)."""
        out = sp.csr_matrix((self.size, self.size))
        for w, t in zip(self.coefficients(point), self.terms):
            if w != 0.0:
                out = out + w * sp.csr_matrix(t.matrix, dtype=float)
        return out

    def evaluate_exact(self, point: Sequence[Any] | Mapping[str, Any]) -> list[list[Fraction]]:
        """Exact rational ``F(p)`` as a list of rows of :class:`fractions.Fraction`."""
        out = [[Fraction(0)] * self.size for _ in range(self.size)]
        for w, t in zip(self.coefficients(point, exact=True), self.terms):
            if w == 0:
                continue
            m = t.matrix
            if sp.issparse(m):
                coo = sp.coo_matrix(m)
                for i, j, v in zip(coo.row, coo.col, coo.data):
                    out[int(i)][int(j)] += w * int(v)
            else:
                for i, j in zip(*np.nonzero(m)):
                    out[int(i)][int(j)] += w * int(m[i, j])
        return out

    def to_sympy(self, symbols: Sequence[Any] | None = None) -> Any:
        """The family as a sympy Matrix in the gain symbols."""
        import sympy

        syms = list(symbols) if symbols is not None else list(sympy.symbols(" ".join(self.gains)))
        out = sympy.zeros(self.size, self.size)
        for t in self.terms:
            mono = sympy.Rational(t.coefficient.numerator, t.coefficient.denominator)
            for s, e in zip(syms, t.exponents):
                mono *= s**e
            out += mono * sympy.Matrix(t.dense().tolist())
        return out


def family_from_sympy(
    name: str,
    matrix: Any,
    gain_symbols: Sequence[Any],
    *,
    block_size: int = 3,
    row_labels: Sequence[str] = (),
    spacecraft: int | None = None,
) -> MatrixFamily:
    """Convert a symmetric sympy Matrix, polynomial in ``gain_symbols`` with
    rational coefficients, to a :class:`MatrixFamily`.

    Examples
    --------
    >>> import sympy
    >>> ko, kq, b = sympy.symbols("K_o K_q beta")
    >>> f = family_from_sympy("F", sympy.Matrix([[ko, b / 2], [b / 2, kq]]), (ko, kq, b))
    >>> f.evaluate((1, 2, 3)).tolist()
    [[1.0, 1.5], [1.5, 2.0]]
    """
    import sympy

    mat = sympy.Matrix(matrix)
    if mat.shape[0] != mat.shape[1]:
        raise ValueError(f"expected a square matrix, received shape {mat.shape}")
    if (mat - mat.T).applyfunc(sympy.expand) != sympy.zeros(*mat.shape):
        raise ValueError(f"expected a symmetric matrix for {name}, received a non-symmetric one")
    n = mat.shape[0]
    gens = list(gain_symbols)
    entries: dict[tuple[int, int], dict[tuple[int, ...], Fraction]] = {}
    for i in range(n):
        for j in range(n):
            e = sympy.expand(mat[i, j])
            if e == 0:
                continue
            poly = sympy.Poly(e, *gens)
            for mono, c in poly.terms():
                if not c.is_Rational:
                    raise ValueError(
                        f"expected rational coefficients in {name}[{i},{j}], received {c}"
                    )
                entries.setdefault((i, j), {})[tuple(int(x) for x in mono)] = Fraction(
                    int(c.p), int(c.q)
                )
    return family_from_entries(
        name, n, entries, gains=tuple(str(s) for s in gens), block_size=block_size,
        row_labels=tuple(row_labels), spacecraft=spacecraft,
    )


def family_from_entries(
    name: str,
    size: int,
    entries: dict[tuple[int, int], dict[tuple[int, ...], Fraction]],
    *,
    gains: tuple[str, ...] = GAIN_NAMES,
    block_size: int = 3,
    row_labels: tuple[str, ...] = (),
    spacecraft: int | None = None,
) -> MatrixFamily:
    """Build a :class:`MatrixFamily` from sparse polynomial entries
    ``{(row, col): {exponents: coefficient}}`` (both triangles given).

    Entries of each monomial share one integer matrix scaled by ``1/lcm`` of
    their denominators; matrices larger than 64 are stored sparse.

    Examples
    --------
    >>> f = family_from_entries("F", 2, {(0, 0): {(1, 0, 0): Fraction(1, 2)},
    ...                                  (1, 1): {(0, 0, 0): Fraction(1, 3)}})
    >>> f.evaluate((2, 0, 0)).round(4).tolist()
    [[1.0, 0.0], [0.0, 0.3333]]
    """
    buckets: dict[tuple[int, ...], dict[tuple[int, int], Fraction]] = {}
    for (i, j), pd in entries.items():
        for mono, c in pd.items():
            if c != 0:
                buckets.setdefault(mono, {})[(i, j)] = c
    terms = []
    for mono in sorted(buckets):
        cells = buckets[mono]
        den = 1
        for c in cells.values():
            den = math.lcm(den, c.denominator)
        rows = [ij[0] for ij in cells]
        cols = [ij[1] for ij in cells]
        vals = [int(c * den) for c in cells.values()]
        if size > 64:
            mat: Any = sp.csr_matrix((vals, (rows, cols)), shape=(size, size), dtype=np.int64)
        else:
            mat = np.zeros((size, size), dtype=np.int64)
            mat[rows, cols] = vals
        terms.append(FamilyTerm(mono, Fraction(1, den), mat))
    return MatrixFamily(
        name=name, gains=gains, terms=tuple(terms), size=size, block_size=block_size,
        row_labels=row_labels, spacecraft=spacecraft,
    )
