"""Sampled agent designs: per-spacecraft sample-and-hold with the design's trigger rule.

``SAMPLING = "periodic"`` (period from :attr:`AgentOptions.period`), ``"event"`` (the
design's ``event(v)``, monitored continuously, crossings located by root finding) or
``"self-triggered"`` (the design's ``next_interval(v)``, evaluated at each broadcast).  The
exact hybrid integrator :func:`~formsync_design.sim.hybrid.simulate_hybrid` integrates the
rigid bodies (DOP853, ``AgentOptions.rtol``/``atol``) between updates; at an update of
spacecraft ``i`` (module docstring of :mod:`formsync_design.sim.agents`) it broadcasts
``(q_i, w_i)``, and its torque is recomputed from its current state, its in-neighbours' last
broadcasts and the reference at that instant, then held.  The reference itself is known to
pinned spacecraft at all times (closed form for a constant reference rate, a DOP853 solution
at ``rtol = 1e-12`` otherwise).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.models.quaternion import cross_matrix
from formsync_design.sim.agent_kernel import (
    ATTITUDE_SIZE,
    agent_law,
    gain_vector,
    get_agent_kernel,
    reference_rate_function,
)
from formsync_design.sim.hybrid import (
    HybridOptions,
    event,
    periodic,
    self_triggered,
    simulate_hybrid,
)
from formsync_design.spec.agent import AgentDesign

__all__ = ["simulate_agents_sampled", "attitude_entries_np", "reference_trajectory"]


def attitude_entries_np(rep: str, q: np.ndarray) -> np.ndarray:
    """NumPy twin of :func:`~formsync_design.sim.agent_kernel.attitude_entries`.

    >>> attitude_entries_np("mrp", np.array([0.0, 0, 1, 0])).tolist()
    [0.0, 0.0, 1.0]
    """
    qn = np.asarray(q, float) / np.linalg.norm(q)
    v, q0 = qn[:3], qn[3]
    if rep == "quaternion":
        return qn
    if rep == "mrp":
        return v / (1 + q0) if q0 >= 0 else -v / (1 - q0)
    R = (q0 * q0 - v @ v) * np.eye(3) + 2 * np.outer(v, v) + 2 * q0 * cross_matrix(v)
    return R.T.ravel()  # column-major


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product in the ``(q1, q2, q3, q0)`` order."""
    pv, p0, qv, q0 = p[:3], p[3], q[:3], q[3]
    return np.concatenate([p0 * qv + q0 * pv + np.cross(pv, qv), [p0 * q0 - pv @ qv]])


def reference_trajectory(reference: Any, tf: float) -> Any:
    """``t -> (q_ref (4,), w_ref (3,), wdot_ref (3,))`` on ``[0, tf]``.

    >>> from formsync_design.sim.agents import Reference
    >>> f = reference_trajectory(Reference((0, 0, 0, 1), ("0", "0", "0.1")), 10.0)
    >>> np.round(f(10.0)[0], 12).tolist() == np.round([0, 0, math.sin(0.5), math.cos(0.5)], 12).tolist()
    True
    """
    rr = reference_rate_function(reference.rate)
    q0 = np.asarray(reference.attitude, float)

    def rates(t: float) -> tuple[np.ndarray, np.ndarray]:
        w, wd = rr(t)
        return np.asarray(w).ravel(), np.asarray(wd).ravel()

    if reference.constant_rate:
        w = rates(0.0)[0]
        nw = float(np.linalg.norm(w))

        def at(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            if nw == 0.0:
                return q0.copy(), w, np.zeros(3)
            half = 0.5 * nw * t
            e = np.concatenate([math.sin(half) * w / nw, [math.cos(half)]])
            return _qmul(q0, e), w, np.zeros(3)

        return at
    from scipy.integrate import solve_ivp

    def f(t: float, q: np.ndarray) -> np.ndarray:
        w = rates(t)[0]
        v, s = q[:3], q[3]
        return np.concatenate([0.5 * (s * w + np.cross(v, w)), [-0.5 * v @ w]])

    sol = solve_ivp(f, (0.0, max(tf, 1e-9)), q0, method="DOP853", rtol=1e-12, atol=1e-14,
                    dense_output=True)

    def at_t(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = sol.sol(t)
        w, wd = rates(t)
        return q / np.linalg.norm(q), w, wd

    return at_t


def simulate_agents_sampled(design: AgentDesign, formation: Any, opt: Any) -> Any:
    """The sampled path of :func:`~formsync_design.sim.agents.simulate_agents` (module docstring)."""
    from formsync_design.sim.agents import agent_parameters, assemble_result

    f = formation
    n = f.n
    rep = design.representation
    na = ATTITUDE_SIZE[rep]
    rule = design.decl.sampling
    if rule == "periodic" and opt.period is None:
        raise InputError(f"expected a sampling period for the periodic design {design.name}, "
                         "received none")
    ref_rate = f.reference.rate if f.reference is not None else ("0", "0", "0")
    kern = get_agent_kernel(design, f.neighbours(), opt.switch, 1, 1, ref_rate, compile=False)
    p = agent_parameters(design, f, opt, kern.layout)
    nbrs = f.neighbours()
    laws = {len(nb): agent_law(design, len(nb), opt.switch) for nb in nbrs}
    a_all = f.weights()
    offs = np.cumsum([0] + [len(nb) for nb in nbrs])
    b = f.graph.pinning_matrix.diagonal() if f.graph.has_leader else np.zeros(n)
    gains = gain_vector(design, f.gains)
    J = np.asarray(f.inertias, float)
    umax = np.inf if opt.torque_limit is None else opt.torque_limit
    ref_at = reference_trajectory(f.reference, opt.tf) if f.reference is not None else None

    def ref_vec(t: float) -> np.ndarray:
        if ref_at is None:
            return np.zeros(na + 6)
        q, w, wd = ref_at(t)
        return np.concatenate([attitude_entries_np(rep, q), w, wd])

    def row(xr: np.ndarray) -> np.ndarray:
        return np.concatenate([attitude_entries_np(rep, xr[:4]), xr[4:7]])

    def nbr_block(i: int, held: np.ndarray) -> np.ndarray:
        nb = nbrs[i]
        if not nb:
            return np.zeros((na + 3, 1))
        return np.stack([row(held[j]) for j in nb], axis=1)

    def weights(i: int) -> np.ndarray:
        return a_all[offs[i]: offs[i + 1]] if len(nbrs[i]) else np.zeros(1)

    def control(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> np.ndarray:
        law = laws[len(nbrs[i])]
        u = law.law(row(xi), J[i], t, nbr_block(i, held), weights(i),
                    b[i], ref_vec(t), gains if gains.size else np.zeros(1), opt.phi)[0]
        return np.clip(np.asarray(u).ravel(), -umax, umax)

    def trig_args(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> list[Any]:
        return [row(xi), row(held[i]), J[i], t, nbr_block(i, held), weights(i), b[i], ref_vec(t),
                gains if gains.size else np.zeros(1), opt.phi]

    if rule == "periodic":
        rules = [periodic(opt.period)] * n
    elif rule == "event":
        def g(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> float:
            law = laws[len(nbrs[i])]
            assert law.event is not None
            return float(law.event(*trig_args(t, i, xi, held)))

        rules = [event(g)] * n
    elif rule == "self-triggered":
        def tau(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> float:
            law = laws[len(nbrs[i])]
            assert law.next_interval is not None
            val = float(law.next_interval(*trig_args(t, i, xi, held)))
            if not (math.isfinite(val) and val > 0):
                from formsync_design.errors import SimulationError

                raise SimulationError(f"the self-trigger rule of {design.name} gave a next "
                                      f"interval {val:g} <= 0 for spacecraft {i + 1} at "
                                      f"t = {t:g} s (the rule must be positive)")
            return val

        rules = [self_triggered(tau)] * n
    else:  # pragma: no cover - validated at load
        raise InputError(f"expected a sampled design, received SAMPLING {rule!r}")

    plant = kern.plant

    def dyn(t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        xx = np.concatenate([x[:, :4].ravel(), x[:, 4:7].ravel()])
        if ref_at is not None:
            xx = np.concatenate([xx, ref_at(t)[0]])
        dx = np.asarray(plant(xx, u.ravel(), t, p)).ravel()
        dq = dx[: 4 * n].reshape(n, 4)
        dw = dx[4 * n: 7 * n].reshape(n, 3)
        return np.concatenate([dq, dw], axis=1)

    T = int(math.floor(opt.tf / opt.output_step + 1e-9))
    t_eval = np.arange(T + 1) * opt.output_step
    x0 = np.concatenate([f.attitudes, f.rates], axis=1)
    res = simulate_hybrid(dyn, control, rules, x0, (0.0, float(t_eval[-1])), t_eval,
                          options=HybridOptions(rtol=opt.rtol, atol=opt.atol))
    Xs = res.x  # (T, N, 7)
    X = np.concatenate([Xs[:, :, :4].reshape(len(res.t), -1), Xs[:, :, 4:7].reshape(len(res.t), -1)],
                       axis=1)
    if ref_at is not None:
        X = np.concatenate([X, np.array([ref_at(tk)[0] for tk in res.t])], axis=1)
    return assemble_result(design, f, opt, kern, p, np.asarray(res.t), X, "hybrid-dop853",
                   torques=np.asarray(res.u), sampled=res)
