"""Test design: self-triggered quaternion consensus (FORM = "agent").

``u = -J (k_p sum_j a_ij (q_i - qhat_j) + k_d w)`` with the neighbours' last broadcasts;
the next broadcast comes ``tau = tau0 / (1 + |w|)`` after this one.
"""

import sympy as sp

FORM = "agent"
NAME = "agent_selftrig"
REPRESENTATION = "quaternion"
SAMPLING = "self-triggered"
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3"}, "tau0": {"range": "0.05:1"}}


def controller(v):
    s = v.q * 0
    for n in v.nbrs:
        s += n.a * (v.q - n.q)
    return -v.J * (v.k_p * s + v.k_d * v.w)


def next_interval(v):
    return v.tau0 / (1 + sp.sqrt((v.w.T * v.w)[0, 0]))
