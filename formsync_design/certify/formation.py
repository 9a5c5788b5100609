"""The formation-level certificate of any agent design on the graph given.

From the design's exact linearisation at consensus on the graph
(:func:`~formsync_design.derive.formation.linearize_formation`), ``A(g) = T^-1 F(g)``:

1. **Consensus directions.**  Leaderless: the largest subspace ``S`` of common states
   ``1 (x) y`` that ``A(g)`` leaves invariant for every gain (exact rational elimination,
   per monomial of ``F``); the verdict is about the quotient ``A_Q`` (the disagreement: every
   coordinate ``x_i - x_N``, plus the common directions that are not invariant).  With a
   leader: the full state (it must converge to the reference).
2. **At a point** (exact rational gains): ``A_Q`` is Hurwitz when a Lyapunov matrix ``P``
   (solved in floats, then taken as exact) satisfies ``P > 0`` and
   ``A_Q^T P + P A_Q < 0``, both proven by :mod:`~formsync_design.certify.lyapunov`
   (rigorous rounding of the exact rational ``A_Q``); the certified decay rate is
   ``lambda_min(Q) / (2 lambda_max(P))``.  It is *refuted* when, for a shift
   ``sigma > 0``, ``(A_Q - sigma I)^T P + P (A_Q - sigma I) > 0`` is proven and ``P`` has
   a positive diagonal entry: by the inertia theorem ``A_Q`` then has an eigenvalue with
   real part ``> sigma`` (the witness also gives that eigenvalue and its eigenvector, in
   floats, for a reader to check).
3. **Over a box**: when ``F`` is multi-affine in the free gains, one ``P`` proven at every
   vertex proves every point (the Lyapunov matrix is multi-affine in the gains and the
   box is the convex hull of its vertices' values); otherwise the monomials are taken as
   independent over their ranges (a sound relaxation, at most 1024 vertices).  A vertex
   that is refuted refutes the box.

The verdict's :class:`~formsync_design.certify.scope.Scope`: the formation on the graph,
local exponential stability of consensus (or of the reference), the switching function's
realisation and the equilibrium as assumptions.  A law that is not differentiable at the
equilibrium is ``undecided`` with the term named.

>>> import numpy as np
>>> from formsync_design.gains import GainBox
>>> from formsync_design.spec.loader import load_design
>>> d = load_design("ma_quat_smc")
>>> box = GainBox.parse({"K1": "1.15", "K2": "0.15", "P1": "0.03", "P2": "0.03"})
>>> r = certify_formation(d, "ring:4", [np.diag([50.0, 55.0, 60.0])] * 4, box)
>>> str(r.status), r.scope.system, r.scope.property
('certified', <System.FORMATION: 'formation'>, <Property.LOCAL_EXPONENTIAL: 'local-exponential'>)
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.certify.lyapunov import decide_point
from formsync_design.certify.quotient import (
    consensus_quotient,
    matrix_at,
    quotient_terms,
    state_terms,
)
from formsync_design.certify.results import Status
from formsync_design.certify.scope import Basis, Property, Scope, System

__all__ = ["FormationWitness", "FormationCertificate", "certify_formation", "lagrangian_scope",
           "conditions_scope", "MAX_VERTICES"]

#: Most vertices a box certificate checks (free gains, or monomials when not multi-affine).
MAX_VERTICES = 1024



@dataclass(frozen=True)
class FormationWitness:
    """A refuting gain point: ``A_Q`` has an eigenvalue with real part ``> sigma`` (proven
    by the inertia certificate ``(A_Q - sigma I)^T P + P (A_Q - sigma I) >= ell I``,
    ``ell > 0``, ``P[k, k] > 0``), the float eigenvalue and eigenvector of the full
    linearisation (largest entries, by label)."""

    point: dict[str, Fraction]
    sigma: float
    ell: float
    diagonal_index: int
    eigenvalue: complex
    residual: float
    mode: tuple[tuple[str, complex], ...]

    def text(self) -> str:
        pt = ", ".join(f"{k}={float(v):g}" for k, v in self.point.items())
        top = ", ".join(f"{lab}: {abs(c):.3g}" for lab, c in self.mode[:4])
        lam = self.eigenvalue
        return (f"unstable mode at {pt}: eigenvalue {lam.real:.6g}{lam.imag:+.6g}j "
                f"(Re > {self.sigma:.3g} proven by the inertia theorem); largest entries {top}")

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.gains import json_number

        return {"point": {k: json_number(v) for k, v in self.point.items()},
                "real_part_above": self.sigma, "inertia_margin": self.ell,
                "positive_diagonal_of_P": self.diagonal_index,
                "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
                "residual": self.residual,
                "mode": [[lab, c.real, c.imag] for lab, c in self.mode]}


@dataclass(frozen=True)
class FormationCertificate:
    """The formation-level verdict (module docstring).

    ``status``; ``scope``; ``decay``: the certified exponential rate (certified only);
    ``witness``: a :class:`FormationWitness` (refuted only); ``reason``: why undecided;
    ``evidence``: sizes, method, spectral abscissae at the points checked, seconds.
    """

    status: Status
    scope: Scope
    decay: float | None = None
    witness: FormationWitness | None = None
    reason: str = ""
    evidence: Mapping[str, Any] = field(default_factory=dict)

    @property
    def certified(self) -> bool:
        return self.status == Status.CERTIFIED

    def text(self) -> str:
        head = f"formation certificate: {self.status}"
        if self.decay is not None:
            head += f" (certified decay rate {self.decay:.4g} 1/s)"
        lines = [head, f"  scope: {self.scope.text()}"]
        if self.witness is not None:
            lines.append(f"  witness: {self.witness.text()}")
        if self.reason:
            lines.append(f"  reason: {self.reason}")
        ev = self.evidence
        if "quotient_dim" in ev:
            lines.append(f"  checked: {ev['points']} gain point(s), disagreement dimension "
                         f"{ev['quotient_dim']} (consensus directions {ev['consensus_dim']}), "
                         f"largest real part {ev['spectral_abscissa']:.4g}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"status": str(self.status), "scope": self.scope.to_dict()}
        if self.decay is not None:
            out["decay_rate"] = self.decay
        if self.witness is not None:
            out["witness"] = self.witness.to_dict()
        if self.reason:
            out["reason"] = self.reason
        out["evidence"] = {k: v for k, v in self.evidence.items()}
        return out


# ------------------------------------------------------------------ exact linear algebra


def _mode(loop: Any, point: Mapping[str, Fraction], target: complex) -> tuple[complex, float, tuple]:
    A = np.linalg.solve(loop.T_float(), loop.F.evaluate({k: float(v) for k, v in point.items()}))
    lam, vec = np.linalg.eig(A)
    j = int(np.argmin(np.abs(lam - target)))
    v = vec[:, j] / np.linalg.norm(vec[:, j])
    res = float(np.linalg.norm(A @ v - lam[j] * v))
    order = np.argsort(-np.abs(v))[:6]
    return complex(lam[j]), res, tuple((loop.labels[k], complex(v[k])) for k in order)


def _vertices(box: Any, names: tuple[str, ...]) -> list[dict[str, Fraction]]:
    axes = []
    for nm in names:
        r = box[nm]
        lo, hi = Fraction(r.lo), Fraction(r.hi)
        axes.append([lo] if lo == hi else [lo, hi])
    return [dict(zip(names, pt)) for pt in itertools.product(*axes)]


def _scope(design: Any, lin: Any, graph: Any, leader: bool) -> Scope:
    assumptions = []
    if not lin.switching:
        pass  # the law has no switching function: nothing is realised
    elif lin.switch == "sgn":
        assumptions.append("sgn realised as the ideal sign")
    else:
        assumptions.append(f"sgn realised as {lin.switch}(x/phi), phi = {lin.phi} "
                           "(the boundary-layer law)")
    assumptions.append("equilibrium: the reference attitude at rest, controller states 0"
                       if leader else "equilibrium: every spacecraft at one attitude (the "
                       "identity), at rest, controller states 0")
    if lin.covered:
        assumptions.append("nonlinear conclusion by Lyapunov's indirect method (the law is "
                           "differentiable at the equilibrium: checked)")
    if lin.emulation:
        assumptions.append(f"sampling ({design.decl.sampling}) not covered: the "
                           "continuous-time emulation (held values equal to current ones)")
    covers = ("the exact linearisation of the closed loop at the equilibrium"
              if lin.covered else f"nothing: the law is not differentiable there ({lin.why})")
    return Scope(System.FORMATION, Property.LOCAL_EXPONENTIAL,
                 "the reference (full state)" if leader else "consensus (full state)",
                 graph=graph.name, n=graph.n, assumptions=tuple(assumptions), covers=covers,
                 basis=Basis.PROOF)


def certify_formation(design: Any, graph: Any, inertias: Any, box: Any, *, switch: str = "sat",
                      phi: Any = "1/100", pinning: Any = None) -> FormationCertificate:
    """The formation-level certificate of ``design`` on ``graph`` over ``box`` (module
    docstring).  ``box``: a :class:`~formsync_design.gains.GainBox` of the design's
    controller gains (multipliers are not part of the dynamics and are ignored)."""
    from formsync_design.derive.formation import linearize_formation
    from formsync_design.spec.declarations import GainRole

    t0 = time.perf_counter()
    ctrl = [g.name for g in design.decl.gains if g.role == GainRole.CONTROLLER]
    missing = [g for g in ctrl if g not in box]
    if missing:
        from formsync_design.errors import InputError

        raise InputError(f"expected values for the controller gains {ctrl} of {design.name}, "
                         f"missing {missing}")
    fixed = {g: Fraction(box[g].lo) for g in ctrl if box[g].lo == box[g].hi}
    lin = linearize_formation(design, graph, inertias, switch=switch, phi=phi, fixed=fixed,
                              pinning=pinning)
    leader = bool(design.decl.leader)
    scope = _scope(design, lin, lin.graph, leader)
    if not lin.covered or lin.loop is None:
        return FormationCertificate(Status.UNDECIDED, scope,
                                    reason=f"the linearisation does not decide it: {lin.why}",
                                    evidence={"seconds": time.perf_counter() - t0})
    loop = lin.loop
    terms = state_terms(loop)
    q = consensus_quotient(loop, terms, leader)
    qterms = quotient_terms(q, terms)
    gains = loop.gains
    free = [g for g in gains]
    multi_affine = all(e <= 1 for mono in qterms for e in mono)
    ev: dict[str, Any] = {"method": "", "quotient_dim": q.dim, "consensus_dim": q.consensus_dim,
                          "free_gains": free, "multi_affine": multi_affine}
    verts = _vertices(box, tuple(free)) if free else [{}]
    if len(verts) > MAX_VERTICES:
        return FormationCertificate(Status.UNDECIDED, scope, reason=f"{len(verts)} vertices "
                                    f"exceed the limit {MAX_VERTICES}", evidence=ev)
    full_point = {**{g: v for g, v in fixed.items()}}
    results = []
    for pt in verts:
        A, dA = matrix_at(qterms, gains, pt, q.dim)
        d = decide_point(A, dA)
        results.append((pt, A, dA, d))
        if d["status"] == Status.REFUTED:
            lam, res, mode = _mode(loop, pt, d["top"])
            w = FormationWitness({**full_point, **pt}, d["sigma"], d["ell"], d["k"], lam, res, mode)
            ev.update(method="inertia certificate at a vertex", points=len(results),
                      spectral_abscissa=d["abscissa"], seconds=time.perf_counter() - t0)
            return FormationCertificate(Status.REFUTED, scope, witness=w, evidence=ev)
    alphas = [d["abscissa"] for _, _, _, d in results]
    ev["spectral_abscissa"] = max(alphas)
    ev["points"] = len(results)
    if any(d["status"] != Status.CERTIFIED for _, _, _, d in results):
        bad = next(d for _, _, _, d in results if d["status"] != Status.CERTIFIED)
        ev.update(method="point checks", seconds=time.perf_counter() - t0)
        return FormationCertificate(Status.UNDECIDED, scope, reason=bad.get("reason", ""),
                                    evidence=ev)
    if len(verts) == 1:
        d = results[0][3]
        ev.update(method="Lyapunov certificate at the point", seconds=time.perf_counter() - t0)
        return FormationCertificate(Status.CERTIFIED, scope, decay=d["decay"], evidence=ev)
    if not multi_affine:
        ev.update(method="vertex point checks (not multi-affine: no box proof)",
                  seconds=time.perf_counter() - t0)
        return FormationCertificate(Status.UNDECIDED, scope, reason="the linearisation is not "
                                    "multi-affine in the free gains: every vertex is stable, the "
                                    "box is not proven", evidence=ev)
    ranges = {g: (Fraction(box[g].lo), Fraction(box[g].hi)) for g in free}
    got = _box(qterms, gains, q.dim, ranges, depth=0)
    ev.update(method=f"common Lyapunov matrix per sub-box, proven at its vertices (multi-affine; "
              f"{got[2]} sub-box(es))", points=got[3], seconds=time.perf_counter() - t0)
    if got[0] == Status.CERTIFIED:
        return FormationCertificate(Status.CERTIFIED, scope, decay=got[1], evidence=ev)
    if got[0] == Status.REFUTED:
        pt, d, A = got[4]
        lam, res, mode = _mode(loop, pt, d["top"])
        w = FormationWitness({**full_point, **pt}, d["sigma"], d["ell"], d["k"], lam, res, mode)
        return FormationCertificate(Status.REFUTED, scope, witness=w, evidence=ev)
    return FormationCertificate(Status.UNDECIDED, scope, reason="every vertex is stable but no "
                                "common Lyapunov matrix was proven on every sub-box (depth "
                                f"{_MAX_DEPTH})", evidence=ev)


_MAX_DEPTH = 4


def _common_p(mats: list[np.ndarray]) -> np.ndarray | None:
    """A common Lyapunov matrix of ``mats`` by an SDP (a hint: re-checked by the caller)."""
    import cvxpy as cp

    n = mats[0].shape[0]
    P = cp.Variable((n, n), symmetric=True)
    cons = [P >> np.eye(n)] + [A.T @ P + P @ A << -np.eye(n) for A in mats]
    try:
        cp.Problem(cp.Minimize(cp.trace(P)), cons).solve(solver=cp.CLARABEL)
    except (cp.SolverError, ValueError, ArithmeticError):
        return None
    if P.value is None or not np.all(np.isfinite(P.value)):
        return None
    return np.asarray((P.value + P.value.T) / 2)


def _box(qterms: Any, gains: tuple[str, ...], dim: int, ranges: dict[str, tuple[Fraction, Fraction]],
         depth: int) -> tuple[Any, ...]:
    """``(status, decay, sub-boxes, points, refuting (point, decision, A))`` of a box of the
    free gains: a common ``P`` proven at its vertices, else the box split along its widest
    axis (at most :data:`_MAX_DEPTH` levels)."""
    from formsync_design.certify.lyapunov import lyapunov_lower_bound, pd_lower_bound

    names = tuple(ranges)
    verts = [dict(zip(names, pt)) for pt in itertools.product(
        *[[lo] if lo == hi else [lo, hi] for lo, hi in ranges.values()])]
    mats = []
    for pt in verts:
        A, dA = matrix_at(qterms, gains, pt, dim)
        d = decide_point(A, dA)
        if d["status"] == Status.REFUTED:
            return (Status.REFUTED, None, 1, len(verts), (pt, d, A))
        if d["status"] != Status.CERTIFIED:
            return (Status.UNDECIDED, None, 1, len(verts), None)
        mats.append((A, dA, d["P"]))
    center = {g: (lo + hi) / 2 for g, (lo, hi) in ranges.items()}
    Ac, _ = matrix_at(qterms, gains, center, dim)
    cands: list[Any] = []
    dc = decide_point(Ac, np.abs(Ac) * 2.0**-52)
    if dc["status"] == Status.CERTIFIED:
        cands.append(dc["P"])
    cands.append(sum(P / np.abs(P).max() for _, _, P in mats))
    if dim <= 60:
        cands.append(_common_p([A for A, _, _ in mats]))
    for P in cands:
        if P is None:
            continue
        P = (P + P.T) / 2
        if pd_lower_bound(P) <= 0:
            continue
        ells = [lyapunov_lower_bound(A, dA, P) for A, dA, _ in mats]
        if min(ells) > 0:
            pmax = float(np.abs(P).sum(axis=1).max()) * (1 + 1e-12)
            return (Status.CERTIFIED, min(ells) / (2 * pmax), 1, len(verts), None)
    if depth >= _MAX_DEPTH:
        return (Status.UNDECIDED, None, 1, len(verts), None)
    g = max(names, key=lambda k: ranges[k][1] - ranges[k][0])
    lo, hi = ranges[g]
    mid = (lo + hi) / 2
    decay, boxes, points = np.inf, 0, len(verts)
    for part in ((lo, mid), (mid, hi)):
        got = _box(qterms, gains, dim, {**ranges, g: part}, depth + 1)
        boxes += got[2]
        points += got[3]
        if got[0] != Status.CERTIFIED:
            return (got[0], None, boxes, points, got[4])
        decay = min(decay, got[1])
    return (Status.CERTIFIED, decay, boxes, points, None)

def lagrangian_scope(graph: Any, spec: Any, kv_checked: bool) -> Scope:
    """The scope of a Lagrangian design's ``Theta_i``/``Pi`` certificate on ``graph``: the
    formation on that graph (``Pi`` is assembled from its Laplacian), asymptotic
    synchronisation by the design's Lyapunov function ``V' <= -zeta^T (Pi x I) zeta``.

    >>> from formsync_design.graphs import load_graph
    >>> from formsync_design.spec.loader import load_spec
    >>> lagrangian_scope(load_graph("ring:4"), load_spec(), False).text()[:60]
    'formation on ring:4 (N = 4): asymptotic stability of synchro'
    """
    assumptions = ["the quaternion-vector Lagrangian model: q0_i > 0 along the trajectory "
                   "(the chart of the derivation; its edge q0 = 0 is where the law is undefined)",
                   "sgn ideal (the switching term as derived)"]
    if spec.decl.switching is not None:
        assumptions.append("disturbance bound and K_v condition checked" if kv_checked else
                           "no K_v check: the disturbance-free loop")
    return Scope(System.FORMATION, Property.ASYMPTOTIC, "synchronisation (attitude errors and "
                 "rates)", graph=getattr(graph, "name", str(graph)), n=graph.n,
                 assumptions=tuple(assumptions),
                 covers="the design's Lyapunov function on the whole formation (Theta_i, Pi "
                 "from the derivation)", basis=Basis.PROOF)


def conditions_scope(design: Any) -> Scope:
    """The scope of an agent design's own ``conditions(c)`` families: what they prove is what
    the design's author wrote them for; by themselves they are never a formation verdict."""
    return Scope(System.DESIGN_CONDITIONS, Property.CONDITIONS, "design's conditions(c) "
                 "families (positive definite on the box)",
                 covers=f"the families of {design.name}'s conditions(c) hook, not the formation",
                 basis=Basis.PROOF)
