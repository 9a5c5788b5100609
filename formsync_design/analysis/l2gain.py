"""Certified L2 gain (disturbance attenuation) of a linearised agent formation.

The question: for the linearisation ``T xi' = F(p) xi + G d``, ``z = C xi`` of an agent
design at its commanded attitude (:func:`~formsync_design.derive.linearize.linearize_agents`),
is the L2 gain from the disturbance torques ``d`` to the attitude errors ``z`` at most
``gamma`` -- at one gain point ``p``, or for every ``p`` in a box?

The dissipation inequality.  With the storage ``V = (T xi)^T P (T xi)`` (``P`` symmetric),
``V' = 2 (T xi)^T P (F xi + G d)``, so

    V' + |z|^2 - gamma^2 |d|^2 = [xi; d]^T M(P, p, gamma) [xi; d],
    M = [[F^T P T + T^T P F + C^T C,  T^T P G], [G^T P T,  -gamma^2 I]],

and ``P > 0``, ``-M > 0`` prove (integrate from ``xi(0) = 0``) ``int |z|^2 <= gamma^2 int
|d|^2`` on every horizon, and (its upper-left block) ``A = T^{-1} F`` Hurwitz: the
linearisation is exponentially stable.  ``F`` is multi-affine in the gains for a fixed
``P`` (the lead-filter design's entries are ``1, k_p, k_d a_f, a_f``), so the box's vertices
decide ``-M(P, p) > 0`` for every ``p`` in the box, exactly like ``Theta_i`` and ``Pi``.

Pipeline (the solver is a hint; the exact re-check decides, in both directions):

1. the H-infinity norm of the linearisation, numerically (:func:`hinf_norm`, Hamiltonian
   bisection), at the point or at every vertex of the box: the smallest ``gamma`` any
   storage can certify (bounded real lemma);
2. a storage ``P``: the stabilising solution of the Riccati equation
   ``A^T X + X A + C^T C + eps I + X B B^T X / gamma^2 = 0`` (``method="riccati"``) or the
   SDP ``max t: -M(P, p_v) >= t I, P >= t I`` at every vertex ``p_v`` (``method="sdp"``,
   cvxpy + Clarabel), then ``P`` rounded to a dyadic rational;
3. the families ``-M(P, p)`` and ``P`` built exactly (:func:`dissipation_families`) and
   decided by :func:`~formsync_design.certify.engine.certify_box` (rigorous Cholesky bound or
   exact ``LDL^T`` at every vertex);
4. when ``gamma`` is below the norm: an exact **frequency witness** (:func:`frequency_witness`):
   a gain point, a rational frequency ``omega`` and a disturbance amplitude ``u`` (Gaussian
   rationals) whose forced response has ``|z|^2 > gamma^2 |u|^2``, computed in exact
   rational arithmetic: a sinusoidal disturbance that the loop amplifies by more than
   ``gamma`` -- no storage of any kind can certify ``gamma`` there.

Scope (what a certificate covers): the linearisation at the commanded attitude, at rest,
with the filter at rest; the nonlinear loop's gain approaches it as the disturbance goes to
zero.  Larger disturbances are simulated and compared with the certificate, not certified.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.analysis.l2freq import FrequencyWitness, frequency_witness, hinf_norm
from formsync_design.certify.results import CertificationResult, Status
from formsync_design.derive.families import MatrixFamily, family_from_entries
from formsync_design.derive.linearize import LinearLoop
from formsync_design.errors import InputError, SolverError
from formsync_design.gains import GainBox, json_number, parse_number

__all__ = [
    "dissipation_families",
    "L2Certificate",
    "certify_gamma",
    "certify_l2_box",
    "smallest_box_gamma",
    "sdp_min_gamma",
    "round_up_gamma",
    "harmonic_steady_bound",
]

#: Largest total PSD row count solved by Clarabel (larger dissipation SDPs: SCS).
SDP_CLARABEL_MAX = 80

#: Iteration limit of SCS on the larger dissipation SDPs (a hint: an unconverged storage
#: simply fails the exact re-check).
SCS_MAX_ITERS = 5000


# ----------------------------------------------------------------------------- numerics
def round_up_gamma(x: float, digits: int = 4) -> Fraction:
    """The smallest decimal with ``digits`` significant digits that is ``>= x``.

    >>> str(round_up_gamma(7.70484)), str(round_up_gamma(0.012341, 3))
    ('1541/200', '31/2500')
    """
    if not (x > 0 and math.isfinite(x)):
        raise InputError(f"expected a positive finite gain bound, received {x!r}")
    e = math.floor(math.log10(x)) - digits + 1
    q = Fraction(10) ** e
    k = math.ceil(Fraction(x) / q)
    return k * q


# ----------------------------------------------------------------------------- storage
def _riccati(A: np.ndarray, B: np.ndarray, C: np.ndarray, gamma: float, eps: float) -> np.ndarray | None:
    """Stabilising solution of ``A^T X + X A + C^T C + eps I + X B B^T X / gamma^2 = 0``."""
    import scipy.linalg as sl

    n = A.shape[0]
    Q = C.T @ C + eps * np.eye(n)
    H = np.block([[A, B @ B.T / gamma**2], [-Q, -A.T]])
    try:
        S, U, k = sl.schur(H, output="real", sort="lhp")
    except (np.linalg.LinAlgError, ValueError):
        return None
    if k != n:
        return None
    U1, U2 = U[:n, :n], U[n:, :n]
    try:
        X = np.linalg.solve(U1.T, U2.T).T
    except np.linalg.LinAlgError:
        return None
    X = (X + X.T) / 2
    if not np.all(np.isfinite(X)):
        return None
    return X


def _numeric_M(F: np.ndarray, T: np.ndarray, G: np.ndarray, C: np.ndarray, Ph: np.ndarray,
               gamma2: float) -> np.ndarray:
    top = F.T @ Ph @ T
    top = top + top.T + C.T @ C
    cross = T.T @ Ph @ G
    return np.block([[top, cross], [cross.T, -gamma2 * np.eye(G.shape[1])]])


def _solve(prob: Any) -> bool:
    """Solve a dissipation SDP: Clarabel for small ones, SCS (first-order) above
    :data:`SDP_CLARABEL_MAX` rows, where an interior-point KKT system is dense in the storage's
    entries (minutes instead of seconds); the result is only a hint either way."""
    import cvxpy as cp

    cones = [c.args[0].shape[0] for c in prob.constraints if isinstance(c, cp.constraints.PSD)]
    rows = sum(cones)
    opts: dict[str, Any] = ({} if rows <= SDP_CLARABEL_MAX else
                            {"max_iters": SCS_MAX_ITERS, "eps_abs": 1e-6, "eps_rel": 1e-6})
    solver = cp.CLARABEL if rows <= SDP_CLARABEL_MAX else cp.SCS
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an inaccurate hint is re-checked like any other
            prob.solve(solver=solver, **opts)
    except (cp.error.SolverError, ArithmeticError, ValueError):
        return False
    return prob.status in ("optimal", "optimal_inaccurate")


def _lmi(P: Any, A: np.ndarray, B: np.ndarray, C: np.ndarray, g2: Any) -> Any:
    import cvxpy as cp

    top = A.T @ P
    M = cp.bmat([[top + top.T + C.T @ C, P @ B], [B.T @ P, -g2 * np.eye(B.shape[1])]])
    return (M + M.T) / 2


def _sdp_storage(systems: Sequence[tuple], C: np.ndarray, gamma2: float, Ti: np.ndarray
                 ) -> np.ndarray | None:
    """``P`` maximising ``t`` with ``-M(P, p_v) >= t I`` (every vertex) and ``P >= t I``, in
    the standard coordinates ``xi' = A xi + B d``; returned as the descriptor storage
    ``T^{-T} P T^{-1}``."""
    import cvxpy as cp

    n, m = systems[0][1].shape[0], systems[0][2].shape[1]
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    cons = [P >> t * np.eye(n), t <= 1.0]
    cons += [_lmi(P, s[1], s[2], C, gamma2) << -t * np.eye(n + m) for s in systems]
    prob = cp.Problem(cp.Maximize(t), cons)
    if not _solve(prob) or t.value is None or t.value <= 0:
        return None
    return Ti.T @ np.asarray(P.value) @ Ti


def sdp_min_gamma(systems: Sequence[tuple], C: np.ndarray) -> float | None:
    """The SDP ``min gamma^2`` s.t. ``M(P, p_v, gamma) <= 0`` at every vertex, ``P >= 0``
    (one common quadratic storage; at a single point the bounded real lemma makes its value
    the H-infinity norm).  A numerical hint: the level is certified afterwards."""
    import cvxpy as cp

    n = systems[0][1].shape[0]
    P = cp.Variable((n, n), symmetric=True)
    g2 = cp.Variable()
    m = systems[0][2].shape[1]
    cons = [P >> 1e-6 * np.eye(n)]
    cons += [_lmi(P, s[1], s[2], C, g2) << -1e-7 * np.eye(n + m) for s in systems]
    prob = cp.Problem(cp.Minimize(g2), cons)
    if not _solve(prob) or g2.value is None or not g2.value > 0:
        return None
    return float(math.sqrt(g2.value))


def _dyadic(X: np.ndarray, bits: int) -> tuple[list[list[int]], int]:
    """``X ~ Xi / 2^k`` with integers ``|Xi| <= 2^bits`` (symmetric)."""
    big = float(np.max(np.abs(X)))
    k = bits - math.ceil(math.log2(big)) if big > 0 else bits
    Xi = np.rint(X * 2.0**k)
    Xi = np.rint((Xi + Xi.T) / 2)
    return [[int(v) for v in row] for row in Xi], k


# ----------------------------------------------------------------------------- families
def dissipation_families(lin: LinearLoop, P: Sequence[Sequence[Fraction]], gamma2: Fraction
                         ) -> tuple[MatrixFamily, MatrixFamily]:
    """The exact families ``-M(P, p)`` (in the loop's gains, size ``nx + 3N``) and ``P``
    (constant) of the module docstring, from the exact ``F``, ``T``, ``G``, ``C``.

    Raises
    ------
    OverflowError
        An integer coefficient matrix does not fit in int64 (round ``P`` coarser).
    """
    nx, nw = lin.nx, lin.nw
    size = nx + nw
    T = lin.T
    # P T (dense, exact): T is block diagonal
    PT = [[sum((P[r][k] * T[k][c] for k in range(max(0, c - 2), min(nx, c + 3)) if T[k][c]),
               Fraction(0)) for c in range(nx)] for r in range(nx)]
    entries: dict[tuple[int, int], dict[tuple[int, ...], Fraction]] = {}

    def add(r: int, c: int, mono: tuple[int, ...], v: Fraction) -> None:
        if v:
            d = entries.setdefault((r, c), {})
            d[mono] = d.get(mono, Fraction(0)) + v

    zero = tuple(0 for _ in lin.gains)
    for mono, cells in lin.F.terms.items():
        # (F^T P T)[a, c] = sum_r F[r, a] (P T)[r, c]
        byrow: dict[int, list[tuple[int, Fraction]]] = {}
        for (r, a), v in cells.items():
            byrow.setdefault(r, []).append((a, v))
        acc: dict[tuple[int, int], Fraction] = {}
        for r, items in byrow.items():
            row = PT[r]
            for a, v in items:
                for c in range(nx):
                    if row[c]:
                        acc[(a, c)] = acc.get((a, c), Fraction(0)) + v * row[c]
        for (a, c), v in acc.items():
            add(a, c, mono, -v)
            add(c, a, mono, -v)
    CtC = lin.C.T @ lin.C  # 0/1 selections: exact in floating point
    for a, b in zip(*np.nonzero(CtC)):
        add(int(a), int(b), zero, -Fraction(int(round(CtC[a, b]))))
    gcols = [(int(r), int(c)) for r, c in zip(*np.nonzero(lin.G))]
    for r_, c in gcols:  # -(T^T P G)[a, c] = -(P T)[r_, a] (G = 0/1, T symmetric)
        for a in range(nx):
            v = PT[r_][a] * int(lin.G[r_, c])
            add(a, nx + c, zero, -v)
            add(nx + c, a, zero, -v)
    for k in range(nw):
        add(nx + k, nx + k, zero, gamma2)
    labels = (*lin.labels, *[f"d{k}_{i + 1}" for i in range(lin.n) for k in (1, 2, 3)])
    fam = family_from_entries("dissipation -M(P, p)", size, entries, gains=lin.gains,
                              block_size=1, row_labels=labels)
    pent = {(r, c): {zero: P[r][c]} for r in range(nx) for c in range(nx) if P[r][c]}
    pfam = family_from_entries("storage P", nx, pent, gains=lin.gains, block_size=1,
                               row_labels=lin.labels)
    return fam, pfam


@dataclass(frozen=True)
class _Conditions:
    """A ``ConditionsLike`` for :func:`~formsync_design.certify.engine.certify_box`."""

    families: tuple[MatrixFamily, ...]
    gains: tuple[str, ...]
    graph: Any
    source: str = "l2-dissipation"


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class L2Certificate:
    """A decided L2-gain question (module docstring).

    Attributes
    ----------
    status : Status (``certified``: ``gamma`` proven on the whole box; ``refuted``: an exact
        :class:`FrequencyWitness`; ``undecided``)
    gamma : Fraction (the level asked, or the smallest one certified)
    box : GainBox; hinf : numerical H-infinity norm (max over the vertices checked) with
        its ``peak_frequency``; method : ``riccati`` / ``sdp``
    certification : the :class:`~formsync_design.certify.results.CertificationResult` of the
        families ``-M(P, p)`` and ``P`` (None when refuted)
    witness : FrequencyWitness or None
    storage_bits : rounding of ``P`` (``P = P_int / 2^k``); pieces : sub-boxes used
    """

    status: Status
    gamma: Fraction
    box: GainBox
    hinf: float
    peak_frequency: float
    method: str
    certification: tuple[CertificationResult, ...] = ()
    witness: FrequencyWitness | None = None
    reason: str = ""
    elapsed: float = 0.0
    storage: tuple[tuple[tuple[Fraction, ...], ...], ...] = field(default=(), repr=False)

    @property
    def certified(self) -> bool:
        return self.status == Status.CERTIFIED

    @property
    def margin(self) -> Fraction | None:
        """Certified lower bound of ``lambda_min(-M)`` over the box (``None`` unless certified)."""
        if not self.certified:
            return None
        vals = [c.margin_lower_bound for c in self.certification]
        return None if any(v is None for v in vals) else min(v for v in vals if v is not None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": str(self.status), "gamma": json_number(self.gamma),
            "box": self.box.to_dict(), "hinf_numerical": json_number(self.hinf),
            "peak_frequency": json_number(self.peak_frequency), "method": self.method,
            "certified_margin": None if self.margin is None else json_number(self.margin),
            "pieces": len(self.certification),
            "witness": None if self.witness is None else self.witness.to_dict(),
            "reason": self.reason, "elapsed_s": self.elapsed,
        }


def _box(lin: LinearLoop, box: Any) -> GainBox:
    return GainBox.parse(box, lin.gains, positive=True)


def _vertex_systems(lin: LinearLoop, verts: Sequence[tuple[Fraction, ...]]) -> list[tuple]:
    out = []
    for v in verts:
        pt = {k: float(x) for k, x in zip(lin.gains, v)}
        A, B, C = lin.standard(pt)
        out.append((pt, A, B, C, lin.F.evaluate(pt)))
    return out


def _try_storage(lin: LinearLoop, bx: GainBox, gamma: Fraction, method: str,
                 systems: list[tuple]) -> tuple[CertificationResult | None, list]:
    """Find a storage for the whole box and decide it exactly; ``(result, P)``."""
    from formsync_design.certify.engine import certify_box

    T = lin.T_float()
    g2 = float(gamma) ** 2
    cands: list[np.ndarray] = []
    Ti = np.linalg.inv(T)
    if method == "sdp":
        Ph = _sdp_storage(systems, lin.C, g2, Ti)
        if Ph is not None:
            cands.append(Ph)
    else:
        for _, A, B, C, _F in systems:
            for eps in (1e-6, 1e-4, 1e-2):
                X = _riccati(A, B, C, float(gamma), eps * max(1.0, float(np.max(np.abs(C)))))
                if X is not None:
                    cands.append(Ti.T @ X @ Ti)
    best: tuple[float, np.ndarray] | None = None
    for Ph in cands:
        worst = min(float(np.linalg.eigvalsh(-_numeric_M(s[4], T, lin.G, lin.C, Ph, g2))[0])
                    for s in systems)
        worst = min(worst, float(np.linalg.eigvalsh(Ph)[0]))
        if best is None or worst > best[0]:
            best = (worst, Ph)
    if best is None or best[0] <= 0:
        return None, []
    last: CertificationResult | None = None
    for bits in (44, 40, 36):
        Pi, k = _dyadic(best[1], bits)
        P = [[Fraction(v, 2**k) if k >= 0 else Fraction(v * 2**-k) for v in row] for row in Pi]
        try:
            fam, pfam = dissipation_families(lin, P, gamma**2)
        except OverflowError:
            continue
        conds = _Conditions((fam, pfam), lin.gains, lin.graph)
        res = certify_box(conds, bx, use_sdp=False)
        last = res
        if res.certified:
            return res, P
    return last, []


def _round_down_level(g: Fraction, bits: int = 24) -> Fraction:
    """A dyadic level ``<= g`` within ``2^-bits`` relative (its square's denominator is a
    power of two, like the storage's: the family's integers stay small)."""
    e = math.floor(math.log2(float(g))) - bits
    q = Fraction(2) ** e
    return math.floor(g / q) * q


def certify_l2_box(lin: LinearLoop, box: Any, gamma: Any, *, method: str = "auto",
                   max_pieces: int = 16) -> L2Certificate:
    """Decide whether the linearisation's L2 gain is ``<= gamma`` for every gain in ``box``.

    ``certified``: every sub-box (at most ``max_pieces``, bisected along the relatively
    widest gain when one storage does not cover a box) has a storage ``P`` with ``P > 0`` and
    ``-M(P, p) > 0`` at its vertices, re-checked exactly; ``refuted``: an exact
    :class:`FrequencyWitness` at a vertex or centre of a (sub-)box; else ``undecided``.

    >>> from formsync_design.derive.linearize import linearize_agents
    >>> from formsync_design.spec.loader import load_design
    >>> lin = linearize_agents(load_design("lv2012"), "path:2", [np.eye(3) * 2] * 2, pinning=[1, 1])
    >>> str(certify_l2_box(lin, {"k_p": (1, 2), "k_d": 4, "a_f": 1}, 3).status)
    'certified'
    >>> r = certify_l2_box(lin, {"k_p": (1, 2), "k_d": 4, "a_f": 1}, "0.5")
    >>> str(r.status), r.witness.gain > 0.5
    ('refuted', True)
    """
    t0 = time.perf_counter()
    g = parse_number(gamma, "gamma")
    if g <= 0:
        raise InputError(f"expected a positive gamma, received {float(g):g}")
    bx = _box(lin, box)
    # a level with a long decimal expansion is certified through a shorter one below it
    # (certifying gc <= g certifies g): the dissipation family's integers stay in int64
    gc = g if g.denominator < 10**6 else _round_down_level(g)
    point = all(lo == hi for lo, hi in bx.bounds)
    meth = method if method != "auto" else ("riccati" if point else "sdp")
    if meth not in ("sdp", "riccati"):
        raise InputError(f"expected method auto, sdp or riccati, received {method!r}")
    stack = [bx]
    done: list[CertificationResult] = []
    hmax, wpk = 0.0, math.nan
    while stack:
        b = stack.pop()
        verts = b.vertices()
        centre = tuple((lo + hi) / 2 for lo, hi in b.bounds)
        systems = _vertex_systems(lin, verts)
        for pt_, A, B, C, _F in [*systems, *_vertex_systems(lin, [centre])]:
            h, w = hinf_norm(A, B, C)
            if h > hmax:
                hmax, wpk = h, w
            if h > float(g):
                wit = frequency_witness(lin, pt_, g, omega=w)
                if wit is not None:
                    return L2Certificate(Status.REFUTED, g, bx, hmax, wpk, meth, witness=wit,
                                         reason=f"the L2 gain exceeds {float(g):g} at "
                                                f"{ {k: float(v) for k, v in wit.point.items()} }",
                                         elapsed=time.perf_counter() - t0)
        res, _ = _try_storage(lin, b, gc, meth, systems)
        if res is not None and res.certified:
            done.append(res)
            continue
        if len(done) + len(stack) + 2 > max_pieces:
            return L2Certificate(Status.UNDECIDED, g, bx, hmax, wpk, meth, tuple(done),
                                 reason=f"no common storage on a sub-box and the piece limit "
                                        f"{max_pieces} is reached", elapsed=time.perf_counter() - t0)
        widths = [(hi - lo) / hi for lo, hi in b.bounds]
        k = max(range(len(widths)), key=lambda i: widths[i])
        if widths[k] == 0:
            return L2Certificate(Status.UNDECIDED, g, bx, hmax, wpk, meth, tuple(done),
                                 reason="the exact re-check of the storage failed at a point "
                                        "(gamma too close to the norm)",
                                 elapsed=time.perf_counter() - t0)
        lo, hi = b.bounds[k]
        mid = (lo + hi) / 2
        for part in ((lo, mid), (mid, hi)):
            bounds = list(b.bounds)
            bounds[k] = part
            stack.append(_box(lin, {n: bb for n, bb in zip(lin.gains, bounds)}))
    return L2Certificate(Status.CERTIFIED, g, bx, hmax, wpk, meth, tuple(done),
                         elapsed=time.perf_counter() - t0)


def certify_gamma(lin: LinearLoop, gains: Mapping[str, Any], *, method: str = "auto",
                  digits: int = 4) -> L2Certificate:
    """The smallest certified ``gamma`` at one gain point.

    The level starts from the numerical H-infinity norm (``method="riccati"``, the default
    for a point) or from the SDP ``min gamma`` (``method="sdp"``), rounded up to ``digits``
    significant digits, then 0.1 %, 1 %, 5 % above it when the exact re-check of the storage
    fails; each level is decided by :func:`certify_l2_box` on the degenerate box.

    >>> from formsync_design.derive.linearize import linearize_agents
    >>> from formsync_design.spec.loader import load_design
    >>> lin = linearize_agents(load_design("lv2012"), "path:2", [np.eye(3) * 2] * 2, pinning=[1, 1])
    >>> c = certify_gamma(lin, {"k_p": 1, "k_d": 4, "a_f": 1})
    >>> str(c.status), float(c.gamma) >= c.hinf, float(c.gamma) <= 1.001 * c.hinf + 1e-3
    ('certified', True, True)
    """
    pt = {k: parse_number(gains[k], k) for k in lin.gains}
    A, B, C = lin.standard({k: float(v) for k, v in pt.items()})
    h, _ = hinf_norm(A, B, C)
    if not math.isfinite(h):
        raise SolverError("the linearisation is not exponentially stable at these gains; no "
                          "finite L2 gain (check the gains and the graph's pinning)")
    meth = "riccati" if method == "auto" else method
    start = h
    if meth == "sdp":
        g = sdp_min_gamma([(None, A, B, C, None)], C)
        if g is None:
            raise SolverError("the SDP min gamma failed at these gains; try method='riccati'")
        start = g
    return _lowest_level(lin, {k: (v, v) for k, v in pt.items()}, start, meth, digits, 1)


def _lowest_level(lin: LinearLoop, box: Any, start: float, method: str, digits: int,
                  pieces: int) -> L2Certificate:
    last = None
    for rel in (0.0, 1e-3, 1e-2, 5e-2):
        g = round_up_gamma(start * (1 + rel) * (1 + 1e-9), digits)
        res = certify_l2_box(lin, box, g, method=method, max_pieces=pieces)
        if res.certified:
            return res
        last = res
    assert last is not None
    return last


def smallest_box_gamma(lin: LinearLoop, box: Any, *, digits: int = 4) -> L2Certificate:
    """The smallest ``gamma`` one quadratic storage certifies on the whole ``box``: the SDP
    :func:`sdp_min_gamma` over the box's vertices (a convex problem), rounded up and decided
    exactly by :func:`certify_l2_box` (``method="sdp"``, one piece).

    >>> from formsync_design.derive.linearize import linearize_agents
    >>> from formsync_design.spec.loader import load_design
    >>> lin = linearize_agents(load_design("lv2012"), "path:2", [np.eye(3) * 2] * 2, pinning=[1, 1])
    >>> c = smallest_box_gamma(lin, {"k_p": (1, 1.1), "k_d": 4, "a_f": 1})
    >>> str(c.status), float(c.gamma) >= c.hinf
    ('certified', True)

    On ``k_p`` in ``[1, 2]`` the two vertices have no common quadratic Lyapunov function at
    all (lightly damped modes of different frequencies): the SDP is infeasible, a
    :class:`~formsync_design.errors.SolverError` says so (:func:`certify_l2_box` still certifies
    such a box by splitting it).
    """
    bx = _box(lin, box)
    systems = _vertex_systems(lin, bx.vertices())
    g = sdp_min_gamma(systems, lin.C)
    if g is None:
        raise SolverError("the box SDP min gamma found no common quadratic storage on this box; "
                          "split it (certify_l2_box does) or narrow it")
    return _lowest_level(lin, bx, g, "sdp", digits, 1)


def harmonic_steady_bound(gamma: Any, harmonic: np.ndarray) -> float:
    """A bound of ``|z(t)|`` in the steady state of the linearisation under the harmonic
    disturbance ``c + a sin(w1 t + p1) sin(w2 t + p2)`` per spacecraft and axis
    (:class:`~formsync_design.models.disturbances.DisturbanceModel` parameters ``(N, 3, 6)``),
    implied by an L2-gain certificate ``gamma``: the disturbance is a sum of sinusoids
    ``Re(U_nu e^{i nu t})`` (``sin A sin B = (cos(A - B) - cos(A + B))/2``, grouped by frequency
    ``nu``, ``nu = 0`` real); the steady response to each is ``Re(G(i nu) U_nu e^{i nu t})`` with
    ``|G(i nu) U_nu| <= ||G||_inf |U_nu| <= gamma |U_nu|``, so ``|z(t)| <= gamma sum_nu |U_nu|``
    (floating point, rounded up by ``1e-12`` relative).

    >>> h = np.zeros((1, 3, 6)); h[0, 0, :2] = (1.0, 0.5); h[0, 0, 2] = 0.2; h[0, 0, 5] = np.pi / 2
    >>> round(harmonic_steady_bound(2, h), 9)     # constant 1 plus 0.5 sin(0.2 t)
    3.0
    """
    H = np.asarray(harmonic, dtype=float)
    n = H.shape[0]
    comps: dict[float, np.ndarray] = {}

    def add(nu: float, phase: float, amp: float, idx: int) -> None:
        if amp == 0:
            return
        if nu < 0:
            nu, phase = -nu, -phase
        key = round(nu, 12)
        vec = comps.setdefault(key, np.zeros(3 * n, dtype=complex))
        vec[idx] += amp * (math.cos(phase) if key == 0 else complex(math.cos(phase), math.sin(phase)))

    for i in range(n):
        for k in range(3):
            c, a, w1, p1, w2, p2 = H[i, k]
            idx = 3 * i + k
            add(0.0, 0.0, c, idx)
            add(w1 - w2, p1 - p2, a / 2, idx)
            add(w1 + w2, p1 + p2, -a / 2, idx)
    total = sum(float(np.linalg.norm(v)) for v in comps.values())
    return float(parse_number(gamma, "gamma")) * total * (1 + 1e-12)
