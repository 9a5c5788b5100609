"""Closed-loop kernels: the parameter vector, the CasADi functions of one formation
size / controller, their C compilation and the caches (memory and disk).

Every cache is keyed by the specification's content (:attr:`Spec.key
<formsync_design.spec.loader.Spec.key>`) as well as the size and options, so a
variant controller is never simulated with another controller's kernel.  The
compiled objects live in :func:`cache_dir` ``/kernels`` (never inside the
repository), named ``<function>_<digest>.so`` where the digest covers the
generated C source, the specification key, the flags, the CasADi version and
the host.

Everything is built from :func:`agent_functions`, the closed loop of one spacecraft
(the derived model and the specification's controller through the bridge): the
formation-level functions of :class:`Kernel` (CasADi's VM, CVODES, the RK4 ``chunk``
kernels) call it per spacecraft, and the compiled whole-horizon kernel
(:mod:`formsync_design.sim.native`) loops over it in C.

Compilation (:mod:`formsync_design.sim.ccompile`): with a C compiler ``get_kernel(...,
compile=True)`` compiles the ``chunk`` kernels; without one they run in CasADi's
virtual machine (slower) and a :class:`RuntimeWarning` says so once.
``FORMSYNC_NO_COMPILE=1`` selects the virtual machine on purpose.  A compiler that
exists but fails raises :class:`~formsync_design.errors.CompilerError` (exit status 3).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from formsync_design.errors import CompilerError, InputError
from formsync_design.models.disturbances import (
    disturbance_torque,
    disturbance_trig,
    kernel_parameters,
)
from formsync_design.sim.bridge import build_controller, controller_gain_names, model_function
from formsync_design.sim.ccompile import (
    build_shared,
    c_compiler,
    compile_enabled,
    generated_source,
    warn_no_compiler,
)
from formsync_design.sim.formation import Formation, SimOptions
from formsync_design.sim.layout import param_slices
from formsync_design.sim.metrics import metrics_expr
from formsync_design.spec.loader import Spec, load_spec

__all__ = [
    "CHUNK",
    "UNROLL_MAX",
    "Kernel",
    "get_kernel",
    "cached_kernels",
    "clear_kernel_cache",
    "pack_params",
    "param_layout",
    "gain_size",
    "compile_function",
    "agent_functions",
    "NTRIG",
]


def gain_size(spec: Spec) -> int:
    """Entries of the controller gains in the parameter vector (a diagonal gain: 3).

    >>> gain_size(load_spec(None))
    3
    """
    return sum(3 if str(g.kind) == "diag" else 1 for g in spec.decl.gains
               if g.name in controller_gain_names(spec))


def param_layout(n: int, ngains: int = 3) -> dict[str, slice]:
    """Slices of the flat kernel parameter vector (``ngains``: :func:`gain_size`)."""
    sizes = [
        ("gains", ngains),  # the design's controller gains (liang2016: K_o, K_q, beta)
        ("K_v", n),
        ("phi", 1),
        ("umax", 3 * n),
        ("J", 9 * n),
        ("Jinv", 9 * n),
        ("L", n * n),
        ("freq", 6),  # shared disturbance frequencies (w1[3], w2[3])
        ("harm", 18 * n),
        ("gg", 1),
        ("orbit", 4),  # mu, R, n, theta0
    ]
    return param_slices(sizes)


def pack_params(f: Formation, opt: SimOptions, spec: Spec | None = None) -> np.ndarray:
    """The flat parameter vector of the compiled kernel for ``f`` and ``opt``.

    The controller gains are packed in the order of ``spec``'s declaration
    (default: the gains' own order); gains that are not the design's are an
    :class:`~formsync_design.errors.InputError`.
    """
    n = f.n
    g = f.gains
    gv = g.vector(controller_gain_names(spec) if spec is not None else None)
    if spec is not None and spec.decl.switching is None and any(k != 0 for k in g.K_v):
        raise InputError(f"expected no K_v for design {spec.name} (it has no switching term), "
                         f"received K_v = {max(g.K_v):g}")
    lay = param_layout(n, len(gv))
    p = np.zeros(lay["_size"].stop)
    p[lay["gains"]] = gv
    p[lay["K_v"]] = g.K_v
    p[lay["phi"]] = opt.phi
    p[lay["umax"]] = np.inf if opt.torque_limit is None else opt.torque_limit
    J = np.asarray(f.inertias, dtype=float)
    p[lay["J"]] = J.transpose(0, 2, 1).ravel()  # column-major per matrix (CasADi)
    p[lay["Jinv"]] = np.linalg.inv(J).transpose(0, 2, 1).ravel()
    p[lay["L"]] = f.graph.laplacian.astype(float).T.ravel()
    freq, harm = kernel_parameters(f.disturbance)
    p[lay["freq"]] = freq
    p[lay["harm"]] = harm.ravel()
    p[lay["gg"]] = 1.0 if f.disturbance.gravity_gradient else 0.0
    o = f.disturbance.orbit
    p[lay["orbit"]] = (o.mu, o.radius, o.mean_motion, o.phase)
    return p


@dataclass
class Kernel:
    """CasADi functions of one formation size / controller variant (internal).

    ``ctrl(x, t, p) -> u`` (3N torques, limited), ``plant(x, u, t, p) -> xdot``,
    ``rhs(x, t, p) -> (xdot, u)`` (continuous closed loop), ``evaluate(x, t, p) -> (xdot,
    u, tau, uraw)`` (with the switching argument and the torque before the limit),
    ``metrics(x) -> (Omega_m, Q_m)``,
    ``chunk(xa, h, p) -> (XA, U, MINQ0, MET)`` - ``K`` output intervals of ``M`` RK4
    sub-steps each, ``xa = (x, t)``; ``mc_chunk(xa, h, p) -> (XA_end, S)`` with
    per-interval summaries ``S = (Omega_m, Q_m, min q0, max|u|, max norm error)``.
    """

    n: int
    switch: str
    zoh: bool
    M: int
    K: int
    inverse: str
    spec_key: str
    ctrl: ca.Function
    plant: ca.Function
    rhs: ca.Function
    metrics: ca.Function
    chunk: ca.Function
    mc_chunk: ca.Function
    compiled: bool = False
    compile_seconds: float = 0.0
    sources: dict = field(default_factory=dict)
    evaluate: ca.Function | None = None
    layout: dict = field(default_factory=dict)


#: Entries of the time-only disturbance vector of :func:`agent_functions` (``fsk_trig``).
NTRIG = 16


def _trig_vector(trig: dict) -> Any:
    return ca.vertcat(trig["s1"], trig["c1"], trig["s2"], trig["c2"], trig["RI"], trig["k_gg"])


def _trig_dict(v: Any) -> dict:
    return {"s1": v[0:3], "c1": v[3:6], "s2": v[6:9], "c2": v[9:12], "RI": v[12:15], "k_gg": v[15]}


_AGENTS: dict[tuple[Any, ...], tuple[ca.Function, ca.Function, ca.Function, ca.Function]] = {}


def agent_functions(spec: Spec, switch: str, inverse: str
                    ) -> tuple[ca.Function, ca.Function, ca.Function, ca.Function]:
    """The closed loop of one spacecraft, the single definition every kernel is built from.

    ``fsk_trig(t, freq, orbit) -> trig`` (:data:`NTRIG` time-only disturbance terms, once
    per evaluation for the whole formation); ``fsk_agent(qb, w, s, trig, gains, K_v, phi,
    umax, J, Jinv, harm, gg) -> (dqb, dw, u, tau, uraw)`` with ``qb = (q, q0)``, the body
    rate ``w``, ``s = sum_j L_ij q_j``, the design's controller gains (:func:`gain_size`
    entries), the limited torque ``u``, the switching argument ``tau`` (zeros for a design
    without a switching term) and the torque before the limit ``uraw``; ``fsk_plant(qb, w, u, trig, J, Jinv, harm, gg) ->
    (dqb, dw)`` under a given (held) torque; ``fsk_ctrl`` (the inputs of ``fsk_agent``)
    ``-> (u, tau, uraw)`` the controller alone.  ``J``, ``Jinv``: 9 entries, column-major;
    ``harm``: 18 (:func:`~formsync_design.models.disturbances.kernel_parameters`).

    >>> trig, agent, plant, ctrl = agent_functions(load_spec(None), "sat", "E")
    >>> agent.name_out(), plant.n_in()
    (['dqb', 'dw', 'u', 'tau', 'uraw'], 8)
    """
    key = (spec.key, switch, inverse)
    hit = _AGENTS.get(key)
    if hit is not None:
        return hit
    ng = gain_size(spec)
    qb, w, s = ca.SX.sym("qb", 4), ca.SX.sym("w", 3), ca.SX.sym("s", 3)
    trig_v = ca.SX.sym("trig", NTRIG)
    gp, kv, phi = ca.SX.sym("gains", ng), ca.SX.sym("K_v"), ca.SX.sym("phi")
    umax, J9, Ji9 = ca.SX.sym("umax", 3), ca.SX.sym("J", 9), ca.SX.sym("Jinv", 9)
    harm, gg, u_in = ca.SX.sym("harm", 18), ca.SX.sym("gg"), ca.SX.sym("u", 3)
    gargs, k = [], 0
    for gname in controller_gain_names(spec):
        width = 3 if str(spec.decl.gain(gname).kind) == "diag" else 1
        gargs.append(gp[k : k + width])
        k += width
    q, q0 = qb[:3], qb[3]
    J, Jinv = ca.reshape(J9, 3, 3), ca.reshape(Ji9, 3, 3)
    E = model_function()(q, q0, ca.SX.zeros(3), J)[0]  # E depends on (q, q0) only
    qd = ca.mtimes(E, w)
    out = build_controller(spec, switch=switch, inverse=inverse).function(
        q, q0, qd, J, s, *gargs, kv, phi)
    u = ca.fmin(umax, ca.fmax(-umax, out[0]))
    trig = _trig_dict(trig_v)
    ud = disturbance_torque(trig, q, q0, J, harm, gg)
    dqb = ca.vertcat(qd, -0.5 * ca.dot(q, w))  # eq. (1)

    def dw(torque: Any) -> Any:  # eq. (2)
        return ca.mtimes(Jinv, -ca.cross(w, ca.mtimes(J, w)) + torque + ud)

    opts = {"cse": True}
    agent = ca.Function("fsk_agent", [qb, w, s, trig_v, gp, kv, phi, umax, J9, Ji9, harm, gg],
                        [dqb, dw(u), u, out[1], out[0]],
                        ["qb", "w", "s", "trig", "gains", "K_v", "phi", "umax", "J", "Jinv", "harm", "gg"],
                        ["dqb", "dw", "u", "tau", "uraw"], opts)
    plant = ca.Function("fsk_plant", [qb, w, u_in, trig_v, J9, Ji9, harm, gg], [dqb, dw(u_in)],
                        ["qb", "w", "u", "trig", "J", "Jinv", "harm", "gg"], ["dqb", "dw"], opts)
    ctrl = ca.Function("fsk_ctrl", [qb, w, s, trig_v, gp, kv, phi, umax, J9, Ji9, harm, gg],
                       [u, out[1], out[0]],
                       ["qb", "w", "s", "trig", "gains", "K_v", "phi", "umax", "J", "Jinv", "harm", "gg"],
                       ["u", "tau", "uraw"], opts)
    t, freq, orbit = ca.SX.sym("t"), ca.SX.sym("freq", 6), ca.SX.sym("orbit", 4)
    trig_fn = ca.Function("fsk_trig", [t, freq, orbit],
                          [_trig_vector(disturbance_trig(t, freq, orbit))],
                          ["t", "freq", "orbit"], ["trig"], opts)
    _AGENTS[key] = (trig_fn, agent, plant, ctrl)
    return _AGENTS[key]


def _build_symbolic(
    n: int, switch: str, inverse: str, spec: Spec
) -> tuple[ca.Function, ca.Function, ca.Function, ca.Function, ca.Function]:
    """The formation's functions, from :func:`agent_functions` called per spacecraft
    (inlined in the SX graph) and the dense Laplacian product ``S = Q L^T``."""
    lay = param_layout(n, gain_size(spec))
    x = ca.SX.sym("x", 7 * n)
    u_in = ca.SX.sym("u", 3 * n)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", lay["_size"].stop)
    trig_fn, agent, plant_fn, _ = agent_functions(spec, switch, inverse)
    gp, Kv, phi, umax = p[lay["gains"]], p[lay["K_v"]], p[lay["phi"]], p[lay["umax"]]
    Jall, Jinv_all, harm, gg = p[lay["J"]], p[lay["Jinv"]], p[lay["harm"]], p[lay["gg"]]
    L = ca.reshape(p[lay["L"]], n, n)
    trig = trig_fn(t, p[lay["freq"]], p[lay["orbit"]])  # time-only terms, once for the formation
    qb = [x[4 * i : 4 * i + 4] for i in range(n)]
    w = [x[4 * n + 3 * i : 4 * n + 3 * i + 3] for i in range(n)]
    S = ca.mtimes(ca.horzcat(*[qb[i][:3] for i in range(n)]), L.T)  # column i = s_i
    per = [(Jall[9 * i : 9 * i + 9], Jinv_all[9 * i : 9 * i + 9], harm[18 * i : 18 * i + 18])
           for i in range(n)]
    outs = [agent(qb[i], w[i], S[:, i], trig, gp, Kv[i], phi, umax[3 * i : 3 * i + 3], *per[i], gg)
            for i in range(n)]
    u = ca.vertcat(*[o[2] for o in outs])
    xdot = ca.vertcat(*[o[0] for o in outs], *[o[1] for o in outs])
    ctrl = ca.Function("fs_ctrl", [x, t, p], [u], ["x", "t", "p"], ["u"])
    pl = [plant_fn(qb[i], w[i], u_in[3 * i : 3 * i + 3], trig, *per[i], gg) for i in range(n)]
    xdot_u = ca.vertcat(*[o[0] for o in pl], *[o[1] for o in pl])
    plant = ca.Function("fs_plant", [x, u_in, t, p], [xdot_u], ["x", "u", "t", "p"], ["xdot"])
    rhs = ca.Function("fs_rhs", [x, t, p], [xdot, u], ["x", "t", "p"], ["xdot", "u"])
    tau = ca.vertcat(*[o[3] for o in outs])
    uraw = ca.vertcat(*[o[4] for o in outs])
    evaluate = ca.Function("fs_evaluate", [x, t, p], [xdot, u, tau, uraw], ["x", "t", "p"],
                           ["xdot", "u", "tau", "uraw"])
    metrics = ca.Function("fs_metrics", [x], [metrics_expr(x, n)], ["x"], ["m"])
    return ctrl, plant, rhs, metrics, evaluate


#: Output intervals per call of the compiled kernel.
CHUNK = 100

#: Sub-steps per output interval up to which the RK4 loop is unrolled in the kernel.
UNROLL_MAX = 10


def _build_kernel(n: int, switch: str, zoh: bool, M: int, K: int, inverse: str, spec: Spec) -> Kernel:
    ctrl, plant, rhs, metrics, evaluate = _build_symbolic(n, switch, inverse, spec)
    nx = 7 * n
    npar = plant.size1_in(3)
    # one RK4 sub-step (MX calling the SX right-hand side once per stage, so the C code
    # holds the closed loop once whatever the number of sub-steps)
    xa = ca.MX.sym("xa", nx + 1)
    h = ca.MX.sym("h")
    p = ca.MX.sym("p", npar)
    u0 = ca.MX.sym("u0", 3 * n)
    x, t = xa[:nx], xa[nx]

    def f(xx: Any, tt: Any) -> Any:
        return plant(xx, u0, tt, p) if zoh else rhs(xx, tt, p)[0]

    if zoh:
        k1, u1 = f(x, t), u0
    else:
        k1, u1 = rhs(x, t, p)  # the torque at the sub-step start comes with the first stage
    k2 = f(x + h / 2 * k1, t + h / 2)
    k3 = f(x + h / 2 * k2, t + h / 2)
    k4 = f(x + h * k3, t + h)
    xn = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    q0n = ca.vertcat(*[xn[4 * i + 3] for i in range(n)])
    nerr = ca.mmax(ca.vertcat(*[ca.fabs(ca.sumsqr(xn[4 * i : 4 * i + 4]) - 1) for i in range(n)]))
    step = ca.Function("fs_step", [xa, h, p, u0], [ca.vertcat(xn, t + h), q0n, nerr, u1])
    # one output interval: the control at its start (held under ZOH), M sub-steps;
    # unrolled up to UNROLL_MAX sub-steps (fastest), a mapaccum loop beyond (compile time)
    xa = ca.MX.sym("xa", nx + 1)
    h = ca.MX.sym("h")
    p = ca.MX.sym("p", npar)
    # under ZOH the held control; otherwise unused (the first stage computes the torque)
    uhold = ctrl(xa[:nx], xa[nx], p) if zoh else ca.MX.zeros(3 * n)
    if M <= UNROLL_MAX:
        xk, q0s, nes, us = xa, [], [], []
        for _ in range(M):
            xk, q0k, nek, uk = step(xk, h, p, uhold)
            q0s.append(q0k)
            nes.append(nek)
            us.append(uk)
        xa_end, Q0, NE, ustart = xk, ca.horzcat(*q0s), ca.horzcat(*nes), us[0]
    else:
        XA, Q0, NE, US = step.mapaccum("fs_steps", M)(xa, h, p, uhold)
        xa_end, ustart = XA[:, -1], US[:, 0]
    minq0 = ca.vertcat(*[ca.mmin(Q0[i, :]) for i in range(n)])
    interval = ca.Function(
        "fs_interval", [xa, h, p], [xa_end, ustart, minq0, metrics(xa_end[:nx])], ["xa", "h", "p"],
        ["xa_next", "u", "minq0", "m"],
    )
    chunk = interval.mapaccum("fs_chunk", K)
    summ = ca.vertcat(metrics(xa_end[:nx]), ca.mmin(minq0), ca.mmax(ca.fabs(ustart)), ca.mmax(NE))
    mc_interval = ca.Function("fs_mc_interval", [xa, h, p], [xa_end, summ], ["xa", "h", "p"], ["xa_next", "s"])
    mc_acc = mc_interval.mapaccum("fs_mc_acc", K)
    xa2 = ca.MX.sym("xa", nx + 1)
    h2 = ca.MX.sym("h")
    p2 = ca.MX.sym("p", npar)
    XA2, Ssum = mc_acc(xa2, h2, p2)
    mc_chunk = ca.Function("fs_mc_chunk", [xa2, h2, p2], [XA2[:, -1], Ssum], ["xa", "h", "p"], ["xa_end", "s"])
    return Kernel(n, switch, zoh, M, K, inverse, spec.key, ctrl, plant, rhs, metrics, chunk, mc_chunk,
                  evaluate=evaluate, layout=param_layout(n, gain_size(spec)))


def _compile(fn: ca.Function, spec_key: str) -> tuple[ca.Function, bool]:
    """C code generation + the C compiler, cached on disk by the generated source and
    the specification key; without a compiler, the CasADi VM (with a warning)."""
    cc = c_compiler()
    if cc is None:
        warn_no_compiler(stacklevel=4)
        return fn, False
    name = fn.name()
    cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    cg.add(fn)
    src = generated_source(cg, f"{name}.c", f"the simulation kernel {name}")
    so = build_shared(name, src, spec_key, cc)
    try:
        return ca.external(name, str(so)), True
    except RuntimeError as e:
        raise CompilerError(
            f"loading the compiled kernel {so} failed ({' '.join(str(e).split())[:200]}); delete "
            "it to rebuild, or set FORMSYNC_NO_COMPILE=1"
        ) from None


_KERNELS: dict[tuple[Any, ...], Kernel] = {}


def get_kernel(
    n: int,
    switch: str,
    zoh: bool,
    M: int,
    K: int = 100,
    inverse: str = "E",
    compile: bool = True,
    spec: Spec | str | Path | None = None,
) -> Kernel:
    """Build (and compile, cached on disk and in memory) the kernel of a formation size.

    The caches are keyed by ``spec.key`` as well as the size and options, so
    two specifications never share a kernel.

    Examples
    --------
    >>> k = get_kernel(2, "sat", False, 2, K=1, compile=False)
    >>> k.spec_key == load_spec(None).key, k.n
    (True, 2)
    """
    sp_spec = load_spec(spec)
    compile = bool(compile) and compile_enabled()
    key = (sp_spec.key, n, switch, zoh, M, K, inverse, compile)
    hit = _KERNELS.get(key)
    if hit is not None:
        return hit
    t0 = time.perf_counter()
    k = _build_kernel(n, switch, zoh, M, K, inverse, sp_spec)
    if compile:
        k.chunk, ok1 = _compile(k.chunk, sp_spec.key)
        k.mc_chunk, ok2 = _compile(k.mc_chunk, sp_spec.key)
        k.compiled = ok1 and ok2
    k.compile_seconds = time.perf_counter() - t0
    _KERNELS[key] = k
    return k


def cached_kernels() -> list[tuple[str, int, str]]:
    """``(spec key, N, switch)`` of every kernel held in memory (for inspection and tests).

    >>> isinstance(cached_kernels(), list)
    True
    """
    return [(k[0], k[1], k[2]) for k in _KERNELS]


def clear_kernel_cache() -> None:
    """Forget the kernels held in memory (the compiled files on disk stay; benchmarks use
    this to time a cold build).

    >>> clear_kernel_cache(); cached_kernels()
    []
    """
    _KERNELS.clear()


def compile_function(fn: ca.Function, key: str) -> tuple[ca.Function, bool]:
    """Compile a CasADi function through the kernel compiler and disk cache.

    The entry point for simulation modules other than the formation kernels (e.g.
    :mod:`formsync_design.sim.tracking`): C code generation, the C compiler, the disk
    cache keyed by the generated source, ``key`` (the design's content digest), the flags
    and the host; the CasADi virtual machine without a compiler.  Returns the function and
    whether it was compiled.
    """
    return _compile(fn, key)
