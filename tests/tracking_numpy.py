"""An independent numpy/scipy implementation of the fly-around closed loop.

The test oracle of :mod:`formsync_design.sim.tracking` and the baseline of
``benchmarks/bench_flyaround.py``.  It shares no code with the compiled simulation's
CasADi model: the reference and the desired frame come from
:mod:`formsync_design.models.relative_reference` (Taylor-mode derivatives, not CasADi's AD), the
attitude law is written out here in numpy (not translated from the design's SymPy), the
allocation and the PWM are :func:`~formsync_design.models.thrusters.pinv_allocation` and
:func:`~formsync_design.models.pwm.pwm`, the truth dynamics are
:func:`~formsync_design.models.orbit.relative_nonlinear_rhs` + the MRP kinematics + Euler's
equation as one numpy right-hand side, and every sample is integrated by
``scipy.integrate.solve_ivp`` over the exact segments between the pulse edges (constant
thrust on each).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from formsync_design.models.mrp import mrp_from_matrix, mrp_rhs_terms, mrp_to_matrix
from formsync_design.models.orbit import cw_matrices, relative_nonlinear_rhs
from formsync_design.models.pwm import pwm
from formsync_design.models.relative_reference import desired_attitude, desired_position_T
from formsync_design.models.thrusters import pinv_allocation, positive_null_vector
from formsync_design.sim.tracking import initial_state, lqr_for


def c_ti(t: float, sc) -> np.ndarray:
    u = sc.target.argp + sc.target.nu + sc.mean_motion * t
    c, s = math.cos(u), math.sin(u)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def make_rhs(sc):
    """The truth right-hand side ``f(t, y, wrench_b)`` (numpy, whole-vector operations)."""
    j = sc.inertia
    jinv = np.linalg.inv(j)
    r0 = sc.target.a

    def rhs(t, y, wrench):
        s, w = y[6:9], y[9:12]
        f_t = c_ti(t, sc) @ (mrp_to_matrix(s) @ wrench[:3]) / sc.mass
        orb = relative_nonlinear_rhs(t, y[:6], r0, f_t, sc.mu)
        sdot = np.array(mrp_rhs_terms(s, w))
        wdot = jinv @ (-np.cross(w, j @ w) + wrench[3:])
        return np.concatenate([orb, sdot, wdot])

    return rhs


def control(t, y, sc, spec, opt, lqr_k, z):
    """One sample's control: errors, the law, the wrench, the thrusts."""
    n = sc.mean_motion
    d = desired_attitude(t, sc.reference, n, opt.reading)
    c_bi = mrp_to_matrix(y[6:9]).T
    c_di = d.R_dT @ c_ti(t, sc)
    c_bd = c_bi @ c_di.T
    sig = mrp_from_matrix(c_bd.T)
    w = y[9:12]
    w_d = c_bd @ d.omega_di
    a_d = c_bd @ d.omega_di_dot
    w_sd = w - w_d
    jh = sc.inertia if sc.law_inertia is None else sc.law_inertia
    kp = sc.gains["k_p"][0]
    kd = np.diag(sc.gains["K_d"])
    torque = np.cross(w, jh @ w) + jh @ (a_d - np.cross(w_sd, w_d)) - kp * sig - kd @ w_sd
    L = desired_position_T(t, sc.reference, 2, opt.reading)
    xd = np.concatenate([L[0], L[1]])
    a_cw, _ = cw_matrices(n)
    ff = L[2] - a_cw[3:] @ xd
    dx = y[:6] - xd
    acc = -lqr_k @ dx + ff
    f_b = sc.mass * c_bi @ c_ti(t, sc).T @ acc
    wrench = np.concatenate([f_b, torque])
    alloc = pinv_allocation(sc.layout, wrench, "shift" if opt.allocation == "pinv-shift"
                            else "clip", null_vector=z)
    return wrench, alloc.thrusts, dx, sig, w_sd


def simulate_numpy(sc, opt, spec, samples: int, rtol: float = 1e-10, atol: float = 1e-12,
                   method: str = "DOP853"):
    """``samples`` control samples; returns the states at the sample instants (K+1, 12), the
    on-times (K, m) and the errors."""
    lqr, _, _ = lqr_for(spec, sc)
    z = positive_null_vector(sc.layout)
    y, _ = initial_state(sc, opt.reading)
    rhs = make_rhs(sc)
    dt = opt.sample_period
    a = sc.layout.matrix
    states, taus, errs = [y.copy()], [], []
    carry = np.zeros(sc.layout.count)
    for k in range(samples):
        t0 = k * dt
        wrench, f, dx, sig, w_sd = control(t0, y, sc, spec, opt, lqr.K, z)
        p = pwm(f, dt, sc.layout.thrust, opt.min_pulse, carry if opt.carry else None)
        if opt.carry:
            carry = np.where(f * dt + carry < sc.layout.thrust * opt.min_pulse, p.carry, 0.0)
        start, end = p.start_times, p.start_times + p.on_times
        edges = np.unique(np.concatenate([[0.0, dt], start[p.on_times > 0],
                                          end[p.on_times > 0]]))
        for lo, hi in zip(edges[:-1], edges[1:]):
            if hi - lo <= 1e-15:
                continue
            mid = 0.5 * (lo + hi)
            on = ((start <= mid) & (mid < end)).astype(float)
            wr = a @ (sc.layout.thrust * on)
            sol = solve_ivp(lambda t, yy, wr=wr: rhs(t, yy, wr), (t0 + lo, t0 + hi), y,
                            method=method, rtol=rtol, atol=atol)
            y = sol.y[:, -1]
        n2 = float(y[6:9] @ y[6:9])
        if n2 > 1:
            y = y.copy()
            y[6:9] = -y[6:9] / n2
        states.append(y.copy())
        taus.append(p.on_times)
        errs.append(np.concatenate([dx, sig, w_sd]))
    return np.array(states), np.array(taus), np.array(errs)
