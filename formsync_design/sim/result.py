"""The result of every attitude-formation simulation run: a frozen :class:`SimResult` and its
status :class:`SimStatus`.

One type for the three producers: the Lagrangian simulator
(:func:`~formsync_design.sim.simulator.simulate` of a quaternion specification), the agent
designs' drivers (:func:`~formsync_design.sim.agents.simulate_agents`, continuous and sampled;
``simulate`` of an agent design dispatches there) and the fly-around of a design on the
relative-orbit plant (:func:`~formsync_design.sim.tracking.simulate_flyaround`; ``simulate`` of a
``FlyaroundScenario``), a formation of one spacecraft.  The fields every run has (the
trajectory, torques, the attitude and rate disagreement, peak torque, effort, ...) are filled
by all; the Lagrangian simulator's measures (``omega_m``, ``q_m``, ``min_q0``, the singular
stop, ...) are ``None`` in the other runs, an agent design's controller states, reference,
monitors and transmissions are empty/``None`` in a Lagrangian run, and only a fly-around has
``orbit`` (:class:`~formsync_design.sim.orbit_record.OrbitRecord`: the relative orbit, the
per-sample outputs of the loop, the thrusters' fuel and velocity increments).

The convergence criterion is the producer's, stated in its options: ``Q_m <= q_tol`` and
``Omega_m <= omega_tol`` (:class:`~formsync_design.sim.formation.SimOptions`) for the
Lagrangian simulator, the attitude and rate disagreement (and the errors to the reference)
within ``angle_tol``/``rate_tol`` (:class:`~formsync_design.sim.agents.AgentOptions`) for an
agent design, the attitude tracking error angle and the relative-position error within
``angle_tol``/``position_tol`` (:class:`~formsync_design.sim.tracking_scenario.
FlyaroundOptions`) for a fly-around.  (The Monte-Carlo summaries have types of their own.)
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar, overload

import numpy as np

from formsync_design.gains import json_number
from formsync_design.notebook import NotebookViews
from formsync_design.sim.disagreement import attitude_disagreement, rate_disagreement, settle_time
from formsync_design.sim.formation import SimOptions, state_names

if TYPE_CHECKING:
    from formsync_design.sim.orbit_record import OrbitRecord

__all__ = ["SimResult", "SimStatus", "STATUSES"]


class SimStatus(enum.StrEnum):
    """How a simulation run ended.

    ``converged``: the run's criterion (its options: ``Q_m``/``Omega_m`` within
    ``q_tol``/``omega_tol`` for the Lagrangian simulator; the attitude and rate disagreement,
    and the errors to the reference, within ``angle_tol``/``rate_tol`` for an agent design;
    the attitude tracking error angle ``4 atan|sigma_sd|`` within ``angle_tol`` (deg) and the
    relative-position error within ``position_tol`` (m) for a fly-around) holds from
    ``convergence_time`` to the horizon (a fly-around: to its last sample); ``not-converged``:
    the horizon was reached without that (``convergence_time`` is None); ``singular``
    (Lagrangian simulator): stopped early at the ``q0 -> 0`` singularity
    (``singular_spacecraft``, ``singular_time``; every measure describes the trajectory up to
    the stop only); ``diverged``: the state became non-finite (away from the singularity;
    ``diverged_time``, the trajectory ends before it);
    ``stopped`` (sampled agent designs): the hybrid integrator stopped (Zeno protection or too
    many triggers, ``message`` says which).
    """

    CONVERGED = "converged"
    NOT_CONVERGED = "not-converged"
    SINGULAR = "singular"
    DIVERGED = "diverged"
    STOPPED = "stopped"


STATUSES = tuple(s.value for s in SimStatus)


_R = TypeVar("_R")


class _FromTrajectory(Generic[_R]):
    """A field of :class:`SimResult` that a producer may leave ``None``: it is then computed
    from the trajectory on first read (and kept, read-only).  The measures an agent run needs
    for its convergence criterion are given; the Lagrangian simulator leaves them, since they
    cost ``O(T N^2)`` (every pair of spacecraft at every output time) - more than the compiled
    run itself - and most of its callers never read them."""

    def __init__(self, compute: Any) -> None:
        self._compute = compute
        self._slot = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self._slot = "_" + name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> None: ...
    @overload
    def __get__(self, obj: _R, owner: type | None = None) -> np.ndarray: ...

    def __get__(self, obj: Any, owner: type | None = None) -> np.ndarray | None:
        if obj is None:  # the dataclass's default: None, computed on first read
            return None
        value = obj.__dict__.get(self._slot)
        if value is None:
            value = self._compute(obj)
            value.setflags(write=False)
            obj.__dict__[self._slot] = value
        return value

    def __set__(self, obj: Any, value: np.ndarray | None) -> None:
        obj.__dict__[self._slot] = value


def _effort(r: SimResult) -> np.ndarray:
    sq = np.sum(r.torques * r.torques, axis=2)
    return np.asarray(np.trapezoid(sq, r.t, axis=0), float)


@dataclass(frozen=True, kw_only=True)
class SimResult(NotebookViews):
    """A finished simulation run of a formation (frozen; arrays are per output time).

    Attributes
    ----------
    status : SimStatus; message : str (one line a user can act on; empty for an agent run
        that converged or did not)
    design : str (the specification's or agent design's name); graph : str (its name; a
        fly-around: ``none (one spacecraft tracking a target)``)
    t : (T,) output grid (s); quaternions : (T, N, 4) ``(q1, q2, q3, q0)``; rates : (T, N, 3)
        body rates (rad/s); states : (T, N, nz) controller states (``nz = 0`` for the
        Lagrangian simulator); torques : (T, N, 3) control torques (N m, limited; ``torques[k]``
        acts on ``[t_k, t_{k+1})`` exactly under a hold, the value at ``t_k`` otherwise);
        reference : (T, 4) or None
    attitude_error : (T,) largest pairwise principal angle (deg)
    reference_error : (T,) or None, largest angle to the reference (deg)
    rate_error : (T,) largest pairwise body-rate difference (rad/s; to the reference rate
        with a leader, given by the producer)
    convergence_time : float or None
        First output time from which the producer's criterion (module docstring) holds to the
        end; None when not reached within the horizon or when the run stopped early.
    peak_torque : (N, 3) max ``|u|`` per spacecraft and axis (N m); effort : (N,)
        ``int |u_i|^2 dt`` (trapezoid on the output grid, exact for held torques of sampled
        agent designs)

    ``attitude_error``, ``rate_error`` and ``effort`` given as None (the Lagrangian
    simulator's) are computed from the trajectory on first read
    (:mod:`~formsync_design.sim.disagreement`, the trapezoid rule), then kept.
    monitors : dict name -> (T, N) (an agent design's monitors)
    transmissions : (N,) or None; min_interevent, mean_interevent : (N,) or None;
    trigger_times : per spacecraft or None (sampled agent designs)
    state_names : tuple of str (the producer's state order); integrator : str (the method used)
    diverged_time : float or None, when the state became non-finite (status ``diverged``)

    A fly-around (one spacecraft, :mod:`~formsync_design.sim.orbit_record`): ``t`` the
    control instants ``t_k`` (the state at the end of the last sample is in
    ``orbit.states``); quaternions and rates the truth attitude (from its MRP) and body rate
    at ``t_k``; torques the torque the PWM pulses realise, averaged over the sample (held on
    ``[t_k, t_k + dt)``; effort ``sum_k |u_k|^2 dt`` of these averages); reference the desired
    attitude ``q_d = q (x) q_sd^*``; reference_error the tracking error angle
    ``4 atan|sigma_sd|`` (deg); rate_error ``|omega_sd|`` (rad/s); states ``(T, 1, 0)``.
    orbit : OrbitRecord or None
        The relative orbit and the thrusters of a fly-around (None in every other run).

    The Lagrangian simulator's extras (None/empty in an agent run):

    omega_m, q_m : (T,) the paper's relative measures ``Omega_m`` and ``Q_m``
    min_q0 : (N,) smallest ``q0`` over all sub-steps; singular_spacecraft (1-based) /
        singular_time when the ``q0 -> 0`` singularity was hit (None otherwise)
    saturation_end_time : last grid time with some torque component at ``torque_limit``
        (None without a limit or if never reached)
    stats : dict - integrator, steps, rhs evaluations, wall/compile seconds, max norm error
    options : the options object of the run (``SimOptions``; ``AgentOptions`` in an agent run)
    spec_key : str, content key of the specification (or design) simulated
    """

    status: SimStatus
    message: str
    design: str
    graph: str
    t: np.ndarray
    quaternions: np.ndarray
    rates: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    reference: np.ndarray | None
    attitude_error: _FromTrajectory[SimResult] = _FromTrajectory(
        lambda r: attitude_disagreement(r.quaternions))
    reference_error: np.ndarray | None
    rate_error: _FromTrajectory[SimResult] = _FromTrajectory(lambda r: rate_disagreement(r.rates))
    convergence_time: float | None
    peak_torque: np.ndarray
    effort: _FromTrajectory[SimResult] = _FromTrajectory(_effort)
    monitors: dict[str, np.ndarray]
    transmissions: np.ndarray | None = None
    min_interevent: np.ndarray | None = None
    mean_interevent: np.ndarray | None = None
    trigger_times: tuple[np.ndarray, ...] | None = None
    state_names: tuple[str, ...] = ()
    integrator: str = "rk4"
    diverged_time: float | None = None
    omega_m: np.ndarray | None = None
    q_m: np.ndarray | None = None
    min_q0: np.ndarray | None = None
    singular_spacecraft: int | None = None
    singular_time: float | None = None
    saturation_end_time: float | None = None
    stats: dict[str, Any] = field(default_factory=dict)
    options: Any = None
    spec_key: str = ""
    orbit: OrbitRecord | None = None

    @property
    def n(self) -> int:
        """Number of spacecraft."""
        return int(self.quaternions.shape[1])

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the entries of :attr:`x` (``q1_1, ..., q0_N, w1_1, ..., w3_N``)."""
        return tuple(state_names(self.n))

    @cached_property
    def x(self) -> np.ndarray:
        """(T, 7N) states: the quaternions, then the rates
        (:func:`~formsync_design.sim.formation.pack_state` order; read-only)."""
        T = len(self.t)
        x = np.concatenate([self.quaternions.reshape(T, 4 * self.n),
                            self.rates.reshape(T, 3 * self.n)], axis=1)
        x.setflags(write=False)
        return x

    @cached_property
    def u(self) -> np.ndarray:
        """(T, 3N) torques ``(u1_1, u2_1, u3_1, ..., u3_N)`` (N m; read-only)."""
        u = self.torques.reshape(len(self.t), 3 * self.n)
        u.setflags(write=False)
        return u

    @property
    def final_q_m(self) -> float | None:
        """``Q_m`` at the end (None in an agent run)."""
        return None if self.q_m is None else float(self.q_m[-1])

    @property
    def final_omega_m(self) -> float | None:
        """``Omega_m`` at the end (rad/s; None in an agent run)."""
        return None if self.omega_m is None else float(self.omega_m[-1])

    @property
    def final_rates(self) -> np.ndarray:
        """(N, 3) absolute body rates at the end (rad/s)."""
        return np.array(self.rates[-1])

    @property
    def common_rate(self) -> np.ndarray:
        """(3,) the mean of :attr:`final_rates` (a common drift if nonzero)."""
        return self.rates[-1].mean(axis=0)

    @property
    def converged(self) -> bool:
        """True for ``status == converged``."""
        return self.status == SimStatus.CONVERGED

    @property
    def stopped_early(self) -> bool:
        """True when the run stopped before the horizon (``singular``, ``diverged`` or
        ``stopped``)."""
        return self.status in (SimStatus.SINGULAR, SimStatus.DIVERGED, SimStatus.STOPPED)

    @property
    def stop_time(self) -> float:
        """Last time of the trajectory: the horizon, or the early stop's grid time.  A
        fly-around's outputs are at its control instants; its last state (the horizon, or
        the last finite one) is one sample period after the last of them
        (:class:`~formsync_design.sim.orbit_record.OrbitRecord` ``states``)."""
        if self.orbit is not None:
            return float((self.orbit.states.shape[0] - 1) * self.options.sample_period)
        return float(self.t[-1])

    def time_to(self, angle_deg: float) -> float | None:
        """First output time from which the attitude disagreement stays <= ``angle_deg``."""
        return settle_time(self.t, self.attitude_error <= angle_deg)

    def _final(self, name: str, last: Any) -> float:
        """The last value of the measure ``name``: from its series when that is given or was
        read, else ``last()``, the measure of the last output time alone (each output time's
        value depends on that time only, so it is the same number without the ``O(T N^2)``
        series: the summary of a 256-spacecraft run spent 2.3 s there, 0.17 s simulating)."""
        series = self.__dict__.get("_" + name)
        return float((series if series is not None else last())[-1])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no trajectories), numbers through :func:`json_number`.

        The same keys for every run: the Lagrangian simulator's measures are None (``stats``
        empty) in an agent run; ``orbit`` is a fly-around's summary (``samples``,
        ``fuel_kg``, ``delta_v_m_s``, ``delta_v_net_m_s``, ``allocation``, ``lp_fallbacks``:
        :meth:`~formsync_design.sim.orbit_record.OrbitRecord.to_dict`), None in every other
        run.  ``convergence_time`` is None when not reached (or stopped early);
        ``singular_spacecraft``/``singular_time`` are None unless ``status`` is ``singular``;
        ``torque_limit``/``sample_period`` None mean no limit / continuous control.
        """
        def arr(a: Any) -> Any:
            return None if a is None else [json_number(float(x)) for x in np.ravel(a)]

        def num(x: Any) -> Any:
            return None if x is None else json_number(x)

        return {
            "status": str(self.status), "message": self.message, "design": self.design,
            "graph": self.graph, "integrator": self.integrator,
            "tf": json_number(self.stop_time) if self.t.size else None,
            "diverged_time": num(self.diverged_time),
            "convergence_time": num(self.convergence_time),
            "final_attitude_error_deg": json_number(self._final(
                "attitude_error", lambda: attitude_disagreement(self.quaternions[-1:]))),
            "final_reference_error_deg": None if self.reference_error is None
            else json_number(float(self.reference_error[-1])),
            "final_rate_error": json_number(self._final(
                "rate_error", lambda: rate_disagreement(self.rates[-1:]))),
            "peak_torque": [[json_number(float(x)) for x in row] for row in self.peak_torque],
            "effort": arr(self.effort),
            "monitors": {k: {"min": json_number(float(np.nanmin(v))),
                             "max": json_number(float(np.nanmax(v)))}
                         for k, v in self.monitors.items()},
            "transmissions": None if self.transmissions is None
            else [int(k) for k in self.transmissions],
            "min_interevent": arr(self.min_interevent),
            "mean_interevent": arr(self.mean_interevent),
            "spec_key": self.spec_key,
            "n": self.n,
            "final_omega_m": num(self.final_omega_m),
            "final_q_m": num(self.final_q_m),
            "min_q0": arr(self.min_q0),
            "singular_spacecraft": num(self.singular_spacecraft),
            "singular_time": num(self.singular_time),
            "saturation_end_time": num(self.saturation_end_time),
            "final_rates": _jsonable(self.final_rates),
            "common_rate": _jsonable(self.common_rate),
            "options": _options(self.options, self.integrator),
            "stats": _jsonable(self.stats),
            "orbit": None if self.orbit is None else self.orbit.to_dict(),
        }

    def to_npz(self, path: str | Path) -> Path:
        """Write ``t, x, u, names`` (and ``omega_m, q_m`` of a Lagrangian run) to a compressed
        NPZ file."""
        from formsync_design.outdir import save_npz

        p = Path(path)
        metrics: dict[str, Any] = {} if self.omega_m is None else {"omega_m": self.omega_m, "q_m": self.q_m}
        save_npz(p, t=self.t, x=self.x, u=self.u, **metrics, names=np.array(self.names))
        return p

    def to_csv(self, path: str | Path) -> Path:
        """Write one row per grid time: ``t, <state names>, u1_1.., Omega_m, Q_m`` (the last two
        in a Lagrangian run)."""
        p = Path(path)
        unames = [f"u{k}_{i}" for i in range(1, self.n + 1) for k in (1, 2, 3)]
        cols: list[Any] = [self.t, self.x, self.u]
        heads = ["t", *self.names, *unames]
        if self.omega_m is not None:
            cols += [self.omega_m, self.q_m]
            heads += ["Omega_m", "Q_m"]
        data = np.column_stack(cols)
        from formsync_design.outdir import atomic_path

        with atomic_path(p) as tmp:
            np.savetxt(tmp, data, delimiter=",", header=",".join(heads), comments="", fmt="%.17g")
        return p


def _options(o: Any, integrator: str) -> Any:
    """The options of a run as JSON: the Lagrangian simulator's (with the step and the method
    it resolved to; a triggered run's ``integrator`` is the hybrid integrator it ran, which
    has no fixed step), else every field of the options dataclass."""
    if o is None:
        return None
    if isinstance(o, SimOptions):
        hybrid = integrator.startswith("hybrid")
        return _jsonable({
            "switch": o.switch,
            "phi": o.phi,
            "torque_limit": o.torque_limit,
            "sample_period": o.sample_period,
            "integrator": integrator if hybrid else o.method,
            "step": o.interval / o.substeps if o.method == "rk4" and not hybrid else None,
            "output_step": o.interval,
            "rtol": o.rtol,
            "atol": o.atol,
            "q_tol": o.q_tol,
            "omega_tol": o.omega_tol,
            "q0_floor": o.q0_floor,
        })
    return _jsonable({f.name: getattr(o, f.name) for f in fields(o)})


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    return json_number(x)
