"""Bad specification: the Lyapunov candidate uses a symbol the view does not provide."""

import sympy as sp


def controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def lyapunov(v):
    gamma = sp.Symbol("gamma", positive=True)
    return gamma * v.qd.dot(v.qd) / 2
