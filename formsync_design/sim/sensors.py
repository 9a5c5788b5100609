"""Rate-gyro models and an exogenous torque channel for agent-design simulations.

A law of an agent design reads the body rate ``v.w`` (when its ``MEASURED`` allows it).  With
a :class:`RateSensors` model the compiled kernel (``measured`` variant of
:func:`~formsync_design.sim.agent_kernel.get_agent_kernel`) hands the law the gyro output

    w_meas,i(t) = h_i(t) (w_i(t) + b_i + n_i,k),     h_i(t) = 1 for t < t_fail,i, else 0,

instead of the true rate (the plant always integrates the true rate): a constant bias
``b_i``, white noise ``n_i,k ~ N(0, sigma_i^2 I)`` drawn once per RK4 step ``h`` and held over
it (a gyro sampled at ``1/h``; the two-sided power spectral density of the held sequence is
``sigma^2 h`` at low frequency, i.e. an angle random walk ``sigma sqrt(h)`` rad/sqrt(s)), and a
gyro that fails at ``t_fail`` and then reads zero.  A design that never reads ``v.w`` runs
exactly as without the model (bit for bit: the law's inputs do not change).

``torque_input`` (``(steps, N, 3)``, N m) is an exogenous disturbance held over each RK4 step
and added to the model disturbance: the input of a measured L2 gain
(:func:`formsync_design.sim.l2measure.measured_l2_gain`), whose energy ``h sum |d_k|^2`` is
exact for the held signal.

>>> s = RateSensors.of(3, bias=1e-4, noise_std=2e-4, failed={2: 0.0}, seed=1)
>>> s.fail_time.tolist(), s.bias.shape, s.offsets(4, 0.01).shape
([inf, 0.0, inf], (3, 3), (4, 3, 3))
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number

__all__ = ["RateSensors", "external_inputs"]


@dataclass(frozen=True)
class RateSensors:
    """A rate-gyro model per spacecraft (module docstring).

    Attributes
    ----------
    bias : (N, 3) rad/s; noise_std : (N,) rad/s per sample (at the RK4 step);
    fail_time : (N,) s (``inf``: healthy); seed : int (the noise sequence's seed)
    """

    bias: np.ndarray
    noise_std: np.ndarray
    fail_time: np.ndarray
    seed: int = 0

    def __post_init__(self) -> None:
        b = np.asarray(self.bias, dtype=float)
        n = b.shape[0] if b.ndim == 2 else 0
        s = np.asarray(self.noise_std, dtype=float).reshape(-1)
        f = np.asarray(self.fail_time, dtype=float).reshape(-1)
        if b.shape != (n, 3) or s.shape != (n,) or f.shape != (n,) or n == 0:
            raise InputError(f"expected bias (N, 3), noise_std (N,), fail_time (N,), received "
                             f"{b.shape}, {s.shape}, {f.shape}")
        if not (np.all(np.isfinite(b)) and np.all(np.isfinite(s)) and np.all(s >= 0)):
            raise InputError("expected finite gyro biases and non-negative noise levels")
        if np.any(np.isnan(f)) or np.any(f < 0):
            raise InputError(f"expected gyro failure times >= 0 (inf: healthy), received "
                             f"{f.tolist()}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise InputError(f"expected an integer noise seed, received {self.seed!r}")
        for name, v in (("bias", b), ("noise_std", s), ("fail_time", f)):
            v.setflags(write=False)
            object.__setattr__(self, name, v)

    @classmethod
    def of(cls, n: int, *, bias: Any = 0.0, noise_std: Any = 0.0,
           failed: Mapping[int, float] | None = None, seed: int = 0) -> RateSensors:
        """``n`` gyros: ``bias`` a number (every axis, signs drawn from ``seed``), a 3-vector
        or ``(N, 3)``; ``noise_std`` a number or ``(N,)``; ``failed`` ``{spacecraft (1-based):
        failure time}``."""
        b = np.asarray(bias, dtype=float)
        if b.ndim == 0:
            signs = np.random.default_rng([seed, 1]).choice([-1.0, 1.0], size=(n, 3))
            b = float(b) * signs
        elif b.shape == (3,):
            b = np.tile(b, (n, 1))
        s = np.broadcast_to(np.asarray(noise_std, dtype=float), (n,)).copy()
        f = np.full(n, math.inf)
        for k, tf in (failed or {}).items():
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
                raise InputError(f"expected failed spacecraft numbers in 1..{n}, received {k!r}")
            f[int(k) - 1] = float(tf)
        return cls(b, s, f, int(seed))

    @property
    def n(self) -> int:
        return int(self.bias.shape[0])

    def offsets(self, steps: int, h: float) -> np.ndarray:
        """``(steps, N, 3)`` offsets ``b_i + n_i,k`` (the noise drawn from ``seed``)."""
        del h  # the per-sample standard deviation is given at the step: documented above
        rng = np.random.default_rng([self.seed, 2])
        noise = rng.normal(size=(steps, self.n, 3)) * self.noise_std[None, :, None]
        return self.bias[None, :, :] + noise

    def to_dict(self) -> dict[str, Any]:
        return {"bias": [[json_number(float(x)) for x in row] for row in self.bias],
                "noise_std": [json_number(float(x)) for x in self.noise_std],
                "fail_time": [json_number(float(x)) for x in self.fail_time], "seed": self.seed}


def external_inputs(n: int, steps: int, h: float, sensors: RateSensors | None,
                    torque_input: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's ``EXT`` (``6N x steps``, one column per RK4 step) and the failure times."""
    ext = np.zeros((steps, 2, n, 3))
    tfail = np.full(n, math.inf)
    if sensors is not None:
        if sensors.n != n:
            raise InputError(f"expected a gyro model of {n} spacecraft, received {sensors.n}")
        ext[:, 0] = sensors.offsets(steps, h)
        tfail = np.asarray(sensors.fail_time, dtype=float)
    if torque_input is not None:
        d = np.asarray(torque_input, dtype=float)
        if d.shape != (steps, n, 3) or not np.all(np.isfinite(d)):
            raise InputError(f"expected a finite torque input of shape ({steps}, {n}, 3) (one "
                             f"value per RK4 step), received {d.shape}")
        ext[:, 1] = d
    return ext.reshape(steps, 6 * n).T.copy(), tfail
