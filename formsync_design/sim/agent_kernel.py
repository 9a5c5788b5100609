"""Compiled formation kernels of agent designs (:mod:`formsync_design.spec.agent`).

The truth plant of every agent design is the same rigid body per spacecraft, integrated in
the unit quaternion (normalised after every step) and Euler's equation; the design sees its
own representation computed from it:

* ``quaternion``: ``q``, ``q0`` of the integrated (normalised) quaternion, sign as integrated;
* ``mrp``: ``sigma = q_v / (1 + q0)`` on the short set ``|sigma| <= 1`` (sign of ``q`` chosen
  with ``q0 >= 0``): the shadow-set switch of an MRP integrator happens exactly where the
  integrated ``q0`` changes sign (:func:`formsync_design.models.mrp.mrp_from_quat`);
* ``so3``: ``R(q)`` (body to inertial), orthonormal to rounding for a unit ``q``
  (``|R^T R - I| ~ 1e-16``): the rotation never drifts off the group.

State order (pydy style; documented in every result): ``q1_1, q2_1, q3_1, q0_1, ..., q0_N,
w1_1, ..., w3_N``, then the controller states ``z`` of spacecraft 1..N (declaration order),
then the reference quaternion ``q1_ref, q2_ref, q3_ref, q0_ref`` for a design with a leader.

Each spacecraft's law is translated once per in-degree ``m`` from SymPy to CasADi through the
one numeric bridge :func:`formsync_design.sim.bridge.sympy_to_casadi`; ``sgn`` becomes
``sign``, ``sat(x/phi)`` or ``tanh(x/phi)``.  The named CasADi function ``agent_law_m`` has
inputs ``own`` (attitude entries, rate, states), ``J`` (3x3), ``t``, ``nbrs`` (``m`` rows of
attitude, rate, states), ``a`` (``m`` weights), ``b``, ``ref`` (attitude, rate, rate
derivative), ``gains``, ``phi`` and outputs ``u``, ``zdot``, ``monitors``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from formsync_design.errors import InputError
from formsync_design.models.disturbances import (
    disturbance_torque,
    disturbance_trig,
    kernel_parameters,
)
from formsync_design.sim.bridge import sympy_to_casadi
from formsync_design.sim.layout import param_slices
from formsync_design.sim.reference_rate import reference_rate_expressions, reference_rate_function
from formsync_design.spec.agent import AgentDesign, agent_expressions
from formsync_design.spec.agent_view import AgentView, sgn
from formsync_design.spec.dag import replace_function
from formsync_design.spec.declarations import GainKind, GainRole

__all__ = [
    "agent_parameters",
    "ATTITUDE_SIZE",
    "AgentLaw",
    "agent_law",
    "attitude_entries",
    "AgentKernel",
    "agent_param_layout",
    "get_agent_kernel",
    "agent_state_names",
    "gain_vector",
    "gain_count",
    "LawInputs",
    "law_inputs",
]

#: Attitude entries a law receives per representation.
ATTITUDE_SIZE = {"quaternion": 4, "mrp": 3, "so3": 9}


def agent_state_names(n: int, design: AgentDesign) -> list[str]:
    """Names of the kernel state entries (module docstring).

    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}})
    >>> agent_state_names(2, d)[:4], agent_state_names(2, d)[-1]
    (['q1_1', 'q2_1', 'q3_1', 'q0_1'], 'w3_2')
    """
    out = [f"{c}_{i}" for i in range(1, n + 1) for c in ("q1", "q2", "q3", "q0")]
    out += [f"{c}_{i}" for i in range(1, n + 1) for c in ("w1", "w2", "w3")]
    for i in range(1, n + 1):
        for name, k in design.decl.states:
            out += [f"{name}{c}_{i}" for c in range(1, k + 1)]
    if design.decl.leader:
        out += ["q1_ref", "q2_ref", "q3_ref", "q0_ref"]
    return out


def attitude_entries(rep: str, q: Any) -> Any:
    """CasADi attitude entries of a representation from a quaternion ``(q1, q2, q3, q0)``
    (normalised here), in the order of :meth:`AttitudeSymbols.attitude_symbols`.

    >>> e = attitude_entries("mrp", ca.DM([0, 0, 0, -1.0]))
    >>> [float(x) for x in ca.vertcat(*e).full().ravel()]
    [0.0, 0.0, 0.0]
    """
    qn = q / ca.norm_2(q)
    v, q0 = qn[0:3], qn[3]
    if rep == "quaternion":
        return [qn[0], qn[1], qn[2], qn[3]]
    if rep == "mrp":
        s = ca.if_else(q0 >= 0, v / (1 + q0), -v / (1 - q0))
        return [s[0], s[1], s[2]]
    R = (q0 * q0 - ca.dot(v, v)) * ca.DM.eye(3) + 2 * ca.mtimes(v, v.T) + 2 * q0 * ca.skew(v)
    return [R[i, j] for j in range(3) for i in range(3)]  # column-major


def _switch(expr: Any, switch: str, phi: sp.Symbol) -> Any:
    # DAG-aware (formsync_design.spec.dag): a deeply composed law has a huge tree
    if switch == "sgn":
        return replace_function(expr, sgn, sp.sign)
    if switch == "sat":
        # unevaluated: SymPy's Min/Max search their arguments for redundant ones (slow on
        # a large argument) and would find none here
        return replace_function(expr, sgn, lambda a: sp.Max(-1, sp.Min(1, a / phi, evaluate=False),
                                                            evaluate=False))
    if switch == "tanh":
        return replace_function(expr, sgn, lambda a: sp.tanh(a / phi))
    raise InputError(f"expected a switch in ['sgn', 'sat', 'tanh'], received {switch!r}")


def _gain_symbols(design: AgentDesign) -> list[sp.Symbol]:
    """The controller gains' scalar symbols in kernel order (a diagonal gain: 3)."""
    out: list[sp.Symbol] = []
    for g in design.decl.gains:
        if g.role != GainRole.CONTROLLER:
            continue
        if g.kind == GainKind.DIAG:
            out += list(sp.symbols(f"{g.name}_1:4", positive=True))
        else:
            out.append(g.symbol)
    return out


def gain_count(design: AgentDesign) -> int:
    """The number of controller gain values in kernel order (a diagonal gain: 3), without
    deriving anything.

    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> gain_count(agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}))
    1
    """
    return sum(3 if g.kind == GainKind.DIAG else 1 for g in design.decl.gains
               if g.role == GainRole.CONTROLLER)


@dataclass
class AgentLaw:
    """The CasADi functions of one in-degree ``m`` (module docstring): ``law`` (``u``,
    ``zdot``, ``monitors``), and for sampled designs ``event`` / ``next_interval``
    (``(own, held, J, t, nbrs, a, b, ref, gains, phi) -> scalar``)."""

    m: int
    law: ca.Function
    monitors: tuple[str, ...]
    event: ca.Function | None = None
    next_interval: ca.Function | None = None


@dataclass
class LawInputs:
    """The CasADi inputs of a spacecraft's translated functions (module docstring: ``own``,
    ``held``, ``J``, ``t``, ``nbrs``, ``a``, ``b``, ``ref``, ``gains``, ``phi``) and the
    binding of every symbol of its view to them; :meth:`translate` turns an expression of the
    view into CasADi with the switching function replaced."""

    own: Any
    held: Any
    J: Any
    t: Any
    nbrs: Any
    a: Any
    b: Any
    ref: Any
    gains: Any
    phi: Any
    bind: dict[Any, Any]
    phi_symbol: sp.Symbol
    expressions: dict[str, Any]

    def translate(self, expr: Any, switch: str, memo: dict) -> Any:
        return sympy_to_casadi(_switch(sp.sympify(expr), switch, self.phi_symbol), self.bind,
                               memo)


def law_inputs(design: AgentDesign, m: int) -> LawInputs:
    """The inputs and bindings of a spacecraft with ``m`` in-neighbours, with the design's
    expressions on its view (:func:`~formsync_design.spec.agent.agent_expressions`)."""
    ex = agent_expressions(design, m)
    v: AgentView = ex["view"]
    na = ATTITUDE_SIZE[design.representation]
    states = design.decl.states
    nz = design.decl.state_size
    phi_s = sp.Symbol("phi", positive=True)
    own = ca.SX.sym("own", na + 3 + nz)
    held = ca.SX.sym("held", na + 3)
    J = ca.SX.sym("J", 3, 3)
    t = ca.SX.sym("t")
    nb = ca.SX.sym("nbrs", na + 3 + nz, max(m, 1))
    a = ca.SX.sym("a", max(m, 1))
    b = ca.SX.sym("b")
    ref = ca.SX.sym("ref", na + 6)
    gsyms = _gain_symbols(design)
    gains = ca.SX.sym("gains", max(len(gsyms), 1))
    phi = ca.SX.sym("phi")
    bind: dict[Any, Any] = {v.t: t, phi_s: phi}
    for k, s_ in enumerate(gsyms):
        bind[s_] = gains[k]
    for i in range(3):
        for j in range(3):
            bind[v.J[i, j]] = J[i, j]

    def bind_state(sym: Any, vec: Any, with_states: bool) -> None:
        for k, s_ in enumerate(sym.attitude_symbols()):
            bind[s_] = vec[k]
        for k in range(3):
            bind[sym.w[k]] = vec[na + k]
        if with_states:
            off = na + 3
            for name, size in states:
                for k in range(size):
                    bind[sym.z[name][k]] = vec[off + k]
                off += size

    bind_state(v.own, own, True)
    bind_state(v.held, held, False)
    for k, n in enumerate(v.nbrs):
        bind_state(n, nb[:, k], True)
        bind[n.a] = a[k]
    if design.decl.leader:
        bind[v.b] = b
        for k, s_ in enumerate(v.ref.attitude_symbols()):
            bind[s_] = ref[k]
        for k in range(3):
            bind[v.ref.w[k]] = ref[na + k]
            bind[v.ref.wdot[k]] = ref[na + 3 + k]
    return LawInputs(own, held, J, t, nb, a, b, ref, gains, phi, bind, phi_s, ex)


_LAWS: dict[tuple[str, int, str], AgentLaw] = {}


def agent_law(design: AgentDesign, m: int, switch: str = "sgn") -> AgentLaw:
    """The translated law of a spacecraft with ``m`` in-neighbours (cached by the design's key).

    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}})
    >>> f = agent_law(d, 0).law
    >>> f.name_in()[:3], float(f(own=[0, 0, 0, 1, 1, 2, 3], gains=[2])["u"][2])
    (['own', 'J', 't'], -6.0)
    """
    ck = (design.key, m, switch)
    hit = _LAWS.get(ck)
    if hit is not None:
        return hit
    li = law_inputs(design, m)
    ex = li.expressions
    states = design.decl.states
    memo: dict = {}

    def cas(e: Any) -> Any:
        return li.translate(e, switch, memo)

    own, held, J, t, nb, a, b, ref, gains, phi = (li.own, li.held, li.J, li.t, li.nbrs, li.a,
                                                  li.b, li.ref, li.gains, li.phi)
    u = cas(ex["u"])
    zdot = ca.vertcat(*[cas(ex["states"][n]) for n, _ in states]) if states else ca.SX.zeros(0)
    mons = ex.get("monitors", {})
    mon = ca.vertcat(*[cas(e) for e in mons.values()]) if mons else ca.SX.zeros(0)
    ins = [own, J, t, nb, a, b, ref, gains, phi]
    names = ["own", "J", "t", "nbrs", "a", "b", "ref", "gains", "phi"]
    law = ca.Function(f"agent_law_{m}", ins, [u, zdot, mon], names, ["u", "zdot", "monitors"])
    out = AgentLaw(m, law, tuple(mons))
    trig_ins = [own, held, J, t, nb, a, b, ref, gains, phi]
    trig_names = ["own", "held", "J", "t", "nbrs", "a", "b", "ref", "gains", "phi"]
    if "event" in ex:
        out.event = ca.Function(f"agent_event_{m}", trig_ins, [cas(ex["event"])], trig_names, ["g"])
    if "next_interval" in ex:
        out.next_interval = ca.Function(f"agent_tau_{m}", trig_ins, [cas(ex["next_interval"])],
                                        trig_names, ["tau"])
    _LAWS[ck] = out
    return out


def agent_param_layout(n: int, ngains: int, narcs: int) -> dict[str, slice]:
    """Slices of the flat kernel parameter vector."""
    sizes = [("gains", max(ngains, 1)), ("phi", 1), ("umax", 3 * n), ("J", 9 * n),
             ("Jinv", 9 * n), ("a", max(narcs, 1)), ("b", n), ("freq", 6), ("harm", 18 * n),
             ("gg", 1), ("orbit", 4), ("tfail", n)]
    return param_slices(sizes)


@dataclass
class AgentKernel:
    """The CasADi functions of one agent formation structure (internal to :mod:`sim.agents`).

    ``rhs(x, t, p) -> xdot``; ``observe(x, t, p) -> (u, monitors)`` (the limited torques of
    every spacecraft, ``3N``, and the monitors, ``nmon x N`` flattened spacecraft-major);
    ``plant(x, u, t, p) -> xdot`` (a given torque; the sampled path); ``chunk(x0, t0, h, p)
    -> X`` (``K`` output intervals of ``M`` RK4 sub-steps with the quaternions normalised
    after every sub-step, states at the interval ends).
    """

    n: int
    nx: int
    M: int
    K: int
    switch: str
    neighbours: tuple[tuple[int, ...], ...]
    monitors: tuple[str, ...]
    rhs: ca.Function
    observe: ca.Function
    plant: ca.Function
    chunk: ca.Function
    layout: dict[str, slice]
    compiled: bool = False
    compile_seconds: float = 0.0
    laws: dict[int, AgentLaw] = field(default_factory=dict)
    measured: bool = False
    mapped: dict[int, ca.Function] = field(default_factory=dict)
    integrators: dict[tuple[Any, ...], ca.Function] = field(default_factory=dict)
    batched: dict[tuple[int, int], ca.Function] = field(default_factory=dict)

    def chunk_map(self, runs: int, threads: int) -> ca.Function:
        """``chunk`` mapped over ``runs`` columns (initial states ``(nx + 1, runs)`` and
        parameter vectors ``(P, runs)``; the step is shared) on ``threads`` threads: each
        column is one call of ``chunk`` as a single run makes it (its parameter vector
        repeated over the ``K`` intervals, which ``chunk``, a ``mapaccum``, takes one per
        interval), the same compiled arithmetic, so every run equals its single run bitwise.
        Kept per count."""
        key = (runs, threads)
        fn = self.batched.get(key)
        if fn is None:
            xa = ca.MX.sym("xa", self.chunk.size_in(0))
            h = ca.MX.sym("h")
            p = ca.MX.sym("p", self.chunk.size1_in(2))
            one = ca.Function("agent_chunk_run", [xa, h, p], [self.chunk(xa, h, p)])
            fn = self.batched[key] = (one.map(runs, "thread", threads) if threads > 1
                                      else one.map(runs))
        return fn

    def cvodes(self, grid: np.ndarray, rtol: float, atol: float) -> ca.Function:
        """CasADi's CVODES over ``rhs`` from ``t = 0`` to the output times ``grid``
        (``x0``, ``p`` -> ``xf`` at every time), built once per grid and tolerances and kept:
        the runs of a verification on one formation share it."""
        key = (np.asarray(grid, dtype=float).tobytes(), float(rtol), float(atol))
        fn = self.integrators.get(key)
        if fn is None:
            xs, ts = ca.SX.sym("x", self.nx), ca.SX.sym("t")
            ps = ca.SX.sym("p", self.layout["_size"].stop)
            ode = {"x": xs, "t": ts, "p": ps, "ode": self.rhs(xs, ts, ps)}
            fn = self.integrators[key] = ca.integrator(
                "agents", "cvodes", ode, 0.0, [float(v) for v in grid],
                {"reltol": rtol, "abstol": atol, "max_num_steps": 10**7})
        return fn

    def observe_map(self, samples: int) -> ca.Function:
        """``observe`` mapped over ``samples`` columns (built once per count and kept: runs
        on one output grid share it)."""
        fn = self.mapped.get(samples)
        if fn is None:
            fn = self.mapped[samples] = self.observe.map(samples)
        return fn


def _normalise(x: Any, n: int, leader_at: int | None) -> Any:
    parts = []
    for i in range(n):
        qi = x[4 * i: 4 * i + 4]
        parts.append(qi / ca.norm_2(qi))
    rest = x[4 * n:] if leader_at is None else x[4 * n: leader_at]
    out = [*parts, rest]
    if leader_at is not None:
        qr = x[leader_at: leader_at + 4]
        out.append(qr / ca.norm_2(qr))
    return ca.vertcat(*out)


def _build(design: AgentDesign, neighbours: tuple[tuple[int, ...], ...], switch: str, M: int,
           K: int, ref_rate: tuple[Any, ...], measured: bool = False) -> AgentKernel:
    n = len(neighbours)
    rep = design.representation
    na = ATTITUDE_SIZE[rep]
    nz = design.decl.state_size
    leader = design.decl.leader
    narcs = sum(len(nb) for nb in neighbours)
    ngains = len(_gain_symbols(design))
    lay = agent_param_layout(n, ngains, narcs)
    nx = 7 * n + nz * n + (4 if leader else 0)
    x = ca.SX.sym("x", nx)
    uin = ca.SX.sym("u", 3 * n)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", lay["_size"].stop)
    q = [x[4 * i: 4 * i + 4] for i in range(n)]
    w = [x[4 * n + 3 * i: 4 * n + 3 * i + 3] for i in range(n)]
    z = [x[7 * n + nz * i: 7 * n + nz * i + nz] for i in range(n)]
    J = [ca.reshape(p[lay["J"]][9 * i: 9 * i + 9], 3, 3) for i in range(n)]
    Jinv = [ca.reshape(p[lay["Jinv"]][9 * i: 9 * i + 9], 3, 3) for i in range(n)]
    att = [ca.vertcat(*attitude_entries(rep, q[i])) for i in range(n)]
    # the measurement/disturbance channel (``measured`` kernels): ext = (rate offsets b_i + n_i
    # (3N), extra torques (3N)), held over each RK4 step; a law sees the rate its gyro reports,
    # h_i(t) (w_i + b_i + n_i) with h_i = 0 from the failure time on
    ext = ca.SX.sym("ext", 6 * n) if measured else ca.SX.zeros(6 * n)
    seen = w
    if measured:
        tf_ = p[lay["tfail"]]
        seen = [ca.if_else(t < tf_[i], 1, 0) * (w[i] + ext[3 * i: 3 * i + 3]) for i in range(n)]
    full = [ca.vertcat(att[i], seen[i], z[i]) for i in range(n)]
    laws: dict[int, AgentLaw] = {}
    if leader:
        lead_at = 7 * n + nz * n
        qr = x[lead_at: lead_at + 4]
        rr = reference_rate_function(ref_rate)
        wr, wdr = rr(t)
        ref = ca.vertcat(*attitude_entries(rep, qr), wr, wdr)
    else:
        lead_at = None
        ref = ca.SX.zeros(na + 6)
        wr = ca.SX.zeros(3)
    us, zds, mons = [], [], []
    arc = 0
    for i, nb in enumerate(neighbours):
        m = len(nb)
        law = laws.get(m) or agent_law(design, m, switch)
        laws[m] = law
        nbm = ca.horzcat(*[full[j] for j in nb]) if m else ca.SX.zeros(na + 3 + nz, 1)
        am = p[lay["a"]][arc: arc + m] if m else ca.SX.zeros(1)
        arc += m
        out = law.law(full[i], J[i], t, nbm, am, p[lay["b"]][i], ref, p[lay["gains"]],
                      p[lay["phi"]])
        lim = p[lay["umax"]][3 * i: 3 * i + 3]
        us.append(ca.fmin(lim, ca.fmax(-lim, out[0])))
        zds.append(out[1])
        mons.append(out[2])
    u = ca.vertcat(*us)
    trig = disturbance_trig(t, p[lay["freq"]], p[lay["orbit"]])

    def plant_expr(uv: Any) -> Any:
        dq, dw = [], []
        for i in range(n):
            v3, q0 = q[i][0:3], q[i][3]
            ud = disturbance_torque(trig, v3, q0, J[i], p[lay["harm"]][18 * i: 18 * i + 18],
                                    p[lay["gg"]])
            dq.append(ca.vertcat(0.5 * (q0 * w[i] + ca.cross(v3, w[i])), -0.5 * ca.dot(v3, w[i])))
            Jw = ca.mtimes(J[i], w[i])
            dw.append(ca.mtimes(Jinv[i], -ca.cross(w[i], Jw) + uv[3 * i: 3 * i + 3] + ud
                                + ext[3 * n + 3 * i: 3 * n + 3 * i + 3]))
        parts = [*dq, *dw, *zds]
        if leader:
            v3, q0 = qr[0:3], qr[3]
            parts.append(ca.vertcat(0.5 * (q0 * wr + ca.cross(v3, wr)), -0.5 * ca.dot(v3, wr)))
        return ca.vertcat(*parts)

    xin = [x, t, p, ext] if measured else [x, t, p]
    xnames = ["x", "t", "p", "ext"] if measured else ["x", "t", "p"]
    rhs = ca.Function("agent_rhs", xin, [plant_expr(u)], xnames, ["xdot"])
    plant = ca.Function("agent_plant", [x, uin, t, p], [plant_expr(uin)], ["x", "u", "t", "p"],
                        ["xdot"]) if not measured else ca.Function(
        "agent_plant", [x, uin, t, p, ext], [plant_expr(uin)], ["x", "u", "t", "p", "ext"], ["xdot"])
    mon_all = ca.vertcat(*mons) if mons else ca.SX.zeros(0)
    observe = ca.Function("agent_observe", xin, [u, mon_all], xnames, ["u", "monitors"])
    # RK4 sub-step on MX (the SX right-hand side called once per stage), then the output
    # interval of M sub-steps and K intervals by mapaccum
    xs, ts, hs, ps = ca.MX.sym("x", nx), ca.MX.sym("t"), ca.MX.sym("h"), ca.MX.sym("p", p.shape[0])
    es = ca.MX.sym("ext", 6 * n)
    ex = [es] if measured else []
    k1 = rhs(xs, ts, ps, *ex)
    k2 = rhs(xs + hs / 2 * k1, ts + hs / 2, ps, *ex)
    k3 = rhs(xs + hs / 2 * k2, ts + hs / 2, ps, *ex)
    k4 = rhs(xs + hs * k3, ts + hs, ps, *ex)
    xn = _normalise(xs + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4), n, lead_at)
    step = ca.Function("agent_step", [ca.vertcat(xs, ts), hs, ps, *ex], [ca.vertcat(xn, ts + hs)])
    xa, h2, p2 = ca.MX.sym("xa", nx + 1), ca.MX.sym("h"), ca.MX.sym("p", p.shape[0])
    eM = ca.MX.sym("ext", 6 * n, M)
    xk = xa
    if M <= 10:
        for j in range(M):
            xk = step(xk, h2, p2, *([eM[:, j]] if measured else []))
    else:
        xk = step.mapaccum("agent_steps", M)(xa, h2, p2, *([eM] if measured else []))[:, -1]
    interval = ca.Function("agent_interval", [xa, h2, p2, *([eM] if measured else [])], [xk])
    chunk = interval.mapaccum("agent_chunk", K)
    return AgentKernel(n=n, nx=nx, M=M, K=K, switch=switch, neighbours=neighbours,
                       monitors=next(iter(laws.values())).monitors if laws else (),
                       rhs=rhs, observe=observe, plant=plant, chunk=chunk, layout=lay,
                       laws=laws, measured=measured)


_KERNELS: dict[tuple[Any, ...], AgentKernel] = {}


def get_agent_kernel(design: AgentDesign, neighbours: tuple[tuple[int, ...], ...], switch: str,
                     M: int, K: int, ref_rate: Sequence[Any] = ("0", "0", "0"),
                     compile: bool = True, measured: bool = False) -> AgentKernel:
    """The (compiled, cached) kernel of a design on a graph structure (in-neighbour lists).

    ``ref_rate``: the leader's body rate, three SymPy expressions in ``t`` (or formulas,
    :func:`reference_rate_expressions`).  ``measured``: the kernel with the
    measurement/disturbance channel (``rhs``, ``observe``,
    ``plant`` take an extra input ``ext`` of ``6N``: rate offsets the laws see, then extra
    torques; ``chunk(x0, h, p, EXT)`` takes ``EXT`` of ``6N x (M K)``, one column per RK4
    step) and the gyro failure times ``p[layout["tfail"]]``.

    Cached in memory by the design's key, the structure and the options, and on disk by the
    generated C source (:func:`formsync_design.sim.kernels.compile_function`).
    """
    from formsync_design.sim.ccompile import compile_enabled
    from formsync_design.sim.kernels import compile_function

    compile = bool(compile) and compile_enabled()
    rate = reference_rate_expressions(ref_rate)
    key = (design.key, neighbours, switch, M, K, tuple(sp.srepr(r) for r in rate), compile,
           measured)
    hit = _KERNELS.get(key)
    if hit is not None:
        return hit
    t0 = time.perf_counter()
    k = _build(design, neighbours, switch, M, K, rate, measured)
    if compile:
        k.chunk, ok = compile_function(k.chunk, design.key)
        k.compiled = ok
    k.compile_seconds = time.perf_counter() - t0
    _KERNELS[key] = k
    return k


def gain_vector(design: AgentDesign, gains: Any) -> np.ndarray:
    """The controller gains of ``gains`` (a :class:`~formsync_design.sim.formation.Gains`) in
    kernel order; a gain the design does not declare, or a missing one, is an InputError.

    A design whose Lagrangian view has the switching gain ``K_v`` takes it, one controller
    gain of the agent form, from ``gains.K_v`` when it is given there (one value for every
    spacecraft)."""
    decls = [g for g in design.decl.gains if g.role == GainRole.CONTROLLER]
    names = tuple(g.name for g in decls)
    given = gains.as_dict()
    if "K_v" in names and "K_v" not in given and len(set(gains.K_v)) == 1:
        given["K_v"] = gains.K_v[0]
    if set(given) != set(names):
        raise InputError(f"expected the gains {', '.join(names)} of design {design.name}, "
                         f"received {', '.join(given) or 'none'}")
    out: list[float] = []
    for g in decls:
        val = given[g.name]
        if g.kind == GainKind.DIAG:
            out.extend(val if isinstance(val, tuple) else (val, val, val))
        elif isinstance(val, tuple):
            raise InputError(f"expected a scalar gain {g.name} (declared scalar), received "
                             f"three values")
        else:
            out.append(val)
    return np.asarray(out, dtype=float)


def agent_parameters(design: AgentDesign, f: Any, opt: Any, layout: dict) -> np.ndarray:
    """The flat kernel parameter vector of the formation ``f`` under the options ``opt``
    (an :class:`~formsync_design.sim.agents.AgentFormation` and
    :class:`~formsync_design.sim.agents.AgentOptions`; layout :func:`agent_param_layout`)."""
    p = np.zeros(layout["_size"].stop)
    g = gain_vector(design, f.gains)
    p[layout["gains"]][: g.size] = g
    p[layout["phi"]] = opt.phi
    p[layout["umax"]] = np.inf if opt.torque_limit is None else opt.torque_limit
    J = np.asarray(f.inertias, dtype=float)
    p[layout["J"]] = J.transpose(0, 2, 1).ravel()
    p[layout["Jinv"]] = np.linalg.inv(J).transpose(0, 2, 1).ravel()
    w = f.weights()
    p[layout["a"]][: w.size] = w
    p[layout["b"]] = f.graph.pinning_matrix.diagonal() if f.graph.has_leader else 0.0
    assert f.disturbance is not None
    freq, harm = kernel_parameters(f.disturbance)
    p[layout["freq"]] = freq
    p[layout["harm"]] = harm.ravel()
    p[layout["gg"]] = 1.0 if f.disturbance.gravity_gradient else 0.0
    o = f.disturbance.orbit
    p[layout["orbit"]] = (o.mu, o.radius, o.mean_motion, o.phase)
    return p
