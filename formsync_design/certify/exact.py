"""Exact and rigorously rounded linear algebra for the certification re-check.

Everything here decides a sign question without trusting a floating-point
number: exact rational ``LDL^T`` (dense :func:`exact_ldl`, sparse
:func:`exact_sparse_ldl` with a minimum-degree order), a rigorous floating-point
lower bound of ``lambda_min`` (:func:`rigorous_lower_bound`, Higham Thm 10.3),
and the exact sign of a quadratic form ``x^T (F(p) - margin I) x`` at a rational
gain point in Python integers (:func:`quad_value_sign`, :func:`check_witness`).
Floats appear only as a fast pre-filter that can never decide a non-positive
sign (and is skipped when the integers do not fit in a float).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sp

from formsync_design.errors import InputError

__all__ = [
    "UNIT_ROUNDOFF",
    "EXACT_SPARSE_MAX",
    "EXACT_SPARSE_BUDGET",
    "gamma_bound",
    "exact_fraction",
    "round_down",
    "round_up",
    "exact_ldl",
    "exact_sparse_ldl",
    "min_degree_order",
    "rigorous_lower_bound",
    "check_witness",
    "integer_coo",
    "quad_forms",
    "weight_exact",
    "round_vector",
    "quad_value_sign",
]

UNIT_ROUNDOFF = 2.0**-53  # unit roundoff
_ETA = 2.0**-1074  # smallest subnormal
_TINY_R = 2.0**-500
_INFL = 1.0 + 1e-10

#: Largest block order for the sparse exact ``LDL^T`` fallback.
EXACT_SPARSE_MAX = 2000
#: Most rational multiply-adds the sparse exact fallback may spend on one matrix.
EXACT_SPARSE_BUDGET = 4_000_000


def gamma_bound(k: int) -> float:
    """Upper bound of ``gamma_k = k u / (1 - k u)`` (valid while ``k u < 0.01``).

    >>> gamma_bound(1) > 2.0**-53
    True
    """
    if k * UNIT_ROUNDOFF >= 0.01:  # pragma: no cover - only for absurd sizes
        raise InputError(f"expected a matrix order below {int(0.01 / UNIT_ROUNDOFF)}, received {k}")
    return 1.01 * k * UNIT_ROUNDOFF


def min_degree_order(adj: Sequence[set[int]]) -> list[int]:
    """A greedy minimum-degree elimination order of a symmetric sparsity graph.

    Keeps the fill of a sparse ``LDL^T`` small (a star's leaves go before its
    hub, so no fill; a path or ring stays banded).

    >>> min_degree_order([{1, 2, 3, 4}, {0}, {0}, {0}, {0}])
    [1, 2, 3, 0, 4]
    """
    nbr = [set(s) - {i} for i, s in enumerate(adj)]
    alive = set(range(len(nbr)))
    order: list[int] = []
    while alive:
        k = min(alive, key=lambda i: (len(nbr[i]), i))
        order.append(k)
        alive.discard(k)
        ns = nbr[k]
        for i in ns:
            nbr[i].discard(k)
            nbr[i] |= ns - {i}
        nbr[k] = set()
    return order


def exact_sparse_ldl(
    rows: Sequence[Mapping[int, Fraction]], *, budget: int = EXACT_SPARSE_BUDGET
) -> tuple[bool | None, list[Fraction] | None]:
    """Decide positive definiteness of a sparse symmetric rational matrix exactly.

    ``rows[i]`` maps column ``j`` to ``A_ij`` (both triangles, zeros omitted).
    The matrix is eliminated in a minimum-degree order ``P`` (``A`` is PD iff
    ``P^T A P`` is): every pivot positive means PD; at the first pivot
    ``d_k <= 0`` the vector ``x = P L^{-T} e_k`` has ``x^T A x = d_k <= 0``.

    Returns
    -------
    (is_pd, witness)
        ``(True, None)`` PD; ``(False, x)`` not PD with the exact witness ``x``;
        ``(None, None)`` when the work would exceed ``budget`` multiply-adds.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> exact_sparse_ldl([{0: F(2), 1: F(-1)}, {0: F(-1), 1: F(2)}])
    (True, None)
    >>> pd, x = exact_sparse_ldl([{0: F(1), 1: F(-1)}, {0: F(-1), 1: F(1)}])
    >>> pd, x
    (False, [Fraction(1, 1), Fraction(1, 1)])
    """
    n = len(rows)
    w: list[dict[int, Fraction]] = [
        {int(j): Fraction(v) for j, v in r.items() if v != 0} for r in rows
    ]
    order = min_degree_order([set(r) for r in w])
    pos = {v: k for k, v in enumerate(order)}
    done: set[int] = set()
    lcols: dict[int, dict[int, Fraction]] = {}  # pivot -> {row: l_row,pivot}
    work = 0
    for k in order:
        d = w[k].get(k, Fraction(0))
        if d <= 0:
            x = {k: Fraction(1)}
            for piv in reversed(order[: pos[k]]):
                s = sum((lv * x[r] for r, lv in lcols[piv].items() if r in x), Fraction(0))
                if s:
                    x[piv] = -s
            return False, [x.get(i, Fraction(0)) for i in range(n)]
        done.add(k)
        rest = {j: v for j, v in w[k].items() if j not in done}
        work += len(rest) * len(rest)
        if work > budget:
            return None, None
        col = {i: v / d for i, v in rest.items()}
        lcols[k] = col
        for i, li in col.items():
            wi = w[i]
            wi.pop(k, None)
            for j, akj in rest.items():
                nv = wi.get(j, Fraction(0)) - li * akj
                if nv:
                    wi[j] = nv
                else:
                    wi.pop(j, None)
    return True, None


# ---------------------------------------------------------------------------
# exact and rigorous linear algebra
# ---------------------------------------------------------------------------
def exact_ldl(a: Sequence[Sequence[Fraction]]) -> tuple[bool, list[Fraction] | None]:
    """Decide positive definiteness of a symmetric rational matrix exactly.

    Symmetric Gaussian elimination (``LDL^T`` without pivoting) in
    :class:`fractions.Fraction`.  ``A`` is PD iff every pivot is positive
    (Sylvester's criterion).  At the first pivot ``d_k <= 0`` the vector
    ``x = L^{-T} e_k`` (zero beyond ``k``) has ``x^T A x = d_k <= 0``.

    Returns
    -------
    (is_pd, witness)
        ``witness`` is ``None`` when PD, else a list of Fractions.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> exact_ldl([[F(2), F(1)], [F(1), F(2)]])
    (True, None)
    >>> exact_ldl([[F(1), F(2)], [F(2), F(1)]])
    (False, [Fraction(-2, 1), Fraction(1, 1)])
    """
    n = len(a)
    w = [list(map(Fraction, row)) for row in a]
    lmat = [[Fraction(0)] * n for _ in range(n)]
    for k in range(n):
        d = w[k][k]
        if d <= 0:
            x = [Fraction(0)] * n
            x[k] = Fraction(1)
            for i in range(k - 1, -1, -1):
                x[i] = -sum((lmat[j][i] * x[j] for j in range(i + 1, k + 1)), Fraction(0))
            return False, x
        lmat[k][k] = Fraction(1)
        rowk = w[k]
        for i in range(k + 1, n):
            if rowk[i] == 0:
                continue
            li = rowk[i] / d
            lmat[i][k] = li
            wi = w[i]
            for j in range(k + 1, n):
                if rowk[j] != 0:
                    wi[j] -= li * rowk[j]
    return True, None


def _chol_batched(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column Cholesky of a stack ``b`` (V, n, n); returns (R^T factor, ok)."""
    v, n, _ = b.shape
    lo = np.zeros_like(b)
    ok = np.ones(v, dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        for j in range(n):
            s = b[:, j, j] - np.einsum("vk,vk->v", lo[:, j, :j], lo[:, j, :j])
            bad = ~(s > 0)
            ok &= ~bad
            s = np.where(bad, 1.0, s)
            d = np.sqrt(s)
            lo[:, j, j] = d
            if j + 1 < n:
                col = b[:, j + 1 :, j] - np.einsum("vik,vk->vi", lo[:, j + 1 :, :j], lo[:, j, :j])
                lo[:, j + 1 :, j] = col / d[:, None]
    ok &= np.all(np.isfinite(lo.reshape(v, -1)), axis=1)
    return lo, ok


def _chol_bound(lo: np.ndarray, ok: np.ndarray, n: int) -> np.ndarray:
    """Upper bound of ``||dB||_2`` from the factor (inf where not ok)."""
    v = lo.shape[0]
    flat = np.abs(lo.reshape(v, -1))
    nz = np.where(flat > 0, flat, np.inf).min(axis=1)
    ok = ok & (nz >= _TINY_R)
    fro2 = np.einsum("vk,vk->v", flat, flat) * _INFL * (1.0 + gamma_bound(n * n + 1))
    out = gamma_bound(n + 1) * fro2 * _INFL + 4.0 * n * n * _ETA
    return np.where(ok, out, np.inf)


def rigorous_lower_bound(
    mats: Sequence[np.ndarray],
    weights: np.ndarray,
    sigma: np.ndarray,
    *,
    weight_roundings: int = 1,
) -> np.ndarray:
    """Rigorous lower bounds of ``lambda_min(sum_k w_k G_k)`` at many points.

    Parameters
    ----------
    mats : sequence of (n, n) integer arrays ``G_k`` (symmetric, exactly representable)
    weights : (V, K) float array
        Floating-point weights ``w~_k``; each must satisfy
        ``|w~_k - w_k| <= gamma_{weight_roundings} |w_k|`` for the exact ``w_k``.
    sigma : (V,) float array of shifts (candidates just below ``lambda_min``)
    weight_roundings : int
        Number of roundings in each weight (``2 * degree + 1`` for a monomial
        of correctly rounded gains times a correctly rounded coefficient).

    Returns
    -------
    (V,) float array ``ell`` with ``lambda_min(sum_k w_k G_k) >= ell`` proven,
    ``-inf`` where the Cholesky factorization of the shifted matrix broke down.

    Notes
    -----
    Bound (module docstring): ``ell = sigma - gamma_{n+1}||R||_F^2 -
    gamma_{K+w+3} max_i sum_j S_ij - 4 n^2 eta``, every term inflated, the
    subtraction rounded down.

    Examples
    --------
    >>> import numpy as np
    >>> g = [np.array([[2, -1], [-1, 2]])]
    >>> ell = rigorous_lower_bound(g, np.array([[1.0]]), np.array([0.999]))
    >>> bool(0.99 < ell[0] <= 1.0)
    True
    """
    mats = [np.asarray(m, dtype=float) for m in mats]
    w = np.atleast_2d(np.asarray(weights, dtype=float))
    sig = np.asarray(sigma, dtype=float).reshape(-1)
    n = mats[0].shape[0]
    nv, k = w.shape
    eye = np.eye(n)
    rows = np.stack([np.abs(m).sum(axis=1) for m in mats])  # (K, n)
    rowmax = (np.abs(w) @ rows).max(axis=1) + np.abs(sig)
    e1 = gamma_bound(k + weight_roundings + 3) * rowmax * _INFL * (1.0 + gamma_bound(n + k + 2))
    out = np.full(nv, -np.inf)
    if n <= 48:
        b = np.einsum("vk,kij->vij", w, np.stack(mats)) - sig[:, None, None] * eye
        lo, ok = _chol_batched(b)
        ec = _chol_bound(lo, ok, n)
    else:
        ec = np.full(nv, np.inf)
        for i in range(nv):
            bi = sum(w[i, kk] * mats[kk] for kk in range(k)) - sig[i] * eye
            try:
                li = np.linalg.cholesky(bi)
            except np.linalg.LinAlgError:
                continue
            if not np.all(np.isfinite(li)):
                continue
            ec[i] = _chol_bound(li[None], np.ones(1, dtype=bool), n)[0]
    good = np.isfinite(ec)
    tot = (ec + e1) * _INFL
    with np.errstate(invalid="ignore"):
        val = np.nextafter(sig - tot, -np.inf)
    out[good] = val[good]
    return out


def check_witness(
    terms: Sequence[tuple[tuple[int, ...], Fraction, Any]],
    point: Sequence[Fraction],
    x: Sequence[int],
    margin: Fraction = Fraction(0),
) -> Fraction:
    """Exact ``x^T (F(p) - margin I) x`` for integer ``x`` and rational ``p``.

    ``terms`` are ``(exponents, coefficient, integer matrix)`` (a family's
    terms); the quadratic forms ``x^T G_k x`` are computed in Python integers.

    Examples
    --------
    >>> import numpy as np
    >>> from fractions import Fraction as F
    >>> t = [((1,), F(1), np.array([[1, 2], [2, 1]]))]
    >>> check_witness(t, (F(1, 2),), [1, -1])
    Fraction(-1, 1)
    """
    q = quad_forms([m for _, _, m in terms], x)
    xx = sum(int(v) * int(v) for v in x)
    val = -Fraction(margin) * xx
    for (e, c, _), qk in zip(terms, q):
        if qk:
            val += weight_exact(e, exact_fraction(c), point) * qk
    return val


_COO_CACHE: dict[int, tuple[Any, list[int], list[int], list[int]]] = {}


def integer_coo(m: Any) -> tuple[list[int], list[int], list[int]]:
    """Nonzeros of an integer matrix as Python lists (cached per matrix object).

    >>> integer_coo(np.array([[0, 2], [3, 0]]))
    ([0, 1], [1, 0], [2, 3])
    """
    hit = _COO_CACHE.get(id(m))
    if hit is not None and hit[0] is m:
        return hit[1], hit[2], hit[3]
    if sp.issparse(m):
        c = sp.coo_matrix(m)
        rows, cols, vals = c.row.tolist(), c.col.tolist(), [int(v) for v in c.data.tolist()]
    else:
        arr = np.asarray(m, dtype=np.int64)
        nz = np.nonzero(arr)
        rows, cols, vals = nz[0].tolist(), nz[1].tolist(), [int(v) for v in arr[nz].tolist()]
    if len(_COO_CACHE) > 4096:
        _COO_CACHE.clear()
    _COO_CACHE[id(m)] = (m, rows, cols, vals)  # keeps m alive: the id stays unique
    return rows, cols, vals


def quad_forms(mats: Sequence[Any], x: Sequence[int]) -> list[int]:
    """The exact integers ``x^T G_k x`` for integer matrices ``G_k`` and integer ``x``.

    >>> quad_forms([np.array([[2, -1], [-1, 2]])], [10**30, 10**30])
    [2000000000000000000000000000000000000000000000000000000000000]
    """
    xi = [int(v) for v in x]
    out = []
    for m in mats:
        rows, cols, vals = integer_coo(m)
        s = 0
        for i, j, v in zip(rows, cols, vals):
            s += v * xi[i] * xi[j]
        out.append(s)
    return out


def weight_exact(e: Sequence[int], c: Fraction, point: Sequence[Fraction]) -> Fraction:
    """The exact monomial weight ``c * prod_a p_a^{e_a}``.

    >>> weight_exact((1, 0, 2), Fraction(1, 2), (Fraction(3), Fraction(7), Fraction(1, 10)))
    Fraction(3, 200)
    """
    w = exact_fraction(c)
    for g, k in zip(point, e):
        for _ in range(k):
            w *= g
    return w


def round_vector(x: np.ndarray, bits: int = 24) -> list[int]:
    """A float direction as integers with ``bits`` bits (``[]`` for zero/non-finite).

    >>> round_vector(np.array([0.5, -1.0]), bits=4)
    [8, -16]
    """
    x = np.asarray(x, dtype=float)
    s = np.abs(x).max()
    if not np.isfinite(s) or s == 0:
        return []
    return [int(v) for v in np.rint(x / s * 2.0**bits)]


def exact_fraction(c: Any) -> Fraction:
    """A Fraction with Python-int numerator and denominator (numpy ints break hashing).

    >>> exact_fraction(np.int64(3))
    Fraction(3, 1)
    """
    c = Fraction(c)
    return Fraction(int(c.numerator), int(c.denominator))


def round_up(margin: Fraction) -> float:
    """The smallest float ``>= margin``.

    >>> round_up(Fraction(1, 3)) >= Fraction(1, 3)
    True
    """
    m = float(margin)
    if Fraction(m) < margin:
        m = float(np.nextafter(m, np.inf))
    return m


def round_down(q: Fraction) -> float:
    """The largest float ``<= q``.

    >>> round_down(Fraction(1, 3)) <= Fraction(1, 3)
    True
    """
    f = float(q)
    if Fraction(f) > q:
        f = float(np.nextafter(f, -np.inf))
    return f


def quad_value_sign(
    exps: Sequence[tuple[int, ...]],
    coefs: Sequence[Fraction],
    q: Sequence[int],
    xx: int,
    pt: Sequence[Fraction],
    margin: Fraction,
) -> int:
    """Sign of ``sum_k c_k p^{e_k} q_k - margin * xx`` in integer arithmetic
    (everything multiplied by one positive common denominator).

    >>> from fractions import Fraction as F
    >>> quad_value_sign([(1,)], [F(1)], [10**400], 10**400, (F(1, 2),), F(1, 2))
    0
    """
    # fast rejection: a float estimate clearly positive (its error is below
    # ~10 u * mag << 1e-6 mag); a non-positive value is always confirmed exactly
    # (skipped when an integer does not fit in a float: exact witnesses from a
    # near-singular LDL^T have huge entries, and floats must never decide)
    try:
        approx = -float(margin) * float(xx)
        mag = abs(approx)
        for e, c, qk in zip(exps, coefs, q):
            if qk:
                t = float(c) * float(qk)
                for g, k in zip(pt, e):
                    if k:
                        t *= float(g) ** k
                approx += t
                mag += abs(t)
        fast = math.isfinite(approx) and math.isfinite(mag) and approx > 1e-6 * mag
    except OverflowError:
        fast = False
    if fast:
        return 1
    nums = [g.numerator for g in pt]
    dens = [g.denominator for g in pt]
    maxe = [max((e[a] for e in exps), default=0) for a in range(len(pt))]
    lden = 1
    for c in coefs:
        lden = lden * c.denominator // math.gcd(lden, c.denominator)
    dpow = 1
    for d, me in zip(dens, maxe):
        dpow *= d**me
    total = -margin.numerator * xx * lden * dpow
    for e, c, qk in zip(exps, coefs, q):
        if not qk:
            continue
        t = qk * c.numerator * (lden // c.denominator) * margin.denominator
        for nn, d, k, me in zip(nums, dens, e, maxe):
            t *= nn**k * d ** (me - k)
        total += t
    return (total > 0) - (total < 0)
