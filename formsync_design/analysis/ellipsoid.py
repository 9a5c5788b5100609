"""Ultimate bounds of a linear system with quadratically constrained inputs: an invariant,
attracting ellipsoid from an LMI, re-checked in exact rational arithmetic.

For ``x' = A x + B v`` with inputs constrained by ``g_k(x, v) = zeta^T G_k zeta + c_k >= 0``
(``zeta = (x, v)``, ``k = 1..K``: a norm bound ``|d|^2 <= dbar^2`` is ``G = -diag(0, I)``,
``c = dbar^2``; a sector bound on a state-dependent input is indefinite), suppose ``P > 0``,
``tau_k >= 0`` and ``alpha > 0`` satisfy

    Phi = [[A^T P + P A + alpha P, P B], [B^T P, 0]] + sum_k tau_k G_k <= 0,
    sum_k tau_k c_k <= alpha.

Then ``V = x^T P x`` has ``V' + alpha (V - 1) = zeta^T Phi_0 zeta - alpha <= -sum_k tau_k
zeta^T G_k zeta - alpha <= sum_k tau_k c_k - alpha <= 0`` whenever the constraints hold, so
``{V <= 1}`` is invariant and ``limsup V <= 1`` from every start: ultimately
``|C_j x| <= sqrt(C_j P^{-1} C_j^T)`` for every output row ``C_j`` (the S-procedure form of
the invariant-ellipsoid / bounded-real LMI, Boyd, El Ghaoui, Feron, Balakrishnan, *Linear
Matrix Inequalities in System and Control Theory*, SIAM 1994, section 6.1.3).

:func:`invariant_ellipsoid` searches ``alpha`` on a grid (refined around its best value), solves ``min max_j C_j P^{-1}
C_j^T`` for each by cvxpy + Clarabel, re-solves the best candidates with a strict margin
relative to their scale (the solver meets its constraints only to its tolerance), takes ``P``
and ``tau`` as exact rationals and re-checks every inequality exactly (``exact_ldl`` on
``-Phi`` and ``P``);
the bounds are the exact ``C_j P^{-1} C_j^T`` rounded up.  The solver's answer is only a
hint: a candidate that fails the exact re-check is discarded.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

__all__ = ["EllipsoidBound", "invariant_ellipsoid", "sqrt_up"]


@dataclass(frozen=True)
class EllipsoidBound:
    """A re-checked invariant ellipsoid ``{x^T P x <= 1}`` (``P``, ``tau`` exact) and the
    ultimate bounds ``|C_j x| <= bounds[j]`` (floats rounded up from exact values), ``tried``
    the number of ``alpha`` values solved;
    ``certified`` is False (and ``bounds`` infinite) when no grid value passed."""

    certified: bool
    alpha: Fraction | None
    P: tuple[tuple[Fraction, ...], ...] | None
    tau: tuple[Fraction, ...] | None
    bounds: tuple[float, ...]
    tried: int

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.gains import json_number

        return {"certified": self.certified,
                "alpha": None if self.alpha is None else json_number(self.alpha),
                "bounds": [json_number(b) for b in self.bounds], "tried": self.tried}


def sqrt_up(q: Fraction) -> float:
    """A float ``b >= sqrt(q)`` (checked exactly: ``b^2 >= q``).

    >>> sqrt_up(Fraction(4)), sqrt_up(Fraction(2)) ** 2 >= 2
    (2.0, True)
    """
    b = math.sqrt(float(q))
    while Fraction(b) ** 2 < q:
        b = math.nextafter(b, math.inf)
    return b


def _frac(a: np.ndarray) -> list[list[Fraction]]:
    return [[Fraction(float(x)) for x in row] for row in np.atleast_2d(a)]


def _solve_exact(P: list[list[Fraction]], b: list[Fraction]) -> list[Fraction]:
    """``P^{-1} b`` by exact Gaussian elimination (``P`` positive definite: no pivoting)."""
    n = len(P)
    a = [row[:] + [b[i]] for i, row in enumerate(P)]
    for k in range(n):
        for i in range(k + 1, n):
            if a[i][k] != 0:
                f = a[i][k] / a[k][k]
                a[i] = [x - f * y for x, y in zip(a[i], a[k])]
    x = [Fraction(0)] * n
    for i in range(n - 1, -1, -1):
        x[i] = (a[i][n] - sum((a[i][j] * x[j] for j in range(i + 1, n)), Fraction(0))) / a[i][i]
    return x


def _exact_check(A: list[list[Fraction]], B: list[list[Fraction]], G: Sequence[Any],
                 c: Sequence[Fraction], P: list[list[Fraction]], tau: list[Fraction],
                 alpha: Fraction) -> bool:
    from formsync_design.certify.exact import exact_ldl

    n, p = len(A), len(B[0]) if B else 0
    if any(t < 0 for t in tau) or sum((t * ck for t, ck in zip(tau, c)), Fraction(0)) > alpha:
        return False
    if not exact_ldl(P)[0]:
        return False
    m = n + p
    phi = [[Fraction(0)] * m for _ in range(m)]
    for i in range(n):
        for j in range(n):
            phi[i][j] = (sum((A[k][i] * P[k][j] + P[i][k] * A[k][j] for k in range(n)),
                             Fraction(0)) + alpha * P[i][j])
        for j in range(p):
            pb = sum((P[i][k] * B[k][j] for k in range(n)), Fraction(0))
            phi[i][n + j] = pb
            phi[n + j][i] = pb
    for t, Gk in zip(tau, G):
        if t == 0:
            continue
        for i in range(m):
            for j in range(m):
                if Gk[i][j] != 0:
                    phi[i][j] += t * Gk[i][j]
    return exact_ldl([[-x for x in row] for row in phi])[0]


def invariant_ellipsoid(A: np.ndarray, B: np.ndarray, G: Sequence[np.ndarray],
                        c: Sequence[float], C: np.ndarray,
                        alphas: Sequence[float] | None = None) -> EllipsoidBound:
    """The tightest re-checked ellipsoid over a grid of ``alpha`` (module docstring).

    ``A`` (n, n), ``B`` (n, p), ``G_k`` (n + p, n + p) symmetric, ``c_k`` >= 0, ``C`` (q, n);
    every float is taken as its exact binary value.  ``alphas`` default: 12 values
    log-spaced over ``[1e-3, 2] |max Re lambda(A)|``.

    >>> # x' = -2 x + d, |d| <= 1: the exact ultimate bound is 1/2 (alpha = 2)
    >>> r = invariant_ellipsoid(np.array([[-2.0]]), np.array([[1.0]]),
    ...                         [np.diag([0.0, -1.0])], [1.0], np.array([[1.0]]), [2.0])
    >>> r.certified, round(r.bounds[0], 4)
    (True, 0.5)
    """
    import cvxpy as cp

    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    C = np.atleast_2d(np.asarray(C, dtype=float))
    n, p = B.shape
    if alphas is None:
        rate = -float(np.linalg.eigvals(A).real.max())
        if rate <= 0:
            return EllipsoidBound(False, None, None, None, tuple([math.inf] * len(C)), 0)
        alphas = list(np.geomspace(rate * 1e-3, 2 * rate, 12))
    Af, Bf = _frac(A), _frac(B)
    Gf = [_frac(g) for g in G]
    cf = [Fraction(float(x)) for x in c]
    Cf = _frac(C)
    cands: list[tuple[float, float, np.ndarray]] = []
    Pv = cp.Variable((n, n), symmetric=True)
    tv = cp.Variable(len(G), nonneg=True)
    t = cp.Variable()
    al_p = cp.Parameter(nonneg=True)  # one compiled problem for the whole alpha grid (DPP)
    mg_p = cp.Parameter(nonneg=True)  # the strict margin of Phi, P and the constant condition
    top = A.T @ Pv + Pv @ A + al_p * Pv
    phi = cp.bmat([[top, Pv @ B], [B.T @ Pv, np.zeros((p, p))]])
    phi = phi + sum((tv[k] * G[k] for k in range(len(G))), np.zeros((n + p, n + p)))
    cvec = np.asarray(c, dtype=float)
    cons = [(phi + phi.T) / 2 << -mg_p * np.eye(n + p), Pv >> mg_p * np.eye(n),
            tv @ cvec <= al_p - mg_p]
    for row in C:
        cons.append(cp.bmat([[cp.reshape(t, (1, 1), order="C"), row[None, :]],
                             [row[:, None], Pv]]) >> 0)
    prob = cp.Problem(cp.Minimize(t), cons)

    def solve(al: float, margin: float) -> tuple[np.ndarray, np.ndarray, float] | None:
        al_p.value, mg_p.value = float(al), float(margin)
        try:
            prob.solve(solver=cp.CLARABEL)
        except cp.error.SolverError:
            return None
        if Pv.value is None or tv.value is None or t.value is None:
            return None
        return (Pv.value + Pv.value.T) / 2, np.maximum(tv.value, 0.0), float(t.value)

    for al in alphas:
        sol = solve(al, 1e-12)
        if sol is not None:
            cands.append((sol[2], float(al), sol[0]))
    if cands:  # refine around the best grid value (quarter and half octaves)
        best = min(cands, key=lambda x: x[0])[1]
        for f in (2**-0.5, 2**-0.25, 2**0.25, 2**0.5):
            sol = solve(best * f, 1e-12)
            if sol is not None:
                cands.append((sol[2], best * f, sol[0]))
    # the solver's objective orders the candidates; each is re-solved with a margin relative
    # to its own scale (the solver meets its constraints only to its tolerance) and the first
    # that passes the exact re-check decides (its bound is recomputed exactly)
    for _, al, P0 in sorted(cands, key=lambda x: x[0]):
        size = float(np.abs(P0).max()) * (1.0 + float(np.abs(A).max()) + al)
        for rel in (1e-7, 1e-6, 1e-5):
            sol = solve(al, rel * size)
            if sol is None:
                continue
            Pe = _frac(sol[0])
            te = [Fraction(float(x)) for x in sol[1]]
            ae = Fraction(al)
            if not _exact_check(Af, Bf, Gf, cf, Pe, te, ae):
                continue
            qs = []
            for row in Cf:
                x = _solve_exact(Pe, row)
                qs.append(sum((a * b for a, b in zip(row, x)), Fraction(0)))
            return EllipsoidBound(True, ae, tuple(tuple(r) for r in Pe), tuple(te),
                                  tuple(sqrt_up(q) for q in qs), len(cands))
    return EllipsoidBound(False, None, None, None, tuple([math.inf] * len(C)), len(alphas))
