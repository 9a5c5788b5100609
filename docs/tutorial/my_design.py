"""MRP consensus by a linear sliding surface: the design of the "write your own design" tutorial.

Spacecraft ``i`` measures its MRP ``sigma_i``, its body rate ``w_i`` and its in-neighbours'
MRPs and rates, and applies

* the consensus error ``e_i = sum_j a_ij (sigma_i - sigma_j)``, its rate
  ``e_i' = sum_j a_ij (G(sigma_i) w_i - G(sigma_j) w_j)``;
* the sliding variable ``s_i = w_i + k_1 e_i``;
* the torque ``u_i = w_i x J_i w_i - J_i (k_1 e_i' + k_2 s_i)``,

so that Euler's equation gives ``s_i' = -k_2 s_i + J_i^-1 d_i``: with ``V_i = |s_i|^2 / 2``,
``V_i' = -k_2 |s_i|^2 + s_i . J_i^-1 d_i``.  The certificate (``conditions``) derives this
along the closed loop and returns the condition ``k_2 > 0`` (with ``k_1 > 0`` for the
surface).
"""

import sympy as sp

from formsync_design.errors import DerivationError

FORM = "agent"
NAME = "my_design"
TITLE = "MRP consensus by a linear sliding surface (tutorial)"
REPRESENTATION = "mrp"
GAINS = {
    "k_1": {"range": "0.05:1", "description": "surface gain (consensus stiffness)"},
    "k_2": {"range": "0.05:1", "description": "reaching gain"},
}
GRAPHS = ("undirected", "weakly-connected")
MEASURED = ("attitude", "rate", "neighbour-attitude", "neighbour-rate")


def consensus_error(v):
    """``(e_i, e_i')``: the consensus error and its rate, from the view ``v``."""
    e = sp.zeros(3, 1)
    ed = sp.zeros(3, 1)
    for n in v.nbrs:
        e += n.a * (v.sigma - n.sigma)
        ed += n.a * (v.G(v.sigma) * v.w - v.G(n.sigma) * n.w)
    return e, ed


def controller(v):
    e, ed = consensus_error(v)
    s = v.w + v.k_1 * e
    return v.w.cross(v.J * v.w) - v.J * (v.k_1 * ed + v.k_2 * s)


def monitors(v):
    """``sigma_norm``: ``|sigma_i|`` (1 at the shadow switch, 180 degrees)."""
    return {"sigma_norm": sp.sqrt(v.sigma.dot(v.sigma))}


def conditions(c):
    """Derive ``s_i' = -k_2 s_i + J^-1 d_i`` along the closed loop, for every in-degree.

    ``J s_i' = J w_i' + k_1 J e_i'`` with ``J w_i' = u_i - w_i x J w_i + d_i`` (Euler's
    equation, so no symbolic ``J J^-1`` has to be cancelled) and ``e_i'`` differentiated
    along the loop.  Then ``V_i = |s_i|^2 / 2`` has ``V_i' = -k_2 |s_i|^2 + s_i . J^-1 d_i``.
    """
    k_1, k_2 = c.gains["k_1"], c.gains["k_2"]
    for m in sorted({len(c.graph.receives_from(i)) for i in range(c.graph.n)}):
        loop = c.closed_loop(m)
        v = loop.view
        e, _ = consensus_error(v)
        s = v.w + v.k_1 * e
        J_sdot = loop.u - v.w.cross(v.J * v.w) + loop.disturbance + v.k_1 * v.J * c.time_derivative(e, loop)
        if sp.expand(J_sdot + k_2 * v.J * s - loop.disturbance) != sp.zeros(3, 1):
            raise DerivationError(f"my_design: s' is not -k_2 s + J^-1 d for in-degree {m}")
    return [("reaching: V' = -k_2 |s|^2 at d = 0", sp.Matrix([[k_2]]), ("s",)),
            ("surface gain", sp.Matrix([[k_1]]), ("e",))]
