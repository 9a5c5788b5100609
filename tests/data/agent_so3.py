"""Test design: geometric PD consensus on SO(3) on a weighted digraph (FORM = "agent").

``e_i = sum_j a_ij (1/2) vee(R_j^T R_i - R_i^T R_j)``, ``u = w x J w - J (k_R e_i + k_w w)``;
a monitor records ``tr(R_j^T R_i)`` of the first in-neighbour (E singular where it is +-1).
"""

import sympy as sp

FORM = "agent"
NAME = "agent_so3"
REPRESENTATION = "so3"
GAINS = {"k_R": {"range": "0.1:2"}, "k_w": {"range": "0.5:3"}}
GRAPHS = ("spanning-tree",)


def controller(v):
    e = sp.zeros(3, 1)
    for n in v.nbrs:
        e += n.a * v.vee(n.R.T * v.R - v.R.T * n.R) / 2
    return v.w.cross(v.J * v.w) - v.J * (v.k_R * e + v.k_w * v.w)


def monitors(v):
    if not v.nbrs:
        return {"trace": sp.Integer(3)}
    return {"trace": (v.nbrs[0].R.T * v.R).trace()}


def conditions(c):
    """A plumbing test (not a derivation): both gains positive, and k_w^2 > k_R / 2."""
    k_R, k_w = c.gains["k_R"], c.gains["k_w"]
    return [("gains", sp.diag(k_R, k_w), ("e_R", "w")),
            ("damping", sp.Matrix([[k_w, k_R / 2], [k_R / 2, k_w]]), ("e_R", "w"))]
