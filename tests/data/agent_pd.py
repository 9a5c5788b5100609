"""Test design: quaternion PD consensus written as an agent design (FORM = "agent").

The same closed loop as the Lagrangian ``pd_consensus``: with ``q' = E w`` the torque makes
``q'' = -k_d q' - k_p s``, ``s = sum_j a_ij (q_i - q_j)``:
``w' = Q (q''_des - E' w)``, ``u = J w' + w x J w`` with ``Q = E^{-1} = 2 (q0 I - q^ + q q^T / q0)``.
"""

import sympy as sp

FORM = "agent"
NAME = "agent_pd"
REPRESENTATION = "quaternion"
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3"}}
GRAPHS = ("weakly-connected",)


def controller(v):
    E = v.E(v.q, v.q0)
    qd = E * v.w
    q0d = -(v.q.T * v.w)[0, 0] / 2
    Ed = (q0d * sp.eye(3) + v.hat(qd)) / 2
    s = sp.zeros(3, 1)
    for n in v.nbrs:
        s += n.a * (v.q - n.q)
    qdd = -v.k_d * qd - v.k_p * s
    Q = 2 * (v.q0 * sp.eye(3) - v.hat(v.q) + v.q * v.q.T / v.q0)
    wdot = Q * (qdd - Ed * v.w)
    return v.J * wdot + v.w.cross(v.J * v.w)
