"""The inputs and the result of a fly-around simulation (:func:`~formsync_design.sim.tracking.
simulate_flyaround`): the scenario (orbits, spacecraft, fly-around reference, thrusters,
gains), the options (horizon, sample period, allocation rule, PWM), the run and its status,
and the 3-2-1 Euler angles of the initial attitude.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.models.orbit import (
    MU_EARTH,
    ZHANG2014_CHASER,
    ZHANG2014_TARGET,
    KeplerElements,
    LQRDesign,
    mean_motion,
)
from formsync_design.models.relative_reference import (
    ZHANG2014_FLYAROUND,
    FlyaroundParams,
)
from formsync_design.models.thrusters import (
    EXHAUST_VELOCITY,
    MIN_PULSE_S,
    ThrusterLayout,
    zhang2014_layout,
)
from formsync_design.sim.tracking_model import (
    N_THRUSTERS_MAX,
)

__all__ = [
    "ALLOCATIONS",
    "euler321",
    "FlyaroundScenario",
    "FlyaroundOptions",
    "FlyaroundStatus",
    "FlyaroundRun",
]

#: Allocation rules: pseudo-inverse with a null-space shift, pseudo-inverse clipped, LP.
ALLOCATIONS = ("pinv-shift", "pinv-clip", "lp")


def euler321(angles_deg: Any) -> np.ndarray:
    """``C = R1(phi) R2(theta) R3(psi)`` (coordinate transformation) of 3-2-1 angles (deg).

    >>> bool(np.allclose(euler321([0, 0, 90]) @ [1.0, 0, 0], [0, -1, 0]))
    True
    """
    a = np.radians(np.asarray(angles_deg, dtype=float))
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputError(f"expected 3 finite angles (deg), received shape {a.shape}")

    def r(axis: int, t: float) -> np.ndarray:
        c, s = math.cos(t), math.sin(t)
        m = np.eye(3)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        m[i, i], m[i, j], m[j, i], m[j, j] = c, s, -s, c
        return m

    return r(0, a[0]) @ r(1, a[1]) @ r(2, a[2])


@dataclass(frozen=True)
class FlyaroundScenario:
    """Everything physical about a fly-around run.

    Attributes
    ----------
    target, chaser : KeplerElements
        Initial orbits (the target's must be circular).
    mass : float
        Chaser mass (kg), constant (assumption of the case).
    inertia : numpy.ndarray
        Plant inertia (kg m^2, 3x3 SPD).
    law_inertia : numpy.ndarray or None
        The inertia the attitude law uses (None: the plant's).
    reference : FlyaroundParams
    attitude0_deg, rate0 : numpy.ndarray
        Initial 3-2-1 angles of the body relative to the desired frame (deg) and the body
        rate relative to the desired frame (rad/s, body axes).
    layout : ThrusterLayout
    gains : dict
        The design's gains: name -> tuple of floats (1 value, or 3 for a diagonal gain).
    mu : float
    """

    target: KeplerElements
    chaser: KeplerElements
    mass: float
    inertia: np.ndarray
    reference: FlyaroundParams
    layout: ThrusterLayout
    gains: dict = field(default_factory=dict)
    law_inertia: np.ndarray | None = None
    attitude0_deg: np.ndarray = field(default_factory=lambda: np.ones(3))
    rate0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    mu: float = MU_EARTH

    def __post_init__(self) -> None:
        j = np.asarray(self.inertia, dtype=float)
        if j.shape != (3, 3) or not np.allclose(j, j.T) or np.linalg.eigvalsh(j).min() <= 0:
            raise InputError(f"expected a symmetric positive definite 3x3 inertia, received "
                             f"shape {j.shape}")
        object.__setattr__(self, "inertia", j)
        if self.law_inertia is not None:
            object.__setattr__(self, "law_inertia", np.asarray(self.law_inertia, dtype=float))
        if not (math.isfinite(self.mass) and self.mass > 0):
            raise InputError(f"expected a mass > 0 kg, received {self.mass:g}")
        if self.target.e != 0:
            raise InputError(f"expected a circular target orbit (e = 0), received e = "
                             f"{self.target.e:g}")
        if self.layout.count > N_THRUSTERS_MAX:
            raise InputError(f"expected at most {N_THRUSTERS_MAX} thrusters, received "
                             f"{self.layout.count}")
        object.__setattr__(self, "attitude0_deg", np.asarray(self.attitude0_deg, dtype=float))
        object.__setattr__(self, "rate0", np.asarray(self.rate0, dtype=float))

    @classmethod
    def paper(cls, gains: dict) -> FlyaroundScenario:
        """The paper's case (section 4) with the design's ``gains`` (the paper prints none;
        the shipped case file ``verification/zhang2014_flyaround.toml`` chooses them)."""
        return cls(ZHANG2014_TARGET, ZHANG2014_CHASER, 2000.0,
                   np.diag([3256.0, 2922.0, 3505.0]), ZHANG2014_FLYAROUND, zhang2014_layout(),
                   dict(gains))

    @property
    def mean_motion(self) -> float:
        return mean_motion(self.target.a, self.mu)


@dataclass(frozen=True)
class FlyaroundOptions:
    """How a fly-around run is simulated.

    Attributes
    ----------
    tf : float
        Horizon (s); a whole number of samples.
    sample_period : float
        Control sample period (s).
    substeps : int
        RK4 sub-steps per sample (each with the exact average thrust of every pulse).
    allocation : str
        One of :data:`ALLOCATIONS`.
    carry : bool
        Carry each thruster's rounding error (below the minimum pulse) to the next sample.
    min_pulse : float
        Minimum pulse width (s).
    exhaust_velocity : float
        Effective exhaust velocity (m/s), for the fuel.
    reading : str
        ``corrected`` (``phi_r`` with ``exp(-t/P1)``) or ``printed`` (``exp(-1/P1)``).
    compile : bool
        Compile the kernel to C (else the CasADi virtual machine).
    """

    tf: float = 18000.0
    sample_period: float = 0.2
    substeps: int = 10
    allocation: str = "pinv-shift"
    carry: bool = False
    min_pulse: float = MIN_PULSE_S
    exhaust_velocity: float = EXHAUST_VELOCITY
    reading: str = "corrected"
    compile: bool = True

    def __post_init__(self) -> None:
        if self.allocation not in ALLOCATIONS:
            raise InputError(f"expected allocation one of {list(ALLOCATIONS)}, received "
                             f"{self.allocation!r}")
        if self.reading not in ("corrected", "printed"):
            raise InputError(f"expected reading 'corrected' or 'printed', received "
                             f"{self.reading!r}")
        for name in ("tf", "sample_period", "exhaust_velocity"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"expected {name} > 0, received {v:g}")
        if not (math.isfinite(self.min_pulse) and 0 <= self.min_pulse <= self.sample_period):
            raise InputError(f"expected 0 <= min_pulse <= sample_period, received "
                             f"{self.min_pulse:g}")
        if not isinstance(self.substeps, int) or not 1 <= self.substeps <= 100:
            raise InputError(f"expected substeps an integer in 1..100, received "
                             f"{self.substeps!r}")
        k = self.tf / self.sample_period
        if abs(k - round(k)) > 1e-9 * k:
            raise InputError(f"expected tf a whole number of samples of "
                             f"{self.sample_period:g} s, received tf = {self.tf:g}")

    @property
    def samples(self) -> int:
        return int(round(self.tf / self.sample_period))


class FlyaroundStatus(enum.StrEnum):
    """How a fly-around run ended: ``completed`` (every sample to ``tf``) or ``diverged``
    (a non-finite state at ``diverged_time``; the run ends at the last finite state)."""

    COMPLETED = "completed"
    DIVERGED = "diverged"


@dataclass(frozen=True)
class FlyaroundRun:
    """A simulated fly-around.

    Attributes
    ----------
    t : numpy.ndarray
        Sample times ``t_k`` (the control instants), ``(K,)``.
    states : numpy.ndarray
        ``(K + 1, 12)`` truth states at ``t_k`` and the final time:
        ``(rho, rho', sigma, omega)``.
    outputs : dict of numpy.ndarray
        Per-sample outputs (:data:`~formsync_design.sim.tracking_model.OUTPUTS`): ``dX``,
        ``sigma_sd``, ``omega_sd`` (at ``t_k``), ``on_time``, ``wrench_cmd``, ``wrench_pwm``,
        ``raw_min``, ``frame_status``, ``switched``, ``thrust_cmd``.
    lqr : LQRDesign
    options : FlyaroundOptions
    scenario : FlyaroundScenario
    seconds : float
        Wall time of the integration (the compiled kernel build excluded).
    build_seconds : float
        Kernel build (generation + compilation, or the cache hit).
    lp_fallbacks : int
        Samples of an ``lp`` run solved by the bounded LP (upper bounds binding).
    status : FlyaroundStatus
        ``completed``, or ``diverged``: the state was non-finite at ``diverged_time``, and
        ``t``, ``states`` and ``outputs`` end at the last finite state before it.
    diverged_time : float or None
        The first sample time with a non-finite state (status ``diverged``).
    """

    t: np.ndarray
    states: np.ndarray
    outputs: dict
    lqr: LQRDesign
    options: FlyaroundOptions
    scenario: FlyaroundScenario
    seconds: float
    build_seconds: float
    lp_fallbacks: int = 0
    status: FlyaroundStatus = FlyaroundStatus.COMPLETED
    diverged_time: float | None = None

    @property
    def message(self) -> str:
        """One line on how the run ended (``diverged at t = ...`` for a diverged run)."""
        if self.status == FlyaroundStatus.DIVERGED:
            return (f"diverged at t = {self.diverged_time:g} s (non-finite state; the run ends at "
                    f"t = {float(self.states.shape[0] - 1) * self.options.sample_period:g} s): "
                    "check the gains, the inertia and the sample period")
        return f"completed {self.t.size} samples to t = {self.options.tf:g} s"

    @property
    def impulses(self) -> np.ndarray:
        """Per-sample, per-thruster impulse (N s), ``(K, m)``."""
        m = self.scenario.layout.count
        return self.scenario.layout.thrust * self.outputs["on_time"][:, :m]

    @property
    def total_impulse(self) -> float:
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

    def window(self, t0: float, t1: float | None = None) -> np.ndarray:
        """Boolean mask of the samples with ``t0 <= t_k <= t1``."""
        hi = self.t[-1] if t1 is None else t1
        return (self.t >= t0) & (self.t <= hi)

    def to_dict(self) -> dict[str, Any]:
        return {"samples": int(self.t.size), "fuel_kg": json_number(self.fuel),
                "delta_v_m_s": json_number(self.delta_v),
                "delta_v_net_m_s": json_number(self.delta_v_net),
                "allocation": self.options.allocation, "seconds": json_number(self.seconds),
                "lp_fallbacks": self.lp_fallbacks, "status": str(self.status),
                "diverged_time": None if self.diverged_time is None
                else json_number(self.diverged_time)}
