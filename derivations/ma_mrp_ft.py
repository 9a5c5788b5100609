"""Comparison method 3 of Ma, Dong, Ma, Wang (Fig. 6): MRP finite-time coordination.

The paper cites Zhang, Hu, Ma et al., *Distributed finite-time attitude coordinated tracking
control for multiple spacecraft systems*, Control and Decision 29(9) (2014) ([6]) and says it
was run "with the same initial conditions and parameters".  [6]'s equations were not
available to us; we take the nonsingular fast terminal sliding mode on MRP consensus errors
of that family (finite-time coordination in MRPs: [6], [9] Lyu et al. 2016, [10] Ran, Chen,
Misra 2017; the nonsingular fast terminal surface of Yu et al. 2005), leaderless (C1), with
the SO(3) design's four gains in their counterpart places (C2):

* consensus error ``e_i = sum_j a_ij (sigma_i - sigma_j)`` (MRPs on the short set, as the
  truth plant maps them; ``sigma_i`` jumps at the shadow switch), ``e_i' = sum_j a_ij
  (G(sigma_i) w_i - G(sigma_j) w_j)``;
* surface ``s_i = w_i + K1 e_i + P1 beta(e_i)`` (``beta``: :func:`formsync_design.spec.sliding.fpow`,
  the same second surface near small errors as the SO(3) design);
* reaching law ``s' = -K2 s - P2 sig^{1/2}(s)``:
  ``u_i = w x J w - J (K1 e' + P1 beta'(e) o e' + K2 s + P2 sig^{1/2}(s))``.

The weights enter unnormalised (``sum_j a_ij``, 0.37..0.61 on the paper's graph) and
``sigma ~ theta/4``: for the same gains the attitude stiffness is several times smaller than
the SO(3) design's, whose command is a normalised average and ``e_R ~ theta``.
"""

import sympy as sp

from formsync_design.spec.sliding import dfpow, fpow

FORM = "agent"
NAME = "ma_mrp_ft"
TITLE = "MRP finite-time sliding-mode coordination (comparison method 3 of Ma et al., after [6])"
REPRESENTATION = "mrp"
GAINS = {
    "K1": {"kind": "diag", "range": "0.5:2", "description": "surface gain"},
    "K2": {"kind": "diag", "range": "0.05:0.5", "description": "linear reaching gain"},
    "P1": {"kind": "diag", "range": "0.01:0.1", "description": "fractional-power surface gain"},
    "P2": {"kind": "diag", "range": "0.01:0.1", "description": "fractional-power reaching gain"},
    "eps": {"range": "1/100", "description": "threshold of the small-error surface"},
}
GRAPHS = ("spanning-tree",)
SAMPLING = "continuous"
MEASURED = ("attitude", "rate", "neighbour-attitude", "neighbour-rate")


def controller(v):
    e = sp.zeros(3, 1)
    ed = sp.zeros(3, 1)
    for n in v.nbrs:
        e += n.a * (v.sigma - n.sigma)
        ed += n.a * (v.G(v.sigma) * v.w - v.G(n.sigma) * n.w)
    s = v.w + v.K1 * e + v.P1 * e.applyfunc(lambda x: fpow(x, v.eps))
    sd_att = v.K1 * ed + v.P1 * sp.diag(*[dfpow(x, v.eps) for x in e]) * ed
    sig = s.applyfunc(lambda x: sp.sqrt(sp.Abs(x, evaluate=False)) * v.sgn(x))
    return v.w.cross(v.J * v.w) - v.J * (sd_att + v.K2 * s + v.P2 * sig)


def monitors(v):
    """``sigma_norm``: ``|sigma_i|`` (1 at the shadow switch, 180 degrees)."""
    return {"sigma_norm": sp.sqrt(v.sigma.dot(v.sigma))}
