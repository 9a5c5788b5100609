"""Structure of the certification problem: deduplicated families, diagonal blocks, pencils.

Families with identical content (e.g. ``Theta_i`` of spacecraft with equal
degree) are deduplicated; each family is split into the connected components
of its sparsity pattern (``Pi`` splits into the ``qdot`` block and ``n``
identical ``1x1`` blocks); identical blocks are deduplicated again.  A block
larger than :data:`EXACT_MAX` rows whose term matrices lie in a pencil
``span{I, M}`` (``Pi``'s ``qdot`` block is ``K_o I - beta L``) is a
:class:`Pencil`: its eigenvalues are ``a(p) + b(p) mu`` for the eigenvalues
``mu`` of ``M``, enclosed rigorously once by :func:`pencil_spectrum`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from formsync_design.certify.exact import UNIT_ROUNDOFF, exact_fraction, rigorous_lower_bound
from formsync_design.derive.families import MatrixFamily
from formsync_design.errors import InputError

__all__ = [
    "EXACT_MAX",
    "Pencil",
    "Block",
    "Group",
    "Structure",
    "analyze",
    "pencil_spectrum",
    "closed_form_extremes",
]

#: Blocks up to this order get the dense exact rational fallback (and never the pencil path).
EXACT_MAX = 24

@dataclass
class Pencil:
    """A block ``sum_k w_k(p) (alpha_k I + beta_k M)`` with one integer matrix ``M``."""

    m: Any  # csr integer matrix
    alphas: list[Fraction]
    betas: list[Fraction]
    mu_min_f: float = math.nan
    mu_max_f: float = math.nan
    mu_lo: Fraction | None = None
    mu_hi: Fraction | None = None
    vec_min: np.ndarray | None = None
    vec_max: np.ndarray | None = None
    #: exact integer eigenvectors of the extreme eigenvalues (closed-form spectra only)
    exact_min: list[int] | None = None
    exact_max: list[int] | None = None


@dataclass
class Block:
    """One distinct diagonal block: ``sum_k c_k p^{e_k} G_k`` with integer ``G_k``."""

    index: int
    size: int
    exps: list[tuple[int, ...]]
    coefs: list[Fraction]
    mats: list[Any]  # integer dense arrays (or csr for pencil blocks)
    multiaffine: bool
    pencil: Pencil | None = None
    roundings: int = 1
    # where it occurs: list of (group index, row indices in the family)
    places: list[tuple[int, np.ndarray]] = field(default_factory=list)

    @property
    def terms(self) -> list[tuple[tuple[int, ...], Fraction, Any]]:
        return list(zip(self.exps, self.coefs, self.mats))


@dataclass
class Group:
    """Families with identical content (one representative, all names)."""

    index: int
    family: MatrixFamily  # representative
    names: list[str]
    spacecraft: list[int]
    blocks: list[int]  # block indices


@dataclass
class Structure:
    """Deduplicated, block-decomposed view of a set of families (see module doc)."""

    gains: tuple[str, ...]
    groups: list[Group]
    blocks: list[Block]
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
            data: tuple[bytes, ...] = (
                c.indptr.tobytes(), c.indices.tobytes(), np.asarray(c.data, dtype=np.int64).tobytes()
            )
        else:
            data = (np.asarray(m, dtype=np.int64).tobytes(),)
        parts.append((tuple(int(e) for e in t.exponents), exact_fraction(t.coefficient), data))
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
        if max(abs(den), abs(int(a * den)), abs(int(b * den))) >= 2**62:
            return None  # not representable in int64: no pencil (the dense path decides)
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
    groups: list[Group] = []
    gkeys: dict[tuple, int] = {}
    for f in fams:
        k = _family_key(f)
        gi = gkeys.get(k)
        if gi is None:
            gi = len(groups)
            gkeys[k] = gi
            groups.append(Group(gi, f, [], [], []))
        groups[gi].names.append(f.name)
        if f.spacecraft is not None:
            groups[gi].spacecraft.append(int(f.spacecraft))
    blocks: list[Block] = []
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
            coefs = [exact_fraction(f.terms[i].coefficient) for i in keep]
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
                        pen = Pencil(pr[0], pr[1], pr[2])
                mats: list[Any] = subs if pen is not None else [s.toarray() for s in subs]
                rnd = 2 * max((sum(e) for e in exps), default=0) + 1
                blocks.append(Block(bi, len(rows), exps, coefs, mats, maff, pen, rnd))
            blocks[bi].places.append((g.index, rows))
            g.blocks.append(bi)
    st = Structure(gains, groups, blocks, len(fams))
    if len(_STRUCT_CACHE) > 32:
        _STRUCT_CACHE.clear()
    _STRUCT_CACHE[ck] = (fams, st)
    return st



def _family_key_csr(s: Any) -> tuple:
    c = sp.csr_matrix(s)
    c.sort_indices()
    return (c.indptr.tobytes(), c.indices.tobytes(), np.asarray(c.data, dtype=np.int64).tobytes())


def pencil_spectrum(p: Pencil) -> None:
    """Rigorous enclosure ``mu_lo <= lambda(M) <= mu_hi`` (computed once, stored on ``p``).

    >>> import scipy.sparse as sp
    >>> from fractions import Fraction as F
    >>> p = Pencil(sp.csr_matrix([[1, -1], [-1, 1]]), [F(1)], [F(0)])
    >>> pencil_spectrum(p)
    >>> p.mu_lo <= 0 and p.mu_hi >= 2
    True
    """
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
    slack = 64 * n * UNIT_ROUNDOFF * max(scale, 1.0) + 1e-12 * max(scale, 1.0)
    m_int = p.m.toarray()
    lo = rigorous_lower_bound([m_int], np.array([[1.0]]), np.array([p.mu_min_f - slack]))[0]
    hi = rigorous_lower_bound([-m_int], np.array([[1.0]]), np.array([-p.mu_max_f - slack]))[0]
    if not (np.isfinite(lo) and np.isfinite(hi)):  # pragma: no cover - should not happen
        # fall back to Gershgorin: |lambda| <= max row sum (exact integers)
        r = int(np.abs(m_int).sum(axis=1).max())
        p.mu_lo, p.mu_hi = Fraction(-r), Fraction(r)
        return
    p.mu_lo, p.mu_hi = Fraction(float(lo)), -Fraction(float(hi))
    cf = closed_form_extremes(p.m)
    if cf is not None:  # exact spectrum: ties decided without any factorization
        p.mu_lo, p.exact_min, p.mu_hi, p.exact_max = cf


def closed_form_extremes(m: Any) -> tuple[Fraction, list[int], Fraction, list[int]] | None:
    """Exact extreme eigenpairs of ``M = +-L`` for the Laplacian ``L`` of a complete
    graph or a star (closed-form spectra ``{0, n}`` and ``{0, 1, n}``), else ``None``.

    Returns ``(mu_min, x_min, mu_max, x_max)`` with integer eigenvectors.

    >>> import scipy.sparse as sp
    >>> from formsync_design.graphs.build import make_graph
    >>> closed_form_extremes(sp.csr_matrix(make_graph("star:4").laplacian))
    (Fraction(0, 1), [1, 1, 1, 1], Fraction(4, 1), [3, -1, -1, -1])
    >>> closed_form_extremes(sp.csr_matrix(make_graph("ring:5").laplacian)) is None
    True
    """
    a = sp.csr_matrix(m, dtype=np.int64)
    n = a.shape[0]
    if n < 3:
        return None
    for sign in (1, -1):
        lap = a * sign
        d = lap.diagonal()
        off = lap - sp.diags(d, dtype=np.int64)
        if np.any(off.data > 0) or np.any(np.asarray(lap.sum(axis=1)).ravel() != 0):
            continue
        if np.any(off.data != -1) and off.count_nonzero():
            continue
        ones = [1] * n
        res: tuple[Fraction, list[int]] | None = None
        if np.all(d == n - 1):  # complete: 0 (ones), n (e_0 - e_1)
            res = (Fraction(n), [1, -1] + [0] * (n - 2))
        else:
            hubs = np.flatnonzero(d == n - 1)
            if len(hubs) == 1 and np.count_nonzero(d == 1) == n - 1:  # star
                h = int(hubs[0])
                res = (Fraction(n), [n - 1 if i == h else -1 for i in range(n)])
        if res is None:
            continue
        if sign == 1:
            return Fraction(0), ones, res[0], res[1]
        return -res[0], res[1], Fraction(0), ones
    return None

