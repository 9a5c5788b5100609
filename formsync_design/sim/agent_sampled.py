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

A design with kept values (``HOLD``, :mod:`formsync_design.sim.agent_triggers`) computes
``hold(v)`` at each of its updates and its trigger functions read them.  ``record`` (a dict,
optional) receives the hybrid run (``"hybrid"``), the number of trigger-function
evaluations per spacecraft (``"trigger_evaluations"``: every evaluation of ``event`` by the
integrator's crossing detection and root finding, or one ``next_interval`` per broadcast)
and the kept values at every update (``"kept"``: per spacecraft, ``(K_i, size)``).  The rigid
bodies' right-hand side is compiled (C, cached on disk) unless ``FORMSYNC_NO_COMPILE`` is set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.models.quaternion import cross_matrix
from formsync_design.sim.agent_kernel import (
    ATTITUDE_SIZE,
    agent_law,
    agent_parameters,
    gain_vector,
    get_agent_kernel,
)
from formsync_design.sim.hybrid import (
    HybridOptions,
    event,
    periodic,
    self_triggered,
    simulate_hybrid,
)
from formsync_design.sim.reference_rate import reference_rate_expressions
from formsync_design.spec.agent import AgentDesign

__all__ = ["SampledRun", "run_sampled_agents", "attitude_entries_np", "reference_trajectory"]

_PLANTS: dict[tuple[Any, ...], Any] = {}


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
    import sympy as sp

    ts = sp.Symbol("t", real=True)
    exprs = list(reference_rate_expressions(reference.rate))
    w_np = sp.lambdify(ts, exprs, "numpy")
    wd_np = sp.lambdify(ts, [sp.diff(e, ts) for e in exprs], "numpy")
    q0 = np.asarray(reference.attitude, float)

    def rates(t: float) -> tuple[np.ndarray, np.ndarray]:
        return (np.asarray(w_np(t), dtype=float).ravel(),
                np.asarray(wd_np(t), dtype=float).ravel())

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


@dataclass(frozen=True)
class SampledRun:
    """One sampled run in kernel state order: the kernel and parameter vector it was observed
    with, the update grid ``t``, the states (``(T, nx)``), the held torques and the hybrid
    run (:class:`~formsync_design.sim.hybrid.HybridResult`)."""

    kernel: Any
    parameters: np.ndarray
    t: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    hybrid: Any


def run_sampled_agents(design: AgentDesign, formation: Any, opt: Any,
                       record: dict | None = None) -> SampledRun:
    """The sampled run of :func:`~formsync_design.sim.agents.simulate_agents` (module
    docstring; ``formation``, ``opt``: an :class:`~formsync_design.sim.agents.AgentFormation`
    and :class:`~formsync_design.sim.agents.AgentOptions`; ``record``: the hybrid run, trigger
    evaluations and kept values), assembled into an
    :class:`~formsync_design.sim.result.SimResult` by
    :func:`~formsync_design.sim.agents.simulate_agents_sampled`."""
    f = formation
    n = f.n
    rep = design.representation
    na = ATTITUDE_SIZE[rep]
    rule = design.decl.sampling
    if rule == "periodic" and opt.period is None:
        raise InputError(f"expected a sampling period for the periodic design {design.name}, "
                         "received none")
    ref_rate = f.reference.rate if f.reference is not None else ("0", "0", "0")
    law_design = _law_design(design)
    kern = get_agent_kernel(law_design, f.neighbours(), opt.switch, 1, 1, ref_rate, compile=False)
    p = agent_parameters(design, f, opt, kern.layout)
    nbrs = f.neighbours()
    laws = {len(nb): agent_law(law_design, len(nb), opt.switch) for nb in nbrs}
    a_all = f.weights()
    offs = np.cumsum([0] + [len(nb) for nb in nbrs])
    b = f.graph.pinning_matrix.diagonal() if f.graph.has_leader else np.zeros(n)
    gains = gain_vector(design, f.gains)
    J = np.asarray(f.inertias, float)
    umax = np.inf if opt.torque_limit is None else opt.torque_limit
    ref_at = reference_trajectory(f.reference, opt.tf) if f.reference is not None else None
    last_ref: list[Any] = [None, None]

    def ref_vec(t: float) -> np.ndarray:
        if ref_at is None:
            return np.zeros(na + 6)
        if last_ref[0] != t:  # every spacecraft's trigger is evaluated at the same instants
            q, w, wd = ref_at(t)
            last_ref[0], last_ref[1] = t, np.concatenate([attitude_entries_np(rep, q), w, wd])
        return last_ref[1]

    def row(xr: np.ndarray) -> np.ndarray:
        return np.concatenate([attitude_entries_np(rep, xr[:4]), xr[4:7]])

    def nbr_block(i: int, held: np.ndarray) -> np.ndarray:
        nb = nbrs[i]
        if not nb:
            return np.zeros((na + 3, 1))
        return np.stack([row(held[j]) for j in nb], axis=1)

    def weights(i: int) -> np.ndarray:
        return a_all[offs[i]: offs[i + 1]] if len(nbrs[i]) else np.zeros(1)

    gains_in = gains if gains.size else np.zeros(1)
    kept_fns: dict[int, Any] = {}
    if design.decl.hold:
        from formsync_design.sim.agent_triggers import kept_size, kept_trigger_functions

        kept_fns = {len(nb): kept_trigger_functions(design, len(nb), opt.switch) for nb in nbrs}
        kept = np.zeros((n, max(kept_size(design), 1)))
    kept_log: list[list[np.ndarray]] = [[] for _ in range(n)]
    evaluations = np.zeros(n, dtype=np.int64)

    def control(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> np.ndarray:
        law = laws[len(nbrs[i])]
        if kept_fns:
            kept[i] = _caller(kept_fns[len(nbrs[i])].hold)(
                row(xi), row(held[i]), kept[i], J[i], t, nbr_block(i, held), weights(i), b[i],
                ref_vec(t), gains_in, opt.phi)[0]
            kept_log[i].append(kept[i].copy())
        u = _caller(law.law)(row(xi), J[i], t, nbr_block(i, held), weights(i),
                             b[i], ref_vec(t), gains_in, opt.phi)[0]
        return np.clip(u, -umax, umax)

    def trig_args(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> list[Any]:
        if kept_fns:
            return [row(xi), row(held[i]), kept[i], J[i], t, nbr_block(i, held), weights(i), b[i],
                    ref_vec(t), gains_in, opt.phi]
        return [row(xi), row(held[i]), J[i], t, nbr_block(i, held), weights(i), b[i], ref_vec(t),
                gains_in, opt.phi]

    def trig_fn(i: int, which: str) -> Any:
        src = kept_fns[len(nbrs[i])] if kept_fns else laws[len(nbrs[i])]
        fn = getattr(src, which)
        assert fn is not None
        return fn

    if rule == "periodic":
        rules = [periodic(opt.period)] * n
    elif rule == "event":
        def g(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> float:
            evaluations[i] += 1
            return float(_caller(trig_fn(i, "event"))(*trig_args(t, i, xi, held))[0][0])

        rules = [event(g)] * n
    elif rule == "self-triggered":
        def tau(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> float:
            evaluations[i] += 1
            val = float(_caller(trig_fn(i, "next_interval"))(*trig_args(t, i, xi, held))[0][0])
            if not (math.isfinite(val) and val > 0):
                from formsync_design.errors import SimulationError

                raise SimulationError(f"the self-trigger rule of {design.name} gave a next "
                                      f"interval {val:g} <= 0 for spacecraft {i + 1} at "
                                      f"t = {t:g} s (the rule must be positive)")
            return val

        rules = [self_triggered(tau)] * n
    else:  # pragma: no cover - validated at load
        raise InputError(f"expected a sampled design, received SAMPLING {rule!r}")

    plant = _compiled_plant(design, kern, f.neighbours(), ref_rate)
    # the bodies' rates do not depend on the reference quaternion the plant also carries
    lead = np.array([0.0, 0.0, 0.0, 1.0]) if ref_at is not None else np.zeros(0)

    call = _BufferedCall(plant, [np.zeros(kern.nx), np.zeros(3 * n), np.zeros(1), p], kern.nx)

    def dyn(t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        args = call.args
        args[0][: 4 * n] = x[:, :4].ravel()
        args[0][4 * n: 7 * n] = x[:, 4:7].ravel()
        args[0][7 * n:] = lead
        args[1][:] = u.ravel()
        args[2][0] = t
        dx = call()
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
    if record is not None:
        record["hybrid"] = res
        record["trigger_evaluations"] = evaluations.copy()
        record["kept"] = tuple(np.array(k) for k in kept_log)
    return SampledRun(kernel=kern, parameters=p, t=np.asarray(res.t), states=X,
                      torques=np.asarray(res.u), hybrid=res)


def _law_design(design: AgentDesign) -> AgentDesign:
    """The design the kernel translates: itself, or for a design with kept values its law
    alone (its trigger functions read ``v.kept`` and are translated by
    :mod:`formsync_design.sim.agent_triggers`)."""
    if not design.decl.hold:
        return design
    from dataclasses import replace
    from types import MappingProxyType

    return replace(design, key=f"{design.key}:law", decl=replace(design.decl, hold=(),
                   sampling="periodic"), functions=MappingProxyType(
                   {"controller": design.controller, **{k: v for k, v in design.functions.items()
                                                        if k == "monitors"}}))


def _compiled_plant(design: AgentDesign, kern: Any, neighbours: Any, ref_rate: Any) -> Any:
    """The kernel's plant ``(x, u, t, p) -> xdot``, compiled to C (cached on disk by the
    generated source) unless compilation is disabled."""
    from formsync_design.sim.ccompile import compile_enabled
    from formsync_design.sim.kernels import compile_function

    if not compile_enabled():
        return kern.plant
    key = (design.key, tuple(neighbours), tuple(str(r) for r in ref_rate))
    hit = _PLANTS.get(key)
    if hit is None:
        hit, _ = compile_function(kern.plant, design.key)
        _PLANTS[key] = hit
    return hit


_CALLERS: dict[int, Any] = {}


def _caller(fn: Any) -> Any:
    """The buffered caller of a CasADi function (one per function object, kept alive)."""
    hit = _CALLERS.get(id(fn))
    if hit is None or hit[0] is not fn:
        hit = (fn, _ArgCall(fn))
        _CALLERS[id(fn)] = hit
    return hit[1]


class _ArgCall:
    """``fn(*args) -> [outputs as flat arrays]`` through the zero-copy buffer of ``fn``: each
    argument (a number or an array, matrices column-major as CasADi stores them) is copied into
    a bound array, so no CasADi ``DM`` is built per call."""

    def __init__(self, fn: Any) -> None:
        self.ins = [np.zeros(fn.size1_in(k) * fn.size2_in(k)) for k in range(fn.n_in())]
        self.outs = [np.zeros(fn.size1_out(k) * fn.size2_out(k)) for k in range(fn.n_out())]
        self._buf, self._trigger = fn.buffer()
        for k, a in enumerate(self.ins):
            if a.size:
                self._buf.set_arg(k, memoryview(a))  # type: ignore[arg-type]
        for k, a in enumerate(self.outs):
            if a.size:
                self._buf.set_res(k, memoryview(a))  # type: ignore[arg-type]

    def __call__(self, *args: Any) -> list[np.ndarray]:
        for dst, a in zip(self.ins, args):
            if dst.size:
                dst[:] = np.ravel(a, order="F")
        self._trigger()
        return [o.copy() for o in self.outs]


class _BufferedCall:
    """A CasADi function evaluated through its zero-copy buffer (``Function.buffer``): the
    arguments are NumPy arrays bound once (``args``, updated in place by the caller), the
    result a fresh copy - about 200 times cheaper per call than ``fn(*numpy_arrays)``."""

    def __init__(self, fn: Any, args: list[np.ndarray], n_out: int) -> None:
        self.args = [np.ascontiguousarray(a, dtype=float).copy() for a in args]
        self.out = np.zeros(n_out)
        self._buf, self._trigger = fn.buffer()
        for k, a in enumerate(self.args):
            self._buf.set_arg(k, memoryview(a))  # type: ignore[arg-type]
        self._buf.set_res(0, memoryview(self.out))  # type: ignore[arg-type]

    def __call__(self) -> np.ndarray:
        self._trigger()
        return self.out.copy()
