"""Communication delay (issue 15, item 3): exact per-mode delay margins from the
characteristic quasi-polynomial, and a fixed-step simulator of the delayed loop.

Two standard models of neighbour data arriving ``tau`` seconds late:

``processing``
    both terms of ``s_i`` are delayed, ``s_i(t - tau) = sum_j (q_i - q_j)(t - tau)``
    (the spacecraft processes the relative measurement ``tau`` late); the loop
    decouples per Laplacian mode for *any* graph.  The delay margin depends on
    the topology through ``lambda_max`` (the "most exigent eigenvalue" of
    second-order consensus, cf. Cepeda-Gomez & Olgac 2011).
``transmission``
    own state current, neighbours' past: ``s_i = m_i q_i(t) - sum_j q_j(t - tau)``;
    it decouples per mode only when ``D`` and ``A`` commute, i.e. for regular
    graphs (checked; otherwise the sufficient Lyapunov-Krasovskii certificate of
    :mod:`formsync_design.analysis.lk` gives a certified lower bound, ``method``
    ``"lyapunov-krasovskii"``).  Atay (2013,
    *SIAM J. Control Optim.* / "The consensus problem in networks with
    transmission delays", Phil. Trans. R. Soc. A 371) shows consensus can then be
    delay-independent; here: when the magnitude condition has no crossing
    frequency.

Per mode ``k`` the derived loop (``c_qd``, ``c_s`` from
:func:`~formsync_design.derive.closed_loop.derive_closed_loop`, damping on the
spacecraft's own rate, undelayed) has the characteristic quasi-polynomial
``P_0(s) + P_1(s) e^{-s tau}``.  It is retarded (``deg P_1 < deg P_0``) and
Hurwitz at ``tau = 0`` (checked), so by continuity of the roots in ``tau``
(Gu, Kharitonov & Chen 2003, Sec. 1.3) it stays stable until the smallest
``tau`` at which a root reaches the imaginary axis: ``s = i w`` with
``|P_0(i w)| = |P_1(i w)|`` (a polynomial in ``w^2``, roots by numpy) and
``e^{-i w tau} = -P_0(i w) / P_1(i w)``.  No crossing frequency: stable for every
delay.  The margin is computed in floating point (a well-conditioned root of a
low-degree polynomial) and reported rounded down by a relative ``1e-9``; the
eigenvalue enclosure's upper and lower ends are both evaluated.  Scope: the
nominal linear loop (switching term and disturbance excluded).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from formsync_design.analysis.modes import mode_model
from formsync_design.analysis.results import jsonify
from formsync_design.analysis.spectrum import laplacian_spectrum
from formsync_design.errors import InputError
from formsync_design.graphs import make_graph

__all__ = ["DelayModel", "DelayMargin", "delay_margin", "mode_quasi_polynomial", "coefficient_quasi_polynomial",
           "coefficient_delay_margin", "crossing_delays", "delay_section",
           "simulate_delayed_loop", "simulate_dde"]


class DelayModel(StrEnum):
    """Which neighbour data is late."""

    PROCESSING = "processing"
    TRANSMISSION = "transmission"


@dataclass(frozen=True)
class DelayMargin:
    """Certified delay margin of a gain point (``inf``: delay-independent)."""

    graph: str
    model: DelayModel
    gains: tuple[float, ...]
    margin: float
    critical_lambda: float | None
    crossing_frequency: float | None
    method: str = "quasi-polynomial"

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"graph": self.graph, "model": str(self.model), "gains": list(self.gains),
                        "margin_s": self.margin, "critical_lambda": self.critical_lambda,
                        "crossing_frequency": self.crossing_frequency, "method": self.method})


def mode_quasi_polynomial(model: str, lam: float, gains: Any, degree: int | None = None,
                          spec: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """``(P_0, P_1)`` coefficient arrays (highest power first) of one mode's quasi-polynomial,
    at a gain point of the design's controller gains.

    ``degree`` is the (regular) graph's degree, needed for ``transmission``.

    >>> p0, p1 = mode_quasi_polynomial("processing", 2.0, (1.6, 0.4, 0.3))
    >>> p0.tolist(), p1.tolist()
    ([1.0, 1.6, 0.0], [0.8])
    >>> [x.tolist() for x in mode_quasi_polynomial("processing", 2.0, (0.4, 1.6), spec="pd_consensus")]
    [[1.0, 1.6, 0.0], [0.8]]
    """
    cqd, cs = (float(x) for x in mode_model(spec).coefficients(gains))
    return coefficient_quasi_polynomial(model, lam, cqd, cs, degree)


def coefficient_quasi_polynomial(model: str, lam: float, cqd: float, cs: float,
                                 degree: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`mode_quasi_polynomial` from the closed-loop coefficients ``c_qd``, ``c_s``."""
    m = DelayModel(str(model))
    # x'' = cqd x' + cs * (own part) x(t) + cs * (delayed part) x(t - tau)
    if m is DelayModel.PROCESSING:
        own, late = 0.0, lam
    else:
        if degree is None:
            raise InputError("expected the graph degree for the transmission model, received none")
        own, late = float(degree), lam - float(degree)
    p0 = np.array([1.0, -cqd, -cs * own])
    p1 = np.array([-cs * late])
    return p0, p1


def crossing_delays(p0: np.ndarray, p1: np.ndarray) -> list[tuple[float, float]]:
    """``(w, tau)`` of the first crossing at each crossing frequency ``w > 0``.

    >>> [(round(w, 6), round(t, 6)) for w, t in crossing_delays(np.array([1.0, 1.0]), np.array([2.0]))]
    [(1.732051, 1.2092)]
    """
    # |P0(iw)|^2 - |P1(iw)|^2 as a polynomial in w (real coefficients)
    w = np.polynomial.Polynomial([0, 1])

    def at_iw(p: np.ndarray) -> tuple[Any, Any]:
        re = np.polynomial.Polynomial([0.0])
        im = np.polynomial.Polynomial([0.0])
        deg = len(p) - 1
        for k, c in enumerate(p):
            pw = deg - k
            term = c * w**pw
            r = pw % 4
            if r == 0:
                re = re + term
            elif r == 1:
                im = im + term
            elif r == 2:
                re = re - term
            else:
                im = im - term
        return re, im

    r0, i0 = at_iw(p0)
    r1, i1 = at_iw(p1)
    mag = r0 * r0 + i0 * i0 - r1 * r1 - i1 * i1
    out = []
    for root in mag.roots():
        if abs(root.imag) > 1e-9 * max(1.0, abs(root)) or root.real <= 1e-12:
            continue
        om = float(root.real)
        z0 = complex(np.polyval(p0, 1j * om))
        z1 = complex(np.polyval(p1, 1j * om))
        if abs(z1) == 0:
            continue
        phase = cmath.phase(-z0 / z1)  # e^{-i w tau} = -P0/P1
        tau = ((-phase) % (2 * math.pi)) / om
        out.append((om, tau))
    return sorted(out)


def _hurwitz(p: np.ndarray) -> bool:
    return bool(np.all(np.roots(p).real < 0))


def delay_margin(graph: Any, gains: Any, model: str = "processing", *, spec: Any = None) -> DelayMargin:
    """Certified delay margin of the nominal loop at a gain point of the design's controller
    gains (minimum over modes).

    Examples
    --------
    >>> dm = delay_margin("ring:8", (1.6, 0.4, 0.3))
    >>> round(dm.margin, 4), dm.critical_lambda
    (1.2195, 4.0)
    >>> delay_margin("ring:8", (1.6, 0.4, 0.3), "transmission").margin
    inf
    >>> round(delay_margin("ring:8", (0.4, 1.6), spec="pd_consensus").margin, 4)   # the same loop
    1.2195
    """
    g = make_graph(graph)
    if str(model) not in {d.value for d in DelayModel}:
        raise InputError(f"expected a delay model processing|transmission, received {model}")
    m = DelayModel(str(model))
    mm = mode_model(spec)  # validates that the specification decouples per mode
    cqd_f, cs_f = mm.coefficients(gains)
    gp = tuple(float(x) for x in mm.subs(gains).values())
    if m is DelayModel.TRANSMISSION and len(set(g.degrees)) != 1:
        # no per-mode decoupling: sufficient Lyapunov-Krasovskii certificate (analysis.lk)
        from formsync_design.analysis.lk import lk_delay_margin

        cert = lk_delay_margin(g, gains, "transmission", spec=spec)
        return DelayMargin(g.name, m, gp, cert.margin, None, None, "lyapunov-krasovskii")
    margin, lam_c, om_c = coefficient_delay_margin(g, float(cqd_f), float(cs_f), m)
    return DelayMargin(g.name, m, gp, margin, lam_c, om_c)


def coefficient_delay_margin(graph: Any, cqd: float, cs: float,
                             model: str = "processing") -> tuple[float, float | None, float | None]:
    """``(margin, critical lambda, crossing frequency)`` of the loop ``q'' = c_qd q' + c_s s``
    with ``s`` delayed per ``model`` (exact per mode; the transmission model needs a regular
    graph).  ``0`` when the loop is not stable without delay.

    >>> round(coefficient_delay_margin("ring:8", -1.6, -0.4)[0], 4)
    1.2195
    """
    g = make_graph(graph)
    m = DelayModel(str(model))
    deg = None
    if m is DelayModel.TRANSMISSION:
        if len(set(g.degrees)) != 1:
            raise InputError(f"expected a regular graph for the exact transmission-delay margin, received {g.name}")
        deg = g.degrees[0]
    best, lam_c, om_c = math.inf, None, None
    for c in laplacian_spectrum(g).clusters:
        for lam in {float(c.lo), float(c.hi)}:
            p0, p1 = coefficient_quasi_polynomial(m, lam, cqd, cs, deg)
            full = p0.copy()
            full[-len(p1):] += p1
            if not _hurwitz(full):
                return 0.0, lam, None
            for om, tau in crossing_delays(p0, p1):
                if tau < best:
                    best, lam_c, om_c = tau, lam, om
    margin = best * (1 - 1e-9) if math.isfinite(best) else math.inf
    return margin, lam_c, om_c


def simulate_dde(f: Any, history: Any, tau: float, h: float, tf: float, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fixed-step RK4 for ``x' = f(x(t), x(t - tau))`` with a constant pre-history.

    ``tau`` must be a multiple of ``h``; the delayed state at the half step is the
    cubic Hermite interpolant of the stored grid values and derivatives
    (4th-order accurate on smooth pieces).  Returns ``(t, x)``.

    >>> t, x = simulate_dde(lambda x, xd: -xd, None, 1.0, 0.01, 2.0, np.array([1.0]))
    >>> bool(abs(x[-1, 0] - (1 - 2.0 + 0.5)) < 1e-8)     # x = 1 - t + (t-1)^2/2 on [1, 2]
    True
    """
    m = round(tau / h)
    if abs(m * h - tau) > 1e-9 * max(tau, 1.0):
        raise InputError(f"expected a delay that is a multiple of the step {h:g}, received {tau:g}")
    n = round(tf / h)
    x = np.zeros((n + 1, len(x0)))
    dx = np.zeros_like(x)
    x[0] = x0
    hist0 = np.asarray(x0 if history is None else history, dtype=float)

    def delayed(k: int, frac: float) -> np.ndarray:
        """State at ``t_k + frac h - tau`` = grid index ``k - m + frac``."""
        j = k - m
        if j < 0:
            return hist0
        if frac == 0:
            return x[j]
        a, b = x[j], x[j + 1]
        da, db = dx[j] * h, dx[j + 1] * h
        s = frac
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        return h00 * a + h10 * da + h01 * b + h11 * db

    for k in range(n):
        dx[k] = f(x[k], delayed(k, 0.0))
        xdh = delayed(k, 0.5)
        xd1 = delayed(k + 1, 0.0)
        k1 = dx[k]
        k2 = f(x[k] + h / 2 * k1, xdh)
        k3 = f(x[k] + h / 2 * k2, xdh)
        k4 = f(x[k] + h * k3, xd1)
        x[k + 1] = x[k] + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    dx[n] = f(x[n], delayed(n, 0.0))
    return np.arange(n + 1) * h, x


def simulate_delayed_loop(graph: Any, gains: Any, tau: float, model: str = "processing", *,
                          tf: float = 60.0, h: float = 0.01, seed: int = 0,
                          spec: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Simulate the delayed nominal linear loop of the whole graph (one axis), at a gain point
    of the design's controller gains.

    Returns ``(t, d)`` with ``d`` the norm of the disagreement of ``(q, q')``.
    Initial state: seeded random disagreement, constant pre-history.
    """
    g = make_graph(graph)
    cqd, cs = (float(x) for x in mode_model(spec).coefficients(gains))
    lap = g.laplacian.astype(float)
    deg = np.diag(lap)
    adj = np.diag(deg) - lap
    n = g.n
    m = DelayModel(str(model))

    def f(x: np.ndarray, xd: np.ndarray) -> np.ndarray:
        q, w = x[:n], x[n:]
        qd = xd[:n]
        s = lap @ qd if m is DelayModel.PROCESSING else deg * q - adj @ qd
        return np.concatenate([w, cqd * w + cs * s])

    rng = np.random.default_rng(seed)
    x0 = np.concatenate([rng.normal(size=n), np.zeros(n)])
    x0[:n] -= x0[:n].mean()
    t, x = simulate_dde(f, x0, tau, h, tf, x0)
    proj = np.eye(n) - np.ones((n, n)) / n
    d = np.sqrt(((x[:, :n] @ proj) ** 2).sum(axis=1) + ((x[:, n:] @ proj) ** 2).sum(axis=1))
    return t, d




def delay_section(graphs: tuple[str, ...] = ("ring:8", "star:8", "complete:8"),
                  point: tuple[float, float, float] = (1.6, 0.4, 0.3)) -> list[str]:
    """Markdown lines: delay margins of both delay models at a gain point, per graph."""
    lines = ["## Communication delay margins (item 3)", "",
             f"Gains (K_o, K_q, beta) = {point}; nominal linear loop; exact per-mode crossing analysis "
             "of the characteristic quasi-polynomial (`inf`: stable for every delay; transmission "
             "delay decouples per mode only on regular graphs).", "",
             "| graph | processing delay margin | critical lambda | transmission delay margin |",
             "|---|---|---|---|"]
    for gname in graphs:
        g = make_graph(gname)
        pm = delay_margin(g, point, "processing")
        if len(set(g.degrees)) == 1:
            tm = delay_margin(g, point, "transmission")
            ts = "inf (delay-independent)" if math.isinf(tm.margin) else f"{tm.margin:.4g} s"
        else:
            ts = "not decoupled (irregular graph)"
        lam = "-" if pm.critical_lambda is None else f"{pm.critical_lambda:g}"
        lines.append(f"| {g.name} | {pm.margin:.4g} s | {lam} | {ts} |")
    lines.append("")
    return lines
