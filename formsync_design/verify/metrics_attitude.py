"""Metrics of a run's attitude display and torque history (the registry of
:mod:`formsync_design.verify.metrics`; registered when an engine case is read).

=========================  ======  ==========  ==============================================
metric                     unit    evidence    value
=========================  ======  ==========  ==============================================
euler_error_time           s       simulation  first time from which the Euler-angle error
                                               ``Qa`` stays <= threshold_deg
euler_angle_jumps          count   simulation  jumps of an Euler angle by > jump_deg between
                                               two output samples
rotation_element_step      1       simulation  largest change of ``R_row,col`` between samples
late_torque_ratio          1       simulation  max ``|u_i|`` after ``after_s`` / its peak
common_rate                rad/s   simulation  ``|mean_i w_i|`` at tf (a common rotation)
monitor_min, monitor_max   1       simulation  a design monitor's extreme over the run
nonfinite_torques          count   simulation  torque entries that are not finite
orthonormality_error       1       simulation  max ``|R^T R - I|`` over the run
=========================  ======  ==========  ==============================================

The Euler angles are pitch, yaw, roll of :data:`~formsync_design.models.euler.PITCH_YAW_ROLL`
(``R = Rz(pitch) Ry(yaw) Rx(roll)``, yaw in ``[-90, 90]``): a display of the attitude whose
ranges make it jump while the attitude moves continuously.  ``Qa = sqrt(sum_{i >= 2} |r_i -
r_1|^2)`` (deg) compares every spacecraft's angles ``r_i`` with spacecraft 1's, each
difference wrapped to ``(-180, 180]`` (:func:`~formsync_design.models.euler.qa_error`).  A
run that diverged or stopped has no value.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formsync_design.models.euler import jumps, pitch_yaw_roll, qa_error, quats_to_matrices
from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric

__all__ = ["euler_error_time", "run_angles"]

_THRESHOLD = MetricArg("threshold_deg", "number", 1.0, quantity="angle", minimum=0.0,
                       doc="the bound on Qa (deg)")
_ANGLE_NAMES = ("pitch", "yaw", "roll")


def _ended(r: Any) -> str | None:
    if str(r.status) in ("diverged", "stopped"):
        return f"run {r.status}: {r.message}"
    return None


def run_angles(r: Any) -> np.ndarray:
    """``(T, N, 3)`` pitch, yaw, roll (deg) of a run's attitudes."""
    return pitch_yaw_roll(quats_to_matrices(r.quaternions))


def euler_error_time(r: Any, threshold: float) -> float | None:
    """The first output time from which ``Qa <= threshold`` holds to the end of the run
    (``None``: not at the end).

    >>> from types import SimpleNamespace
    >>> q = np.array([[[0, 0, 0, 1.0], [0, 0, np.sin(0.1), np.cos(0.1)]],
    ...               [[0, 0, 0, 1.0], [0, 0, 0, 1.0]]])
    >>> euler_error_time(SimpleNamespace(t=np.array([0.0, 1.0]), quaternions=q), 1.0)
    1.0
    """
    ok = qa_error(run_angles(r)) <= threshold
    bad = np.nonzero(~ok)[0]
    if not ok[-1]:
        return None
    return float(r.t[0] if bad.size == 0 else r.t[bad[-1] + 1])


@register_metric("euler_error_time", unit="s", evidence="simulation", args=(_THRESHOLD,),
                 doc="first output time from which the Euler-angle error Qa (pitch, yaw, roll "
                 "of every spacecraft against spacecraft 1's, differences wrapped to (-180, "
                 "180], deg) stays <= threshold_deg; not reached by tf: >= tf; diverged or "
                 "stopped: unknown")
def _euler_error_time(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    t = euler_error_time(r, float(ctx.args["threshold_deg"]))
    if t is None:
        return ctx.value(float(r.t[-1]), f"not reached by tf = {float(r.t[-1]):g} s",
                         bound="lower")
    return ctx.value(t, f"Qa <= {float(ctx.args['threshold_deg']):g} deg")


@register_metric("euler_angle_jumps", unit="count", evidence="simulation",
                 args=(MetricArg("jump_deg", "number", 90.0, quantity="angle", minimum=0.0,
                                 doc="a change between two output samples larger than this "
                                 "is a jump"),),
                 doc="the number of jumps of an Euler angle (pitch, yaw, roll of any "
                 "spacecraft) by more than jump_deg between two output samples; the first one "
                 "in the detail")
def _jumps(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    A = run_angles(r)
    ej = jumps(A.reshape(len(r.t), -1), float(ctx.args["jump_deg"]))
    if not ej:
        return ctx.value(0.0, "none")
    k, col = ej[0]
    return ctx.value(float(len(ej)), f"first at t = {float(r.t[k]):.2f} s (spacecraft "
                     f"{col // 3 + 1}, {_ANGLE_NAMES[col % 3]})")


@register_metric("rotation_element_step", unit="1", evidence="simulation",
                 args=(MetricArg("row", "int", 2, minimum=1, doc="1-based row of R"),
                       MetricArg("col", "int", 3, minimum=1, doc="1-based column of R")),
                 doc="the largest change of the rotation-matrix element R_row,col (body to "
                 "inertial) of any spacecraft between two output samples")
def _element_step(ctx: MetricContext) -> MetricValue:
    i, j = int(ctx.args["row"]), int(ctx.args["col"])
    if i > 3 or j > 3:
        return ctx.value(None, f"R has no element ({i}, {j})")
    R = quats_to_matrices(ctx.run().quaternions)
    return ctx.value(float(np.abs(np.diff(R[:, :, i - 1, j - 1], axis=0)).max()),
                     f"R_{i}{j}, every spacecraft")


@register_metric("late_torque_ratio", unit="1", evidence="simulation",
                 args=(MetricArg("spacecraft", "int", minimum=1, doc="1-based spacecraft"),
                       MetricArg("after_s", "number", quantity="horizon", minimum=0.0,
                                 doc="from this time on (s)"),
                       MetricArg("fraction", "number", 0.01, quantity="tolerance", minimum=0.0,
                                 doc="the detail says from when |u| stays below this x peak")),
                 doc="the largest torque norm |u_i(t)| of the spacecraft for t >= after_s over "
                 "its peak over the run; the detail says from when it stays below fraction x "
                 "the peak; diverged: unknown")
def _late_torque(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    if str(r.status) == "diverged":
        return ctx.value(None, f"run diverged: {r.message}")
    k = int(ctx.args["spacecraft"])
    if k > r.torques.shape[1]:
        return ctx.value(None, f"spacecraft {k} is not in the formation")
    u = np.linalg.norm(r.torques[:, k - 1, :], axis=1)
    late = u[r.t >= float(ctx.args["after_s"])]
    if not late.size or not u.max() > 0:
        return ctx.value(None, "no torque after after_s (or none at all)")
    frac = float(ctx.args["fraction"])
    big = np.nonzero(u > frac * u.max())[0]
    since = (f"{float(r.t[big[-1] + 1]):.2f} s" if big.size and big[-1] + 1 < len(r.t)
             else "not reached")
    return ctx.value(float(late.max() / u.max()), f"peak |u_{k}| {u.max():.4g} N m; below "
                     f"{frac:g} x peak from {since}")


@register_metric("common_rate", unit="rad/s", evidence="simulation",
                 doc="|mean over the spacecraft of the body rates| at tf: the rate of a common "
                 "rotation the formation keeps")
def _common_rate(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    return ctx.value(float(np.linalg.norm(r.rates[-1].mean(axis=0))), f"at t = {float(r.t[-1]):g} s")


def _monitor(ctx: MetricContext, stat: str) -> MetricValue:
    name = str(ctx.args["monitor"])
    mons = ctx.run().monitors
    if name not in mons:
        return ctx.value(None, f"design has no monitor {name!r} (monitors {sorted(mons)})")
    v = np.asarray(mons[name], dtype=float)
    return ctx.value(float(np.nanmin(v) if stat == "min" else np.nanmax(v)),
                     f"monitor {name}, every spacecraft and output time")


_MONITOR = MetricArg("monitor", "text", doc="a monitor the design's monitors(v) returns")


@register_metric("monitor_min", unit="1", evidence="simulation", args=(_MONITOR,),
                 doc="the smallest value of a design monitor (monitors(v)) over the run and the "
                 "spacecraft")
def _monitor_min(ctx: MetricContext) -> MetricValue:
    return _monitor(ctx, "min")


@register_metric("monitor_max", unit="1", evidence="simulation", args=(_MONITOR,),
                 doc="the largest value of a design monitor (monitors(v)) over the run and the "
                 "spacecraft")
def _monitor_max(ctx: MetricContext) -> MetricValue:
    return _monitor(ctx, "max")


@register_metric("nonfinite_torques", unit="count", evidence="simulation",
                 doc="the number of torque entries (output times x spacecraft x axes) that are "
                 "not finite numbers: 0 when the law stayed defined")
def _nonfinite(ctx: MetricContext) -> MetricValue:
    u = np.asarray(ctx.run().torques, dtype=float)
    return ctx.value(float(np.sum(~np.isfinite(u))), f"of {u.size} entries")


@register_metric("orthonormality_error", unit="1", evidence="simulation",
                 doc="the largest |R^T R - I| entry over the run and the spacecraft (R from the "
                 "integrated attitude)")
def _orthonormality(ctx: MetricContext) -> MetricValue:
    R = quats_to_matrices(ctx.run().quaternions)
    return ctx.value(float(np.abs(np.einsum("...ki,...kj->...ij", R, R) - np.eye(3)).max()))
