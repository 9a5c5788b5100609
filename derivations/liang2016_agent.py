"""Controller (4) of Liang et al. 2016 written per spacecraft (``FORM = "agent"``).

The same law as ``derivations/liang2016.py`` (the Lagrangian form ``u_i = Q_i^{-T}{(B_i - K_o
A_i) q_i' - K_q A_i s_i - K_v A_i sgn(q_i' + beta s_i)}``), written with the body rate ``w``
that the agent kernels can replace by a gyro's output (:mod:`formsync_design.sim.sensors`):
the torque makes ``q_i'' = -K_o q_i' - K_q s_i - K_v sgn(q_i' + beta s_i)`` through
``q' = E w``, ``w' = Q (q''_des - E' w)``, ``u = J w' + w x J w`` with ``Q = E^{-1} =
2 (q0 I - q^ + q q^T / q0)`` and ``s_i = sum_j a_ij (q_i - q_j)`` (the paper's unit weights on
an undirected graph).  With perfect rates it is the paper's controller (tested against the
classic simulator); with a biased, noisy or failed gyro it is what a spacecraft running
controller (4) on that gyro does -- the comparison case of the output-feedback design
``lv2012``.  One switching gain ``k_v`` (the paper's ``K_vi``, 0.01) for every spacecraft.
"""

import sympy as sp

FORM = "agent"
NAME = "liang2016_agent"
TITLE = "Controller (4) of Liang et al. 2016, agent form (reads the body rate from its gyro)"
REPRESENTATION = "quaternion"
GAINS = {
    "K_o": {"range": "0.5:3", "description": "rate gain"},
    "K_q": {"range": "0.05:1", "description": "attitude coupling gain"},
    "beta": {"range": "0.01:0.5", "description": "sliding-variable weight"},
    "k_v": {"range": "0.001:0.1", "description": "switching gain (every spacecraft)"},
}
GRAPHS = ("undirected", "weakly-connected")
SAMPLING = "continuous"


def controller(v):
    E = v.E(v.q, v.q0)
    qd = E * v.w
    q0d = -(v.q.T * v.w)[0, 0] / 2
    Ed = (q0d * sp.eye(3) + v.hat(qd)) / 2
    s = sp.zeros(3, 1)
    for n in v.nbrs:
        s += n.a * (v.q - n.q)
    qdd = -v.K_o * qd - v.K_q * s - v.k_v * v.sgn(qd + v.beta * s)
    Q = 2 * (v.q0 * sp.eye(3) - v.hat(v.q) + v.q * v.q.T / v.q0)
    wdot = Q * (qdd - Ed * v.w)
    return v.J * wdot + v.w.cross(v.J * v.w)


def monitors(v):
    """``q0`` (controller (4) is undefined at ``q0 = 0``)."""
    return {"q0": v.q0}
