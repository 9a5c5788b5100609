"""A controller that does not cancel B: the engine must refuse it."""


def controller(v):
    return v.Q.I.T * (-v.K_o * v.A * v.qd - v.K_q * v.A * v.s)


def lyapunov(v):
    return v.qd.dot(v.qd) / 2
