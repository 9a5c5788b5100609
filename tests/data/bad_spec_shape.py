"""Bad specification: the controller returns a 3x3 matrix instead of a 3x1 torque."""


def controller(v):
    return v.B - v.K_o * v.A


def lyapunov(v):
    return v.qd.dot(v.qd) / 2
