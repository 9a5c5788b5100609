"""The optimization hint: one cvxpy + Clarabel SDP for candidate certificate levels.

``max sum_b t_b  s.t.  F_b(v) / s_b - t_b I >= 0`` for every reduced block ``b``
and vertex ``v`` (pencil blocks reduce to scalar constraints at the extreme
eigenvalues of ``M``; dense blocks larger than :data:`SDP_MAX_BLOCK` take their
hint from LAPACK).  Every solver status goes through
:data:`~formsync_design.certify.results.STATUS_MAP`.  The result is a hint
only: the re-check decides, whatever the solver said.
"""

from __future__ import annotations

import math
import time
from fractions import Fraction

import numpy as np

from formsync_design.certify.results import SolverOutcome, SolverStats, solver_outcome
from formsync_design.certify.structure import Structure, pencil_spectrum
from formsync_design.certify.vertices import float_gains, float_weights

__all__ = ["CLARABEL_OPTIONS", "SDP_MAX_BLOCK", "sdp_levels"]

#: Clarabel tolerances.  The SDP is only a hint (every number is re-checked), so
#: 1e-7 is ample; the default 1e-8 stalls on degenerate (repeated-eigenvalue)
#: blocks such as complete graphs and ends "AlmostSolved" (optimal_inaccurate).
CLARABEL_OPTIONS: dict[str, float] = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7}

#: Dense blocks larger than this take their hint from LAPACK rather than the SDP.
SDP_MAX_BLOCK = 64


def sdp_levels(
    st: Structure, verts: list[tuple[Fraction, ...]]
) -> tuple[dict[int, float], SolverStats]:
    """Candidate levels ``t_b <= lambda_min(F_b(v))`` for every block from one SDP.

    Each block is divided by its own scale (largest row sum of ``|F_b(v)|``
    over the vertices), so gains of very different magnitudes (``K_q = 4e10``
    beside ``beta = 3e4``) give a well-conditioned problem; the levels are
    scaled back.  The levels are only a hint for the re-check, never a verdict.

    >>> from fractions import Fraction as F
    >>> from formsync_design.certify.structure import analyze
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> st = analyze(derive_conditions("ring:4").families)
    >>> levels, stats = sdp_levels(st, [(F(16, 10), F(4, 10), F(3, 10))])
    >>> str(stats.outcome), len(levels) == len(st.blocks)
    ('ok', True)
    """
    import cvxpy as cp

    gf = float_gains(verts)
    nb = len(st.blocks)
    t = cp.Variable(nb)
    cons = []
    fixed: dict[int, float] = {}
    scales = np.ones(nb)
    for b in st.blocks:
        w = float_weights(b, gf)
        if b.pencil is not None:
            pencil_spectrum(b.pencil)
            p = b.pencil
            a = w @ np.array([float(x) for x in p.alphas])
            bb = w @ np.array([float(x) for x in p.betas])
            mu_abs = max(abs(p.mu_min_f), abs(p.mu_max_f))
            s = _scale(float(np.max(np.abs(a)) + np.max(np.abs(bb)) * mu_abs))
            scales[b.index] = s
            for mu in (p.mu_min_f, p.mu_max_f):
                cons.append((a + bb * mu) / s >= t[b.index])
        elif b.size <= SDP_MAX_BLOCK:
            mats = np.stack([np.asarray(m, dtype=float) for m in b.mats])
            fvs = np.einsum("vk,kij->vij", w, mats)
            s = _scale(float(np.abs(fvs).sum(axis=2).max()))
            scales[b.index] = s
            for i in range(len(verts)):
                fv = fvs[i] / s
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
    except (cp.error.SolverError, ArithmeticError, ValueError) as e:
        raw = "solver_error"
        note = (note + "; " if note else "") + f"solver raised: {type(e).__name__}"
    elapsed = time.perf_counter() - t0
    outcome = solver_outcome(raw)
    stats = getattr(prob, "solver_stats", None)
    iters = getattr(stats, "num_iters", None) if stats is not None else None
    stime = getattr(stats, "solve_time", None) if stats is not None else None
    levels: dict[int, float] = {}
    if outcome in (SolverOutcome.OK, SolverOutcome.INACCURATE) and t.value is not None:
        levels = {i: float(t.value[i]) * float(scales[i]) for i in range(nb) if i not in fixed}
        levels = {i: v for i, v in levels.items() if math.isfinite(v)}
    return levels, SolverStats(
        solver="CLARABEL",
        raw_status=raw,
        outcome=outcome,
        solve_time=float(stime) if stime is not None else elapsed,
        iterations=int(iters) if iters is not None else None,
        constraints=len(cons),
        value=float(prob.value) if levels and prob.value is not None else None,
        note=note,
    )




def _scale(s: float) -> float:
    return s if math.isfinite(s) and s > 0 else 1.0
