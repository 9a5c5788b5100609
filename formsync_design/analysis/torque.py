"""Certified peak-torque bound from a set of initial attitudes and rates, for a gain point
or a whole gain cell, any design (issue 15, item 2).

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

State bounds.  The nominal loop (``K_v = 0``, no disturbance, exact model cancellation, as
in the paper's proof) is linear in ``q`` and depends on the gains only through
``d = -c_qd`` and ``k = -c_s``: over a gain cell they lie in exact enclosures
``[d_lo, d_hi]``, ``[k_lo, k_hi]`` (:func:`~.modecheck.coefficient_ranges`; a point is a
degenerate cell), required positive.  Per Laplacian mode ``(x, y) = (u_k^T q, u_k^T q')``
(``b = k lambda``) two quadratic functions never increase for any ``d, b >= 0``: the mode's
energy ``b x^2 + y^2`` (derivative ``-2 d y^2``) and the energy of the derivative system
``b y^2 + a^2`` (``(y, a)`` obeys the same equation, ``a = y' = -(b x + d y)``).  Hence, for
every ``t >= 0`` and every ``theta > 0``,

    ``x(t)^2 <= x0^2 + y0^2 / b``,  ``y(t)^2 <= b x0^2 + y0^2``,
    ``a(t)^2 <= b y0^2 + (b x0 + d y0)^2 <= (1 + theta) b^2 x0^2 + (b + (1 + 1/theta) d^2) y0^2``,

each ``alpha_k x0^2 + gamma_k y0^2`` with ``alpha_k, gamma_k`` sums of positive terms
``c k^i d^j lambda^m``, bounded over the cell and the eigenvalue enclosure term by term
(each monotone in each variable).  A spacecraft's output ``o_i = sum_k u_k(i) o_k`` obeys
``|o_i|^2 <= (sum_k u_k(i)^2 w_k) sum_k o_k^2 / w_k`` (Cauchy-Schwarz) with weights
``w_k = lambda_k^a`` (``a = 0, 1, 2``: ``sum_k u_k(i)^2 w_k = 1 - 1/N``, the degree ``m_i``,
``m_i^2 + m_i``), and ``sum_k h_k x_k0^2 <= max_k (h_k / lambda_k^c) X_c`` with
``X_0 = N r0^2`` and ``X_1 = min(4 |E|, lambda_max N) r0^2 >= q^T L q`` (likewise ``Y_c`` with
``v0 = w0 / 2 >= |q_i'(0)|``).  Every combination of ``a``, ``c`` and ``theta`` (a small grid)
is a valid bound; the smallest is kept: this is the search over the Lyapunov weighting.  By
superposition (the loop is linear) the responses to the initial attitudes (``y0 = 0``:
``a^2 <= b^2 x0^2``) and to the initial rates (``x0 = 0``: ``a^2 <= (b + d^2) y0^2``) may also be
bounded separately, each with its own weighting, and added; the smaller bound is kept.  From
``(0, y0)`` the mode's attitude also obeys ``|x(t)| <= |y0| / d``: ``sigma = d x + y`` has
``sigma' = -b x``, so ``sigma^2 + b x^2`` never increases, ``|sigma| <= |y0|``, and
``x' = -d x + sigma`` (tight for overdamped modes, where ``y0^2 / b`` is not).
The consensus mode obeys ``q_bar'' = c_qd q_bar'``: ``|q_bar'(t)| <= v0``,
``|q_bar(t)| <= r0 + v0 / d_lo`` (or through ``(1 + theta) x0^2 + (1 + 1/theta) y0^2 / d^2``
together with the other modes).  Everything up to the final square roots is exact rational
arithmetic; the roots and the torque's float products are rounded up by a relative
``1e-12``.  A bound ``|q_i(t)| < 1`` is required (else ``q0`` could reach 0; undecided).

Refutation of a torque limit (:func:`torque_limit_check`): at the vertex of the cell with
the largest ``|c_s|``, the initial state with ``q_h = r0 e``, every other ``q_j = -r0 e``
(``e`` the top eigenvector of ``J_h``), ``omega = 0`` for a spacecraft ``h`` of largest
``m_h lambda_max(J_h)`` is in the set, and already at ``t = 0`` it needs
``|u_h| = 4 |c_s| m_h r0 lambda_max(J_h) / sqrt(1 - r0^2)``: above the limit, no bound can
certify it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.analysis.modecheck import coefficient_ranges, split_box
from formsync_design.analysis.modes import mode_model
from formsync_design.analysis.results import Verdict, jsonify
from formsync_design.analysis.spectrum import LaplacianSpectrum, laplacian_spectrum
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, parse_number
from formsync_design.graphs import make_graph

__all__ = ["TorqueBound", "TorqueCheck", "peak_torque_bound", "torque_limit_check", "controller_torque",
           "initial_torque_witness", "torque_section", "THETAS"]

_UP = 1 + 1e-12
#: The Young-inequality weights tried (``(b x0 + d y0)^2 <= (1 + theta) b^2 x0^2 + (1 + 1/theta) d^2 y0^2``).
THETAS = (Fraction(1, 64), Fraction(1, 16), Fraction(1, 4), Fraction(1), Fraction(4))

# per-mode bounds o_k(t)^2 <= alpha x0^2 + gamma y0^2: terms (coefficient, k-exp, d-exp, lambda-exp)
Terms = list[tuple[Fraction, int, int, int]]


def _mode_terms(theta: Fraction) -> dict[str, tuple[Terms, Terms]]:
    one = Fraction(1)
    return {
        "x": ([(one, 0, 0, 0)], [(one, -1, 0, -1)]),
        "y": ([(one, 1, 0, 1)], [(one, 0, 0, 0)]),
        "a": ([(1 + theta, 2, 0, 2)], [(one, 1, 0, 1), (1 + 1 / theta, 0, 2, 0)]),
    }


def _sup(terms: Terms, shift: int, k: tuple[Fraction, Fraction], d: tuple[Fraction, Fraction],
         lam: tuple[Fraction, Fraction]) -> Fraction:
    """Exact sup over the box of ``sum c k^i d^j lambda^(m - shift)`` (positive ``c``, positive box)."""
    out = Fraction(0)
    for c, i, j, m in terms:
        m -= shift
        out += (c * (k[1] if i > 0 else k[0]) ** i * (d[1] if j > 0 else d[0]) ** j
                * (lam[1] if m > 0 else lam[0]) ** m)
    return out


@dataclass(frozen=True)
class TorqueBound:
    """Certified ``max_t |u_i(t)|_2`` per spacecraft from the initial set, for every gain of
    ``box`` (``inf``: none)."""

    status: Verdict
    graph: str
    box: GainBox
    r0: Fraction
    w0: Fraction
    bound: tuple[float, ...]
    q_max: float
    rate_max: float
    acc_max: float
    reason: str

    @property
    def peak(self) -> float:
        """The largest per-spacecraft bound (N m)."""
        return max(self.bound) if self.bound else math.inf

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"status": str(self.status), "graph": self.graph, "box": self.box.to_dict(),
                        "r0": self.r0, "w0_rad_s": self.w0, "bound_N_m": list(self.bound), "peak_N_m": self.peak,
                        "q_max": self.q_max, "qdot_max": self.rate_max, "acc_max": self.acc_max,
                        "reason": self.reason})


def _inertias(inertias: Any, n: int) -> list[np.ndarray]:
    J = np.asarray(inertias, dtype=float)
    Js = [J] * n if J.shape == (3, 3) else list(J)
    if len(Js) != n or any(np.shape(x) != (3, 3) for x in Js):
        raise InputError(f"expected one 3x3 inertia or {n} of them, received shape {J.shape}")
    for i, x in enumerate(Js):
        if not np.all(np.isfinite(x)) or np.linalg.eigvalsh((x + x.T) / 2)[0] <= 0:
            raise InputError(f"expected a symmetric positive definite inertia for spacecraft {i + 1}, "
                             f"received {np.asarray(x).tolist()}")
    return Js


def _radii(r0: Any, w0: Any) -> tuple[Fraction, Fraction]:
    r0f, w0f = Fraction(parse_number(r0, "r0")), Fraction(parse_number(w0, "w0"))
    if not (0 <= r0f < 1) or w0f < 0:
        raise InputError(f"expected 0 <= r0 < 1 and w0 >= 0, received r0={float(r0f):g}, w0={float(w0f):g}")
    return r0f, w0f


def _box(mm: Any, gains: Any) -> GainBox:
    if isinstance(gains, (GainBox, dict)):
        return split_box(mm, gains)[0]
    return split_box(mm, dict(zip(mm.names, gains)))[0]


_SPLIT: dict[str, tuple[list[Terms], list[Terms]]] = {
    # superposition: the response to (x0, 0) and to (0, y0) separately (a(0) = -b x0, resp. -d y0);
    # each a list of alternative per-mode bounds (the smallest is taken per eigenvalue cluster):
    # from (0, y0) also |x(t)| <= sup |sigma| / d with sigma = d x + y, sigma' = -b x, sigma^2 <= y0^2
    "x": ([[(Fraction(1), 0, 0, 0)]], [[(Fraction(1), -1, 0, -1)], [(Fraction(1), 0, -2, 0)]]),
    "y": ([[(Fraction(1), 1, 0, 1)]], [[(Fraction(1), 0, 0, 0)]]),
    "a": ([[(Fraction(1), 2, 0, 2)]], [[(Fraction(1), 1, 0, 1), (Fraction(1), 0, 2, 0)]]),
}


def _best(alts: list[Terms], deg: int, n: int, clusters: Any, k: Any, d: Any,
          sums: tuple[Fraction, Fraction]) -> Fraction:
    """Smallest ``S_a(i) max_k h_k / lambda_k^(a + c) * sums[c]`` over the weightings ``a``, ``c``
    (``h_k``: per cluster the smallest of the alternative bounds)."""
    svals = (1 - Fraction(1, n), Fraction(deg), Fraction(deg * deg + deg))
    return min(svals[a] * max(min(_sup(t, a + c, k, d, (cl.lo, cl.hi)) for t in alts) for cl in clusters)
               * sums[c] for a in (0, 1, 2) for c in (0, 1))


def _combined(which: str, deg: int, n: int, clusters: Any, k: Any, d: Any, xs: tuple[Fraction, Fraction],
              ys: tuple[Fraction, Fraction]) -> float:
    """Bound of ``|sum_k u_k(i) o_k(t)|`` (rounded up) over the weightings (module docstring): the
    joint bound ``sqrt(S (sum alpha x0^2 + sum gamma y0^2) / w)``, or by superposition the sum of
    the bounds of the responses to the initial attitudes and to the initial rates, each with its
    own weighting; the smaller."""
    best: Fraction | None = None
    for theta in (THETAS if which == "a" else THETAS[:1]):
        al, ga = _mode_terms(theta)[which]
        svals = (1 - Fraction(1, n), Fraction(deg), Fraction(deg * deg + deg))
        for a in (0, 1, 2):
            for cx in (0, 1):
                for cy in (0, 1):
                    hx = max(_sup(al, a + cx, k, d, (c.lo, c.hi)) for c in clusters)
                    hy = max(_sup(ga, a + cy, k, d, (c.lo, c.hi)) for c in clusters)
                    val = svals[a] * (hx * xs[cx] + hy * ys[cy])
                    if best is None or val < best:
                        best = val
    assert best is not None
    ax, gy = _SPLIT[which]
    split = (_sqrt_up(_best(ax, deg, n, clusters, k, d, xs)) + _sqrt_up(_best(gy, deg, n, clusters, k, d, ys))) * _UP
    return min(_sqrt_up(best), split)


def _sqrt_up(x: Fraction) -> float:
    return math.sqrt(float(x)) * _UP


def peak_torque_bound(graph: Any, gains: Any, inertias: Any, r0: Any, w0: Any, *, spec: Any = None,
                      spectrum: LaplacianSpectrum | None = None) -> TorqueBound:
    """Certified bound on ``|u_i(t)|_2`` for all ``t >= 0``, every gain of ``gains`` (a point in
    the design's gain order, or a box of its gains) and every initial ``|q_i(0)| <= r0``
    (quaternion vector part), ``|omega_i(0)| <= w0`` (rad/s); nominal loop (module docstring).

    Examples
    --------
    >>> J = np.diag([50.0, 55.0, 60.0])
    >>> tb = peak_torque_bound("ring:4", (1.6, 0.4, 0.3), J, 0.1, 0.01)
    >>> tb.status.value, 0 < tb.peak < 100, tb.q_max < 1
    ('certified', True, True)
    >>> cell = peak_torque_bound("ring:4", {"K_o": (1.5, 1.7), "K_q": (0.35, 0.45), "beta": (0.2, 0.3)}, J, 0.1, 0.01)
    >>> cell.peak >= tb.peak
    True
    >>> peak_torque_bound("ring:4", (0.4, 1.6), J, 0.1, 0.01, spec="pd_consensus").status.value
    'certified'
    """
    g = make_graph(graph)
    mm = mode_model(spec)
    box = _box(mm, gains)
    r0f, w0f = _radii(r0, w0)
    Js = _inertias(inertias, g.n)
    n, name = g.n, g.name
    nope = TorqueBound(Verdict.UNDECIDED, name, box, r0f, w0f, (math.inf,) * n, math.inf, math.inf,
                       math.inf, "")
    d, k = coefficient_ranges(mm, box)
    if d[0] <= 0 or k[0] <= 0:
        return replace(nope, reason="the nominal loop needs c_qd < 0 and c_s < 0 on the whole cell (d = -c_qd "
                       f"in [{float(d[0]):g}, {float(d[1]):g}], k = -c_s in [{float(k[0]):g}, {float(k[1]):g}])")
    sp_ = spectrum if spectrum is not None else laplacian_spectrum(g)
    clusters = sp_.clusters
    v0 = w0f / 2
    energy_cap = min(Fraction(4 * len(g.edges)), sp_.lambda_max_hi * n)
    xs = (n * r0f**2, energy_cap * r0f**2)
    ys = (n * v0**2, energy_cap * v0**2)
    degs = sorted(set(g.degrees))
    # attitude: through the mean, or all modes at once (the consensus mode with Young's inequality)
    lam2 = sp_.lambda_2_lo
    full_q = min((1 + t) * n * r0f**2 + max((1 + 1 / t) / d[0] ** 2, 1 / (k[0] * lam2)) * n * v0**2
                 for t in THETAS)
    # by superposition: every mode (the consensus one too) from (x0, 0) keeps |x| <= |x0|, from
    # (0, y0) keeps |x| <= |y0| / d (the sigma bound above)
    split_q = (_sqrt_up(n * r0f**2) + _sqrt_up(n * v0**2 / d[0] ** 2)) * _UP
    e_dis = {m: _combined("x", m, n, clusters, k, d, xs, ys) for m in degs}
    y_dis = {m: _combined("y", m, n, clusters, k, d, xs, ys) for m in degs}
    a_dis = {m: _combined("a", m, n, clusters, k, d, xs, ys) for m in degs}
    q_i = {m: min(float(r0f + v0 / d[0]) * _UP + e_dis[m], _sqrt_up(full_q), split_q) * _UP for m in degs}
    full_qd = k[1] * xs[1] + n * v0**2
    qd_i = {m: min(float(v0) * _UP + y_dis[m], _sqrt_up(full_qd)) * _UP for m in degs}
    acc_i = {m: (float(d[1] * v0) * _UP + a_dis[m]) * _UP for m in degs}
    r_max = max(q_i.values())
    if r_max >= 1:
        return replace(nope, q_max=r_max, reason=f"the attitude bound |q_i(t)| <= {r_max:.4g} does not exclude "
                       "q0 = 0 (shrink the initial set)")
    out = []
    for i, Ji in enumerate(Js):
        m = g.degrees[i]
        r, qd, acc = q_i[m], qd_i[m], acc_i[m]
        q0 = math.sqrt(1 - r**2) / _UP
        om = 2 * qd / q0
        qdot_term = 2 * qd**2 * (1 + 3 * r / q0 + r**3 / q0**3)
        ev = np.linalg.eigvalsh((Ji + Ji.T) / 2)
        jmax, spread = float(ev[-1]) * _UP, float(ev[-1] - ev[0]) / 2 * _UP
        out.append((jmax * (2 / q0 * acc + qdot_term) + spread * om**2) * _UP**3)
    what = "every gain of the cell" if not all(x.is_point for x in box.ranges) else "the gain point"
    return TorqueBound(Verdict.CERTIFIED, name, box, r0f, w0f, tuple(out), r_max, max(qd_i.values()),
                       max(acc_i.values()),
                       f"per-mode energies of the nominal loop and of its derivative never increase for {what} "
                       "(d = -c_qd, k = -c_s enclosed exactly) and bound q, q' and the acceleration; "
                       "u = J (Q a + Q' q') + omega x J omega bounds the torque")


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


def initial_torque_witness(graph: Any, gains: Any, inertias: Any, r0: Any, *, spec: Any = None) -> dict[str, Any]:
    """A gain of the cell and an initial state of the set whose torque at ``t = 0`` is as large
    as this construction allows (module docstring): a lower bound of the peak torque.

    >>> w = initial_torque_witness("star:4", (1.6, 0.4, 0.3), np.diag([50.0, 55.0, 60.0]), 0.1)
    >>> w["spacecraft"], round(w["torque_N_m"], 4)     # 4 * 0.4 * 3 * 0.1 * 60 / sqrt(0.99)
    (1, 28.9451)
    """
    g = make_graph(graph)
    mm = mode_model(spec)
    box = _box(mm, gains)
    r0f = _radii(r0, 0)[0]
    Js = _inertias(inertias, g.n)
    best_v, best_cs = None, Fraction(0)
    for v in box.vertices():
        cs = mm.coefficients(v)[1]
        if best_v is None or abs(cs) > abs(best_cs):
            best_v, best_cs = v, cs
    assert best_v is not None
    h = max(range(g.n), key=lambda i: (g.degrees[i] * float(np.linalg.eigvalsh(Js[i])[-1]), -i))
    w, vecs = np.linalg.eigh((Js[h] + Js[h].T) / 2)
    e = vecs[:, -1]
    r = float(r0f)
    q = np.array([-r * e] * g.n)
    q[h] = r * e
    s = g.laplacian.astype(float) @ q
    u = controller_torque(q[h], np.zeros(3), Js[h], float(best_cs) * s[h])
    return {"gains": dict(zip(mm.names, best_v)), "spacecraft": h + 1, "q_h": r0f, "q_others": -r0f,
            "axis": e.tolist(), "omega": 0, "torque_N_m": float(np.linalg.norm(u))}


@dataclass(frozen=True)
class TorqueCheck:
    """A torque limit decided over a gain cell: certified (bound within the limit), refuted
    (an initial state of the set needs more at ``t = 0``) or undecided."""

    status: Verdict
    limit: float
    bound: TorqueBound
    witness: dict[str, Any] | None
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"status": str(self.status), "limit_N_m": self.limit, "bound": self.bound.to_dict(),
                        "witness": self.witness, "reason": self.reason})


def torque_limit_check(graph: Any, gains: Any, limit: float, inertias: Any, r0: Any, w0: Any, *,
                       spec: Any = None, spectrum: LaplacianSpectrum | None = None) -> TorqueCheck:
    """Decide ``max_t |u_i(t)| <= limit`` from the initial set for every gain of a cell or point.

    >>> J = np.diag([50.0, 55.0, 60.0])
    >>> [torque_limit_check("ring:6", (1.6, 0.4, 0.3), u, J, 0.1, 0.01).status.value for u in (100, 30, 10)]
    ['certified', 'undecided', 'refuted']
    """
    tb = peak_torque_bound(graph, gains, inertias, r0, w0, spec=spec, spectrum=spectrum)
    where = f"from every |q_i(0)| <= {float(tb.r0):g}, |omega_i(0)| <= {float(tb.w0):g} rad/s"
    if tb.status is Verdict.CERTIFIED and tb.peak <= limit:
        return TorqueCheck(Verdict.CERTIFIED, limit, tb, None,
                           f"|u_i(t)| <= {tb.peak:.6g} N m for all t {where} (nominal loop), within the limit "
                           f"{limit:g} N m")
    w = initial_torque_witness(graph, gains, inertias, r0, spec=spec)
    if w["torque_N_m"] > limit * (1 + 1e-9):
        pt = ", ".join(f"{k}={float(v):g}" for k, v in w["gains"].items())
        return TorqueCheck(Verdict.REFUTED, limit, tb, w,
                           f"at {pt}, spacecraft {w['spacecraft']} needs {w['torque_N_m']:.6g} N m already at "
                           f"t = 0 from an initial state of the set (q_{w['spacecraft']} = r0 e, the others "
                           f"-r0 e, omega = 0): above the limit {limit:g} N m")
    why = tb.reason if tb.status is not Verdict.CERTIFIED else (
        f"the certified bound {tb.peak:.6g} N m {where} is above the limit {limit:g} N m and the largest "
        f"initial torque found is {w['torque_N_m']:.6g} N m (the bound is conservative: undecided)")
    return TorqueCheck(Verdict.UNDECIDED, limit, tb, w, why)


def torque_section(graphs: tuple[str, ...] = ("ring:8", "star:8", "complete:8"),
                   point: tuple[str, str, str] = ("1.6", "0.4", "0.3"),
                   r0: str = "0.05", w0: str = "0.01") -> list[str]:
    """Markdown lines: certified peak-torque bounds (point and cell) and a simulated peak, per graph."""
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.formation import Formation, Gains, SimOptions
    from formsync_design.sim.simulator import simulate

    J = np.diag([50.0, 55.0, 60.0])
    cell = {"K_o": ("1.4", "1.8"), "K_q": ("0.3", "0.5"), "beta": ("0.2", "0.4")}
    lines = ["## Certified peak torque (item 2)", "",
             f"Gains (K_o, K_q, beta) = ({', '.join(point)}), J = diag(50, 55, 60) kg m^2, initial set "
             f"|q_i(0)| <= {r0}, |omega_i(0)| <= {w0} rad/s, nominal loop (K_v = 0, no disturbance).",
             "The bound holds for every trajectory from the set (`formsync certify --torque-limit U`); the",
             "cell bound for every gain of the cell K_o in [1.4, 1.8], K_q in [0.3, 0.5], beta in [0.2, 0.4]",
             "too (`formsync region --torque-limit U`). The simulated peak is the largest over 4 seeded",
             "trajectories from the set (every |q_i(0)| = r0, every |omega_i(0)| = w0, random directions, and",
             "the initial state of the refutation witness: a spacecraft of largest degree at r0 e, the others",
             "at -r0 e, at rest), simulated by `formsync simulate`'s RK4 kernel. The worst peak from the set",
             "lies between the simulated peak and the bound, so the bound is within the factor",
             "'bound / simulated' of it. Per mode the energy of the nominal loop and of its derivative bound",
             "q, q' and the acceleration; the remaining gap is Cauchy-Schwarz across modes and the norm",
             "inequalities of the torque.", "",
             "| graph | certified bound (N m) | cell bound (N m) | initial-torque witness (N m) | simulated peak (N m) "
             "| bound / simulated | q_max |",
             "|---|---|---|---|---|---|---|"]
    for gname in graphs:
        g = make_graph(gname)
        tb = peak_torque_bound(g, point, J, r0, w0)
        cb = peak_torque_bound(g, cell, J, r0, w0)
        wit = initial_torque_witness(g, point, J, r0)
        rng = np.random.default_rng(2016)
        gains = [float(Fraction(x)) for x in point]
        peak = 0.0
        for trial in range(4):
            if trial < 3:
                q = rng.normal(size=(g.n, 3))
                q *= float(Fraction(r0)) / np.linalg.norm(q, axis=1, keepdims=True)
                w = rng.normal(size=(g.n, 3))
                w *= float(Fraction(w0)) / np.linalg.norm(w, axis=1, keepdims=True)
            else:
                q = np.array([-float(Fraction(r0)) * np.array(wit["axis"])] * g.n)
                q[wit["spacecraft"] - 1] *= -1
                w = np.zeros((g.n, 3))
            att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
            f = Formation(g, np.array([J] * g.n), att, w, Gains(*gains, (0.0,) * g.n), no_disturbance(g.n))
            r = simulate(f, SimOptions(tf=40.0, compile=False))
            peak = max(peak, float(np.linalg.norm(r.u.reshape(len(r.t), g.n, 3), axis=2).max()))
        lines.append(f"| {g.name} | {tb.peak:.4g} | {cb.peak:.4g} | {wit['torque_N_m']:.4g} | {peak:.3g} | "
                     f"{tb.peak / peak:.2f} | {tb.q_max:.3g} |")
    lines.append("")
    return lines
