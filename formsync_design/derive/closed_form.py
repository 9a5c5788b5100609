"""Closed-form positivity conditions of the derived families and the exact
``K_vi`` (disturbance rejection) condition."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from itertools import product
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

from formsync_design.errors import InputError
from formsync_design.models.inertia import check_inertia

if TYPE_CHECKING:
    from formsync_design.derive.lyapunov import LyapunovConditions

__all__ = ["ClosedFormCondition", "closed_form_conditions", "pi_pencils", "required_kv",
           "kv_condition_holds"]


# ---------------------------------------------------------------------------
# closed-form conditions
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ClosedFormCondition:
    """A closed-form necessary-and-sufficient condition ``expression > 0``.

    Attributes
    ----------
    family : str
        ``"Theta(m)"`` or ``"Pi"`` block name.
    expression : sympy.Expr
        Polynomial in the gains (and possibly ``m``, ``lambda``) that must be > 0.
    constants : dict
        Graph constants substituted (e.g. ``{"lambda_max(L)": 4.0}``).
    how : str
        How it was obtained (Schur complement, pencil spectrum).
    """

    family: str
    expression: sp.Expr
    constants: dict
    how: str
    gains: tuple[str, ...] = ("K_o", "K_q", "beta")

    def holds(self, point: tuple[float, ...]) -> bool:
        """Evaluate at a gain point (in :attr:`gains` order) in floating point."""
        sub: dict[Any, Any] = {sp.Symbol(n, positive=True): v for n, v in zip(self.gains, point)}
        sub.update({sp.Symbol(k): v for k, v in self.constants.items()})
        return float(self.expression.subs(sub)) > 0

    def substituted(self) -> sp.Expr:
        """The expression with the graph constants substituted (floating point)."""
        return self.expression.subs({sp.Symbol(k): v for k, v in self.constants.items()})


def closed_form_conditions(conds: LyapunovConditions) -> tuple[ClosedFormCondition, ...]:
    """Closed-form PD conditions where the structure allows them.

    ``Theta(m)``: when its edge block is ``c I_m`` and its coupling column is
    ``b 1``, Schur: ``Theta > 0  <=>  c > 0  and  c*Theta_00 - m b^2 > 0``.
    ``Pi``: block-diagonal with blocks in a pencil ``alpha I + gamma G``
    (``G`` the Laplacian or adjacency): PD iff ``alpha + gamma mu > 0`` at the
    extreme eigenvalues ``mu`` of ``G``.

    Examples
    --------
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> cf = closed_form_conditions(derive_conditions("ring:6"))
    >>> [str(c.expression) for c in cf if c.family.startswith("Theta")]
    ['K_o*beta/4 + K_q/4', 'K_o*beta/8 + K_q/8 - beta**2/2']
    """
    gens = tuple(sp.Symbol(n, positive=True) for n in conds.gains)
    out: list[ClosedFormCondition] = []
    seen: set[int] = set()
    for fam in conds.theta:
        m = fam.size - 1
        if m in seen:
            continue
        seen.add(m)
        T = fam.to_sympy(gens)
        c = T[1, 1]
        b = T[0, 1]
        if T[1:, 1:] == c * sp.eye(m) and all(T[0, k] == b for k in range(1, m + 1)):
            out.append(ClosedFormCondition(f"Theta(m={m})", sp.expand(c), {}, "edge block c I_m",
                                           conds.gains))
            out.append(ClosedFormCondition(
                f"Theta(m={m})", sp.expand(c * T[0, 0] - m * b**2), {},
                "Schur complement of the edge block c I_m", conds.gains,
            ))
    blocks = pi_pencils(conds)
    for label, (alpha, gamma, gname, lo, hi) in blocks.items():
        for mu, which in ((lo, "min"), (hi, "max")):
            if gamma == 0 and which == "max":
                continue
            lam = sp.Symbol(f"lambda_{which}({gname})")
            expr = sp.expand(alpha + gamma * lam) if gamma != 0 else sp.expand(alpha)
            consts = {str(lam): mu} if gamma != 0 else {}
            how = (f"{label} = alpha I + gamma {gname}: eigenvalues alpha + gamma mu, "
                   f"extreme at lambda_min/lambda_max({gname})" if gamma != 0 else
                   f"{label} = alpha I")
            out.append(ClosedFormCondition(f"Pi[{label}]", expr, consts, how, conds.gains))
    # remove duplicates (gamma == 0 gives the same expression twice)
    uniq: list[ClosedFormCondition] = []
    for c in out:
        if not any(u.family == c.family and sp.expand(u.expression - c.expression) == 0 for u in uniq):
            uniq.append(c)
    return tuple(uniq)


def pi_pencils(conds: LyapunovConditions) -> dict:
    """Decompose Pi's diagonal blocks as alpha I + gamma G when possible.

    Works term by term on the family (no dense symbolic matrix), so it scales
    to large graphs.  Returns ``{block: (alpha, gamma, G name, lambda_min(G),
    lambda_max(G))}``; empty when Pi has a cross block or a block outside
    such a pencil.
    """
    import scipy.sparse as sps

    g = conds.graph
    n = g.n
    gens = tuple(sp.Symbol(n, positive=True) for n in conds.gains)
    cands = {"L": sps.csr_matrix(g.laplacian), "Adj": sps.csr_matrix(g.adjacency)}
    eye = sps.identity(n, dtype=np.int64, format="csr")
    out = {}
    for label, sl in (("M", slice(0, n)), ("N", slice(n, 2 * n))):
        chosen = None
        for gname, G in cands.items():
            alpha: sp.Expr = sp.Integer(0)
            gamma: sp.Expr = sp.Integer(0)
            ok = True
            for t in conds.pi.terms:
                full = sps.csr_matrix(t.matrix)
                if label == "M" and (full[:n, n:].count_nonzero() or full[n:, :n].count_nonzero()):
                    return {}
                blk = full[sl, sl]
                if blk.count_nonzero() == 0:
                    continue
                i, j = g.edges[0]
                b = Fraction(int(blk[i, j]), int(G[i, j])) if G[i, j] != 0 else Fraction(0)
                a = Fraction(int(blk[0, 0])) - b * int(G[0, 0])
                den = a.denominator * b.denominator
                resid = blk * den - eye * int(a * den) - G * int(b * den)
                if resid.count_nonzero() != 0:
                    ok = False
                    break
                mono = sp.Integer(1)
                for sym, e in zip(gens, t.exponents):
                    mono *= sym**e
                c = sp.Rational(t.coefficient.numerator, t.coefficient.denominator) * mono
                alpha += c * sp.Rational(a.numerator, a.denominator)
                gamma += c * sp.Rational(b.numerator, b.denominator)
            if ok:
                ev = np.linalg.eigvalsh(G.toarray().astype(float)) if n <= 1500 else None
                if ev is None:  # pragma: no cover - very large graphs
                    return {}
                # a connected graph's Laplacian has lambda_min = 0 exactly
                lo = 0.0 if gname == "L" else float(ev[0])
                chosen = (sp.expand(alpha), sp.expand(gamma), gname, lo, float(ev[-1]))
                break
        if chosen is None:
            return {}
        out[label] = chosen
    return out


# ---------------------------------------------------------------------------
# disturbance bound (K_vi condition)
# ---------------------------------------------------------------------------
def required_kv(J: Any, ubar: float) -> float:
    """Smallest ``K_vi`` with ``eps_i >= 0`` for every attitude and every
    disturbance with ``|u_d,k| <= ubar``.

    ``A^{-1} Q^T u_d = E J^{-1} u_d`` (``E = (q0 I + q^x)/2``); ``2E`` has
    singular values ``{1, 1, q0}`` and rotates a vector by at most 90 degrees,
    so ``sup_q ||E y||_inf = ||y||_2 / 2``; the convex ``||J^{-1}u||_2`` is
    maximal at a vertex of the disturbance box.  Hence
    ``K_vi* = (ubar/2) max_{v in {-1,1}^3} ||J^{-1} v||_2``.

    Examples
    --------
    >>> round(required_kv(50 * np.eye(3), 1.0), 6)
    0.017321
    """
    Jm = check_inertia(J)
    if not (np.isfinite(ubar) and ubar > 0):
        raise InputError(f"expected a positive finite disturbance bound, received {ubar!r}")
    Ji = np.linalg.inv(Jm)
    best = max(float(np.linalg.norm(Ji @ np.array(v, dtype=float))) for v in product((-1, 1), repeat=3))
    return 0.5 * ubar * best


def kv_condition_holds(kv: Any, J: Any, ubar: Any) -> bool:
    """Exact check of ``K_vi >= K_vi*`` in rational arithmetic.

    Compares ``K_vi^2 >= (ubar^2/4) v^T J^{-2} v`` for all sign vectors ``v``
    with ``J``, ``ubar``, ``K_vi`` converted exactly to rationals.

    Examples
    --------
    >>> kv_condition_holds(0.01, 50 * np.eye(3), 0.5)
    True
    """
    Jm = check_inertia(J)
    kv_f = Fraction(kv) if not isinstance(kv, float) else Fraction(kv)
    if kv_f <= 0:
        raise InputError(f"expected a positive K_vi, received {kv!r}")
    Jq = sp.Matrix(3, 3, [sp.Rational(Fraction(float(x))) for x in Jm.flatten()])
    Ji = Jq.inv()
    ub = sp.Rational(Fraction(ubar) if not isinstance(ubar, float) else Fraction(ubar))
    k = sp.Rational(kv_f)
    for v in product((-1, 1), repeat=3):
        w = Ji * sp.Matrix(v)
        if k**2 < ub**2 / 4 * (w.T * w)[0, 0]:
            return False
    return True
