"""Lyapunov-Krasovskii certificate of a delay margin on any connected graph (issue 15, item 3).

The per-mode quasi-polynomial analysis of :mod:`formsync_design.analysis.delay`
needs the loop to decouple per Laplacian mode; the transmission-delay loop does
so only on regular graphs.  Here a sufficient certificate for every connected
graph.

Delayed loop (one axis; ``c_qd``, ``c_s`` from
:func:`~formsync_design.derive.closed_loop.derive_closed_loop`)::

    q'' = c_qd q' + c_s s,   transmission: s = D q(t) - A q(t - tau)
                             processing:   s = L q(t - tau)

With ``v = q'`` and the exact identity ``q(t) - q(t - tau) = int_{t-tau}^t v``,
``D q - A q_tau = L q + A int v`` and ``L q_tau = L q - L int v``.  The consensus
position drops out (``L 1 = 0``): with the integer difference coordinates
``e = E q`` (``e_i = q_i - q_n``) and ``L q = L T e`` (``T = [I; 0]``), the state
``x = (e, v)`` of dimension ``2n - 1`` obeys the distributed-delay system
``x' = F x + B int_{t-tau}^t H x(s) ds`` with ``F = [[0, E], [c_s L T, c_qd I]]``,
``H x = v`` and ``B = [0; c_s A]`` (transmission) or ``[0; -c_s L]`` (processing).
No substitution of the dynamics into the integral is made, so no additional
dynamics are introduced (Gu & Niculescu 2001).  ``(e, v) -> 0`` is consensus.

Lyapunov-Krasovskii functional with Jensen's inequality (Gu, Kharitonov & Chen
2003, Sec. 5.7; Fridman 2014, *Introduction to Time-Delay Systems*, Sec. 3.6)::

    V = x' P x + int_{-tau}^0 int_{t+th}^t v' R v ds dth,
    V' <= [x; w]' M [x; w],   w = int_{t-tau}^t v,
    M = [[P F + F' P + tau H' R H, P B], [B' P, -R / tau]]

so ``P > 0``, ``R > 0``, ``M < 0`` certify asymptotic stability for the delay
``tau`` (and, as ``M`` is affine in ``tau`` after scaling the last block row and
column by ``tau``, for every delay in ``[0, tau]``: the LMI at ``tau`` implies it at
every smaller delay with the same ``P``, ``R`` because ``tau H'RH`` shrinks and
``-R/tau`` grows more negative).  cvxpy + Clarabel proposes ``P``, ``R`` (a hint);
they are rounded to dyadic rationals and ``P``, ``R`` and ``-M`` are decided
positive definite by exact rational ``LDL^T``
(:func:`~formsync_design.certify.exact.exact_ldl`) with the gains as exact
rationals.  The certified margin is the largest bisection delay that passes the
exact check; it is a lower bound of the true margin (sufficient condition).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.analysis.results import jsonify
from formsync_design.certify.exact import exact_ldl
from formsync_design.errors import InputError
from formsync_design.graphs import make_graph

__all__ = ["LKStatus", "LKCertificate", "lk_delay_system", "lk_check_exact", "lk_delay_margin"]

_DYADIC = 2**30


class LKStatus(StrEnum):
    """Outcome of the Lyapunov-Krasovskii margin search."""

    CERTIFIED = "certified"      # a positive delay passed the exact check
    NOT_CERTIFIED = "not_certified"  # no tested delay passed (inconclusive: sufficient test)


@dataclass(frozen=True)
class LKCertificate:
    """Certified delay margin from the Lyapunov-Krasovskii LMI (a lower bound)."""

    graph: str
    model: str
    gains: tuple[Fraction, ...]
    status: LKStatus
    margin: float
    tested: tuple[tuple[float, bool], ...]

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"graph": self.graph, "model": self.model, "gains": list(self.gains),
                        "status": str(self.status), "margin_s": self.margin,
                        "method": "Lyapunov-Krasovskii LMI (Jensen), exact rational re-check",
                        "tested": [[t, ok] for t, ok in self.tested]})


def _coefficients(gains: tuple[Fraction, ...], spec: Any) -> tuple[Fraction, Fraction]:
    from formsync_design.analysis.modes import mode_model

    return mode_model(spec).coefficients(gains)


def lk_delay_system(graph: Any, gains: Any, model: str = "transmission", *,
                    spec: Any = None) -> tuple[list[list[Fraction]], list[list[Fraction]], int]:
    """Exact ``(F, B, n)`` of ``x' = F x + B int_{t-tau}^t v`` with ``x = (e, v)``.

    Examples
    --------
    >>> f, b, n = lk_delay_system("path:2", (1, 1, 0))
    >>> n, [[str(x) for x in row] for row in f]
    (2, [['0', '1', '-1'], ['-1', '-1', '0'], ['1', '0', '-1']])
    """
    from formsync_design.analysis.modes import mode_model

    g = make_graph(graph)
    gl = tuple(Fraction(int(v.p), int(v.q)) for v in mode_model(spec).subs(gains).values())
    if model not in ("transmission", "processing"):
        raise InputError(f"expected a delay model transmission|processing, received {model}")
    cqd, cs = _coefficients(gl, spec)
    n = g.n
    lap = [[Fraction(int(x)) for x in row] for row in g.laplacian]
    adj = [[Fraction(int(x)) for x in row] for row in g.adjacency]
    m = 2 * n - 1
    f = [[Fraction(0)] * m for _ in range(m)]
    for i in range(n - 1):          # e_i' = v_i - v_n
        f[i][n - 1 + i] += 1
        f[i][n - 1 + n - 1] -= 1
    for i in range(n):              # v_i' = c_qd v_i + c_s (L T e)_i + delayed term
        f[n - 1 + i][n - 1 + i] += cqd
        for j in range(n - 1):
            f[n - 1 + i][j] += cs * lap[i][j]
    coef = adj if model == "transmission" else [[-x for x in row] for row in lap]
    b = [[Fraction(0)] * n for _ in range(m)]
    for i in range(n):
        for j in range(n):
            b[n - 1 + i][j] = cs * coef[i][j]
    return f, b, n


def _lmi_matrix(f: list[list[Fraction]], b: list[list[Fraction]], n: int, p: list[list[Fraction]],
                r: list[list[Fraction]], tau: Fraction) -> list[list[Fraction]]:
    """``-M`` scaled: ``[[-(PF + F'P) - tau H'RH, -PB], [-B'P, R / tau]]`` (exact)."""
    m = len(f)
    pf = [[sum((p[i][k] * f[k][j] for k in range(m) if f[k][j]), Fraction(0)) for j in range(m)]
          for i in range(m)]
    pb = [[sum((p[i][k] * b[k][j] for k in range(m) if b[k][j]), Fraction(0)) for j in range(n)]
          for i in range(m)]
    size = m + n
    out = [[Fraction(0)] * size for _ in range(size)]
    for i in range(m):
        for j in range(m):
            out[i][j] = -(pf[i][j] + pf[j][i])
        for j in range(n):
            out[i][m + j] = -pb[i][j]
            out[m + j][i] = -pb[i][j]
    for i in range(n):
        for j in range(n):
            out[n - 1 + i][n - 1 + j] -= tau * r[i][j]
            out[m + i][m + j] = r[i][j] / tau
    return out


def lk_check_exact(f: list[list[Fraction]], b: list[list[Fraction]], n: int, p: Any, r: Any,
                   tau: Fraction) -> bool:
    """Exact decision of ``P > 0``, ``R > 0`` and ``M < 0`` for rational ``P``, ``R``.

    >>> f, b, n = lk_delay_system("path:2", (2, 1, 0))
    >>> lk_check_exact(f, b, n, [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 0], [0, 1]], Fraction(1, 100))
    False
    """
    pq = [[Fraction(x) for x in row] for row in p]
    rq = [[Fraction(x) for x in row] for row in r]
    if any(pq[i][j] != pq[j][i] for i in range(len(pq)) for j in range(len(pq))):
        return False
    if any(rq[i][j] != rq[j][i] for i in range(n) for j in range(n)):
        return False
    for mat in (pq, rq):
        if not exact_ldl(mat)[0]:
            return False
    return exact_ldl(_lmi_matrix(f, b, n, pq, rq, tau))[0]


def _round_sym(x: np.ndarray) -> list[list[Fraction]]:
    s = (x + x.T) / 2
    return [[Fraction(round(float(v) * _DYADIC), _DYADIC) for v in row] for row in s]


def _try_delay(f: list[list[Fraction]], b: list[list[Fraction]], n: int, tau: float) -> bool:
    import cvxpy as cp

    m = len(f)
    fa = np.array([[float(x) for x in row] for row in f])
    ba = np.array([[float(x) for x in row] for row in b])
    h = np.zeros((n, m))
    h[:, n - 1:] = np.eye(n)
    p = cp.Variable((m, m), symmetric=True)
    r = cp.Variable((n, n), symmetric=True)
    blk = cp.bmat([[p @ fa + fa.T @ p + tau * h.T @ r @ h, p @ ba], [ba.T @ p, -r / tau]])
    eps = 1e-6
    cons = [p >> eps * np.eye(m), r >> eps * np.eye(n), (blk + blk.T) / 2 << -eps * np.eye(m + n),
            cp.trace(p) <= 1e3 * m]
    prob = cp.Problem(cp.Minimize(0), cons)
    try:
        prob.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return False  # no hint near the feasibility boundary: nothing certified at this delay
    if prob.status not in ("optimal", "optimal_inaccurate") or p.value is None or r.value is None:
        return False  # the solver's hint is negative or unknown: nothing certified at this delay
    tq = Fraction(tau)
    return lk_check_exact(f, b, n, _round_sym(p.value), _round_sym(r.value), tq)


def lk_delay_margin(graph: Any, gains: Any, model: str = "transmission", *, spec: Any = None,
                    tau_max: float = 20.0, iterations: int = 12) -> LKCertificate:
    """Largest delay certified by the Lyapunov-Krasovskii LMI (bisection, exact re-check).

    Every reported delay ``tau`` passed the exact check; by the affine structure the
    certificate covers all of ``[0, tau]``.  ``tau_max`` caps the search (a certificate at
    ``tau_max`` is reported as ``tau_max``, not as delay-independence).

    Examples
    --------
    >>> c = lk_delay_margin("star:4", (1.6, 0.4, 0.3), iterations=4, tau_max=4.0)
    >>> str(c.status), c.margin > 0
    ('certified', True)
    """
    from formsync_design.analysis.modes import mode_model

    g = make_graph(graph)
    f, b, n = lk_delay_system(g, gains, model, spec=spec)
    gl = tuple(Fraction(int(v.p), int(v.q)) for v in mode_model(spec).subs(gains).values())
    tested: list[tuple[float, bool]] = []
    lo, hi = 0.0, float(tau_max)
    if _try_delay(f, b, n, hi):
        tested.append((hi, True))
        lo = hi
    else:
        tested.append((hi, False))
        for _ in range(iterations):
            mid = (lo + hi) / 2 if lo > 0 else hi / 4
            ok = _try_delay(f, b, n, mid)
            tested.append((mid, ok))
            if ok:
                lo = mid
            else:
                hi = mid
            if lo > 0 and (hi - lo) <= 1e-3 * hi:
                break
    status = LKStatus.CERTIFIED if lo > 0 else LKStatus.NOT_CERTIFIED
    return LKCertificate(g.name, model, gl, status, lo if lo > 0 else 0.0, tuple(tested))

