"""Simulation of agent designs (:mod:`formsync_design.spec.agent`) on directed weighted graphs.

:func:`simulate_agents` runs a formation whose spacecraft each apply the design's law with
their in-neighbours' information (weights ``a_ij``), an optional leader (pinning gains
``b_i``, reference attitude and rate), controller states and the paper's (or any)
disturbance:

* continuous designs: a compiled fixed-step RK4 kernel (:mod:`~formsync_design.sim.agent_kernel`;
  the unit quaternions are normalised after every sub-step) or adaptive CVODES;
* sampled designs (``SAMPLING`` ``periodic``, ``event``, ``self-triggered``): the exact hybrid
  integrator :func:`~formsync_design.sim.hybrid.simulate_hybrid` (DOP853; trigger instants
  located by root finding, never rounded to a grid).  At an update of spacecraft ``i`` it
  broadcasts its state, recomputes its torque from its own state and its in-neighbours' last
  broadcasts and holds the torque until its next update.

Outputs (the one :class:`~formsync_design.sim.result.SimResult`): the trajectory, torques, the attitude disagreement (largest
principal angle between two spacecraft, degrees) and the error to the reference, the rate
disagreement, the convergence time to the options' tolerances, peak torques, control effort,
the design's monitors and, for sampled designs, the transmissions and inter-event times.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from formsync_design.errors import InputError, SimulationError
from formsync_design.graphs.digraph import Digraph
from formsync_design.models.disturbances import DisturbanceModel, no_disturbance
from formsync_design.models.inertia import check_inertias
from formsync_design.sim.agent_kernel import (
    agent_parameters,
    agent_state_names,
    get_agent_kernel,
)
from formsync_design.sim.agent_native import native_agents_available
from formsync_design.sim.disagreement import (
    attitude_disagreement,
    principal_angles,
    rate_disagreement,
    settle_time,
)
from formsync_design.sim.formation import Gains
from formsync_design.sim.reference_rate import reference_rate_expressions, reference_rate_function
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.spec.agent import AgentDesign, uses_switching

__all__ = [
    "Reference",
    "AgentFormation",
    "AgentOptions",
    "MAX_AGENT_GRID_POINTS",
    "MAX_AGENT_STEPS",
    "AGENT_STATUSES",
    "simulate_agents",
    "simulate_agents_sampled",
    "simulate_agents_batch",
    "assemble_result",
    "resolve_auto",
    "observe_grid",
]


@dataclass(frozen=True)
class Reference:
    """A leader's (reference) motion: initial attitude ``(q1, q2, q3, q0)`` and body rate
    ``w_ref(t)`` as three SymPy expressions in ``t`` (constants are expressions too).

    ``rate`` may be given as formulas (text or numbers): they are read by
    :func:`formsync_design.safeexpr.parse_formula` (never evaluated) and stored as
    expressions.

    >>> r = Reference((0, 0, 0, 1), ("0.01", "0", "0"))
    >>> r.constant_rate, r.rate
    (True, (0.0100000000000000, 0, 0))
    """

    attitude: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    rate: tuple[Any, Any, Any] = ("0", "0", "0")

    def __post_init__(self) -> None:
        q = np.asarray(self.attitude, dtype=float)
        if q.shape != (4,) or abs(float(np.linalg.norm(q)) - 1) > 1e-9:
            raise InputError(f"expected a unit reference quaternion (q1, q2, q3, q0), received "
                             f"{list(self.attitude)}")
        rate = reference_rate_expressions(self.rate)
        reference_rate_function(rate)  # validates that the kernels compile them
        object.__setattr__(self, "attitude", tuple(float(v) for v in q))
        object.__setattr__(self, "rate", rate)

    @property
    def constant_rate(self) -> bool:
        return all(not r.free_symbols for r in self.rate)


@dataclass(frozen=True)
class AgentFormation:
    """Everything physical about an agent-design run.

    Attributes
    ----------
    graph : Digraph (or an undirected Graph, taken as a digraph with unit weights)
        Who receives from whom (``a_ij``), pinning gains ``b_i`` to the leader.
    inertias : (N, 3, 3); attitudes : (N, 4) ``(q1, q2, q3, q0)`` unit; rates : (N, 3)
    gains : Gains
        The design's controller gains by name (a diagonal gain: one value or three).
    disturbance : DisturbanceModel
    reference : Reference or None
        Required exactly when the design declares ``LEADER``.
    states : mapping name -> (N, size), optional
        Initial controller states (default zero).
    """

    graph: Digraph
    inertias: np.ndarray
    attitudes: np.ndarray
    rates: np.ndarray
    gains: Gains
    disturbance: DisturbanceModel | None = None
    reference: Reference | None = None
    states: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from formsync_design.graphs.theorem import as_digraph

        object.__setattr__(self, "graph", as_digraph(self.graph))
        n = self.graph.n
        J = check_inertias(self.inertias, n)
        Q = np.asarray(self.attitudes, dtype=float)
        W = np.asarray(self.rates, dtype=float)
        if Q.shape != (n, 4):
            raise InputError(f"expected {n} quaternions (q1, q2, q3, q0), received shape {Q.shape}")
        for i, qb in enumerate(Q):
            if abs(float(np.linalg.norm(qb)) - 1) > 1e-9:
                raise InputError(f"expected a unit quaternion for spacecraft {i + 1}, received "
                                 f"norm {float(np.linalg.norm(qb)):.12g}")
        if W.shape != (n, 3) or not np.all(np.isfinite(W)):
            raise InputError(f"expected {n} finite rates (N, 3), received shape {W.shape}")
        if not isinstance(self.gains, Gains):
            object.__setattr__(self, "gains", Gains(dict(self.gains)))
        object.__setattr__(self, "inertias", J)
        object.__setattr__(self, "attitudes", Q)
        object.__setattr__(self, "rates", W)
        if self.disturbance is None:
            object.__setattr__(self, "disturbance", no_disturbance(n))

    @property
    def n(self) -> int:
        return self.graph.n

    def neighbours(self) -> tuple[tuple[int, ...], ...]:
        """In-neighbour lists (0-based, increasing), the kernel's structure."""
        return tuple(self.graph.receives_from(i) for i in range(self.n))

    def weights(self) -> np.ndarray:
        """``a_ij`` in the order of :meth:`neighbours` (flattened)."""
        A = self.graph.adjacency
        return np.array([A[i, j] for i, nb in enumerate(self.neighbours()) for j in nb], float)


#: Most output grid points of one agent run (``tf / output_step``): the trajectory and the
#: law's torques and monitors at every point are kept in memory and evaluated per point.
MAX_AGENT_GRID_POINTS = 1_000_000

#: Most RK4 steps of one agent run (``tf / step``; about 10 us each for ten spacecraft).
MAX_AGENT_STEPS = 1_000_000_000


#: The statuses an agent-design run ends with (:class:`~formsync_design.sim.result.SimStatus`
#: without ``singular``, a stop of the Lagrangian simulator only): ``converged`` (attitude and
#: rate disagreement, and the errors to the reference, within the options' tolerances from
#: ``convergence_time`` to the end), ``not-converged``, ``stopped`` (the hybrid integrator
#: stopped: Zeno protection or too many triggers, ``message`` says which) and ``diverged``
#: (the state became non-finite at ``diverged_time``; the trajectory ends at the last finite
#: output time).
AGENT_STATUSES: tuple[SimStatus, ...] = (SimStatus.CONVERGED, SimStatus.NOT_CONVERGED,
                                         SimStatus.STOPPED, SimStatus.DIVERGED)


@dataclass(frozen=True)
class AgentOptions:
    """Simulation options.

    ``tf`` horizon (s); ``output_step`` (s); ``step`` RK4 step (s, a divisor of
    ``output_step``); ``integrator`` ``rk4``, ``dopri5`` (adaptive, at ``rtol``/``atol``, dense
    output on the output grid), ``cvodes`` or ``auto`` (:func:`resolve_auto`) (continuous
    designs; sampled designs always use the exact hybrid integrator with ``rtol``/``atol``); ``switch`` ``sgn``/``sat``/
    ``tanh`` with boundary layer ``phi``; ``torque_limit`` per axis (N m, ``None``: none);
    ``angle_tol`` (deg) and ``rate_tol`` (rad/s) for convergence; ``period`` of periodic
    sampling (s).
    """

    tf: float = 100.0
    output_step: float = 0.1
    step: float = 0.01
    integrator: str = "rk4"
    switch: str = "sgn"
    phi: float = 0.01
    torque_limit: float | None = None
    angle_tol: float = 1.0
    rate_tol: float = 1e-3
    rtol: float = 1e-9
    atol: float = 1e-11
    period: float | None = None

    def __post_init__(self) -> None:
        for name in ("tf", "output_step", "step", "phi", "angle_tol", "rate_tol", "rtol", "atol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"expected a positive finite {name}, received {v!r}")
        if self.tf / self.output_step > MAX_AGENT_GRID_POINTS:
            raise InputError(f"expected at most {MAX_AGENT_GRID_POINTS} output grid points "
                             f"(tf / output_step) in one run, received {self.tf / self.output_step:.3g} "
                             f"(tf {self.tf:g} s, output_step {self.output_step:g} s); shorten tf "
                             "or raise output_step")
        if self.tf / self.step > MAX_AGENT_STEPS:
            raise InputError(f"expected at most {MAX_AGENT_STEPS:.0e} integration steps (tf / step) in "
                             f"one run, received {self.tf / self.step:.3g} (tf {self.tf:g} s, step "
                             f"{self.step:g} s); shorten tf or raise step")
        ratio = self.output_step / self.step
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise InputError(f"expected step to divide output_step, received step {self.step:g} "
                             f"and output_step {self.output_step:g}")
        if self.integrator not in ("auto", "rk4", "dopri5", "cvodes"):
            raise InputError(f"expected integrator auto, rk4, dopri5 or cvodes, received "
                             f"{self.integrator!r}")
        if self.switch not in ("sgn", "sat", "tanh"):
            raise InputError(f"expected switch sgn, sat or tanh, received {self.switch!r}")
        if self.torque_limit is not None and not self.torque_limit > 0:
            raise InputError(f"expected a positive torque limit, received {self.torque_limit!r}")
        if self.period is not None and not self.period > 0:
            raise InputError(f"expected a positive sampling period, received {self.period!r}")


def _check(design: AgentDesign, f: AgentFormation) -> None:
    if getattr(design, "form", None) != "agent":
        raise InputError(f"expected an agent design (FORM = 'agent'), received "
                         f"{getattr(design, 'name', design)!r}")
    if design.decl.leader and f.reference is None:
        raise InputError(f"expected a reference (leader) for design {design.name} (it declares "
                         "LEADER), received none")
    if not design.decl.leader and f.reference is not None:
        raise InputError(f"expected no reference for design {design.name} (it declares no "
                         "LEADER), received one")
    if design.decl.leader and not f.graph.has_leader:
        raise InputError(f"expected pinning gains b_i to the leader for design {design.name}, "
                         f"received graph {f.graph.name!r} without a leader")
    for name in f.states:
        if name not in dict(design.decl.states):
            raise InputError(f"expected initial states among {[s for s, _ in design.decl.states]}, "
                             f"received {name!r}")


def _x0(design: AgentDesign, f: AgentFormation) -> np.ndarray:
    parts = [f.attitudes.ravel(), f.rates.ravel()]
    zs = []
    for i in range(f.n):
        for name, k in design.decl.states:
            z = np.zeros((f.n, k)) if name not in f.states else np.asarray(f.states[name], float)
            if z.shape != (f.n, k):
                raise InputError(f"expected initial states {name} of shape ({f.n}, {k}), "
                                 f"received {z.shape}")
            zs.append(z[i])
    if zs:
        parts.append(np.concatenate(zs))
    if design.decl.leader:
        assert f.reference is not None
        parts.append(np.asarray(f.reference.attitude, float))
    return np.concatenate(parts)


def _grid(opt: AgentOptions) -> tuple[int, int, int]:
    """RK4 sub-steps per output interval ``M``, output intervals ``T`` and intervals per kernel
    call ``K`` of the options."""
    T = int(math.floor(opt.tf / opt.output_step + 1e-9))
    if T < 1:
        raise InputError(f"expected tf >= output_step, received tf {opt.tf:g} and output_step "
                         f"{opt.output_step:g}")
    return int(round(opt.output_step / opt.step)), T, min(T, 200)


def simulate_agents(design: AgentDesign, formation: AgentFormation,
                    options: AgentOptions | None = None, *, sensors: Any = None,
                    torque_input: np.ndarray | None = None) -> SimResult:
    """Simulate ``formation`` under ``design`` (module docstring).

    ``sensors`` (a :class:`~formsync_design.sim.sensors.RateSensors`) makes the law read a
    biased, noisy or failed gyro instead of the true rate; ``torque_input`` (``(steps, N, 3)``,
    ``steps = tf / step``) adds a torque held over each RK4 step (:mod:`~formsync_design.sim.
    sensors`).  Both need the ``rk4`` integrator and a continuous design.

    Examples
    --------
    Rate damping ``u = -k w`` on a free rigid body decays every rate:

    >>> from formsync_design.graphs import load_graph
    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    >>> f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
    ...                    np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.1), Gains(k=1.0))
    >>> r = simulate_agents(d, f, AgentOptions(tf=5, output_step=0.5, step=0.05))
    >>> round(float(r.rates[-1, 0, 0]), 6) == round(0.1 * math.exp(-5), 6)
    True
    """
    opt = options or AgentOptions()
    _check(design, formation)
    measured = sensors is not None or torque_input is not None
    if opt.integrator == "auto":
        opt = replace(opt, integrator=resolve_auto(design, measured, opt.switch))
    if measured and (opt.integrator != "rk4" or design.decl.sampling != "continuous"):
        raise InputError(f"expected the rk4 integrator and a continuous design for a gyro model "
                         f"or a torque input, received {opt.integrator} and "
                         f"{design.decl.sampling}")
    if design.decl.sampling != "continuous":
        return simulate_agents_sampled(design, formation, opt)
    f = formation
    M, T, K = _grid(opt)
    ref_rate = f.reference.rate if f.reference is not None else ("0", "0", "0")
    if not measured and opt.integrator in ("rk4", "dopri5"):
        if native_agents_available():
            return _simulate_native(design, f, opt, M, T, ref_rate)
        if opt.integrator == "dopri5":
            raise SimulationError("expected a C compiler (gcc/cc) for the dopri5 integrator of "
                                  "agent designs, received none (FORMSYNC_NO_COMPILE or no "
                                  "compiler): use --integrator rk4 or cvodes")
    kern = get_agent_kernel(design, f.neighbours(), opt.switch, M, K, ref_rate,
                            measured=measured)
    p = agent_parameters(design, f, opt, kern.layout)
    x0 = _x0(design, f)
    t = np.arange(T + 1) * opt.output_step
    ext = None
    if measured:
        from formsync_design.sim.sensors import external_inputs

        ext, tfail = external_inputs(f.n, T * M, opt.step, sensors, torque_input)
        p[kern.layout["tfail"]] = tfail
    if opt.integrator == "rk4":
        X = np.empty((T + 1, kern.nx))
        X[0] = x0
        xa = np.concatenate([x0, [0.0]])
        k = 0
        diverged = None
        while k < T:
            if ext is not None:
                blk = ext[:, k * M: (k + K) * M]
                if blk.shape[1] < K * M:
                    blk = np.concatenate([blk, np.zeros((blk.shape[0], K * M - blk.shape[1]))], 1)
                out = np.asarray(kern.chunk(xa, opt.step, p, blk))
            else:
                out = np.asarray(kern.chunk(xa, opt.step, p))  # (nx + 1, K)
            take = min(K, T - k)
            X[k + 1: k + 1 + take] = out[:-1, :take].T
            xa = out[:, take - 1]
            bad = np.flatnonzero(~np.isfinite(X[k + 1: k + 1 + take]).all(axis=1))
            if bad.size:  # a finding: the run ends at the last finite output time
                diverged = k + 1 + int(bad[0])
                break
            k += take
        if diverged is not None:
            return _diverged(design, f, opt, kern, p, t, X, diverged)
    else:
        integ = kern.cvodes(t[1:], opt.rtol, opt.atol)
        try:
            sol = integ(x0=x0, p=p)
        except RuntimeError as e:
            raise SimulationError(f"CVODES failed on {design.name} ({' '.join(str(e).split())[:160]});"
                                  " try --integrator rk4 or a boundary layer") from None
        X = np.vstack([x0, np.asarray(sol["xf"]).T])
    obs_ext = None
    if ext is not None:  # the held inputs of the step starting at each output time
        cols = np.minimum(np.arange(T + 1) * M, ext.shape[1] - 1)
        obs_ext = ext[:, cols].T
    return assemble_result(design, f, opt, kern, p, t, X, opt.integrator, ext=obs_ext)


_SWITCHES: dict[str, bool] = {}


def _switches(design: AgentDesign) -> bool:
    """:func:`~formsync_design.spec.agent.uses_switching`, once per design (it derives the
    law)."""
    hit = _SWITCHES.get(design.key)
    if hit is None:
        hit = _SWITCHES[design.key] = uses_switching(design)
    return hit


def resolve_auto(design: AgentDesign, measured: bool = False, switch: str = "sgn") -> str:
    """The integrator ``auto`` stands for: ``dopri5`` (the compiled adaptive driver), or
    ``rk4`` for a law switching under ``sgn`` (an adaptive step would chase its sliding
    mode), a sampled design (its own hybrid integrator), a gyro model or torque input, or
    without a C compiler.

    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.sgn(v.w), gains={"k": {}})
    >>> resolve_auto(d)
    'rk4'
    """
    if (measured or design.decl.sampling != "continuous" or not native_agents_available()
            or (switch == "sgn" and _switches(design))):
        return "rk4"
    return "dopri5"


def _simulate_native(design: AgentDesign, f: AgentFormation, opt: AgentOptions, M: int, T: int,
                     ref_rate: Any) -> SimResult:
    """A continuous run on the compiled driver (:mod:`~formsync_design.sim.agent_native`): one
    object per design, the graph and everything physical as data."""
    import time

    from formsync_design.sim.agent_kernel import agent_param_layout, gain_count
    from formsync_design.sim.agent_native import get_native_agents

    if opt.integrator == "dopri5" and opt.switch == "sgn" and _switches(design):
        raise InputError(f"expected --switch sat or tanh with the dopri5 integrator (design "
                         f"{design.name} switches; an adaptive step would chase its sliding "
                         "mode), received sgn")
    t0 = time.perf_counter()
    nk = get_native_agents(design, opt.switch)
    nb = f.neighbours()
    lay = agent_param_layout(f.n, gain_count(design), sum(len(v) for v in nb))
    p = agent_parameters(design, f, opt, lay)
    t = np.arange(T + 1) * opt.output_step
    for m in sorted({len(v) for v in nb}):
        nk.law(m)  # built (or loaded) before the clock of the run starts
    t1 = time.perf_counter()
    run = nk.run(nb, lay, p, _x0(design, f), t, opt.integrator, step=opt.step, substeps=M,
                 rtol=opt.rtol, atol=opt.atol, ref_rate=ref_rate)
    t2 = time.perf_counter()
    stats = {"integrator": opt.integrator, "compiled": True, "steps": run.steps,
             "rejected_steps": run.rejected, "rhs_evaluations": run.rhs_evaluations,
             "wall_seconds": t2 - t1, "build_seconds": t1 - t0}
    if run.status == 2 and run.reason == 3:
        raise SimulationError(f"the {opt.integrator} integrator stopped on {design.name} at t = "
                              f"{run.t_fail:g} s (too many steps); try --integrator rk4 or a "
                              "boundary layer")
    k = run.X.shape[0]
    res = assemble_result(design, f, opt, nk, p, t[:k], run.X, opt.integrator,
                          observed=(run.U, run.MON))
    res = replace(res, stats=stats)
    if run.status == 1:  # a finding: the trajectory ends at the last finite output time
        tdiv = float(t[k]) if k < t.size else run.t_fail
        return replace(res, status=SimStatus.DIVERGED, diverged_time=tdiv,
                       convergence_time=None,
                       message=f"diverged at t = {tdiv:g} s (non-finite state; the trajectory "
                               f"ends at t = {float(t[k - 1]):g} s): try a smaller step or a "
                               "boundary layer")
    if run.status == 2:  # the adaptive step underflowed: a finite escape time (a finding)
        return replace(res, status=SimStatus.DIVERGED, diverged_time=run.t_fail,
                       convergence_time=None,
                       message=f"diverged at t = {run.t_fail:.6g} s (the {opt.integrator} step "
                               "size underflowed: the state escapes in finite time, or a "
                               f"discontinuity stops the step; the trajectory ends at t = "
                               f"{float(t[k - 1]):g} s): try --integrator rk4 or a boundary "
                               "layer")
    return res


def _diverged(design: AgentDesign, f: AgentFormation, opt: AgentOptions, kern: Any,
              p: np.ndarray, t: np.ndarray, X: np.ndarray, index: int) -> SimResult:
    """The result of a run whose state is non-finite from output ``index`` on: a finding,
    the trajectory ending at the last finite output time."""
    X = X[:index]
    tdiv, t = float(t[index]), t[:index]
    res = assemble_result(design, f, opt, kern, p, t, X, opt.integrator)
    return replace(res, status=SimStatus.DIVERGED, diverged_time=tdiv, convergence_time=None,
                   message=f"diverged at t = {tdiv:g} s (non-finite state; the trajectory ends "
                           f"at t = {float(t[-1]):g} s): try a smaller step or a boundary layer")


def simulate_agents_batch(design: AgentDesign, formations: Sequence[AgentFormation],
                          options: AgentOptions | None = None, *,
                          threads: int | None = None) -> list[SimResult]:
    """The runs of ``formations`` (Monte-Carlo draws of one case) under ``design``, spread
    over ``threads`` threads (default: the machine's cores).  Each result equals
    :func:`simulate_agents` of its formation bitwise: with the compiled driver
    (:mod:`~formsync_design.sim.agent_native`, ``rk4`` and ``dopri5``) each run is one call
    of it; without a C compiler the runs of one graph structure advance together, one call
    of the RK4 kernel mapped over them per chunk of output intervals.  A run whose state goes
    non-finite ends there as alone.  Otherwise (``cvodes``, sampled designs, several
    structures or reference rates) the runs go one by one through :func:`simulate_agents`.

    >>> from formsync_design.graphs import load_graph
    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    >>> fs_ = [AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
    ...                       np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), w), Gains(k=1.0))
    ...        for w in (0.1, 0.2)]
    >>> opt = AgentOptions(tf=5, output_step=0.5, step=0.05)
    >>> both = simulate_agents_batch(d, fs_, opt)
    >>> all(np.array_equal(b.rates, simulate_agents(d, f, opt).rates) for b, f in zip(both, fs_))
    True
    """
    from sympy import srepr

    opt = options or AgentOptions()
    fl = list(formations)
    if (design.decl.sampling == "continuous" and opt.integrator in ("rk4", "dopri5")
            and native_agents_available()):
        # the compiled driver: each run is one call of it (the same arithmetic as a single
        # run), on ``threads`` threads (the driver runs without the interpreter lock)
        from concurrent.futures import ThreadPoolExecutor

        workers = max(1, min(len(fl), threads or os.cpu_count() or 1))
        if workers == 1 or len(fl) < 2:
            return [simulate_agents(design, f, opt) for f in fl]
        with ThreadPoolExecutor(workers) as pool:
            return list(pool.map(lambda f: simulate_agents(design, f, opt), fl))
    # the reference rates are SymPy expressions (Reference); one kernel serves one of them
    refs = {None if f.reference is None else tuple(srepr(r) for r in f.reference.rate) for f in fl}
    if (len(fl) < 2 or opt.integrator != "rk4" or design.decl.sampling != "continuous"
            or len({f.neighbours() for f in fl}) > 1 or len(refs) > 1):
        return [simulate_agents(design, f, opt) for f in fl]
    for f in fl:
        _check(design, f)
    f0, B = fl[0], len(fl)
    M, T, K = _grid(opt)
    kern = get_agent_kernel(design, f0.neighbours(), opt.switch, M, K,
                            f0.reference.rate if f0.reference is not None else ("0", "0", "0"))
    P = np.stack([agent_parameters(design, f, opt, kern.layout) for f in fl], axis=1)
    X = np.empty((B, T + 1, kern.nx))
    X[:, 0] = np.stack([_x0(design, f) for f in fl])
    xa = np.concatenate([X[:, 0].T, np.zeros((1, B))])
    fn = kern.chunk_map(B, max(1, min(B, threads or os.cpu_count() or 1)))
    diverged: list[int | None] = [None] * B
    k = 0
    while k < T and any(d is None for d in diverged):
        out = np.asarray(fn(xa, opt.step, P)).reshape(kern.nx + 1, B, K)
        take = min(K, T - k)
        X[:, k + 1: k + 1 + take] = out[:-1, :, :take].transpose(1, 2, 0)
        xa = np.ascontiguousarray(out[:, :, take - 1])
        for b in range(B):
            if diverged[b] is None:
                bad = np.flatnonzero(~np.isfinite(X[b, k + 1: k + 1 + take]).all(axis=1))
                if bad.size:  # this run ends at its last finite output time
                    diverged[b] = k + 1 + int(bad[0])
        k += take
    t = np.arange(T + 1) * opt.output_step
    return [assemble_result(design, f, opt, kern, P[:, b].copy(), t, X[b], opt.integrator)
            if diverged[b] is None else
            _diverged(design, f, opt, kern, P[:, b].copy(), t, X[b], int(diverged[b] or 0))
            for b, f in enumerate(fl)]


def simulate_agents_sampled(design: AgentDesign, formation: AgentFormation, opt: AgentOptions,
                            record: dict | None = None) -> SimResult:
    """The sampled path of :func:`simulate_agents`
    (:func:`~formsync_design.sim.agent_sampled.run_sampled_agents`; ``record``: the hybrid
    run, trigger evaluations and kept values)."""
    from formsync_design.sim.agent_sampled import run_sampled_agents

    run = run_sampled_agents(design, formation, opt, record)
    return assemble_result(design, formation, opt, run.kernel, run.parameters, run.t, run.states,
                           "hybrid-dop853", torques=run.torques, sampled=run.hybrid)


def observe_grid(kern: Any, X: np.ndarray, t: np.ndarray, p: np.ndarray,
                 ext: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's ``observe`` (torques, monitors) at every output time in one call: the
    CasADi function mapped over the ``K`` samples (columns), each evaluated as one call of
    it would be; ``(K, 3 N)`` torques and ``(K, monitors)``."""
    K = X.shape[0]
    fn = kern.observe_map(K)
    # the parameter vector is one column, which the mapped function repeats for every sample
    # (a tiled (P, K) copy cost more to convert than the evaluations themselves)
    args = [X.T, np.asarray(t, float).reshape(1, K), np.asarray(p, float).reshape(-1, 1)]
    if ext is not None:
        args.append(np.asarray(ext, float).T)
    u, m = fn(*args)
    return (np.asarray(u, float).reshape(kern.observe.size1_out(0), K).T,
            np.asarray(m, float).reshape(kern.observe.size1_out(1), K).T)


def assemble_result(design: AgentDesign, f: AgentFormation, opt: AgentOptions, kern: Any, p: np.ndarray,
            t: np.ndarray, X: np.ndarray, integrator: str, *, torques: np.ndarray | None = None,
            sampled: Any = None, ext: np.ndarray | None = None,
            observed: tuple[np.ndarray, np.ndarray] | None = None) -> SimResult:
    """The :class:`~formsync_design.sim.result.SimResult` of a trajectory ``X`` (kernel state
    order) on the grid ``t`` (shared by the continuous and the sampled paths; ``ext``: the
    measured kernel's held inputs at each output time).  Its status is one of
    :data:`AGENT_STATUSES`.  The disagreement metrics are computed in C when a compiler is
    available (:func:`~formsync_design.sim.agent_native.native_disagreement`, every pair,
    equal to :mod:`~formsync_design.sim.disagreement` to rounding, tested against it), else
    by the NumPy functions.  ``observed``: the torques and monitors at every output time
    when the driver evaluated them (else ``kern``'s ``observe``)."""
    n = f.n
    nz = design.decl.state_size
    Q = X[:, : 4 * n].reshape(X.shape[0], n, 4)
    W = X[:, 4 * n: 7 * n].reshape(X.shape[0], n, 3)
    Z = X[:, 7 * n: 7 * n + nz * n].reshape(X.shape[0], n, nz)
    R = X[:, 7 * n + nz * n: 7 * n + nz * n + 4] if design.decl.leader else None
    U_obs, Mv = observed if observed is not None else observe_grid(
        kern, X if X.shape[1] == kern.nx or R is None else np.concatenate([X, R], axis=1), t, p,
        ext)
    U = U_obs.reshape(-1, n, 3) if torques is None else torques
    mons: dict[str, np.ndarray] = {}
    names = kern.monitors
    for j, name in enumerate(names):
        mons[name] = Mv[:, j::len(names)] if names else Mv
    if native_agents_available():
        from formsync_design.sim.agent_native import native_disagreement

        att, rate_dis = native_disagreement(Q, W)
    else:
        att, rate_dis = attitude_disagreement(Q), None
    if R is not None:
        ref_err = np.degrees(principal_angles(Q, R[:, None, :])).max(axis=1)
        rr = reference_rate_function(f.reference.rate if f.reference else ("0", "0", "0"))
        wref = np.array([np.asarray(rr(tk)[0]).ravel() for tk in t])
        rate_err = np.linalg.norm(W - wref[:, None, :], axis=2).max(axis=1)
        ok = (ref_err <= opt.angle_tol) & (rate_err <= opt.rate_tol) & (att <= opt.angle_tol)
    else:
        ref_err = None
        rate_err = rate_disagreement(W) if rate_dis is None else rate_dis
        ok = (att <= opt.angle_tol) & (rate_err <= opt.rate_tol)
    conv = settle_time(t, ok)
    status = SimStatus.CONVERGED if conv is not None else SimStatus.NOT_CONVERGED
    message = ""
    if sampled is not None and str(sampled.status) != "completed":
        status, message = SimStatus.STOPPED, sampled.message
    sq = np.sum(U * U, axis=2)
    effort = np.trapezoid(sq, t, axis=0) if sampled is None else sampled.control_effort
    return SimResult(
        status=status, message=message, design=design.name, graph=f.graph.name, t=t,
        quaternions=Q, rates=W, states=Z, torques=U, reference=R, attitude_error=att,
        reference_error=ref_err, rate_error=rate_err, convergence_time=conv,
        peak_torque=np.abs(U).max(axis=0), effort=np.asarray(effort, float), monitors=mons,
        transmissions=None if sampled is None else sampled.transmissions,
        min_interevent=None if sampled is None else sampled.min_interevent,
        mean_interevent=None if sampled is None else sampled.mean_interevent,
        trigger_times=None if sampled is None else tuple(sampled.trigger_times),
        state_names=tuple(agent_state_names(n, design)), integrator=integrator,
        options=opt, spec_key=design.key,
    )
