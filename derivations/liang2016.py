"""Liang, Wang, Sun, Zhang (2016), J. Harbin Inst. Technol. 48(4): controller (4) and Theorem 1.

One design, two views of the same law (``FORM = "agent"``, with a Lagrangian view):

* ``controller(v)``, the agent form every engine stage runs: the law written per spacecraft
  with the body rate ``w`` (which the agent kernels can replace by a gyro's output,
  :mod:`formsync_design.sim.sensors`).  The torque makes ``q_i'' = -K_o q_i' - K_q s_i -
  K_v sgn(q_i' + beta s_i)`` through ``q' = E w``, ``w' = Q (q''_des - E' w)``, ``u = J w' +
  w x J w`` with ``Q = E^{-1} = 2 (q0 I - q^ + q q^T / q0)`` and ``s_i = sum_j a_ij (q_i -
  q_j)`` (the paper's unit weights on an undirected graph); one switching gain ``K_v`` (the
  paper's ``K_vi``, 0.01) for every spacecraft.
* ``lagrangian_controller(v)`` and ``lyapunov(v)``, the paper's own form: eq. (4) in the
  opaque model matrices ``A q'' + B q' = Q^T u`` and the Lyapunov candidate of Theorem 1,
  from which the derivation stage derives the Theta_i / Pi families the formation
  certificate decides (``formsync_design.spec.loader.load_spec`` gives this view; ``K_v``
  there is the per-spacecraft switching gain ``K_vi``).

Both views are the same closed loop with perfect rates; tests/test_interop.py checks that
their linearisations agree (a consistency check between the two views).
"""

import sympy as sp

FORM = "agent"
NAME = "liang2016"
TITLE = "Liang et al. 2016, controller (4) and the Lyapunov function of Theorem 1"
REPRESENTATION = "quaternion"
GAINS = {
    "K_o": {"description": "rate-damping gain"},
    "K_q": {"description": "coupling gain"},
    "beta": {"description": "sliding-variable weight"},
    "K_v": {"role": "switching", "description": "switching gain K_vi"},
}
GRAPHS = ("undirected", "weakly-connected")  # Theorem 1: an undirected connected graph
SAMPLING = "continuous"


def controller(v):
    """Controller (4) per spacecraft, in the body rate (module docstring)."""
    E = v.E(v.q, v.q0)
    qd = E * v.w
    q0d = -(v.q.T * v.w)[0, 0] / 2
    Ed = (q0d * sp.eye(3) + v.hat(qd)) / 2
    s = sp.zeros(3, 1)
    for n in v.nbrs:
        s += n.a * (v.q - n.q)
    qdd = -v.K_o * qd - v.K_q * s - v.K_v * v.sgn(qd + v.beta * s)
    Q = 2 * (v.q0 * sp.eye(3) - v.hat(v.q) + v.q * v.q.T / v.q0)
    wdot = Q * (qdd - Ed * v.w)
    return v.J * wdot + v.w.cross(v.J * v.w)


def monitors(v):
    """``q0`` (controller (4) is undefined at ``q0 = 0``)."""
    return {"q0": v.q0}


def lagrangian_controller(v):
    """Paper eq. (4):
    u_i = Q_i^{-T} {(B_i - K_o A_i) q_i' - K_q A_i s_i - K_vi A_i sgn[q_i' + beta s_i]}."""
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def lyapunov(v):
    """V_i = (K_q + beta K_o)/4 sum_j |q_i - q_j|^2 + |q_i'|^2/2 + beta sum_j (q_i - q_j)^T q_i'."""
    c = (v.K_q + v.beta * v.K_o) / 4
    return (
        c * sum((e.dot(e) for e in v.edges), 0)
        + v.qd.dot(v.qd) / 2
        + v.beta * sum((e.dot(v.qd) for e in v.edges), 0)
    )
