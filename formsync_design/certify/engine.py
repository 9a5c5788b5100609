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
   (:mod:`formsync_design.certify.structure`)
2. **Optimization (hint).** The re-check (3.) first starts from LAPACK's
   eigenvalues.  Only when that leaves some block undecided (and no witness
   refutes the box) does :func:`certify_box` solve, with cvxpy + Clarabel,
   ``max t_b  s.t.  F_b(v) - t_b I >= 0`` for every reduced block ``b`` and
   vertex ``v`` (pencil blocks reduce to scalar constraints at the extreme
   eigenvalues of ``M``; dense blocks larger than ``SDP_MAX_BLOCK`` take their
   hint from LAPACK ``eigvalsh``; :mod:`formsync_design.certify.sdp`, each block
   scaled to unit size) and re-check the undecided blocks from those levels
   (``use_sdp="always"`` solves it first, for every box).  Every solver status
   is mapped through :data:`STATUS_MAP`.  The levels are a *hint*: an
   inaccurate, failed, unbounded or unknown solver outcome only means the
   re-check keeps LAPACK's eigenvalues; it never vetoes a re-checked
   certificate, and a box the re-check decides never needs it (nor cvxpy).
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
     of ``F(v) - eps I`` whenever the floating-point test is inconclusive:
     dense up to ``EXACT_MAX`` rows, sparse in a minimum-degree order
     (:func:`~formsync_design.certify.exact.exact_sparse_ldl`) for larger
     blocks, pencils included, within a work budget; it decides exactly (a
     point within 1e-13 of the boundary, an exact tie ``K_o = beta
     lambda_max(L)``) and, when a pivot is ``<= 0``, yields an exact witness
     ``x = L^{-T} e_k``.
   * pencil blocks: ``lambda_min >= a + min(b mu_lo, b mu_hi)`` in exact
     rationals, with ``[mu_lo, mu_hi]`` a rigorous enclosure of the spectrum of
     ``M`` computed by the floating-point test above.

   A refutation needs a witness ``x`` (integers) with
   ``x^T (F(v) - eps I) x <= 0`` evaluated exactly from the integer term
   matrices (:func:`check_witness`).

Result vocabulary (:class:`~formsync_design.certify.results.Status`):
``certified`` (every block PD at every vertex, re-checked, whatever the hint
said), ``refuted`` (an exactly checked witness), ``undecided`` (inconclusive
re-check, not multi-affine), ``error`` (unknown solver status *and* an
inconclusive re-check).  Only a certified result has a certified margin.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from fractions import Fraction
from itertools import product
from typing import Any

import numpy as np
import scipy.sparse as sp

from formsync_design.certify.exact import (
    round_up,
    weight_exact,
)
from formsync_design.certify.results import (
    CertificationResult,
    KvCheck,
    SolverOutcome,
    SolverStats,
    Status,
)
from formsync_design.certify.sdp import sdp_levels
from formsync_design.certify.structure import Block, Structure, analyze
from formsync_design.certify.summary import block_certified, summarize
from formsync_design.certify.vertices import (
    VertexResults,
    evaluate_block,
    evaluate_vertices,
    float_gains,
)
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, parse_number

__all__ = [
    "SUBDIVISION_LIMIT",
    "Bounds",
    "as_box",
    "box_vertices",
    "certify_box",
    "check_kv",
]

#: Exact ``(lo, hi)`` pairs of a box, in gain order (``GainBox.bounds``).
Bounds = tuple[tuple[Fraction, Fraction], ...]


def as_box(box: Any, gains: Sequence[str] = ("K_o", "K_q", "beta")) -> GainBox:
    """Normalize a gain box to a :class:`~formsync_design.gains.GainBox` over ``gains``.

    Parameters
    ----------
    box : mapping, sequence or GainBox
        Per gain a value, a ``(lo, hi)`` pair, an ``"LO:HI"`` string or a
        :class:`~formsync_design.gains.GainRange`; as a mapping by gain name
        or as a sequence in ``gains`` order.  Floats are taken as the decimal
        they print as (``0.1`` is ``1/10``).

    Raises
    ------
    InputError
        Missing gains, reversed/non-finite bounds or a non-positive gain.

    Examples
    --------
    >>> as_box({"K_o": (1, 2), "K_q": 0.4, "beta": "0.3"}).bounds
    ((Fraction(1, 1), Fraction(2, 1)), (Fraction(2, 5), Fraction(2, 5)), (Fraction(3, 10), Fraction(3, 10)))
    """
    return GainBox.parse(box, tuple(gains), positive=True)


def box_vertices(box: GainBox | Bounds) -> list[tuple[Fraction, ...]]:
    """Distinct vertices of a box (a degenerate axis contributes one value).

    >>> len(box_vertices(((1, 2), (3, 3), (4, 5))))
    4
    """
    if isinstance(box, GainBox):
        return box.vertices()
    axes = [(lo,) if lo == hi else (lo, hi) for lo, hi in box]
    return [tuple(v) for v in product(*axes)]


def check_kv(
    kv: Any, inertias: Sequence[Any], ubar: Any, *, switching_matches: bool | None = True
) -> KvCheck:
    """Check ``K_vi >= K_vi*`` for every spacecraft with the derivation's bound
    (:func:`~formsync_design.derive.closed_form.required_kv`, decided exactly by
    :func:`~formsync_design.derive.closed_form.kv_condition_holds`).

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
    from formsync_design.derive.closed_form import kv_condition_holds, required_kv

    n = len(inertias)

    def per(v: Any, what: str) -> list[Fraction]:
        vals = list(v) if isinstance(v, (list, tuple, np.ndarray)) else [v] * n
        if len(vals) != n:
            raise InputError(f"expected {n} {what} values (one per spacecraft), received {len(vals)}")
        out = [parse_number(x, what) for x in vals]
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
    use_sdp: bool | str = True,
) -> CertificationResult:
    """Decide whether every ``Theta_i`` and ``Pi`` is ``> margin I`` on a whole gain box.

    Parameters
    ----------
    conditions : LyapunovConditions
        From :func:`~formsync_design.derive.conditions.derive_conditions` or
        :func:`~formsync_design.derive.conditions.paper_conditions` (anything with
        ``families``, ``gains`` and ``graph`` attributes).
    box : mapping, sequence or GainBox
        The gain box (see :meth:`formsync_design.gains.GainBox.parse`); every gain ``> 0``.
    margin : number, default 0
        Require ``lambda_min > margin`` everywhere (``>= 0``).
    kv : KvCheck, optional
        Result of :func:`check_kv`; a failing check refutes.
    use_sdp : bool or "always"
        True (default): solve the cvxpy/Clarabel SDP for candidate levels only
        when the re-check from LAPACK's hints leaves a block undecided (the
        ``solver`` of the result then says ``skipped`` when it was not needed);
        ``"always"``: solve it first for every box; False: never.  The verdict
        always comes from the same exact/rigorous re-check.

    Returns
    -------
    CertificationResult
        ``status`` in ``certified``, ``refuted``, ``undecided``, ``error``.

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> r = certify_box(derive_conditions("ring:8"), {"K_o": (1.5, 1.7), "K_q": 0.4, "beta": 0.3})
    >>> str(r.status), str(r.solver.outcome)
    ('certified', 'skipped')
    >>> r = certify_box(derive_conditions("ring:8"), {"K_o": (1.5, 1.7), "K_q": 0.4, "beta": 0.3},
    ...                 use_sdp="always")
    >>> str(r.status), str(r.solver.outcome)
    ('certified', 'ok')
    >>> r = certify_box(derive_conditions("star:8"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    >>> str(r.status), r.witness.family
    ('refuted', 'Theta_1')
    """
    t_start = time.perf_counter()
    gains = tuple(conditions.gains)
    bx = as_box(box, gains)
    mg = parse_number(margin, "margin")
    if mg < 0:
        raise InputError(f"expected a non-negative margin, received {float(mg):g}")
    st = analyze(conditions.families)
    verts = bx.vertices()
    maff = all(b.multiaffine for b in st.blocks)
    if use_sdp not in (True, False, "always"):
        raise InputError(f"expected use_sdp True, False or 'always', received {use_sdp!r}")
    # the hint guides, never vetoes: a failed/inaccurate solve gives no candidate
    # levels (LAPACK hints instead), and blocks a candidate left undecided are
    # re-checked once more from their own LAPACK hint (and the other way round)
    if use_sdp == "always":
        levels, stats = sdp_levels(st, verts)
        cand = levels if stats.outcome in (SolverOutcome.OK, SolverOutcome.INACCURATE) else None
        vr = evaluate_vertices(st, verts, mg, candidates=cand)
        if cand:
            _retry(st, verts, mg, vr)
    else:
        vr = evaluate_vertices(st, verts, mg)
        stats = SolverStats("none", "skipped", SolverOutcome.SKIPPED, 0.0, None, 0, None,
                            "LAPACK hints" if not use_sdp else
                            "not needed: the re-check from LAPACK hints decided every block")
        if use_sdp and _needs_hint(st, vr):
            levels, stats = sdp_levels(st, verts)
            if stats.outcome in (SolverOutcome.OK, SolverOutcome.INACCURATE) and levels:
                _retry(st, verts, mg, vr, candidates=levels)
    sub: dict[int, tuple[bool, Fraction | None, int]] = {}
    for b in st.blocks:
        if not b.multiaffine and not vr.witness[b.index]:
            sub[b.index] = _subdivide_certify(b, bx.bounds, mg, vr.method)
    fams, witness = summarize(st, vr, verts, mg, gains, sub)
    all_cert = all(block_certified(st.blocks[i], vr, sub) for i in range(len(st.blocks)))
    reason = ""
    hint_note = ""
    if stats.outcome not in (SolverOutcome.OK, SolverOutcome.SKIPPED):
        hint_note = (f"the SDP hint was {stats.outcome} ({stats.raw_status}); "
                     "the verdict comes from the re-check alone")
    if witness is not None:
        status = Status.REFUTED
        reason = f"{witness.family} is not > {float(mg):g} I at the gain point of the witness"
    elif kv is not None and not kv.holds:
        status = Status.REFUTED
        reason = (
            f"K_v condition fails for spacecraft {list(kv.failing)}" if kv.failing else kv.note
        )
    elif all_cert:
        status = Status.CERTIFIED
        reason = hint_note
    elif not maff:
        status = Status.UNDECIDED
        bad = sorted({st.groups[g].names[0] for b in st.blocks
                      if not b.multiaffine and not sub.get(b.index, (False,))[0]
                      for g, _ in b.places})
        nsub = sum(v[2] for v in sub.values())
        reason = (
            f"{bad} not multi-affine in the gains: the vertex argument does not apply and the "
            f"interval subdivision ({nsub} sub-boxes, limit {SUBDIVISION_LIMIT}) was inconclusive"
        )
    elif stats.outcome == SolverOutcome.ERROR:
        status = Status.ERROR
        reason = (f"unknown solver status {stats.raw_status!r} and the re-check alone was "
                  "inconclusive")
    else:
        status = Status.UNDECIDED
        reason = ("re-check inconclusive at some vertex (eigenvalue too close to the margin, "
                  "exact fallback over its size/work limit)")
        if hint_note:
            reason += "; " + hint_note
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


def _needs_hint(st: Structure, vr: VertexResults) -> bool:
    """True when a multi-affine block is undecided at some vertex and no witness refutes
    the box (then, and only then, the SDP's levels could change the verdict)."""
    if any(vr.witness[b.index] for b in st.blocks):
        return False
    return any(b.multiaffine and np.any(vr.status[b.index] == 0) for b in st.blocks)


def _retry(
    st: Structure, verts: list[tuple[Fraction, ...]], mg: Fraction, vr: VertexResults,
    candidates: Mapping[int, float] | None = None,
) -> None:
    """Re-check the blocks left undecided, from ``candidates`` (the SDP's levels) or, when
    None, from their own LAPACK hints; a vertex keeps the first decision reached."""
    redo = [b.index for b in st.blocks if np.any(vr.status[b.index] == 0)]
    if not redo:
        return
    again = evaluate_vertices(st, verts, mg, candidates=candidates, blocks=redo)
    for bi in redo:
        better = (vr.status[bi] == 0) & (again.status[bi] != 0)
        vr.status[bi][better] = again.status[bi][better]
        vr.lower[bi][better] = again.lower[bi][better]
        for i in np.flatnonzero(better):
            if int(i) in again.witness[bi]:
                vr.witness[bi][int(i)] = again.witness[bi][int(i)]
    for k, v in again.method.items():
        if k != "undecided":
            vr.method[k] = vr.method.get(k, 0) + v
    vr.method["undecided"] = sum(int(np.sum(s == 0)) for s in vr.status)


_ARGUMENT_SUB = (
    "non-multi-affine blocks: lambda_min(F(p)) >= lambda_min(F(c)) - sum_k dev_k ||G_k||_inf "
    "on sub-boxes with centre c (dev_k = exact interval bound of |w_k(p) - w_k(c)|, gains "
    "positive), with bisection"
)

#: Most sub-boxes the interval argument for a non-multi-affine block may use.
SUBDIVISION_LIMIT = 4096


def _monomial_range(e: Sequence[int], c: Fraction, box: Bounds) -> tuple[Fraction, Fraction]:
    lo = weight_exact(e, c, [a for a, _ in box])
    hi = weight_exact(e, c, [b for _, b in box])
    return (lo, hi) if lo <= hi else (hi, lo)  # gains > 0: monotone in every factor


def _subdivide_certify(
    b: Block, box: Bounds, mg: Fraction, method: dict[str, int], limit: int | None = None
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
            wc = weight_exact(e, co, c)
            dev += max(hi - wc, wc - lo) * r
        need = mg + dev
        used += 1
        st_, low_, _, _ = evaluate_block(b, [c], float_gains([c]), need, round_up(need), None, method)
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


