"""Comparison method 2 of Ma, Dong, Ma, Wang (Fig. 6): quaternion sliding-mode coordination.

The paper cites Huang, Wang, Duan, *Distributed attitude control for multiple flexible
spacecraft under actuator failures and saturation*, Nonlinear Dyn. 88 (2017) ([11]) for this
method and says it was run "with the same initial conditions and parameters".  Huang et
al.'s equations were not available to us (only their introduction); we take the standard
distributed quaternion sliding-mode coordination law of that family (Wu, Wang, Poh, *Int. J.
Robust Nonlinear Control* 23 (2013), the paper's [29]: relative-quaternion sliding surface,
exponential reaching law of Gao & Hung 1993), without the flexible modes, faults and
saturation of [11] (assumption B1), with the SO(3) design's gains where they have a
counterpart (B2: ``K1`` the surface gain, ``K2`` the linear and ``P2`` the switching reaching
gain):

* relative attitude ``q_ij = q_j^* (x) q_i`` (vector part ``q0_j q_i - q0_i q_j - q_j x q_i``),
  relative rate ``w_ij = w_i - R(q_ij)^T w_j``, ``q_ij' = (q0_ij I + q_ij^) w_ij / 2``;
* surface ``s_i = w_i + K1 sum_j a_ij q_ij`` (on ``s = 0``: first-order kinematic consensus);
* reaching law ``s' = -K2 s - P2 sgn(s)``:
  ``u_i = w x J w - J (K1 sum_j a_ij q_ij' + K2 s_i + P2 sgn(s_i))``.

The quaternions are used as integrated (their sign is not chosen per step): the law has the
quaternion's double cover, which the paper names as this method's drawback.
"""

import sympy as sp

FORM = "agent"
NAME = "ma_quat_smc"
TITLE = "Quaternion sliding-mode coordination (comparison method 2 of Ma et al., after [11], [29])"
REPRESENTATION = "quaternion"
GAINS = {
    "K1": {"kind": "diag", "range": "0.5:2", "description": "sliding-surface gain"},
    "K2": {"kind": "diag", "range": "0.05:0.5", "description": "linear reaching gain"},
    "P2": {"kind": "diag", "range": "0.01:0.1", "description": "switching reaching gain"},
}
GRAPHS = ("spanning-tree",)
SAMPLING = "continuous"
MEASURED = ("attitude", "rate", "neighbour-attitude", "neighbour-rate")


def relative(v, n):
    """``(q_ij vector, q0_ij, w_ij)`` of spacecraft ``i`` (view ``v``) to neighbour ``n``."""
    qv = n.q0 * v.q - v.q0 * n.q - n.q.cross(v.q)
    q0 = n.q0 * v.q0 + n.q.dot(v.q)
    Rij = (q0**2 - qv.dot(qv)) * sp.eye(3) + 2 * qv * qv.T + 2 * q0 * v.hat(qv)
    return qv, q0, v.w - Rij.T * n.w


def controller(v):
    eps = sp.zeros(3, 1)
    epsd = sp.zeros(3, 1)
    for n in v.nbrs:
        qv, q0, wij = relative(v, n)
        eps += n.a * qv
        epsd += n.a * (q0 * sp.eye(3) + v.hat(qv)) * wij / 2
    s = v.w + v.K1 * eps
    return v.w.cross(v.J * v.w) - v.J * (v.K1 * epsd + v.K2 * s + v.P2 * v.sgn(s))


def monitors(v):
    """``q0_rel``: the scalar part of the relative quaternion to the first in-neighbour (its
    sign shows the double cover: negative means the law pushes the long way round)."""
    if not v.nbrs:
        return {"q0_rel": sp.Integer(1)}
    return {"q0_rel": relative(v, v.nbrs[0])[1]}
