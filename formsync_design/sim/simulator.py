"""Fast nonlinear simulation of a spacecraft formation under a specification's controller
(default: the paper's controller (4); ``simulate(..., spec=...)`` for another).

Plant (per spacecraft ``i``, paper eqs. 1-2)::

    [q_i; q0_i]' = [E(q_i, q0_i); -q_i^T/2] omega_i           (kinematics, eq. 1)
    J_i omega_i' = -omega_i x J_i omega_i + u_i + u_di          (Euler, eq. 2)

``E`` comes from the derived model (:mod:`formsync_design.models.attitude`) through
:mod:`formsync_design.sim.bridge`; the controller ``u_i`` is the specification's
(paper eq. 4), translated by the bridge from the derived ``A, B, Q`` - one
source of truth, no hand-copied formula.  ``q_i' = E omega_i`` is what the
controller receives as ``qd``; ``s_i = sum_{j in G_i}(q_i - q_j)``.

State layout (pydy style: coordinates, then speeds)
----------------------------------------------------
``x = (q1_1, q2_1, q3_1, q0_1, ..., q1_N, q2_N, q3_N, q0_N,
w1_1, w2_1, w3_1, ..., w1_N, w2_N, w3_N)``: ``4N`` quaternion entries (vector
part first, scalar ``q0`` last, as in the model's ``state_symbols``) then
``3N`` body rates (rad/s, body frame w.r.t. inertial).  :func:`state_names`
gives the names.  The full quaternion is integrated (``q0`` is a state, not
``sqrt(1 - |q|^2)``), so a crossing ``q0 -> 0`` - where ``Q = E^{-1}`` is
singular and (4) undefined - is *seen*: every (sub-)step's ``q0`` is checked
against ``q0_floor`` (default 0.02) and the run stops with status
``"singular"`` naming the spacecraft and the time, located on the step's
interpolant to ``event_tol`` (default 1e-9 s).  Near ``q0 = 0`` the body rate
``|omega| ~ 2|q'|/q0`` grows without bound, so when the fixed RK4 step blows up
first, the interval is re-integrated with ``h/10`` and ``h/100`` to reach the
floor (DOPRI5 shrinks its step by itself); a blow-up that persists right after
some ``q0 < 0.1`` is still reported as ``"singular"`` (the message gives the
smallest ``q0`` reached); any other NaN/inf is the status ``"diverged"`` with
its time (``diverged_time``; a finding, as a singular run is).  Trajectories
end at the event.

Quaternion norm policy: no renormalisation.  The kinematics preserve
``|q_bar| = 1`` exactly, so its numerical drift measures integration error;
it is reported (``stats["max_norm_error"]``) and a run whose drift exceeds
``norm_tol`` (default 1e-5) raises :class:`SimulationError` (tighten the
step).  The controller maps ``Q^{-1}`` to ``E`` (exact on the unit sphere;
see :mod:`formsync_design.sim.bridge`); the drift is the size of the error that
mapping can make.

Integrators
-----------
All but CVODES run in the compiled whole-horizon kernel of
:mod:`formsync_design.sim.native`: one call integrates the whole horizon,
locates the events and returns the output grid; one shared object per
specification, switch and ``inverse`` serves every formation size and graph.
It is compiled with gcc ``-O3 -march=native`` and cached in the user cache dir
(``$FORMSYNC_CACHE_DIR``, else ``$XDG_CACHE_HOME/formsync-design`` or
``~/.cache/formsync-design``; keyed by the generated source, the specification's
content key ``spec.key``, flags, CasADi version and host, so a variant controller
never reuses another's kernel); the first build takes a few seconds, later runs
load it.  Without a C compiler the same algorithms run in Python over CasADi's
virtual machine (:mod:`formsync_design.sim.adaptive`) with a
:class:`RuntimeWarning`; ``compile=False`` or ``FORMSYNC_NO_COMPILE=1`` choose it
silently; a compiler that fails raises :class:`~formsync_design.errors.CompilerError`.

``"auto"`` (default) is ``"dopri5"``, or ``"rk4"`` when a ``step`` is given or the
switch is ``sgn``.  ``"dopri5"``: Dormand-Prince 5(4) (Hairer's DOPRI5, dense
output) at ``rtol``/``atol`` (defaults 1e-8/1e-12, chosen by the error budget of the
README: every quantity the verification judges within 1e-5 relative of a tight
reference); every step ends at the next kink of the closed loop (a switching
argument crossing the boundary layer ``|tau| = phi``, a torque crossing its limit),
located on the dense output, so no step straddles one - on the paper's case the
final state then agrees with a CVODES rtol 1e-12 reference to 1e-10.  ``"rk4"``:
classical fixed-step Runge-Kutta 4 with ``step`` (default 0.05 s; final state to
3e-7 on the paper's case); crossings are counted at step ends and the first and
the last located on the cubic Hermite interpolant.  ``"cvodes"``: CasADi's adaptive
SUNDIALS CVODES (BDF) with ``rtol``/``atol``, for reference runs; continuous
control only.  ``stats["events"]`` gives the count and the first and last located
time of the switching and torque-limit crossings.
``sgn`` is simulated as the discontinuous law it is: with a fixed step the
switching term chatters at the step rate, so the relative rate stalls at a
level proportional to the step (paper's case: ``Omega_m`` ~ 4.5e-4 rad/s with
``h = 0.05`` s, 8.7e-5 with 0.01 s) - what a digital implementation at that
rate would do; ``dopri5`` refuses it (it would chase the sliding mode); use
``sat``/``tanh`` for smooth runs.

Sampled control: with ``sample_period = Ts`` the torque is computed from the
state at ``t_k = k Ts`` and held constant (zero-order hold) while the plant is
integrated (RK4 sub-steps ``<= step``, or DOPRI5 on each hold interval); the
output grid is then the sample grid.
"""

from __future__ import annotations

import math
import time
from typing import Any

import casadi as ca
import numpy as np

from formsync_design.errors import InputError, SimulationError
from formsync_design.sim.adaptive import run_vm
from formsync_design.sim.formation import (
    Formation,
    SimOptions,
    state_names,
    unpack_state,
)
from formsync_design.sim.kernels import get_kernel, pack_params
from formsync_design.sim.lagrangian_outcome import classify_failure, lagrangian_message
from formsync_design.sim.metrics import convergence_time, linear_metrics
from formsync_design.sim.native import METHODS, SWITCH_EVENTS, get_native
from formsync_design.sim.native_c import CFG
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.spec.loader import Spec, load_spec

__all__ = [
    "simulate",
    "driver_config",
]


def simulate(
    formation: Any,
    options: Any = None,
    *,
    spec: Any = None,
    sensors: Any = None,
    torque_input: np.ndarray | None = None,
    trigger: Any = None,
) -> Any:
    """Simulate a formation under a design: the one entry point of simulation.

    What is simulated, and by which integrator, follows from the formation's type and the
    design:

    * a :class:`~formsync_design.sim.formation.Formation` (options :class:`SimOptions`): the
      design's Lagrangian view on the compiled whole-horizon driver (DOPRI5 or RK4 with
      located events, :mod:`formsync_design.sim.native`; CVODES on request), with the paper's
      metrics ``Q_m``/``Omega_m`` and the ``q0`` singularity; with ``trigger``
      (``"periodic:T"``, ``"event:SIGMA[:FLOOR]"`` or a
      :class:`~formsync_design.sim.sampled.TriggerSpec`) per-spacecraft sample-and-hold on
      the exact hybrid integrator (:func:`~formsync_design.sim.sampled.simulate_sampled`);
    * an :class:`~formsync_design.sim.agents.AgentFormation` (options
      :class:`~formsync_design.sim.agents.AgentOptions`): the design's agent form, per
      spacecraft on a directed weighted graph with a leader, controller states and the
      design's sampling rule (compiled RK4 formation kernel or CVODES for a continuous law,
      the exact hybrid integrator for a periodic, event- or self-triggered one;
      :func:`~formsync_design.sim.agents.simulate_agents`); a design given by its
      Lagrangian view runs its agent form (:func:`~formsync_design.spec.lagrangian_agent.agent_of`).
      ``sensors`` (a :class:`~formsync_design.sim.sensors.RateSensors` gyro model) and
      ``torque_input`` (``(steps, N, 3)`` held torques) are taken here;
    * a :class:`~formsync_design.sim.tracking_scenario.FlyaroundScenario` (options
      :class:`~formsync_design.sim.tracking_scenario.FlyaroundOptions`): the orbit and
      attitude closed loop of a design on the relative-orbit plant with thrusters,
      allocation and PWM (:func:`~formsync_design.sim.tracking.simulate_flyaround`; default design
      ``zhang2014_flyaround``), a formation of one spacecraft whose result also holds the
      relative orbit and the thrusters (``orbit``, an
      :class:`~formsync_design.sim.orbit_record.OrbitRecord`).

    Parameters
    ----------
    formation : Formation, AgentFormation or FlyaroundScenario
    options : SimOptions, AgentOptions or FlyaroundOptions, optional
        The options of the formation's path (its defaults when omitted).
    spec : Spec, AgentDesign, str, Path or None
        The design (a shipped design's name, a file or a loaded design; default: the paper's,
        ``liang2016``, or ``zhang2014_flyaround`` for a fly-around).  Kernels are cached
        under its content key.
    sensors, torque_input : optional
        An agent formation's gyro model and extra held torques (the ``rk4`` integrator and
        a continuous law); refused for the other paths.
    trigger : str or TriggerSpec, optional
        A Lagrangian formation's per-spacecraft trigger rule (an agent design declares its
        own sampling rule: :func:`~formsync_design.spec.agent.rule_variant`).

    Returns
    -------
    SimResult
        For every path (one type): status ``converged`` / ``not-converged`` / ``singular`` /
        ``diverged`` / ``stopped``, a finding, not an error.  A Lagrangian run's
        ``convergence_time`` is the criterion of its options (``Q_m <= q_tol`` and
        ``Omega_m <= omega_tol`` to the end), an agent run's that of
        :class:`~formsync_design.sim.agents.AgentOptions` (``angle_tol``, ``rate_tol``), a
        fly-around's that of :class:`~formsync_design.sim.tracking_scenario.FlyaroundOptions`
        (the attitude tracking error within ``angle_tol``, the relative-position error within
        ``position_tol``); ``attitude_error``/``rate_error`` are the largest pairwise
        principal angle and body-rate difference of a formation (a fly-around's one
        spacecraft: no pair, and ``rate_error`` is its rate tracking error ``|omega_sd|``).

    Raises
    ------
    InputError
        Options of another path, a formation the design cannot run (an agent-only design
        on a ``Formation``), ``sensors``/``torque_input`` outside an agent formation.
    SimulationError
        Quaternion norm drift beyond ``options.norm_tol``, a step-size underflow or too
        many steps away from the ``q0`` singularity.

    Examples
    --------
    >>> from formsync_design.graphs.build import make_graph
    >>> from formsync_design.models.disturbances import no_disturbance
    >>> from formsync_design.sim.formation import Formation, Gains
    >>> q = np.array([[0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]])
    >>> att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    >>> f = Formation(make_graph("path:2"), np.array([np.eye(3)] * 2), att, np.zeros((2, 3)),
    ...               Gains(1.6, 0.4, 0.3, (0.0, 0.0)), no_disturbance(2))
    >>> r = simulate(f, SimOptions(tf=60.0, compile=False))
    >>> str(r.status), r.final_q_m < 1e-4
    ('converged', True)

    The same spacecraft as an agent formation run the paper's law in its agent form:

    >>> from formsync_design.sim.agents import AgentFormation, AgentOptions
    >>> a = AgentFormation(make_graph("path:2"), f.inertias, att, np.zeros((2, 3)),
    ...                    Gains(K_o=1.6, K_q=0.4, beta=0.3, K_v=0.0), no_disturbance(2))
    >>> ra = simulate(a, AgentOptions(tf=60.0, output_step=0.5, step=0.05), spec="liang2016")
    >>> type(ra) is type(r), str(ra.status), bool(ra.attitude_error[-1] < 0.01)
    (True, 'converged', True)
    """
    from formsync_design.sim.agents import AgentFormation
    from formsync_design.spec.loader import agent_design_of, load_design

    measured = sensors is not None or torque_input is not None
    if trigger is not None and not isinstance(formation, Formation):
        raise InputError(f"expected a trigger rule only for a Formation (an agent design "
                         f"declares its sampling rule), received one with a "
                         f"{type(formation).__name__}")
    if _is_flyaround(formation):
        if measured:
            raise InputError("expected sensors and torque_input only for an AgentFormation, "
                             "received them with a fly-around scenario")
        from formsync_design.sim.tracking import simulate_flyaround

        return simulate_flyaround(formation, options, spec)
    if spec is not None:
        plant = getattr(getattr(load_design(spec), "decl", None), "plant", "attitude")
        if plant != "attitude":
            raise InputError(f"expected a FlyaroundScenario for a design on the {plant} plant, "
                             f"received a {type(formation).__name__}")
    if isinstance(formation, AgentFormation):
        from formsync_design.sim.agents import AgentOptions, simulate_agents
        from formsync_design.spec.lagrangian_agent import agent_of

        # a loaded design (agent or Lagrangian) as given, a name or file loaded
        design = agent_of(spec if getattr(spec, "decl", None) is not None else load_design(spec))
        agent_opt = options if options is not None else AgentOptions()
        if not isinstance(agent_opt, AgentOptions):
            raise InputError(f"expected AgentOptions for an AgentFormation, received a "
                             f"{type(agent_opt).__name__}")
        return simulate_agents(design, formation, agent_opt, sensors=sensors,
                               torque_input=torque_input)
    agent = agent_design_of(spec)
    if agent is not None:
        raise InputError(f"expected an AgentFormation for the agent design {agent.name}, "
                         f"received a {type(formation).__name__}")
    if measured:
        raise InputError(f"expected an AgentFormation for sensors or a torque input (the agent "
                         f"kernels' gyro and torque channels), received a "
                         f"{type(formation).__name__}")
    opt = options if options is not None else SimOptions()
    if not isinstance(formation, Formation):
        raise InputError(f"expected a Formation, an AgentFormation or a FlyaroundScenario, "
                         f"received a {type(formation).__name__}")
    if not isinstance(opt, SimOptions):
        raise InputError(f"expected SimOptions, received a {type(opt).__name__}")
    sp_spec = load_spec(spec)
    if trigger is not None:
        from formsync_design.sim.sampled import TriggerSpec, parse_trigger, simulate_sampled

        rule = trigger if isinstance(trigger, TriggerSpec) else parse_trigger(str(trigger))
        return simulate_sampled(formation, opt, rule, sp_spec)
    if opt.method == "cvodes":
        return _simulate_cvodes(formation, opt, sp_spec)
    return _simulate_driver(formation, opt, sp_spec)


def _is_flyaround(formation: Any) -> bool:
    """Is ``formation`` a fly-around scenario (checked without importing the tracking
    modules for the other paths)?"""
    if type(formation).__name__ != "FlyaroundScenario":
        return False
    from formsync_design.sim.tracking_scenario import FlyaroundScenario

    return isinstance(formation, FlyaroundScenario)


def _grid_count(opt: SimOptions) -> int:
    K = opt.tf / opt.interval
    Kr = round(K)
    if abs(K - Kr) > 1e-9 * max(1.0, K):
        raise InputError(
            f"expected tf ({opt.tf:g} s) to be a multiple of the output interval "
            f"({opt.interval:g} s), received ratio {K:.6g}"
        )
    return max(1, int(Kr))


def driver_config(opt: SimOptions, spec: Spec) -> np.ndarray:
    """The configuration vector of the whole-horizon driver for ``opt``
    (:data:`~formsync_design.sim.native_c.CFG`)."""
    method = opt.method
    swkind = SWITCH_EVENTS[opt.switch] if spec.decl.switching is not None else 0
    vals = {
        "method": METHODS[method], "interval": opt.interval, "substeps": opt.substeps,
        "rtol": opt.rtol, "atol": opt.atol,
        "hmax": opt.max_step if opt.max_step is not None else opt.tf,
        "floor": opt.q0_floor, "normtol": opt.norm_tol, "zoh": opt.sample_period is not None,
        "evtol": opt.event_tol, "qtol": opt.q_tol, "wtol": opt.omega_tol,
        "maxsteps": max(1e6, 1000.0 * _grid_count(opt)), "h0": 0.0, "swkind": swkind, "kinkstop": 1.0,
    }
    return np.array([float(vals[k]) for k in CFG])


def _runner(f: Formation, opt: SimOptions, spec: Spec, p: np.ndarray) -> tuple[Any, bool, float]:
    """``run(x0, t0, K, cfg)`` of the compiled driver, else of its Python mirror on CasADi's
    VM; whether compiled; the build seconds."""
    n = f.n
    t0 = time.perf_counter()
    nk = get_native(spec, opt.switch, opt.inverse, opt.compile)
    if nk is not None:
        def run(x0: np.ndarray, t: float, K: int, cfg: np.ndarray) -> Any:
            return nk.run(n, p, cfg, x0, t, K)
        return run, True, time.perf_counter() - t0
    kern = get_kernel(n, opt.switch, opt.sample_period is not None, 1, 1, opt.inverse, False, spec=spec)

    def run_py(x0: np.ndarray, t: float, K: int, cfg: np.ndarray) -> Any:
        return run_vm(kern, n, p, cfg, x0, t, K)
    return run_py, False, time.perf_counter() - t0


def _events(ev: dict[str, float], tol: float) -> dict[str, Any]:
    def one(name: str) -> dict[str, Any]:
        first, last = ev[f"{name}_first"], ev[f"{name}_last"]
        return {"count": int(ev[f"{name}_count"]),
                "first": None if math.isnan(first) else first,
                "last": None if math.isnan(last) else last}

    return {"tolerance": tol, "switching": one("switch"), "torque_limit": one("limit")}


def _simulate_driver(f: Formation, opt: SimOptions, spec: Spec) -> SimResult:
    """RK4 or DOPRI5 over the whole horizon in one call of the driver."""
    Ktot = _grid_count(opt)
    method = opt.method
    p = pack_params(f, opt, spec)
    cfg = driver_config(opt, spec)
    run, compiled, build = _runner(f, opt, spec, p)
    t0 = time.perf_counter()
    out = run(f.initial_state(), 0.0, Ktot, cfg)
    wall = time.perf_counter() - t0
    info = out.info
    X, U, MET, minq = out.X, out.U, out.MET, np.minimum(out.MINQ, f.attitudes[:, 3])
    kdone = int(info["kdone"])
    sing_sc = sing_t = div_t = None
    status = int(info["status"])
    if status == 1:
        sing_sc, sing_t = int(info["sc"]), float(info["tevent"])
    elif status in (2, 3):
        sc, when, q0_last = classify_failure(run, cfg, opt, X, info, Ktot, kdone)
        if sc is None:
            div_t = when
        else:
            sing_sc, sing_t = sc, when
            minq[sc - 1] = min(minq[sc - 1], q0_last)
    t = np.arange(X.shape[0]) * opt.interval
    steps = int(info["steps"])
    nfev, nctrl = int(info["nfev"]), int(info["nctrl"])
    stats: dict[str, Any] = {"integrator": method, "compiled": compiled}
    if method == "rk4":
        stats.update(step=opt.interval / opt.substeps, substeps_per_interval=opt.substeps)
    else:
        stats.update(rtol=opt.rtol, atol=opt.atol, rejected_steps=int(info["rejected"]))
    stats.update({
        "steps": steps,
        "rhs_evaluations": nfev,
        "controller_evaluations": nctrl if opt.sample_period is not None else nfev + nctrl,
        "wall_seconds": wall,
        "build_seconds": build,
        "events": _events(out.events, opt.event_tol),
    })
    return _finish(f, opt, spec.name, spec.key, t, X, U, minq, sing_sc, sing_t, stats, MET, div_t)


def _finish(
    f: Formation,
    opt: SimOptions,
    design: str,
    spec_key: str,
    t: np.ndarray,
    X: np.ndarray,
    U: np.ndarray,
    minq: np.ndarray,
    sing_sc: int | None,
    sing_t: float | None,
    stats: dict,
    metrics: np.ndarray | None = None,
    diverged_time: float | None = None,
) -> SimResult:
    n = f.n
    if metrics is None:
        om, qm = linear_metrics(X, n)
    else:
        om, qm = np.ascontiguousarray(metrics[:, 0]), np.ascontiguousarray(metrics[:, 1])
    quats, rates = unpack_state(X, n)
    norm_err = float(np.max(np.abs(np.linalg.norm(quats, axis=2) - 1)))
    stats = {**stats, "max_norm_error": norm_err}
    if norm_err > opt.norm_tol and sing_sc is None and diverged_time is None:
        raise SimulationError(
            f"expected the quaternion norm to stay within {opt.norm_tol:g} of 1, received drift "
            f"{norm_err:.3e}; tighten the step/tolerances"
        )
    if sing_sc is not None:
        status = SimStatus.SINGULAR
        ct = None
    elif diverged_time is not None:
        status = SimStatus.DIVERGED
        ct = None
    else:
        ct = convergence_time(t, om, qm, opt.q_tol, opt.omega_tol)
        status = SimStatus.CONVERGED if ct is not None else SimStatus.NOT_CONVERGED
    sat_end = None
    if opt.torque_limit is not None:
        at = np.flatnonzero((np.abs(U) >= opt.torque_limit * (1 - 1e-12)).any(axis=1))
        sat_end = float(t[at[-1]]) if at.size else None
    T = len(t)
    torques = U.reshape(T, n, 3)
    for a in (t, X, U, om, qm, quats, rates, torques):
        a.setflags(write=False)
    fields: dict[str, Any] = dict(
        status=status,
        design=design,
        graph=f.graph.name,
        t=t,
        quaternions=quats,
        rates=rates,
        states=np.zeros((T, n, 0)),
        torques=torques,
        reference=None,
        attitude_error=None,  # these three: computed from the trajectory on first read
        reference_error=None,
        rate_error=None,
        convergence_time=ct,
        peak_torque=np.max(np.abs(U.reshape(len(U), n, 3)), axis=0),
        effort=None,
        monitors={},
        state_names=tuple(state_names(n)),
        integrator=str(stats["integrator"]),
        diverged_time=diverged_time,
        omega_m=om,
        q_m=qm,
        min_q0=minq,
        singular_spacecraft=sing_sc,
        singular_time=sing_t,
        saturation_end_time=sat_end,
        stats=stats,
        options=opt,
        spec_key=spec_key,
    )
    return SimResult(message=lagrangian_message(SimResult(message="", **fields)), **fields)


def _simulate_cvodes(f: Formation, opt: SimOptions, spec: Spec) -> SimResult:
    n = f.n
    Ktot = _grid_count(opt)
    kern = get_kernel(n, opt.switch, False, 1, 1, opt.inverse, compile=False, spec=spec)
    p = pack_params(f, opt, spec)
    x = ca.SX.sym("x", 7 * n)
    t = ca.SX.sym("t")
    ps = ca.SX.sym("p", p.size)
    dae = {"x": x, "t": t, "p": ps, "ode": kern.rhs(x, t, ps)[0]}
    grid = np.arange(1, Ktot + 1) * opt.interval
    integ = ca.integrator(
        "fs_cvodes", "cvodes", dae, 0.0, grid,
        {"abstol": opt.atol, "reltol": opt.rtol, "max_num_steps": 10**7, "print_stats": False,
         **({"max_step_size": opt.max_step} if opt.max_step is not None else {})},
    )
    t0 = time.perf_counter()
    try:
        out = integ(x0=f.initial_state(), p=p)
    except RuntimeError as e:
        raise SimulationError(f"expected CVODES to integrate to tf = {opt.tf:g} s, it failed: {str(e)[:300]}") from None
    wall = time.perf_counter() - t0
    X = np.vstack([f.initial_state()[None, :], out["xf"].full().T])
    tg = np.arange(X.shape[0]) * opt.interval
    q0s = X[:, [4 * i + 3 for i in range(n)]]
    hit = np.flatnonzero((~(q0s > opt.q0_floor)).any(axis=1))
    sing_sc = sing_t = None
    if hit.size:
        k = int(hit[0])
        i = int(np.flatnonzero(~(q0s[k] > opt.q0_floor))[0])
        a, b = q0s[k - 1, i], q0s[k, i]
        frac = (a - opt.q0_floor) / (a - b) if np.isfinite(b) and a != b else 1.0
        sing_sc, sing_t = i + 1, float(tg[k - 1] + opt.interval * min(max(frac, 0), 1))
        X, tg = X[:k], tg[:k]
    div_t = None
    if not hit.size and not np.all(np.isfinite(X)):  # diverged: the trajectory ends before it
        k = int(np.flatnonzero(~np.isfinite(X).all(axis=1))[0])
        div_t = float(tg[k])
        X, tg, q0s = X[:k], tg[:k], q0s[:k]
    U = kern.ctrl.map(X.shape[0])(X.T, tg[None, :], p).full().T
    st = integ.stats()
    stats = {
        "integrator": "cvodes",
        "compiled": False,
        "rtol": opt.rtol,
        "atol": opt.atol,
        "steps": int(st.get("nsteps", -1)) if isinstance(st, dict) else -1,
        "rhs_evaluations": int(st.get("nfevals", -1)) if isinstance(st, dict) else -1,
        "wall_seconds": wall,
        "build_seconds": kern.compile_seconds,
    }
    minq = np.min(q0s[: max(1, X.shape[0])], axis=0)
    return _finish(f, opt, spec.name, kern.spec_key, tg, X, U, minq, sing_sc, sing_t, stats, None,
                   div_t)
