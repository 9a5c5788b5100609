"""Bad specification: raises while it is imported."""

raise RuntimeError("this design needs a file that is not there")


def controller(v):
    return v.qd


def lyapunov(v):
    return v.qd.dot(v.qd)
