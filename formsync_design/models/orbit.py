"""Relative orbit models for the Zhang et al. 2014 fly-around case (issue 14).

Keplerian elements to an inertial (ECI) state, the relative orbit frame, the
nonlinear relative dynamics about a circular reference orbit (the truth model),
the Clohessy-Wiltshire / Hill (CW/HCW) linear model with its closed-form
solution, and an LQR design on it with its guaranteed stability margins
computed, not assumed.

Frames and state order
----------------------
* ECI: inertial, ``Z`` along the reference orbit's angular momentum when the
  inclination is zero.
* Relative orbit frame ``T`` (paper section 1, frame ``o_T x_T y_T z_T``):
  origin at the target's centre of mass, ``x_T`` radial (from the Earth's
  centre away through the target), ``z_T`` along the target's orbit normal
  (angular momentum), ``y_T = z_T x x_T`` (along-track for a circular orbit).
  This is the usual LVLH/Hill frame with axes (radial, along-track, normal).
* Relative state, everywhere in this module: ``X = (x, y, z, x', y', z')``,
  the chaser's position relative to the target in ``T`` and its rate of
  change *as seen in the rotating frame* ``T``; the control input is the
  specific force ``u = (u_x, u_y, u_z)`` in ``T`` (m/s^2).

Assumptions (the paper does not state them; each is ours)
---------------------------------------------------------
* ``mu = 3.986004418e14 m^3/s^2`` (WGS-84/EGM-96 value); the paper's ``a`` of
  about 42 164 km is the GEO radius for this ``mu``.
* The paper gives (a, e, i, u) only.  We take the right ascension of the
  ascending node ``Omega = 0`` for both spacecraft (the target's node is
  undefined at ``i = 0``), the argument of perigee ``omega = 0`` (circular
  orbits) and ``u`` as the argument of latitude (the true anomaly for
  ``omega = 0``).  With these, the paper's initial relative position is about
  ``(-2, -500.41, -1.15) m`` in ``T``: a 500 m separation, consistent with the
  500 m fly-around sphere (see :mod:`formsync_design.models.relative_reference`, which
  recovers the paper's initial angles from it).
* The paper writes the LQR law as ``u = K X`` with ``K = -R^-1 B^T P``; we
  return the positive gain ``K = R^-1 B^T P`` and use ``u = -K X``.
* The paper's LQR weights ``Q, R`` are not printed (the equations were lost
  in the text we work from); callers choose them.
"""

from __future__ import annotations

import enum
import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from formsync_design.errors import InputError, SolverError
from formsync_design.gains import json_number, parse_real

__all__ = [
    "MU_EARTH",
    "KeplerElements",
    "ZHANG2014_TARGET",
    "ZHANG2014_CHASER",
    "elements_to_state",
    "mean_motion",
    "lvlh_matrix",
    "relative_state",
    "two_body_rhs",
    "relative_nonlinear_rhs",
    "cw_matrices",
    "cw_transition",
    "LQRDesign",
    "lqr_design",
    "MarginStatus",
    "LQRMargins",
    "lqr_margins",
]

#: Earth's gravitational parameter (m^3/s^2), an assumption (module docstring).
MU_EARTH = 3.986004418e14


@dataclass(frozen=True)
class KeplerElements:
    """Classical orbital elements (SI units, angles in radians).

    Attributes
    ----------
    a : float
        Semi-major axis (m), positive (elliptic orbits only).
    e : float
        Eccentricity, ``0 <= e < 1``.
    i : float
        Inclination (rad).
    raan : float
        Right ascension of the ascending node (rad).
    argp : float
        Argument of perigee (rad).
    nu : float
        True anomaly (rad); for a circular orbit with ``argp = 0`` this is the
        argument of latitude ``u``.

    Examples
    --------
    >>> el = KeplerElements.from_degrees(a=7.0e6, e=0.0, i=0.0, u=90.0)
    >>> round(math.degrees(el.nu), 6), el.raan, el.argp
    (90.0, 0.0, 0.0)
    """

    a: float
    e: float
    i: float
    raan: float = 0.0
    argp: float = 0.0
    nu: float = 0.0

    def __post_init__(self) -> None:
        for name in ("a", "e", "i", "raan", "argp", "nu"):
            object.__setattr__(self, name, parse_real(getattr(self, name), name))
        if self.a <= 0:
            raise InputError(f"expected a semi-major axis a > 0 m, received {self.a:g}")
        if not 0 <= self.e < 1:
            raise InputError(f"expected an eccentricity 0 <= e < 1, received {self.e:g}")

    @classmethod
    def from_degrees(
        cls, a: float, e: float, i: float, u: float, raan: float = 0.0, argp: float = 0.0
    ) -> KeplerElements:
        """Elements from degrees; ``u`` is the angle from perigee (``argp = 0``: from the node)."""
        return cls(a, e, math.radians(i), math.radians(raan), math.radians(argp), math.radians(u))

    def to_dict(self) -> dict[str, Any]:
        return {k: json_number(getattr(self, k)) for k in ("a", "e", "i", "raan", "argp", "nu")}


#: The paper's target (section 4): a = 42 164 137 m, e = 0, i = 0 deg, u = 215 deg.
ZHANG2014_TARGET = KeplerElements.from_degrees(a=42_164_137.0, e=0.0, i=0.0, u=215.0)
#: The paper's chaser: a = 42 164 135 m, e = 0, i = 2.71795e-6 deg, u = 214.99932 deg.
ZHANG2014_CHASER = KeplerElements.from_degrees(a=42_164_135.0, e=0.0, i=2.71795e-6, u=214.99932)


def _rot1(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot3(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def elements_to_state(el: KeplerElements, mu: float = MU_EARTH) -> tuple[np.ndarray, np.ndarray]:
    """ECI position (m) and velocity (m/s) of the elements ``el``.

    Perifocal state rotated by ``R3(raan) R1(i) R3(argp)``.

    Examples
    --------
    >>> r, v = elements_to_state(KeplerElements(a=7.0e6, e=0.0, i=0.0))
    >>> r.tolist(), bool(abs(v[1] - math.sqrt(MU_EARTH / 7.0e6)) < 1e-9)
    ([7000000.0, 0.0, 0.0], True)
    """
    mu = parse_real(mu, "mu")
    p = el.a * (1.0 - el.e**2)
    r = p / (1.0 + el.e * math.cos(el.nu))
    r_pf = np.array([r * math.cos(el.nu), r * math.sin(el.nu), 0.0])
    v_pf = math.sqrt(mu / p) * np.array([-math.sin(el.nu), el.e + math.cos(el.nu), 0.0])
    rot = _rot3(el.raan) @ _rot1(el.i) @ _rot3(el.argp)
    return rot @ r_pf, rot @ v_pf


def mean_motion(a: float, mu: float = MU_EARTH) -> float:
    """Mean motion ``n = sqrt(mu / a^3)`` (rad/s).

    >>> round(2 * math.pi / mean_motion(42_164_137.0) / 3600, 3)  # GEO: one sidereal day
    23.934
    """
    a = parse_real(a, "a")
    if a <= 0:
        raise InputError(f"expected a semi-major axis a > 0 m, received {a:g}")
    return math.sqrt(parse_real(mu, "mu") / a**3)


def lvlh_matrix(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotation ``C_TI`` from ECI to the relative orbit frame ``T`` (rows: x_T, y_T, z_T).

    ``x_T = r/|r|``, ``z_T = h/|h|`` with ``h = r x v``, ``y_T = z_T x x_T``.

    >>> C = lvlh_matrix(np.array([0.0, 7e6, 0.0]), np.array([-7.5e3, 0.0, 0.0]))
    >>> (C + 0.0).round(12).tolist()  # x_T = +Y, y_T = -X, z_T = +Z
    [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    r = np.asarray(r, dtype=float)
    h = np.cross(r, np.asarray(v, dtype=float))
    if np.linalg.norm(r) == 0 or np.linalg.norm(h) == 0:
        raise InputError(
            "expected a non-degenerate orbit (r != 0, r x v != 0), received a degenerate one"
        )
    x = r / np.linalg.norm(r)
    z = h / np.linalg.norm(h)
    return np.vstack([x, np.cross(z, x), z])


def relative_state(
    target: tuple[np.ndarray, np.ndarray], chaser: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """The relative state ``X = (rho, rho')`` of ``chaser`` about ``target`` in ``T``.

    ``rho = C (r_c - r_t)``; ``rho' = C (v_c - v_t) - w x rho`` with the
    frame's angular velocity ``w = (0, 0, |h|/|r_t|^2)`` in ``T`` (exact for any
    unperturbed target orbit).

    Examples
    --------
    The paper's case: about 500 m behind the target, 2 m below, 1.15 m south.

    >>> X = relative_state(elements_to_state(ZHANG2014_TARGET), elements_to_state(ZHANG2014_CHASER))
    >>> [round(float(c), 2) for c in X[:3]]
    [-2.0, -500.41, -1.15]
    """
    r_t, v_t = (np.asarray(a, dtype=float) for a in target)
    r_c, v_c = (np.asarray(a, dtype=float) for a in chaser)
    c = lvlh_matrix(r_t, v_t)
    w = np.array([0.0, 0.0, np.linalg.norm(np.cross(r_t, v_t)) / float(r_t @ r_t)])
    rho = c @ (r_c - r_t)
    return np.concatenate([rho, c @ (v_c - v_t) - np.cross(w, rho)])


def two_body_rhs(t: float, y: np.ndarray, mu: float = MU_EARTH) -> np.ndarray:
    """Unperturbed two-body dynamics, state ``(r, v)`` in ECI.

    >>> bool(two_body_rhs(0.0, np.array([7e6, 0, 0, 0, 7.5e3, 0.0]))[3] == -MU_EARTH / 7e6**2)
    True
    """
    r = y[:3]
    return np.concatenate([y[3:], -mu * r / np.linalg.norm(r) ** 3])


def relative_nonlinear_rhs(
    t: float, x: np.ndarray, r0: float, u: np.ndarray | None = None, mu: float = MU_EARTH
) -> np.ndarray:
    """Exact relative dynamics about a circular reference orbit of radius ``r0``.

    With ``n = sqrt(mu/r0^3)``, ``r_c = |(r0 + x, y, z)|`` and specific force ``u``
    (in ``T``), the truth model of this module::

        x'' =  2 n y' + n^2 (r0 + x) - mu (r0 + x) / r_c^3 + u_x
        y'' = -2 n x' + n^2 y        - mu y / r_c^3        + u_y
        z'' =                        - mu z / r_c^3        + u_z

    Examples
    --------
    A chaser on the reference orbit itself (``X = 0``) stays there:

    >>> float(np.abs(relative_nonlinear_rhs(0.0, np.zeros(6), 42_164_137.0)).max()) < 1e-12
    True
    """
    n = mean_motion(r0, mu)
    px, py, pz, vx, vy, vz = x
    rc3 = ((r0 + px) ** 2 + py**2 + pz**2) ** 1.5
    acc = np.array(
        [
            2 * n * vy + n**2 * (r0 + px) - mu * (r0 + px) / rc3,
            -2 * n * vx + n**2 * py - mu * py / rc3,
            -mu * pz / rc3,
        ]
    )
    if u is not None:
        acc = acc + np.asarray(u, dtype=float)
    return np.concatenate([[vx, vy, vz], acc])


def cw_matrices(n: float) -> tuple[np.ndarray, np.ndarray]:
    """CW/HCW model ``X' = A X + B u`` (state order of the module docstring).

    >>> A, B = cw_matrices(1.0)
    >>> A[3].tolist(), A[4].tolist(), A[5].tolist(), B.shape
    ([3.0, 0.0, 0.0, 0.0, 2.0, 0.0], [0.0, 0.0, 0.0, -2.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0, 0.0, 0.0], (6, 3))
    """
    n = parse_real(n, "mean motion n")
    if n <= 0:
        raise InputError(f"expected a mean motion n > 0 rad/s, received {n:g}")
    a = np.zeros((6, 6))
    a[:3, 3:] = np.eye(3)
    a[3, 0], a[3, 4] = 3 * n**2, 2 * n
    a[4, 3] = -2 * n
    a[5, 2] = -(n**2)
    b = np.vstack([np.zeros((3, 3)), np.eye(3)])
    return a, b


def cw_transition(n: float, t: float) -> np.ndarray:
    """Clohessy-Wiltshire closed-form state-transition matrix ``Phi(t)`` (6x6).

    The classical analytic solution (radial, along-track, normal), written out
    term by term, independent of any matrix exponential.

    >>> Phi = cw_transition(1e-3, 0.0)
    >>> bool(np.array_equal(Phi, np.eye(6)))
    True
    """
    n, t = parse_real(n, "mean motion n"), parse_real(t, "time t")
    s, c = math.sin(n * t), math.cos(n * t)
    return np.array(
        [
            [4 - 3 * c, 0, 0, s / n, 2 * (1 - c) / n, 0],
            [6 * (s - n * t), 1, 0, -2 * (1 - c) / n, (4 * s - 3 * n * t) / n, 0],
            [0, 0, c, 0, 0, s / n],
            [3 * n * s, 0, 0, c, 2 * s, 0],
            [-6 * n * (1 - c), 0, 0, -2 * s, 4 * c - 3, 0],
            [0, 0, -n * s, 0, 0, c],
        ]
    )


@dataclass(frozen=True)
class LQRDesign:
    """An LQR state feedback ``u = -K X`` with ``K = R^-1 B^T P``.

    Attributes
    ----------
    K, P : numpy.ndarray
        Gain (m x n) and the stabilizing solution of the algebraic Riccati
        equation ``A^T P + P A - P B R^-1 B^T P + Q = 0``.
    riccati_residual : float
        ``max |A^T P + P A - P B R^-1 B^T P + Q|`` relative to ``max(|Q|, 1)``,
        computed from the returned ``P``.
    closed_loop_eigenvalues : numpy.ndarray
        Eigenvalues of ``A - B K``.
    """

    K: np.ndarray
    P: np.ndarray
    riccati_residual: float
    closed_loop_eigenvalues: np.ndarray

    @property
    def max_real_part(self) -> float:
        """Largest real part of the closed-loop eigenvalues (negative: Hurwitz)."""
        return float(np.max(self.closed_loop_eigenvalues.real))

    def to_dict(self) -> dict[str, Any]:
        return {
            "K": [[json_number(v) for v in row] for row in self.K],
            "riccati_residual": json_number(self.riccati_residual),
            "max_real_part": json_number(self.max_real_part),
        }


def _matrix(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    m = np.asarray(value, dtype=float)
    if m.shape != shape:
        raise InputError(f"expected {name} of shape {shape}, received shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise InputError(f"expected {name} with finite entries, received a non-finite one")
    return m


def lqr_design(A: Any, B: Any, Q: Any, R: Any) -> LQRDesign:
    """Continuous LQR by ``scipy.linalg.solve_continuous_are``.

    ``Q`` must be symmetric positive semidefinite, ``R`` symmetric positive
    definite.  Raises :class:`SolverError` if scipy finds no stabilizing
    solution (e.g. ``(A, B)`` not stabilizable).

    Examples
    --------
    >>> A, B = cw_matrices(mean_motion(42_164_137.0))
    >>> d = lqr_design(A, B, np.eye(6), np.eye(3))
    >>> d.riccati_residual < 1e-9, d.max_real_part < 0, d.K.shape
    (True, True, (3, 6))
    """
    a = np.asarray(A, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise InputError(f"expected A square, received shape {a.shape}")
    nx = a.shape[0]
    b = np.asarray(B, dtype=float)
    if b.ndim != 2 or b.shape[0] != nx:
        raise InputError(f"expected B with {nx} rows, received shape {b.shape}")
    nu = b.shape[1]
    q = _matrix(Q, "Q", (nx, nx))
    r = _matrix(R, "R", (nu, nu))
    if not (np.allclose(q, q.T) and np.allclose(r, r.T)):
        raise InputError("expected symmetric Q and R, received a non-symmetric one")
    if np.linalg.eigvalsh(q).min() < -1e-12 * max(1.0, np.abs(q).max()):
        raise InputError(
            f"expected Q positive semidefinite, received min eigenvalue {np.linalg.eigvalsh(q).min():g}"
        )
    if np.linalg.eigvalsh(r).min() <= 0:
        raise InputError(
            f"expected R positive definite, received min eigenvalue {np.linalg.eigvalsh(r).min():g}"
        )
    try:
        p = scipy.linalg.solve_continuous_are(a, b, q, r)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise SolverError(
            f"the Riccati solver failed ({exc}); check that (A, B) is stabilizable and (Q, A) detectable"
        ) from None
    k = np.linalg.solve(r, b.T @ p)
    res = a.T @ p + p @ a - p @ b @ k + q
    eig = np.linalg.eigvals(a - b @ k)
    return LQRDesign(k, p, float(np.abs(res).max() / max(1.0, np.abs(q).max())), eig)


class MarginStatus(enum.StrEnum):
    """Outcome of :func:`lqr_margins`."""

    HOLD = "hold"  # every computed check confirms the guaranteed margins
    VIOLATED = "violated"  # a check found a perturbation within the guarantee that destabilizes
    NOT_APPLICABLE = "not-applicable"  # R not diagonal: the per-channel guarantee is not claimed
    ERROR = "error"


@dataclass(frozen=True)
class LQRMargins:
    """Computed evidence for the LQR's guaranteed margins (diagonal ``R``).

    Attributes
    ----------
    status : MarginStatus
    min_return_difference : float
        ``min over the frequency grid of lambda_min(R^-1/2 (I+L)^H R (I+L) R^-1/2)``
        with ``L(jw) = K (jwI - A)^-1 B``; the guarantee needs ``>= 1``.
    worst_gain_real_part : float
        Largest closed-loop eigenvalue real part of ``A - B diag(k) K`` over
        every vertex ``k_i`` in ``{1/2, 1, 10, 1000}`` per channel.
    worst_phase_real_part : float
        Largest eigenvalue real part of ``A - B diag(e^{j phi_i}) K`` over
        every vertex ``phi_i`` in ``{-60, 0, 60}`` degrees per channel and the
        common phases on a grid of ``[-60, 60]`` degrees.
    gain_margin_low : float
        Smallest common gain reduction factor keeping ``A - B k K`` Hurwitz
        (bisection; ``<= 1/2`` confirms the guarantee).
    phase_margin_deg : float
        Largest common phase ``phi`` (degrees, up to 180) keeping
        ``A - B e^{j phi} K`` Hurwitz (bisection; ``>= 60`` confirms it).
    """

    status: MarginStatus
    min_return_difference: float
    worst_gain_real_part: float
    worst_phase_real_part: float
    gain_margin_low: float
    phase_margin_deg: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": str(self.status),
            "min_return_difference": json_number(self.min_return_difference),
            "worst_gain_real_part": json_number(self.worst_gain_real_part),
            "worst_phase_real_part": json_number(self.worst_phase_real_part),
            "gain_margin_low": json_number(self.gain_margin_low),
            "phase_margin_deg": json_number(self.phase_margin_deg),
        }


def _max_re(a: np.ndarray, b: np.ndarray, gain: np.ndarray, k: np.ndarray) -> float:
    return float(np.max(np.linalg.eigvals(a - b @ np.diag(gain) @ k).real))


def _bisect(stable_at: Any, good: float, bad: float, steps: int = 60) -> float:
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if stable_at(mid):
            good = mid
        else:
            bad = mid
    return good


def lqr_margins(A: Any, B: Any, design: LQRDesign, R: Any, n_freq: int = 400) -> LQRMargins:
    """Check the LQR's guaranteed margins by computation (diagonal ``R``).

    For diagonal ``R`` an LQR loop broken at the plant input keeps the closed
    loop stable for gains in ``[1/2, inf)`` and phases within ``+-60 deg`` in
    every channel simultaneously (Safonov & Athans 1977).  This function does
    not assume it: it evaluates the return-difference inequality on a
    log-spaced frequency grid, the eigenvalues of the closed loop at every
    vertex of the per-channel gain and phase boxes, and the actual common
    gain and phase margins by bisection.

    Examples
    --------
    >>> A, B = cw_matrices(mean_motion(42_164_137.0))
    >>> d = lqr_design(A, B, np.eye(6), 1e4 * np.eye(3))
    >>> m = lqr_margins(A, B, d, 1e4 * np.eye(3))
    >>> str(m.status), m.min_return_difference >= 1 - 1e-9, m.phase_margin_deg >= 60
    ('hold', True, True)
    """
    a = np.asarray(A, dtype=float)
    b = np.asarray(B, dtype=float)
    r = np.asarray(R, dtype=float)
    k = design.K
    nu = b.shape[1]
    if r.shape != (nu, nu):
        raise InputError(f"expected R of shape {(nu, nu)}, received shape {r.shape}")
    diagonal = bool(np.all(r == np.diag(np.diag(r))))
    # return difference on a frequency grid spanning the closed-loop and open-loop scales
    eig_scale = np.abs(np.concatenate([design.closed_loop_eigenvalues, np.linalg.eigvals(a)]))
    eig_scale = eig_scale[eig_scale > 0]
    lo = max(float(eig_scale.min()) * 1e-3, 1e-12) if eig_scale.size else 1e-6
    hi = float(eig_scale.max()) * 1e3 if eig_scale.size else 1e3
    rh = np.diag(np.sqrt(np.diag(r))) if diagonal else np.real(scipy.linalg.sqrtm(r))
    rh_inv = np.linalg.inv(rh)
    nx = a.shape[0]
    min_rd = math.inf
    for w in np.concatenate([[0.0], np.logspace(math.log10(lo), math.log10(hi), n_freq)]):
        try:
            loop = k @ np.linalg.solve(1j * w * np.eye(nx) - a, b)
        except np.linalg.LinAlgError:
            continue  # an open-loop pole on the grid: L is infinite there
        f = rh @ (np.eye(nu) + loop) @ rh_inv
        min_rd = min(min_rd, float(np.linalg.svd(f, compute_uv=False).min() ** 2))
    gains = [0.5, 1.0, 10.0, 1000.0]
    worst_gain = max(_max_re(a, b, np.array(g), k) for g in itertools.product(gains, repeat=nu))
    phases = [math.radians(p) for p in (-60.0, 0.0, 60.0)]
    worst_phase = max(
        _max_re(a, b, np.exp(1j * np.array(p)), k) for p in itertools.product(phases, repeat=nu)
    )
    for p in np.linspace(-math.pi / 3, math.pi / 3, 25):
        worst_phase = max(worst_phase, _max_re(a, b, np.full(nu, np.exp(1j * p)), k))
    ones = np.ones(nu)
    gain_low = _bisect(lambda g: _max_re(a, b, g * ones, k) < 0, 1.0, 0.0)
    if _max_re(a, b, np.exp(1j * math.pi) * ones, k) < 0:
        phase = 180.0
    else:
        phase = math.degrees(
            _bisect(lambda p: _max_re(a, b, np.exp(1j * p) * ones, k) < 0, 0.0, math.pi)
        )
    values = (min_rd, worst_gain, worst_phase, gain_low, phase)
    if not all(math.isfinite(v) for v in values):
        status = MarginStatus.ERROR
    elif not diagonal:
        status = MarginStatus.NOT_APPLICABLE
    elif (
        min_rd >= 1 - 1e-9
        and worst_gain < 0
        and worst_phase < 0
        and gain_low <= 0.5
        and phase >= 60
    ):
        status = MarginStatus.HOLD
    else:
        status = MarginStatus.VIOLATED
    return LQRMargins(status, *values)
