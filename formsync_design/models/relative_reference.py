"""Fly-around reference trajectory and desired-attitude frame (Zhang et al. 2014, issue 14).

The desired relative position on the fly-around envelope, in the fly-around
reference frame ``r``::

    l_r = [a sin(phi_r) cos(theta_r), b sin(phi_r) sin(theta_r), c cos(phi_r)]
    phi_r   = (phi_r0 - pi/2) exp(-t/P1) + pi/2
    theta_r = 2 pi / T (t + P2 exp(-t/P2) - P2) + theta_r0

its exact time derivatives (Taylor-mode differentiation, any order), the
frame rotation ``R_rT`` and the desired attitude frame ``d`` that points the
sensor axis ``x_d`` at the target, with its angular velocity and
acceleration.

Frames (paper section 1)
------------------------
* ``T``: the relative orbit frame of :mod:`formsync_design.models.orbit`
  (``x_T`` radial, ``y_T`` along-track, ``z_T`` orbit normal).
* ``r``: the fly-around frame, ``v_r = R_rT v_T`` with the 3-1-2 sequence
  ``R_rT = R_y(beta) R_x(alpha) R_z(gamma)``; ``R_x, R_y, R_z`` are the
  principal *coordinate-transformation* matrices (``R_x(a) = [[1,0,0],[0,c,s],
  [0,-s,c]]``).  The paper's case has ``gamma = beta = 0``, ``alpha = 70 deg``.
* ``d``: the desired attitude frame, ``v_d = R_dr v_r``; its rows are
  ``x_d = -l/|l|`` (from the chaser towards the target), ``y_d = -h/|h|``
  with ``h = l x l'`` (the negative normal of the fly-around plane) and
  ``z_d = x_d x y_d``.

Assumptions and findings (the equations for ``R_rT`` and ``R_dr`` were lost in
the text we work from; every item below is ours)
---------------------------------------------------------------------------
* The order ``R_y(beta) R_x(alpha) R_z(gamma)`` and the sign convention of the
  principal matrices are reconstructed.  They are confirmed by the paper's own
  numbers: from the initial orbits of section 4 they give
  ``phi_r0 = 20.13 deg`` and ``theta_r0 = 269.33 deg``, the printed initial
  angles (:func:`initial_angles`; the opposite sign of ``alpha`` would give
  ``phi_r0`` near 160 deg).
* ``phi_r``: the paper prints ``exp(-1/P1)``, which is a constant, so
  ``phi_r`` would never move from ``(phi_r0 - pi/2) e^{-1/P1} + pi/2``
  (about 20.2 deg, not even ``phi_r0``): the chaser would never enter the
  fly-around plane, contradicting the paper's own Fig. 8 (a smooth transition
  into the 70 deg plane).  We implement both readings (``reading="printed"``
  and the default ``"corrected"``, ``exp(-t/P1)``); :func:`printed_phi_finding`
  computes the difference.
* Singular cases of ``R_dr`` (the paper's fallback matrix is lost): when
  ``|l| <= tol_position`` (chaser at the target) the frame is the caller's
  ``previous`` frame, or the fly-around frame itself (``R_dr = I``) if none;
  when ``|l x l'| <= tol_momentum`` (straight-line motion or none) the sensor
  axis still points at the target and ``y_d`` is the negative fly-around normal
  ``-z_r`` made orthogonal to ``x_d`` (or ``-y_r`` if ``z_r`` is parallel to
  ``x_d``): the plane the regular law converges to for a circular fly-around.
  In both cases the frame is held, i.e. its angular velocity and acceleration
  relative to ``r`` are reported as zero ("steady relative motion" in the
  paper's words).
* The target orbit is circular with constant mean motion ``n``: ``omega_Ti =
  (0, 0, n)`` in ``T`` and ``omega_rT = 0`` (``R_rT`` constant).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number, parse_real

__all__ = [
    "FlyaroundParams",
    "ZHANG2014_FLYAROUND",
    "rotation_rT",
    "phi_r",
    "theta_r",
    "desired_position",
    "desired_position_T",
    "initial_angles",
    "PrintedPhiFinding",
    "printed_phi_finding",
    "FrameStatus",
    "DesiredAttitude",
    "attitude_frame",
    "desired_attitude",
]

_READINGS = ("corrected", "printed")


@dataclass(frozen=True)
class FlyaroundParams:
    """Fly-around envelope and schedule (SI units, angles in radians).

    Attributes
    ----------
    a, b, c : float
        Ellipsoid semi-axes of the envelope (m), positive.
    gamma, alpha, beta : float
        3-1-2 angles of ``R_rT`` (rad).
    phi0, theta0 : float
        Initial angles ``phi_r0``, ``theta_r0`` (rad).
    p1, p2 : float
        Delay constants ``P1``, ``P2`` (s), positive.
    period : float
        Fly-around period ``T`` (s), positive.

    Examples
    --------
    >>> p = ZHANG2014_FLYAROUND
    >>> p.a, round(math.degrees(p.alpha), 9), p.p1, p.p2, p.period
    (500.0, 70.0, 1000.0, 2000.0, 7200.0)
    """

    a: float
    b: float
    c: float
    gamma: float
    alpha: float
    beta: float
    phi0: float
    theta0: float
    p1: float
    p2: float
    period: float

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            object.__setattr__(self, name, parse_real(getattr(self, name), name))
        for name in ("a", "b", "c", "p1", "p2", "period"):
            if getattr(self, name) <= 0:
                raise InputError(f"expected {name} > 0, received {getattr(self, name):g}")

    @classmethod
    def from_degrees(cls, **kw: float) -> FlyaroundParams:
        """Build from angles in degrees (``gamma, alpha, beta, phi0, theta0``)."""
        for name in ("gamma", "alpha", "beta", "phi0", "theta0"):
            kw[name] = math.radians(parse_real(kw.get(name, 0.0), name))
        return cls(**kw)

    def to_dict(self) -> dict[str, Any]:
        return {k: json_number(getattr(self, k)) for k in self.__dataclass_fields__}


#: The paper's case (section 4): sphere of 500 m, alpha_rT = 70 deg, phi_r0 = 20.13 deg,
#: theta_r0 = 269.33 deg, P1 = 1000 s, P2 = 2000 s, T = 7200 s.
ZHANG2014_FLYAROUND = FlyaroundParams.from_degrees(
    a=500.0, b=500.0, c=500.0, gamma=0.0, alpha=70.0, beta=0.0,
    phi0=20.13, theta0=269.33, p1=1000.0, p2=2000.0, period=7200.0,
)  # fmt: skip


def _rx(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def _ry(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _rz(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_rT(params: FlyaroundParams) -> np.ndarray:
    """``R_rT = R_y(beta) R_x(alpha) R_z(gamma)`` (``v_r = R_rT v_T``).

    >>> R = rotation_rT(ZHANG2014_FLYAROUND)
    >>> [round(float(v), 6) for v in R @ [0.0, 0.0, 1.0]]  # z_T in r: tilted 70 deg about x
    [0.0, 0.939693, 0.34202]
    """
    return _ry(params.beta) @ _rx(params.alpha) @ _rz(params.gamma)


# ----- truncated Taylor series ("jets"): coefficient k is the k-th derivative / k! -----


def _check_order(order: int) -> int:
    if not isinstance(order, int) or isinstance(order, bool) or order < 0:
        raise InputError(f"expected a derivative order as an integer >= 0, received {order!r}")
    return order


def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(np.broadcast_shapes(a.shape, b.shape))
    for k in range(min(len(a), len(b))):
        for i in range(k + 1):
            out[k] += a[i] * b[k - i]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(a.shape)
    for k in range(a.shape[0]):
        for i in range(k + 1):
            out[k] += np.cross(a[i], b[k - i])
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return _mul(a, b).sum(axis=-1)


def _sqrt(a: np.ndarray) -> np.ndarray:
    out = np.zeros(a.shape)
    out[0] = math.sqrt(a[0])
    for k in range(1, a.shape[0]):
        out[k] = (a[k] - sum(out[j] * out[k - j] for j in range(1, k))) / (2 * out[0])
    return out


def _recip(a: np.ndarray) -> np.ndarray:
    out = np.zeros(a.shape)
    out[0] = 1.0 / a[0]
    for k in range(1, a.shape[0]):
        out[k] = -sum(a[j] * out[k - j] for j in range(1, k + 1)) / a[0]
    return out


def _sincos(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s, c = np.zeros(f.shape), np.zeros(f.shape)
    s[0], c[0] = math.sin(f[0]), math.cos(f[0])
    for k in range(1, f.shape[0]):
        s[k] = sum(j * f[j] * c[k - j] for j in range(1, k + 1)) / k
        c[k] = -sum(j * f[j] * s[k - j] for j in range(1, k + 1)) / k
    return s, c


def _unit(v: np.ndarray) -> np.ndarray:
    return _mul(v, _recip(_sqrt(_dot(v, v)))[:, None])


def _to_derivatives(coef: np.ndarray) -> np.ndarray:
    fact = np.array([math.factorial(k) for k in range(coef.shape[0])], dtype=float)
    return coef * fact.reshape((-1,) + (1,) * (coef.ndim - 1))


def _to_coefficients(der: np.ndarray) -> np.ndarray:
    fact = np.array([math.factorial(k) for k in range(der.shape[0])], dtype=float)
    return der / fact.reshape((-1,) + (1,) * (der.ndim - 1))


# ----- the schedule -----


def phi_r(
    t: float, params: FlyaroundParams, order: int = 2, reading: str = "corrected"
) -> np.ndarray:
    """``phi_r`` and its time derivatives up to ``order`` (closed form).

    ``reading="corrected"``: ``(phi0 - pi/2) e^{-t/P1} + pi/2``, whose k-th
    derivative is ``(phi0 - pi/2) (-1/P1)^k e^{-t/P1}``;
    ``reading="printed"``: ``(phi0 - pi/2) e^{-1/P1} + pi/2``, a constant.

    Examples
    --------
    >>> p = ZHANG2014_FLYAROUND
    >>> [round(math.degrees(v), 4) for v in phi_r(0.0, p, order=1)]
    [20.13, 0.0699]
    >>> [round(math.degrees(v), 4) for v in phi_r(0.0, p, order=1, reading="printed")]
    [20.1998, 0.0]
    """
    t, order = parse_real(t, "time t"), _check_order(order)
    if reading not in _READINGS:
        raise InputError(f"expected reading in {_READINGS}, received {reading!r}")
    out = np.zeros(order + 1)
    amp = params.phi0 - math.pi / 2
    if reading == "printed":
        out[0] = amp * math.exp(-1.0 / params.p1) + math.pi / 2
        return out
    decay = math.exp(-t / params.p1)
    for k in range(order + 1):
        out[k] = amp * (-1.0 / params.p1) ** k * decay
    out[0] += math.pi / 2
    return out


def theta_r(t: float, params: FlyaroundParams, order: int = 2) -> np.ndarray:
    """``theta_r = 2 pi/T (t + P2 e^{-t/P2} - P2) + theta0`` and its derivatives (closed form).

    ``theta_r' = 2 pi/T (1 - e^{-t/P2})``; for ``k >= 2`` the k-th derivative
    is ``2 pi/T P2 (-1/P2)^k e^{-t/P2}``.

    Examples
    --------
    >>> p = ZHANG2014_FLYAROUND
    >>> th = theta_r(1e6, p, order=1)
    >>> bool(abs(th[1] - 2 * math.pi / p.period) < 1e-15)  # the rate tends to 2 pi / T
    True
    """
    t, order = parse_real(t, "time t"), _check_order(order)
    w = 2 * math.pi / params.period
    decay = math.exp(-t / params.p2)
    out = np.zeros(order + 1)
    out[0] = w * (t + params.p2 * decay - params.p2) + params.theta0
    if order >= 1:
        out[1] = w * (1.0 - decay)
    for k in range(2, order + 1):
        out[k] = w * params.p2 * (-1.0 / params.p2) ** k * decay
    return out


def desired_position(
    t: float, params: FlyaroundParams, order: int = 2, reading: str = "corrected"
) -> np.ndarray:
    """``l_r`` in the fly-around frame and its derivatives: array ``(order + 1, 3)``.

    Row ``k`` is the k-th time derivative, exact (Taylor-mode differentiation
    of the closed-form angles).

    Examples
    --------
    >>> L = desired_position(0.0, ZHANG2014_FLYAROUND)
    >>> L.shape, round(float(np.linalg.norm(L[0])), 9)  # on the 500 m sphere
    ((3, 3), 500.0)
    """
    order = _check_order(order)
    s_p, c_p = _sincos(_to_coefficients(phi_r(t, params, order, reading)))
    s_t, c_t = _sincos(_to_coefficients(theta_r(t, params, order)))
    coef = np.stack([params.a * _mul(s_p, c_t), params.b * _mul(s_p, s_t), params.c * c_p], axis=-1)
    return _to_derivatives(coef)


def desired_position_T(
    t: float, params: FlyaroundParams, order: int = 2, reading: str = "corrected"
) -> np.ndarray:
    """``l_T = R_rT^T l_r`` (relative orbit frame) and its derivatives, ``(order + 1, 3)``.

    >>> L = desired_position_T(0.0, ZHANG2014_FLYAROUND, order=0)
    >>> [round(float(v), 1) for v in L[0]]  # on the sphere, ~500 m behind the target
    [-2.0, -500.0, -1.1]
    """
    return desired_position(t, params, order, reading) @ rotation_rT(params)


def initial_angles(l_T: Any, params: FlyaroundParams) -> tuple[float, float]:
    """``(phi_r0, theta_r0)`` (rad) of an initial relative position ``l_T``.

    ``phi = arccos(z_r/|l|)``, ``theta = atan2(y_r, x_r)`` in ``[0, 2 pi)``
    with ``l_r = R_rT l_T``.  Raises :class:`InputError` for ``l_T = 0``.

    Examples
    --------
    The paper's initial orbits give its printed angles (20.13 deg, 269.33 deg):

    >>> from formsync_design.models.orbit import (ZHANG2014_CHASER, ZHANG2014_TARGET,
    ...     elements_to_state, relative_state)
    >>> X0 = relative_state(elements_to_state(ZHANG2014_TARGET), elements_to_state(ZHANG2014_CHASER))
    >>> [round(math.degrees(a), 2) for a in initial_angles(X0[:3], ZHANG2014_FLYAROUND)]
    [20.13, 269.33]
    """
    v = np.asarray(l_T, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InputError(f"expected l_T as 3 finite numbers, received shape {v.shape}")
    norm = float(np.linalg.norm(v))
    if norm == 0:
        raise InputError("expected a non-zero initial relative position, received 0")
    lr = rotation_rT(params) @ v
    phi = math.acos(max(-1.0, min(1.0, lr[2] / norm)))
    theta = math.atan2(lr[1], lr[0]) % (2 * math.pi)
    return phi, theta


@dataclass(frozen=True)
class PrintedPhiFinding:
    """The printed ``phi_r`` (with ``exp(-1/P1)``) against the corrected one.

    Attributes
    ----------
    printed_span : float
        ``max - min`` of the printed ``phi_r`` over the samples (rad): 0 means constant.
    printed_value : float
        Its value (rad).
    printed_start_offset : float
        ``printed phi_r(0) - phi_r0`` (rad): the printed law does not even start at ``phi_r0``.
    corrected_span : float
        ``max - min`` of the corrected ``phi_r`` over the samples (rad).
    corrected_final_gap : float
        ``pi/2 - corrected phi_r(t_end)`` (rad): how far from the fly-around plane at the end.
    printed_final_gap : float
        ``pi/2 - printed phi_r(t_end)`` (rad).
    """

    printed_span: float
    printed_value: float
    printed_start_offset: float
    corrected_span: float
    corrected_final_gap: float
    printed_final_gap: float

    def to_dict(self) -> dict[str, Any]:
        return {k: json_number(getattr(self, k)) for k in self.__dataclass_fields__}


def printed_phi_finding(
    params: FlyaroundParams, t_end: float, samples: int = 1001
) -> PrintedPhiFinding:
    """Evaluate both readings of ``phi_r`` on ``[0, t_end]`` (the finding of the module docstring).

    Examples
    --------
    >>> f = printed_phi_finding(ZHANG2014_FLYAROUND, 18_000.0)
    >>> f.printed_span, round(math.degrees(f.printed_final_gap), 2), f.corrected_final_gap < 1e-6
    (0.0, 69.8, True)
    """
    t_end = parse_real(t_end, "t_end")
    if t_end <= 0 or samples < 2:
        raise InputError(f"expected t_end > 0 and samples >= 2, received {t_end:g} and {samples}")
    ts = np.linspace(0.0, t_end, samples)
    pr = np.array([phi_r(t, params, 0, "printed")[0] for t in ts])
    co = np.array([phi_r(t, params, 0)[0] for t in ts])
    return PrintedPhiFinding(
        printed_span=float(pr.max() - pr.min()),
        printed_value=float(pr[0]),
        printed_start_offset=float(pr[0] - params.phi0),
        corrected_span=float(co.max() - co.min()),
        corrected_final_gap=float(math.pi / 2 - co[-1]),
        printed_final_gap=float(math.pi / 2 - pr[-1]),
    )


class FrameStatus(enum.StrEnum):
    """Which branch of the desired-frame law produced ``R_dr``."""

    REGULAR = "regular"
    STRAIGHT_LINE = "straight-line"  # |l x l'| small: straight-line motion or none (fallback)
    COINCIDENT = "coincident"  # |l| small: chaser at the target (fallback)


@dataclass(frozen=True)
class DesiredAttitude:
    """The desired attitude frame ``d`` at one instant.

    Attributes
    ----------
    status : FrameStatus
    R_dr : numpy.ndarray
        ``v_d = R_dr v_r`` (rows ``x_d, y_d, z_d`` in ``r``).
    omega_dr, omega_dr_dot : numpy.ndarray
        Angular velocity of ``d`` relative to ``r`` and its time derivative, in ``d``.
    R_dT : numpy.ndarray
        ``R_dr R_rT`` (``v_d = R_dT v_T``); filled by :func:`desired_attitude`.
    omega_di, omega_di_dot : numpy.ndarray
        Inertial angular velocity of ``d`` and its derivative, in ``d``
        (filled by :func:`desired_attitude`; ``omega_dr`` copies otherwise).
    """

    status: FrameStatus
    R_dr: np.ndarray
    omega_dr: np.ndarray
    omega_dr_dot: np.ndarray
    R_dT: np.ndarray
    omega_di: np.ndarray
    omega_di_dot: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        def mat(m: np.ndarray) -> Any:
            return [json_number(v) for v in m] if m.ndim == 1 else [mat(row) for row in m]

        out: dict[str, Any] = {"status": str(self.status)}
        for k in ("R_dr", "omega_dr", "omega_dr_dot", "R_dT", "omega_di", "omega_di_dot"):
            out[k] = mat(getattr(self, k))
        return out


def _vee(m: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


def attitude_frame(
    l_derivs: Any,
    previous: Any = None,
    tol_position: float = 1e-9,
    tol_momentum: float = 1e-12,
) -> DesiredAttitude:
    """Desired frame ``R_dr`` from ``l`` and its derivatives ``(l, l', l'', l''')`` in ``r``.

    Rows ``x_d = -l/|l|``, ``y_d = -h/|h|`` (``h = l x l'``), ``z_d = x_d x y_d``;
    ``omega_dr`` needs ``l''`` and ``omega_dr_dot`` needs ``l'''`` (derivatives
    not given are taken as zero).  Singular cases use the fallback of the
    module docstring; ``tol_momentum`` is relative to ``|l| |l'|``.

    Examples
    --------
    Uniform circular motion in the ``x_r y_r`` plane at rate 0.1 rad/s:

    >>> w = 0.1
    >>> fr = attitude_frame([[1.0, 0, 0], [0, w, 0], [-w**2, 0, 0], [0, -w**3, 0]])
    >>> str(fr.status), (fr.R_dr + 0.0).round(12).tolist()[1], [round(float(v), 12) + 0.0 for v in fr.omega_dr]
    ('regular', [0.0, 0.0, -1.0], [0.0, -0.1, 0.0])
    >>> str(attitude_frame([[1.0, 0, 0], [2.0, 0, 0]]).status)  # straight-line motion
    'straight-line'
    """
    der = np.asarray(l_derivs, dtype=float)
    if der.ndim != 2 or der.shape[1] != 3 or der.shape[0] < 1 or not np.all(np.isfinite(der)):
        raise InputError(
            f"expected l and its derivatives as finite rows of 3, received shape {der.shape}"
        )
    if der.shape[0] < 4:
        der = np.vstack([der, np.zeros((4 - der.shape[0], 3))])
    der = der[:4]
    zero = np.zeros(3)
    l_norm = float(np.linalg.norm(der[0]))
    if l_norm <= tol_position:
        if previous is None:
            r_dr = np.eye(3)
        else:
            r_dr = np.asarray(previous, dtype=float)
            if r_dr.shape != (3, 3) or not np.allclose(r_dr @ r_dr.T, np.eye(3), atol=1e-9):
                raise InputError(
                    f"expected previous as a 3x3 rotation matrix, received shape {r_dr.shape}"
                )
        return DesiredAttitude(FrameStatus.COINCIDENT, r_dr, zero, zero, r_dr, zero, zero)
    coef = _to_coefficients(der)
    # h = l x l' as a jet: coefficient k of l' is (k+1) c_{k+1} (the last one is unknown
    # and unused: R_dr is needed to coefficient 2 only)
    ldot = np.vstack([np.array([(k + 1) * coef[k + 1] for k in range(3)]), np.zeros((1, 3))])
    h = _cross(coef, ldot)
    x = -_unit(coef)
    if float(np.linalg.norm(h[0])) <= tol_momentum * l_norm * max(
        float(np.linalg.norm(der[1])), 1.0
    ):
        x0 = x[0]
        axis = np.array([0.0, 0.0, -1.0]) if abs(x0[2]) < 0.9 else np.array([0.0, -1.0, 0.0])
        y0 = axis - (axis @ x0) * x0
        y0 /= np.linalg.norm(y0)
        r_dr = np.vstack([x0, y0, np.cross(x0, y0)])
        return DesiredAttitude(FrameStatus.STRAIGHT_LINE, r_dr, zero, zero, r_dr, zero, zero)
    y = -_unit(h)
    z = _cross(x, y)
    rot = np.stack([x, y, z], axis=1)  # (4, 3, 3): coefficient k of R_dr
    r0, r1, r2 = rot[0], rot[1], 2.0 * rot[2]
    omega = _vee(-r1 @ r0.T)
    omega_dot = _vee(-r2 @ r0.T - r1 @ r1.T)
    return DesiredAttitude(FrameStatus.REGULAR, r0, omega, omega_dot, r0, omega, omega_dot)


def desired_attitude(
    t: float,
    params: FlyaroundParams,
    n: float,
    reading: str = "corrected",
    previous: Any = None,
) -> DesiredAttitude:
    """The desired attitude at time ``t`` for a circular target orbit of mean motion ``n``.

    ``omega_di = omega_dr + R_dT (0, 0, n)`` and
    ``omega_di' = omega_dr' - omega_dr x R_dT (0, 0, n)`` (both in ``d``;
    ``omega_rT = 0`` and ``n`` constant).

    Examples
    --------
    >>> from formsync_design.models.orbit import mean_motion
    >>> d = desired_attitude(0.0, ZHANG2014_FLYAROUND, mean_motion(42_164_137.0))
    >>> str(d.status), bool(np.allclose(d.R_dT @ d.R_dT.T, np.eye(3)))
    ('regular', True)
    >>> [round(float(v), 1) for v in d.R_dT[0] * 500]  # x_d points at the target: -l_T
    [2.0, 500.0, 1.1]
    """
    n = parse_real(n, "mean motion n")
    fr = attitude_frame(desired_position(t, params, 3, reading), previous)
    r_dt = fr.R_dr @ rotation_rT(params)
    w_ti = r_dt @ np.array([0.0, 0.0, n])
    return DesiredAttitude(
        fr.status,
        fr.R_dr,
        fr.omega_dr,
        fr.omega_dr_dot,
        r_dt,
        fr.omega_dr + w_ti,
        fr.omega_dr_dot - np.cross(fr.omega_dr, w_ti),
    )
