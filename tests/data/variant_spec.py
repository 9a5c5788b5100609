"""A modified candidate: half the cross weight and an extra |s_i|^2 term (same controller)."""

NAME = "variant"
TITLE = "variant candidate (half cross weight, extra |s_i|^2)"


def controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def lyapunov(v):
    s = v.s
    return (
        (v.K_q + v.beta * v.K_o) / 4 * sum((e.dot(e) for e in v.edges), 0)
        + v.qd.dot(v.qd) / 2
        + v.beta / 2 * sum((e.dot(v.qd) for e in v.edges), 0)
        + v.beta**2 / 8 * s.dot(s)
    )
