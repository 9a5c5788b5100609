"""Bad specification: uses an attribute the controller view does not have."""


def controller(v):
    return v.Q.I.T * (v.B * v.qd - v.K_q * v.A * v.omega)


def lyapunov(v):
    return v.qd.dot(v.qd) / 2
