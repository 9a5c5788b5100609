"""Figures of a simulation, mirroring the paper's Figs. 3-6.

Fig. 3: relative angular-velocity metric ``Omega_m`` (log scale);
Fig. 4: relative attitude metric ``Q_m`` (log scale);
Figs. 5-6: control torques of spacecraft 1-4 and 5-8 (one panel per spacecraft).

Every function returns :class:`matplotlib.figure.Figure` objects built
without :mod:`matplotlib.pyplot`: nothing here selects or changes the
backend, opens a window or registers global figure state, so a notebook
renders the returned figures inline and a script may save them with any
backend; :func:`save_figure` writes byte-reproducible files.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from formsync_design.errors import InputError
from formsync_design.sim.result import SimResult

__all__ = ["metric_figure", "torque_figures", "all_figures", "save_figure"]


def _positive(y: np.ndarray) -> np.ndarray:
    """Zeros (exact synchronisation) drawn at the smallest positive float, not dropped."""
    y = np.asarray(y, dtype=float)
    return np.where(y > 0, y, np.finfo(float).tiny)


def metric_figure(result: SimResult, which: str = "omega") -> Figure:
    """``Omega_m`` (``which="omega"``) or ``Q_m`` (``"q"``) against time, log scale,
    with the convergence tolerance and time marked.

    >>> from formsync_design.verify.case import load_case
    >>> from formsync_design.sim.simulator import simulate, SimOptions
    >>> r = simulate(load_case().formation(), SimOptions(tf=5.0, compile=False))
    >>> fig = metric_figure(r, "q"); fig.axes[0].get_yscale()
    'log'
    """
    if which not in ("omega", "q"):
        raise InputError(f"expected which = 'omega' or 'q', received {which!r}")
    if result.omega_m is None or result.q_m is None:
        raise InputError(f"expected a run of the Lagrangian simulator (its Omega_m and Q_m), "
                         f"received a run of the agent design {result.design} (its figures: "
                         "formsync_design.sim.agent_figures)")
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.subplots()
    o = result.options
    if which == "omega":
        y, tol, label = result.omega_m, o.omega_tol, r"$\Omega_m$ (rad/s)"
        title = "Relative angular-velocity metric (paper Fig. 3)"
    else:
        y, tol, label = result.q_m, o.q_tol, r"$Q_m$"
        title = "Relative attitude metric (paper Fig. 4)"
    ax.semilogy(result.t, _positive(y), lw=1.2, color="C0")
    ax.axhline(tol, color="C3", ls="--", lw=0.8, label=f"tolerance {tol:g}")
    if result.convergence_time is not None:
        ax.axvline(result.convergence_time, color="C2", ls=":", lw=0.8,
                   label=f"converged at {result.convergence_time:.1f} s")
    if result.singular_time is not None:
        ax.axvline(result.singular_time, color="k", lw=0.8,
                   label=f"q0 singular (S/C{result.singular_spacecraft})")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(label)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def torque_figures(result: SimResult, per_figure: int = 4) -> list[Figure]:
    """Torques ``u_i`` (3 axes) per spacecraft, ``per_figure`` panels per figure
    (paper Figs. 5-6), with the torque limit drawn when one is set."""
    if per_figure < 1:
        raise InputError(f"expected per_figure >= 1, received {per_figure}")
    figs = []
    U = result.torques
    lim = result.options.torque_limit
    for start in range(0, result.n, per_figure):
        idx = list(range(start, min(start + per_figure, result.n)))
        fig = Figure(figsize=(6.4, 1.9 * len(idx) + 0.6))
        axes = fig.subplots(len(idx), 1, sharex=True, squeeze=False)
        for ax, i in zip(axes[:, 0], idx):
            for k in range(3):
                ax.plot(result.t, U[:, i, k], lw=0.9, label=f"$u_{{{k + 1}}}$")
            if lim is not None:
                for s in (-1, 1):
                    ax.axhline(s * lim, color="k", ls="--", lw=0.6)
            ax.set_ylabel(f"S/C{i + 1} (N m)", fontsize=8)
            ax.grid(True, alpha=0.3)
        axes[0, 0].legend(fontsize=7, ncol=3, loc="upper right")
        axes[-1, 0].set_xlabel("t (s)")
        fig.suptitle(f"Control torques of spacecraft {idx[0] + 1}-{idx[-1] + 1} (paper Figs. 5-6)", fontsize=10)
        fig.tight_layout()
        figs.append(fig)
    return figs


def all_figures(result: SimResult) -> dict[str, Figure]:
    """``{"omega_m": ..., "q_m": ..., "torques_1-4": ..., ...}``."""
    out = {"omega_m": metric_figure(result, "omega"), "q_m": metric_figure(result, "q")}
    per = 4
    for k, fig in enumerate(torque_figures(result, per)):
        a = k * per + 1
        b = min((k + 1) * per, result.n)
        out[f"torques_{a}-{b}"] = fig
    return out


def save_figure(fig: Figure, path: str | Path) -> Path:
    """Save reproducibly: PNG without the Software stamp, SVG without date and
    with a fixed hash salt."""
    from formsync_design.outdir import save_figure as save_atomic

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".png":
        save_atomic(fig, p, dpi=120, metadata={"Software": None})
    elif suffix == ".svg":
        with matplotlib.rc_context({"svg.hashsalt": "formsync-design"}):
            save_atomic(fig, p, metadata={"Date": None, "Creator": None})
    else:
        raise InputError(f"expected a .png or .svg figure path, received {str(p)!r}")
    return p
