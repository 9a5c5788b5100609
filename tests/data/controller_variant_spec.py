"""A variant controller: twice the attitude-coupling gain (-2 K_q A s_i instead of -K_q A s_i).

Its closed loop is the paper's with K_q replaced by 2 K_q, which the tests use as an
independent truth for the simulated trajectory.
"""

NAME = "double-kq"
TITLE = "controller (4) with 2 K_q on the coupling term"


def controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * (
        (v.B - v.K_o * v.A) * v.qd - 2 * v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau)
    )


def lyapunov(v):
    c = (2 * v.K_q + v.beta * v.K_o) / 4
    return (
        c * sum((e.dot(e) for e in v.edges), 0)
        + v.qd.dot(v.qd) / 2
        + v.beta * sum((e.dot(v.qd) for e in v.edges), 0)
    )
