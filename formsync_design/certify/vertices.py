"""Decide ``F_b(p) - margin I > 0`` for every distinct block at many gain points.

Per block and point: a rigorous floating-point Cholesky bound (shift from the
LAPACK eigenvalue or a candidate level), an exact witness from the rounded
eigenvector, then exact rational ``LDL^T`` (dense for small blocks, sparse in a
minimum-degree order for large ones, pencil blocks included): the exact
fallback decides boundary-hugging points and exact ties (``K_o = beta
lambda_max(L)``) for any graph, within :data:`~formsync_design.certify.exact.EXACT_SPARSE_BUDGET`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from formsync_design.certify.exact import (
    EXACT_SPARSE_MAX,
    UNIT_ROUNDOFF,
    exact_ldl,
    exact_sparse_ldl,
    integer_coo,
    quad_forms,
    quad_value_sign,
    rigorous_lower_bound,
    round_down,
    round_up,
    round_vector,
    weight_exact,
)
from formsync_design.certify.structure import EXACT_MAX, Block, Structure, pencil_spectrum

__all__ = [
    "VertexResults",
    "float_gains",
    "float_weights",
    "evaluate_vertices",
    "evaluate_block",
    "witness_ok",
    "uniform_refutation",
]


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


def float_gains(points: Sequence[Sequence[Fraction]]) -> np.ndarray:
    """Gain points as a ``(V, G)`` float array (correctly rounded).

    >>> float_gains([(Fraction(1, 2), Fraction(3))]).tolist()
    [[0.5, 3.0]]
    """
    return np.array([[float(g) for g in p] for p in points], dtype=float).reshape(len(points), -1)


def float_weights(block: Block, gf: np.ndarray) -> np.ndarray:
    """Floating-point monomial weights ``c_k p^{e_k}`` of a block, shape ``(V, K)``.

    >>> from formsync_design.derive.conditions import derive_conditions
    >>> from formsync_design.certify.structure import analyze
    >>> b = analyze(derive_conditions("ring:4").families).blocks[0]
    >>> float_weights(b, np.array([[1.0, 2.0, 3.0]])).shape[0]
    1
    """
    w = np.empty((gf.shape[0], len(block.exps)))
    for k, (e, c) in enumerate(zip(block.exps, block.coefs)):
        col = np.full(gf.shape[0], float(c))
        for a, ea in enumerate(e):
            for _ in range(ea):
                col = col * gf[:, a]
        w[:, k] = col
    return w



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
    >>> from formsync_design.certify.structure import analyze
    >>> st = analyze(derive_conditions("ring:4").families)
    >>> r = evaluate_vertices(st, [(F(16, 10), F(4, 10), F(3, 10))])
    >>> [int(s[0]) for s in r.status]
    [1, 1, 1]
    """
    pts = [tuple(Fraction(g) for g in p) for p in points]
    gf = float_gains(pts)
    nv = len(pts)
    m_up = round_up(margin)
    bl = range(len(st.blocks)) if blocks is None else blocks
    status: list[np.ndarray] = []
    lower: list[np.ndarray] = []
    hint: list[np.ndarray] = []
    wit: list[dict[int, list[int]]] = []
    # ("exact-sparse-ldl" is added when used, keeping existing reports' counters unchanged)
    method = {"float-cholesky": 0, "exact-ldl": 0, "pencil": 0, "witness": 0, "undecided": 0}
    for bi in range(len(st.blocks)):
        if bi not in bl:
            status.append(np.zeros(nv, dtype=np.int8))
            lower.append(np.full(nv, -np.inf))
            hint.append(np.full(nv, np.nan))
            wit.append({})
            continue
        b = st.blocks[bi]
        s_, lo_, h_, w_ = evaluate_block(b, pts, gf, margin, m_up, (candidates or {}).get(bi), method)
        status.append(s_)
        lower.append(lo_)
        hint.append(h_)
        wit.append(w_)
    return VertexResults(status, lower, hint, wit, method)


def evaluate_block(
    b: Block,
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
    w = float_weights(b, gf)
    if b.pencil is not None:
        p = b.pencil
        pencil_spectrum(p)
        assert p.mu_lo is not None and p.mu_hi is not None
        assert p.vec_min is not None and p.vec_max is not None
        a_f = w @ np.array([float(a) for a in p.alphas])
        b_f = w @ np.array([float(x) for x in p.betas])
        hint = a_f + np.minimum(b_f * p.mu_min_f, b_f * p.mu_max_f)
        for i, pt in enumerate(pts):
            ws = [weight_exact(e, c, pt) for e, c in zip(b.exps, b.coefs)]
            a = sum((wk * ak for wk, ak in zip(ws, p.alphas)), Fraction(0))
            bb = sum((wk * bk for wk, bk in zip(ws, p.betas)), Fraction(0))
            ell_q = a + min(bb * p.mu_lo, bb * p.mu_hi)
            if ell_q > margin:
                status[i] = 1
                lower[i] = round_down(ell_q)
                method["pencil"] += 1
                continue
            exact_vec = p.exact_min if bb > 0 else p.exact_max
            if bb == 0:
                x = [1] + [0] * (b.size - 1)
            elif exact_vec is not None:  # exact eigenvector (closed-form spectrum)
                x = list(exact_vec)
            else:
                x = round_vector(p.vec_min if bb > 0 else p.vec_max)
            if x and witness_ok(b, pt, x, margin):
                status[i] = -1
                wit[i] = x
                method["witness"] += 1
            else:
                _exact_decide(b, pt, margin, i, status, lower, wit, method)
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
    slack = 64 * (b.size + len(mats)) * UNIT_ROUNDOFF * np.maximum(scale, 1e-300)
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
    for i in (int(k) for k in np.flatnonzero(status == 0)):
        pt = pts[i]
        # a witness from the eigenvector of the smallest eigenvalue
        if hint[i] <= float(margin) + 1e-6 * max(1.0, scale[i]):
            if vecs is not None:
                v = vecs[i][:, 0]
            elif b.size == 1:
                v = np.ones(1)
            else:
                v = np.linalg.eigh(stack[i])[1][:, 0]
            x = round_vector(v)
            if x and witness_ok(b, pt, x, margin):
                status[i] = -1
                wit[i] = x
                method["witness"] += 1
                continue
        _exact_decide(b, pt, margin, i, status, lower, wit, method)
    return status, lower, hint, wit



def _exact_decide(
    b: Block,
    pt: tuple[Fraction, ...],
    margin: Fraction,
    i: int,
    status: np.ndarray,
    lower: np.ndarray,
    wit: dict[int, list[int]],
    method: dict[str, int],
) -> None:
    """Exact rational ``LDL^T`` of ``F_b(pt) - margin I`` (dense up to ``EXACT_MAX``
    rows, sparse in a minimum-degree order up to ``EXACT_SPARSE_MAX``): decides
    exactly, with an exact witness when not PD; ``undecided`` only over budget."""
    pd: bool | None
    if b.size <= EXACT_MAX:
        pd, xw = exact_ldl(_exact_matrix(b, pt, margin))
        method["exact-ldl"] += 1
    elif b.size <= EXACT_SPARSE_MAX:
        pd, xw = exact_sparse_ldl(_exact_rows(b, pt, margin))
        method["exact-sparse-ldl"] = method.get("exact-sparse-ldl", 0) + 1
    else:
        pd, xw = None, None
    if pd is None:
        method["undecided"] += 1
        return
    if pd:
        status[i] = 1
        lower[i] = max(lower[i], round_down(margin))
        return
    assert xw is not None
    den = 1
    for q in xw:
        den = den * q.denominator // math.gcd(den, q.denominator)
    xi = [int(q * den) for q in xw]
    g = 0
    for xv in xi:
        g = math.gcd(g, xv)
    xi = [xv // g for xv in xi] if g > 1 else xi
    if witness_ok(b, pt, xi, margin):  # (counted under its exact method, as before)
        status[i] = -1
        wit[i] = xi
    else:  # pragma: no cover - an exact LDL^T witness is exact by construction
        method["undecided"] += 1


def _exact_rows(b: Block, pt: Sequence[Fraction], margin: Fraction) -> list[dict[int, Fraction]]:
    rows: list[dict[int, Fraction]] = [{} for _ in range(b.size)]
    for e, c, m in b.terms:
        wk = weight_exact(e, c, pt)
        if wk == 0:
            continue
        for r, col, v in zip(*integer_coo(m)):
            rows[r][col] = rows[r].get(col, Fraction(0)) + wk * v
    for r in range(b.size):
        rows[r][r] = rows[r].get(r, Fraction(0)) - margin
    return rows


def witness_ok(b: Block, pt: Sequence[Fraction], x: Sequence[int], margin: Fraction) -> bool:
    """Exact test of ``x^T (F_b(pt) - margin I) x <= 0`` (integer arithmetic).

    >>> from formsync_design.derive.conditions import derive_conditions
    >>> from formsync_design.certify.structure import analyze
    >>> st = analyze(derive_conditions("ring:4").families)
    >>> pi = max(st.blocks, key=lambda b: b.size)            # K_o I - beta L
    >>> pt = (Fraction(1), Fraction(1), Fraction(1))         # 1 - 4 < 0 on [1,-1,1,-1]
    >>> witness_ok(pi, pt, [1, -1, 1, -1], Fraction(0)), witness_ok(pi, pt, [1, 1, 1, 1], Fraction(0))
    (True, False)
    """
    q = quad_forms(b.mats, x)
    xx = sum(int(v) * int(v) for v in x)
    return quad_value_sign(b.exps, b.coefs, q, xx, pt, Fraction(margin)) <= 0




def _exact_matrix(b: Block, pt: Sequence[Fraction], margin: Fraction) -> list[list[Fraction]]:
    n = b.size
    out = [[Fraction(0)] * n for _ in range(n)]
    for e, c, m in b.terms:
        wk = weight_exact(e, c, pt)
        if wk == 0:
            continue
        rows, cols, vals = integer_coo(m)
        for i, j, v in zip(rows, cols, vals):
            out[i][j] += wk * v
    for i in range(n):
        out[i][i] -= margin
    return out


def uniform_refutation(
    b: Block, x: Sequence[int], points: Sequence[Sequence[Fraction]], margin: Fraction
) -> bool:
    """True when ``x^T (F_b(v) - margin I) x <= 0`` exactly at every point.

    For a multi-affine block and the vertices of a box this proves that every
    point of the box violates the condition (module doc).

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> from formsync_design.certify.structure import analyze
    >>> st = analyze(derive_conditions("ring:4").families)
    >>> pi_block = max(st.blocks, key=lambda b: b.size)      # K_o I - beta L
    >>> from itertools import product
    >>> box = list(product((F(1, 10), F(1, 5)), (F(1),), (F(1, 2), F(1))))
    >>> uniform_refutation(pi_block, [1, -1, 1, -1], box, F(0))  # eigenvector of lambda_max(L)
    True
    """
    if not b.multiaffine:
        return False
    q = quad_forms(b.mats, x)
    xx = sum(int(v) * int(v) for v in x)
    return all(quad_value_sign(b.exps, b.coefs, q, xx, pt, Fraction(margin)) <= 0
               for pt in points)

