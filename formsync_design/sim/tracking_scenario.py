"""The inputs of a fly-around simulation (:func:`~formsync_design.sim.tracking.
simulate_flyaround`): the scenario (orbits, spacecraft, fly-around reference, thrusters,
gains), the options (horizon, sample period, allocation rule, PWM, the convergence
tolerances), and the 3-2-1 Euler angles of the initial attitude.  The run is a
:class:`~formsync_design.sim.result.SimResult` whose ``orbit`` holds the relative orbit and
the thrusters (:class:`~formsync_design.sim.orbit_record.OrbitRecord`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.models.orbit import (
    MU_EARTH,
    KeplerElements,
    mean_motion,
)
from formsync_design.models.relative_reference import (
    FlyaroundParams,
)
from formsync_design.models.thrusters import (
    EXHAUST_VELOCITY,
    MIN_PULSE_S,
    ThrusterLayout,
)
from formsync_design.sim.tracking_model import (
    N_THRUSTERS_MAX,
)

__all__ = [
    "ALLOCATIONS",
    "euler321",
    "FlyaroundScenario",
    "FlyaroundOptions",
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
    angle_tol : float
        Attitude tolerance (deg, default 1) of the convergence criterion: a completed run is
        ``converged`` when from some sample to the last one the attitude tracking error angle
        ``4 atan|sigma_sd|`` is at most ``angle_tol`` and the relative-position error
        ``|rho - l_T|`` at most ``position_tol`` (the run's ``convergence_time`` is the first
        such sample), else ``not-converged``.  The rate and velocity errors are not part of
        it.  The defaults are the toolbox's choice (the paper states no convergence
        criterion): just above the steady-state errors it reports (about 0.63 deg and
        0.55 m, section 4), so a run with the paper's accuracy counts as converged.  The
        shipped case (``verification/zhang2014_flyaround.toml``) meets them from t = 70.4 s.
    position_tol : float
        Relative-position tolerance (m, default 1) of that criterion.
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
    angle_tol: float = 1.0
    position_tol: float = 1.0

    def __post_init__(self) -> None:
        if self.allocation not in ALLOCATIONS:
            raise InputError(f"expected allocation one of {list(ALLOCATIONS)}, received "
                             f"{self.allocation!r}")
        if self.reading not in ("corrected", "printed"):
            raise InputError(f"expected reading 'corrected' or 'printed', received "
                             f"{self.reading!r}")
        for name in ("tf", "sample_period", "exhaust_velocity", "angle_tol", "position_tol"):
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
