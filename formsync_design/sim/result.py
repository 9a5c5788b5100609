"""The result of one simulation: a frozen :class:`SimResult`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.gains import json_number
from formsync_design.notebook import NotebookViews
from formsync_design.sim.formation import SimOptions, SimStatus, unpack_state

__all__ = ["SimResult"]


@dataclass(frozen=True)
class SimResult(NotebookViews):
    """A finished simulation (frozen).

    Attributes
    ----------
    status : SimStatus
        ``converged`` / ``not-converged`` / ``singular`` (see :class:`SimStatus`).
    t : (T,) grid (s); x : (T, 7N) states (module docstring); u : (T, 3N) torques (N m),
        ``u[k]`` acts on ``[t_k, t_{k+1})`` (exactly under ZOH; the value at ``t_k`` otherwise)
    omega_m, q_m : (T,) the paper's metrics
    convergence_time : float or None
        First grid time after which both metrics stay within tolerance; None when
        not reached within the horizon (``not-converged``) or when the run stopped
        early (``singular``).
    final_omega_m, final_q_m : float
    peak_torque : (N, 3) max ``|u|`` per spacecraft and axis (N m)
    min_q0 : (N,) over all sub-steps; singular_spacecraft (1-based) / singular_time when hit
        (both None otherwise; ``stop_time`` is the end of the trajectory either way)
    saturation_end_time : last grid time with some torque component at ``torque_limit``
        (None without a limit or if never reached)
    final_rates : (N, 3) absolute body rates at the end (rad/s);
    common_rate : (3,) their mean (a common drift if nonzero)
    stats : dict - integrator, steps, rhs evaluations, wall/compile seconds, max norm error
    options : SimOptions; n : int; names : list of state names
    spec_key : str
        Content key of the specification whose controller was simulated.
    diverged_time : float or None
        When the state became non-finite (status ``diverged``), else None.
    """

    status: SimStatus
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
    spec_key: str = ""
    diverged_time: float | None = None


    @property
    def converged(self) -> bool:
        """True for ``status == converged``."""
        return self.status == SimStatus.CONVERGED

    @property
    def stopped_early(self) -> bool:
        """True when the run stopped before the horizon (``singular`` or ``diverged``)."""
        return self.status in (SimStatus.SINGULAR, SimStatus.DIVERGED)

    @property
    def stop_time(self) -> float:
        """Last time of the trajectory: the horizon, or the singular stop's grid time."""
        return float(self.t[-1])

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
        if self.status == "diverged":
            return (f"diverged at t = {self.diverged_time:.4f} s (non-finite state, not near the "
                    f"q0 singularity; the trajectory ends at t = {self.t[-1]:g} s): reduce the step "
                    "or tighten the tolerances")
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
            "status": str(self.status),
            "spec_key": self.spec_key,
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
            "diverged_time": self.diverged_time,
            "saturation_end_time": self.saturation_end_time,
            "final_rates": self.final_rates.tolist(),
            "common_rate": self.common_rate.tolist(),
            "options": {
                "switch": o.switch,
                "phi": o.phi,
                "torque_limit": o.torque_limit,
                "sample_period": o.sample_period,
                "integrator": o.method,
                "step": o.interval / o.substeps if o.method == "rk4" else None,
                "output_step": o.interval,
                "rtol": o.rtol,
                "atol": o.atol,
                "q_tol": o.q_tol,
                "omega_tol": o.omega_tol,
                "q0_floor": o.q0_floor,
            },
            "stats": self.stats,
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no trajectories), numbers by :func:`~formsync_design.gains.json_number`.

        ``convergence_time`` is None when not reached (or stopped early);
        ``singular_spacecraft``/``singular_time`` are None unless ``status`` is
        ``singular``; ``torque_limit``/``sample_period`` None mean no limit /
        continuous control.
        """
        return _jsonable(self.summary())

    def to_npz(self, path: str | Path) -> Path:
        """Write ``t, x, u, omega_m, q_m, names`` to a compressed NPZ file."""
        from formsync_design.outdir import save_npz

        p = Path(path)
        save_npz(
            p, t=self.t, x=self.x, u=self.u, omega_m=self.omega_m, q_m=self.q_m, names=np.array(self.names)
        )
        return p

    def to_csv(self, path: str | Path) -> Path:
        """Write one row per grid time: ``t, <state names>, u1_1.., Omega_m, Q_m``."""
        p = Path(path)
        unames = [f"u{k}_{i}" for i in range(1, self.n + 1) for k in (1, 2, 3)]
        header = ",".join(["t", *self.names, *unames, "Omega_m", "Q_m"])
        data = np.column_stack([self.t, self.x, self.u, self.omega_m, self.q_m])
        from formsync_design.outdir import atomic_path

        with atomic_path(p) as tmp:
            np.savetxt(tmp, data, delimiter=",", header=header, comments="", fmt="%.17g")
        return p


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    return json_number(x)
