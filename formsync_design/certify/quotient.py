"""The disagreement coordinates of a formation linearisation, in exact arithmetic.

``A(g) = T^-1 F(g)`` per monomial of ``F`` (:func:`state_terms`, the inertia blocks of ``T``
inverted exactly); the largest subspace of common states ``1 (x) y`` that every monomial
matrix leaves invariant and the quotient by it (:func:`consensus_quotient`: with a leader, the
full state); ``A_Q = Pi A B`` per monomial (:func:`quotient_terms`) and its value at a gain
point with its rounding bound (:func:`matrix_at`).  Used by
:mod:`~formsync_design.certify.formation`.

>>> from formsync_design.derive.formation import linearize_formation
>>> from formsync_design.spec.loader import load_design
>>> lin = linearize_formation(load_design("ma_quat_smc"), "ring:3", [[[1, 0, 0], [0, 1, 0], [0, 0, 1]]] * 3)
>>> q = consensus_quotient(lin.loop, state_terms(lin.loop), leader=False)
>>> q.dim, q.consensus_dim
(12, 6)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

__all__ = ["Sparse", "Quotient", "state_terms", "consensus_quotient", "quotient_terms",
           "matrix_at"]

Sparse = dict[tuple[int, int], Fraction]


def state_terms(loop: Any) -> dict[tuple[int, ...], Sparse]:
    """``T^-1 F_k`` for every monomial ``k`` (``T``'s 3x3 inertia blocks inverted exactly)."""
    n = loop.n
    T = loop.T
    inv: dict[int, list[list[Fraction]]] = {}
    for i in range(n):
        r0 = 3 * n + 3 * i
        inv[i] = _inv3([[T[r0 + a][r0 + b] for b in range(3)] for a in range(3)])
    out: dict[tuple[int, ...], Sparse] = {}
    for mono, cells in loop.F.terms.items():
        rows: dict[int, dict[int, Fraction]] = {}
        for (r, c), v in cells.items():
            rows.setdefault(r, {})[c] = v
        res: Sparse = {}
        for r, cols in rows.items():
            if 3 * n <= r < 6 * n:
                i, a = divmod(r - 3 * n, 3)
                for b in range(3):
                    coef = inv[i][b][a]
                    if coef:
                        rr = 3 * n + 3 * i + b
                        for c, v in cols.items():
                            res[(rr, c)] = res.get((rr, c), Fraction(0)) + coef * v
            else:
                for c, v in cols.items():
                    res[(r, c)] = res.get((r, c), Fraction(0)) + v
        out[mono] = {k: v for k, v in res.items() if v != 0}
    return out


def _inv3(m: list[list[Fraction]]) -> list[list[Fraction]]:
    a, b, c = m[0]
    d, e, f = m[1]
    g, h, k = m[2]
    det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
    if det == 0:
        from formsync_design.errors import InputError

        raise InputError("expected invertible inertia matrices, received a singular one")
    adj = [[e * k - f * h, c * h - b * k, b * f - c * e],
           [f * g - d * k, a * k - c * g, c * d - a * f],
           [d * h - e * g, b * g - a * h, a * e - b * d]]
    return [[x / det for x in row] for row in adj]


def _nullspace(rows: list[list[Fraction]], r: int) -> list[list[Fraction]]:
    """A basis of ``{c in Q^r : row . c = 0 for every row}`` (exact elimination)."""
    pivots: dict[int, list[Fraction]] = {}
    for row in rows:
        v = list(row)
        for col, prow in pivots.items():
            if v[col]:
                f = v[col]
                v = [x - f * y for x, y in zip(v, prow)]
        nz = next((j for j, x in enumerate(v) if x), None)
        if nz is None:
            continue
        p = v[nz]
        v = [x / p for x in v]
        for col, prow in list(pivots.items()):
            if prow[nz]:
                f = prow[nz]
                pivots[col] = [x - f * y for x, y in zip(prow, v)]
        pivots[nz] = v
        if len(pivots) == r:
            return []
    free = [j for j in range(r) if j not in pivots]
    basis = []
    for fcol in free:
        c = [Fraction(0)] * r
        c[fcol] = Fraction(1)
        for col, prow in pivots.items():
            c[col] = -prow[fcol]
        basis.append(c)
    return basis


@dataclass(frozen=True)
class Quotient:
    """The disagreement coordinates: ``A_Q = Pi A B`` (see :func:`consensus_quotient`)."""

    dim: int
    consensus_dim: int
    rows: tuple[dict[int, Fraction], ...]    # Pi: quotient coordinate -> combination of x
    cols: tuple[int, ...]                    # B: quotient coordinate -> state index (0/1)
    basis: tuple[tuple[Fraction, ...], ...]  # Y: the invariant common directions (p-vectors)


def consensus_quotient(loop: Any, terms: Mapping[tuple[int, ...], Sparse], leader: bool) -> Quotient:
    """The largest invariant subspace of common states and the quotient by it (module
    docstring).  ``Pi`` and ``B`` are exact; ``A_Q = Pi A B`` for every gain."""
    n, nz = loop.n, loop.nz
    p = 6 + nz
    nx = p * n

    def idx(i: int, c: int) -> int:
        return 3 * i + c if c < 3 else (3 * n + 3 * i + c - 3 if c < 6 else 6 * n + nz * i + c - 6)

    if leader or n == 1:
        Y: list[list[Fraction]] = []
    else:
        Y = [[Fraction(int(a == b)) for a in range(p)] for b in range(p)]   # columns
        byrow = {mono: _rows_of(t) for mono, t in terms.items()}
        while Y:
            r = len(Y)
            eqs: list[list[Fraction]] = []
            perp = _nullspace([list(col) for col in Y], p) if r < p else []
            for rows in byrow.values():
                # M = A (1 (x) Y): row x -> sum_c A[x, idx(j, c)] Y[c]
                M: dict[int, list[Fraction]] = {}
                for x, cols in rows.items():
                    acc = [Fraction(0)] * r
                    for col, v in cols.items():
                        c = _coord(col, n, nz)
                        for k in range(r):
                            if Y[k][c]:
                                acc[k] += v * Y[k][c]
                    M[x] = acc
                zero = [Fraction(0)] * r
                last = [M.get(idx(n - 1, c), zero) for c in range(p)]
                for i in range(n - 1):
                    for c in range(p):
                        row = M.get(idx(i, c), zero)
                        d = [a - b for a, b in zip(row, last[c])]
                        if any(d):
                            eqs.append(d)
                for w in perp:
                    d = [sum((w[c] * last[c][k] for c in range(p)), Fraction(0)) for k in range(r)]
                    if any(d):
                        eqs.append(d)
            null = _nullspace(eqs, r)
            if len(null) == r:
                break
            Y = [[sum((cc[k] * Y[k][a] for k in range(r)), Fraction(0)) for a in range(p)]
                 for cc in null]
    r = len(Y)
    # complete Y by coordinate vectors e_C' to a basis W of Q^p
    chosen: list[int] = []
    cur = [list(col) for col in Y]
    for c in range(p):
        if len(chosen) + r == p:
            break
        trial = cur + [[Fraction(int(a == c)) for a in range(p)]]
        if len(_nullspace(trial, p)) == p - len(trial):
            cur = trial
            chosen.append(c)
    W = [[Fraction(int(a == c)) for a in range(p)] for c in chosen] + [list(col) for col in Y]
    Winv = _invert([[W[k][a] for k in range(p)] for a in range(p)])   # W as columns
    # x_N = W [u''; coeff]; u_i = x_i - Y coeff (i < N)
    K = [[sum((Y[k][a] * Winv[len(chosen) + k][b] for k in range(r)), Fraction(0))
          for b in range(p)] for a in range(p)]
    prow: list[dict[int, Fraction]] = []
    pcol: list[int] = []
    last_i = n - 1
    for i in range(n - 1 if r else n):
        for c in range(p):
            comb = {idx(i, c): Fraction(1)}
            if r:
                for b in range(p):
                    if K[c][b]:
                        comb[idx(last_i, b)] = comb.get(idx(last_i, b), Fraction(0)) - K[c][b]
            prow.append({k: v for k, v in comb.items() if v})
            pcol.append(idx(i, c))
    if r:
        for k, c in enumerate(chosen):
            prow.append({idx(last_i, b): Winv[k][b] for b in range(p) if Winv[k][b]})
            pcol.append(idx(last_i, c))
    assert len(prow) == nx - r
    return Quotient(nx - r, r, tuple(prow), tuple(pcol), tuple(tuple(col) for col in Y))


def _rows_of(t: Sparse) -> dict[int, dict[int, Fraction]]:
    rows: dict[int, dict[int, Fraction]] = {}
    for (r, c), v in t.items():
        rows.setdefault(r, {})[c] = v
    return rows


def _coord(col: int, n: int, nz: int) -> int:
    if col < 3 * n:
        return col % 3
    if col < 6 * n:
        return 3 + (col - 3 * n) % 3
    return 6 + (col - 6 * n) % nz


def _invert(m: list[list[Fraction]]) -> list[list[Fraction]]:
    k = len(m)
    aug = [list(row) + [Fraction(int(i == j)) for j in range(k)] for i, row in enumerate(m)]
    for col in range(k):
        piv = next(r for r in range(col, k) if aug[r][col])
        aug[col], aug[piv] = aug[piv], aug[col]
        pv = aug[col][col]
        aug[col] = [x / pv for x in aug[col]]
        for r in range(k):
            if r != col and aug[r][col]:
                f = aug[r][col]
                aug[r] = [x - f * y for x, y in zip(aug[r], aug[col])]
    return [row[k:] for row in aug]


def quotient_terms(q: Quotient, terms: Mapping[tuple[int, ...], Sparse]) -> dict[tuple[int, ...], Sparse]:
    """``Pi A_k B`` for every monomial ``k``, sparse exact."""
    colpos = {c: j for j, c in enumerate(q.cols)}
    out: dict[tuple[int, ...], Sparse] = {}
    for mono, t in terms.items():
        rows = _rows_of(t)
        res: Sparse = {}
        for qi, comb in enumerate(q.rows):
            for x, wgt in comb.items():
                for col, v in rows.get(x, {}).items():
                    j = colpos.get(col)
                    if j is not None:
                        res[(qi, j)] = res.get((qi, j), Fraction(0)) + wgt * v
        out[mono] = {k: v for k, v in res.items() if v}
    return out


# ------------------------------------------------------------------ decisions


def matrix_at(qterms: Mapping[tuple[int, ...], Sparse], gains: tuple[str, ...], point: Mapping[str, Fraction],
        dim: int) -> tuple[np.ndarray, np.ndarray]:
    """The float matrix (correctly rounded exact entries) and its rounding bound."""
    exact: dict[tuple[int, int], Fraction] = {}
    for mono, t in qterms.items():
        w = Fraction(1)
        for g, e in zip(gains, mono):
            w *= Fraction(point[g]) ** e
        if w == 0:
            continue
        for k, v in t.items():
            exact[k] = exact.get(k, Fraction(0)) + w * v
    A = np.zeros((dim, dim))
    for (r, c), v in exact.items():
        A[r, c] = float(v)
    return A, np.abs(A) * 2.0**-53 * 1.01
