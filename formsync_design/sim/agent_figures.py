"""Figures of an agent-design run (:class:`~formsync_design.sim.result.SimResult`).

``attitude``: the attitude disagreement (largest pairwise principal angle) and, with a
leader, the largest error to the reference, in degrees on a log scale, with the tolerance
and the convergence time marked; ``torques``: ``|u_i|`` of every spacecraft; ``rates``:
the rate error.  Built without :mod:`matplotlib.pyplot` (no backend is selected); saved
byte-reproducibly with :func:`formsync_design.sim.figures.save_figure`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

__all__ = ["attitude_figure", "torque_norm_figure", "rate_error_figure", "agent_figures"]


def _positive(y: np.ndarray) -> np.ndarray:
    y = np.asarray(y, dtype=float)
    return np.where(y > 0, y, np.finfo(float).tiny)


def attitude_figure(r: Any, angle_tol: float | None = None) -> Figure:
    """Attitude disagreement (and error to the reference) against time, log scale.

    >>> import numpy as np
    >>> from formsync_design.graphs import load_graph
    >>> from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
    >>> from formsync_design.sim.formation import Gains
    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    >>> f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
    ...                    np.array([[0, 0, 0, 1.0]] * 2), np.full((2, 3), 0.1), Gains(k=1.0))
    >>> r = simulate_agents(d, f, AgentOptions(tf=2, output_step=0.5, step=0.05))
    >>> sorted(agent_figures(r))
    ['attitude', 'rates', 'torques']
    """
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.add_subplot()
    ax.semilogy(r.t, _positive(r.attitude_error), label="largest pairwise angle")
    if r.reference_error is not None:
        ax.semilogy(r.t, _positive(r.reference_error), label="largest angle to the reference")
    if angle_tol is not None:
        ax.axhline(angle_tol, color="0.5", ls="--", lw=0.8, label=f"{angle_tol:g} deg")
    if r.convergence_time is not None:
        ax.axvline(r.convergence_time, color="0.3", ls=":", lw=0.8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("angle (deg)")
    ax.set_title(f"{r.design} on {r.graph}: attitude disagreement")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def torque_norm_figure(r: Any) -> Figure:
    """``|u_i(t)|`` (N m) of every spacecraft."""
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.add_subplot()
    norms = np.linalg.norm(r.torques, axis=2)
    for i in range(norms.shape[1]):
        ax.plot(r.t, norms[:, i], lw=0.9, label=f"S/C{i + 1}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("|u_i| (N m)")
    ax.set_title(f"{r.design} on {r.graph}: control torques")
    ax.legend(fontsize=7, ncol=4)
    fig.tight_layout()
    return fig


def rate_error_figure(r: Any) -> Figure:
    """The rate error (rad/s, log scale)."""
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.add_subplot()
    ax.semilogy(r.t, _positive(r.rate_error))
    ax.set_xlabel("t (s)")
    ax.set_ylabel("rate error (rad/s)")
    ax.set_title(f"{r.design} on {r.graph}: rate error")
    fig.tight_layout()
    return fig


def agent_figures(r: Any, angle_tol: float | None = None) -> dict[str, Figure]:
    """All figures of a run, by file stem."""
    return {"attitude": attitude_figure(r, angle_tol), "torques": torque_norm_figure(r),
            "rates": rate_error_figure(r)}
