"""The seeded Monte-Carlo draws of an ``engine`` case: one formation per run, the same draws
for every scenario of a formation (so a metric can compare two scenarios run by run).

Three draw rules (``[montecarlo] draws``, :mod:`formsync_design.verify.enginecase`):

``box`` (the default)
    the draws of :func:`~formsync_design.sim.agent_montecarlo.run_agent_montecarlo`: one
    seed per run (:meth:`~formsync_design.sim.montecarlo_data.MonteCarloSettings.run_seeds`),
    the gains uniform in the box, every initial attitude a rotation from the identity by an
    angle uniform in ``[0, max_angle]`` about a uniform axis, rates uniform in
    ``[-max_rate, max_rate]`` (:func:`~formsync_design.sim.agent_montecarlo.agent_run_formation`);
``about-reference``
    one generator seeded once (:func:`reference_draws`): every spacecraft rotated from the
    leader's initial attitude (the identity without a leader) by an angle uniform in
    ``[0, max_angle]`` about a uniform axis, rates ``N(0, rate_sigma^2)`` per axis, then the
    disturbance's oscillating phases uniform (in this order); the gains are the scenario's;
``euler-uniform``
    one generator seeded once (:func:`euler_draws`): per draw, every 3-2-1 Euler angle of
    every spacecraft uniform in ``[-max_angle, max_angle]`` (deg), then every rate component
    uniform in ``[-max_rate, max_rate]``; the gains are the scenario's.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

__all__ = ["DRAW_RULES", "reference_draws", "euler_draws", "quaternion_product"]

#: The draw rules of ``[montecarlo] draws``.
DRAW_RULES = ("box", "about-reference", "euler-uniform")


def quaternion_product(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product in the ``(q1, q2, q3, q0)`` order.

    >>> quaternion_product(np.array([0, 0, 1.0, 0]), np.array([0, 0, 1.0, 0])).tolist()
    [0.0, 0.0, 0.0, -1.0]
    """
    pv, p0, qv, q0 = p[:3], p[3], q[:3], q[3]
    return np.concatenate([p0 * qv + q0 * pv + np.cross(pv, qv), [p0 * q0 - pv @ qv]])


def reference_draws(base: Any, reference: Any, runs: int, seed: int, max_angle_deg: float,
                    rate_sigma: float) -> list[Any]:
    """The ``about-reference`` draws (module docstring) of the formation ``base`` (an
    :class:`~formsync_design.sim.agents.AgentFormation`; ``reference`` its leader or ``None``).

    >>> from formsync_design.resources import case_file
    >>> from formsync_design.verify.agentcase import load_agent_case
    >>> c = load_agent_case(case_file("selftrigger_mrp"))
    >>> fs = reference_draws(c.formation(), c.reference, 2, 7, 60.0, 0.01)
    >>> len(fs), bool(np.allclose(np.linalg.norm(fs[1].attitudes, axis=1), 1))
    (2, True)
    """
    rng = np.random.default_rng(seed)
    n = base.n
    q_ref = np.asarray(reference.attitude if reference is not None else (0, 0, 0, 1), float)
    out = []
    for _ in range(runs):
        Q = np.empty((n, 4))
        for i in range(n):
            ax = rng.normal(size=3)
            ax /= np.linalg.norm(ax)
            ang = math.radians(max_angle_deg) * rng.random()
            Q[i] = quaternion_product(q_ref, np.concatenate([math.sin(ang / 2) * ax,
                                                             [math.cos(ang / 2)]]))
            if Q[i, 3] < 0:
                Q[i] *= -1
        W = rate_sigma * rng.normal(size=(n, 3))
        dist = base.disturbance.with_phases(rng) if base.disturbance is not None else None
        out.append(replace(base, attitudes=Q, rates=W, disturbance=dist))
    return out


def euler_draws(base: Any, runs: int, seed: int, max_angle_deg: float, max_rate: float
                ) -> list[Any]:
    """The ``euler-uniform`` draws (module docstring) of the formation ``base``.

    >>> from formsync_design.resources import case_file
    >>> from formsync_design.verify.agentcase import load_agent_case
    >>> fs = euler_draws(load_agent_case(case_file("ma_so3")).formation(), 2, 7, 60.0, 0.5)
    >>> len(fs), bool(np.abs(fs[0].rates).max() <= 0.5)
    (2, True)
    """
    from formsync_design.verify.agentcase import euler321_to_quat

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(runs):
        E = rng.uniform(-max_angle_deg, max_angle_deg, size=(base.n, 3))
        W = rng.uniform(-max_rate, max_rate, size=(base.n, 3))
        Q = np.array([euler321_to_quat(*e) for e in E])
        out.append(replace(base, attitudes=Q, rates=W))
    return out
