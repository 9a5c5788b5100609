"""Measured L2 gains of agent formations, from disturbance torques to attitude errors.

A run starts at the commanded attitude, at rest, filters at rest (the L2 gain is defined
from that state), and is driven by a torque input held over each RK4 step
(:mod:`formsync_design.sim.sensors`); the output is ``z = (e_1 .. e_N)``, the vector parts of
``q_r^* (x) q_i``.  The measured gain is ``sqrt(int |z|^2 / int |d|^2)`` over the horizon:
``int |d|^2 = h sum_k |d_k|^2`` exactly for the held input, ``int |z|^2`` by the trapezoid rule
on the output grid (pass ``output_step = step`` for the RK4 grid).  By causality the
finite-horizon ratio of a linear system from rest never exceeds its H-infinity norm, so a
certified ``gamma`` must bound every measured value on the linearisation's domain.

Signals (:func:`random_disturbance`, seeded): ``white`` (independent normal samples per
step), ``multisine`` (8 sinusoids, random frequencies in ``(0, w_max)``, phases, amplitudes
and directions), ``steps`` (piecewise constant, random levels held 5-50 s), all scaled to a
given RMS per axis.

>>> rng = np.random.default_rng(0)
>>> d = random_disturbance(rng, "multisine", 1000, 2, 0.05, rms=1e-3, w_max=1.0)
>>> d.shape, round(float(np.sqrt(np.mean(d ** 2))) * 1e3, 6)
((1000, 2, 3), 1.0)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from formsync_design.errors import InputError

__all__ = ["SIGNALS", "random_disturbance", "harmonic_samples", "attitude_errors",
           "measured_l2_gain"]

#: Random disturbance families of :func:`random_disturbance`.
SIGNALS = ("white", "multisine", "steps")


def random_disturbance(rng: np.random.Generator, kind: str, steps: int, n: int, h: float, *,
                       rms: float, w_max: float = 1.0) -> np.ndarray:
    """A ``(steps, n, 3)`` torque sequence of the family ``kind`` with RMS ``rms`` (N m)."""
    t = np.arange(steps) * h
    if kind == "white":
        d = rng.normal(size=(steps, n, 3))
    elif kind == "multisine":
        d = np.zeros((steps, n, 3))
        for _ in range(8):
            w = rng.uniform(0.0, w_max)
            ph = rng.uniform(0, 2 * math.pi)
            amp = rng.normal(size=(n, 3))
            d += np.sin(w * t + ph)[:, None, None] * amp[None]
    elif kind == "steps":
        d = np.zeros((steps, n, 3))
        k = 0
        while k < steps:
            dur = max(1, int(rng.uniform(5.0, 50.0) / h))
            d[k: k + dur] = rng.normal(size=(n, 3))
            k += dur
    else:
        raise InputError(f"expected a disturbance signal among {list(SIGNALS)}, received {kind!r}")
    scale = float(np.sqrt(np.mean(d**2)))
    return d * (rms / scale) if scale > 0 else d


def harmonic_samples(model: Any, steps: int, h: float) -> np.ndarray:
    """``(steps, N, 3)`` samples at the step starts of a time-only disturbance model
    (:class:`~formsync_design.models.disturbances.DisturbanceModel` without gravity gradient):
    ``c + a sin(w1 t + p1) sin(w2 t + p2)`` per axis."""
    if model.gravity_gradient:
        raise InputError("expected a time-only disturbance model (no gravity gradient) to sample")
    H = np.asarray(model.harmonic)
    t = (np.arange(steps) * h)[:, None, None]
    c, a, w1, p1, w2, p2 = (H[None, :, :, k] for k in range(6))
    return c + a * np.sin(w1 * t + p1) * np.sin(w2 * t + p2)


def attitude_errors(quaternions: np.ndarray, reference: Any = (0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    """``(T, N, 3)`` vector parts of ``q_r^* (x) q_i`` (toolbox product, ``(q1, q2, q3, q0)``).

    >>> q = np.array([[[0.0, 0.0, math.sin(0.1), math.cos(0.1)]]])
    >>> [round(float(x), 6) for x in attitude_errors(q)[0, 0]]
    [0.0, 0.0, 0.099833]
    """
    r = np.asarray(reference, dtype=float)
    rv, r0 = -r[:3], r[3]
    qv, q0 = quaternions[..., :3], quaternions[..., 3:4]
    return r0 * qv + q0 * rv + np.cross(np.broadcast_to(rv, qv.shape), qv)


def measured_l2_gain(result: Any, torque_input: np.ndarray, h: float,
                     reference: Any = (0.0, 0.0, 0.0, 1.0)) -> float:
    """``sqrt(int |z|^2 / int |d|^2)`` of a run driven by ``torque_input`` (module docstring).

    >>> from formsync_design.sim.agents import AgentFormation, AgentOptions, Reference, simulate_agents
    >>> from formsync_design.sim.formation import Gains
    >>> from formsync_design.spec.loader import load_design
    >>> from formsync_design.graphs.digraph_io import make_digraph
    >>> f = AgentFormation(make_digraph("path:2", pinning=[1, 1]), np.array([np.eye(3) * 2] * 2),
    ...                    np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3)),
    ...                    Gains(k_p=1.0, k_d=4.0, a_f=1.0), reference=Reference())
    >>> d = random_disturbance(np.random.default_rng(1), "steps", 400, 2, 0.05, rms=1e-3)
    >>> r = simulate_agents(load_design("lv2012"), f, AgentOptions(tf=20, output_step=0.05, step=0.05),
    ...                     torque_input=d)
    >>> 0 < measured_l2_gain(r, d, 0.05) <= 1.135   # 1.135: its certified gamma (certify_gamma)
    True
    """
    d = np.asarray(torque_input, dtype=float)
    w2 = h * float(np.sum(d**2))
    if not w2 > 0:
        raise InputError("expected a non-zero torque input to measure a gain")
    z = attitude_errors(result.quaternions, reference)
    z2 = float(np.trapezoid(np.sum(z**2, axis=(1, 2)), result.t))
    return math.sqrt(z2 / w2)
