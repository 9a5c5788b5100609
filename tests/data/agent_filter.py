"""Test design: attitude-only feedback with a first-order filter state (FORM = "agent").

``x' = -lam (x - q)``; the filter output ``y = lam (q - x)`` approximates ``q'``;
``u = -k_p J sum_j a_ij (q_i - q_j) - k_d J y``.  No body rate anywhere in the law.
"""

FORM = "agent"
NAME = "agent_filter"
REPRESENTATION = "quaternion"
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3"}, "lam": {"range": "1:10"}}
STATES = {"x": 3}
MEASURED = ("attitude", "neighbour-attitude")
GRAPHS = ("weakly-connected",)


def controller(v):
    s = v.q * 0
    for n in v.nbrs:
        s += n.a * (v.q - n.q)
    y = v.lam * (v.q - v.z["x"])
    return -v.J * (v.k_p * s + v.k_d * y)


def states(v):
    return {"x": -v.lam * (v.z["x"] - v.q)}
