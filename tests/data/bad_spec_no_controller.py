"""Bad specification: no controller()."""


def lyapunov(v):
    return v.qd.dot(v.qd) / 2
