"""The compiled formation kernel of agent designs: built once per design, run on any graph.

A design's law is translated and compiled per spacecraft, once per design (its content key),
switch and in-degree ``m``; the graph (in-neighbours in CSR form, arc weights, pinning
gains), the inertias, the gains, the limits and the disturbance are run-time data.  Nothing
here depends on the formation size, the horizon or the output grid, so a new ``N``, ``tf`` or
``output_step`` of a design compiles nothing (a new in-degree compiles that degree's law
once; a leader's reference rate, three expressions in ``t``, compiles once per rate).

The CasADi functions (named inputs and outputs; the C driver
``formsync_design/sim/agent_driver.c`` calls them in this order):

* ``fsa_pre(q, w, z) -> full``: what a spacecraft broadcasts (attitude in the design's
  representation, :func:`~formsync_design.sim.agent_kernel.attitude_entries`; rate; states);
* ``fsa_trig(t, freq, orbit) -> trig``: the time-only disturbance terms
  (:func:`~formsync_design.models.disturbances.disturbance_trig`: ``s1, c1, s2, c2, RI,
  k_gg``, 16 values);
* ``fsa_lead(qr, t) -> ref, dqr``: the reference (attitude entries, rate, rate derivative)
  and its quaternion's derivative;
* ``fsa_dist(q, J, harm, trig, gg) -> ud``: the disturbance torque
  (:func:`~formsync_design.models.disturbances.disturbance_torque`), evaluated only in a run
  whose disturbance parameters are not all zero;
* ``fsa_law_<m>(own, q, w, J, Jinv, a, b, ref, gains, phi, umax, ud, t, nbr_1, ...,
  nbr_m) -> dq, dw, dz``: one spacecraft's closed loop (``nbr_k``: what its ``k``-th
  in-neighbour broadcasts), the law of
  :func:`~formsync_design.sim.agent_kernel.agent_law` (the one symbolic-to-CasADi bridge)
  limited to ``umax`` per axis, the rigid body and the disturbance torque ``ud``;
* ``fsa_obs_<m>`` (the same inputs) ``-> u, monitors``: the limited torque and the design's
  monitors, evaluated at the output times only.

State order: that of :func:`~formsync_design.sim.agent_kernel.agent_state_names`.  The
parameter vector: :func:`~formsync_design.sim.agent_kernel.agent_param_layout`.

Integrators: ``rk4`` (fixed step, quaternions normalised after every sub-step, the arithmetic
of the unrolled kernel's ``chunk``) and ``dopri5`` (adaptive Dormand-Prince 5(4) with dense
output on the output grid).  Without a C compiler (or with ``FORMSYNC_NO_COMPILE=1``)
:func:`native_agents_available` is False and the callers use the CasADi kernel of
:mod:`~formsync_design.sim.agent_kernel`.
"""

from __future__ import annotations

import ctypes
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from formsync_design.errors import CompilerError
from formsync_design.models.disturbances import disturbance_torque, disturbance_trig
from formsync_design.sim.agent_kernel import (
    ATTITUDE_SIZE,
    agent_law,
    attitude_entries,
    gain_count,
)
from formsync_design.sim.ccompile import (
    CFLAGS,
    build_shared,
    c_compiler,
    code_digest,
    compile_enabled,
    generated_source,
)
from formsync_design.sim.reference_rate import reference_rate_expressions, reference_rate_function
from formsync_design.spec.agent import AgentDesign

__all__ = [
    "METHODS",
    "NativeAgentKernel",
    "NativeRun",
    "native_agents_available",
    "get_native_agents",
    "csr",
    "native_disagreement",
]

#: The driver's integrators.
METHODS = {"rk4": 0, "dopri5": 1}

#: Trigonometric disturbance terms, in the order of ``fsa_trig``'s output.
_TRIG = (("s1", 3), ("c1", 3), ("s2", 3), ("c2", 3), ("RI", 3), ("k_gg", 1))
_NTRIG = sum(k for _, k in _TRIG)

#: The parameter blocks the driver reads, in its order (``P_*`` of the driver).
_BLOCKS = ("gains", "phi", "umax", "J", "Jinv", "a", "b", "freq", "harm", "gg", "orbit")

#: The code that generates the compiled functions: part of every cache key.
_GENERATOR = ("sim/agent_native.py", "sim/agent_kernel.py", "sim/bridge.py",
              "models/disturbances.py", "sim/reference_rate.py", "spec")

_DRIVER = Path(__file__).with_name("agent_driver.c")

#: The kernels' flags, plus calls inside an object resolved at link time (CasADi's helpers,
#: e.g. ``casadi_sq``, are inlined instead of called through the symbol table).
_FLAGS = (*CFLAGS, "-fno-semantic-interposition")


def native_agents_available() -> bool:
    """True when the compiled driver can be used (a C compiler, compiling not switched off).

    >>> isinstance(native_agents_available(), bool)
    True
    """
    return compile_enabled() and c_compiler() is not None


def _generator_digest() -> str:
    return code_digest(_GENERATOR)


def csr(neighbours: tuple[tuple[int, ...], ...]) -> tuple[np.ndarray, np.ndarray]:
    """Row pointers and columns (int32) of in-neighbour lists (arc ``k`` of spacecraft ``i``
    is ``ci[rp[i] + k]``, the order of the arc weights).

    >>> rp, ci = csr(((1, 2), (0,), ()))
    >>> rp.tolist(), ci.tolist()
    ([0, 2, 3, 3], [1, 2, 0])
    """
    rp = np.zeros(len(neighbours) + 1, dtype=np.int32)
    rp[1:] = np.cumsum([len(nb) for nb in neighbours])
    ci = np.fromiter((j for nb in neighbours for j in nb), dtype=np.int32,
                     count=int(rp[-1]))
    return rp, ci


def _pre_function(design: AgentDesign) -> ca.Function:
    nz = design.decl.state_size
    q, w, z = ca.SX.sym("q", 4), ca.SX.sym("w", 3), ca.SX.sym("z", nz)
    full = ca.vertcat(*attitude_entries(design.representation, q), w, z)
    return ca.Function("fsa_pre", [q, w, z], [full], ["q", "w", "z"], ["full"], {"cse": True})


def _trig_function() -> ca.Function:
    t, freq, orbit = ca.SX.sym("t"), ca.SX.sym("freq", 6), ca.SX.sym("orbit", 4)
    d = disturbance_trig(t, freq, orbit)
    out = ca.vertcat(*[d[name] for name, _ in _TRIG])
    return ca.Function("fsa_trig", [t, freq, orbit], [out], ["t", "freq", "orbit"], ["trig"],
                       {"cse": True})


def _lead_function(rep: str, rate: tuple[Any, ...]) -> ca.Function:
    qr, t = ca.SX.sym("qr", 4), ca.SX.sym("t")
    wr, wdr = reference_rate_function(rate)(t)
    v3, q0 = qr[0:3], qr[3]
    ref = ca.vertcat(*attitude_entries(rep, qr), wr, wdr)
    dq = ca.vertcat(0.5 * (q0 * wr + ca.cross(v3, wr)), -0.5 * ca.dot(v3, wr))
    return ca.Function("fsa_lead", [qr, t], [ref, dq], ["qr", "t"], ["ref", "dqr"],
                       {"cse": True})


def _dist_function() -> ca.Function:
    q, Jv, harm = ca.SX.sym("q", 4), ca.SX.sym("J", 9), ca.SX.sym("harm", 18)
    trig, gg = ca.SX.sym("trig", _NTRIG), ca.SX.sym("gg")
    parts, off = {}, 0
    for name, k in _TRIG:
        parts[name] = trig[off: off + k] if k > 1 else trig[off]
        off += k
    ud = disturbance_torque(parts, q[0:3], q[3], ca.reshape(Jv, 3, 3), harm, gg)
    return ca.Function("fsa_dist", [q, Jv, harm, trig, gg], [ud],
                       ["q", "J", "harm", "trig", "gg"], ["ud"], {"cse": True})


def _law_functions(design: AgentDesign, m: int,
                   switch: str) -> tuple[list[ca.Function], tuple[str, ...]]:
    """``fsa_law_<m>`` (the state derivative) and ``fsa_obs_<m>`` (torque and monitors) of a
    spacecraft with ``m`` in-neighbours, and the monitor names."""
    law = agent_law(design, m, switch)
    na = ATTITUDE_SIZE[design.representation]
    nz = design.decl.state_size
    nf = na + 3 + nz
    ng = max(gain_count(design), 1)
    own, q, w = ca.SX.sym("own", nf), ca.SX.sym("q", 4), ca.SX.sym("w", 3)
    Jv, Jiv = ca.SX.sym("J", 9), ca.SX.sym("Jinv", 9)
    # one input per in-neighbour: the driver points each at that neighbour's broadcast
    nbs = [ca.SX.sym(f"nbr_{k + 1}", nf) for k in range(max(m, 1))]
    nb = ca.horzcat(*nbs)
    a, b = ca.SX.sym("a", max(m, 1)), ca.SX.sym("b")
    ref, gains, phi = ca.SX.sym("ref", na + 6), ca.SX.sym("gains", ng), ca.SX.sym("phi")
    umax, ud, t = ca.SX.sym("umax", 3), ca.SX.sym("ud", 3), ca.SX.sym("t")
    J, Jinv = ca.reshape(Jv, 3, 3), ca.reshape(Jiv, 3, 3)
    u_raw, zdot, mon = law.law(own, J, t, nb, a, b, ref, gains, phi)
    u = ca.fmin(umax, ca.fmax(-umax, u_raw))
    v3, q0 = q[0:3], q[3]
    dq = ca.vertcat(0.5 * (q0 * w + ca.cross(v3, w)), -0.5 * ca.dot(v3, w))
    dw = ca.mtimes(Jinv, -ca.cross(w, ca.mtimes(J, w)) + u + ud)
    ins = [own, q, w, Jv, Jiv, a, b, ref, gains, phi, umax, ud, t, *nbs]
    names = ["own", "q", "w", "J", "Jinv", "a", "b", "ref", "gains", "phi", "umax", "ud", "t",
             *[f"nbr_{k + 1}" for k in range(len(nbs))]]
    f = ca.Function(f"fsa_law_{m}", ins, [dq, dw, zdot], names, ["dq", "dw", "dz"],
                    {"cse": True})
    g = ca.Function(f"fsa_obs_{m}", ins, [u, mon], names, ["u", "monitors"], {"cse": True})
    return [f, g], law.monitors


@dataclass
class _Compiled:
    """A loaded object's function: its address and CasADi work sizes."""

    lib: Any
    address: int
    sizes: tuple[int, int, int, int]
    monitors: tuple[str, ...] = ()


def _c_string(name: str, text: str) -> str:
    r"""A C definition of the string ``text`` (every byte an octal escape).

    >>> _c_string("s", "a,b")
    'const char s[] = "\\141\\054\\142";\n'
    """
    body = "".join(f"\\{b:03o}" for b in text.encode())
    return f'const char {name}[] = "{body}";\n'


def _load(name: str, make: Any, key: str, functions: tuple[str, ...],
          monitors: bool = False) -> dict[str, _Compiled]:
    """The compiled object ``name`` holding ``functions`` (``make()`` returns them, and with
    ``monitors`` the monitor names as well), built once and cached on disk by ``key``."""
    cc = c_compiler()
    if cc is None:  # pragma: no cover - callers check native_agents_available first
        raise CompilerError("expected a C compiler (gcc/cc) for the compiled agent kernel, "
                            "received none")

    def source() -> str:
        fns, names = make() if monitors else (make(), ())
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for fn in fns:
            cg.add(fn)
        src = generated_source(cg, f"{name}.c", f"the agent kernel functions {name}")
        # the monitor names travel with the compiled law: a warm run derives nothing
        return src + (_c_string("fsa_monitors", "\n".join(names)) if monitors else "")

    so = build_shared(name, source, key, cc, flags=_FLAGS)
    out: dict[str, _Compiled] = {}
    try:
        lib = ctypes.CDLL(str(so))
        names: tuple[str, ...] = ()
        if monitors:
            raw = ctypes.cast(ctypes.addressof(ctypes.c_char.in_dll(lib, "fsa_monitors")),
                              ctypes.c_char_p).value or b""
            names = tuple(raw.decode().split("\n")) if raw else ()
        for fname in functions:
            fn = getattr(lib, fname)
            sz = [ctypes.c_longlong() for _ in range(4)]
            getattr(lib, f"{fname}_work")(*[ctypes.byref(v) for v in sz])
            out[fname] = _Compiled(lib, ctypes.cast(fn, ctypes.c_void_p).value or 0,
                                   (sz[0].value, sz[1].value, sz[2].value, sz[3].value), names)
    except (OSError, AttributeError, ValueError) as e:
        raise CompilerError(f"loading the compiled kernel {so} failed ({e}); delete it to "
                            "rebuild, or set FORMSYNC_NO_COMPILE=1") from None
    return out


_DRIVER_LIB: list[Any] = []
_LOCK = threading.Lock()


def _driver() -> Any:
    with _LOCK:
        if not _DRIVER_LIB:
            cc = c_compiler()
            if cc is None:  # pragma: no cover - callers check native_agents_available first
                raise CompilerError("expected a C compiler (gcc/cc) for the compiled agent "
                                    "kernel, received none")
            so = build_shared("fsa_driver", _DRIVER.read_text(), "agent driver", cc,
                              flags=_FLAGS, libs=("-lm", "-lpthread"))
            lib = ctypes.CDLL(str(so))
            P = ctypes.c_void_p
            lib.fsa_run.argtypes = [P, P, P, P, P, P, P, P, ctypes.c_long, P, P, P, P, P]
            lib.fsa_run.restype = ctypes.c_int
            lib.fsa_eval.argtypes = [P, P, P, P, P, P, ctypes.c_double, P, P, P, P]
            lib.fsa_eval.restype = ctypes.c_int
            lib.fsa_disagreement.argtypes = [ctypes.c_long, ctypes.c_long, P, P, P, P, P,
                                             ctypes.c_int]
            lib.fsa_disagreement.restype = ctypes.c_int
            _DRIVER_LIB.append(lib)
        return _DRIVER_LIB[0]


@dataclass
class NativeRun:
    """One run's output: states ``X`` (``(k, nx)``), torques ``U`` (``(k, 3N)``, after the
    limit) and monitors ``MON`` (``(k, N * nmon)``, spacecraft-major) at the first ``k``
    output times, the status (``0`` horizon reached, ``1`` a non-finite state at
    ``t_fail``, ``2`` the step size underflowed (``reason`` 2) or too many steps (3)) and the
    integrator's counts."""

    X: np.ndarray
    U: np.ndarray
    MON: np.ndarray
    status: int
    reason: int
    t_fail: float
    steps: int
    rejected: int
    rhs_evaluations: int


@dataclass
class NativeAgentKernel:
    """The compiled functions of one design and switch (module docstring); any formation.

    ``monitors``: the design's monitor names (the columns of :attr:`NativeRun.MON` per
    spacecraft)."""

    design: AgentDesign
    switch: str
    monitors: tuple[str, ...] = ()
    common: dict[str, _Compiled] = field(default_factory=dict)
    laws: dict[int, dict[str, _Compiled]] = field(default_factory=dict)
    leads: dict[tuple[str, ...], _Compiled] = field(default_factory=dict)

    def _key(self, *parts: str) -> str:
        return "\n".join([self.design.key, self.switch, _DIGEST[0], *parts])

    def law(self, m: int) -> dict[str, _Compiled]:
        """The compiled closed loop (``fsa_law_<m>``) and observation (``fsa_obs_<m>``) of a
        spacecraft with ``m`` in-neighbours (built once)."""
        hit = self.laws.get(m)
        if hit is None:
            with _LOCK:
                hit = self.laws.get(m)
                if hit is None:
                    hit = self.laws[m] = _load(
                        f"fsa_law_{m}", lambda: _law_functions(self.design, m, self.switch),
                        self._key("law", str(m)), (f"fsa_law_{m}", f"fsa_obs_{m}"),
                        monitors=True)
                    self.monitors = hit[f"fsa_law_{m}"].monitors
        return hit

    def lead(self, rate: tuple[Any, ...]) -> _Compiled:
        rk = tuple(sp.srepr(r) for r in reference_rate_expressions(rate))
        hit = self.leads.get(rk)
        if hit is None:
            with _LOCK:
                hit = self.leads.get(rk)
                if hit is None:
                    hit = self.leads[rk] = _load("fsa_lead", lambda: [_lead_function(
                        self.design.representation, reference_rate_expressions(rate))],
                        "\n".join([self.design.representation, _DIGEST[0], *rk]),
                        ("fsa_lead",))["fsa_lead"]
        return hit

    def _setup(self, neighbours: tuple[tuple[int, ...], ...], layout: dict[str, slice],
               ref_rate: Any, p: np.ndarray) -> tuple[Any, ...]:
        n = len(neighbours)
        rp, ci = csr(neighbours)
        degs = sorted({len(nb) for nb in neighbours})
        maxdeg = degs[-1] if degs else 0
        fns = (ctypes.c_void_p * (6 + 2 * maxdeg))()
        used = [self.common[k] for k in ("fsa_pre", "fsa_trig", "fsa_dist")]
        fns[0], fns[1] = self.common["fsa_pre"].address, self.common["fsa_trig"].address
        fns[3] = self.common["fsa_dist"].address
        if self.design.decl.leader:
            ld = self.lead(ref_rate)
            fns[2] = ld.address
            used.append(ld)
        for m in degs:
            c = self.law(m)
            fns[4 + m] = c[f"fsa_law_{m}"].address
            fns[5 + maxdeg + m] = c[f"fsa_obs_{m}"].address
            used += list(c.values())
        sizes = np.max([c.sizes for c in used], axis=0)
        na = ATTITUDE_SIZE[self.design.representation]
        # the disturbance torque is evaluated only when the run has one (data, not code)
        # (the harmonic terms' amplitudes c, a of every axis: 6 parameters an axis, the
        # phases' cosines and sines are not amplitudes)
        amp = p[layout["harm"]].reshape(-1, 6)[:, :2]
        dist = bool(np.any(amp != 0) or np.any(p[layout["gg"]] != 0))
        dims = np.array([n, na, self.design.decl.state_size, len(self.monitors),
                         int(self.design.decl.leader), maxdeg, _NTRIG, *sizes, int(dist)],
                        dtype=np.int64)
        off = np.array([layout[b].start for b in _BLOCKS], dtype=np.int64)
        return dims, off, rp, ci, fns

    def evaluate(self, neighbours: tuple[tuple[int, ...], ...], layout: dict[str, slice],
                 p: np.ndarray, t: float, x: np.ndarray,
                 ref_rate: Any = ("0", "0", "0")) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The closed loop at ``(t, x)``: state derivative, torques, monitors."""
        dims, off, rp, ci, fns = self._setup(neighbours, layout, ref_rate, p)
        n = len(neighbours)
        x = np.ascontiguousarray(x, dtype=float)
        p = np.ascontiguousarray(p, dtype=float)
        xd, u = np.zeros(x.size), np.zeros(3 * n)
        mon = np.zeros(max(n * len(self.monitors), 1))
        rc = _driver().fsa_eval(*[a.ctypes.data for a in (dims, off, rp, ci, p)], fns, float(t),
                                x.ctypes.data, xd.ctypes.data, u.ctypes.data, mon.ctypes.data)
        if rc != 0:
            raise MemoryError("the agent driver could not allocate its work arrays")
        return xd, u, mon[: n * len(self.monitors)]

    def run(self, neighbours: tuple[tuple[int, ...], ...], layout: dict[str, slice],
            p: np.ndarray, x0: np.ndarray, tgrid: np.ndarray, method: str, *,
            step: float = 0.0, substeps: int = 1, rtol: float = 1e-8, atol: float = 1e-12,
            max_step: float = 0.0, max_steps: int = 10**8,
            ref_rate: Any = ("0", "0", "0")) -> NativeRun:
        """Integrate from ``x0`` at ``tgrid[0]`` and record every time of ``tgrid``
        (``rk4``: ``substeps`` steps of ``step`` per output interval)."""
        dims, off, rp, ci, fns = self._setup(neighbours, layout, ref_rate, p)
        n, nmon = len(neighbours), len(self.monitors)
        T = len(tgrid) - 1
        x0 = np.ascontiguousarray(x0, dtype=float)
        nx = x0.size
        X = np.empty((T + 1, nx))
        U = np.empty((T + 1, 3 * n))
        MON = np.empty((T + 1, max(n * nmon, 1)))
        cfg = np.array([METHODS[method], step, substeps, rtol, atol, max_step, max_steps, 0.0])
        info = np.zeros(8)
        tg = np.ascontiguousarray(tgrid, dtype=float)
        p = np.ascontiguousarray(p, dtype=float)
        rc = _driver().fsa_run(*[a.ctypes.data for a in (dims, off, rp, ci, p)], fns,
                               cfg.ctypes.data, x0.ctypes.data, T, tg.ctypes.data,
                               X.ctypes.data, U.ctypes.data, MON.ctypes.data, info.ctypes.data)
        if rc != 0:
            raise MemoryError("the agent driver could not allocate its work arrays")
        k = int(info[1])
        return NativeRun(X[:k], U[:k], MON[:k, : n * nmon], int(info[0]), int(info[6]),
                         float(info[5]), int(info[2]), int(info[3]), int(info[4]))


def native_disagreement(Q: np.ndarray, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The attitude disagreement (deg) and the rate disagreement (rad/s) per sample of
    ``Q`` (``(T, N, 4)``) and ``W`` (``(T, N, 3)``): the values of
    :func:`~formsync_design.sim.disagreement.attitude_disagreement` and
    :func:`~formsync_design.sim.disagreement.rate_disagreement` (every pair examined; the
    exact angle formula on every pair that can hold the maximum), in C for large formations.

    >>> import math
    >>> Q = np.array([[[0, 0, 0, 1.0], [0, 0, math.sin(0.25), math.cos(0.25)]]])
    >>> a, r = native_disagreement(Q, np.array([[[0.0, 0, 0], [0, 3, 4]]]))
    >>> round(float(a[0]), 10) == round(math.degrees(0.5), 10), float(r[0])
    (True, 5.0)
    """
    Q = np.ascontiguousarray(Q, dtype=float)
    W = np.ascontiguousarray(W, dtype=float)
    T, n = Q.shape[0], Q.shape[1]
    threads = max(1, min(os.cpu_count() or 1, 8))
    att, rate, work = np.empty(T), np.empty(T), np.empty(9 * max(n, 1) * threads)
    _driver().fsa_disagreement(T, n, Q.ctypes.data, W.ctypes.data, att.ctypes.data,
                               rate.ctypes.data, work.ctypes.data, threads)
    return np.degrees(att), rate


_DIGEST: list[str] = []
_NATIVE: dict[tuple[str, str], NativeAgentKernel] = {}


def get_native_agents(design: AgentDesign, switch: str) -> NativeAgentKernel:
    """The compiled kernel of ``design`` under ``switch`` (cached in memory, and on disk by
    the design's key, the switch and the generator's code); the per-degree laws are built
    on first use.  Call only when :func:`native_agents_available`."""
    key = (design.key, switch)
    hit = _NATIVE.get(key)
    if hit is not None:
        return hit
    with _LOCK:
        if not _DIGEST:
            _DIGEST.append(_generator_digest())
    k = NativeAgentKernel(design, switch)
    k.common.update(_load("fsa_pre", lambda: [_pre_function(design)],
                          "\n".join([design.representation, str(design.decl.state_size),
                                     _DIGEST[0]]), ("fsa_pre",)))
    k.common.update(_load("fsa_env", lambda: [_trig_function(), _dist_function()], _DIGEST[0],
                          ("fsa_trig", "fsa_dist")))
    _NATIVE[key] = k
    return k
