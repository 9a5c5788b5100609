"""Pulse-width modulation of thruster forces and the fuel they burn.

* PWM: the on-time ``tau = f dt / thrust`` is rounded to 0 or the minimum
  pulse when shorter than it (to the nearer one), pulses are centred in the
  period, and the rounding error may be carried to the next period (so the
  cumulative impulse error of a thruster stays within half a minimum pulse).
* fuel: the propellant mass of a total impulse, and of a velocity change by the rocket
  equation, at the effective exhaust velocity (:mod:`~formsync_design.models.thrusters` has
  the layout, the allocation and the constants of the paper's thrusters).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.models.thrusters import (
    EXHAUST_VELOCITY,
    MIN_PULSE_S,
    SAMPLE_PERIOD_S,
    THRUST_N,
)

__all__ = ["PWMResult", "pwm", "fuel_mass", "rocket_fuel"]


@dataclass(frozen=True)
class PWMResult:
    """Pulse widths over one sample period.

    Attributes
    ----------
    on_times : numpy.ndarray
        Per-thruster on-time (s), 0 or in ``[min_pulse, dt]``.
    start_times : numpy.ndarray
        Pulse starts within the period (s): pulses are centred.
    impulses : numpy.ndarray
        ``thrust * on_times`` (N s).
    carry : numpy.ndarray
        Impulse not delivered (commanded - delivered, N s), to add next period.
    saturated : numpy.ndarray
        Boolean mask: commanded more than ``thrust * dt``.
    """

    on_times: np.ndarray
    start_times: np.ndarray
    impulses: np.ndarray
    carry: np.ndarray
    saturated: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        return {
            "on_times": [json_number(v) for v in self.on_times],
            "start_times": [json_number(v) for v in self.start_times],
            "carry": [json_number(v) for v in self.carry],
            "saturated": [bool(v) for v in self.saturated],
        }


def pwm(
    thrusts: Any,
    dt: float = SAMPLE_PERIOD_S,
    thrust: float = THRUST_N,
    min_pulse: float = MIN_PULSE_S,
    carry: Any = None,
) -> PWMResult:
    """Pulse widths delivering the impulse ``thrusts * dt`` (+ ``carry``) per thruster.

    ``tau = demand / thrust``; below ``min_pulse`` it is rounded to the nearer
    of 0 and ``min_pulse``; above ``dt`` it saturates.  Without saturation the
    delivered impulse differs from the demand by at most half a minimum pulse
    (``thrust * min_pulse / 2``) per thruster, and the difference is returned
    as ``carry``.

    Examples
    --------
    >>> r = pwm([25.0, 5.0, 2.0, 3.0, 0.0])  # 25 N for 0.2 s; 5 N -> 40 ms; 2 N -> 16 ms (< 30 ms)
    >>> [round(float(v), 6) for v in r.on_times]
    [0.2, 0.04, 0.03, 0.03, 0.0]
    >>> [round(float(v), 6) + 0.0 for v in r.carry]  # 2 N: 0.4 N s asked, 0.75 given
    [0.0, 0.0, -0.35, -0.15, 0.0]
    """
    f = np.asarray(thrusts, dtype=float)
    if f.ndim != 1 or not np.all(np.isfinite(f)):
        raise InputError(
            f"expected thrusts as a 1-D array of finite numbers, received shape {f.shape}"
        )
    for name, v in (("dt", dt), ("thrust", thrust), ("min_pulse", min_pulse)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"expected {name} > 0, received {v:g}")
    if min_pulse > dt:
        raise InputError(f"expected min_pulse <= dt, received {min_pulse:g} > {dt:g}")
    demand = f * dt + (np.zeros_like(f) if carry is None else np.asarray(carry, dtype=float))
    tau = np.clip(demand / thrust, 0.0, dt)
    short = tau < min_pulse
    tau = np.where(short, np.where(tau >= min_pulse / 2, min_pulse, 0.0), tau)
    saturated = demand > thrust * dt
    impulses = thrust * tau
    return PWMResult(tau, (dt - tau) / 2, impulses, demand - impulses, saturated)


def fuel_mass(total_impulse: float, exhaust_velocity: float = EXHAUST_VELOCITY) -> float:
    """Propellant mass (kg) for a total thruster impulse (N s): ``I / v_e``.

    >>> round(fuel_mass(25.0 * 0.03), 9)  # one minimum pulse
    0.000258621
    """
    if not (math.isfinite(exhaust_velocity) and exhaust_velocity > 0):
        raise InputError(f"expected exhaust_velocity > 0 m/s, received {exhaust_velocity:g}")
    return float(total_impulse) / exhaust_velocity


def rocket_fuel(delta_v: float, mass0: float, exhaust_velocity: float = EXHAUST_VELOCITY) -> float:
    """Propellant mass (kg) for a velocity change (Tsiolkovsky): ``m0 (1 - exp(-dv / v_e))``.

    The paper's 15.8065 m/s at 2000 kg needs 10.87 kg by this formula, 0.22 kg
    less than its 11.0926 kg.  The paper does not say how it computed either
    number; one possible explanation (not verified) is propellant spent on
    attitude (opposed pulses produce torque but no velocity change).

    >>> round(rocket_fuel(15.8065, 2000.0), 2)
    10.87
    """
    if not (math.isfinite(mass0) and mass0 > 0):
        raise InputError(f"expected mass0 > 0 kg, received {mass0:g}")
    if not (math.isfinite(exhaust_velocity) and exhaust_velocity > 0):
        raise InputError(f"expected exhaust_velocity > 0 m/s, received {exhaust_velocity:g}")
    return float(mass0 * -math.expm1(-float(delta_v) / exhaust_velocity))
