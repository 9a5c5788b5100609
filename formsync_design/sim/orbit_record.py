"""What a fly-around run records beyond a formation's attitude: the relative orbit, the
thrusters and the allocation (:class:`OrbitRecord`); the fly-around's
:class:`~formsync_design.sim.result.SimResult` is built from it by
:func:`~formsync_design.sim.tracking.flyaround_result`.

A fly-around (:func:`~formsync_design.sim.tracking.simulate_flyaround`) is a formation of
one spacecraft: its :class:`~formsync_design.sim.result.SimResult` holds the chaser's
attitude, body rate and applied torque at the control instants ``t_k``, the attitude
tracking error, and in ``orbit`` this record: the truth states with the relative orbit, the
per-sample outputs of the loop (errors, wrenches, thrusts, PWM on-times), the LQR design, the
scenario, and the fuel and velocity increments derived from the pulses.

The status of a completed run follows :class:`~formsync_design.sim.tracking_scenario.
FlyaroundOptions`' ``angle_tol`` and ``position_tol``: ``converged`` when from
``convergence_time`` to the last sample the attitude tracking error angle
``4 atan|sigma_sd|`` is at most ``angle_tol`` (deg) and the relative-position error
``|rho - l_T|`` at most ``position_tol`` (m), else ``not-converged``; a non-finite state is
``diverged`` (with ``diverged_time``).

>>> import formsync_design as fs
>>> case = fs.load_flyaround_case()
>>> run = fs.simulate(case.scenario, fs.FlyaroundOptions(tf=2.0))
>>> isinstance(run.orbit, fs.OrbitRecord), run.n, run.orbit.states.shape
(True, 1, (11, 12))
>>> sorted(run.to_dict()["orbit"])
['allocation', 'delta_v_m_s', 'delta_v_net_m_s', 'fuel_kg', 'lp_fallbacks', 'samples']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.models.orbit import LQRDesign
from formsync_design.sim.tracking_scenario import FlyaroundOptions, FlyaroundScenario

__all__ = ["GRAPH", "OrbitRecord", "orbit_of"]

#: The ``graph`` of a fly-around run.
GRAPH = "none (one spacecraft tracking a target)"


@dataclass(frozen=True, kw_only=True)
class OrbitRecord:
    """The relative orbit and the thrusters of a fly-around run (module docstring).

    Attributes
    ----------
    t : numpy.ndarray
        Sample times ``t_k`` (the control instants), ``(K,)``: the run's ``SimResult.t``.
    states : numpy.ndarray
        ``(K + 1, 12)`` truth states at ``t_k`` and at the end of the last sample:
        ``(rho, rho', sigma, omega)`` (relative position and velocity in the target's orbit
        frame, m and m/s; MRP of body to inertial; body rate, rad/s).
    outputs : dict of numpy.ndarray
        Per-sample outputs (:data:`~formsync_design.sim.tracking_model.OUTPUTS`), ``K`` rows
        each: ``dX``, ``sigma_sd``, ``omega_sd`` (at ``t_k``), ``on_time``, ``wrench_cmd``,
        ``wrench_pwm``, ``raw_min``, ``frame_status``, ``switched``, ``thrust_cmd``.
    lqr : LQRDesign
        The orbit loop's LQR design on the CW model.
    scenario : FlyaroundScenario
    options : FlyaroundOptions
        The run's options (the same object as ``SimResult.options``).
    lp_fallbacks : int
        Samples of an ``lp`` run solved by the bounded LP (upper bounds binding).
    """

    t: np.ndarray
    states: np.ndarray
    outputs: dict[str, np.ndarray]
    lqr: LQRDesign
    scenario: FlyaroundScenario
    options: FlyaroundOptions
    lp_fallbacks: int = 0

    @property
    def impulses(self) -> np.ndarray:
        """Per-sample, per-thruster impulse (N s), ``(K, m)``: thrust times on-time."""
        m = self.scenario.layout.count
        return self.scenario.layout.thrust * self.outputs["on_time"][:, :m]

    @property
    def total_impulse(self) -> float:
        """Sum of :attr:`impulses` (N s)."""
        return float(self.impulses.sum())

    @property
    def fuel(self) -> float:
        """Propellant (kg): total impulse over the exhaust velocity."""
        return self.total_impulse / self.options.exhaust_velocity

    @property
    def delta_v(self) -> float:
        """Thruster velocity increment (m/s): total impulse over the mass."""
        return self.total_impulse / self.scenario.mass

    @property
    def delta_v_net(self) -> float:
        """Net velocity increment (m/s): ``sum_k |F_net,k| dt / m`` (opposed pulses cancel)."""
        f = self.outputs["wrench_pwm"][:, :3]
        return float(np.linalg.norm(f, axis=1).sum() * self.options.sample_period
                     / self.scenario.mass)

    @property
    def position_error(self) -> np.ndarray:
        """``|rho - l_T|`` (m) at ``t_k``, ``(K,)``."""
        return np.linalg.norm(self.outputs["dX"][:, :3], axis=1)

    def window(self, t0: float, t1: float | None = None) -> np.ndarray:
        """Boolean mask of the samples with ``t0 <= t_k <= t1`` (``t1`` None: the last)."""
        hi = self.t[-1] if t1 is None else t1
        return (self.t >= t0) & (self.t <= hi)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: ``samples``, ``fuel_kg``, ``delta_v_m_s``, ``delta_v_net_m_s``,
        ``allocation``, ``lp_fallbacks``."""
        return {"samples": int(self.t.size), "fuel_kg": json_number(self.fuel),
                "delta_v_m_s": json_number(self.delta_v),
                "delta_v_net_m_s": json_number(self.delta_v_net),
                "allocation": self.options.allocation, "lp_fallbacks": int(self.lp_fallbacks)}


def orbit_of(run: Any) -> OrbitRecord:
    """The :class:`OrbitRecord` of a fly-around run (a one-line :class:`InputError` for a run
    without one)."""
    rec = getattr(run, "orbit", None)
    if not isinstance(rec, OrbitRecord):
        raise InputError(f"expected a fly-around run (a SimResult with an orbit record), "
                         f"received {type(run).__name__} without one")
    return rec
