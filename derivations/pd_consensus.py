"""Quaternion PD consensus with absolute rate damping (the toolbox's baseline design).

Source: W. Ren, "Distributed attitude alignment in spacecraft formation flying",
Int. J. Adaptive Control and Signal Processing 21 (2007): the PD consensus law
"attitude differences to the neighbours plus absolute rate damping", no switching
term.  Written here in the quaternion-vector Lagrangian coordinates of the toolbox
(``A q'' + B q' = Q^T u``, the same coordinates as Liang et al. 2016), with the same
model cancellation as Liang's controller (4):

    u_i = Q_i^{-T} [ (B_i - k_d A_i) q_i' - k_p A_i s_i ],   s_i = sum_{j in G_i} (q_i - q_j)

so the closed loop is ``q_i'' = -k_d q_i' - k_p s_i + A_i^{-1} Q_i^T u_di``.
Assumption (ours, stated in the derivation report): the cancellation form is ours;
Ren's law acts on body rates with the inertia, and agrees with this one to first order.

One design, two views of the same law (``FORM = "agent"``, with a Lagrangian view):
``controller(v)`` is the agent form every engine stage runs, written per spacecraft with the
body rate ``w`` (``q' = E w``, ``w' = Q (q''_des - E' w)``, ``u = J w' + w x J w`` with
``Q = E^{-1} = 2 (q0 I - q^ + q q^T / q0)`` and ``s_i = sum_j a_ij (q_i - q_j)``), so that
``q_i'' = -k_d q_i' - k_p s_i``; ``lagrangian_controller(v)`` and ``lyapunov(v)`` are the
Lagrangian view above, from which the derivation stage derives the Theta_i / Pi families
(``formsync_design.spec.loader.load_spec``).  With perfect rates both are the same closed
loop; tests/test_interop.py checks that their linearisations agree.

The Lyapunov candidate is the classic strict one for second-order consensus, with a
cross term whose weight ``eps`` is a *multiplier*: a parameter of the certificate, not of
the controller, which the certificate may choose per gain box:

    V_i = (k_p + eps k_d)/4 sum_j |q_i - q_j|^2 + |q_i'|^2/2 + eps sum_j (q_i - q_j)^T q_i'
"""

import sympy as sp

FORM = "agent"
NAME = "pd_consensus"
TITLE = "Quaternion PD consensus with absolute rate damping (Ren 2007), baseline"
REPRESENTATION = "quaternion"
GAINS = {
    "k_p": {"range": "0.1:2", "description": "attitude coupling gain"},
    "k_d": {"range": "0.5:3", "description": "absolute rate-damping gain"},
    "eps": {"role": "multiplier", "range": "1/1000:1",
            "description": "cross-term weight of the Lyapunov candidate"},
}
GRAPHS = ("undirected", "weakly-connected")
SAMPLING = "continuous"


def controller(v):
    """The PD consensus law per spacecraft, in the body rate (module docstring)."""
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


def monitors(v):
    """``q0`` (the law, like controller (4), is undefined at ``q0 = 0``)."""
    return {"q0": v.q0}


def lagrangian_controller(v):
    """u_i = Q_i^{-T} [(B_i - k_d A_i) q_i' - k_p A_i s_i]."""
    return v.Q.I.T * ((v.B - v.k_d * v.A) * v.qd - v.k_p * v.A * v.s)


def lyapunov(v):
    """V_i = (k_p + eps k_d)/4 sum |e|^2 + |q_i'|^2/2 + eps sum e^T q_i'."""
    c = (v.k_p + v.eps * v.k_d) / 4
    return (
        c * sum((e.dot(e) for e in v.edges), 0)
        + v.qd.dot(v.qd) / 2
        + v.eps * sum((e.dot(v.qd) for e in v.edges), 0)
    )
