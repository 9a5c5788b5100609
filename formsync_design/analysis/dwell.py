"""Dwell-time certificate for switching topologies (issue 15, item 4), for when no common
Lyapunov function exists over a graph set.

Coordinates: ``z = T q`` with ``T = [I_{N-1}, -1]`` (differences to spacecraft N), per axis;
since ``L 1 = 0``, ``L q = L R z`` with ``R = [I_{N-1}; 0]``, so the nominal loop of graph
``j`` (``q'' = c_qd q' + c_s L_j q``) reads ``(z, z')' = A_j (z, z')`` with the rational
``A_j = [[0, I], [c_s T L_j R, c_qd I]]``.  Per graph the exact rational solution
``P_j`` of ``A_j^T P_j + P_j A_j = -I`` (checked ``P_j > 0`` by an exact LDL^T) gives
``V_j' <= -2 lambda_0 V_j`` for the rational ``lambda_0`` with ``I - 2 lambda_0 P_j >= 0``
(exact), and a rational ``mu >= 1`` with ``mu P_j - P_k >= 0`` for every pair (exact), so
``V_k <= mu V_j``.  Standard argument (Hespanha & Morse 1999; Liberzon, *Switching in
Systems and Control*, Thm 3.2): every switching signal with dwell time
``tau_d > ln(mu) / (2 lambda_0)`` is exponentially stable, with
``V(t) <= mu^{N_sigma(t)} exp(-2 lambda_0 t) V(0)``.  Only ``ln`` is taken in floating
point (rounded up by a relative ``1e-12``).  Dense: meant for formations up to a few
tens of spacecraft.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.analysis.modecheck import GAINS
from formsync_design.analysis.modes import mode_model
from formsync_design.analysis.results import Verdict, jsonify
from formsync_design.errors import InputError
from formsync_design.graphs import make_graph

__all__ = ["DwellTime", "certify_dwell_time", "reduced_matrix", "lyapunov_exact", "is_pd_exact", "dwell_section"]

FMatrix = list[list[Fraction]]


@dataclass(frozen=True)
class DwellTime:
    """A certified minimum dwell time over a graph set at a gain point."""

    status: Verdict
    graphs: tuple[str, ...]
    gains: tuple[Fraction, ...]
    decay: Fraction
    mu: Fraction
    dwell: float
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"status": str(self.status), "graphs": list(self.graphs),
                        "gains": list(self.gains), "lambda_0": self.decay, "mu": self.mu,
                        "dwell_time_s": self.dwell, "reason": self.reason})


def reduced_matrix(graph: Any, c_qd: Fraction, c_s: Fraction) -> FMatrix:
    """``A_j`` (``2(N-1)`` square, exact) of the nominal loop in difference coordinates.

    >>> [[str(x) for x in row] for row in reduced_matrix("path:2", Fraction(-2), Fraction(-1))]
    [['0', '1'], ['-2', '-2']]
    """
    g = make_graph(graph)
    n = g.n
    lap = [[Fraction(int(x)) for x in row] for row in g.laplacian.tolist()]
    m = n - 1
    # (T L R)_{ik} = L_{ik} - L_{Nk} for i, k < N
    tlr = [[lap[i][k] - lap[n - 1][k] for k in range(m)] for i in range(m)]
    size = 2 * m
    a = [[Fraction(0)] * size for _ in range(size)]
    for i in range(m):
        a[i][m + i] = Fraction(1)
        a[m + i][m + i] = c_qd
        for k in range(m):
            a[m + i][k] = c_s * tlr[i][k]
    return a


def _solve(mat: FMatrix, rhs: list[Fraction]) -> list[Fraction]:
    n = len(mat)
    aug = [row[:] + [rhs[i]] for i, row in enumerate(mat)]
    for col in range(n):
        piv = next((r for r in range(col, n) if aug[r][col] != 0), None)
        if piv is None:
            raise InputError("expected a Hurwitz closed loop (unique Lyapunov solution), received a "
                             "singular Lyapunov equation")
        aug[col], aug[piv] = aug[piv], aug[col]
        pv = aug[col][col]
        for r in range(n):
            if r != col and aug[r][col] != 0:
                f = aug[r][col] / pv
                aug[r] = [x - f * y for x, y in zip(aug[r], aug[col])]
    return [aug[i][n] / aug[i][i] for i in range(n)]


def lyapunov_exact(a: FMatrix) -> FMatrix:
    """Exact ``P`` with ``A^T P + P A = -I`` (symmetric unknowns, rational elimination).

    >>> p = lyapunov_exact([[Fraction(0), Fraction(1)], [Fraction(-1), Fraction(-2)]])
    >>> [[str(x) for x in r] for r in p]
    [['3/2', '1/2'], ['1/2', '1/2']]
    """
    n = len(a)
    idx: dict[tuple[int, int], int] = {}
    for i in range(n):
        for j in range(i, n):
            idx[(i, j)] = len(idx)
    m = len(idx)
    rows, rhs = [], []
    for i in range(n):
        for j in range(i, n):
            row = [Fraction(0)] * m
            # (A^T P + P A)_{ij} = sum_k A_{ki} P_{kj} + P_{ik} A_{kj}
            for k in range(n):
                if a[k][i]:
                    row[idx[(min(k, j), max(k, j))]] += a[k][i]
                if a[k][j]:
                    row[idx[(min(i, k), max(i, k))]] += a[k][j]
            rows.append(row)
            rhs.append(Fraction(-1 if i == j else 0))
    sol = _solve(rows, rhs)
    return [[sol[idx[(min(i, j), max(i, j))]] for j in range(n)] for i in range(n)]


def is_pd_exact(m: FMatrix) -> bool:
    """Positive definiteness by exact LDL^T (every pivot > 0).

    >>> is_pd_exact([[Fraction(2), Fraction(1)], [Fraction(1), Fraction(1)]]), is_pd_exact([[Fraction(1), Fraction(2)], [Fraction(2), Fraction(1)]])
    (True, False)
    """
    a = [row[:] for row in m]
    n = len(a)
    for k in range(n):
        if a[k][k] <= 0:
            return False
        for i in range(k + 1, n):
            f = a[i][k] / a[k][k]
            if f:
                for j in range(k, n):
                    a[i][j] -= f * a[k][j]
    return True


def _float(m: FMatrix) -> np.ndarray:
    return np.array([[float(x) for x in row] for row in m])


def certify_dwell_time(graphs: Any, gains: Any, *, spec: Any = None) -> DwellTime:
    """Certified minimum dwell time over a graph set at a gain point of the design's gains.

    Examples
    --------
    >>> d = certify_dwell_time(["star:4", "path:4"], (1.6, 0.4, 0.3))
    >>> d.status.value, 0 < d.dwell < 100, d.mu >= 1
    ('certified', True, True)
    >>> certify_dwell_time(["star:4", "path:4"], (0.4, 1.6), spec="pd_consensus").dwell == d.dwell   # same loop
    True
    """
    gs = [make_graph(x) for x in graphs]
    if not gs or len({g.n for g in gs}) != 1:
        raise InputError(f"expected a non-empty set of graphs with one N, received {[g.name for g in gs]}")
    mm = mode_model(spec)
    gp = tuple(Fraction(int(v.p), int(v.q)) for v in mm.subs(gains).values())
    if gs[0].n > 40:
        raise InputError(f"expected at most 40 spacecraft for the dense dwell-time certificate, received {gs[0].n}")
    c_qd, c_s = mm.coefficients(gp)
    names = tuple(g.name for g in gs)
    ps = []
    for g in gs:
        p = lyapunov_exact(reduced_matrix(g, c_qd, c_s))
        if not is_pd_exact(p):
            return DwellTime(Verdict.REFUTED, names, gp, Fraction(0), Fraction(0), math.inf,
                             f"the nominal loop on {g.name} is not stable (no positive definite Lyapunov "
                             "solution): no dwell time helps")
        ps.append(p)
    size = len(ps[0])
    eye = [[Fraction(int(i == j)) for j in range(size)] for i in range(size)]
    # lambda_0: I - 2 lambda_0 P_j > 0 for every j
    lam_f = min(1 / (2 * float(np.linalg.eigvalsh(_float(p)).max())) for p in ps)
    lam0 = Fraction(lam_f * (1 - 1e-6)).limit_denominator(10**9)
    while not all(is_pd_exact([[eye[i][j] - 2 * lam0 * p[i][j] for j in range(size)] for i in range(size)])
                  for p in ps):
        lam0 /= 2
    # mu: mu P_j - P_k > 0 for every pair
    mu_f = 1.0
    for pj in ps:
        lj = np.linalg.cholesky(_float(pj))
        li = np.linalg.inv(lj)
        for pk in ps:
            mu_f = max(mu_f, float(np.linalg.eigvalsh(li @ _float(pk) @ li.T).max()))
    mu = Fraction(mu_f * (1 + 1e-6)).limit_denominator(10**9)
    if mu < 1 or len(ps) == 1:
        mu = Fraction(1)
    for _ in range(60):
        if all(is_pd_exact([[mu * pj[i][j] - pk[i][j] for j in range(size)] for i in range(size)])
               for pj in ps for pk in ps if pj is not pk):
            break
        mu *= Fraction(11, 10)
    else:  # pragma: no cover - a finite mu always exists for positive definite P_j
        return DwellTime(Verdict.UNDECIDED, names, gp, lam0, mu, math.inf,
                         "no ratio mu passed the exact check")
    dwell = math.log(float(mu)) * (1 + 1e-12) / (2 * float(lam0)) if mu > 1 else 0.0
    return DwellTime(Verdict.CERTIFIED, names, gp, lam0, mu, dwell,
                     f"per-graph V_j (exact Lyapunov solutions) decay at 2 lambda_0 = {float(2 * lam0):.4g}/s "
                     f"and V_k <= {float(mu):.4g} V_j (exact): every switching with dwell time > "
                     f"{dwell:.4g} s is exponentially stable")


def dwell_section(sets: tuple[tuple[str, ...], ...] = (("star:6", "path:6"), ("complete:6", "path:6"),
                                                       ("ring:8", "star:8")),
                  point: tuple[str, str, str] = ("0.3", "1", "0.3")) -> list[str]:
    """Markdown lines: graph sets without a common quadratic V in the searched class, and the
    certified dwell time of per-graph Lyapunov functions."""
    from formsync_design.analysis.switching import certify_switching

    lines = ["## Dwell time when no common Lyapunov function is found (item 4)", "",
             f"Gains (K_o, K_q, beta) = ({', '.join(point)}). Per graph, the exact rational solution of "
             "`A_j^T P_j + P_j A_j = -I`",
             "(difference coordinates) gives `V_j' <= -2 lambda_0 V_j` and `V_k <= mu V_j` (both checked exactly);",
             "every switching that stays longer than `ln(mu) / (2 lambda_0)` on each graph is exponentially",
             "stable (`formsync certify --graphs-set G1,G2 --min-dwell T`).", "",
             "| graph set | common V (searched class) | lambda_0 (1/s) | mu | certified dwell time (s) |",
             "|---|---|---|---|---|"]
    for s in sets:
        c = certify_switching(s, dict(zip(GAINS, point)))
        d = certify_dwell_time(s, point)
        lines.append(f"| {', '.join(s)} | {c.status.value} | {float(d.decay):.4g} | {float(d.mu):.4g} | "
                     f"{d.dwell:.4g} |")
    lines.append("")
    return lines
