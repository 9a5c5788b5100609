"""Certified peak-torque bound from a set of initial attitudes and rates (issue 15, item 2).

Controller structure (derived): :func:`~formsync_design.derive.closed_loop.derive_closed_loop`
gives ``Q^T u = A a + B q'`` with the commanded acceleration
``a = c_qd q' + c_s s + c_sigma sigma``, and the model
(:func:`~formsync_design.models.attitude.derive_attitude_model`) has
``B q' = Q^T (J Q' q' + omega x J omega)``, ``A = Q^T J Q``, ``omega = Q q'``, so

    ``u_i = J_i (Q_i a_i + Q_i' q_i') + omega_i x J_i omega_i``.

Norms used (``r = |q_i|``, ``q0 = sqrt(1 - r^2)``): ``|Q| = 2 / q0`` (the
singular values of ``E = Q^-1`` are ``1/2, 1/2, q0/2``);
``|Q' q'| <= 2 |q'|^2 (1 + 3 r / q0 + r^3 / q0^3)`` (triangle inequality on
``Q = 2 (q0 I - q^x + q q^T / q0)``); ``|omega x J omega| <= (l_max - l_min) / 2 |omega|^2``
(``omega x J omega = omega x (J - c I) omega`` for the mid eigenvalue ``c``).

State bounds: the nominal loop (``K_v = 0``, no disturbance, exact model
cancellation, as in the paper's proof) is linear in ``q``.  Per Laplacian mode
``k`` the exact rational solution ``P_k(lambda)`` of
``A_k^T P_k + P_k A_k = -I`` gives ``V = sum_k z_k^T P_k z_k`` with ``V' <= 0``
on the disagreement subspace, so for every linear functional ``c``,
``|c^T z(t)|^2 <= V(0) c^T P^-1 c``, and
``V(0) <= max_k lambda_max(P_k) N (r0^2 + (w0/2)^2)`` (``|q'| <= |omega| / 2``).
With ``sum_k u_k(i)^2 = 1 - 1/N`` this bounds ``|q_i - q_bar|``, ``|q_i' - q_bar'|`` and
``|s_i|``; the average obeys ``q_bar'' = c_qd q_bar'``, so ``|q_bar(t)| <= r0 + v0 / K_o``
and ``|q_bar'(t)| <= v0``.  Every sup over a Laplacian eigenvalue enclosure is
an exact rational bound (numerator and denominator ranges); only the final
square roots are taken in floating point and rounded up by a relative ``1e-12``.
A bound ``|q_i(t)| < 1`` is required (else ``q0`` could reach 0; undecided).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cache
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.analysis.modes import (
    LAMBDA,
    mode_model,
    poly_coeffs_in_lambda,
    sym_to_fraction,
)
from formsync_design.analysis.results import Verdict, jsonify
from formsync_design.analysis.spectrum import laplacian_spectrum, poly_range
from formsync_design.derive.closed_loop import derive_closed_loop
from formsync_design.errors import InputError
from formsync_design.gains import parse_number
from formsync_design.graphs import make_graph

__all__ = ["TorqueBound", "peak_torque_bound", "controller_torque", "mode_lyapunov", "sup_rational", "torque_section"]

_UP = 1 + 1e-12


@dataclass(frozen=True)
class TorqueBound:
    """Certified ``max_t |u_i(t)|_2`` per spacecraft from the initial set (``inf``: none)."""

    status: Verdict
    graph: str
    gains: tuple[Fraction, Fraction, Fraction]
    r0: Fraction
    w0: Fraction
    bound: tuple[float, ...]
    q_max: float
    rate_max: float
    s_max: float
    reason: str

    @property
    def peak(self) -> float:
        """The largest per-spacecraft bound (N m)."""
        return max(self.bound) if self.bound else math.inf

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"status": str(self.status), "graph": self.graph,
                        "gains": dict(zip(("K_o", "K_q", "beta"), self.gains)), "r0": self.r0,
                        "w0_rad_s": self.w0, "bound_N_m": list(self.bound), "peak_N_m": self.peak,
                        "q_max": self.q_max, "qdot_max": self.rate_max, "s_max": self.s_max,
                        "reason": self.reason})


@cache
def _lyap_symbolic(key: tuple) -> tuple[sp.Expr, ...]:
    spec, gains = key[0], key[1:]
    mm = mode_model(spec)
    sub = {g: sp.Rational(v.numerator, v.denominator) for g, v in zip(mm.gains, gains)}
    a = mm.a.subs(sub)
    p00, p01, p11 = sp.symbols("p00 p01 p11")
    p = sp.Matrix([[p00, p01], [p01, p11]])
    eq = a.T * p + p * a + sp.eye(2)
    sol = sp.solve([eq[0, 0], eq[0, 1], eq[1, 1]], [p00, p01, p11], dict=True)
    if len(sol) != 1:
        raise InputError(f"expected a unique Lyapunov solution per mode, received {len(sol)} at gains "
                         f"{[float(g) for g in gains]}")
    s = sol[0]
    ps = [sp.cancel(s[x]) for x in (p00, p01, p11)]
    det = sp.cancel(ps[0] * ps[2] - ps[1] ** 2)
    return (ps[0] + ps[2], sp.cancel(ps[2] / det), sp.cancel(ps[0] / det),
            sp.cancel(LAMBDA**2 * ps[2] / det), ps[0], det)


def mode_lyapunov(gains: Any, spec: Any = None) -> dict[str, sp.Expr]:
    """Exact ``P_k(lambda)`` quantities of ``A_k^T P + P A_k = -I`` at a gain point:
    ``trace``, ``inv00``, ``inv11`` (entries of ``P^-1``), ``lam2_inv00``, ``p00``, ``det``.

    >>> d = mode_lyapunov((2, 1, Fraction(1, 10)))
    >>> sp.simplify(d["trace"].subs(LAMBDA, 1))   # A = [[0, 1], [-1, -2]]
    2
    """
    gs = tuple(Fraction(parse_number(x, n)) for x, n in zip(gains, ("K_o", "K_q", "beta")))
    vals = _lyap_symbolic((spec, *gs))
    return dict(zip(("trace", "inv00", "inv11", "lam2_inv00", "p00", "det"), vals))


def sup_rational(expr: sp.Expr, lo: Fraction, hi: Fraction) -> Fraction | None:
    """Exact upper bound of a rational function of ``lambda`` on ``[lo, hi]`` whose
    numerator and denominator keep their signs there (None if the denominator's sign is
    not proven constant).

    >>> sup_rational(1 / (1 + LAMBDA), Fraction(1), Fraction(3))
    Fraction(1, 2)
    """
    num, den = sp.fraction(sp.together(expr))
    nl, nh = poly_range(poly_coeffs_in_lambda(num, {}), lo, hi)
    dl, dh = poly_range(poly_coeffs_in_lambda(den, {}), lo, hi)
    if dl <= 0:
        nl, nh, dl, dh = -nh, -nl, -dh, -dl
        if dl <= 0:
            return None
    return nh / dl if nh >= 0 else nh / dh


def peak_torque_bound(graph: Any, gains: Any, inertias: Any, r0: Any, w0: Any, *,
                      spec: Any = None) -> TorqueBound:
    """Certified bound on ``|u_i(t)|_2`` for all ``t >= 0`` from every initial
    ``|q_i(0)| <= r0`` (quaternion vector part) and ``|omega_i(0)| <= w0`` (rad/s).

    Parameters
    ----------
    graph : Graph or spec
    gains : (K_o, K_q, beta), a point
    inertias : (3, 3) or (N, 3, 3) array (kg m^2)
    r0, w0 : numbers

    Examples
    --------
    >>> tb = peak_torque_bound("ring:4", (1.6, 0.4, 0.3), np.diag([50.0, 55.0, 60.0]), 0.1, 0.01)
    >>> tb.status.value, 0 < tb.peak < 1000, tb.q_max < 1
    ('certified', True, True)
    """
    g = make_graph(graph)
    gs = tuple(Fraction(parse_number(x, n)) for x, n in zip(gains, ("K_o", "K_q", "beta")))
    if len(gs) != 3:
        raise InputError(f"expected gains (K_o, K_q, beta), received {len(gs)} values")
    r0f, w0f = Fraction(parse_number(r0, "r0")), Fraction(parse_number(w0, "w0"))
    if not (0 <= r0f < 1) or w0f < 0:
        raise InputError(f"expected 0 <= r0 < 1 and w0 >= 0, received r0={float(r0f):g}, w0={float(w0f):g}")
    J = np.asarray(inertias, dtype=float)
    Js = [J] * g.n if J.shape == (3, 3) else list(J)
    if len(Js) != g.n or any(np.shape(x) != (3, 3) for x in Js):
        raise InputError(f"expected one 3x3 inertia or {g.n} of them, received shape {J.shape}")
    cl = derive_closed_loop(spec)
    gsub = {s: sp.Rational(v.numerator, v.denominator) for s, v in zip(mode_model(spec).gains, gs)}
    c_qd = sym_to_fraction(sp.sympify(cl.c_qd).subs(gsub))
    c_s = sym_to_fraction(sp.sympify(cl.c_s).subs(gsub))
    name = g.name
    nope = TorqueBound(Verdict.UNDECIDED, name, (gs[0], gs[1], gs[2]), r0f, w0f, (math.inf,) * g.n,
                       math.inf, math.inf, math.inf, "")
    if c_qd >= 0:
        return _with(nope, "the consensus mode q_bar'' = c_qd q_bar' is not damped (c_qd >= 0)")
    from formsync_design.analysis.certificates import GAINS, certify

    if certify(g, dict(zip(GAINS, gs)), "spectral", spec=spec).status is not Verdict.CERTIFIED:
        # Hurwitz per mode is what makes P_k > 0 (so det > 0 and every ratio below positive)
        return _with(nope, "the nominal loop is not proven stable at these gains (spectral certificate)")
    q = mode_lyapunov(gs, spec)
    tr = i00 = i11 = l2 = Fraction(0)
    for c in laplacian_spectrum(g).clusters:
        vals = [sup_rational(q[k], c.lo, c.hi) for k in ("trace", "inv00", "inv11", "lam2_inv00")]
        p00_lo = poly_range(poly_coeffs_in_lambda(sp.fraction(sp.together(q["p00"]))[0], {}), c.lo, c.hi)[0]
        ok = [v for v in vals if v is not None]
        if len(ok) != 4 or p00_lo <= 0:
            return _with(nope, "the mode Lyapunov function is not proven positive definite "
                         "(the nominal loop is not stable at these gains)")
        tr, i00, i11, l2 = (max(a, b) for a, b in zip((tr, i00, i11, l2), ok))
    n = g.n
    v0 = w0f / 2
    V0 = tr * n * (r0f**2 + v0**2)
    w = V0 * (1 - Fraction(1, n))
    dis_q = math.sqrt(float(w * i00)) * _UP
    dis_v = math.sqrt(float(w * i11)) * _UP
    s_max = math.sqrt(float(w * l2)) * _UP
    r_max = (float(r0f + v0 / (-c_qd)) + dis_q) * _UP
    qd_max = (float(v0) + dis_v) * _UP
    if r_max >= 1:
        return _with(nope, f"the attitude bound |q_i(t)| <= {r_max:.4g} does not exclude q0 = 0 "
                     "(shrink the initial set)")
    q0 = math.sqrt(1 - r_max**2) / _UP
    om = 2 * qd_max / q0
    acc = float(-c_qd) * qd_max + float(abs(c_s)) * s_max
    qdot_term = 2 * qd_max**2 * (1 + 3 * r_max / q0 + r_max**3 / q0**3)
    out = []
    for Ji in Js:
        ev = np.linalg.eigvalsh((Ji + Ji.T) / 2)
        jmax, spread = float(ev[-1]) * _UP, float(ev[-1] - ev[0]) / 2 * _UP
        out.append((jmax * (2 / q0 * acc + qdot_term) + spread * om**2) * _UP)
    return TorqueBound(Verdict.CERTIFIED, name, (gs[0], gs[1], gs[2]), r0f, w0f, tuple(out), r_max,
                       qd_max, s_max, "V' <= 0 per Laplacian mode (exact Lyapunov solution) bounds q, q' "
                       "and s_i; u = J (Q a + Q' q') + omega x J omega bounds the torque")


def _with(tb: TorqueBound, reason: str) -> TorqueBound:
    from dataclasses import replace

    return replace(tb, reason=reason)


def controller_torque(q: np.ndarray, qd: np.ndarray, J: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``u = J (Q a + Q' q') + omega x J omega`` for one spacecraft (numpy; ``q`` vector part).

    >>> u = controller_torque(np.zeros(3), np.zeros(3), np.eye(3), np.array([1.0, 0, 0]))
    >>> u.tolist()   # at rest, identity attitude: Q = 2 I
    [2.0, 0.0, 0.0]
    """
    q0 = math.sqrt(1 - float(q @ q))
    sk = np.array([[0, -q[2], q[1]], [q[2], 0, -q[0]], [-q[1], q[0], 0]])
    Q = 2 * (q0 * np.eye(3) - sk + np.outer(q, q) / q0)
    q0d = -float(q @ qd) / q0
    vk = np.array([[0, -qd[2], qd[1]], [qd[2], 0, -qd[0]], [-qd[1], qd[0], 0]])
    Qd = 2 * (q0d * np.eye(3) - vk + (np.outer(qd, q) + np.outer(q, qd)) / q0 - np.outer(q, q) * q0d / q0**2)
    om = Q @ qd
    return np.asarray(J @ (Q @ a + Qd @ qd) + np.cross(om, J @ om))


def torque_section(graphs: tuple[str, ...] = ("ring:8", "star:8", "complete:8"),
                   point: tuple[str, str, str] = ("1.6", "0.4", "0.3"),
                   r0: str = "0.05", w0: str = "0.01") -> list[str]:
    """Markdown lines: certified peak-torque bounds and a simulated peak, per graph."""
    from formsync_design.analysis.inertia import simulate_mismatch

    J = np.diag([50.0, 55.0, 60.0])
    lines = ["## Certified peak torque (item 2)", "",
             f"Gains (K_o, K_q, beta) = ({', '.join(point)}), J = diag(50, 55, 60) kg m^2, initial set "
             f"|q_i(0)| <= {r0}, |omega_i(0)| <= {w0} rad/s, nominal loop (K_v = 0, no disturbance).",
             "The bound holds for every trajectory from the set (`formsync certify --torque-limit U`); the",
             "simulated peak is one trajectory from a corner of the set (every |q_i(0)| = r0, every",
             "|omega_i(0)| = w0, seeded directions), RK4. The bound is conservative: it bounds states by a",
             "quadratic Lyapunov function (a factor sqrt(N kappa)) and the torque by norm inequalities.", "",
             "| graph | certified bound (N m) | simulated peak (N m) | certified attitude bound q_max |", "|---|---|---|---|"]
    for gname in graphs:
        g = make_graph(gname)
        tb = peak_torque_bound(g, point, J, r0, w0)
        rng = np.random.default_rng(2016)
        q = rng.normal(size=(g.n, 3))
        q *= float(Fraction(r0)) / np.linalg.norm(q, axis=1, keepdims=True)
        w = rng.normal(size=(g.n, 3))
        w *= float(Fraction(w0)) / np.linalg.norm(w, axis=1, keepdims=True)
        att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
        gains = [float(Fraction(x)) for x in point]
        t, qs, ws = simulate_mismatch(g, gains, np.array([J] * g.n), np.array([J] * g.n), att, w,
                                      tf=40.0, step=0.02)
        lap = g.laplacian.astype(float)
        peak = 0.0
        for k in range(len(t)):
            qv, q0 = qs[k, :, :3], qs[k, :, 3:4]
            qd = 0.5 * (q0 * ws[k] + np.cross(qv, ws[k]))
            s = lap @ qv
            for i in range(g.n):
                a = -gains[0] * qd[i] - gains[1] * s[i]
                peak = max(peak, float(np.linalg.norm(controller_torque(qv[i], qd[i], J, a))))
        lines.append(f"| {g.name} | {tb.peak:.4g} | {peak:.3g} | {tb.q_max:.3g} |")
    lines.append("")
    return lines
