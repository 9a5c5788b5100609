"""Bad specification: the Lyapunov candidate raises when called (indexes a missing edge)."""


def controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def lyapunov(v):
    return v.edges[5].dot(v.qd)
