"""A variant specification for the verification tests: the paper's law (4) with the
attitude gain doubled (K_q -> 2 K_q), and the paper's Lyapunov candidate with the same
substitution."""

NAME = "case_spec_fast"
TITLE = "paper's controller and candidate with the attitude gain doubled"


def controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - 2 * v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def lyapunov(v):
    c = (2 * v.K_q + v.beta * v.K_o) / 4
    return (
        c * sum((e.dot(e) for e in v.edges), 0)
        + v.qd.dot(v.qd) / 2
        + v.beta * sum((e.dot(v.qd) for e in v.edges), 0)
    )
