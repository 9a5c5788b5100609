"""Fast nonlinear simulation of a spacecraft formation under controller (4).

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
singular and (4) undefined - is *seen*: every sub-step's ``q0`` is checked
against ``q0_floor`` (default 0.02) and the run stops with status
``"singular"`` naming the spacecraft and the (linearly interpolated) time.
Near ``q0 = 0`` the body rate ``|omega| ~ 2|q'|/q0`` grows without bound, so
when the compiled fixed step blows up first, the interval is re-integrated
with ``h/10`` and ``h/100`` (CasADi VM) to reach the floor; a blow-up that
persists right after some ``q0 < 0.1`` is still reported as ``"singular"``
(the message gives the smallest ``q0`` reached), any other NaN/inf raises
:class:`SimulationError` naming the time.  Trajectories end at the event.

Quaternion norm policy: no renormalisation.  The kinematics preserve
``|q_bar| = 1`` exactly, so its numerical drift measures integration error;
it is reported (``stats["max_norm_error"]``) and a run whose drift exceeds
``norm_tol`` (default 1e-5) raises :class:`SimulationError` (tighten the
step).  The controller maps ``Q^{-1}`` to ``E`` (exact on the unit sphere;
see :mod:`formsync_design.sim.bridge`); the drift is the size of the error that
mapping can make.

Integrators
-----------
``"rk4"`` (default): classical fixed-step Runge-Kutta 4 with step
``step`` (default 0.05 s; on the paper's case the final state then agrees
with a CVODES rtol 1e-12 reference to 3e-7 and the norm drift is 1e-7),
compiled to C with CasADi code generation and gcc ``-O3 -march=native``,
cached in the user cache dir (``$FORMSYNC_CACHE_DIR``, else
``$XDG_CACHE_HOME/formsync-design`` or ``~/.cache/formsync-design``; keyed
by the generated source, flags, CasADi version and host); the first build of
a kernel takes 5-10 s, later ones load it.  Without gcc (or with
``compile=False``) the same kernel runs in CasADi's virtual machine.
``"cvodes"``: CasADi's adaptive SUNDIALS CVODES (BDF) with ``rtol``/``atol``
(defaults 1e-8/1e-10), for reference runs; continuous control only.
``sgn`` is simulated as the discontinuous law it is: with a fixed step the
switching term chatters at the step rate, so the relative rate stalls at a
level proportional to the step (paper's case: ``Omega_m`` ~ 4.5e-4 rad/s with
``h = 0.05`` s, 8.7e-5 with 0.01 s) - what a digital implementation at that
rate would do; use ``sat``/``tanh`` for smooth runs.

Sampled control: with ``sample_period = Ts`` the torque is computed from the
state at ``t_k = k Ts`` and held constant (zero-order hold) while the plant is
integrated with sub-steps ``<= step``; the output grid is then the sample grid.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from formsync_design.errors import InputError, SimulationError
from formsync_design.graphs.build import Graph
from formsync_design.models.disturbances import (
    DisturbanceModel,
    disturbance_torque,
    disturbance_trig,
    kernel_parameters,
)
from formsync_design.sim.bridge import SWITCHES, build_controller, model_function

__all__ = [
    "Gains",
    "Formation",
    "SimOptions",
    "SimResult",
    "INTEGRATORS",
    "simulate",
    "state_names",
    "pack_state",
    "unpack_state",
    "formation_metrics",
    "convergence_time",
    "cache_dir",
    "Kernel",
    "get_kernel",
    "CHUNK",
]

INTEGRATORS = ("rk4", "cvodes")
STATUSES = ("converged", "not-converged", "singular")


def state_names(n: int) -> list[str]:
    """Names of the state entries (module docstring for the layout).

    >>> state_names(2)[:4], state_names(2)[8:11]
    (['q1_1', 'q2_1', 'q3_1', 'q0_1'], ['w1_1', 'w2_1', 'w3_1'])
    """
    quat = [f"{c}_{i}" for i in range(1, n + 1) for c in ("q1", "q2", "q3", "q0")]
    rates = [f"{c}_{i}" for i in range(1, n + 1) for c in ("w1", "w2", "w3")]
    return quat + rates


def pack_state(quaternions: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """``(N, 4)`` quaternions ``(q1, q2, q3, q0)`` and ``(N, 3)`` rates -> state vector.

    >>> pack_state(np.array([[0, 0, 0, 1.0]]), np.array([[1.0, 2, 3]])).tolist()
    [0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 3.0]
    """
    return np.concatenate([np.asarray(quaternions, float).ravel(), np.asarray(rates, float).ravel()])


def unpack_state(x: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """State vector(s) ``(..., 7N)`` -> quaternions ``(..., N, 4)`` and rates ``(..., N, 3)``."""
    x = np.asarray(x, dtype=float)
    return x[..., : 4 * n].reshape(*x.shape[:-1], n, 4), x[..., 4 * n :].reshape(*x.shape[:-1], n, 3)


# ---------------------------------------------------------------------------
# inputs


@dataclass(frozen=True)
class Gains:
    """Controller gains: scalars ``K_o, K_q, beta`` and ``K_v`` per spacecraft.

    >>> Gains(1.6, 0.4, 0.3, (0.01,) * 8).K_v[0]
    0.01
    """

    K_o: float
    K_q: float
    beta: float
    K_v: tuple[float, ...]

    def __post_init__(self) -> None:
        for name in ("K_o", "K_q", "beta"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise InputError(f"expected a positive finite gain {name}, received {v!r}")
        kv = tuple(float(k) for k in np.atleast_1d(np.asarray(self.K_v, dtype=float)))
        if not all(math.isfinite(k) and k >= 0 for k in kv):
            raise InputError(f"expected finite K_v >= 0, received {self.K_v!r}")
        object.__setattr__(self, "K_v", kv)
        for name in ("K_o", "K_q", "beta"):
            object.__setattr__(self, name, float(getattr(self, name)))


@dataclass(frozen=True)
class Formation:
    """Everything physical about a formation run.

    Attributes
    ----------
    graph : Graph
    inertias : numpy.ndarray, shape (N, 3, 3), kg m^2, symmetric positive definite
    attitudes : numpy.ndarray, shape (N, 4), ``(q1, q2, q3, q0)``, unit, ``q0 > 0``
    rates : numpy.ndarray, shape (N, 3), rad/s (body frame)
    gains : Gains
    disturbance : DisturbanceModel
    """

    graph: Graph
    inertias: np.ndarray
    attitudes: np.ndarray
    rates: np.ndarray
    gains: Gains
    disturbance: DisturbanceModel

    def __post_init__(self) -> None:
        n = self.graph.n
        J = _array(self.inertias, "inertias")
        if J.shape != (n, 3, 3):
            raise InputError(f"expected {n} inertias (graph size) of shape 3x3, received shape {J.shape}")
        for i, Ji in enumerate(J):
            if not np.allclose(Ji, Ji.T, rtol=0, atol=1e-12 * max(1.0, float(np.abs(Ji).max()))):
                raise InputError(f"expected a symmetric inertia for spacecraft {i + 1}, received {Ji.tolist()}")
            if np.linalg.eigvalsh(Ji)[0] <= 0:
                raise InputError(
                    f"expected a positive definite inertia for spacecraft {i + 1}, received eigenvalues "
                    f"{np.linalg.eigvalsh(Ji).round(6).tolist()}"
                )
        Q = _array(self.attitudes, "attitudes")
        if Q.shape != (n, 4):
            raise InputError(f"expected {n} quaternions (q1, q2, q3, q0), received shape {Q.shape}")
        for i, qb in enumerate(Q):
            nrm = float(np.linalg.norm(qb))
            if abs(nrm - 1) > 1e-9:
                raise InputError(f"expected a unit quaternion for spacecraft {i + 1}, received norm {nrm!r}")
            if qb[3] <= 0:
                raise InputError(
                    f"expected q0 > 0 for spacecraft {i + 1} (controller (4) needs q0 != 0), "
                    f"received q0 = {qb[3]!r}"
                )
        W = _array(self.rates, "rates")
        if W.shape != (n, 3):
            raise InputError(f"expected {n} rate vectors of length 3, received shape {W.shape}")
        if len(self.gains.K_v) == 1:
            object.__setattr__(self, "gains", replace(self.gains, K_v=self.gains.K_v * n))
        if len(self.gains.K_v) != n:
            raise InputError(f"expected {n} values of K_v (one per spacecraft), received {len(self.gains.K_v)}")
        if self.disturbance.n != n:
            raise InputError(f"expected a disturbance for {n} spacecraft, received {self.disturbance.n}")
        for name, a in (("inertias", J), ("attitudes", Q), ("rates", W)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def n(self) -> int:
        return self.graph.n

    def initial_state(self) -> np.ndarray:
        """The state vector (module docstring for the layout)."""
        return pack_state(self.attitudes, self.rates)


def _array(a: Any, name: str) -> np.ndarray:
    try:
        out = np.array(a, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected a numeric array for {name}, received {a!r}") from None
    if not np.all(np.isfinite(out)):
        raise InputError(f"expected finite {name}, received NaN/inf")
    return out


@dataclass(frozen=True)
class SimOptions:
    """Simulation options (defaults documented per field).

    Attributes
    ----------
    tf : float
        Horizon (s), default 200.
    switch : {"sgn", "sat", "tanh"}
        Switching term, default ``sat``.
    phi : float
        Boundary layer of ``sat``/``tanh`` (default 0.01; the paper does not print it).
    torque_limit : float or None
        Per-axis actuator limit ``|u_k| <= torque_limit`` (N m); None = unlimited.
    sample_period : float or None
        Zero-order-hold control period Ts (s); None = continuous control.
    integrator : {"rk4", "cvodes"}
    step : float
        RK4 step (s), default 0.05 (also the maximum sub-step under ZOH).
    output_step : float
        Output grid spacing (s), default 0.1 (the sample period under ZOH).
    rtol, atol : float
        CVODES tolerances (defaults 1e-8, 1e-10).
    q_tol, omega_tol : float
        Convergence thresholds on Q_m (-) and Omega_m (rad/s), defaults 1e-4, 1e-5.
    q0_floor : float
        Singularity detection: stop when some ``q0_i <= q0_floor`` (default 0.02, where
        ``|omega| ~ 2|q'|/q0`` is 100 |q'| and ``cond(Q) = 1/q0`` is 50).
    norm_tol : float
        Maximum tolerated quaternion norm drift (default 1e-5; the paper's case with
        ``sat`` drifts 1e-7 at the default step, ``sgn`` chattering ~1e-6 over 200 s).
    compile : bool
        Compile the RK4 kernel to C (default True); False uses CasADi's VM.
    inverse : {"E", "solve"}
        How the bridge evaluates ``Q^{-1}``.
    """

    tf: float = 200.0
    switch: str = "sat"
    phi: float = 0.01
    torque_limit: float | None = None
    sample_period: float | None = None
    integrator: str = "rk4"
    step: float = 0.05
    output_step: float = 0.1
    rtol: float = 1e-8
    atol: float = 1e-10
    q_tol: float = 1e-4
    omega_tol: float = 1e-5
    q0_floor: float = 0.02
    norm_tol: float = 1e-5
    compile: bool = True
    inverse: str = "E"

    def __post_init__(self) -> None:
        if self.switch not in SWITCHES:
            raise InputError(f"expected switch in {SWITCHES}, received {self.switch!r}")
        if self.integrator not in INTEGRATORS:
            raise InputError(f"expected integrator in {INTEGRATORS}, received {self.integrator!r}")
        for name in ("tf", "phi", "step", "output_step", "rtol", "atol", "q_tol", "omega_tol", "norm_tol"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise InputError(f"expected a positive finite {name}, received {v!r}")
        if not (isinstance(self.q0_floor, (int, float)) and 0 <= self.q0_floor < 1):
            raise InputError(f"expected 0 <= q0_floor < 1, received {self.q0_floor!r}")
        for name in ("torque_limit", "sample_period"):
            v = getattr(self, name)
            if v is not None and (not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0):
                raise InputError(f"expected a positive finite {name} or none, received {v!r}")
        if self.sample_period is not None and self.integrator != "rk4":
            raise InputError(
                f"expected integrator 'rk4' with a sample period (zero-order hold), received {self.integrator!r}"
            )
        if self.inverse not in ("E", "solve"):
            raise InputError(f"expected inverse 'E' or 'solve', received {self.inverse!r}")

    @property
    def interval(self) -> float:
        """Output-grid spacing actually used (the sample period under ZOH)."""
        return float(self.sample_period) if self.sample_period is not None else float(self.output_step)

    @property
    def substeps(self) -> int:
        """RK4 sub-steps per output interval (``ceil(interval/step)``)."""
        return max(1, math.ceil(self.interval / self.step - 1e-9))


# ---------------------------------------------------------------------------
# parameter vector


def _param_layout(n: int) -> dict[str, slice]:
    sizes = [
        ("gains", 3),  # K_o, K_q, beta
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
    out, k = {}, 0
    for name, s in sizes:
        out[name] = slice(k, k + s)
        k += s
    out["_size"] = slice(0, k)
    return out


def pack_params(f: Formation, opt: SimOptions) -> np.ndarray:
    """The flat parameter vector of the compiled kernel for ``f`` and ``opt``."""
    n = f.n
    lay = _param_layout(n)
    p = np.zeros(lay["_size"].stop)
    g = f.gains
    p[lay["gains"]] = (g.K_o, g.K_q, g.beta)
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


# ---------------------------------------------------------------------------
# symbolic kernel


def _metrics_expr(x: ca.SX, n: int) -> ca.SX:
    """``(Omega_m, Q_m)`` (paper section 3) as CasADi expressions of the state.

    ``q_ij`` = vector part of ``q_bar_j^* (x) q_bar_i`` (paper's product):
    ``q0_j q_i - q0_i q_j - q_j x q_i``; ``omega_ij = omega_i - omega_j`` (body
    components, as in the paper's objective ``omega_i -> omega_j``).  Sums run
    over ordered pairs ``i != j`` and are normalised by ``n(n-1)``.
    """
    sw = 0
    sq = 0
    for i in range(n):
        qi, q0i = x[4 * i : 4 * i + 3], x[4 * i + 3]
        wi = x[4 * n + 3 * i : 4 * n + 3 * i + 3]
        for j in range(i + 1, n):
            qj, q0j = x[4 * j : 4 * j + 3], x[4 * j + 3]
            wj = x[4 * n + 3 * j : 4 * n + 3 * j + 3]
            qij = q0j * qi - q0i * qj - ca.cross(qj, qi)
            sq = sq + ca.sumsqr(qij)
            sw = sw + ca.sumsqr(wi - wj)
    # ordered pairs: each unordered pair twice (|q_ji| = |q_ij|)
    norm = n * (n - 1)
    return ca.vertcat(ca.sqrt(2 * sw / norm), ca.sqrt(2 * sq / norm))


@dataclass
class Kernel:
    """CasADi functions of one formation size / controller variant (internal).

    ``ctrl(x, t, p) -> u`` (3N torques, limited), ``plant(x, u, t, p) -> xdot``,
    ``rhs(x, t, p) -> xdot`` (continuous closed loop), ``metrics(x) -> (Omega_m, Q_m)``,
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
    ctrl: ca.Function
    plant: ca.Function
    rhs: ca.Function
    metrics: ca.Function
    chunk: ca.Function
    mc_chunk: ca.Function
    compiled: bool = False
    compile_seconds: float = 0.0
    sources: dict = field(default_factory=dict)


def _build_symbolic(n: int, switch: str, inverse: str) -> tuple[ca.Function, ca.Function, ca.Function, ca.Function]:
    lay = _param_layout(n)
    x = ca.SX.sym("x", 7 * n)
    u_in = ca.SX.sym("u", 3 * n)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", lay["_size"].stop)
    K_o, K_q, beta = p[lay["gains"]][0], p[lay["gains"]][1], p[lay["gains"]][2]
    Kv = p[lay["K_v"]]
    phi = p[lay["phi"]]
    umax = p[lay["umax"]]
    Jall = p[lay["J"]]
    Jinv_all = p[lay["Jinv"]]
    L = ca.reshape(p[lay["L"]], n, n)
    harm = p[lay["harm"]]
    freq = p[lay["freq"]]
    gg = p[lay["gg"]]
    orbit = p[lay["orbit"]]
    mf = model_function()
    ctrl_fn = build_controller(switch=switch, inverse=inverse).function
    q = [x[4 * i : 4 * i + 3] for i in range(n)]
    q0 = [x[4 * i + 3] for i in range(n)]
    w = [x[4 * n + 3 * i : 4 * n + 3 * i + 3] for i in range(n)]
    J = [ca.reshape(Jall[9 * i : 9 * i + 9], 3, 3) for i in range(n)]
    Jinv = [ca.reshape(Jinv_all[9 * i : 9 * i + 9], 3, 3) for i in range(n)]
    zero3 = ca.SX.zeros(3)
    E = [mf(q[i], q0[i], zero3, J[i])[0] for i in range(n)]  # E depends on (q, q0) only
    qd = [ca.mtimes(E[i], w[i]) for i in range(n)]
    Qmat = ca.horzcat(*q)  # 3 x n
    S = ca.mtimes(Qmat, L.T)  # column i = sum_j L_ij q_j = s_i
    us = []
    for i in range(n):
        out = ctrl_fn(q[i], q0[i], qd[i], J[i], S[:, i], K_o, K_q, beta, Kv[i], phi)
        ui = out[0]
        lim = umax[3 * i : 3 * i + 3]
        us.append(ca.fmin(lim, ca.fmax(-lim, ui)))
    u = ca.vertcat(*us)
    ctrl = ca.Function("fs_ctrl", [x, t, p], [u], ["x", "t", "p"], ["u"])

    trig = disturbance_trig(t, freq, orbit)  # time-only terms, once for the formation

    def plant_expr(uv: ca.SX) -> ca.SX:
        dq, dw = [], []
        for i in range(n):
            ud = disturbance_torque(trig, q[i], q0[i], J[i], harm[18 * i : 18 * i + 18], gg)
            dq.append(ca.vertcat(qd[i], -0.5 * ca.dot(q[i], w[i])))  # eq. (1)
            Jw = ca.mtimes(J[i], w[i])
            dw.append(ca.mtimes(Jinv[i], -ca.cross(w[i], Jw) + uv[3 * i : 3 * i + 3] + ud))  # eq. (2)
        return ca.vertcat(*dq, *dw)

    plant = ca.Function("fs_plant", [x, u_in, t, p], [plant_expr(u_in)], ["x", "u", "t", "p"], ["xdot"])
    rhs = ca.Function("fs_rhs", [x, t, p], [plant_expr(u), u], ["x", "t", "p"], ["xdot", "u"])
    metrics = ca.Function("fs_metrics", [x], [_metrics_expr(x, n)], ["x"], ["m"])
    return ctrl, plant, rhs, metrics


#: Output intervals per call of the compiled kernel.
CHUNK = 100

#: Sub-steps per output interval up to which the RK4 loop is unrolled in the kernel.
UNROLL_MAX = 10


def _build_kernel(n: int, switch: str, zoh: bool, M: int, K: int, inverse: str) -> Kernel:
    ctrl, plant, rhs, metrics = _build_symbolic(n, switch, inverse)
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
    return Kernel(n, switch, zoh, M, K, inverse, ctrl, plant, rhs, metrics, chunk, mc_chunk)


def cache_dir() -> Path:
    """User cache directory of compiled kernels (never inside the repository).

    ``$FORMSYNC_CACHE_DIR``, else ``$XDG_CACHE_HOME/formsync-design``, else
    ``~/.cache/formsync-design``.
    """
    env = os.environ.get("FORMSYNC_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "formsync-design"


#: gcc flags of the kernels.  ``-march=native`` (27% faster than plain ``-O2`` here) makes
#: the objects machine-specific, so the cache key includes the host and its CPU.
_CFLAGS = ["-O3", "-march=native", "-fPIC", "-shared"]


def _host_tag() -> str:
    import platform

    cpu = ""
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next((ln for ln in fh if ln.startswith("model name")), "")
    except OSError:  # pragma: no cover - not Linux
        pass
    return f"{platform.node()}|{platform.machine()}|{cpu.strip()}"


def _compile(fn: ca.Function) -> tuple[ca.Function, bool]:
    """C code generation + gcc, cached by the hash of the generated source."""
    cc = shutil.which("gcc") or shutil.which("cc")
    if cc is None:
        return fn, False
    name = fn.name()
    with tempfile.TemporaryDirectory() as td:
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        cg.add(fn)
        cg.generate(td + os.sep)
        src = Path(td, f"{name}.c").read_text()
    key = hashlib.sha256((src + " ".join(_CFLAGS) + ca.__version__ + _host_tag()).encode()).hexdigest()[:20]
    d = cache_dir() / "kernels"
    so = d / f"{name}_{key}.so"
    if not so.is_file():
        d.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=d) as td:
            c = Path(td, f"{name}.c")
            c.write_text(src)
            tmp_so = Path(td, so.name)
            r = subprocess.run([cc, *_CFLAGS, str(c), "-o", str(tmp_so), "-lm"], capture_output=True, text=True)
            if r.returncode != 0:  # pragma: no cover - compiler trouble
                raise SimulationError(f"expected the C kernel to compile, {cc} said: {r.stderr[-500:]}")
            os.replace(tmp_so, so)  # atomic: concurrent processes never see half a file
    return ca.external(name, str(so)), True


_KERNELS: dict = {}


def get_kernel(n: int, switch: str, zoh: bool, M: int, K: int = 100, inverse: str = "E", compile: bool = True) -> Kernel:
    """Build (and compile, cached on disk and in memory) the kernel of a formation size."""
    key = (n, switch, zoh, M, K, inverse, compile)
    hit = _KERNELS.get(key)
    if hit is not None:
        return hit
    t0 = time.perf_counter()
    k = _build_kernel(n, switch, zoh, M, K, inverse)
    if compile:
        k.chunk, ok1 = _compile(k.chunk)
        k.mc_chunk, ok2 = _compile(k.mc_chunk)
        k.compiled = ok1 and ok2
    k.compile_seconds = time.perf_counter() - t0
    _KERNELS[key] = k
    return k


# ---------------------------------------------------------------------------
# metrics in numpy (post-processing on a grid)


def formation_metrics(kernel_or_n: Kernel | int, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Omega_m, Q_m)`` at every row of ``X`` (shape ``(T, 7N)``), via the CasADi metric."""
    if isinstance(kernel_or_n, Kernel):
        mf = kernel_or_n.metrics
    else:
        x = ca.SX.sym("x", 7 * int(kernel_or_n))
        mf = ca.Function("fs_metrics", [x], [_metrics_expr(x, int(kernel_or_n))])
    X = np.atleast_2d(X)
    out = mf.map(X.shape[0])(X.T).full()
    return out[0], out[1]


def convergence_time(t: np.ndarray, omega_m: np.ndarray, q_m: np.ndarray, q_tol: float, omega_tol: float) -> float | None:
    """First grid time after which ``Q_m <= q_tol`` and ``Omega_m <= omega_tol`` hold to the end.

    ``None`` if the last sample violates either bound.

    >>> convergence_time(np.arange(4.0), np.array([1, 0, 1, 0.0]), np.zeros(4), 1e-4, 1e-5)
    3.0
    """
    ok = (np.asarray(q_m) <= q_tol) & (np.asarray(omega_m) <= omega_tol)
    if ok.size == 0 or not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    k = 0 if bad.size == 0 else int(bad[-1]) + 1
    return float(t[k])


# ---------------------------------------------------------------------------
# result


@dataclass(frozen=True)
class SimResult:
    """A finished simulation (frozen).

    Attributes
    ----------
    status : {"converged", "not-converged", "singular"}
    t : (T,) grid (s); x : (T, 7N) states (module docstring); u : (T, 3N) torques (N m),
        ``u[k]`` acts on ``[t_k, t_{k+1})`` (exactly under ZOH; the value at ``t_k`` otherwise)
    omega_m, q_m : (T,) the paper's metrics
    convergence_time : float or None
    final_omega_m, final_q_m : float
    peak_torque : (N, 3) max |u| per spacecraft and axis (N m)
    min_q0 : (N,) over all sub-steps; singular_spacecraft (1-based) / singular_time when hit
    saturation_end_time : last grid time with some torque component at ``torque_limit``
        (None without a limit or if never reached)
    final_rates : (N, 3) absolute body rates at the end (rad/s);
    common_rate : (3,) their mean (a common drift if nonzero)
    stats : dict - integrator, steps, rhs evaluations, wall/compile seconds, max norm error
    options : SimOptions; n : int; names : list of state names
    """

    status: str
    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    omega_m: np.ndarray
    q_m: np.ndarray
    convergence_time: float | None
    final_omega_m: float
    final_q_m: float
    peak_torque: np.ndarray
    min_q0: np.ndarray
    singular_spacecraft: int | None
    singular_time: float | None
    saturation_end_time: float | None
    final_rates: np.ndarray
    common_rate: np.ndarray
    stats: dict
    options: SimOptions
    n: int
    names: tuple[str, ...]

    @property
    def converged(self) -> bool:
        return self.status == "converged"

    @property
    def quaternions(self) -> np.ndarray:
        """(T, N, 4) ``(q1, q2, q3, q0)``."""
        return unpack_state(self.x, self.n)[0]

    @property
    def rates(self) -> np.ndarray:
        """(T, N, 3) body rates (rad/s)."""
        return unpack_state(self.x, self.n)[1]

    @property
    def torques(self) -> np.ndarray:
        """(T, N, 3) control torques (N m)."""
        return self.u.reshape(len(self.t), self.n, 3)

    def message(self) -> str:
        """One line a user can act on."""
        if self.status == "singular":
            i = int(self.singular_spacecraft or 1)
            q0 = float(self.min_q0[i - 1])
            if q0 <= self.options.q0_floor:
                return (
                    f"q0 of spacecraft {i} reached {self.options.q0_floor:g} at t = {self.singular_time:.4f} s: "
                    f"Q is singular at q0 = 0 and controller (4) undefined"
                )
            return (
                f"q0 of spacecraft {i} fell to {q0:.3g} at t = {self.singular_time:.4f} s and the "
                f"integration blew up there (|omega| ~ 2|q'|/q0): the q0 -> 0 singularity of Q, "
                f"where controller (4) is undefined"
            )
        if self.status == "converged":
            return (
                f"converged at t = {self.convergence_time:.2f} s (Q_m <= {self.options.q_tol:g}, "
                f"Omega_m <= {self.options.omega_tol:g} rad/s to the end)"
            )
        return (
            f"not converged within tf = {self.t[-1]:g} s: final Q_m = {self.final_q_m:.3e}, "
            f"Omega_m = {self.final_omega_m:.3e} rad/s (tolerances {self.options.q_tol:g}, "
            f"{self.options.omega_tol:g})"
        )

    def summary(self) -> dict:
        """JSON-ready summary (no trajectories)."""
        o = self.options
        return {
            "status": self.status,
            "message": self.message(),
            "n": self.n,
            "tf": float(self.t[-1]),
            "convergence_time": self.convergence_time,
            "final_omega_m": self.final_omega_m,
            "final_q_m": self.final_q_m,
            "peak_torque": self.peak_torque.tolist(),
            "min_q0": self.min_q0.tolist(),
            "singular_spacecraft": self.singular_spacecraft,
            "singular_time": self.singular_time,
            "saturation_end_time": self.saturation_end_time,
            "final_rates": self.final_rates.tolist(),
            "common_rate": self.common_rate.tolist(),
            "options": {
                "switch": o.switch,
                "phi": o.phi,
                "torque_limit": o.torque_limit,
                "sample_period": o.sample_period,
                "integrator": o.integrator,
                "step": o.step,
                "output_step": o.interval,
                "rtol": o.rtol,
                "atol": o.atol,
                "q_tol": o.q_tol,
                "omega_tol": o.omega_tol,
                "q0_floor": o.q0_floor,
            },
            "stats": self.stats,
        }

    def to_npz(self, path: str | Path) -> Path:
        """Write ``t, x, u, omega_m, q_m, names`` to a compressed NPZ file."""
        p = Path(path)
        np.savez_compressed(
            p, t=self.t, x=self.x, u=self.u, omega_m=self.omega_m, q_m=self.q_m, names=np.array(self.names)
        )
        return p

    def to_csv(self, path: str | Path) -> Path:
        """Write one row per grid time: ``t, <state names>, u1_1.., Omega_m, Q_m``."""
        p = Path(path)
        unames = [f"u{k}_{i}" for i in range(1, self.n + 1) for k in (1, 2, 3)]
        header = ",".join(["t", *self.names, *unames, "Omega_m", "Q_m"])
        data = np.column_stack([self.t, self.x, self.u, self.omega_m, self.q_m])
        np.savetxt(p, data, delimiter=",", header=header, comments="", fmt="%.17g")
        return p


# ---------------------------------------------------------------------------
# driver


def simulate(formation: Formation, options: SimOptions | None = None) -> SimResult:
    """Simulate the closed-loop formation.

    Parameters
    ----------
    formation : Formation
    options : SimOptions, optional

    Returns
    -------
    SimResult
        Status ``converged`` / ``not-converged`` / ``singular`` (a finding, not an error).

    Raises
    ------
    SimulationError
        NaN/inf in the state (the message names the time), or quaternion norm
        drift beyond ``options.norm_tol``.

    Examples
    --------
    >>> from formsync_design.graphs.build import make_graph
    >>> from formsync_design.models.disturbances import no_disturbance
    >>> q = np.array([[0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]])
    >>> att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    >>> f = Formation(make_graph("path:2"), np.array([np.eye(3)] * 2), att, np.zeros((2, 3)),
    ...               Gains(1.6, 0.4, 0.3, (0.0, 0.0)), no_disturbance(2))
    >>> r = simulate(f, SimOptions(tf=60.0, compile=False))
    >>> r.status, r.final_q_m < 1e-4
    ('converged', True)
    """
    opt = options if options is not None else SimOptions()
    if opt.integrator == "cvodes":
        return _simulate_cvodes(formation, opt)
    return _simulate_rk4(formation, opt)


def _grid_count(opt: SimOptions) -> int:
    K = opt.tf / opt.interval
    Kr = round(K)
    if abs(K - Kr) > 1e-9 * max(1.0, K):
        raise InputError(
            f"expected tf ({opt.tf:g} s) to be a multiple of the output interval "
            f"({opt.interval:g} s), received ratio {K:.6g}"
        )
    return max(1, int(Kr))


def _simulate_rk4(f: Formation, opt: SimOptions) -> SimResult:
    n = f.n
    nx = 7 * n
    Ktot = _grid_count(opt)
    M = opt.substeps
    h = opt.interval / M
    Kc = CHUNK  # fixed, so one compiled kernel serves every horizon (extra intervals are dropped)
    kern = get_kernel(n, opt.switch, opt.sample_period is not None, M, Kc, opt.inverse, opt.compile)
    p = pack_params(f, opt)
    xa = np.concatenate([f.initial_state(), [0.0]])
    Xs = [xa[:nx][None, :]]
    Us, MQ = [], []
    Ms = [kern.metrics(xa[:nx]).full().T]
    t0 = time.perf_counter()
    done = 0
    stop = None
    while done < Ktot:
        XA, U, MINQ, MET = (a.full().T for a in kern.chunk(xa, h, p))
        take = min(Kc, Ktot - done)
        XA, U, MINQ, MET = XA[:take], U[:take], MINQ[:take], MET[:take]
        # singularity first (a finding), then non-finite values (an error); CasADi's
        # fmin ignores NaN, so a blow-up shows in XA/U, not in MINQ
        sing = np.flatnonzero((MINQ <= opt.q0_floor).any(axis=1))
        with np.errstate(all="ignore"):
            drift = np.abs(np.linalg.norm(XA[:, : 4 * n].reshape(-1, n, 4), axis=2) - 1).max(axis=1)
        bad = np.flatnonzero(~np.isfinite(XA).all(axis=1) | ~np.isfinite(U).all(axis=1) | ~(drift <= opt.norm_tol))
        if sing.size or bad.size:
            k = int(min(sing[0] if sing.size else Ktot, bad[0] if bad.size else Ktot))
            Xs.append(XA[:k, :nx])
            Us.append(U[: k + 1])
            MQ.append(MINQ[:k])
            Ms.append(MET[:k])
            stop = True
            done += k
            break
        Xs.append(XA[:, :nx])
        Us.append(U)
        MQ.append(MINQ)
        Ms.append(MET)
        xa = XA[-1]
        done += take
    wall = time.perf_counter() - t0
    X = np.vstack(Xs)
    t = np.arange(X.shape[0]) * opt.interval
    sing_sc = sing_t = None
    if stop is not None:
        # the interval starting at the last kept grid point holds the event
        left = max(1, Ktot - done)
        sing_sc, sing_t, q0_last = _locate_event(
            kern, X[-1], float(t[-1]), h, M, p, opt.q0_floor, opt.norm_tol, min(10, left)
        )
        if sing_sc is None:
            raise SimulationError(
                f"expected finite states with quaternion norm drift <= {opt.norm_tol:g}, received "
                f"NaN/inf or a larger drift at t = {sing_t:.4f} s (smallest q0 just before: "
                f"{q0_last:.3g}, not near the q0 singularity); reduce the step"
            )
        U = np.vstack(Us)[: X.shape[0]]
    else:
        # torque at tf (under ZOH: the value the hold would apply next)
        ulast = kern.ctrl(X[-1], t[-1], p).full().ravel()
        U = np.vstack([*Us, ulast[None, :]])
    minq = np.min(np.vstack([f.attitudes[:, 3][None, :], *MQ]), axis=0)
    if sing_sc is not None:
        minq[sing_sc - 1] = min(minq[sing_sc - 1], q0_last)
    steps = done * M
    evals = steps * 4
    stats = {
        "integrator": "rk4",
        "compiled": kern.compiled,
        "step": h,
        "substeps_per_interval": M,
        "steps": steps,
        "rhs_evaluations": evals,
        "controller_evaluations": evals if opt.sample_period is None else done,
        "wall_seconds": wall,
        "build_seconds": kern.compile_seconds,
    }
    return _finish(f, opt, kern, t, X, U, minq, sing_sc, sing_t, stats, np.vstack(Ms))


#: A blow-up (NaN/inf) right after some ``q0`` fell below this value is attributed to the
#: ``q0 -> 0`` singularity: there ``|omega| ~ 2|q'|/q0`` and the closed loop becomes
#: arbitrarily fast, so a fixed-step integrator fails before ``q0`` reaches ``q0_floor``.
SINGULAR_BLOWUP_Q0 = 0.1


def _locate_event(
    kern: Kernel, x: np.ndarray, t0: float, h: float, M: int, p: np.ndarray, floor: float,
    norm_tol: float = 1e-6, intervals: int = 10,
) -> tuple[int | None, float, float]:
    """Re-run from ``x`` at ``t0``, the start of the output interval that holds an event,
    for up to ``intervals`` output intervals (CasADi VM), with the step ``h`` and, if the
    state blows up first, with ``h/10`` and ``h/100``:
    near ``q0 = 0`` the body rate ``|omega| ~ 2|q'|/q0`` grows without bound and a
    fixed step loses accuracy before ``q0`` reaches ``floor``.

    Returns ``(spacecraft (1-based) or None, time, smallest q0 before the event)``:
    a spacecraft when some ``q0`` reached ``floor`` (time linearly interpolated), or
    when even ``h/100`` blows up (NaN/inf or norm drift above ``norm_tol``) right
    after some ``q0 < SINGULAR_BLOWUP_Q0``; ``None`` for a blow-up away from the
    singularity or a coarse-step failure that the finer steps do not reproduce
    (time = start of the failing sub-step)."""
    n = kern.n
    iq = [4 * i + 3 for i in range(n)]
    u0 = kern.ctrl(x, t0, p)

    def f(xx: Any, tt: float) -> np.ndarray:
        if kern.zoh:
            return kern.plant(xx, u0, tt, p).full().ravel()
        return kern.rhs(xx, tt, p)[0].full().ravel()

    result: tuple[int | None, float, float] = (None, t0, float(np.min(np.asarray(x)[iq])))
    drift0 = float(np.abs(np.linalg.norm(np.asarray(x)[: 4 * n].reshape(n, 4), axis=1) - 1).max())
    allowed = norm_tol + drift0  # drift already accumulated before the interval is not its fault
    for refine in (1, 10, 100):
        hh = h / refine
        xk, tk = np.array(x, dtype=float), t0
        blew = False
        for _ in range(M * refine * intervals):
            with np.errstate(all="ignore"):
                k1 = f(xk, tk)
                k2 = f(xk + hh / 2 * k1, tk + hh / 2)
                k3 = f(xk + hh / 2 * k2, tk + hh / 2)
                k4 = f(xk + hh * k3, tk + hh)
                xn = xk + hh / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
                drift = np.abs(np.linalg.norm(xn[: 4 * n].reshape(n, 4), axis=1) - 1).max()
            q0a, q0b = xk[iq], xn[iq]
            hit = np.isfinite(q0b) & (q0b <= floor)
            if hit.any():
                best_i, best_t = 0, math.inf
                for i in np.flatnonzero(hit):
                    a, b = q0a[i], q0b[i]
                    frac = (a - floor) / (a - b) if a != b else 1.0
                    tc = tk + hh * min(max(frac, 0.0), 1.0)
                    if tc < best_t:
                        best_i, best_t = int(i), tc
                return best_i + 1, float(best_t), float(floor)
            if not (np.all(np.isfinite(xn)) and drift <= allowed):
                i = int(np.argmin(q0a))
                sc = i + 1 if q0a[i] < SINGULAR_BLOWUP_Q0 else None
                result = (sc, float(tk), float(q0a[i]))
                blew = True
                break
            xk, tk = xn, tk + hh
        if not blew:
            # the finer step passes: the coarse step itself was inadequate
            return None, float(t0), float(np.min(np.asarray(x)[iq]))
    return result


def _finish(
    f: Formation,
    opt: SimOptions,
    kern: Kernel,
    t: np.ndarray,
    X: np.ndarray,
    U: np.ndarray,
    minq: np.ndarray,
    sing_sc: int | None,
    sing_t: float | None,
    stats: dict,
    metrics: np.ndarray | None = None,
) -> SimResult:
    n = f.n
    if metrics is None:
        om, qm = formation_metrics(kern, X)
    else:
        om, qm = np.ascontiguousarray(metrics[:, 0]), np.ascontiguousarray(metrics[:, 1])
    quats, rates = unpack_state(X, n)
    norm_err = float(np.max(np.abs(np.linalg.norm(quats, axis=2) - 1)))
    stats = {**stats, "max_norm_error": norm_err}
    if norm_err > opt.norm_tol and sing_sc is None:
        raise SimulationError(
            f"expected the quaternion norm to stay within {opt.norm_tol:g} of 1, received drift "
            f"{norm_err:.3e}; tighten the step/tolerances"
        )
    if sing_sc is not None:
        status = "singular"
        ct = None
    else:
        ct = convergence_time(t, om, qm, opt.q_tol, opt.omega_tol)
        status = "converged" if ct is not None else "not-converged"
    sat_end = None
    if opt.torque_limit is not None:
        at = np.flatnonzero((np.abs(U) >= opt.torque_limit * (1 - 1e-12)).any(axis=1))
        sat_end = float(t[at[-1]]) if at.size else None
    for a in (t, X, U, om, qm):
        a.setflags(write=False)
    return SimResult(
        status=status,
        t=t,
        x=X,
        u=U,
        omega_m=om,
        q_m=qm,
        convergence_time=ct,
        final_omega_m=float(om[-1]),
        final_q_m=float(qm[-1]),
        peak_torque=np.max(np.abs(U.reshape(len(U), n, 3)), axis=0),
        min_q0=minq,
        singular_spacecraft=sing_sc,
        singular_time=sing_t,
        saturation_end_time=sat_end,
        final_rates=rates[-1].copy(),
        common_rate=rates[-1].mean(axis=0),
        stats=stats,
        options=opt,
        n=n,
        names=tuple(state_names(n)),
    )


def _simulate_cvodes(f: Formation, opt: SimOptions) -> SimResult:
    n = f.n
    Ktot = _grid_count(opt)
    kern = get_kernel(n, opt.switch, False, 1, 1, opt.inverse, compile=False)
    p = pack_params(f, opt)
    x = ca.SX.sym("x", 7 * n)
    t = ca.SX.sym("t")
    ps = ca.SX.sym("p", p.size)
    dae = {"x": x, "t": t, "p": ps, "ode": kern.rhs(x, t, ps)[0]}
    grid = np.arange(1, Ktot + 1) * opt.interval
    integ = ca.integrator(
        "fs_cvodes", "cvodes", dae, 0.0, grid,
        {"abstol": opt.atol, "reltol": opt.rtol, "max_num_steps": 10**7, "print_stats": False},
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
    elif not np.all(np.isfinite(X)):
        k = int(np.flatnonzero(~np.isfinite(X).all(axis=1))[0])
        raise SimulationError(f"expected finite states, received NaN/inf at t = {tg[k]:g} s")
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
    return _finish(f, opt, kern, tg, X, U, minq, sing_sc, sing_t, stats)
