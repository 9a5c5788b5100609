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

The Lyapunov candidate is the classic strict one for second-order consensus, with a
cross term whose weight ``eps`` is a *multiplier*: a parameter of the certificate, not of
the controller, which the certificate may choose per gain box:

    V_i = (k_p + eps k_d)/4 sum_j |q_i - q_j|^2 + |q_i'|^2/2 + eps sum_j (q_i - q_j)^T q_i'
"""

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
