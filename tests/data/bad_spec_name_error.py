"""Bad specification: refers to a name it never defines."""


def controller(v):
    return v.Q.I.T * (v.B * v.qd - K_extra * v.A * v.s)  # noqa: F821


def lyapunov(v):
    return v.qd.dot(v.qd) / 2
