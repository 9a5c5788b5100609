"""Thruster layout, allocation, pulse-width modulation and fuel (Zhang et al. 2014, issue 14).

The paper's chaser has 16 redundant 25 N thrusters A1-A16 shared by orbit and
attitude control, pseudo-inverse allocation, and pulse widths chosen so that
the impulse and angular impulse over a sample period match the command;
minimum pulse 30 ms, exhaust velocity ("specific impulse") 2900 m/s.

Body frame and wrench order
---------------------------
Body axes ``x, y, z`` with the origin at the centre of mass; a wrench is
``w = (F_x, F_y, F_z, T_x, T_y, T_z)`` (N, N m).  Thruster ``i`` at position
``r_i`` firing with force ``f_i u_i`` (``0 <= f_i <= thrust``, ``u_i`` a unit
vector) contributes the column ``[u_i; r_i x u_i]`` of the 6x16 configuration
matrix ``A``, so ``w = A f``.

Assumptions (the layout figure, Fig. 4, is lost; every item below is ours)
--------------------------------------------------------------------------
* :func:`cube_pairs_layout`: eight opposed pairs on the faces of a cube of
  half-edge ``h = 1 m`` (the paper's dimensions are lost; the radius of
  gyration of ``J = diag(3256, 2922, 3505) kg m^2`` at 2000 kg is about
  1.3 m).  Pairs (direction of the force, offset axis):
  A1-A2 ``+x`` offset ``+-y``; A3-A4 ``-x`` offset ``+-y``; A5-A6 ``+x``
  offset ``+-z``; A7-A8 ``-x`` offset ``+-z``; A9-A10 ``+y`` offset ``+-z``;
  A11-A12 ``-y`` offset ``+-z``; A13-A14 ``+z`` offset ``+-x``; A15-A16
  ``-z`` offset ``+-x``.  A thruster pushing along ``+u`` sits on the face
  ``-u``.  :func:`check_positive_spanning` proves (LP hint, exact rational
  re-check) that every wrench is a non-negative combination, i.e. the
  layout can produce any force and torque.
* The centre of mass is at the cube's centre and the body does not rotate
  appreciably within one sample period (0.2 s), so the angular impulse of
  a pulse is ``(r_i x u_i) f_i tau_i``.
* Pseudo-inverse and negative thrusts: every thruster of this layout has an
  opposed twin, so the all-ones vector is in the null space of ``A`` and
  ``1^T A^+ = 0``: the pseudo-inverse thrusts *always* sum to zero and some
  are negative for any non-zero command.  A pseudo-inverse scheme (the
  paper's) must therefore either clip (losing part of the wrench: reported
  as a shortfall) or shift along a positive null-space vector (adding the
  same thrust to opposed twins: exact wrench, more fuel).  The paper does
  not say which; :func:`pinv_allocation` implements both.
* PWM: the on-time ``tau = f dt / thrust`` is rounded to 0 or the minimum
  pulse when shorter than it (to the nearer one), pulses are centred in the
  period, and the rounding error may be carried to the next period (so the
  cumulative impulse error of a thruster stays within half a minimum pulse).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp
from scipy.optimize import linprog

from formsync_design.errors import InputError, SolverError
from formsync_design.gains import json_number

__all__ = [
    "THRUST_N",
    "MIN_PULSE_S",
    "EXHAUST_VELOCITY",
    "SAMPLE_PERIOD_S",
    "ThrusterLayout",
    "cube_pairs_layout",
    "SpanStatus",
    "SpanningResult",
    "check_positive_spanning",
    "positive_null_vector",
    "AllocationStatus",
    "Allocation",
    "pinv_allocation",
    "lp_allocation",
]

THRUST_N = 25.0  #: thrust of one thruster (N), paper section 4
MIN_PULSE_S = 0.030  #: minimum pulse width (s)
EXHAUST_VELOCITY = 2900.0  #: effective exhaust velocity (m/s)
SAMPLE_PERIOD_S = 0.2  #: control sample period (s)


@dataclass(frozen=True)
class ThrusterLayout:
    """Thruster positions and unit force directions in the body frame.

    Attributes
    ----------
    positions, directions : numpy.ndarray
        ``(m, 3)`` arrays (m, unit vectors).
    thrust : float
        Maximum (on) thrust of each thruster (N).
    names : tuple of str

    Examples
    --------
    >>> lay = cube_pairs_layout()
    >>> lay.matrix.shape, lay.names[0], lay.names[-1]
    ((6, 16), 'A1', 'A16')
    >>> lay.matrix[:, 0].tolist()  # A1: +x at (-1, 1, 0): torque -1 N m/N about z
    [1.0, 0.0, 0.0, 0.0, 0.0, -1.0]
    """

    positions: np.ndarray
    directions: np.ndarray
    thrust: float = THRUST_N
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions, dtype=float)
        dirs = np.asarray(self.directions, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != 3 or dirs.shape != pos.shape:
            raise InputError(
                f"expected positions and directions of equal shape (m, 3), received {pos.shape} and {dirs.shape}"
            )
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(dirs))):
            raise InputError(
                "expected finite thruster positions and directions, received a non-finite one"
            )
        norms = np.linalg.norm(dirs, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-12):
            raise InputError(
                f"expected unit thrust directions, received a norm of {norms[np.argmax(np.abs(norms - 1))]:g}"
            )
        if not (math.isfinite(self.thrust) and self.thrust > 0):
            raise InputError(f"expected thrust > 0 N, received {self.thrust:g}")
        names = self.names or tuple(f"A{i + 1}" for i in range(pos.shape[0]))
        if len(names) != pos.shape[0]:
            raise InputError(f"expected {pos.shape[0]} thruster names, received {len(names)}")
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "directions", dirs)
        object.__setattr__(self, "names", tuple(names))

    @property
    def count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def matrix(self) -> np.ndarray:
        """Configuration matrix ``A`` (6 x m): columns ``[u_i; r_i x u_i]``."""
        return np.vstack([self.directions.T, np.cross(self.positions, self.directions).T])

    def to_dict(self) -> dict[str, Any]:
        return {
            "names": list(self.names),
            "thrust": json_number(self.thrust),
            "positions": [[json_number(v) for v in p] for p in self.positions],
            "directions": [[json_number(v) for v in d] for d in self.directions],
        }


def cube_pairs_layout(half_size: float = 1.0, thrust: float = THRUST_N) -> ThrusterLayout:
    """The 16-thruster layout ``cube-pairs`` of a case's ``[thrusters]`` (module docstring):
    8 opposed pairs on the faces of a cube (the reconstruction of the fly-around case's lost
    Fig. 4).

    >>> lay = cube_pairs_layout()
    >>> bool(np.allclose(lay.matrix.sum(axis=1), 0))  # every thruster has an opposed twin
    True
    """
    h = float(half_size)
    if not (math.isfinite(h) and h > 0):
        raise InputError(f"expected half_size > 0 m, received {h:g}")
    e = np.eye(3)
    pos, dirs = [], []
    # (force axis, sign, offset axis)
    for axis, sign, off in [(0, 1, 1), (0, -1, 1), (0, 1, 2), (0, -1, 2),
                            (1, 1, 2), (1, -1, 2), (2, 1, 0), (2, -1, 0)]:  # fmt: skip
        u = sign * e[axis]
        for s in (1, -1):
            pos.append(-h * u + s * h * e[off])
            dirs.append(u)
    return ThrusterLayout(np.array(pos) + 0.0, np.array(dirs) + 0.0, float(thrust))


# ----- positive spanning -----


class SpanStatus(enum.StrEnum):
    """Outcome of :func:`check_positive_spanning`."""

    SPANNING = "positively-spanning"  # exact non-negative combinations of every +-e_k found
    NOT_SPANNING = "not-spanning"  # an exact separating vector y (y^T A >= 0, y^T b < 0) found
    UNDECIDED = "undecided"  # the LP hint could not be confirmed exactly
    ERROR = "error"


@dataclass(frozen=True)
class SpanningResult:
    """Evidence that ``A`` positively spans R^6 (or does not).

    Attributes
    ----------
    status : SpanStatus
    rank : int
        Exact rank of ``A`` (rational arithmetic on the float entries).
    combinations : tuple
        For each target ``+-e_k`` (``k = 0..5``, ``+`` first), the exact
        non-negative thrust combination as ``{thruster index: Fraction}``
        (empty when none was confirmed).
    separating : tuple of Fraction or None
        For ``NOT_SPANNING``: ``y`` with ``y^T A >= 0`` and ``y^T b < 0`` exactly.
    failed_target : str
        The first target without a confirmed combination ('' if none).
    """

    status: SpanStatus
    rank: int
    combinations: tuple[dict[int, Fraction], ...]
    separating: tuple[Fraction, ...] | None = None
    failed_target: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": str(self.status),
            "rank": self.rank,
            "combinations": [
                {str(i): json_number(v) for i, v in c.items()} for c in self.combinations
            ],
            "separating": None
            if self.separating is None
            else [json_number(v) for v in self.separating],
            "failed_target": self.failed_target,
        }


def _exact(a: np.ndarray) -> sp.Matrix:
    return sp.Matrix([[sp.Rational(Fraction(float(v))) for v in row] for row in np.atleast_2d(a)])


def _target_name(k: int, sign: int) -> str:
    return ("+" if sign > 0 else "-") + ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")[k]


def check_positive_spanning(layout: ThrusterLayout) -> SpanningResult:
    """Decide whether every wrench is a non-negative combination of the thrusters.

    The cone ``{A f : f >= 0}`` is all of R^6 iff it contains ``+-e_k`` for
    ``k = 0..5``.  For each, an LP (scipy HiGHS) finds a vertex ``f >= 0``
    with ``A f = +-e_k`` (a hint); the decision is the exact rational solve
    of ``A_S f_S = +-e_k`` on its support ``S`` with ``f_S >= 0`` checked
    exactly.  An infeasible LP is confirmed by an exact Farkas vector
    ``y`` (``y^T A >= 0``, ``y^T b = -1``).

    Examples
    --------
    >>> res = check_positive_spanning(cube_pairs_layout())
    >>> str(res.status), res.rank, res.combinations[0]  # +F_x: A1 and A2 together
    ('positively-spanning', 6, {0: Fraction(1, 2), 1: Fraction(1, 2)})

    Half of the layout (only +x, +y, +z thrusters) cannot pull:

    >>> half = cube_pairs_layout()
    >>> keep = [0, 1, 4, 5, 8, 9, 12, 13]
    >>> sub = ThrusterLayout(half.positions[keep], half.directions[keep])
    >>> r = check_positive_spanning(sub)
    >>> str(r.status), r.failed_target
    ('not-spanning', '-Fx')
    """
    a = layout.matrix
    m = layout.count
    exact_a = _exact(a)
    rank = int(exact_a.rank())
    combos: list[dict[int, Fraction]] = []
    for k in range(6):
        for sign in (1, -1):
            b = np.zeros(6)
            b[k] = sign
            name = _target_name(k, sign)
            lp = linprog(np.ones(m), A_eq=a, b_eq=b, bounds=[(0, None)] * m, method="highs")
            if lp.status == 0:
                support = [i for i in range(m) if lp.x[i] > 1e-12]
                sub = exact_a[:, support]
                rhs = sp.Matrix([sp.Integer(int(v)) for v in b])
                try:
                    sol, params = sub.gauss_jordan_solve(rhs)
                except ValueError:
                    return SpanningResult(SpanStatus.UNDECIDED, rank, tuple(combos), None, name)
                sol = sol.subs({p: 0 for p in params})
                if any(v < 0 for v in sol) or sub * sol != rhs:
                    return SpanningResult(SpanStatus.UNDECIDED, rank, tuple(combos), None, name)
                combos.append(
                    {i: Fraction(int(v.p), int(v.q)) for i, v in zip(support, sol) if v != 0}
                )
                continue
            if lp.status != 2:  # neither solved nor infeasible
                return SpanningResult(SpanStatus.ERROR, rank, tuple(combos), None, name)
            # Farkas: y^T A >= 0, y^T b = -1
            far = linprog(
                np.zeros(6), A_ub=-a.T, b_ub=np.zeros(m), A_eq=b[None, :], b_eq=[-1.0],
                bounds=[(-1e3, 1e3)] * 6, method="highs",
            )  # fmt: skip
            if far.status != 0:
                return SpanningResult(SpanStatus.UNDECIDED, rank, tuple(combos), None, name)
            y = [Fraction(float(v)).limit_denominator(10**6) for v in far.x]
            ya = sp.Matrix([[sp.Rational(v) for v in y]]) * exact_a
            yb = sum(sp.Rational(v) * int(bb) for v, bb in zip(y, b))
            if all(v >= 0 for v in ya) and yb < 0:
                return SpanningResult(SpanStatus.NOT_SPANNING, rank, tuple(combos), tuple(y), name)
            return SpanningResult(SpanStatus.UNDECIDED, rank, tuple(combos), None, name)
    return SpanningResult(SpanStatus.SPANNING, rank, tuple(combos))


def positive_null_vector(layout: ThrusterLayout) -> np.ndarray:
    """A null vector ``z`` of ``A`` with ``min z`` maximal (``max z = 1``).

    Exists with ``min z > 0`` iff the layout positively spans (with full rank);
    raises :class:`InputError` otherwise.

    >>> positive_null_vector(cube_pairs_layout()).round(12).tolist() == [1.0] * 16
    True
    """
    a = layout.matrix
    m = layout.count
    # variables (z, t): maximize t s.t. A z = 0, t <= z_i <= 1
    c = np.zeros(m + 1)
    c[-1] = -1.0
    a_ub = np.hstack([-np.eye(m), np.ones((m, 1))])
    lp = linprog(
        c, A_ub=a_ub, b_ub=np.zeros(m), A_eq=np.hstack([a, np.zeros((6, 1))]), b_eq=np.zeros(6),
        bounds=[(0, 1)] * m + [(0, 1)], method="highs",
    )  # fmt: skip
    if lp.status != 0:
        raise SolverError(
            f"the null-space LP failed (HiGHS status {lp.status}); check the layout for NaN"
        )
    if lp.x[-1] <= 1e-9:
        raise InputError(
            "expected a layout with a strictly positive null vector (positively spanning), received one without"
        )
    z = lp.x[:m] / lp.x[:m].max()
    # polish: project back onto the null space
    z = z - np.linalg.pinv(a) @ (a @ z)
    return z


# ----- allocation -----


class AllocationStatus(enum.StrEnum):
    """Outcome of an allocation."""

    EXACT = "exact"  # the thrusts reproduce the commanded wrench within tolerance
    SHORTFALL = "shortfall"  # within the thrust limits the wrench is not reproduced
    ERROR = "error"


@dataclass(frozen=True)
class Allocation:
    """Thrusts for one commanded wrench.

    Attributes
    ----------
    status : AllocationStatus
    method : str
        ``pinv``, ``pinv-clip``, ``pinv-shift`` or ``lp``.
    thrusts : numpy.ndarray
        Per-thruster force (N), within ``[0, thrust]`` except for ``pinv``.
    commanded, achieved, shortfall : numpy.ndarray
        Wrenches; ``shortfall = commanded - achieved``.
    raw_min : float
        Most negative raw pseudo-inverse thrust (N) (0 for ``lp``).
    total_thrust : float
        ``sum(thrusts)`` (N): fuel rate ``= total_thrust / v_e``.
    """

    status: AllocationStatus
    method: str
    thrusts: np.ndarray
    commanded: np.ndarray
    achieved: np.ndarray
    shortfall: np.ndarray
    raw_min: float
    total_thrust: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": str(self.status),
            "method": self.method,
            "thrusts": [json_number(v) for v in self.thrusts],
            "shortfall": [json_number(v) for v in self.shortfall],
            "raw_min": json_number(self.raw_min),
            "total_thrust": json_number(self.total_thrust),
        }


def _wrench(value: Any) -> np.ndarray:
    w = np.asarray(value, dtype=float)
    if w.shape != (6,) or not np.all(np.isfinite(w)):
        raise InputError(
            f"expected a wrench as 6 finite numbers (Fx, Fy, Fz, Tx, Ty, Tz), received shape {w.shape}"
        )
    return w


def _result(
    layout: ThrusterLayout, method: str, f: np.ndarray, w: np.ndarray, raw_min: float, tol: float
) -> Allocation:
    achieved = layout.matrix @ f
    short = w - achieved
    scale = max(1.0, float(np.abs(w).max()))
    status = (
        AllocationStatus.EXACT
        if float(np.abs(short).max()) <= tol * scale
        else AllocationStatus.SHORTFALL
    )
    return Allocation(status, method, f, w, achieved, short, raw_min, float(f.sum()))


def pinv_allocation(
    layout: ThrusterLayout,
    wrench: Any,
    negative: str = "shift",
    tol: float = 1e-9,
    null_vector: Any = None,
) -> Allocation:
    """Pseudo-inverse allocation ``f = A^+ w`` with a rule for negative thrusts.

    ``negative="none"``: the raw ``A^+ w`` (negative and unbounded thrusts; for
    analysis only); ``"clip"``: clip to ``[0, thrust]``; ``"shift"``: add the
    smallest multiple of :func:`positive_null_vector` that makes every thrust
    non-negative (the wrench is unchanged), then clip to ``thrust``.  A wrench
    not reproduced is reported as a ``SHORTFALL``.  In a control loop, pass
    the layout's ``null_vector`` (computed once) to skip its LP.

    Examples
    --------
    >>> lay = cube_pairs_layout()
    >>> w = [10.0, 0, 0, 0, 0, 5.0]
    >>> raw = pinv_allocation(lay, w, "none")
    >>> round(raw.total_thrust, 12) + 0.0, raw.raw_min < 0  # sums to zero: negative thrusts
    (0.0, True)
    >>> str(pinv_allocation(lay, w, "clip").status), str(pinv_allocation(lay, w, "shift").status)
    ('shortfall', 'exact')
    """
    if negative not in ("none", "clip", "shift"):
        raise InputError(f"expected negative in ('none', 'clip', 'shift'), received {negative!r}")
    w = _wrench(wrench)
    f = np.linalg.pinv(layout.matrix) @ w
    raw_min = float(min(f.min(), 0.0))
    if negative == "none":
        return _result(layout, "pinv", f, w, raw_min, tol)
    if negative == "shift":
        z = positive_null_vector(layout) if null_vector is None else np.asarray(null_vector, float)
        if z.shape != (layout.count,) or not (np.all(np.isfinite(z)) and z.min() > 0):
            raise InputError(
                f"expected null_vector as {layout.count} positive numbers, received shape {z.shape}"
            )
        f = f + max(0.0, float(np.max(-f / z))) * z
    f = np.clip(f, 0.0, layout.thrust)
    return _result(layout, "pinv-" + negative, f, w, raw_min, tol)


def lp_allocation(layout: ThrusterLayout, wrench: Any, tol: float = 1e-9) -> Allocation:
    """Minimum-fuel allocation by linear programming (scipy HiGHS), thrusts in ``[0, thrust]``.

    Stage 1 minimizes the shortfall ``sum |w - A f|`` (forces in N and torques
    in N m, unweighted); stage 2 minimizes ``sum f`` (fuel) among the
    allocations producing the wrench stage 1 achieved (``w`` itself when
    reachable).  An LP failure gives status
    ``ERROR``.

    Examples
    --------
    >>> lay = cube_pairs_layout()
    >>> a = lp_allocation(lay, [10.0, 0, 0, 0, 0, 5.0])
    >>> str(a.status), round(a.total_thrust, 9)
    ('exact', 10.0)
    >>> big = lp_allocation(lay, [150.0, 0, 0, 0, 0, 0])  # four thrusters push +x: 100 N at most
    >>> str(big.status), round(float(big.shortfall[0]), 6)
    ('shortfall', 50.0)
    """
    w = _wrench(wrench)
    a = layout.matrix
    m = layout.count
    # variables (f, s+, s-): A f + s+ - s- = w
    a_eq = np.hstack([a, np.eye(6), -np.eye(6)])
    bounds = [(0.0, layout.thrust)] * m + [(0.0, None)] * 12
    c1 = np.concatenate([np.zeros(m), np.ones(12)])
    st1 = linprog(c1, A_eq=a_eq, b_eq=w, bounds=bounds, method="highs")
    if st1.status != 0:
        nan6 = np.full(6, np.nan)
        return Allocation(
            AllocationStatus.ERROR, "lp", np.full(m, np.nan), w, nan6, nan6, 0.0, math.nan
        )
    achievable = a @ np.clip(st1.x[:m], 0.0, layout.thrust)
    if float(st1.fun) <= tol * max(1.0, float(np.abs(w).max())):
        achievable = w
    st2 = linprog(
        np.ones(m), A_eq=a, b_eq=achievable, bounds=[(0.0, layout.thrust)] * m, method="highs"
    )
    x = st2.x if st2.status == 0 else st1.x
    f = np.clip(x[:m], 0.0, layout.thrust)
    return _result(layout, "lp", f, w, 0.0, tol)


