"""Specification of Liang, Wang, Sun, Zhang (2016), J. Harbin Inst. Technol. 48(4).

Controller (4) and the Lyapunov candidate of Theorem 1, as inputs to the
formsync-design derivation engine (see ``formsync_design.spec.loader``).
"""

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
