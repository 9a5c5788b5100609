"""A candidate coupling the x and y axes: not of the form F (x) I_3."""


def controller(v):
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s)


def lyapunov(v):
    return v.qd.dot(v.qd) / 2 + v.qd[0] * v.qd[1]
