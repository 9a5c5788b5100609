"""Exact hybrid (sampled / event- / self-triggered) simulation of N agents.

Representation-agnostic: the plant is any vectorized ``f(t, x, u)`` with ``x`` of shape
``(N, n)`` (agent-major; row ``i`` is agent ``i``'s state in the plant's own coordinates,
e.g. ``(sigma_i, omega_i)`` for an MRP plant) and ``u`` of shape ``(N, m)``; it returns
``dx/dt`` of shape ``(N, n)``. The integrator state is ``y = [x.ravel(), eta]`` where
``eta`` holds one internal variable per dynamic-event agent (in agent order).

Information model
-----------------
Every agent ``i`` holds ``held[i]``, the state it last *broadcast*, and the last broadcast
of every other agent (the full ``(N, n)`` array ``held`` is passed to the user callables;
a law should read only its neighbours' rows). At a trigger of agent ``i`` at time ``t``:

1. agent ``i`` broadcasts ``x_i(t)``: ``held[i] = x_i(t)`` (seen at once by all agents);
2. agent ``i`` recomputes ``u_i = control(t, i, x_i(t), held)`` and holds it (zero-order
   hold) until its next update;
3. with ``recompute_on_receive=True`` each agent ``j`` that has ``i`` as neighbour
   (``adjacency[j, i] != 0``) also recomputes ``u_j = control(t, j, x_j(t), held)`` without
   broadcasting (as in e.g. Seyboth, Dimarogonas & Johansson 2013); with ``False`` (the
   default, e.g. Dimarogonas, Frazzoli & Johansson 2012) ``u_j`` changes only at ``j``'s
   own triggers.

All agents trigger at the initial time. Agents triggering at the same instant are handled
deterministically: all broadcasts of that instant are applied first (from the same
``x(t)``), then the controls are recomputed in increasing agent order.

Trigger rules (per agent, :class:`TriggerRule`)
-----------------------------------------------
``periodic(T)``
    ``t_k = t_0 + k T`` (computed as a product, no accumulated rounding).
``event(g)``
    trigger at the first ``t`` with ``g(t, i, x_i(t), held) >= 0``, monitored continuously:
    the crossing is located by Brent root finding on the DOP853 dense output (scipy
    ``solve_ivp`` events, ``xtol = 4 eps``), never rounded to a grid. If a broadcast
    makes ``g >= 0`` hold at once, the agent triggers at that same instant.
``self_triggered(tau)``
    at each own trigger ``t_k`` the next time is ``t_{k+1} = t_k + tau(t_k, i, x_i(t_k),
    held)`` (``held`` after the broadcasts of ``t_k``), ``tau > 0``; nothing is
    monitored between triggers (Dimarogonas, Frazzoli & Johansson 2012, section IV).
``dynamic_event(g, beta, theta, eta0)``
    Girard, "Dynamic triggering mechanisms for event-triggered control", IEEE TAC 60(7),
    2015, eqs. (9)-(10) with ``g = gamma(|e|) - sigma alpha(|x|)`` (the quantity a static
    rule keeps non-positive): ``eta' = -beta eta - g``, ``eta(t_0) = eta0 >= 0``, and the
    agent triggers at the first ``t`` with ``eta + theta (-g) < 0`` i.e. when
    ``eta - theta g`` crosses zero downwards. ``eta`` is continuous (not reset). As
    ``theta -> inf`` the static rule ``g >= 0`` is recovered.

Zeno protection
---------------
A trigger of agent ``i`` less than ``min_interevent`` after its previous one stops the run
with status :attr:`HybridStatus.ZENO`; more than ``max_triggers`` triggers in total (the
initial broadcasts excluded) stops it with :attr:`HybridStatus.MAX_TRIGGERS`. Both say so
in ``message``; the trajectory up to the stop is returned.

Divergence
----------
Accepted integrator steps are always finite (a non-finite error estimate rejects the
step). When the dynamics give a non-finite value beyond the last accepted step (the state
or a held input blows up) and the integrator cannot go on, the run stops with status
:attr:`HybridStatus.DIVERGED` and ``diverged_time`` = the time of that last finite state
(a finding, not an error); the trajectory up to it is returned.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from formsync_design.errors import InputError
from formsync_design.gains import json_number

__all__ = [
    "HybridStatus",
    "TriggerKind",
    "TriggerRule",
    "HybridOptions",
    "HybridResult",
    "periodic",
    "event",
    "self_triggered",
    "dynamic_event",
    "simulate_hybrid",
]

Dynamics = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
Control = Callable[[float, int, np.ndarray, np.ndarray], np.ndarray]
AgentScalar = Callable[[float, int, np.ndarray, np.ndarray], float]


class HybridStatus(enum.StrEnum):
    """How a hybrid run ended."""

    COMPLETED = "completed"
    ZENO = "zeno"
    MAX_TRIGGERS = "max-triggers"
    SOLVER_FAILED = "solver-failed"
    DIVERGED = "diverged"


class TriggerKind(enum.StrEnum):
    """The four trigger rules (module docstring)."""

    PERIODIC = "periodic"
    EVENT = "event"
    SELF_TRIGGERED = "self-triggered"
    DYNAMIC_EVENT = "dynamic-event"


@dataclass(frozen=True)
class TriggerRule:
    """One agent's trigger rule; build it with :func:`periodic`, :func:`event`,
    :func:`self_triggered` or :func:`dynamic_event`."""

    kind: TriggerKind
    period: float | None = None
    g: AgentScalar | None = None
    tau: AgentScalar | None = None
    beta: float = 0.0
    theta: float = 0.0
    eta0: float = 0.0

    @property
    def scheduled(self) -> bool:
        """True when the next trigger time is known in advance (periodic, self-triggered)."""
        return self.kind in (TriggerKind.PERIODIC, TriggerKind.SELF_TRIGGERED)


def _positive(value: float, name: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"expected {name} > 0 and finite, received {v:g}")
    return v


def periodic(period: float) -> TriggerRule:
    """Periodic sampling ``t_k = t_0 + k T``.

    >>> periodic(0.5).period
    0.5
    """
    return TriggerRule(TriggerKind.PERIODIC, period=_positive(period, "period"))


def event(g: AgentScalar) -> TriggerRule:
    """Static event trigger: fire when ``g(t, i, x_i, held) >= 0``.

    >>> event(lambda t, i, xi, held: abs(xi[0] - held[i][0]) - 0.1).kind
    <TriggerKind.EVENT: 'event'>
    """
    return TriggerRule(TriggerKind.EVENT, g=g)


def self_triggered(tau: AgentScalar) -> TriggerRule:
    """Self-trigger: next time ``t_k + tau(t_k, i, x_i(t_k), held)``.

    >>> self_triggered(lambda t, i, xi, held: 0.2).kind.value
    'self-triggered'
    """
    return TriggerRule(TriggerKind.SELF_TRIGGERED, tau=tau)


def dynamic_event(g: AgentScalar, beta: float, theta: float, eta0: float) -> TriggerRule:
    """Girard's (2015) dynamic trigger: ``eta' = -beta eta - g``, fire when ``eta - theta g < 0``.

    >>> dynamic_event(lambda t, i, xi, held: 0.0, beta=1.0, theta=2.0, eta0=0.1).theta
    2.0
    """
    beta = float(beta)
    theta = float(theta)
    eta0 = float(eta0)
    for name, v in (("beta", beta), ("theta", theta), ("eta0", eta0)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"expected {name} >= 0 and finite, received {v:g}")
    return TriggerRule(TriggerKind.DYNAMIC_EVENT, g=g, beta=beta, theta=theta, eta0=eta0)


@dataclass(frozen=True)
class HybridOptions:
    """Integration and protection settings (module docstring).

    ``event_tol`` decides which other event agents fire together with the one located
    (``g >= -event_tol``; ``eta - theta g <= event_tol``) and the time tolerance for
    coinciding scheduled triggers.
    """

    rtol: float = 1e-10
    atol: float = 1e-12
    min_interevent: float = 1e-9
    max_triggers: int = 100_000
    event_tol: float = 1e-10
    recompute_on_receive: bool = False


@dataclass(frozen=True)
class HybridResult:
    """A finished hybrid run (frozen).

    Attributes
    ----------
    status, message : how it ended (``message`` is empty on completion)
    t : (T,) requested output times reached; x : (T, N, n) states; u : (T, N, m) the held
        inputs (right-continuous: the value after any update at that instant)
    eta : (T, N) dynamic-event variables (nan for other agents)
    trigger_times : per agent, its trigger (broadcast) times, the initial one included and
        none at the final time ``t1``
    trigger_states : per agent, (K_i, n) the broadcast states
    transmissions : (N,) number of broadcasts per agent (initial one included)
    min_interevent, mean_interevent : (N,) per agent (nan with fewer than two triggers)
    control_effort : (N,) ``int ||u_i||^2 dt`` over the run (exact: ``u`` is piecewise constant)
    stop_time : end of the simulated trajectory
    diverged_time : the time of the last finite state of a ``diverged`` run (else None)
    """

    status: HybridStatus
    message: str
    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    eta: np.ndarray
    trigger_times: tuple[tuple[float, ...], ...]
    trigger_states: tuple[np.ndarray, ...]
    transmissions: np.ndarray
    min_interevent: np.ndarray
    mean_interevent: np.ndarray
    control_effort: np.ndarray
    stop_time: float
    stats: dict[str, Any] = field(default_factory=dict)
    diverged_time: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (numbers through :func:`~formsync_design.gains.json_number`)."""

        def nums(a: Any) -> list[Any]:
            return [json_number(v) for v in np.asarray(a, dtype=float).ravel()]

        return {
            "status": self.status.value,
            "message": self.message,
            "stop_time": json_number(self.stop_time),
            "diverged_time": None if self.diverged_time is None else json_number(self.diverged_time),
            "trigger_times": [[json_number(v) for v in ts] for ts in self.trigger_times],
            "transmissions": [int(v) for v in self.transmissions],
            "min_interevent": nums(self.min_interevent),
            "mean_interevent": nums(self.mean_interevent),
            "control_effort": nums(self.control_effort),
            "final_state": nums(self.x[-1]) if len(self.t) else [],
            "stats": {k: json_number(v) for k, v in self.stats.items()},
        }


def _check_inputs(
    x0: np.ndarray, rules: Sequence[TriggerRule], adjacency: Any, t_span: tuple[float, float]
) -> np.ndarray:
    if x0.ndim != 2:
        raise InputError(f"expected x0 of shape (N, n), received shape {x0.shape}")
    n_agents = x0.shape[0]
    if len(rules) != n_agents:
        raise InputError(
            f"expected {n_agents} trigger rules (one per agent), received {len(rules)}"
        )
    a = np.zeros((n_agents, n_agents)) if adjacency is None else np.asarray(adjacency, float)
    if a.shape != (n_agents, n_agents):
        raise InputError(
            f"expected adjacency of shape ({n_agents}, {n_agents}), received {a.shape}"
        )
    t0, t1 = (float(v) for v in t_span)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"expected t_span (t0, t1) with t1 > t0, received ({t0:g}, {t1:g})")
    return a


def simulate_hybrid(
    f: Dynamics,
    control: Control,
    rules: Sequence[TriggerRule],
    x0: Any,
    t_span: tuple[float, float],
    t_eval: Any,
    *,
    adjacency: Any = None,
    options: HybridOptions | None = None,
) -> HybridResult:
    """Simulate N agents with per-agent sampled control and trigger rules (module docstring).

    Parameters
    ----------
    f : ``f(t, x, u) -> dx`` vectorized over agents, shapes ``(N, n), (N, m) -> (N, n)``
    control : ``control(t, i, x_i, held) -> (m,)``, evaluated only at update instants
    rules : one :class:`TriggerRule` per agent
    x0 : (N, n) initial states; t_span : (t0, t1); t_eval : output times in ``[t0, t1]``
    adjacency : (N, N), ``adjacency[j, i] != 0`` when ``j`` listens to ``i`` (only used with
        ``recompute_on_receive``)

    Examples
    --------
    Two scalar agents ``x' = u`` with ``u_i = -x_i(t_k)`` sampled every 0.5 s:

    >>> f = lambda t, x, u: u
    >>> law = lambda t, i, xi, held: -xi
    >>> r = simulate_hybrid(f, law, [periodic(0.5)] * 2, [[1.0], [2.0]], (0.0, 1.0), [1.0])
    >>> r.status.value, r.transmissions.tolist(), round(float(r.x[-1, 1, 0]), 12)
    ('completed', [2, 2], 0.5)
    """
    opts = options or HybridOptions()
    x0a = np.array(x0, dtype=float)
    adj = _check_inputs(x0a, rules, adjacency, t_span)
    n_agents, n = x0a.shape
    t0, t_end = float(t_span[0]), float(t_span[1])
    t_out = np.sort(np.asarray(t_eval, dtype=float).ravel())
    if t_out.size and (t_out[0] < t0 or t_out[-1] > t_end):
        raise InputError(
            f"expected t_eval within [{t0:g}, {t_end:g}], received [{t_out[0]:g}, {t_out[-1]:g}]"
        )

    dyn = [i for i, r in enumerate(rules) if r.kind is TriggerKind.DYNAMIC_EVENT]
    dyn_slot = {i: n_agents * n + k for k, i in enumerate(dyn)}
    monitored = [i for i, r in enumerate(rules) if not r.scheduled]

    held = x0a.copy()
    held_view = held.view()  # what user callables see: read-only, always current
    held_view.flags.writeable = False
    u = np.zeros((n_agents, 0))
    y = np.concatenate([x0a.ravel(), [rules[i].eta0 for i in dyn]])
    period_count = [0] * n_agents
    next_time = [math.inf] * n_agents
    triggers: list[list[float]] = [[] for _ in range(n_agents)]
    trig_states: list[list[np.ndarray]] = [[] for _ in range(n_agents)]
    effort = np.zeros(n_agents)
    xs: list[np.ndarray] = []
    us: list[np.ndarray] = []
    etas: list[np.ndarray] = []
    n_triggers = 0
    n_segments = 0
    nfev = 0
    status, message = HybridStatus.COMPLETED, ""
    diverged_time: float | None = None
    nonfinite = [-math.inf]  # the latest time the dynamics gave a non-finite value

    def g_of(i: int, t: float, x: np.ndarray) -> float:
        rule = rules[i]
        assert rule.g is not None
        return float(rule.g(t, i, x[i], held_view))

    def rhs(t: float, yy: np.ndarray) -> np.ndarray:
        x = yy[: n_agents * n].reshape(n_agents, n)
        dx = np.asarray(f(t, x, u), dtype=float).reshape(n_agents * n)
        deta = [-rules[i].beta * yy[dyn_slot[i]] - g_of(i, t, x) for i in dyn]
        out = np.concatenate([dx, deta])
        if not np.isfinite(out).all():
            nonfinite[0] = max(nonfinite[0], t)
        return out

    def trigger_value(i: int, t: float, yy: np.ndarray) -> float:
        x = yy[: n_agents * n].reshape(n_agents, n)
        if rules[i].kind is TriggerKind.EVENT:
            return g_of(i, t, x)
        return yy[dyn_slot[i]] - rules[i].theta * g_of(i, t, x)

    def fires_now(i: int, t: float, yy: np.ndarray, tol: float) -> bool:
        v = trigger_value(i, t, yy)
        return v >= -tol if rules[i].kind is TriggerKind.EVENT else v < tol

    def make_event(i: int) -> Callable[[float, np.ndarray], float]:
        def ev(t: float, yy: np.ndarray) -> float:
            return trigger_value(i, t, yy)

        ev.terminal = True  # type: ignore[attr-defined]
        ev.direction = 1.0 if rules[i].kind is TriggerKind.EVENT else -1.0  # type: ignore[attr-defined]
        return ev

    def update(t: float, yy: np.ndarray, firing: list[int]) -> None:
        nonlocal u
        x = yy[: n_agents * n].reshape(n_agents, n)
        for i in firing:
            held[i] = x[i]
            triggers[i].append(t)
            trig_states[i].append(x[i].copy())
        recompute = set(firing)
        if opts.recompute_on_receive:
            recompute |= {j for j in range(n_agents) for i in firing if adj[j, i] != 0}
        new = [
            (j, np.asarray(control(t, j, x[j].copy(), held.copy()), dtype=float).ravel())
            for j in sorted(recompute)
        ]
        if u.shape[1] == 0:
            u = np.zeros((n_agents, new[0][1].size))
        for j, uj in new:
            u[j] = uj
        for i in firing:
            rule = rules[i]
            if rule.kind is TriggerKind.PERIODIC:
                assert rule.period is not None
                period_count[i] += 1
                next_time[i] = t0 + period_count[i] * rule.period
            elif rule.kind is TriggerKind.SELF_TRIGGERED:
                assert rule.tau is not None
                tau = float(rule.tau(t, i, x[i].copy(), held.copy()))
                if not (math.isfinite(tau) and tau > 0):
                    raise InputError(
                        f"expected tau > 0 from agent {i + 1}'s self-trigger at t={t:g}, received {tau:g}"
                    )
                next_time[i] = t + tau

    def record(
        sol_fn: Callable[[np.ndarray], np.ndarray], lo: float, hi: float, last: bool
    ) -> None:
        mask = (t_out >= lo) & ((t_out <= hi) if last else (t_out < hi))
        for tk in t_out[mask]:
            yk = sol_fn(np.array([tk]))[:, 0] if hi > lo else y
            xs.append(yk[: n_agents * n].reshape(n_agents, n).copy())
            us.append(u.copy())
            e = np.full(n_agents, np.nan)
            for i in dyn:
                e[i] = yk[dyn_slot[i]]
            etas.append(e)

    t = t0
    update(t, y, list(range(n_agents)))
    firing = [i for i in monitored if fires_now(i, t, y, 0.0)]
    while True:
        # process triggers at the current instant (repeatedly: a broadcast can fire others)
        while firing:
            too_soon = [
                i for i in firing if triggers[i] and t - triggers[i][-1] < opts.min_interevent
            ]
            if too_soon:
                i = too_soon[0]
                status = HybridStatus.ZENO
                message = (
                    f"agent {i + 1} triggered {t - triggers[i][-1]:g} s after its previous trigger at "
                    f"t={t:g}, below min_interevent={opts.min_interevent:g}; try a rule with a "
                    "positive dwell or a larger threshold"
                )
                break
            if n_triggers + len(firing) > opts.max_triggers:
                status = HybridStatus.MAX_TRIGGERS
                message = f"more than max_triggers={opts.max_triggers} triggers by t={t:g}; raise max_triggers or check the rule for Zeno behaviour"
                break
            n_triggers += len(firing)
            update(t, y, firing)
            firing = [i for i in monitored if fires_now(i, t, y, 0.0)]
        if status is not HybridStatus.COMPLETED or t >= t_end:
            break
        t_stop = min([t_end] + [next_time[i] for i in range(n_agents) if rules[i].scheduled])
        sol = solve_ivp(
            rhs,
            (t, t_stop),
            y,
            method="DOP853",
            rtol=opts.rtol,
            atol=opts.atol,
            events=[make_event(i) for i in monitored] or None,
            dense_output=True,
        )
        n_segments += 1
        nfev += int(sol.nfev)
        t_last = float(sol.t[-1])
        if sol.status == -1 and nonfinite[0] >= t_last:  # a finding: it ends at the last finite state
            record(sol.sol, t, t_last, last=True)
            effort += np.sum(u**2, axis=1) * (t_last - t)
            t, status, diverged_time = t_last, HybridStatus.DIVERGED, t_last
            message = (f"diverged at t = {t_last:g} s (the dynamics are not finite beyond the state "
                       "at that time): check the gains, the torque limit and the sample period")
            break
        if sol.status == -1:
            status = HybridStatus.SOLVER_FAILED
            message = f"solve_ivp failed at t={t:g}: {sol.message}; try looser tolerances"
            break
        t_new = float(sol.t[-1]) if sol.status == 1 else t_stop
        y_new = sol.y[:, -1]
        record(sol.sol, t, t_new, last=t_new >= t_end)
        effort += np.sum(u**2, axis=1) * (t_new - t)
        t, y = t_new, y_new
        if t >= t_end:  # the horizon: no trigger is counted there
            break
        tol_t = opts.event_tol * max(1.0, abs(t))
        firing = [i for i in range(n_agents) if rules[i].scheduled and next_time[i] <= t + tol_t]
        firing += [i for i in monitored if fires_now(i, t, y, opts.event_tol)]
        firing.sort()

    trig = tuple(tuple(ts) for ts in triggers)
    gaps = [np.diff(ts) for ts in triggers]
    x_arr = np.array(xs).reshape(len(xs), n_agents, n)
    m = u.shape[1]
    return HybridResult(
        status=status,
        message=message,
        t=t_out[: len(xs)].copy(),
        x=x_arr,
        u=np.array(us).reshape(len(us), n_agents, m),
        eta=np.array(etas).reshape(len(etas), n_agents),
        trigger_times=trig,
        trigger_states=tuple(np.array(s).reshape(len(s), n) for s in trig_states),
        transmissions=np.array([len(ts) for ts in triggers]),
        min_interevent=np.array([float(gp.min()) if gp.size else math.nan for gp in gaps]),
        mean_interevent=np.array([float(gp.mean()) if gp.size else math.nan for gp in gaps]),
        control_effort=effort,
        stop_time=t,
        stats={"segments": n_segments, "rhs_evaluations": nfev, "triggers": n_triggers},
        diverged_time=diverged_time,
    )
