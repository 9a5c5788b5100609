"""CasADi expressions of the fly-around closed loop (Zhang et al. 2014): reference, desired
attitude, attitude error, the design's laws, allocation, PWM and the truth dynamics.

One sample of the loop (period ``dt``), :func:`build_functions`:

1. reference at ``t_k`` (:mod:`formsync_design.models.relative_reference`, written again here in
   CasADi with its time derivatives by automatic differentiation): ``l_r`` and its first
   three derivatives, the desired frame ``R_dr`` (sensor axis ``x_d = -l/|l|``, ``y_d =
   -h/|h|``, ``h = l x l'``) with the singular-case fallback, ``omega_di``, ``omega_di'``;
2. errors: ``sigma_sd`` (short MRP set of ``R_sd``) and ``omega_sd``; ``X - X_d``;
3. the design's laws, translated from its SymPy expressions by
   :func:`~formsync_design.sim.bridge.sympy_to_casadi` (nothing re-typed): torque ``T_c``
   and specific force ``u_T``; the force in body axes ``F_b = m C_bT u_T``;
4. allocation: ``f = A^+ w`` and a rule for negative thrusts (``shift`` along the
   layout's positive null vector, or ``clip``), clipped to ``[0, F]`` (or thrusts given
   from outside: an LP solved in Python);
5. PWM: on-time ``tau = f dt / F`` (+ the carried rounding error), rounded below the
   minimum pulse to the nearer of 0 and ``tau_min``; pulses centred in the period;
6. truth: ``M`` RK4 sub-steps of the nonlinear relative orbit dynamics (circular target,
   as :func:`~formsync_design.models.orbit.relative_nonlinear_rhs`), the MRP kinematics
   (:func:`~formsync_design.models.mrp.mrp_rhs_terms`) and Euler's equation, each sub-step
   with the exact average thrust of every pulse over it (so the impulse and angular
   impulse of every pulse are delivered exactly); then the shadow switch
   ``|sigma| > 1 -> -sigma/|sigma|^2``.

States: ``x = (rho[3], rho'[3], sigma[3], omega[3])`` (relative orbit frame ``T``; MRP of
body to inertial; body rate); carried: ``(impulse carry[16], previous R_dr[9])``.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from formsync_design.models.mrp import mrp_rhs_terms
from formsync_design.sim.bridge import sympy_to_casadi
from formsync_design.sim.layout import param_slices

__all__ = ["OUTPUTS", "param_layout", "build_functions", "mrp_matrix_ca", "dcm_to_mrp_ca",
           "reference_ca", "N_THRUSTERS_MAX"]

#: Thrusters a compiled kernel holds (a smaller layout pads with zero columns).
N_THRUSTERS_MAX = 16

#: Per-sample outputs of the step function, in order, with their widths.
OUTPUTS: tuple[tuple[str, int], ...] = (
    ("dX", 6), ("sigma_sd", 3), ("omega_sd", 3), ("on_time", N_THRUSTERS_MAX),
    ("wrench_cmd", 6), ("wrench_pwm", 6), ("raw_min", 1), ("frame_status", 1),
    ("switched", 1), ("thrust_cmd", N_THRUSTERS_MAX),
)


def param_layout(ngain: int) -> dict[str, slice]:
    """Slices of the flat parameter vector (``ngain``: entries of the attitude gains)."""
    nt = N_THRUSTERS_MAX
    sizes = [("K", 18), ("att_gains", ngain), ("J", 9), ("Jinv", 9), ("Jhat", 9),
             ("mass", 1), ("mass_hat", 1), ("thrust", 1), ("min_pulse", 1), ("carry", 1),
             ("shift", 1), ("Apinv", 6 * nt), ("A", 6 * nt), ("null", nt), ("ref", 9),
             ("RrT", 9), ("orbit", 4), ("cw", 18), ("tol", 2)]
    return param_slices(sizes)


def mrp_matrix_ca(s: Any) -> Any:
    """``R(sigma)`` (body to reference) of :func:`~formsync_design.models.mrp.mrp_to_matrix`."""
    n2 = ca.dot(s, s)
    sx = ca.skew(s)
    return ca.SX.eye(3) + (8 * ca.mtimes(sx, sx) + 4 * (1 - n2) * sx) / (1 + n2) ** 2


def dcm_to_mrp_ca(r: Any) -> Any:
    """Short-set MRP of a rotation matrix ``R`` (body to reference), Shepperd's branches.

    Inverse of :func:`mrp_matrix_ca`: ``R = (q0^2 - |q|^2) I + 2 q q^T + 2 q0 q^x``.
    """
    tr = r[0, 0] + r[1, 1] + r[2, 2]
    cands = []
    # q0 largest
    s0 = 2 * ca.sqrt(ca.fmax(1 + tr, 1e-300))
    cands.append(ca.vertcat(s0 / 4, (r[2, 1] - r[1, 2]) / s0, (r[0, 2] - r[2, 0]) / s0,
                            (r[1, 0] - r[0, 1]) / s0))
    for i in range(3):
        j, m = (i + 1) % 3, (i + 2) % 3
        si = 2 * ca.sqrt(ca.fmax(1 + 2 * r[i, i] - tr, 1e-300))
        q: list[Any] = [None] * 4
        q[0] = (r[m, j] - r[j, m]) / si
        q[1 + i] = si / 4
        q[1 + j] = (r[j, i] + r[i, j]) / si
        q[1 + m] = (r[m, i] + r[i, m]) / si
        cands.append(ca.vertcat(*q))
    d = [tr, r[0, 0], r[1, 1], r[2, 2]]
    best = cands[3]
    # argmax of d with ties to the lower index (as numpy.argmax)
    pick2 = ca.if_else(d[2] >= d[3], cands[2], cands[3])
    d23 = ca.fmax(d[2], d[3])
    pick1 = ca.if_else(d[1] >= d23, cands[1], pick2)
    d123 = ca.fmax(d[1], d23)
    best = ca.if_else(d[0] >= d123, cands[0], pick1)
    best = best / ca.norm_2(best)
    best = ca.if_else(best[0] < 0, -best, best)
    return best[1:] / (1 + best[0])


def _cross(a: Any, b: Any) -> Any:
    return ca.cross(a, b)


def reference_ca(t: Any, ref: Any, rrt: Any, n: Any, r_prev: Any, tol: Any) -> dict[str, Any]:
    """The desired position and attitude at time ``t`` (module docstring, step 1).

    ``ref = (a, b, c, phi0, theta0, P1, P2, T, printed)``; ``rrt`` = ``R_rT`` (3x3);
    ``tol = (tol_position, tol_momentum)`` as in
    :func:`~formsync_design.models.relative_reference.attitude_frame`.  Returns ``l_T``, its first
    two derivatives, ``R_dT``, ``omega_di``, ``omega_di_dot`` (in ``d``), ``R_dr`` and the
    frame status (0 regular, 1 straight-line, 2 coincident).
    """
    a, b, c, phi0, th0, p1, p2, period, printed = (ref[i] for i in range(9))
    tt = ca.SX.sym("tt")
    arg = ca.if_else(printed > 0.5, 1.0, tt)
    phi = (phi0 - np.pi / 2) * ca.exp(-arg / p1) + np.pi / 2
    th = 2 * np.pi / period * (tt + p2 * ca.exp(-tt / p2) - p2) + th0
    lr = ca.vertcat(a * ca.sin(phi) * ca.cos(th), b * ca.sin(phi) * ca.sin(th), c * ca.cos(phi))
    l1 = ca.jacobian(lr, tt)
    l2 = ca.jacobian(l1, tt)
    x = -lr / ca.norm_2(lr)
    h = _cross(lr, l1)
    y = -h / ca.norm_2(h)
    z = _cross(x, y)
    rdr = ca.vertcat(x.T, y.T, z.T)
    rdot = ca.reshape(ca.jacobian(ca.vec(rdr), tt), 3, 3)
    wm = -ca.mtimes(rdot, rdr.T)
    w_dr = ca.vertcat(0.5 * (wm[2, 1] - wm[1, 2]), 0.5 * (wm[0, 2] - wm[2, 0]),
                      0.5 * (wm[1, 0] - wm[0, 1]))
    wd_dr = ca.jacobian(w_dr, tt)
    sub = [tt]
    vals = [t]
    lr_t, l1_t, l2_t, rdr_t, w_t, wd_t, h_t = ca.substitute(
        [lr, l1, l2, rdr, w_dr, wd_dr, h], sub, vals)
    lnorm = ca.norm_2(lr_t)
    coincident = lnorm <= tol[0]
    straight = ca.norm_2(h_t) <= tol[1] * lnorm * ca.fmax(ca.norm_2(l1_t), 1.0)
    # fallback frame (straight line or no motion): x_d on the target, y_d the negative
    # fly-around normal made orthogonal (or -y_r if z_r is parallel to x_d)
    x0 = -lr_t / ca.fmax(lnorm, 1e-300)
    axis = ca.if_else(ca.fabs(x0[2]) < 0.9, ca.vertcat(0, 0, -1.0), ca.vertcat(0, -1.0, 0))
    y0 = axis - ca.dot(axis, x0) * x0
    y0 = y0 / ca.norm_2(y0)
    r_fb = ca.vertcat(x0.T, y0.T, _cross(x0, y0).T)
    zero = ca.SX.zeros(3)
    r_dr = ca.if_else(coincident, r_prev, ca.if_else(straight, r_fb, rdr_t))
    w_dr_v = ca.if_else(coincident + straight > 0, zero, w_t)
    wd_dr_v = ca.if_else(coincident + straight > 0, zero, wd_t)
    status = ca.if_else(coincident, 2.0, ca.if_else(straight, 1.0, 0.0))
    r_dt = ca.mtimes(r_dr, rrt)
    w_ti = ca.mtimes(r_dt, ca.vertcat(0, 0, n))
    return {
        "l_T": ca.mtimes(rrt.T, lr_t), "l_T_dot": ca.mtimes(rrt.T, l1_t),
        "l_T_ddot": ca.mtimes(rrt.T, l2_t), "R_dr": r_dr, "R_dT": r_dt,
        "omega_di": w_dr_v + w_ti, "omega_di_dot": wd_dr_v - _cross(w_dr_v, w_ti),
        "status": status,
    }


def _c_ti(t: Any, orbit: Any) -> Any:
    u = orbit[3] + orbit[2] * t
    cu, su = ca.cos(u), ca.sin(u)
    return ca.vertcat(ca.horzcat(cu, su, 0), ca.horzcat(-su, cu, 0), ca.horzcat(0, 0, 1))


def _truth_rhs(x: Any, wrench: Any, t: Any, p: Any, lay: dict[str, slice]) -> Any:
    mu, r0, n = p[lay["orbit"]][0], p[lay["orbit"]][1], p[lay["orbit"]][2]
    rho, v, s, w = x[0:3], x[3:6], x[6:9], x[9:12]
    rx = r0 + rho[0]
    rc3 = (rx * rx + rho[1] * rho[1] + rho[2] * rho[2]) ** 1.5
    c_ib = mrp_matrix_ca(s)
    f_t = ca.mtimes(_c_ti(t, p[lay["orbit"]]), ca.mtimes(c_ib, wrench[0:3])) / p[lay["mass"]]
    acc = ca.vertcat(2 * n * v[1] + n * n * rx - mu * rx / rc3,
                     -2 * n * v[0] + n * n * rho[1] - mu * rho[1] / rc3,
                     -mu * rho[2] / rc3) + f_t
    jm = ca.reshape(p[lay["J"]], 3, 3)
    jinv = ca.reshape(p[lay["Jinv"]], 3, 3)
    wdot = ca.mtimes(jinv, -_cross(w, ca.mtimes(jm, w)) + wrench[3:6])
    return ca.vertcat(v, acc, ca.vertcat(*mrp_rhs_terms(s, w)), wdot)


def build_functions(laws: dict[str, Any], ngain: int, substeps: int, dt: float) -> dict[str, Any]:
    """The CasADi functions of one sample (module docstring).

    ``laws``: ``torque`` and ``acceleration`` (SymPy 3x1), ``bind_torque(view quantities)``
    and ``bind_orbit(...)`` callables mapping CasADi values to the SymPy symbols (built by
    :mod:`formsync_design.sim.tracking`).  Returns ``ctrl(x, c, t, p) -> (wrench[6],
    thrust[16], out...)``, ``prop(x, c, t, p, f) -> (x+, c+, out)``, ``step(x, c, t, p) ->
    (x+, c+, out)`` and ``ref(t, x, c, p) -> (l_T, l_T', R_dT, omega_di, omega_di',
    status, sigma_sd, omega_sd)`` for tests.
    """
    lay = param_layout(ngain)
    nt = N_THRUSTERS_MAX
    x = ca.SX.sym("x", 12)
    c = ca.SX.sym("c", nt + 9)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", lay["_size"].stop)
    orbit = p[lay["orbit"]]
    n = orbit[2]
    rrt = ca.reshape(p[lay["RrT"]], 3, 3)
    r_prev = ca.reshape(c[nt:nt + 9], 3, 3)
    ref = reference_ca(t, p[lay["ref"]], rrt, n, r_prev, p[lay["tol"]])
    s, w = x[6:9], x[9:12]
    c_bi = mrp_matrix_ca(s).T
    c_ti = _c_ti(t, orbit)
    c_di = ca.mtimes(ref["R_dT"], c_ti)
    c_bd = ca.mtimes(c_bi, c_di.T)
    sig_sd = dcm_to_mrp_ca(c_bd.T)
    w_d = ca.mtimes(c_bd, ref["omega_di"])
    a_d = ca.mtimes(c_bd, ref["omega_di_dot"])
    w_sd = w - w_d
    torque = sympy_to_casadi(laws["torque"], laws["bind_torque"](
        sig_sd, w_sd, w, w_d, a_d, ca.reshape(p[lay["Jhat"]], 3, 3), p[lay["att_gains"]]))
    xd = ca.vertcat(ref["l_T"], ref["l_T_dot"])
    dx = x[0:6] - xd
    cw = ca.reshape(p[lay["cw"]], 3, 6)
    ff = ref["l_T_ddot"] - ca.mtimes(cw, xd)
    acc = sympy_to_casadi(laws["acceleration"], laws["bind_orbit"](
        dx, ff, ca.reshape(p[lay["K"]], 3, 6)))
    f_b = p[lay["mass_hat"]] * ca.mtimes(ca.mtimes(c_bi, c_ti.T), acc)
    wrench = ca.vertcat(f_b, torque)
    thrust = p[lay["thrust"]]
    raw = ca.mtimes(ca.reshape(p[lay["Apinv"]], nt, 6), wrench)
    raw_min = ca.mmin(raw)
    z = p[lay["null"]]
    shift = ca.fmax(0, ca.mmax(-raw / z))
    f_shift = raw + shift * z
    f_alloc = ca.if_else(p[lay["shift"]] > 0.5, f_shift, ca.fmax(raw, 0))
    f_alloc = ca.fmin(f_alloc, thrust)
    ctrl_out = ca.vertcat(dx, sig_sd, w_sd, wrench, raw_min, ref["status"])
    ctrl = ca.Function("fa_ctrl", [x, c, t, p], [wrench, f_alloc, ctrl_out, ca.vec(ref["R_dr"])],
                       ["x", "c", "t", "p"], ["wrench", "thrust", "out", "R_dr"])
    # PWM and propagation for given thrusts f
    f = ca.SX.sym("f", nt)
    rdr_in = ca.SX.sym("rdr", 9)
    amat = ca.reshape(p[lay["A"]], 6, nt)
    demand = f * dt + p[lay["carry"]] * c[0:nt]
    tau_raw = ca.fmin(ca.fmax(demand / thrust, 0), dt)
    tmin = p[lay["min_pulse"]]
    small = tau_raw < tmin
    tau = ca.if_else(small, ca.if_else(tau_raw >= tmin / 2, tmin, 0), tau_raw)
    carry_next = p[lay["carry"]] * ca.if_else(small, demand - thrust * tau, 0)
    start = (dt - tau) / 2
    end = (dt + tau) / 2
    h = dt / substeps
    xs = x
    for j in range(substeps):
        lo, hi = j * h, (j + 1) * h
        ov = ca.fmax(0, ca.fmin(end, hi) - ca.fmax(start, lo))
        wr = ca.mtimes(amat, thrust * ov / h)
        tj = t + lo
        k1 = _truth_rhs(xs, wr, tj, p, lay)
        k2 = _truth_rhs(xs + h / 2 * k1, wr, tj + h / 2, p, lay)
        k3 = _truth_rhs(xs + h / 2 * k2, wr, tj + h / 2, p, lay)
        k4 = _truth_rhs(xs + h * k3, wr, tj + h, p, lay)
        xs = xs + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    sn = xs[6:9]
    n2 = ca.dot(sn, sn)
    switched = n2 > 1
    sn = ca.if_else(switched, -sn / n2, sn)
    x_next = ca.vertcat(xs[0:6], sn, xs[9:12])
    wrench_pwm = ca.mtimes(amat, thrust * tau) / dt
    c_next = ca.vertcat(carry_next, rdr_in)
    prop = ca.Function("fa_prop", [x, c, t, p, f, rdr_in], [x_next, c_next, tau, wrench_pwm,
                                                            switched],
                       ["x", "c", "t", "p", "f", "rdr"], ["x_next", "c_next", "tau", "wrench_pwm",
                                                         "switched"])
    wr_, fa_, co_, rdr_ = ctrl(x, c, t, p)
    xn_, cn_, tau_, wp_, sw_ = prop(x, c, t, p, fa_, rdr_)
    out = ca.vertcat(co_[0:12], tau_, wr_, wp_, co_[18], co_[19], sw_, fa_)
    step = ca.Function("fa_step", [x, c, t, p], [xn_, cn_, out], ["x", "c", "t", "p"],
                       ["x_next", "c_next", "out"])
    reff = ca.Function("fa_ref", [t, x, c, p], [ref["l_T"], ref["l_T_dot"], ref["R_dT"],
                                             ref["omega_di"], ref["omega_di_dot"], ref["status"],
                                             sig_sd, w_sd],
                       ["t", "x", "c", "p"], ["l_T", "l_T_dot", "R_dT", "omega_di", "omega_di_dot",
                                         "status", "sigma_sd", "omega_sd"])
    return {"ctrl": ctrl, "prop": prop, "step": step, "ref": reff, "layout": lay}
