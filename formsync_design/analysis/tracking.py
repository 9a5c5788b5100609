"""Certificates of the fly-around closed loop (Zhang et al. 2014, issue 14).

Orbit (LQR on the CW model)
    :func:`orbit_certificate`: the Riccati residual, the closed-loop eigenvalues, the
    guaranteed margins of an LQR with diagonal ``R`` checked by computation
    (:func:`~formsync_design.models.orbit.lqr_margins`: return difference, per-channel gain
    and phase boxes, bisected common margins), and the spectral radius of the sampled loop
    (zero-order hold at the sample period, computed, not a proof).

Attitude (the tracking law over a box)
    :func:`attitude_certificate`: for every ``k_p``, diagonal ``K_d`` and diagonal plant
    inertia ``J`` in a box (the law keeps the nominal ``J_hat``) and every reference with
    ``|omega_di,k| <= W_k``, ``|omega_di',k| <= A_k`` (time-varying), the linearized error
    dynamics of :func:`~formsync_design.derive.tracking.derive_tracking_attitude`,
    ``sigma' = omega/4``, ``J omega' = -k_p sigma - K_d omega + N x + d``, satisfy

        V = x^T P x,  P = [[p1 k_p I, p2 J], [p2 J, p3 J]],  V' <= -2 alpha V + 2 (L x)^T d

    (``L = [p2 I, p3 I]``): the homogeneous loop is exponentially stable with rate
    ``alpha`` uniformly over the box.  ``V'`` of the nominal part is ``x^T S0 x`` with
    ``S0 = A0^T P + P A0`` multi-affine in ``(k_p, K_d, J)`` (checked symbolically), so its
    vertices decide ``S0 + 2 alpha P <= -mu I`` (exact rational ``LDL^T``); ``N`` is bounded
    in Frobenius norm over the box in exact rationals (``J = J_hat + delta``) and the
    certificate needs ``mu >= 2 |L|_2 Nbar``.  ``P > 0`` is checked at the vertices too.
    ``S0`` and ``P`` decouple exactly into one 2x2 block per axis (checked symbolically: the
    entries outside the blocks are identically zero), so each block is checked at the
    vertices of its own parameters.  The SDP (cvxpy + Clarabel) only proposes ``p1, p2, p3,
    alpha``; the exact re-check decides.  The nominal nonlinear result (``J = J_hat``: ``V' = -omega^T K_d omega``) is
    the derivation's, for any inertia.

>>> _blocks(sp.Matrix([[1, 0, 2], [0, 3, 0], [2, 0, 1]]))
[[0, 2], [1]]
"""

from __future__ import annotations

import enum
import itertools
import math
import warnings
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.linalg
import sympy as sp

from formsync_design.certify.exact import exact_ldl
from formsync_design.derive.tracking import derive_tracking_attitude
from formsync_design.gains import json_number
from formsync_design.models.orbit import LQRMargins, cw_matrices, lqr_margins
from formsync_design.models.relative_reference import desired_attitude

__all__ = ["CertStatus", "OrbitCertificate", "orbit_certificate", "AttitudeCertificate",
           "attitude_certificate", "reference_rate_bounds"]


class CertStatus(enum.StrEnum):
    """Outcome of a fly-around certificate."""

    CERTIFIED = "certified"  # the exact re-check holds at every vertex and for the bound
    NOT_CERTIFIED = "not-certified"  # the proposed certificate fails the exact re-check
    ERROR = "error"


@dataclass(frozen=True)
class OrbitCertificate:
    """The LQR's computed evidence (module docstring)."""

    K: np.ndarray
    riccati_residual: float
    max_real_part: float
    margins: LQRMargins
    sampled_spectral_radius: float

    def to_dict(self) -> dict[str, Any]:
        return {"K": [[json_number(v) for v in r] for r in self.K],
                "riccati_residual": json_number(self.riccati_residual),
                "max_real_part": json_number(self.max_real_part),
                "margins": self.margins.to_dict(),
                "sampled_spectral_radius": json_number(self.sampled_spectral_radius)}


def orbit_certificate(case: Any) -> OrbitCertificate:
    """LQR evidence for a fly-around case (:class:`~formsync_design.verify.tracking_case.FlyaroundCase`)."""
    from formsync_design.sim.tracking import lqr_for

    design, _, r = lqr_for(case.spec, case.scenario)
    a, b = cw_matrices(case.scenario.mean_motion)
    margins = lqr_margins(a, b, design, r)
    dt = case.options.sample_period
    m = scipy.linalg.expm(np.block([[a, b], [np.zeros((3, 9))]]) * dt)
    phi, gam = m[:6, :6], m[:6, 6:]
    rho = float(np.abs(np.linalg.eigvals(phi - gam @ design.K)).max())
    return OrbitCertificate(design.K, design.riccati_residual, design.max_real_part, margins, rho)


def reference_rate_bounds(case: Any, samples: int = 721) -> tuple[np.ndarray, np.ndarray]:
    """Componentwise ``max |omega_di|`` and ``max |omega_di'|`` (in ``d``) over the case's
    horizon, on ``samples`` equally spaced times (a measurement; the certificate covers
    these times the case's ``rate_margin``)."""
    sc = case.scenario
    n = sc.mean_motion
    w = np.zeros(3)
    a = np.zeros(3)
    for t in np.linspace(0.0, case.options.tf, samples):
        d = desired_attitude(float(t), sc.reference, n, case.options.reading)
        w = np.maximum(w, np.abs(d.omega_di))
        a = np.maximum(a, np.abs(d.omega_di_dot))
    return w, a


@dataclass(frozen=True)
class AttitudeCertificate:
    """The attitude law's certificate over a box (module docstring).

    Attributes
    ----------
    status : CertStatus
    box : dict
        ``k_p``, ``K_d`` (3 pairs), ``J`` (3 pairs), ``W``, ``A`` (rate bounds).
    alpha : Fraction
        Certified exponential rate of the homogeneous linearized loop (1/s).
    p : tuple of Fraction
        ``(p1, p2, p3)``.
    mu : Fraction
        Certified ``lambda_min(-(S0 + 2 alpha P))`` lower bound over the vertices.
    n_bound : Fraction
        Exact upper bound of ``|N|_F`` over the box.
    vertices : int
    worst_vertex : tuple
        The block vertex with the smallest margin (``(name, value)`` pairs).
    forcing_bound : float
        ``max |d|`` over the box (N m), the steady forcing the mismatch leaves.
    multi_affine : bool
        ``S0`` and ``P`` are multi-affine in the box parameters (checked symbolically).
    """

    status: CertStatus
    box: dict
    alpha: Fraction
    p: tuple[Fraction, Fraction, Fraction]
    mu: Fraction
    n_bound: Fraction
    vertices: int
    worst_vertex: tuple
    forcing_bound: float
    multi_affine: bool
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"status": str(self.status), "alpha": json_number(float(self.alpha)),
                "p": [json_number(float(v)) for v in self.p], "mu": json_number(float(self.mu)),
                "n_bound": json_number(float(self.n_bound)), "vertices": self.vertices,
                "forcing_bound": json_number(self.forcing_bound),
                "multi_affine": self.multi_affine, "reason": self.reason,
                "box": {k: [json_number(float(x)) for x in np.ravel(v)]
                        for k, v in self.box.items()}}


def _frac(x: float) -> Fraction:
    return Fraction(x).limit_denominator(10**9)


def _bound_poly(expr: sp.Expr, bounds: dict[sp.Symbol, Fraction]) -> Fraction:
    """``sum |c| prod max|v|`` over the monomials (an exact upper bound of ``|expr|``)."""
    poly = sp.Poly(sp.expand(expr), *bounds)
    tot = Fraction(0)
    for mon, c in poly.terms():
        term = abs(Fraction(sp.Rational(c).p, sp.Rational(c).q))
        for v, k in zip(bounds, mon):
            term *= bounds[v] ** k
        tot += term
    return tot


def attitude_certificate(case: Any, rate_samples: int = 721) -> AttitudeCertificate:
    """Certify the attitude law over the case's ``[certificate]`` box (module docstring).

    >>> from formsync_design.verify.tracking_case import load_flyaround_case
    >>> cert = attitude_certificate(load_flyaround_case(), rate_samples=50)
    >>> str(cert.status), cert.vertices, float(cert.alpha) > 0.02
    ('certified', 128, True)
    """
    import cvxpy as cp

    der = derive_tracking_attitude(case.spec)
    sym = der.symbols
    cfg = case.certificate
    sc = case.scenario
    kp0 = float(sc.gains["k_p"][0])
    kd0 = [float(v) for v in sc.gains["K_d"]]
    j0 = [float(v) for v in np.diag(sc.inertia)]
    jh = [_frac(v) for v in j0]
    kp_box = tuple(_frac(kp0 * s) for s in cfg["k_p_scale"])
    kd_box = [tuple(_frac(k * s) for s in cfg["K_d_scale"]) for k in kd0]
    j_box = [tuple(_frac(j * s) for s in cfg["inertia_scale"]) for j in j0]
    w_meas, a_meas = reference_rate_bounds(case, rate_samples)
    wb = [_frac(cfg["rate_margin"] * float(v)) for v in w_meas]
    ab = [_frac(cfg["rate_margin"] * float(v)) for v in a_meas]
    box = {"k_p": kp_box, "K_d": kd_box, "J": j_box, "W": wb, "A": ab}
    # nominal part: S0 = A0^T P + P A0 with P(J, k_p)
    p1, p2, p3, al = sp.symbols("p1 p2 p3 alpha", real=True)
    kp = sym["k_p"]
    jd = sp.diag(*sym["J"])
    pm = sp.zeros(6, 6)
    pm[:3, :3] = p1 * kp * sp.eye(3)
    pm[:3, 3:] = p2 * jd
    pm[3:, :3] = p2 * jd
    pm[3:, 3:] = p3 * jd
    s0 = (der.A0.T * pm + pm * der.A0).applyfunc(sp.cancel)
    params = [kp, *sym["K_d"], *sym["J"]]
    multi = all(e.is_polynomial(*params) and all(sp.degree(e, v) <= 1 for v in params)
                for e in list(s0) + list(pm) if e != 0)
    # N: J = J_hat + delta, bounded over the box
    deltas = sp.symbols("delta_1:4", real=True)
    nsub = {sym["J"][i]: jh[i] + deltas[i] for i in range(3)}
    nsub.update({sym["J_hat"][i]: jh[i] for i in range(3)})
    bounds: dict[sp.Symbol, Fraction] = {}
    for i in range(3):
        bounds[deltas[i]] = max(abs(j_box[i][0] - jh[i]), abs(j_box[i][1] - jh[i]))
        bounds[sym["omega_di"][i]] = wb[i]
        bounds[sym["omega_di_dot"][i]] = ab[i]
    n_sq = sum((_bound_poly(e.xreplace(nsub), bounds) ** 2 for e in der.N), Fraction(0))
    d_bound = math.sqrt(float(sum((_bound_poly(e.xreplace(nsub), bounds) ** 2
                                   for e in der.forcing), Fraction(0))))
    corners = list(itertools.product(kp_box, *kd_box, *j_box))
    pbox = dict(zip(params, [kp_box, *kd_box, *j_box]))
    reason = ""
    if not multi:
        return AttitudeCertificate(CertStatus.NOT_CERTIFIED, box, Fraction(0), (Fraction(0),) * 3,
                                   Fraction(0), Fraction(0), len(corners), (), d_bound, False,
                                   "S0 is not multi-affine in the box parameters")
    # S0 + 2 alpha P and P decouple exactly into blocks (one per axis here): every entry
    # outside the blocks is identically 0, so a block's own vertices decide it (sound)
    blocks = _blocks(s0 + pm)
    n_hint = float(_sqrt_up(n_sq))
    q1, q2, mu = cp.Variable(), cp.Variable(), cp.Variable()
    apar = cp.Parameter(nonneg=True)
    cons = [q1 >= 0, mu <= 1e6, mu >= 2.2 * n_hint * (cp.abs(q2) + 1)]
    checks = []  # (block indices, its parameters, its vertices)
    for idx in blocks:
        sub_s = s0.extract(idx, idx)
        sub_p = pm.extract(idx, idx)
        bp = [v for v in params if v in (sub_s.free_symbols | sub_p.free_symbols)]
        verts = list(itertools.product(*[pbox[v] for v in bp]))
        checks.append((idx, bp, verts, sub_s, sub_p))
        fs = sp.lambdify([p1, p2, p3, *bp], sub_s, "numpy")
        fp = sp.lambdify([p1, p2, p3, *bp], sub_p, "numpy")
        eye = np.eye(len(idx))
        for cv in verts:
            vals = [float(v) for v in cv]
            c1, c2, c3 = (np.array(fs(*e, *vals), float) for e in np.eye(3))
            d1, d2, d3 = (np.array(fp(*e, *vals), float) for e in np.eye(3))
            pv = q1 * d1 + q2 * d2 + d3
            cons.append(-(q1 * c1 + q2 * c2 + c3) - 2 * apar * pv - mu * eye >> 0)
            cons.append(pv - 1e-6 * eye >> 0)
    prob = cp.Problem(cp.Maximize(mu), cons)

    def solve(alpha: float) -> tuple[float, float, float, float] | None:
        apar.value = alpha
        try:
            with warnings.catch_warnings():  # an inaccurate hint is fine: the re-check decides
                warnings.simplefilter("ignore")
                prob.solve(solver=cp.CLARABEL)
        except cp.error.SolverError:
            return None
        if prob.status not in ("optimal", "optimal_inaccurate") or mu.value is None:
            return None
        return (float(np.asarray(q1.value)), float(np.asarray(q2.value)), 1.0,
                float(np.asarray(mu.value)))

    lo, hi = 0.0, 0.25
    sol0 = solve(0.0)
    if sol0 is None:
        return AttitudeCertificate(CertStatus.NOT_CERTIFIED, box, Fraction(0), (Fraction(0),) * 3,
                                   Fraction(0), _sqrt_up(n_sq), len(corners), (), d_bound, True,
                                   "the SDP found no Lyapunov function of this structure whose "
                                   "margin beats the bound on N (not a refutation)")
    best = (0.0, sol0)
    for _ in range(8):
        mid = 0.5 * (lo + hi)
        sol = solve(mid)
        if sol is None:
            hi = mid
        else:
            lo, best = mid, (mid, sol)
    alpha = _frac(best[0] * 0.98)
    q = best[1]
    pr = (_frac(q[0]), _frac(q[1]), Fraction(1))
    mu_try = _frac(q[3] * 0.9)
    # exact re-check: every block at every one of its vertices, in rationals
    fixed = {p1: _rat(pr[0]), p2: _rat(pr[1]), p3: _rat(pr[2]), al: _rat(alpha)}
    worst: tuple = ()
    min_margin = math.inf
    status = CertStatus.CERTIFIED
    for idx, bp, verts, sub_s, sub_p in checks:
        lyap = (sub_s + 2 * al * sub_p).xreplace(fixed)
        pfix = sub_p.xreplace(fixed)
        for cv in verts:
            point = {v: _rat(x) for v, x in zip(bp, cv)}
            mrat = [[_fr(-lyap[i, k].xreplace(point)) - (mu_try if i == k else 0)
                     for k in range(len(idx))] for i in range(len(idx))]
            prat = [[_fr(pfix[i, k].xreplace(point)) for k in range(len(idx))]
                    for i in range(len(idx))]
            ok, _ = exact_ldl(mrat)
            okp, _ = exact_ldl(prat)
            lam = float(np.linalg.eigvalsh(np.array(mrat, dtype=float)).min())
            if lam < min_margin:
                min_margin, worst = lam, tuple((str(v), float(x)) for v, x in zip(bp, cv))
            if not (ok and okp):
                status = CertStatus.NOT_CERTIFIED
                reason = (f"the exact re-check fails at the vertex "
                          f"{', '.join(f'{v}={float(x):g}' for v, x in zip(bp, cv))}")
                break
        if status != CertStatus.CERTIFIED:
            break
    l_sq = pr[1] ** 2 + pr[2] ** 2
    if status == CertStatus.CERTIFIED and not (mu_try ** 2 >= 4 * l_sq * n_sq):
        status = CertStatus.NOT_CERTIFIED
        reason = "the bound on N exceeds the certified margin mu"
    return AttitudeCertificate(status, box, alpha, pr, mu_try, _sqrt_up(n_sq),
                               len(corners), worst, d_bound, True, reason)


def _rat(x: Fraction) -> sp.Rational:
    return sp.Rational(x.numerator, x.denominator)


def _fr(x: Any) -> Fraction:
    r = sp.Rational(x)
    return Fraction(int(r.p), int(r.q))


def _blocks(m: sp.Matrix) -> list[list[int]]:
    """Index sets of the connected components of the symbolic nonzero pattern of ``m``."""
    n = m.shape[0]
    comp = list(range(n))

    def find(i: int) -> int:
        while comp[i] != i:
            comp[i] = comp[comp[i]]
            i = comp[i]
        return i

    for i in range(n):
        for k in range(n):
            if sp.simplify(m[i, k]) != 0 or sp.simplify(m[k, i]) != 0:
                comp[find(i)] = find(k)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    return sorted(groups.values())


def _sqrt_up(x: Fraction) -> Fraction:
    """A rational upper bound of ``sqrt(x)`` (for the report)."""
    r = _frac(math.sqrt(float(x)) * (1 + 1e-12) + 1e-300)
    while r * r < x:
        r *= Fraction(1000001, 1000000)
    return r
