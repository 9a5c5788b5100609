"""The measurements of a fly-around run (the relative-orbit plant's
:class:`~formsync_design.sim.result.SimResult`, read from its
:class:`~formsync_design.sim.orbit_record.OrbitRecord`), for the metrics of
:mod:`formsync_design.verify.metrics_tracking`.

Rules (every number computed from the run)
------------------------------------------
* the steady state is ``t >= steady_from``; per-axis maxima (the attitude error is the
  rotation-vector component ``4 atan|sigma| sigma_k/|sigma|``, the rate error
  ``omega_sd,k``);
* ``min_pulse_fraction``: the pulses fired at ``t >= 100 s`` that are exactly the minimum
  pulse, over all pulses fired then;
* ``final_plane_error_deg``: the plane fitted (SVD) to the relative positions of the last
  fly-around period against the reference plane's tilt ``alpha_rT``;
  ``final_radius_error_m``: ``max ||rho| - a|`` over that period;
* ``transition_overshoot_deg``: the elevation of ``rho`` above the fly-around plane; the
  largest rise of its magnitude above its running minimum;
* ``pointing_error_deg``: the angle between the body ``x`` axis and the line of sight to
  the target (``-rho``) at ``t >= 100 s``;
* a run whose state went non-finite (status ``diverged``) has no steady state: every
  quantity is nan (the metrics have no value and the claims that read them are undecided).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from formsync_design.sim.orbit_record import orbit_of
from formsync_design.sim.result import SimResult
from formsync_design.sim.tracking import rotation_vectors

__all__ = ["METRICS", "MIN_PULSE_AFTER", "diverged_time", "run_metrics", "pointing_errors",
           "plane_normal"]

#: Time after which the paper says the pulses are mostly minimum pulses (s).
MIN_PULSE_AFTER = 100.0


def _mrp_matrices(sigma: np.ndarray) -> np.ndarray:
    """``R(sigma)`` (body to inertial) for ``(K, 3)`` MRPs, vectorized."""
    n2 = np.einsum("ki,ki->k", sigma, sigma)
    sx = np.zeros((sigma.shape[0], 3, 3))
    sx[:, 0, 1], sx[:, 0, 2], sx[:, 1, 2] = -sigma[:, 2], sigma[:, 1], -sigma[:, 0]
    sx[:, 1, 0], sx[:, 2, 0], sx[:, 2, 1] = sigma[:, 2], -sigma[:, 1], sigma[:, 0]
    sx2 = sx @ sx
    den = ((1 + n2) ** 2)[:, None, None]
    return np.eye(3)[None] + (8 * sx2 + 4 * (1 - n2)[:, None, None] * sx) / den


def pointing_errors(run: SimResult) -> np.ndarray:
    """Angle (rad) between the body ``x`` axis and the line of sight to the target, per
    sample ``t_k``."""
    rec = orbit_of(run)
    sc = rec.scenario
    x = rec.states[:-1]
    u = sc.target.argp + sc.target.nu + sc.mean_motion * run.t
    c, s = np.cos(u), np.sin(u)
    los_t = -x[:, :3] / np.linalg.norm(x[:, :3], axis=1)[:, None]
    los_i = np.stack([c * los_t[:, 0] - s * los_t[:, 1], s * los_t[:, 0] + c * los_t[:, 1],
                      los_t[:, 2]], axis=1)  # C_TI^T los_T
    r_ib = _mrp_matrices(x[:, 6:9])
    los_b = np.einsum("kji,kj->ki", r_ib, los_i)  # C_bI los_I = R^T los_I
    return np.arccos(np.clip(los_b[:, 0], -1.0, 1.0))


def plane_normal(params: Any) -> np.ndarray:
    """The normal ``z_r`` of the fly-around plane of ``params`` in the target frame."""
    from formsync_design.models.relative_reference import rotation_rT

    return rotation_rT(params).T @ np.array([0.0, 0.0, 1.0])  # z_r in T


def _max(a: np.ndarray) -> float:
    """``max`` of an array, nan when it is empty (a window the run does not reach)."""
    return float(np.max(a)) if np.size(a) else math.nan


#: The names :func:`run_metrics` returns, in order.
METRICS = ("rate_error_deg_s", "attitude_error_deg", "attitude_error_axis", "velocity_error_m_s",
           "position_error_m", "delta_v_m_s", "fuel_kg", "min_pulse_fraction",
           "final_plane_error_deg", "final_radius_error_m", "transition_overshoot_deg",
           "pointing_error_deg", "delta_v_net_m_s", "pulses_after_100s", "final_elevation_deg",
           "initial_elevation_deg", "shadow_switches", "raw_min_thrust_n",
           "negative_samples_fraction", "allocation_shortfall_max",
           "allocation_shortfall_after_100s", "saturated_samples", "fallback_frames")


def diverged_time(run: SimResult) -> float | None:
    """The time a run's state went non-finite (None: the run completed)."""
    return run.diverged_time if str(getattr(run, "status", "")) == "diverged" else None


def run_metrics(run: SimResult, steady_from: float) -> dict[str, float]:
    """Every measurement of :data:`METRICS` for a run (all nan for a diverged run)."""
    if diverged_time(run) is not None:
        return dict.fromkeys(METRICS, math.nan)
    rec = orbit_of(run)
    o = rec.outputs
    sc = rec.scenario
    opt = rec.options
    ss = rec.window(steady_from)
    rv = np.degrees(np.abs(rotation_vectors(o["sigma_sd"][ss])))
    rate = np.degrees(np.abs(o["omega_sd"][ss]))
    dx = np.abs(o["dX"][ss])
    m = sc.layout.count
    tau = o["on_time"][:, :m]
    after = run.t >= MIN_PULSE_AFTER
    fired = tau[after] > 0
    n_fired = int(fired.sum())
    is_min = np.abs(tau[after] - opt.min_pulse) <= 1e-9
    x = rec.states[:-1]
    rho = x[:, :3]
    r = np.linalg.norm(rho, axis=1)
    last = run.t >= run.t[-1] - sc.reference.period
    pts = rho[last]
    normal = np.linalg.svd(pts - pts.mean(axis=0), full_matrices=False)[2][-1]
    tilt = math.degrees(math.acos(min(1.0, abs(float(normal[2])))))
    elev = np.degrees(np.abs(np.arcsin(np.clip(rho @ plane_normal(sc.reference) / r, -1, 1))))
    overshoot = float(np.max(elev - np.minimum.accumulate(elev)))
    point = np.degrees(pointing_errors(run))
    amat = sc.layout.matrix
    short = o["wrench_cmd"] - (amat @ o["thrust_cmd"][:, :m].T).T
    saturated = int(np.sum(np.any(tau >= opt.sample_period - 1e-12, axis=1)))
    short_norm = np.abs(short).max(axis=1)
    return {
        "rate_error_deg_s": _max(rate),
        "attitude_error_deg": _max(rv),
        "attitude_error_axis": float(np.argmax(rv.max(axis=0))) if rv.size else math.nan,
        "velocity_error_m_s": _max(dx[:, 3:]),
        "position_error_m": _max(dx[:, :3]),
        "delta_v_m_s": rec.delta_v,
        "fuel_kg": rec.fuel,
        "min_pulse_fraction": float(is_min[fired].sum() / n_fired) if n_fired else math.nan,
        "final_plane_error_deg": abs(tilt - math.degrees(sc.reference.alpha)),
        "final_radius_error_m": float(np.max(np.abs(r[last] - sc.reference.a))),
        "transition_overshoot_deg": overshoot,
        "pointing_error_deg": _max(point[after]),
        "delta_v_net_m_s": rec.delta_v_net,
        "pulses_after_100s": float(n_fired),
        "final_elevation_deg": float(elev[-1]),
        "initial_elevation_deg": float(elev[0]),
        "shadow_switches": float(np.sum(o["switched"])),
        "raw_min_thrust_n": float(np.min(o["raw_min"])),
        "negative_samples_fraction": float(np.mean(o["raw_min"] < 0)),
        "allocation_shortfall_max": float(short_norm.max()),
        "allocation_shortfall_after_100s": _max(short_norm[after]),
        "saturated_samples": float(saturated),
        "fallback_frames": float(np.sum(o["frame_status"] != 0)),
    }
