"""Compiled closed-loop simulation of the fly-around case (Zhang et al. 2014, issue 14).

:func:`simulate_flyaround` runs a design on the relative-orbit plant (default
``zhang2014_flyaround``) on a :class:`FlyaroundScenario` (orbits, spacecraft, fly-around reference, thrusters, gains):
one control sample every ``sample_period`` seconds with the PWM pulses of that sample
integrated inside it (:mod:`formsync_design.sim.tracking_model`).  The sample step is
generated once per design and option set, compiled to C through the kernel compiler and
disk cache of :mod:`formsync_design.sim.kernels`, and folded over chunks of samples
(``casadi.Function.mapaccum``), so the whole 18 000 s case is a few calls into C.  With
``allocation="lp"`` the minimum-fuel LP (:class:`~formsync_design.models.allocation.
MinFuelAllocator`) is solved in Python between a compiled control call and a compiled
propagation call per sample.

The LQR gain is computed from the design's ``lqr_weights`` on the CW model
(:func:`~formsync_design.models.orbit.lqr_design`); the initial relative state from the
Keplerian elements (:func:`~formsync_design.models.orbit.relative_state`); the initial
attitude is the desired attitude at ``t = 0`` rotated by the 3-2-1 angles
``attitude0_deg`` (body relative to desired), with the relative rate ``rate0``.

>>> from formsync_design.verify.tracking_case import load_flyaround_case
>>> sc = load_flyaround_case().scenario          # the paper's case and the case file's gains
>>> isinstance(sc, FlyaroundScenario), sc.gains["k_p"]
(True, (807.0,))
>>> run = simulate_flyaround(sc, FlyaroundOptions(tf=2.0))
>>> run.t.shape, run.quaternions.shape, run.orbit.states.shape, run.orbit.fuel > 0
((10,), (10, 1, 4), (11, 12), True)

The run is a :class:`~formsync_design.sim.result.SimResult` of one spacecraft; ``converged``
needs the attitude and position errors within ``angle_tol`` and ``position_tol`` to the end
(2 s is too short: the initial attitude error is 1.7 deg):

>>> str(run.status), run.convergence_time is None
('not-converged', True)

A state that goes non-finite is a finding, not an error: the run ends at the last finite
state with the status ``diverged`` and the time (a plant of almost no inertia):

>>> from dataclasses import replace
>>> bad = simulate_flyaround(replace(sc, inertia=1e-9 * np.eye(3)), FlyaroundOptions(tf=200.0))
>>> str(bad.status), bad.diverged_time > 0, bool(np.isfinite(bad.orbit.states).all())
('diverged', True, True)
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.models.mrp import mrp_from_matrix, mrp_to_quat_array
from formsync_design.models.orbit import (
    LQRDesign,
    cw_matrices,
    elements_to_state,
    lqr_design,
    relative_state,
)
from formsync_design.models.quaternion import quat_multiply_array
from formsync_design.models.relative_reference import (
    desired_attitude,
    rotation_rT,
)
from formsync_design.models.thrusters import (
    positive_null_vector,
)
from formsync_design.sim.disagreement import settle_time
from formsync_design.sim.orbit_record import GRAPH, OrbitRecord
from formsync_design.sim.result import SimResult, SimStatus
from formsync_design.sim.tracking_model import (
    N_THRUSTERS_MAX,
    OUTPUTS,
    build_functions,
    param_layout,
)
from formsync_design.sim.tracking_scenario import (
    FlyaroundOptions,
    FlyaroundScenario,
    euler321,
)
from formsync_design.spec.agent import AgentDesign
from formsync_design.spec.declarations import GainKind, GainRole
from formsync_design.spec.loader import load_design
from formsync_design.spec.tracking import gain_entry_symbols, tracking_expressions

__all__ = [
    "simulate_flyaround",
    "flyaround_result",
    "initial_state",
    "lqr_for",
    "rotation_vectors",
]

#: Samples per call of the compiled chunk.
CHUNK = 500

#: An ``lp`` run compiles its control and propagation functions from this many samples
#: on (a shorter run is faster in the CasADi virtual machine than with a cold C build).
LP_COMPILE_MIN_SAMPLES = 5000


def lqr_for(spec: AgentDesign, scenario: FlyaroundScenario) -> tuple[LQRDesign, np.ndarray, np.ndarray]:
    """The LQR design of ``spec``'s weights on the CW model: ``(design, Q, R)``."""
    ex = tracking_expressions(spec)
    sub: dict[Any, float] = {}
    for g in spec.decl.gains:
        if g.role != GainRole.WEIGHT:
            continue
        vals = _gain_values(scenario, g)
        sub.update(dict(zip(gain_entry_symbols(g), vals)))
    q = np.array(ex.Q.xreplace(sub).evalf(), dtype=float)
    r = np.array(ex.R.xreplace(sub).evalf(), dtype=float)
    a, b = cw_matrices(scenario.mean_motion)
    return lqr_design(a, b, q, r), q, r


def _gain_values(scenario: FlyaroundScenario, g: Any) -> tuple[float, ...]:
    if g.name not in scenario.gains:
        raise InputError(f"expected a value for the design's gain {g.name!r}, received gains "
                         f"{sorted(scenario.gains)}")
    vals = tuple(float(v) for v in np.atleast_1d(np.asarray(scenario.gains[g.name], float)))
    width = 3 if g.kind == GainKind.DIAG else 1
    if len(vals) == 1 and width == 3:
        vals = vals * 3
    if len(vals) != width or not all(math.isfinite(v) and v > 0 for v in vals):
        raise InputError(f"expected {g.name} as {width} positive number(s), received {vals}")
    return vals


def initial_state(scenario: FlyaroundScenario,
                  reading: str = "corrected") -> tuple[np.ndarray, np.ndarray]:
    """``(x0[12], R_dr(0) row-major[9])`` of the scenario (module docstring)."""
    x_rel = relative_state(elements_to_state(scenario.target, scenario.mu),
                           elements_to_state(scenario.chaser, scenario.mu))
    n = scenario.mean_motion
    d0 = desired_attitude(0.0, scenario.reference, n, reading)
    u0 = scenario.target.argp + scenario.target.nu
    c, s = math.cos(u0), math.sin(u0)
    c_ti = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    c_bd = euler321(scenario.attitude0_deg)
    c_bi = c_bd @ d0.R_dT @ c_ti
    sigma0 = mrp_from_matrix(c_bi.T)
    omega0 = c_bd @ d0.omega_di + scenario.rate0
    return np.concatenate([x_rel, sigma0, omega0]), d0.R_dr.ravel()


class _Kernel:
    def __init__(self, fns: dict[str, Any], chunk: Any, compiled: bool, seconds: float,
                 tag: str) -> None:
        self.fns, self.chunk, self.compiled, self.seconds = fns, chunk, compiled, seconds
        self.tag = tag  # the disk-cache key material: the design's digest and the options
        self.ctrl_c: Any = None
        self.lp_compiled = False
        self.prop_c: Any = None


_KERNELS: dict[tuple[Any, ...], _Kernel] = {}


def _laws(spec: AgentDesign) -> dict[str, Any]:
    ex = tracking_expressions(spec)
    av, ov = ex.attitude_view, ex.orbit_view
    tr = av.track
    ctrl_gains = [g for g in spec.decl.gains if g.role == GainRole.CONTROLLER]

    def bind_torque(sig: Any, w: Any, ws: Any, wd: Any, ad: Any, jh: Any, gv: Any) -> dict:
        b: dict[Any, Any] = {}
        for vec, val in ((tr.sigma, sig), (tr.w, w), (av.w, ws), (tr.w_ref, wd),
                         (tr.wdot_ref, ad)):
            b.update({vec[i]: val[i] for i in range(3)})
        for i in range(3):
            for k in range(i, 3):
                b[av.J[i, k]] = jh[i, k]
        pos = 0
        for g in ctrl_gains:
            for s_ in gain_entry_symbols(g):
                b[s_] = gv[pos]
                pos += 1
        return b

    def bind_orbit(dx: Any, ff: Any, k: Any) -> dict:
        b: dict[Any, Any] = {ov.dX[i]: dx[i] for i in range(6)}
        b.update({ov.ff[i]: ff[i] for i in range(3)})
        b.update({ov.K[i, j]: k[i, j] for i in range(3) for j in range(6)})
        return b

    ngain = sum(len(gain_entry_symbols(g)) for g in ctrl_gains)
    return {"torque": ex.torque, "acceleration": ex.acceleration, "bind_torque": bind_torque,
            "bind_orbit": bind_orbit, "ngain": ngain, "ctrl_gains": ctrl_gains}


def _kernel(spec: AgentDesign, opt: FlyaroundOptions) -> _Kernel:
    from formsync_design.sim.ccompile import compile_enabled
    from formsync_design.sim.kernels import compile_function

    compile = opt.compile and compile_enabled()
    key = (spec.key, opt.substeps, opt.sample_period, compile)
    hit = _KERNELS.get(key)
    if hit is not None:
        return hit
    t0 = time.perf_counter()
    laws = _laws(spec)
    fns = build_functions(laws, laws["ngain"], opt.substeps, opt.sample_period)
    chunk = fns["step"].mapaccum("fa_chunk", CHUNK, 2)
    compiled = False
    tag = f"{spec.key}|flyaround|{opt.substeps}|{opt.sample_period!r}"
    if compile:
        chunk, compiled = compile_function(chunk, tag)
    k = _Kernel(fns, chunk, compiled, time.perf_counter() - t0, tag)
    _KERNELS[key] = k
    return k


def _params(spec: AgentDesign, sc: FlyaroundScenario, opt: FlyaroundOptions,
            lqr: LQRDesign) -> np.ndarray:
    laws = _laws(spec)
    lay = param_layout(laws["ngain"])
    p = np.zeros(lay["_size"].stop)
    p[lay["K"]] = lqr.K.T.ravel()  # column-major 3x6
    gv: list[float] = []
    for g in laws["ctrl_gains"]:
        gv.extend(_gain_values(sc, g))
    p[lay["att_gains"]] = gv
    j = sc.inertia
    jh = sc.inertia if sc.law_inertia is None else sc.law_inertia
    p[lay["J"]] = j.T.ravel()
    p[lay["Jinv"]] = np.linalg.inv(j).T.ravel()
    p[lay["Jhat"]] = jh.T.ravel()
    p[lay["mass"]] = sc.mass
    p[lay["mass_hat"]] = sc.mass
    p[lay["thrust"]] = sc.layout.thrust
    p[lay["min_pulse"]] = opt.min_pulse
    p[lay["carry"]] = 1.0 if opt.carry else 0.0
    p[lay["shift"]] = 1.0 if opt.allocation == "pinv-shift" else 0.0
    nt, m = N_THRUSTERS_MAX, sc.layout.count
    a = np.zeros((6, nt))
    a[:, :m] = sc.layout.matrix
    apinv = np.zeros((nt, 6))
    apinv[:m] = np.linalg.pinv(sc.layout.matrix)
    p[lay["Apinv"]] = apinv.T.ravel()
    p[lay["A"]] = a.T.ravel()
    z = np.ones(nt)
    if opt.allocation == "pinv-shift":
        z[:m] = positive_null_vector(sc.layout)
    p[lay["null"]] = z
    r = sc.reference
    p[lay["ref"]] = [r.a, r.b, r.c, r.phi0, r.theta0, r.p1, r.p2, r.period,
                     1.0 if opt.reading == "printed" else 0.0]
    p[lay["RrT"]] = rotation_rT(r).T.ravel()
    n = sc.mean_motion
    p[lay["orbit"]] = [sc.mu, sc.target.a, n, sc.target.argp + sc.target.nu]
    a_cw, _ = cw_matrices(n)
    p[lay["cw"]] = a_cw[3:, :].T.ravel()
    p[lay["tol"]] = [1e-9, 1e-12]
    return p


def simulate_flyaround(scenario: FlyaroundScenario,
                       options: FlyaroundOptions | None = None,
                       spec: AgentDesign | str | None = None) -> SimResult:
    """Simulate the fly-around closed loop (module docstring).

    Parameters
    ----------
    scenario : FlyaroundScenario
        The case (:func:`~formsync_design.verify.tracking_case.load_flyaround_case` reads
        one from a case file).
    options : FlyaroundOptions, optional
    spec : AgentDesign or str, optional
        A design on the relative-orbit plant (default ``zhang2014_flyaround``).

    Returns
    -------
    SimResult
        One spacecraft (:mod:`formsync_design.sim.orbit_record`): its attitude, body rate and
        applied torque at the control instants, the attitude tracking error, and in
        ``orbit`` the relative orbit, the per-sample outputs and the fuel.  ``converged`` or
        ``not-converged`` by ``options.angle_tol`` and ``options.position_tol``; a
        non-finite state is the status ``diverged`` with its time (no exception).
    """
    sc = scenario
    opt = options if options is not None else FlyaroundOptions()
    sp_ = load_design(spec if spec is not None else "zhang2014_flyaround")
    lqr, _, _ = lqr_for(sp_, sc)
    tb = time.perf_counter()
    kern = _kernel(sp_, opt)
    build = time.perf_counter() - tb  # this run's: a kernel kept from an earlier run costs ~0
    p = _params(sp_, sc, opt, lqr)
    x0, rdr0 = initial_state(sc, opt.reading)
    c0 = np.concatenate([np.zeros(N_THRUSTERS_MAX), rdr0.reshape(3, 3).T.ravel()])
    nk = opt.samples
    t = np.arange(nk) * opt.sample_period
    width = sum(w for _, w in OUTPUTS)
    out = np.empty((nk, width))
    states = np.empty((nk + 1, 12))
    states[0] = x0
    t0 = time.perf_counter()
    fallbacks = 0
    bad: int | None = None  # the first index of ``states`` that is not finite
    if opt.allocation == "lp":
        fallbacks, bad = _run_lp(kern, sc, p, x0, c0, t, out, states)
    else:
        x, c = x0, c0
        for k0 in range(0, nk, CHUNK):
            tt = np.arange(k0, k0 + CHUNK) * opt.sample_period
            xs, cs, os_ = kern.chunk(x, c, tt[None, :], p)
            xs, os_ = np.asarray(xs), np.asarray(os_)
            take = min(CHUNK, nk - k0)
            states[k0 + 1:k0 + 1 + take] = xs[:, :take].T
            out[k0:k0 + take] = os_[:, :take].T
            x, c = xs[:, take - 1], np.asarray(cs)[:, take - 1]
            rows = np.flatnonzero(~np.isfinite(states[k0 + 1:k0 + 1 + take]).all(axis=1))
            if rows.size:  # a finding: the run ends at the last finite state
                bad = k0 + 1 + int(rows[0])
                break
    seconds = time.perf_counter() - t0
    tdiv = None
    if bad is not None:
        # states[bad] (at t_bad) is the first non-finite one: keep the samples before it,
        # whose states (t_0 .. t_{bad-1}) are all finite
        tdiv = float(bad * opt.sample_period)
        t, out, states = t[:bad - 1], out[:bad - 1], states[:bad]
    outputs, pos = {}, 0
    for name, w in OUTPUTS:
        outputs[name] = out[:, pos:pos + w] if w > 1 else out[:, pos]
        pos += w
    record = OrbitRecord(t=t, states=states, outputs=outputs, lqr=lqr, scenario=sc, options=opt,
                         lp_fallbacks=fallbacks)
    lp = opt.allocation == "lp"
    stats = {"integrator": "rk4", "compiled": bool(kern.lp_compiled if lp else kern.compiled),
             "step": opt.sample_period / opt.substeps, "substeps_per_sample": opt.substeps,
             "steps": int(t.size) * opt.substeps, "wall_seconds": seconds,
             "build_seconds": build}
    return flyaround_result(design=sp_.name, spec_key=sp_.key, record=record, diverged_time=tdiv,
                            stats=stats)


def _run_lp(kern: _Kernel, sc: FlyaroundScenario, p: np.ndarray, x0: np.ndarray,
            c0: np.ndarray, t: np.ndarray, out: np.ndarray,
            states: np.ndarray) -> tuple[int, int | None]:
    """The per-sample loop of an ``lp`` run (compiled control and propagation): the LP
    fallbacks and the first index of ``states`` that is not finite (None: all are)."""
    from formsync_design.models.allocation import MinFuelAllocator
    from formsync_design.sim.kernels import compile_function

    if kern.ctrl_c is None or (kern.compiled and not kern.lp_compiled
                               and t.size >= LP_COMPILE_MIN_SAMPLES):
        ctrl, prop = kern.fns["ctrl"], kern.fns["prop"]
        kern.lp_compiled = kern.compiled and t.size >= LP_COMPILE_MIN_SAMPLES
        if kern.lp_compiled:
            ctrl, _ = compile_function(ctrl, kern.tag + "|ctrl")
            prop, _ = compile_function(prop, kern.tag + "|prop")
        kern.ctrl_c, kern.prop_c = ctrl, prop
    alloc = MinFuelAllocator(sc.layout)
    m, nt = sc.layout.count, N_THRUSTERS_MAX
    # zero-copy evaluation (casadi.Function.buffer): the arrays below are the functions'
    # argument and result memory, updated in place every sample
    x, c, tk, f = x0.copy(), c0.copy(), np.zeros(1), np.zeros(nt)
    wr, fa, co, rdr = np.zeros(6), np.zeros(nt), np.zeros(20), np.zeros(9)
    xn, cn, tau, wp, sw = np.zeros(12), np.zeros(c0.size), np.zeros(nt), np.zeros(6), np.zeros(1)
    cbuf, ctrig = kern.ctrl_c.buffer()
    for i, arr in enumerate((x, c, tk, p)):
        cbuf.set_arg(i, arr.data)
    for i, arr in enumerate((wr, fa, co, rdr)):
        cbuf.set_res(i, arr.data)
    pbuf, ptrig = kern.prop_c.buffer()
    for i, arr in enumerate((x, c, tk, p, f, rdr)):
        pbuf.set_arg(i, arr.data)
    for i, arr in enumerate((xn, cn, tau, wp, sw)):
        pbuf.set_res(i, arr.data)
    fb = 0
    for k in range(t.size):
        tk[0] = t[k]
        ctrig()
        a = alloc.allocate(wr)
        fb += a.method != "explicit"
        f[:m] = a.thrusts
        ptrig()
        out[k] = np.concatenate([co[0:12], tau, wr, wp, co[18:20], sw, f])
        x[:] = xn
        c[:] = cn
        states[k + 1] = xn
        if not np.all(np.isfinite(xn)):
            return fb, k + 1
    return fb, None


def _scalar_last(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` scalar-first quaternions as ``(q1, q2, q3, q0)`` with ``q0 >= 0``."""
    q = np.concatenate([q[..., 1:], q[..., :1]], axis=-1)
    return np.where(q[..., 3:] < 0, -q, q)


def flyaround_result(*, design: str, spec_key: str, record: OrbitRecord,
                     diverged_time: float | None, stats: dict[str, Any]) -> SimResult:
    """The :class:`~formsync_design.sim.result.SimResult` of a fly-around run (its fields and
    status: :mod:`formsync_design.sim.orbit_record`) from its record.

    Parameters
    ----------
    design, spec_key : str
        The design's name and content key (a design on the relative-orbit plant).
    record : OrbitRecord
        The samples (a diverged run's end at the last finite state).
    diverged_time : float or None
        The first sample time with a non-finite state (None: the run completed).
    stats : dict
        The integrator's statistics (``SimResult.stats``).
    """
    opt, o = record.options, record.outputs
    k = record.t.size
    truth = record.states[:k]
    q = _scalar_last(mrp_to_quat_array(truth[:, 6:9]))
    # q_b = q_d (x) q_sd (R(sigma_sd): body to desired), so q_d = q_b (x) q_sd^*
    qsd = mrp_to_quat_array(o["sigma_sd"]) * np.array([1.0, -1.0, -1.0, -1.0])
    reference = _scalar_last(quat_multiply_array(mrp_to_quat_array(truth[:, 6:9]), qsd))
    angle = np.degrees(4.0 * np.arctan(np.linalg.norm(o["sigma_sd"], axis=1)))
    torques = np.array(o["wrench_pwm"][:, 3:6])[:, None, :]
    position = record.position_error
    if diverged_time is not None:
        status, conv = SimStatus.DIVERGED, None
        message = (f"diverged at t = {diverged_time:g} s (non-finite state; the run ends at "
                   f"t = {float(record.states.shape[0] - 1) * opt.sample_period:g} s): "
                   "check the gains, the inertia and the sample period")
    else:
        conv = settle_time(record.t, (angle <= opt.angle_tol) & (position <= opt.position_tol))
        status = SimStatus.CONVERGED if conv is not None else SimStatus.NOT_CONVERGED
        head = f"completed {k} samples to t = {opt.tf:g} s"
        if conv is not None:
            message = (f"{head}; attitude error <= {opt.angle_tol:g} deg and position error "
                       f"<= {opt.position_tol:g} m from t = {conv:g} s")
        else:
            message = (f"{head} without converging: at the end the attitude error is "
                       f"{angle[-1]:.3g} deg (angle_tol {opt.angle_tol:g}), the position error "
                       f"{position[-1]:.3g} m (position_tol {opt.position_tol:g})")
    return SimResult(
        status=status, message=message, design=design, graph=GRAPH, t=record.t,
        quaternions=q[:, None, :], rates=np.array(truth[:, 9:12])[:, None, :],
        states=np.zeros((k, 1, 0)), torques=torques, reference=reference,
        reference_error=angle, rate_error=np.linalg.norm(o["omega_sd"], axis=1),
        convergence_time=conv,
        peak_torque=np.abs(torques).max(axis=0) if k else np.zeros((1, 3)),
        effort=np.sum(torques * torques, axis=(0, 2)) * opt.sample_period,
        monitors={}, integrator=str(stats.get("integrator", "rk4")),
        diverged_time=diverged_time, stats=dict(stats), options=opt, spec_key=spec_key,
        orbit=record)


def rotation_vectors(sigma: np.ndarray) -> np.ndarray:
    """Rotation vectors ``4 atan|sigma| sigma/|sigma|`` (rad) of MRPs, ``(K, 3)``.

    >>> rotation_vectors(np.array([[0.0, 0.0, math.tan(0.25)]])).round(12).tolist()
    [[0.0, 0.0, 1.0]]
    """
    n = np.linalg.norm(sigma, axis=1)
    scale = np.where(n > 0, 4 * np.arctan(n) / np.where(n > 0, n, 1.0), 4.0)
    return sigma * scale[:, None]
