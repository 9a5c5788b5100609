"""Test design: MRP consensus with a leader (pinning b_i), a smoothed switching term and a
diagonal gain (FORM = "agent").

``chi = sum_j a_ij (sigma_i - sigma_j) + b (sigma_i - sigma_ref)``,
``u = w x J w - J (K chi + k_d (w - w_ref) + k_s sgn(w - w_ref))``.
"""

FORM = "agent"
NAME = "agent_mrp_leader"
REPRESENTATION = "mrp"
LEADER = True
GAINS = {"K": {"kind": "diag", "range": "0.1:2"}, "k_d": {"range": "0.5:3"},
         "k_s": {"range": "0.001:0.1"}}
GRAPHS = ("leader-reachable",)


def controller(v):
    chi = v.b * (v.sigma - v.ref.sigma)
    for n in v.nbrs:
        chi += n.a * (v.sigma - n.sigma)
    e = v.w - v.ref.w
    return v.w.cross(v.J * v.w) - v.J * (v.K * chi + v.k_d * e + v.k_s * v.sgn(e))
