"""Sampled formations: a design's controller with per-spacecraft sample-and-hold and
trigger rules, on the nonlinear attitude dynamics.

The continuous simulator (:func:`~formsync_design.sim.simulator.simulate`) evaluates
every controller with fresh neighbour data.  Here each spacecraft ``i`` broadcasts its
state ``x_i = (q_i, q0_i, omega_i)`` only at its own trigger instants and holds its
torque in between (zero-order hold), through the exact hybrid integrator
:func:`~formsync_design.sim.hybrid.simulate_hybrid` (DOP853, event location by root
finding).  At an update of spacecraft ``i``:

    s_i = sum_{j in G_i} (q_i(t_k) - qhat_j),     q_i' = E(q_i) omega_i,
    u_i = controller(q_i, q0_i, q_i', J_i, s_i; gains)     (the design's, via the CasADi bridge)

with ``qhat_j`` the last broadcast of neighbour ``j``.  The plant and the disturbance are
the compiled formation kernel's (:class:`~formsync_design.sim.kernels.Kernel` ``plant``),
so the same model equations serve both simulators.

Trigger rules (``TriggerSpec``; ASSUMPTION, the toolbox's choice where a design does not
state its own rule):

``periodic:T``
    every spacecraft broadcasts every ``T`` seconds;
``event:SIGMA[:FLOOR]``
    spacecraft ``i`` broadcasts when ``|q_i - qhat_i| >= SIGMA |shat_i| + FLOOR``, with
    ``shat_i = sum_j (qhat_i - qhat_j)`` (the mixed relative/absolute threshold of
    event-triggered consensus, e.g. Seyboth, Dimarogonas & Johansson 2013; the floor
    excludes Zeno behaviour near consensus).

Outputs: the one :class:`~formsync_design.sim.result.SimResult` of a formation run (the
trajectory, held torques, the paper's metrics, the trigger instants and the number of
transmissions per spacecraft).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import parse_number
from formsync_design.sim.bridge import build_controller, controller_gain_names
from formsync_design.sim.formation import Formation, SimOptions, state_names
from formsync_design.sim.hybrid import (
    HybridOptions,
    HybridResult,
    HybridStatus,
    event,
    periodic,
    simulate_hybrid,
)
from formsync_design.sim.kernels import get_kernel, pack_params
from formsync_design.sim.metrics import convergence_time, formation_metrics
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.spec.loader import Spec, load_spec

__all__ = ["TriggerSpec", "parse_trigger", "simulate_sampled"]


@dataclass(frozen=True)
class TriggerSpec:
    """A trigger rule of every spacecraft: ``kind`` periodic or event, and its numbers.

    >>> parse_trigger("event:0.1:1e-4")
    TriggerSpec(kind='event', period=None, sigma=0.1, floor=0.0001)
    """

    kind: str
    period: float | None = None
    sigma: float | None = None
    floor: float = 0.0

    def text(self) -> str:
        if self.kind == "periodic":
            return f"periodic:{self.period:g}"
        return f"event:{self.sigma:g}:{self.floor:g}"


def parse_trigger(text: str) -> TriggerSpec:
    """``periodic:T`` or ``event:SIGMA[:FLOOR]`` (module docstring).

    >>> parse_trigger("periodic:0.5").period
    0.5
    >>> parse_trigger("sometimes")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected --trigger periodic:T or event:SIGMA[:FLOOR], received 'sometimes'
    """
    parts = str(text).split(":")
    usage = f"expected --trigger periodic:T or event:SIGMA[:FLOOR], received {text!r}"
    if parts[0] == "periodic" and len(parts) == 2:
        T = float(parse_number(parts[1], "trigger period"))
        if not (math.isfinite(T) and T > 0):
            raise InputError(f"expected a positive trigger period, received {parts[1]!r}")
        return TriggerSpec("periodic", period=T)
    if parts[0] == "event" and len(parts) in (2, 3):
        sigma = float(parse_number(parts[1], "trigger sigma"))
        floor = float(parse_number(parts[2], "trigger floor")) if len(parts) == 3 else 0.0
        if not (math.isfinite(sigma) and sigma >= 0 and math.isfinite(floor) and floor >= 0):
            raise InputError(f"expected SIGMA >= 0 and FLOOR >= 0, received {text!r}")
        if sigma == 0 and floor == 0:
            raise InputError(f"expected SIGMA > 0 or FLOOR > 0 (else every instant triggers), "
                             f"received {text!r}")
        return TriggerSpec("event", sigma=sigma, floor=floor)
    raise InputError(usage)


def simulate_sampled(
    f: Formation,
    opt: SimOptions,
    trigger: TriggerSpec,
    spec: Spec | str | None = None,
    *,
    hybrid: HybridOptions | None = None,
    record: dict | None = None,
) -> SimResult:
    """Simulate ``f`` with per-spacecraft sample-and-hold under ``trigger`` (module docstring).

    Uses ``opt.tf``, ``opt.output_step``, ``opt.switch``/``opt.phi`` (the design's switching
    substitute), ``opt.torque_limit``, ``opt.q_tol``/``opt.omega_tol``.  ``record`` (a dict)
    receives the hybrid run (``"hybrid"``: the broadcast states and the integrator's
    statistics).

    Returns
    -------
    SimResult
        The one result type of a formation run (:mod:`~formsync_design.sim.result`): the
        trajectory on the output grid, the held torques, the paper's metrics ``Q_m`` and
        ``Omega_m`` and the convergence time by ``opt.q_tol``/``opt.omega_tol``, the
        transmissions, inter-event times and trigger instants per spacecraft, the exact
        control effort; status ``converged``/``not-converged`` when the horizon was
        reached, ``diverged`` (a non-finite state, ``diverged_time``) or ``stopped`` (Zeno
        protection, too many triggers, a solver failure: ``message`` says which).

    Examples
    --------
    >>> import numpy as np
    >>> from formsync_design.graphs import make_graph
    >>> from formsync_design.models.disturbances import no_disturbance
    >>> from formsync_design.sim import Formation, Gains, SimOptions
    >>> q = np.array([[0.1, 0.0, 0.0], [-0.1, 0.05, 0.0], [0.0, -0.05, 0.1]])
    >>> att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    >>> f = Formation(make_graph("path:3"), np.array([np.eye(3) * 50] * 3), att,
    ...               np.zeros((3, 3)), Gains(k_p=0.5, k_d=1.5), no_disturbance(3))
    >>> r = simulate_sampled(f, SimOptions(tf=60), parse_trigger("periodic:0.5"),
    ...                      "pd_consensus")
    >>> r.converged, r.transmissions.tolist(), r.integrator
    (True, [120, 120, 120], 'hybrid-dop853')
    """
    sp_ = load_spec(spec)
    n = f.n
    kern = get_kernel(n, opt.switch, False, 1, 1, opt.inverse, compile=False, spec=sp_)
    p = pack_params(f, opt, sp_)
    ctrl = build_controller(sp_, switch=opt.switch, inverse=opt.inverse).function
    names = controller_gain_names(sp_)
    gv = f.gains.as_dict()
    gargs = [gv[nm] for nm in names]
    kv = f.gains.K_v
    J = np.asarray(f.inertias, dtype=float)
    A = np.asarray(f.graph.adjacency, dtype=float)
    nbrs = [np.flatnonzero(A[i]) for i in range(n)]
    umax = math.inf if opt.torque_limit is None else float(opt.torque_limit)

    def to_kernel(X: np.ndarray) -> np.ndarray:
        return np.concatenate([X[:, :4].ravel(), X[:, 4:].ravel()])

    def plant(t: float, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        xd = np.asarray(kern.plant(to_kernel(X), U.ravel(), t, p)).ravel()
        return np.column_stack([xd[: 4 * n].reshape(n, 4), xd[4 * n :].reshape(n, 3)])

    def control(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> np.ndarray:
        q, q0, w = xi[:3], xi[3], xi[4:]
        E = 0.5 * (q0 * np.eye(3) + np.array([[0, -q[2], q[1]], [q[2], 0, -q[0]],
                                                [-q[1], q[0], 0]]))
        s = sum((q - held[j, :3] for j in nbrs[i]), np.zeros(3))
        out = ctrl(q, q0, E @ w, J[i], s, *gargs, kv[i], opt.phi)
        u = np.asarray(out[0]).ravel()
        return np.clip(u, -umax, umax)

    if trigger.kind == "periodic":
        rules = [periodic(float(trigger.period))] * n  # type: ignore[arg-type]
    elif trigger.kind == "event":
        sig, fl = float(trigger.sigma), float(trigger.floor)  # type: ignore[arg-type]

        def g(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> float:
            shat = sum((held[i, :3] - held[j, :3] for j in nbrs[i]), np.zeros(3))
            return float(np.linalg.norm(xi[:3] - held[i, :3]) - sig * np.linalg.norm(shat) - fl)

        rules = [event(g)] * n
    else:
        raise InputError(f"expected a periodic or event trigger, received {trigger.kind!r}")
    x0 = np.column_stack([f.attitudes, f.rates])
    t_eval = np.arange(int(round(opt.tf / opt.output_step)) + 1) * opt.output_step
    h = simulate_hybrid(plant, control, rules, x0, (0.0, float(opt.tf)), t_eval, adjacency=A,
                        options=hybrid)
    if record is not None:
        record["hybrid"] = h
    return _result(f, opt, sp_, trigger, h)


def _result(f: Formation, opt: SimOptions, sp_: Spec, trigger: TriggerSpec,
            h: HybridResult) -> SimResult:
    """The :class:`~formsync_design.sim.result.SimResult` of the hybrid run ``h``."""
    n = f.n
    X = np.stack([np.concatenate([x[:, :4].ravel(), x[:, 4:].ravel()]) for x in h.x])
    om, qm = formation_metrics(n, X)
    t = np.asarray(h.t, dtype=float)
    U = np.asarray(h.u, dtype=float).reshape(len(t), n, 3)
    ct = convergence_time(t, om, qm, opt.q_tol, opt.omega_tol)
    if h.status == HybridStatus.COMPLETED:
        status = SimStatus.CONVERGED if ct is not None else SimStatus.NOT_CONVERGED
        message = (f"{trigger.text()}: converged at t = {ct:g} s" if ct is not None else
                   f"{trigger.text()}: not converged within {opt.tf:g} s")
    else:
        status = SimStatus.DIVERGED if h.status == HybridStatus.DIVERGED else SimStatus.STOPPED
        message, ct = h.message, None
    sat_end = None
    if opt.torque_limit is not None:
        at = np.flatnonzero((np.abs(U) >= opt.torque_limit * (1 - 1e-12)).any(axis=(1, 2)))
        sat_end = float(t[at[-1]]) if at.size else None
    W = np.asarray(h.x, dtype=float)[:, :, 4:]
    return SimResult(
        status=status, message=message, design=sp_.name, graph=f.graph.name, t=t,
        quaternions=np.asarray(h.x, dtype=float)[:, :, :4], rates=W,
        states=np.zeros((len(t), n, 0)), torques=U, reference=None, attitude_error=None,
        reference_error=None, rate_error=None, convergence_time=ct,
        peak_torque=np.abs(U).max(axis=0) if len(t) else np.zeros((n, 3)),
        effort=np.asarray(h.control_effort, dtype=float), monitors={},
        transmissions=np.asarray(h.transmissions), min_interevent=h.min_interevent,
        mean_interevent=h.mean_interevent,
        trigger_times=tuple(np.asarray(ts, dtype=float) for ts in h.trigger_times),
        state_names=tuple(state_names(n)), integrator="hybrid-dop853",
        diverged_time=h.diverged_time, omega_m=om, q_m=qm, saturation_end_time=sat_end,
        stats=dict(h.stats), options=opt, spec_key=sp_.key)
