"""Disturbance torques ``u_d`` acting on each spacecraft (body frame, N m).

One parametric family covers every model the simulator offers.  Per
spacecraft ``i`` and body axis ``k``::

    u_d[i,k](t) = c[i,k] + a[i,k] * sin(w1[i,k] t + p1[i,k]) * sin(w2[i,k] t + p2[i,k])
                  + g * (gravity-gradient torque)[k]

The paper's test disturbance (section 3), ``u_d = u_mg + u_un``::

    |(u_mg)_k| = lambda_max(J_i) * 30 mu / R^3          (constant)
    u_un = (1/5) ((u_mg)_1 sin(t/5), (u_mg)_2 cos(t/10), (u_mg)_3 sin(t/10) cos(t/5))

is the member ``c = u_mg``, ``a = u_mg/5`` with
``(w1, p1, w2, p2) = (1/5, 0, 0, pi/2)``, ``(1/10, pi/2, 0, pi/2)``,
``(1/10, 0, 1/5, pi/2)`` on axes 1, 2, 3.  **Assumption (signs):** the paper
prints only ``|(u_mg)_k|``; the default takes every component positive
(``signs=(1, 1, 1)``), a coherent worst case for the common-mode drift.
Monte-Carlo runs may add random phases to the oscillating factors.

Gravity gradient (paper, ref. [17]): ``u_g = 3 mu / |R|^5 R^x J R`` with
``R`` the orbit position (Earth centre to spacecraft) in the body frame.
**Geometry assumption:** a circular orbit of radius ``R = R_earth +
altitude`` in the inertial x-y plane, ``R_I(t) = R (cos(n t + theta0),
sin(n t + theta0), 0)``, ``n = sqrt(mu/R^3)``, identical for all spacecraft
(formation separations are negligible against ``R``), rotated into the body
frame with the attitude quaternion (``q_bar`` maps body to inertial,
consistent with eq. (1): ``q_bar' = q_bar (x) (omega, 0) / 2``), i.e.
``R_B = C^T R_I``, ``C^T = (q0^2 - |q|^2) I + 2 q q^T - 2 q0 q^x``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from formsync_design.errors import InputError

__all__ = [
    "MU_EARTH",
    "R_EARTH",
    "DISTURBANCES",
    "Orbit",
    "DisturbanceModel",
    "paper_disturbance",
    "gravity_gradient_disturbance",
    "no_disturbance",
    "constant_disturbance",
    "harmonic_disturbance",
    "paper_umg_magnitude",
    "kernel_parameters",
    "disturbance_trig",
    "disturbance_torque",
]

#: Earth's gravitational parameter (m^3/s^2, EGM96/WGS-84).
MU_EARTH = 3.986004418e14
#: Earth's equatorial radius (m, WGS-84).
R_EARTH = 6378137.0
#: Disturbance kinds the CLI offers.
DISTURBANCES = ("paper", "gravity-gradient", "none")

_PAPER_FREQ = np.array(
    [[0.2, 0.0, 0.0, math.pi / 2], [0.1, math.pi / 2, 0.0, math.pi / 2], [0.1, 0.0, 0.2, math.pi / 2]]
)


@dataclass(frozen=True)
class Orbit:
    """A circular orbit (see module docstring for the geometry assumption).

    >>> o = Orbit(altitude=400e3)
    >>> round(o.radius / 1e3, 3), round(o.period / 60, 2)
    (6778.137, 92.56)
    """

    altitude: float = 400e3
    mu: float = MU_EARTH
    earth_radius: float = R_EARTH
    phase: float = 0.0

    def __post_init__(self) -> None:
        for name in ("altitude", "mu", "earth_radius", "phase"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                shown = f"{v:g}" if isinstance(v, (int, float)) else type(v).__name__
                raise InputError(f"expected a finite number for orbit {name}, received {shown}")
        if self.altitude < 0 or self.mu <= 0 or self.earth_radius <= 0:
            raise InputError(
                f"expected altitude >= 0, mu > 0, earth_radius > 0, received "
                f"{self.altitude}, {self.mu}, {self.earth_radius}"
            )

    @property
    def radius(self) -> float:
        """Orbit radius ``R`` (m)."""
        return self.earth_radius + self.altitude

    @property
    def mean_motion(self) -> float:
        """``n = sqrt(mu / R^3)`` (rad/s)."""
        return math.sqrt(self.mu / self.radius**3)

    @property
    def period(self) -> float:
        """Orbital period (s)."""
        return 2 * math.pi / self.mean_motion


@dataclass(frozen=True)
class DisturbanceModel:
    """Parameters of the disturbance family (module docstring).

    Attributes
    ----------
    kind : str
        A label (``paper``, ``gravity-gradient``, ``none``, ``constant``, ``harmonic``...).
    harmonic : numpy.ndarray
        Shape ``(N, 3, 6)``: ``(c, a, w1, p1, w2, p2)`` per spacecraft and axis.
    gravity_gradient : bool
        Add the gravity-gradient torque of ``orbit``.
    orbit : Orbit
    """

    kind: str
    harmonic: np.ndarray
    gravity_gradient: bool = False
    orbit: Orbit = field(default_factory=Orbit)

    def __post_init__(self) -> None:
        h = np.asarray(self.harmonic, dtype=float)
        if h.ndim != 3 or h.shape[1:] != (3, 6):
            raise InputError(f"expected harmonic parameters of shape (N, 3, 6), received {h.shape}")
        if not np.all(np.isfinite(h)):
            raise InputError("expected finite disturbance parameters, received NaN/inf")
        h.setflags(write=False)
        object.__setattr__(self, "harmonic", h)

    @property
    def n(self) -> int:
        return int(self.harmonic.shape[0])

    def bound(self, inertias: np.ndarray | None = None) -> np.ndarray:
        """Per-spacecraft bound ``ubar_i >= max_k sup_t |u_d[i,k](t)|`` (N m).

        The harmonic part contributes ``|c| + |a|``; the gravity-gradient part
        ``3 mu/R^3 (lambda_max - lambda_min)/2`` (the largest component of
        ``R^x J R / |R|^2`` over directions), which needs ``inertias``.
        """
        h = self.harmonic
        b = np.max(np.abs(h[:, :, 0]) + np.abs(h[:, :, 1]), axis=1)
        if self.gravity_gradient:
            if inertias is None:
                raise InputError("expected inertias to bound the gravity-gradient torque")
            ev = np.linalg.eigvalsh(np.asarray(inertias, dtype=float))
            b = b + 3 * self.orbit.mu / self.orbit.radius**3 * (ev[:, -1] - ev[:, 0]) / 2
        return b

    def with_phases(self, rng: np.random.Generator) -> DisturbanceModel:
        """A copy with uniform random phases added to every oscillating factor
        (factors with zero frequency are left alone, they scale the amplitude)."""
        h = np.array(self.harmonic)
        for col_w, col_p in ((2, 3), (4, 5)):
            osc = h[:, :, col_w] != 0
            h[:, :, col_p] += np.where(osc, rng.uniform(0, 2 * math.pi, size=osc.shape), 0.0)
        orbit = Orbit(
            self.orbit.altitude, self.orbit.mu, self.orbit.earth_radius, float(rng.uniform(0, 2 * math.pi))
        )
        return DisturbanceModel(self.kind, h, self.gravity_gradient, orbit)


def paper_umg_magnitude(inertia: np.ndarray, orbit: Orbit) -> float:
    """``lambda_max(J) * 30 mu / R^3`` (N m), the paper's ``|(u_mg)_k|``.

    >>> round(paper_umg_magnitude(np.diag([50.0, 55, 62]), Orbit()) * 1e3, 4)
    2.3808
    """
    return float(np.linalg.eigvalsh(np.asarray(inertia, dtype=float))[-1]) * 30 * orbit.mu / orbit.radius**3


def paper_disturbance(
    inertias: np.ndarray, orbit: Orbit | None = None, signs: tuple[float, float, float] = (1, 1, 1)
) -> DisturbanceModel:
    """The paper's ``u_mg + u_un`` for each inertia (module docstring).

    >>> d = paper_disturbance(np.array([np.diag([50.0, 55, 62])]))
    >>> d.harmonic.shape, round(float(d.bound()[0] / d.harmonic[0, 0, 0]), 6)
    ((1, 3, 6), 1.2)
    """
    orb = orbit if orbit is not None else Orbit()
    J = _inertias(inertias)
    sg = np.asarray(signs, dtype=float)
    if sg.shape != (3,) or not np.all(np.isin(sg, (-1.0, 1.0))):
        raise InputError(f"expected three signs +-1, received {sg.ravel().tolist()}")
    h = np.zeros((len(J), 3, 6))
    for i, Ji in enumerate(J):
        umg = paper_umg_magnitude(Ji, orb) * sg
        h[i, :, 0] = umg
        h[i, :, 1] = umg / 5
        h[i, :, 2:] = _PAPER_FREQ
    return DisturbanceModel("paper", h, False, orb)


def gravity_gradient_disturbance(n: int, orbit: Orbit | None = None) -> DisturbanceModel:
    """Gravity-gradient torque alone (module docstring for the geometry)."""
    return DisturbanceModel("gravity-gradient", np.zeros((n, 3, 6)), True, orbit or Orbit())


def no_disturbance(n: int) -> DisturbanceModel:
    """``u_d = 0``.

    >>> no_disturbance(2).bound().tolist()
    [0.0, 0.0]
    """
    return DisturbanceModel("none", np.zeros((n, 3, 6)), False)


def constant_disturbance(vectors: np.ndarray) -> DisturbanceModel:
    """User-supplied constant torques, shape ``(3,)`` (all spacecraft) or ``(N, 3)``."""
    v = np.atleast_2d(np.asarray(vectors, dtype=float))
    if v.shape[1] != 3:
        raise InputError(f"expected constant disturbance vectors of length 3, received shape {v.shape}")
    h = np.zeros((v.shape[0], 3, 6))
    h[:, :, 0] = v
    h[:, :, 3] = h[:, :, 5] = math.pi / 2  # unused oscillating factor set to 1
    return DisturbanceModel("constant", h, False)


def harmonic_disturbance(
    n: int, amplitude: np.ndarray, frequency: np.ndarray, offset: np.ndarray | float = 0.0
) -> DisturbanceModel:
    """User-supplied ``offset + amplitude * sin(frequency t)`` per axis (N m, rad/s).

    ``amplitude``/``frequency``/``offset`` broadcast to shape ``(n, 3)``.

    >>> d = harmonic_disturbance(2, [1e-3, 0, 0], [0.1, 0.1, 0.1])
    >>> d.bound().tolist()
    [0.001, 0.001]
    """
    shape = (n, 3)
    try:
        a = np.broadcast_to(np.asarray(amplitude, dtype=float), shape)
        w = np.broadcast_to(np.asarray(frequency, dtype=float), shape)
        c = np.broadcast_to(np.asarray(offset, dtype=float), shape)
    except ValueError:
        raise InputError(f"expected amplitude/frequency/offset broadcastable to {shape}") from None
    h = np.zeros((n, 3, 6))
    h[:, :, 0], h[:, :, 1], h[:, :, 2] = c, a, w
    h[:, :, 5] = math.pi / 2
    return DisturbanceModel("harmonic", h, False)


def _inertias(inertias: np.ndarray) -> np.ndarray:
    J = np.asarray(inertias, dtype=float)
    if J.ndim != 3 or J.shape[1:] != (3, 3):
        raise InputError(f"expected inertias of shape (N, 3, 3), received {J.shape}")
    return J


def kernel_parameters(d: DisturbanceModel) -> tuple[np.ndarray, np.ndarray]:
    """Parameters of the compiled kernel: shared frequencies ``(w1[3], w2[3])`` and per
    spacecraft and axis ``(c, a, cos p1, sin p1, cos p2, sin p2)`` (shape ``(N, 18)``).

    The kernel evaluates ``sin(w t + p) = sin(w t) cos p + cos(w t) sin p`` with one
    ``sin``/``cos`` pair per axis and factor for the whole formation, so the frequencies
    of each axis must be common to all spacecraft (true for every model here).

    >>> w, h = kernel_parameters(paper_disturbance(np.array([np.eye(3) * 50] * 2)))
    >>> w.tolist(), h.shape
    ([0.2, 0.1, 0.1, 0.0, 0.0, 0.2], (2, 18))
    """
    h = d.harmonic
    w1, w2 = h[:, :, 2], h[:, :, 4]
    if not (np.all(w1 == w1[0]) and np.all(w2 == w2[0])):
        raise InputError(
            "expected disturbance frequencies common to all spacecraft (per axis), received "
            f"{np.unique(w1, axis=0).tolist()} / {np.unique(w2, axis=0).tolist()}"
        )
    out = np.stack(
        [h[:, :, 0], h[:, :, 1], np.cos(h[:, :, 3]), np.sin(h[:, :, 3]), np.cos(h[:, :, 5]), np.sin(h[:, :, 5])],
        axis=2,
    )
    return np.concatenate([w1[0], w2[0]]), out.reshape(len(h), 18)


def disturbance_trig(t: ca.SX, freq: ca.SX, orbit: ca.SX) -> dict:
    """Time-only parts of ``u_d``, computed once per evaluation for the whole formation:
    ``sin``/``cos`` of ``w1 t``, ``w2 t`` (3 each) and the inertial orbit position ``R_I(t)``
    (``orbit = (mu, R, n, theta0)``)."""
    w1, w2 = freq[0:3], freq[3:6]
    R, n, th0 = orbit[1], orbit[2], orbit[3]
    return {
        "s1": ca.sin(w1 * t), "c1": ca.cos(w1 * t), "s2": ca.sin(w2 * t), "c2": ca.cos(w2 * t),
        "RI": R * ca.vertcat(ca.cos(n * t + th0), ca.sin(n * t + th0), 0),
        "k_gg": 3 * orbit[0] / R**5,
    }


def disturbance_torque(trig: dict, q: ca.SX, q0: ca.SX, J: ca.SX, harm: ca.SX, gg: ca.SX) -> ca.SX:
    """CasADi expression of ``u_d`` for one spacecraft (module docstring).

    Parameters
    ----------
    trig : dict from :func:`disturbance_trig`
    q (3), q0 : attitude; J (3x3) : inertia
    harm : 18 kernel parameters ``(c, a, cos p1, sin p1, cos p2, sin p2)`` per axis
    gg : 0/1 multiplier of the gravity-gradient torque

    >>> z = ca.SX.sym("z")
    >>> w, h = kernel_parameters(harmonic_disturbance(1, [0.5, 0, 0], [1.0, 1.0, 1.0], [1.0, 0, 0]))
    >>> tr = disturbance_trig(z, ca.DM(w), ca.DM([1, 1, 1, 0]))
    >>> e = disturbance_torque(tr, ca.DM.zeros(3), 1.0, ca.DM.eye(3), ca.DM(h[0]), 0.0)
    >>> f = ca.Function("f", [z], [e]); round(float(f(np.pi / 2)[0]), 12)
    1.5
    """
    out = []
    for k in range(3):
        c, a, cp1, sp1, cp2, sp2 = (harm[6 * k + j] for j in range(6))
        f1 = trig["s1"][k] * cp1 + trig["c1"][k] * sp1
        f2 = trig["s2"][k] * cp2 + trig["c2"][k] * sp2
        out.append(c + a * f1 * f2)
    ud = ca.vertcat(*out)
    qx = ca.skew(q)
    CT = (q0 * q0 - ca.dot(q, q)) * ca.SX.eye(3) + 2 * ca.mtimes(q, q.T) - 2 * q0 * qx
    RB = ca.mtimes(CT, trig["RI"])
    ugg = trig["k_gg"] * ca.cross(RB, ca.mtimes(J, RB))
    return ud + gg * ugg
