"""Certification of Lyapunov conditions over whole boxes of gains.

Question answered: *is* ``F(p) - eps I`` *positive definite for every family
F in* ``conditions.families`` *(every* ``Theta_i`` *and* ``Pi`` *) and every gain
point p in a box* ``[lo_1, hi_1] x [lo_2, hi_2] x [lo_3, hi_3]``?

Why finitely many computations cover the whole box
--------------------------------------------------
Every family is checked for being *multi-affine* in the gains (each gain
appears with exponent <= 1 in every term, :attr:`MatrixFamily.is_multiaffine`).
For a fixed vector ``x`` the scalar ``x^T F(p) x`` is then affine in each gain
separately, so its minimum over the box is attained at one of the (at most 8)
vertices.  Hence::

    min_{p in box} lambda_min(F(p)) = min_{|x|=1} min_{p in box} x^T F(p) x
                                    = min_{vertices v} lambda_min(F(v)),

i.e. the box is certified iff ``F(v) - eps I`` is PD at every vertex, and a
single vector ``x`` with ``x^T (F(v) - eps I) x <= 0`` at every vertex refutes
*every* point of the box.  A block that is not multi-affine (a spec with, say,
``beta^2`` terms) does not get the vertex argument; it gets an interval
argument with bisection instead: on a sub-box with centre ``c``,
``lambda_min(F(p)) >= lambda_min(F(c)) - sum_k dev_k ||G_k||_inf`` with
``dev_k`` an exact bound of the weight deviation ``|w_k(p) - w_k(c)|`` (gains are
positive, so monomials are monotone), up to ``SUBDIVISION_LIMIT`` sub-boxes;
otherwise ``undecided``.  (Region maps never certify such blocks.)

Pipeline
--------
1. **Structure.** Families with identical content (e.g. ``Theta_i`` of
   spacecraft with equal degree) are deduplicated; each family is split into
   the connected components of its sparsity pattern (``Pi`` splits into the
   ``qdot`` block and ``n`` identical ``1x1`` blocks); identical blocks are
   deduplicated again.  A large block whose term matrices lie in a pencil
   ``span{I, M}`` (``Pi``'s ``qdot`` block is ``K_o I - beta L``, or
   ``span{I, Adjacency}`` for the paper's printed ``M``) is handled through a
   rigorous enclosure of the spectrum of ``M``: the eigenvalues of
   ``a(p) I + b(p) M`` are ``a + b mu``.  The ``(x) I_3`` factor never enters.
2. **Optimization (hint).** :func:`certify_box` solves, with cvxpy + Clarabel,
   ``max t_b  s.t.  F_b(v) - t_b I >= 0`` for every reduced block ``b`` and
   vertex ``v`` (pencil blocks reduce to scalar constraints at the extreme
   eigenvalues of ``M``; dense blocks larger than ``SDP_MAX_BLOCK`` take their
   hint from LAPACK ``eigvalsh``).  Every solver status is mapped through
   :data:`STATUS_MAP`; an unknown status gives status ``"error"``.
3. **Independent re-check** of every block at every vertex, in exact or
   rigorously rounded arithmetic (never the solver's numbers):

   * floating-point Cholesky of ``B = fl(F(v) - sigma I)`` with
     ``sigma`` = (solver or LAPACK hint) minus a small slack, and the bound
     (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed.,
     Thm 10.3; the approach of Rump, BIT 46 (2006) 433-452): if the computed
     factor ``R`` exists then ``R^T R = B + dB`` with
     ``|dB| <= gamma_{n+1} |R^T| |R|``, so
     ``lambda_min(B) >= -gamma_{n+1} ||R||_F^2``.  The assembly error
     ``|B - (F(v) - sigma I)| <= gamma_{K+w+3} S`` (``S = sum_k |w_k||G_k| +
     |sigma| I``, ``K`` terms, ``w`` roundings in each monomial weight) is
     bounded in the 2-norm by the largest row sum of ``S``.  Hence
     ``lambda_min(F(v)) >= sigma - gamma_{n+1}||R||_F^2 - gamma_{K+w+3}
     ||S||_inf - 4 n^2 eta`` (``eta`` = smallest subnormal, against gradual
     underflow; factors with a nonzero entry below ``2^-500`` are rejected).
     All these quantities are inflated by ``1 + 1e-10`` and the final
     subtraction is rounded down (``nextafter``).  See :func:`rigorous_lower_bound`.
   * exact rational ``LDL^T`` (:func:`exact_ldl`, in :class:`fractions.Fraction`)
     of ``F(v) - eps I`` for blocks up to ``EXACT_MAX`` rows whenever the
     floating-point test is inconclusive; it decides exactly and, when a
     pivot is ``<= 0``, yields an exact witness ``x = L^{-T} e_k``.
   * pencil blocks: ``lambda_min >= a + min(b mu_lo, b mu_hi)`` in exact
     rationals, with ``[mu_lo, mu_hi]`` a rigorous enclosure of the spectrum of
     ``M`` computed by the floating-point test above.

   A refutation needs a witness ``x`` (integers) with
   ``x^T (F(v) - eps I) x <= 0`` evaluated exactly from the integer term
   matrices (:func:`check_witness`).

Result vocabulary: ``"certified"`` (every block PD at every vertex, re-checked),
``"refuted"`` (an exactly checked witness), ``"undecided"`` (inaccurate or
failed solve, inconclusive re-check, not multi-affine), ``"error"`` (unknown
solver status).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from itertools import product
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from formsync_design.derive.families import MatrixFamily
from formsync_design.errors import InputError

__all__ = [
    "STATUS_MAP",
    "CLARABEL_OPTIONS",
    "SUBDIVISION_LIMIT",
    "EXACT_MAX",
    "SDP_MAX_BLOCK",
    "Box",
    "as_box",
    "box_vertices",
    "Witness",
    "FamilyMargin",
    "SolverStats",
    "KvCheck",
    "CertificationResult",
    "certify_box",
    "check_kv",
    "exact_ldl",
    "rigorous_lower_bound",
    "check_witness",
    "analyze",
    "Structure",
    "VertexResults",
    "evaluate_vertices",
    "uniform_refutation",
]

#: cvxpy status -> our solver outcome.  Anything not listed maps to ``"error"``.
STATUS_MAP: dict[str, str] = {
    "optimal": "ok",
    "optimal_inaccurate": "inaccurate",
    "infeasible": "failed",
    "infeasible_inaccurate": "failed",
    "unbounded": "failed",
    "unbounded_inaccurate": "failed",
    "infeasible_or_unbounded": "failed",
    "user_limit": "failed",
    "solver_error": "failed",
}

#: Clarabel tolerances.  The SDP is only a hint (every number is re-checked), so
#: 1e-7 is ample; the default 1e-8 stalls on degenerate (repeated-eigenvalue)
#: blocks such as complete graphs and ends "AlmostSolved" (optimal_inaccurate).
CLARABEL_OPTIONS: dict[str, float] = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7}

#: Blocks up to this order get the exact rational fallback (and never the pencil path).
EXACT_MAX = 24
#: Dense blocks larger than this take their hint from LAPACK rather than the SDP.
SDP_MAX_BLOCK = 64

_U = 2.0**-53  # unit roundoff
_ETA = 2.0**-1074  # smallest subnormal
_TINY_R = 2.0**-500
_INFL = 1.0 + 1e-10

Box = tuple[tuple[Fraction, Fraction], ...]


def _gamma(k: int) -> float:
    """Upper bound of ``gamma_k = k u / (1 - k u)`` (valid while ``k u < 0.01``)."""
    if k * _U >= 0.01:  # pragma: no cover - only for absurd sizes
        raise InputError(f"expected a matrix order below {int(0.01 / _U)}, received {k}")
    return 1.01 * k * _U


# ---------------------------------------------------------------------------
# boxes
# ---------------------------------------------------------------------------
def _frac(v: Any, what: str) -> Fraction:
    if isinstance(v, Fraction):
        return v
    if isinstance(v, bool):
        raise InputError(f"expected a number for {what}, received {v!r}")
    if isinstance(v, int):
        return Fraction(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if not math.isfinite(f):
            raise InputError(f"expected a finite number for {what}, received {v!r}")
        return Fraction(repr(f))  # the decimal the user typed (shortest repr)
    if isinstance(v, str):
        try:
            f = float(v)
        except ValueError:
            raise InputError(f"expected a number for {what}, received {v!r}") from None
        if not math.isfinite(f):
            raise InputError(f"expected a finite number for {what}, received {v!r}")
        return Fraction(v.strip())
    raise InputError(f"expected a number for {what}, received {type(v).__name__} {v!r}")


def as_box(box: Any, gains: Sequence[str] = ("K_o", "K_q", "beta")) -> Box:
    """Normalize a gain box to a tuple of exact ``(lo, hi)`` pairs in ``gains`` order.

    Parameters
    ----------
    box : mapping or sequence
        Per gain a value, a ``(lo, hi)`` pair or a
        :class:`~formsync_design.cli.options.GainRange`; as a mapping by gain name
        or as a sequence in ``gains`` order.  Floats are taken as the decimal
        they print as (``0.1`` is ``1/10``).

    Raises
    ------
    InputError
        Missing gains, reversed/non-finite bounds or a non-positive gain.

    Examples
    --------
    >>> as_box({"K_o": (1, 2), "K_q": 0.4, "beta": "0.3"})
    ((Fraction(1, 1), Fraction(2, 1)), (Fraction(2, 5), Fraction(2, 5)), (Fraction(3, 10), Fraction(3, 10)))
    """
    if isinstance(box, Mapping):
        unknown = [k for k in box if k not in gains]
        if unknown:
            raise InputError(f"expected gains {tuple(gains)}, received unknown {unknown}")
        missing = [g for g in gains if g not in box]
        if missing:
            raise InputError(f"expected a range for every gain {tuple(gains)}, missing {missing}")
        items = [box[g] for g in gains]
    else:
        items = list(box)
        if len(items) != len(gains):
            raise InputError(
                f"expected {len(gains)} gain ranges {tuple(gains)}, received {len(items)}"
            )
    out = []
    for g, it in zip(gains, items):
        if hasattr(it, "lo") and hasattr(it, "hi"):
            lo, hi = _frac(it.lo, g), _frac(it.hi, g)
        elif isinstance(it, (tuple, list)):
            if len(it) != 2:
                raise InputError(f"expected (lo, hi) for {g}, received {it!r}")
            lo, hi = _frac(it[0], g), _frac(it[1], g)
        else:
            lo = hi = _frac(it, g)
        if hi < lo:
            raise InputError(f"expected lo <= hi for {g}, received [{float(lo):g}, {float(hi):g}]")
        if lo <= 0:
            raise InputError(f"expected positive gains for {g}, received lower bound {float(lo):g}")
        out.append((lo, hi))
    return tuple(out)


def box_vertices(box: Box) -> list[tuple[Fraction, ...]]:
    """Distinct vertices of a box (a degenerate axis contributes one value).

    >>> len(box_vertices(((1, 2), (3, 3), (4, 5))))
    4
    """
    axes = [(lo,) if lo == hi else (lo, hi) for lo, hi in box]
    return [tuple(v) for v in product(*axes)]


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
    fro2 = np.einsum("vk,vk->v", flat, flat) * _INFL * (1.0 + _gamma(n * n + 1))
    out = _gamma(n + 1) * fro2 * _INFL + 4.0 * n * n * _ETA
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
    e1 = _gamma(k + weight_roundings + 3) * rowmax * _INFL * (1.0 + _gamma(n + k + 2))
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
    q = _quad_forms([m for _, _, m in terms], x)
    xx = sum(int(v) * int(v) for v in x)
    val = -Fraction(margin) * xx
    for (e, c, _), qk in zip(terms, q):
        if qk:
            val += _weight_exact(e, _nf(c), point) * qk
    return val


_COO_CACHE: dict[int, tuple[Any, list[int], list[int], list[int]]] = {}


def _coo(m: Any) -> tuple[list[int], list[int], list[int]]:
    """Nonzeros of an integer matrix as Python lists (cached per matrix object)."""
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


def _quad_forms(mats: Sequence[Any], x: Sequence[int]) -> list[int]:
    xi = [int(v) for v in x]
    out = []
    for m in mats:
        rows, cols, vals = _coo(m)
        s = 0
        for i, j, v in zip(rows, cols, vals):
            s += v * xi[i] * xi[j]
        out.append(s)
    return out


def _weight_exact(e: Sequence[int], c: Fraction, point: Sequence[Fraction]) -> Fraction:
    w = _nf(c)
    for g, k in zip(point, e):
        for _ in range(k):
            w *= g
    return w


def _round_vector(x: np.ndarray, bits: int = 24) -> list[int]:
    x = np.asarray(x, dtype=float)
    s = np.abs(x).max()
    if not np.isfinite(s) or s == 0:
        return []
    return [int(v) for v in np.rint(x / s * 2.0**bits)]


# ---------------------------------------------------------------------------
# structure analysis
# ---------------------------------------------------------------------------
@dataclass
class _Pencil:
    m: Any  # csr integer matrix
    alphas: list[Fraction]
    betas: list[Fraction]
    mu_min_f: float = math.nan
    mu_max_f: float = math.nan
    mu_lo: Fraction | None = None
    mu_hi: Fraction | None = None
    vec_min: np.ndarray | None = None
    vec_max: np.ndarray | None = None


@dataclass
class _Block:
    index: int
    size: int
    exps: list[tuple[int, ...]]
    coefs: list[Fraction]
    mats: list[Any]  # integer dense arrays (or csr for pencil blocks)
    multiaffine: bool
    pencil: _Pencil | None = None
    roundings: int = 1
    # where it occurs: list of (group index, row indices in the family)
    places: list[tuple[int, np.ndarray]] = field(default_factory=list)

    @property
    def terms(self) -> list[tuple[tuple[int, ...], Fraction, Any]]:
        return list(zip(self.exps, self.coefs, self.mats))


@dataclass
class _Group:
    index: int
    family: MatrixFamily  # representative
    names: list[str]
    spacecraft: list[int]
    blocks: list[int]  # block indices


@dataclass
class Structure:
    """Deduplicated, block-decomposed view of a set of families (see module doc)."""

    gains: tuple[str, ...]
    groups: list[_Group]
    blocks: list[_Block]
    n_families: int

    def describe(self) -> str:
        kinds = []
        npen = sum(1 for b in self.blocks if b.pencil is not None)
        kinds.append(
            f"{self.n_families} families -> {len(self.groups)} distinct -> "
            f"{len(self.blocks)} distinct diagonal blocks (largest {max(b.size for b in self.blocks)})"
        )
        if npen:
            kinds.append(f"{npen} pencil block(s) a I + b M via a spectrum enclosure of M")
        return "; ".join(kinds)


def _family_key(f: MatrixFamily) -> tuple:
    parts = []
    for t in f.terms:
        m = t.matrix
        if sp.issparse(m):
            c = sp.csr_matrix(m)
            c.sort_indices()
            c.eliminate_zeros()
            data = (c.indptr.tobytes(), c.indices.tobytes(), np.asarray(c.data, dtype=np.int64).tobytes())
        else:
            data = (np.asarray(m, dtype=np.int64).tobytes(),)
        parts.append((tuple(int(e) for e in t.exponents), _nf(t.coefficient), data))
    return (f.size, tuple(parts))


def _pencil_of(mats_csr: list[Any]) -> tuple[Any, list[Fraction], list[Fraction]] | None:
    n = mats_csr[0].shape[0]
    eye = sp.identity(n, dtype=np.int64, format="csr")
    base = None
    for m in mats_csr:
        d = m.diagonal()
        offd = m - sp.diags(d, dtype=np.int64)
        if offd.count_nonzero() or np.any(d != d[0]):
            base = m
            break
    if base is None:
        return None
    boff = (base - sp.diags(base.diagonal(), dtype=np.int64)).tocoo()
    if boff.nnz == 0:
        return None
    i0, j0, v0 = int(boff.row[0]), int(boff.col[0]), int(boff.data[0])
    alphas, betas = [], []
    for m in mats_csr:
        b = Fraction(int(m[i0, j0]), v0)
        a = Fraction(int(m[0, 0])) - b * int(base[0, 0])
        den = a.denominator * b.denominator
        resid = m * den - eye * int(a * den) - base * int(b * den)
        if resid.count_nonzero():
            return None
        alphas.append(a)
        betas.append(b)
    return sp.csr_matrix(base, dtype=np.int64), alphas, betas


_STRUCT_CACHE: dict[int, tuple[Any, Structure]] = {}


def analyze(families: Sequence[MatrixFamily]) -> Structure:
    """Deduplicate families and split them into distinct diagonal blocks.

    Parameters
    ----------
    families : sequence of MatrixFamily (all over the same gains)

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> s = analyze(derive_conditions("ring:6").families)
    >>> len(s.groups), sorted(b.size for b in s.blocks)
    (2, [1, 3, 6])
    """
    fams = tuple(families)
    ck = id(fams[0]) if len(fams) == 1 else hash(tuple(id(f) for f in fams))
    hit = _STRUCT_CACHE.get(ck)
    if hit is not None and len(hit[0]) == len(fams) and all(a is b for a, b in zip(hit[0], fams)):
        return hit[1]
    gains = fams[0].gains
    for f in fams:
        if f.gains != gains:
            raise InputError(f"expected families over gains {gains}, received {f.gains} in {f.name}")
    groups: list[_Group] = []
    gkeys: dict[tuple, int] = {}
    for f in fams:
        k = _family_key(f)
        gi = gkeys.get(k)
        if gi is None:
            gi = len(groups)
            gkeys[k] = gi
            groups.append(_Group(gi, f, [], [], []))
        groups[gi].names.append(f.name)
        if f.spacecraft is not None:
            groups[gi].spacecraft.append(int(f.spacecraft))
    blocks: list[_Block] = []
    bkeys: dict[tuple, int] = {}
    for g in groups:
        f = g.family
        csrs = [sp.csr_matrix(t.matrix, dtype=np.int64) for t in f.terms]
        pattern = sp.csr_matrix((f.size, f.size), dtype=np.int64)
        for c in csrs:
            pattern = pattern + abs(c)
        ncomp, labels = csgraph.connected_components(pattern, directed=False)
        for comp in range(ncomp):
            rows = np.flatnonzero(labels == comp)
            subs = [c[rows][:, rows] for c in csrs]
            keep = [i for i, s in enumerate(subs) if s.count_nonzero()]
            exps = [tuple(int(e) for e in f.terms[i].exponents) for i in keep]
            coefs = [_nf(f.terms[i].coefficient) for i in keep]
            subs = [subs[i] for i in keep]
            key = (len(rows), tuple(
                (e, c, s.toarray().tobytes() if len(rows) <= 64 else _family_key_csr(s))
                for e, c, s in zip(exps, coefs, subs)
            ))
            bi = bkeys.get(key)
            if bi is None:
                bi = len(blocks)
                bkeys[key] = bi
                maff = all(max(e, default=0) <= 1 for e in exps)
                pen = None
                if len(rows) > EXACT_MAX:
                    pr = _pencil_of(subs)
                    if pr is not None:
                        pen = _Pencil(pr[0], pr[1], pr[2])
                mats: list[Any] = subs if pen is not None else [s.toarray() for s in subs]
                rnd = 2 * max((sum(e) for e in exps), default=0) + 1
                blocks.append(_Block(bi, len(rows), exps, coefs, mats, maff, pen, rnd))
            blocks[bi].places.append((g.index, rows))
            g.blocks.append(bi)
    st = Structure(gains, groups, blocks, len(fams))
    if len(_STRUCT_CACHE) > 32:
        _STRUCT_CACHE.clear()
    _STRUCT_CACHE[ck] = (fams, st)
    return st


def _nf(c: Any) -> Fraction:
    """A Fraction with Python-int numerator and denominator (numpy ints break hashing)."""
    c = Fraction(c)
    return Fraction(int(c.numerator), int(c.denominator))


def _family_key_csr(s: Any) -> tuple:
    c = sp.csr_matrix(s)
    c.sort_indices()
    return (c.indptr.tobytes(), c.indices.tobytes(), np.asarray(c.data, dtype=np.int64).tobytes())


def _pencil_spectrum(p: _Pencil) -> None:
    """Rigorous enclosure ``mu_lo <= lambda(M) <= mu_hi`` (computed once)."""
    if p.mu_lo is not None:
        return
    from scipy.linalg import eigh as _eigh

    md = p.m.toarray().astype(float)
    n = md.shape[0]
    e0, v0 = _eigh(md, subset_by_index=[0, 0])  # extreme eigenpairs only (dsyevr)
    e1, v1 = _eigh(md, subset_by_index=[n - 1, n - 1])
    p.mu_min_f, p.mu_max_f = float(e0[0]), float(e1[0])
    p.vec_min, p.vec_max = v0[:, 0], v1[:, 0]
    scale = float(np.abs(md).sum(axis=1).max())
    slack = 64 * n * _U * max(scale, 1.0) + 1e-12 * max(scale, 1.0)
    m_int = p.m.toarray()
    lo = rigorous_lower_bound([m_int], np.array([[1.0]]), np.array([p.mu_min_f - slack]))[0]
    hi = rigorous_lower_bound([-m_int], np.array([[1.0]]), np.array([-p.mu_max_f - slack]))[0]
    if not (np.isfinite(lo) and np.isfinite(hi)):  # pragma: no cover - should not happen
        # fall back to Gershgorin: |lambda| <= max row sum (exact integers)
        r = int(np.abs(m_int).sum(axis=1).max())
        p.mu_lo, p.mu_hi = Fraction(-r), Fraction(r)
        return
    p.mu_lo, p.mu_hi = Fraction(float(lo)), -Fraction(float(hi))


# ---------------------------------------------------------------------------
# vertex evaluation
# ---------------------------------------------------------------------------
@dataclass
class VertexResults:
    """Per block, per point: status (1 certified, -1 refuted, 0 undecided),
    rigorous lower bound of ``lambda_min`` (float, ``-inf`` unknown), float hint,
    and exact witnesses ``{point index: integer vector}``."""

    status: list[np.ndarray]
    lower: list[np.ndarray]
    hint: list[np.ndarray]
    witness: list[dict[int, list[int]]]
    method: dict[str, int]


def _float_gains(points: Sequence[Sequence[Fraction]]) -> np.ndarray:
    return np.array([[float(g) for g in p] for p in points], dtype=float).reshape(len(points), -1)


def _float_weights(block: _Block, gf: np.ndarray) -> np.ndarray:
    w = np.empty((gf.shape[0], len(block.exps)))
    for k, (e, c) in enumerate(zip(block.exps, block.coefs)):
        col = np.full(gf.shape[0], float(c))
        for a, ea in enumerate(e):
            for _ in range(ea):
                col = col * gf[:, a]
        w[:, k] = col
    return w


def _margin_up(margin: Fraction) -> float:
    m = float(margin)
    if Fraction(m) < margin:
        m = float(np.nextafter(m, np.inf))
    return m


def evaluate_vertices(
    st: Structure,
    points: Sequence[Sequence[Fraction]],
    margin: Fraction = Fraction(0),
    *,
    candidates: Mapping[int, float] | None = None,
    blocks: Sequence[int] | None = None,
) -> VertexResults:
    """Decide ``F_b(p) - margin I > 0`` for every block ``b`` at every point.

    Each decision is rigorous (see module doc): status ``1`` comes with a
    rigorous lower bound ``> margin``; status ``-1`` with an exact witness.

    Parameters
    ----------
    st : Structure (from :func:`analyze`)
    points : sequence of exact gain points
    margin : Fraction
    candidates : {block index: level}, optional
        Candidate certificate levels (e.g. from the SDP); the shift used is
        ``min(candidate, hint) - slack``.
    blocks : optional subset of block indices

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> st = analyze(derive_conditions("ring:4").families)
    >>> r = evaluate_vertices(st, [(F(16, 10), F(4, 10), F(3, 10))])
    >>> [int(s[0]) for s in r.status]
    [1, 1, 1]
    """
    pts = [tuple(Fraction(g) for g in p) for p in points]
    gf = _float_gains(pts)
    nv = len(pts)
    m_up = _margin_up(margin)
    bl = range(len(st.blocks)) if blocks is None else blocks
    status, lower, hint, wit = [], [], [], []
    method = {"float-cholesky": 0, "exact-ldl": 0, "pencil": 0, "witness": 0, "undecided": 0}
    for bi in range(len(st.blocks)):
        if bi not in bl:
            status.append(np.zeros(nv, dtype=np.int8))
            lower.append(np.full(nv, -np.inf))
            hint.append(np.full(nv, np.nan))
            wit.append({})
            continue
        b = st.blocks[bi]
        s_, lo_, h_, w_ = _eval_block(b, pts, gf, margin, m_up, (candidates or {}).get(bi), method)
        status.append(s_)
        lower.append(lo_)
        hint.append(h_)
        wit.append(w_)
    return VertexResults(status, lower, hint, wit, method)


def _eval_block(
    b: _Block,
    pts: list[tuple[Fraction, ...]],
    gf: np.ndarray,
    margin: Fraction,
    m_up: float,
    cand: float | None,
    method: dict[str, int],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, list[int]]]:
    nv = len(pts)
    status = np.zeros(nv, dtype=np.int8)
    lower = np.full(nv, -np.inf)
    wit: dict[int, list[int]] = {}
    w = _float_weights(b, gf)
    if b.pencil is not None:
        p = b.pencil
        _pencil_spectrum(p)
        a_f = w @ np.array([float(a) for a in p.alphas])
        b_f = w @ np.array([float(x) for x in p.betas])
        hint = a_f + np.minimum(b_f * p.mu_min_f, b_f * p.mu_max_f)
        for i, pt in enumerate(pts):
            ws = [_weight_exact(e, c, pt) for e, c in zip(b.exps, b.coefs)]
            a = sum((wk * ak for wk, ak in zip(ws, p.alphas)), Fraction(0))
            bb = sum((wk * bk for wk, bk in zip(ws, p.betas)), Fraction(0))
            ell = a + min(bb * p.mu_lo, bb * p.mu_hi)
            if ell > margin:
                status[i] = 1
                lower[i] = _down(ell)
                method["pencil"] += 1
                continue
            if bb == 0:
                x = [1] + [0] * (b.size - 1)
            else:
                x = _round_vector(p.vec_min if bb > 0 else p.vec_max)
            if x and _witness_ok(b, pt, x, margin):
                status[i] = -1
                wit[i] = x
                method["witness"] += 1
            else:
                method["undecided"] += 1
        return status, lower, hint, wit
    mats = b.mats
    stack = np.einsum("vk,kij->vij", w, np.stack([np.asarray(m, dtype=float) for m in mats]))
    if b.size == 1:
        hint = stack[:, 0, 0].copy()
        vecs = None
    elif b.size <= 64:
        ev, vecs = np.linalg.eigh(stack)
        hint = ev[:, 0]
    else:
        from scipy.linalg import eigh as _eigh

        hint = np.empty(nv)
        vecs = np.empty((nv, b.size, 1))
        for i in range(nv):  # smallest eigenpair only (LAPACK dsyevr)
            wv, vv = _eigh(stack[i], subset_by_index=[0, 0])
            hint[i], vecs[i] = wv[0], vv
    scale = np.abs(stack).sum(axis=2).max(axis=1)
    slack = 64 * (b.size + len(mats)) * _U * np.maximum(scale, 1e-300)
    # the SDP level is used only where it could certify (a level at or below the
    # margin, e.g. from another vertex that fails, would waste this vertex)
    level = hint if cand is None else np.where(cand - slack > m_up, np.minimum(hint, cand), hint)
    sigma = level - slack
    try_f = sigma > m_up
    if np.any(try_f):
        ell = rigorous_lower_bound(mats, w[try_f], sigma[try_f], weight_roundings=b.roundings)
        idx = np.flatnonzero(try_f)
        lower[idx] = ell
        ok = ell > m_up
        status[idx[ok]] = 1
        method["float-cholesky"] += int(ok.sum())
    for i in np.flatnonzero(status == 0):
        pt = pts[i]
        # a witness from the eigenvector of the smallest eigenvalue
        if hint[i] <= float(margin) + 1e-6 * max(1.0, scale[i]):
            if vecs is not None:
                v = vecs[i][:, 0]
            elif b.size == 1:
                v = np.ones(1)
            else:
                v = np.linalg.eigh(stack[i])[1][:, 0]
            x = _round_vector(v)
            if x and _witness_ok(b, pt, x, margin):
                status[i] = -1
                wit[i] = x
                method["witness"] += 1
                continue
        if b.size <= EXACT_MAX:
            fm = _exact_matrix(b, pt, margin)
            pd, xw = exact_ldl(fm)
            method["exact-ldl"] += 1
            if pd:
                status[i] = 1
                lower[i] = max(lower[i], _down(margin))
            else:
                assert xw is not None
                den = 1
                for v in xw:
                    den = den * v.denominator // math.gcd(den, v.denominator)
                xi = [int(v * den) for v in xw]
                if _witness_ok(b, pt, xi, margin):
                    status[i] = -1
                    wit[i] = xi
                else:  # pragma: no cover - exact LDL^T witness is exact by construction
                    method["undecided"] += 1
        else:
            method["undecided"] += 1
    return status, lower, hint, wit


def _witness_ok(b: _Block, pt: Sequence[Fraction], x: Sequence[int], margin: Fraction) -> bool:
    """Exact test of ``x^T (F_b(pt) - margin I) x <= 0`` (integer arithmetic)."""
    q = _quad_forms(b.mats, x)
    xx = sum(int(v) * int(v) for v in x)
    return _quad_value_sign(b.exps, b.coefs, q, xx, pt, Fraction(margin)) <= 0


def _down(q: Fraction) -> float:
    f = float(q)
    if Fraction(f) > q:
        f = float(np.nextafter(f, -np.inf))
    return f


def _exact_matrix(b: _Block, pt: Sequence[Fraction], margin: Fraction) -> list[list[Fraction]]:
    n = b.size
    out = [[Fraction(0)] * n for _ in range(n)]
    for e, c, m in b.terms:
        wk = _weight_exact(e, c, pt)
        if wk == 0:
            continue
        rows, cols, vals = _coo(m)
        for i, j, v in zip(rows, cols, vals):
            out[i][j] += wk * v
    for i in range(n):
        out[i][i] -= margin
    return out


def uniform_refutation(
    b: Any, x: Sequence[int], points: Sequence[Sequence[Fraction]], margin: Fraction
) -> bool:
    """True when ``x^T (F_b(v) - margin I) x <= 0`` exactly at every point.

    For a multi-affine block and the vertices of a box this proves that every
    point of the box violates the condition (module doc).

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> st = analyze(derive_conditions("ring:4").families)
    >>> pi_block = max(st.blocks, key=lambda b: b.size)      # K_o I - beta L
    >>> box = box_vertices(((F(1, 10), F(1, 5)), (F(1), F(1)), (F(1, 2), F(1))))
    >>> uniform_refutation(pi_block, [1, -1, 1, -1], box, F(0))  # eigenvector of lambda_max(L)
    True
    """
    if not b.multiaffine:
        return False
    q = _quad_forms(b.mats, x)
    xx = sum(int(v) * int(v) for v in x)
    return all(_quad_value_sign(b.exps, b.coefs, q, xx, pt, Fraction(margin)) <= 0
               for pt in points)


def _quad_value_sign(
    exps: Sequence[tuple[int, ...]],
    coefs: Sequence[Fraction],
    q: Sequence[int],
    xx: int,
    pt: Sequence[Fraction],
    margin: Fraction,
) -> int:
    """Sign of ``sum_k c_k p^{e_k} q_k - margin * xx`` in integer arithmetic
    (everything multiplied by one positive common denominator)."""
    # fast rejection: a float estimate clearly positive (its error is below
    # ~10 u * mag << 1e-6 mag); a non-positive value is always confirmed exactly
    approx = -float(margin) * xx
    mag = abs(approx)
    for e, c, qk in zip(exps, coefs, q):
        if qk:
            t = float(c) * qk
            for g, k in zip(pt, e):
                if k:
                    t *= float(g) ** k
            approx += t
            mag += abs(t)
    if approx > 1e-6 * mag:
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


# ---------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------
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
            "point": {k: _fr(v) for k, v in self.point.items()},
            "family": self.family,
            "spacecraft": self.spacecraft,
            "also_spacecraft": list(self.also),
            "x": list(self.x),
            "rows": list(self.rows),
            "value": _fr(self.value),
            "rayleigh_quotient": _fr(self.rayleigh),
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
    status: str
    lower: Fraction | None
    hint: float
    upper: Fraction | None
    worst_vertex: tuple[Fraction, ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "spacecraft": list(self.spacecraft),
            "size": self.size,
            "status": self.status,
            "certified_lower_bound": None if self.lower is None else _fr(self.lower),
            "hint_min_lambda": self.hint,
            "upper_bound": None if self.upper is None else _fr(self.upper),
            "worst_vertex": [_fr(v) for v in self.worst_vertex],
        }


@dataclass(frozen=True)
class SolverStats:
    """What the optimization (a hint) did."""

    solver: str
    raw_status: str
    outcome: str  # ok | inaccurate | failed | error | skipped
    solve_time: float
    iterations: int | None
    constraints: int
    value: float | None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "solver": self.solver,
            "raw_status": self.raw_status,
            "outcome": self.outcome,
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
            "ubar": _fr(self.ubar),
            "kv": [_fr(v) for v in self.kv],
            "required_kv": list(self.required),
            "failing_spacecraft": list(self.failing),
            "note": self.note,
        }


@dataclass(frozen=True)
class CertificationResult:
    """Outcome of :func:`certify_box` (status plus evidence)."""

    status: str
    gains: tuple[str, ...]
    box: Box
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
        return self.status == "certified"

    @property
    def margin_lower_bound(self) -> Fraction | None:
        """Rigorous lower bound of the smallest eigenvalue over all families and the box."""
        vals = [f.lower for f in self.families]
        if not vals or any(v is None for v in vals):
            return None
        return min(v for v in vals if v is not None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "graph": self.graph,
            "n": self.n,
            "conditions": self.source,
            "box": {g: [_fr(lo), _fr(hi)] for g, (lo, hi) in zip(self.gains, self.box)},
            "margin": _fr(self.margin),
            "certified_margin": None
            if self.margin_lower_bound is None
            else _fr(self.margin_lower_bound),
            "families": [f.to_dict() for f in self.families],
            "witness": None if self.witness is None else self.witness.to_dict(),
            "kv": None if self.kv is None else self.kv.to_dict(),
            "solver": self.solver.to_dict(),
            "argument": self.argument,
            "recheck": dict(self.recheck),
            "reason": self.reason,
            "elapsed_s": self.elapsed,
        }


def _fr(q: Fraction) -> dict[str, Any]:
    q = Fraction(q)
    return {"value": float(q), "exact": f"{q.numerator}/{q.denominator}" if q.denominator != 1 else str(q.numerator)}


# ---------------------------------------------------------------------------
# the SDP hint
# ---------------------------------------------------------------------------
def _sdp_levels(
    st: Structure, verts: list[tuple[Fraction, ...]]
) -> tuple[dict[int, float], SolverStats]:
    import cvxpy as cp

    gf = _float_gains(verts)
    nb = len(st.blocks)
    t = cp.Variable(nb)
    cons = []
    fixed: dict[int, float] = {}
    for b in st.blocks:
        w = _float_weights(b, gf)
        if b.pencil is not None:
            _pencil_spectrum(b.pencil)
            p = b.pencil
            a = w @ np.array([float(x) for x in p.alphas])
            bb = w @ np.array([float(x) for x in p.betas])
            for mu in (p.mu_min_f, p.mu_max_f):
                cons.append(a + bb * mu >= t[b.index])
        elif b.size <= SDP_MAX_BLOCK:
            mats = np.stack([np.asarray(m, dtype=float) for m in b.mats])
            for i in range(len(verts)):
                fv = np.einsum("k,kij->ij", w[i], mats)
                fv = 0.5 * (fv + fv.T)
                if b.size == 1:
                    cons.append(t[b.index] <= fv[0, 0])
                else:
                    cons.append(fv - t[b.index] * np.eye(b.size) >> 0)
        else:
            # left to the re-check's own LAPACK hint (no candidate level from the SDP)
            fixed[b.index] = math.nan
            cons.append(t[b.index] == 0)
    prob = cp.Problem(cp.Maximize(cp.sum(t)), cons)
    t0 = time.perf_counter()
    note = f"dense blocks larger than {SDP_MAX_BLOCK} rows: hint from LAPACK eigvalsh" if fixed else ""
    try:
        prob.solve(solver=cp.CLARABEL, **CLARABEL_OPTIONS)
        raw = str(prob.status)
    except cp.error.SolverError as e:
        raw = "solver_error"
        note = (note + "; " if note else "") + f"solver raised: {e}"
    elapsed = time.perf_counter() - t0
    outcome = STATUS_MAP.get(raw, "error")
    stats = getattr(prob, "solver_stats", None)
    iters = getattr(stats, "num_iters", None) if stats is not None else None
    stime = getattr(stats, "solve_time", None) if stats is not None else None
    levels: dict[int, float] = {}
    if outcome in ("ok", "inaccurate") and t.value is not None:
        levels = {i: float(t.value[i]) for i in range(nb) if i not in fixed}
    return levels, SolverStats(
        solver="CLARABEL",
        raw_status=raw,
        outcome=outcome,
        solve_time=float(stime) if stime is not None else elapsed,
        iterations=int(iters) if iters is not None else None,
        constraints=len(cons),
        value=float(prob.value) if outcome in ("ok", "inaccurate") and prob.value is not None else None,
        note=note,
    )


# ---------------------------------------------------------------------------
# K_v condition
# ---------------------------------------------------------------------------
def check_kv(
    kv: Any, inertias: Sequence[Any], ubar: Any, *, switching_matches: bool | None = True
) -> KvCheck:
    """Check ``K_vi >= K_vi*`` for every spacecraft with the derivation's bound
    (:func:`~formsync_design.derive.conditions.required_kv`, decided exactly by
    :func:`~formsync_design.derive.conditions.kv_condition_holds`).

    Parameters
    ----------
    kv : number or sequence of numbers (one per spacecraft)
    inertias : sequence of 3x3 arrays (one per spacecraft, kg m^2)
    ubar : number or sequence (per spacecraft): disturbance bound per axis (N m)
    switching_matches : bool or None
        ``conditions.switching_matches``; ``False`` means the K_v argument does not apply.

    Examples
    --------
    >>> import numpy as np
    >>> check_kv(0.01, [50 * np.eye(3)] * 2, 0.5).holds
    True
    """
    from formsync_design.derive.conditions import kv_condition_holds, required_kv

    n = len(inertias)

    def per(v: Any, what: str) -> list[Fraction]:
        vals = list(v) if isinstance(v, (list, tuple, np.ndarray)) else [v] * n
        if len(vals) != n:
            raise InputError(f"expected {n} {what} values (one per spacecraft), received {len(vals)}")
        out = [_frac(x, what) for x in vals]
        for x in out:
            if x <= 0:
                raise InputError(f"expected a positive {what}, received {float(x):g}")
        return out

    kq = per(kv, "K_v")
    ub = per(ubar, "disturbance bound")
    req = tuple(float(required_kv(J, float(u))) for J, u in zip(inertias, ub))
    fails = tuple(
        i + 1
        for i, (k, J, u) in enumerate(zip(kq, inertias, ub))
        if not kv_condition_holds(k, J, u)
    )
    note = ""
    if switching_matches is False:
        note = "the switching argument differs from rho_i: the K_v argument does not apply"
    return KvCheck(not fails and switching_matches is not False, max(ub), tuple(kq), req, fails, note)


# ---------------------------------------------------------------------------
# certify_box
# ---------------------------------------------------------------------------
_ARGUMENT = (
    "multi-affine families: x^T F(p) x is affine in each gain, so min over the box of "
    "lambda_min(F) is attained at a vertex; every distinct diagonal block is re-checked at "
    "every vertex (exact rational LDL^T, rigorous Cholesky bound, or exact pencil spectrum "
    "enclosure)"
)


def certify_box(
    conditions: Any,
    box: Any,
    *,
    margin: Any = 0,
    kv: KvCheck | None = None,
    use_sdp: bool = True,
) -> CertificationResult:
    """Decide whether every ``Theta_i`` and ``Pi`` is ``> margin I`` on a whole gain box.

    Parameters
    ----------
    conditions : LyapunovConditions
        From :func:`~formsync_design.derive.conditions.derive_conditions` or
        :func:`~formsync_design.derive.conditions.paper_conditions` (anything with
        ``families``, ``gains`` and ``graph`` attributes).
    box : see :func:`as_box`
    margin : number, default 0
        Require ``lambda_min > margin`` everywhere (``>= 0``).
    kv : KvCheck, optional
        Result of :func:`check_kv`; a failing check refutes.
    use_sdp : bool
        Solve the cvxpy/Clarabel SDP for the candidate levels (default).  With
        False the hints come from LAPACK; the re-check is the same.

    Returns
    -------
    CertificationResult
        ``status`` in ``certified``, ``refuted``, ``undecided``, ``error``.

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> r = certify_box(derive_conditions("ring:8"), {"K_o": (1.5, 1.7), "K_q": 0.4, "beta": 0.3})
    >>> r.status, r.solver.outcome
    ('certified', 'ok')
    >>> r = certify_box(derive_conditions("star:8"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    >>> r.status, r.witness.family
    ('refuted', 'Theta_1')
    """
    t_start = time.perf_counter()
    gains = tuple(conditions.gains)
    bx = as_box(box, gains)
    mg = _frac(margin, "margin")
    if mg < 0:
        raise InputError(f"expected a non-negative margin, received {float(mg):g}")
    st = analyze(conditions.families)
    verts = box_vertices(bx)
    maff = all(b.multiaffine for b in st.blocks)
    if use_sdp:
        levels, stats = _sdp_levels(st, verts)
    else:
        levels, stats = {}, SolverStats("none", "skipped", "skipped", 0.0, None, 0, None, "LAPACK hints")
    cand = levels if stats.outcome == "ok" else None
    vr = evaluate_vertices(st, verts, mg, candidates=cand)
    sub: dict[int, tuple[bool, Fraction | None, int]] = {}
    for b in st.blocks:
        if not b.multiaffine and not vr.witness[b.index]:
            sub[b.index] = _subdivide_certify(b, bx, mg, vr.method)
    fams, witness = _summarize(st, vr, verts, bx, mg, gains, sub)
    all_cert = all(_block_certified(st.blocks[i], vr, sub) for i in range(len(st.blocks)))
    reason = ""
    if witness is not None:
        status = "refuted"
        reason = f"{witness.family} is not > {float(mg):g} I at the gain point of the witness"
    elif kv is not None and not kv.holds:
        status = "refuted"
        reason = (
            f"K_v condition fails for spacecraft {list(kv.failing)}" if kv.failing else kv.note
        )
    elif stats.outcome == "error":
        status = "error"
        reason = f"unknown solver status {stats.raw_status!r}"
    elif not maff and not all_cert:
        status = "undecided"
        bad = sorted({st.groups[g].names[0] for b in st.blocks
                      if not b.multiaffine and not sub.get(b.index, (False,))[0]
                      for g, _ in b.places})
        nsub = sum(v[2] for v in sub.values())
        reason = (
            f"{bad} not multi-affine in the gains: the vertex argument does not apply and the "
            f"interval subdivision ({nsub} sub-boxes, limit {SUBDIVISION_LIMIT}) was inconclusive"
        )
    elif stats.outcome in ("inaccurate", "failed"):
        status = "undecided"
        reason = f"solver outcome {stats.outcome} ({stats.raw_status}): not certifying"
    elif all_cert:
        status = "certified"
    else:
        status = "undecided"
        reason = "re-check inconclusive at some vertex (eigenvalue too close to the margin)"
    if status == "refuted" and witness is None and kv is not None:
        fams = fams  # matrices may still be certified; the K_v condition refutes
    g = conditions.graph
    return CertificationResult(
        status=status,
        gains=gains,
        box=bx,
        margin=mg,
        source=str(getattr(conditions, "source", "?")),
        graph=str(getattr(g, "name", "graph")),
        n=int(getattr(g, "n", 0)),
        families=fams,
        witness=witness,
        solver=stats,
        argument=_ARGUMENT + ("; " + _ARGUMENT_SUB if sub else "") + "; structure: "
        + st.describe(),
        recheck={k: v for k, v in vr.method.items() if v},
        reason=reason,
        kv=kv,
        elapsed=time.perf_counter() - t_start,
    )


_ARGUMENT_SUB = (
    "non-multi-affine blocks: lambda_min(F(p)) >= lambda_min(F(c)) - sum_k dev_k ||G_k||_inf "
    "on sub-boxes with centre c (dev_k = exact interval bound of |w_k(p) - w_k(c)|, gains "
    "positive), with bisection"
)

#: Most sub-boxes the interval argument for a non-multi-affine block may use.
SUBDIVISION_LIMIT = 4096


def _block_certified(b: _Block, vr: VertexResults, sub: Mapping[int, tuple]) -> bool:
    if b.multiaffine:
        return bool(np.all(vr.status[b.index] == 1))
    return bool(sub.get(b.index, (False,))[0])


def _block_lower(b: _Block, vr: VertexResults, sub: Mapping[int, tuple]) -> Fraction:
    if b.multiaffine:
        return Fraction(float(vr.lower[b.index].min()))
    low = sub[b.index][1]
    assert low is not None
    return low


def _monomial_range(e: Sequence[int], c: Fraction, box: Box) -> tuple[Fraction, Fraction]:
    lo = _weight_exact(e, c, [a for a, _ in box])
    hi = _weight_exact(e, c, [b for _, b in box])
    return (lo, hi) if lo <= hi else (hi, lo)  # gains > 0: monotone in every factor


def _subdivide_certify(
    b: _Block, box: Box, mg: Fraction, method: dict[str, int], limit: int | None = None
) -> tuple[bool, Fraction | None, int]:
    """Interval argument with bisection for a block that is not multi-affine.

    On a sub-box ``B`` with centre ``c``, ``F(p) = F(c) + sum_k (w_k(p) - w_k(c)) G_k``
    and ``||G_k||_2 <= ||G_k||_inf`` (symmetric), so
    ``lambda_min(F(p)) >= lambda_min(F(c)) - sum_k dev_k r_k`` with ``dev_k`` an exact
    bound of ``|w_k(p) - w_k(c)|`` over ``B`` (monomials of positive gains are monotone).
    ``F(c) - (margin + sum dev_k r_k) I > 0`` is decided by the same rigorous
    re-check as a vertex.  Returns ``(certified, lower bound, sub-boxes used)``.
    """
    lim = SUBDIVISION_LIMIT if limit is None else limit
    rnorm = []
    for m in b.mats:
        arr = m.toarray() if sp.issparse(m) else np.asarray(m)
        rnorm.append(int(np.abs(arr).sum(axis=1).max()))
    stack = [box]
    used = 0
    lowest: Fraction | None = None
    while stack:
        bb = stack.pop()
        c = tuple((lo + hi) / 2 for lo, hi in bb)
        dev = Fraction(0)
        for e, co, r in zip(b.exps, b.coefs, rnorm):
            if r == 0:
                continue
            lo, hi = _monomial_range(e, co, bb)
            wc = _weight_exact(e, co, c)
            dev += max(hi - wc, wc - lo) * r
        need = mg + dev
        used += 1
        st_, low_, _, _ = _eval_block(b, [c], _float_gains([c]), need, _margin_up(need), None, method)
        if st_[0] == 1:
            ell = Fraction(float(low_[0])) if np.isfinite(low_[0]) else need
            cand = max(ell, need) - dev
            lowest = cand if lowest is None else min(lowest, cand)
            continue
        if used + len(stack) >= lim:
            return False, None, used
        halves = [[(lo, hi)] if lo == hi else [(lo, (lo + hi) / 2), ((lo + hi) / 2, hi)]
                  for lo, hi in bb]
        stack.extend(tuple(ch) for ch in product(*halves))
    return True, lowest, used


def _summarize(
    st: Structure,
    vr: VertexResults,
    verts: list[tuple[Fraction, ...]],
    bx: Box,
    mg: Fraction,
    gains: tuple[str, ...],
    sub: Mapping[int, tuple] | None = None,
) -> tuple[tuple[FamilyMargin, ...], Witness | None]:
    sub = sub or {}
    fams = []
    witness: Witness | None = None
    for g in st.groups:
        bids = sorted(set(g.blocks))
        hints = [vr.hint[b] for b in bids]
        hmin = min(float(np.nanmin(h)) for h in hints)
        # worst vertex by hint
        worst_b = min(bids, key=lambda b: float(np.nanmin(vr.hint[b])))
        worst_v = int(np.nanargmin(vr.hint[worst_b]))
        cert = all(_block_certified(st.blocks[b], vr, sub) for b in bids)
        lower = None
        if cert:
            lower = min(_block_lower(st.blocks[b], vr, sub) for b in bids)
        upper = None
        fam_status = "certified" if cert else "undecided"
        for b in bids:
            if vr.witness[b]:
                fam_status = "refuted"
                blk = st.blocks[b]
                # the witness with the smallest Rayleigh quotient
                best = None
                for vi, x in vr.witness[b].items():
                    xx = sum(v * v for v in x)
                    rq = check_witness(blk.terms, verts[vi], x, Fraction(0)) / xx
                    if best is None or rq < best[0]:
                        best = (rq, vi, x)
                assert best is not None
                rq, vi, x = best
                upper = rq if upper is None else min(upper, rq)
                if witness is None:
                    rows = next(r for gi, r in blk.places if gi == g.index)
                    fam = g.family
                    covers = uniform_refutation(blk, x, verts, mg)
                    x = _simplify_witness(blk, x, verts[vi], mg, verts if covers else None)
                    xx = sum(v * v for v in x)
                    rq = check_witness(blk.terms, verts[vi], x, Fraction(0)) / xx
                    upper = min(upper, rq)
                    full = [0] * fam.size
                    for loc, r in enumerate(rows.tolist()):
                        full[r] = x[loc]
                    labels = fam.row_labels or tuple(str(i + 1) for i in range(fam.size))
                    witness = Witness(
                        point=dict(zip(gains, verts[vi])),
                        family=g.names[0],
                        spacecraft=g.spacecraft[0] if g.spacecraft else None,
                        also=tuple(g.spacecraft),
                        x=tuple(full),
                        rows=tuple(labels[r] for r in range(fam.size) if full[r] != 0),
                        value=check_witness(
                            [(t.exponents, t.coefficient, t.matrix) for t in fam.terms],
                            verts[vi], full, mg,
                        ),
                        rayleigh=rq,
                        covers_box=covers,
                    )
        fams.append(
            FamilyMargin(
                name=_group_name(g),
                spacecraft=tuple(g.spacecraft),
                size=g.family.size,
                status=fam_status,
                lower=lower,
                hint=hmin,
                upper=upper,
                worst_vertex=verts[worst_v],
            )
        )
    return tuple(fams), witness


def _simplify_witness(
    blk: _Block, x: list[int], pt: tuple[Fraction, ...], mg: Fraction,
    cover: list[tuple[Fraction, ...]] | None,
) -> list[int]:
    """A witness with smaller integers (fewer bits of the same direction) when it
    still checks exactly (and still covers the box when the original did)."""
    big = max(abs(v) for v in x)
    for bits in (4, 8, 12, 16):
        scale = Fraction(2**bits, big)
        y = [int(round(v * scale)) for v in x]
        gcd = 0
        for v in y:
            gcd = math.gcd(gcd, v)
        if gcd == 0:
            continue
        y = [v // gcd for v in y]
        if check_witness(blk.terms, pt, y, mg) > 0:
            continue
        if cover is not None and not uniform_refutation(blk, y, cover, mg):
            continue
        return y
    return x


def _group_name(g: _Group) -> str:
    if len(g.names) == 1:
        return g.names[0]
    base = g.names[0].split("_")[0]
    return f"{base}_i (i = {_ranges(g.spacecraft)})" if g.spacecraft else g.names[0]


def _ranges(ids: Sequence[int]) -> str:
    ids = sorted(ids)
    out = []
    start = prev = ids[0]
    for v in ids[1:] + [None]:  # type: ignore[list-item]
        if v is not None and v == prev + 1:
            prev = v
            continue
        out.append(f"{start}" if start == prev else f"{start}-{prev}")
        if v is not None:
            start = prev = v
    return ",".join(out)
