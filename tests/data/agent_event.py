"""Test design: event-triggered quaternion consensus (FORM = "agent").

Broadcast when ``|q_i - qhat_i|^2 >= delta^2`` (own state against own last broadcast).
"""

FORM = "agent"
NAME = "agent_event"
REPRESENTATION = "quaternion"
SAMPLING = "event"
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3"}, "delta": {"range": "0.001:0.1"}}


def controller(v):
    s = v.q * 0
    for n in v.nbrs:
        s += n.a * (v.q - n.q)
    return -v.J * (v.k_p * s + v.k_d * v.w)


def event(v):
    e = v.q - v.held.q
    return (e.T * e)[0, 0] - v.delta**2
