"""Inputs of a simulation: the formation (graph, inertias, initial state, gains,
disturbance), the options and the state layout (the run statuses are
:class:`~formsync_design.sim.result.SimStatus`).

State layout (pydy style: coordinates, then speeds): ``x = (q1_1, q2_1, q3_1,
q0_1, ..., q1_N, q2_N, q3_N, q0_N, w1_1, w2_1, w3_1, ..., w1_N, w2_N, w3_N)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.graphs.build import Graph
from formsync_design.models.disturbances import DisturbanceModel
from formsync_design.models.inertia import check_inertias
from formsync_design.sim.bridge import SWITCHES

__all__ = [
    "Gains",
    "Formation",
    "SimOptions",
    "INTEGRATORS",
    "DEFAULT_STEP",
    "MAX_GRID_POINTS",
    "state_names",
    "pack_state",
    "unpack_state",
]

INTEGRATORS = ("auto", "rk4", "dopri5", "cvodes")

#: The RK4 step when none is given (s).
DEFAULT_STEP = 0.05


#: Largest number of output grid points of one run (``tf / output_step``): the
#: trajectory is kept in memory (7N + 3N floats per point).
MAX_GRID_POINTS = 10_000_000


def state_names(n: int) -> list[str]:
    """Names of the state entries (module docstring for the layout).

    >>> state_names(2)[:4], state_names(2)[8:11]
    (['q1_1', 'q2_1', 'q3_1', 'q0_1'], ['w1_1', 'w2_1', 'w3_1'])
    """
    quat = [f"{c}_{i}" for i in range(1, n + 1) for c in ("q1", "q2", "q3", "q0")]
    rates = [f"{c}_{i}" for i in range(1, n + 1) for c in ("w1", "w2", "w3")]
    return quat + rates


def pack_state(quaternions: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """``(N, 4)`` quaternions ``(q1, q2, q3, q0)`` and ``(N, 3)`` rates -> state vector.

    >>> pack_state(np.array([[0, 0, 0, 1.0]]), np.array([[1.0, 2, 3]])).tolist()
    [0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 3.0]
    """
    return np.concatenate([np.asarray(quaternions, float).ravel(), np.asarray(rates, float).ravel()])


def unpack_state(x: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """State vector(s) ``(..., 7N)`` -> quaternions ``(..., N, 4)`` and rates ``(..., N, 3)``."""
    x = np.asarray(x, dtype=float)
    return x[..., : 4 * n].reshape(*x.shape[:-1], n, 4), x[..., 4 * n :].reshape(*x.shape[:-1], n, 3)


# ---------------------------------------------------------------------------
# inputs


#: The classic gain names (Liang et al. 2016), the positional form of :class:`Gains`.
CLASSIC_GAIN_NAMES: tuple[str, ...] = ("K_o", "K_q", "beta")


def _gain_value(name: str, v: Any) -> float | tuple[float, float, float]:
    """A positive finite scalar, or three of them (a diagonal gain)."""
    if isinstance(v, (tuple, list, np.ndarray)):
        vals = [_gain_value(name, x) for x in np.asarray(v, dtype=object).ravel()]
        if len(vals) != 3:
            raise InputError(f"expected a scalar or 3 diagonal entries for gain {name}, received "
                             f"{len(vals)} values")
        return (float(vals[0]), float(vals[1]), float(vals[2]))  # type: ignore[arg-type]
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.number)):
        raise InputError(f"expected a positive finite gain {name}, received {type(v).__name__}")
    if not math.isfinite(float(v)) or v <= 0:
        raise InputError(f"expected a positive finite gain {name}, received {float(v):g}")
    return float(v)


@dataclass(frozen=True, init=False)
class Gains:
    """Controller gains of a design (by name, in the design's order) and the switching
    gain ``K_v`` per spacecraft (empty or zeros for a design without a switching term).

    ``Gains(K_o, K_q, beta, K_v)`` (positional) gives the classic gains of liang2016;
    ``Gains({"k_p": 0.5, "k_d": 1.2})`` or ``Gains(k_p=0.5, k_d=1.2)`` any design's.  A
    diagonal gain is three values.  Each gain is also an attribute (``g.K_o``).

    >>> Gains(1.6, 0.4, 0.3, (0.01,) * 8).K_v[0]
    0.01
    >>> g = Gains(k_p=0.5, k_d=(1.0, 1.2, 1.4))
    >>> g.names, g.vector(), g.K_v
    (('k_p', 'k_d'), [0.5, 1.0, 1.2, 1.4], ())
    """

    values: tuple[tuple[str, Any], ...]
    K_v: tuple[float, ...]

    def __init__(self, *args: Any, K_v: Any = (), values: Any = None, **named: Any) -> None:
        if args and isinstance(args[0], Mapping):
            if len(args) > 2 or values is not None or named:
                raise InputError("expected Gains(mapping[, K_v]), received more arguments")
            items = list(args[0].items())
            if len(args) == 2:
                K_v = args[1]
        elif args:
            if len(args) != 4 or values is not None or named:
                raise InputError("expected Gains(K_o, K_q, beta, K_v) or gains by name, received "
                                 f"{len(args)} positional values")
            items = list(zip(CLASSIC_GAIN_NAMES, args[:3]))
            K_v = args[3]
        elif values is not None:
            items = list(values.items()) if isinstance(values, Mapping) else list(values)
        else:
            items = list(named.items())
        if not items:
            raise InputError("expected at least one controller gain, received none")
        names = [str(n) for n, _ in items]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"expected each gain once, received {dup} more than once")
        vals = tuple((str(n), _gain_value(str(n), v)) for n, v in items)
        try:
            kv = tuple(float(k) for k in np.atleast_1d(np.asarray(K_v, dtype=float)))
        except (TypeError, ValueError):
            raise InputError(f"expected numeric K_v values, received {type(K_v).__name__}") from None
        bad = [k for k in kv if not (math.isfinite(k) and k >= 0)]
        if bad:
            raise InputError(f"expected finite K_v >= 0, received {bad[0]:g}")
        object.__setattr__(self, "values", vals)
        object.__setattr__(self, "K_v", kv)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        for n, v in object.__getattribute__(self, "values"):
            if n == name:
                return v
        raise AttributeError(f"{type(self).__name__!s} has no gain {name!r}")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for n, _ in self.values)

    def as_dict(self) -> dict[str, Any]:
        return dict(self.values)

    def vector(self, names: tuple[str, ...] | None = None) -> list[float]:
        """The values in ``names`` order (default: own order), a diagonal gain as 3 entries."""
        d = self.as_dict()
        order = self.names if names is None else names
        missing = [n for n in order if n not in d]
        if missing or (names is not None and set(d) - set(order)):
            raise InputError(f"expected the gains {', '.join(order)}, received "
                             f"{', '.join(self.names)}")
        out: list[float] = []
        for n in order:
            v = d[n]
            out.extend(v if isinstance(v, tuple) else (v,))
        return out


@dataclass(frozen=True)
class Formation:
    """Everything physical about a formation run.

    Attributes
    ----------
    graph : Graph
    inertias : numpy.ndarray, shape (N, 3, 3), kg m^2, symmetric positive definite
    attitudes : numpy.ndarray, shape (N, 4), ``(q1, q2, q3, q0)``, unit, ``q0 > 0``
    rates : numpy.ndarray, shape (N, 3), rad/s (body frame)
    gains : Gains
    disturbance : DisturbanceModel
    """

    graph: Graph
    inertias: np.ndarray
    attitudes: np.ndarray
    rates: np.ndarray
    gains: Gains
    disturbance: DisturbanceModel

    def __post_init__(self) -> None:
        n = self.graph.n
        J = check_inertias(self.inertias, n)
        Q = _array(self.attitudes, "attitudes")
        if Q.shape != (n, 4):
            raise InputError(f"expected {n} quaternions (q1, q2, q3, q0), received shape {Q.shape}")
        ok = Q.size > 0 and bool(np.all(np.abs(np.linalg.norm(Q, axis=1) - 1) <= 1e-9)
                             and np.all(Q[:, 3] > 0))
        for i, qb in enumerate(() if ok else Q):  # only to name the first bad one
            nrm = float(np.linalg.norm(qb))
            if abs(nrm - 1) > 1e-9:
                raise InputError(f"expected a unit quaternion for spacecraft {i + 1}, received norm {nrm:.12g}")
            if qb[3] <= 0:
                raise InputError(
                    f"expected q0 > 0 for spacecraft {i + 1} (controller (4) needs q0 != 0), "
                    f"received q0 = {float(qb[3]):g}"
                )
        W = _array(self.rates, "rates")
        if W.shape != (n, 3):
            raise InputError(f"expected {n} rate vectors of length 3, received shape {W.shape}")
        if len(self.gains.K_v) == 1:
            object.__setattr__(self, "gains", replace(self.gains, K_v=self.gains.K_v * n))
        elif len(self.gains.K_v) == 0:  # a design without a switching term
            object.__setattr__(self, "gains", replace(self.gains, K_v=(0.0,) * n))
        if len(self.gains.K_v) != n:
            raise InputError(f"expected {n} values of K_v (one per spacecraft), received {len(self.gains.K_v)}")
        if self.disturbance.n != n:
            raise InputError(f"expected a disturbance for {n} spacecraft, received {self.disturbance.n}")
        for name, a in (("inertias", J), ("attitudes", Q), ("rates", W)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def n(self) -> int:
        return self.graph.n

    def initial_state(self) -> np.ndarray:
        """The state vector (module docstring for the layout)."""
        return pack_state(self.attitudes, self.rates)


def _array(a: Any, name: str) -> np.ndarray:
    try:
        out = np.array(a, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected a numeric array for {name}, received a {type(a).__name__}") from None
    if not np.all(np.isfinite(out)):
        raise InputError(f"expected finite {name}, received NaN/inf")
    return out


@dataclass(frozen=True)
class SimOptions:
    """Simulation options (defaults documented per field).

    Attributes
    ----------
    tf : float
        Horizon (s), default 200.
    switch : {"sgn", "sat", "tanh"}
        Switching term, default ``sat``.
    phi : float
        Boundary layer of ``sat``/``tanh`` (default 0.01; the paper does not print it).
    torque_limit : float or None
        Per-axis actuator limit ``|u_k| <= torque_limit`` (N m); None = unlimited.
    sample_period : float or None
        Zero-order-hold control period Ts (s); None = continuous control.
    integrator : {"auto", "rk4", "dopri5", "cvodes"}
        ``auto`` (default): ``rk4`` when a ``step`` is given or the switch is ``sgn``
        (a discontinuous law is simulated as a digital controller at the step rate),
        else ``dopri5`` (adaptive Dormand-Prince 5(4) at ``rtol``/``atol``, whose default
        tolerances meet the error budget stated in the README).  All but ``cvodes`` run
        in the compiled whole-horizon kernel (:mod:`formsync_design.sim.native`).
    step : float or None
        Largest RK4 step (s), default None = 0.05 (:data:`DEFAULT_STEP`); each output
        interval is split into ``ceil(interval / step)`` equal sub-steps.  A step longer
        than the output interval cannot be honoured and is an error (not clamped), and so
        is a step with ``dopri5`` or ``cvodes`` (use ``max_step``).
    max_step : float or None
        Largest step of ``dopri5``/``cvodes`` (s); None = unbounded.
    output_step : float
        Output grid spacing (s), default 0.1 (the sample period under ZOH).  ``tf``
        must be a whole multiple of it (of the sample period under ZOH), and
        ``tf / interval`` at most :data:`MAX_GRID_POINTS`.
    rtol, atol : float
        Tolerances of ``dopri5`` and ``cvodes`` (defaults 1e-8, 1e-12: the error budget of
        the README - every quantity the verification judges within 1e-5 relative of a
        tight reference on the paper's case, its topologies and its sensitivity study).
    event_tol : float
        Time tolerance (s) to which events are located on the integrator's interpolant:
        ``q0`` reaching ``q0_floor`` (the stop) and the first/last switching and
        torque-limit crossings (default 1e-9).
    q_tol, omega_tol : float
        Convergence thresholds on Q_m (-) and Omega_m (rad/s), defaults 1e-4, 1e-5.
    q0_floor : float
        Singularity detection: stop when some ``q0_i <= q0_floor`` (default 0.02, where
        ``|omega| ~ 2|q'|/q0`` is 100 ``|q'|`` and ``cond(Q) = 1/q0`` is 50).
    norm_tol : float
        Maximum tolerated quaternion norm drift (default 1e-5; the paper's case with
        ``sat`` drifts 1e-7 at the default step, ``sgn`` chattering ~1e-6 over 200 s).
    compile : bool
        Compile the RK4 kernel to C (default True); False uses CasADi's VM.
    inverse : {"E", "solve"}
        How the bridge evaluates ``Q^{-1}``.
    """

    tf: float = 200.0
    switch: str = "sat"
    phi: float = 0.01
    torque_limit: float | None = None
    sample_period: float | None = None
    integrator: str = "auto"
    step: float | None = None
    output_step: float = 0.1
    rtol: float = 1e-8
    atol: float = 1e-12
    q_tol: float = 1e-4
    omega_tol: float = 1e-5
    q0_floor: float = 0.02
    norm_tol: float = 1e-5
    compile: bool = True
    inverse: str = "E"
    max_step: float | None = None
    event_tol: float = 1e-9

    def __post_init__(self) -> None:
        if self.switch not in SWITCHES:
            raise InputError(f"expected switch in {SWITCHES}, received {self.switch!r}")
        if self.integrator not in INTEGRATORS:
            raise InputError(f"expected integrator in {INTEGRATORS}, received {self.integrator!r}")
        for name in ("tf", "phi", "output_step", "rtol", "atol", "q_tol", "omega_tol", "norm_tol",
                     "event_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                shown = f"{v:g}" if isinstance(v, (int, float)) else type(v).__name__
                raise InputError(f"expected a positive finite {name}, received {shown}")
        if not (isinstance(self.q0_floor, (int, float)) and 0 <= self.q0_floor < 1):
            raise InputError(f"expected 0 <= q0_floor < 1, received {self.q0_floor}")
        for name in ("torque_limit", "sample_period", "step", "max_step"):
            v = getattr(self, name)
            if v is not None and (not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0):
                shown = f"{v:g}" if isinstance(v, (int, float)) else type(v).__name__
                raise InputError(f"expected a positive finite {name} or none, received {shown}")
        if self.sample_period is not None and self.integrator == "cvodes":
            raise InputError(
                "expected integrator 'auto', 'rk4' or 'dopri5' with a sample period (zero-order "
                f"hold), received {self.integrator!r}"
            )
        if self.switch == "sgn" and self.integrator == "dopri5":
            raise InputError(
                "expected integrator 'rk4' (or 'auto') with the discontinuous sgn switch (an "
                "adaptive step would chase its sliding mode), received 'dopri5'"
            )
        if self.step is not None and self.integrator in ("dopri5", "cvodes"):
            raise InputError(
                f"expected no step with integrator {self.integrator!r} (step is the RK4 step; "
                f"use max_step), received step {self.step:g} s"
            )
        if self.max_step is not None and self.method == "rk4":
            raise InputError(
                "expected max_step with an adaptive integrator (dopri5, cvodes), received "
                f"integrator {self.integrator!r}" + (f" with step {self.step:g} s" if self.step else "")
            )
        if self.inverse not in ("E", "solve"):
            raise InputError(f"expected inverse 'E' or 'solve', received {self.inverse!r}")
        iv = self.interval
        if self.method == "rk4" and self.rk4_step > iv * (1 + 1e-12):
            what = "sample period" if self.sample_period is not None else "output step"
            raise InputError(
                f"expected an RK4 step <= the {what} ({iv:g} s), received step {self.rk4_step:g} s; "
                f"use a smaller step or a longer {what}"
            )
        ratio = self.tf / iv
        if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
            what = "sample period" if self.sample_period is not None else "output step"
            raise InputError(
                f"expected tf to be a whole multiple of the {what} ({iv:g} s), received tf = "
                f"{self.tf:g} s ({ratio:.6g} intervals)"
            )
        if ratio > MAX_GRID_POINTS:
            raise InputError(
                f"expected at most {MAX_GRID_POINTS:g} output intervals (tf / output step), received "
                f"{ratio:.4g}; use a longer output step or a shorter tf"
            )

    @property
    def interval(self) -> float:
        """Output-grid spacing actually used (the sample period under ZOH)."""
        return float(self.sample_period) if self.sample_period is not None else float(self.output_step)

    @property
    def method(self) -> str:
        """The integrator actually used (``auto`` resolved, see the class docstring).

        >>> SimOptions().method, SimOptions(step=0.01).method, SimOptions(switch="sgn").method
        ('dopri5', 'rk4', 'rk4')
        """
        if self.integrator != "auto":
            return self.integrator
        return "rk4" if (self.step is not None or self.switch == "sgn") else "dopri5"

    @property
    def rk4_step(self) -> float:
        """The RK4 step (``step``, else :data:`DEFAULT_STEP`)."""
        return float(self.step) if self.step is not None else DEFAULT_STEP

    @property
    def substeps(self) -> int:
        """RK4 sub-steps per output interval (``ceil(interval/step)``)."""
        return max(1, math.ceil(self.interval / self.rk4_step - 1e-9))
