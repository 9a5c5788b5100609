"""Figures of a fly-around run (a :class:`~formsync_design.sim.result.SimResult` with an
``orbit`` record), like the paper's Figs. 5-9 (Zhang et al. 2014).

Fig. 5: thruster on-times of A1-A16 over the first period; Fig. 6: attitude-rate and
attitude tracking errors; Fig. 7: relative-velocity and position tracking errors; Fig. 8:
the relative position in the relative orbit frame; Fig. 9 (a visualization in the paper):
the 3-D relative trajectory with the 500 m sphere's 70 deg circle.  Further:
:func:`transition_figure` (elevation above the fly-around plane) and :func:`fuel_figure`
(cumulative fuel per allocation).  Functions return :class:`matplotlib.figure.Figure`
objects without pyplot (no backend is selected); save them with
:func:`formsync_design.sim.figures.save_figure`.

>>> from formsync_design.sim.tracking import simulate_flyaround
>>> from formsync_design.sim.tracking_scenario import FlyaroundOptions
>>> from formsync_design.verify.tracking_case import load_flyaround_case
>>> run = simulate_flyaround(load_flyaround_case().scenario, FlyaroundOptions(tf=4.0))
>>> sorted(flyaround_figures(run))[:2]
['fig5-thrusters', 'fig6-attitude']
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from formsync_design.errors import InputError
from formsync_design.sim.orbit_record import orbit_of
from formsync_design.sim.result import SimResult

__all__ = ["thruster_figure", "attitude_error_figure", "orbit_error_figure",
           "position_figure", "trajectory_figure", "transition_figure", "fuel_figure",
           "flyaround_figures"]

_AX = ("x", "y", "z")


def _span(run: SimResult, t_end: float | None) -> np.ndarray:
    if t_end is not None and t_end <= 0:
        raise InputError(f"expected t_end > 0 s, received {t_end:g}")
    return run.t <= (run.t[-1] if t_end is None else t_end)


def thruster_figure(run: SimResult, t_end: float | None = 7200.0) -> Figure:
    """On-time of every thruster per sample (ms), one panel each (paper Fig. 5)."""
    rec = orbit_of(run)
    m = rec.scenario.layout.count
    sel = _span(run, t_end)
    t = run.t[sel]
    tau = rec.outputs["on_time"][sel, :m] * 1e3
    cols = 4
    rows = (m + cols - 1) // cols
    fig = Figure(figsize=(9.0, 1.6 * rows + 0.6))
    axes = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    for i in range(rows * cols):
        ax = axes[i // cols, i % cols]
        if i >= m:
            ax.set_visible(False)
            continue
        on = tau[:, i] > 0
        ax.vlines(t[on], 0, tau[on, i], lw=0.4, color="C0")
        ax.set_title(rec.scenario.layout.names[i], fontsize=7, pad=2)
        ax.tick_params(labelsize=6)
        ax.grid(True, alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("on (ms)", fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("t (s)", fontsize=7)
    fig.suptitle(f"Thruster on-times per {rec.options.sample_period:g} s sample (paper Fig. 5)",
                 fontsize=10)
    fig.tight_layout()
    return fig


def _error_figure(run: SimResult, t_end: float | None, top: np.ndarray, bottom: np.ndarray,
                  labels: tuple[str, str], title: str) -> Figure:
    sel = _span(run, t_end)
    fig = Figure(figsize=(6.4, 5.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for k in range(3):
        ax1.plot(run.t[sel], top[sel, k], lw=0.6, label=_AX[k])
        ax2.plot(run.t[sel], bottom[sel, k], lw=0.6, label=_AX[k])
    ax1.set_ylabel(labels[0])
    ax2.set_ylabel(labels[1])
    ax2.set_xlabel("t (s)")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=3, loc="upper right")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def attitude_error_figure(run: SimResult, t_end: float | None = 7200.0) -> Figure:
    """Rate error ``omega_sd`` (deg/s) and attitude error (rotation vector, deg) (Fig. 6)."""
    from formsync_design.sim.tracking import rotation_vectors

    o = orbit_of(run).outputs
    return _error_figure(run, t_end, np.degrees(o["omega_sd"]),
                         np.degrees(rotation_vectors(o["sigma_sd"])),
                         ("rate error (deg/s)", "attitude error (deg)"),
                         "Attitude tracking errors (paper Fig. 6)")


def orbit_error_figure(run: SimResult, t_end: float | None = 7200.0) -> Figure:
    """Relative-velocity (m/s) and position (m) tracking errors (paper Fig. 7)."""
    dx = orbit_of(run).outputs["dX"]
    return _error_figure(run, t_end, dx[:, 3:], dx[:, :3],
                         ("velocity error (m/s)", "position error (m)"),
                         "Relative orbit tracking errors (paper Fig. 7)")


def position_figure(run: SimResult, every: int = 25) -> Figure:
    """The relative position components in the relative orbit frame (paper Fig. 8)."""
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.subplots()
    x = orbit_of(run).states[:-1:every, :3]
    for k in range(3):
        ax.plot(run.t[::every], x[:, k], lw=0.8, label=f"{_AX[k]}_T")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("relative position (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, ncol=3)
    ax.set_title("Relative position in the relative orbit frame (paper Fig. 8)", fontsize=10)
    fig.tight_layout()
    return fig


def trajectory_figure(run: SimResult, every: int = 25) -> Figure:
    """3-D relative trajectory with the target and the 70 deg circle (paper Figs. 8-9)."""
    from formsync_design.models.relative_reference import rotation_rT

    rec = orbit_of(run)
    fig = Figure(figsize=(6.0, 5.4))
    ax = fig.add_subplot(projection="3d")
    x = rec.states[::every, :3]
    ax.plot(x[:, 0], x[:, 1], x[:, 2], lw=0.7, color="C0", label="chaser")
    ref = rec.scenario.reference
    th = np.linspace(0, 2 * np.pi, 361)
    circ = np.stack([ref.a * np.cos(th), ref.b * np.sin(th), np.zeros_like(th)], axis=1)
    circ_t = circ @ rotation_rT(ref)
    ax.plot(circ_t[:, 0], circ_t[:, 1], circ_t[:, 2], "--", lw=0.8, color="C3",
            label=f"{np.degrees(ref.alpha):g} deg circle")
    ax.scatter([0.0], [0.0], [0.0], color="k", s=12, label="target")
    ax.scatter([x[0, 0]], [x[0, 1]], [x[0, 2]], color="C2", s=12, label="start")
    ax.set_xlabel("x_T (m)", fontsize=8)
    ax.set_ylabel("y_T (m)", fontsize=8)
    ax.set_zlabel("z_T (m)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("Relative trajectory (paper Figs. 8-9)", fontsize=10)
    return fig


def transition_figure(series: dict[str, tuple[np.ndarray, np.ndarray]]) -> Figure:
    """Elevation of the chaser above the fly-around plane (deg), per reading of ``phi_r``."""
    fig = Figure(figsize=(6.4, 3.4))
    ax = fig.subplots()
    for name, (t, e) in sorted(series.items()):
        ax.plot(t, e, lw=0.9, label=name)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("elevation above the plane (deg)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Transition into the fly-around plane", fontsize=10)
    fig.tight_layout()
    return fig


def fuel_figure(series: dict[str, tuple[np.ndarray, np.ndarray]]) -> Figure:
    """Cumulative fuel (kg) per allocation rule."""
    fig = Figure(figsize=(6.4, 3.4))
    ax = fig.subplots()
    for name, (t, f) in sorted(series.items()):
        ax.plot(t, f, lw=1.0, label=name)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("fuel (kg)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Cumulative fuel: pseudo-inverse against the minimum-fuel LP", fontsize=10)
    fig.tight_layout()
    return fig


def flyaround_figures(run: SimResult) -> dict[str, Figure]:
    """The run's figures by file stem (Figs. 5-9)."""
    return {"fig5-thrusters": thruster_figure(run), "fig6-attitude": attitude_error_figure(run),
            "fig7-orbit": orbit_error_figure(run), "fig8-position": position_figure(run),
            "fig9-trajectory": trajectory_figure(run)}
