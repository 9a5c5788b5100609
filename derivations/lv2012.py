"""Output-feedback attitude coordination without rate gyros: a lead filter synthesises the
virtual rate (Lv, Hu, Ma, Zhang, Aircraft Eng. Aerosp. Technol. 84(5), 2012), reconstructed.

The extraction of the paper kept its abstract, introduction and model (Euler's equation,
quaternion kinematics ``q' = (q0 I + q^) w / 2``, ``q0' = -q.w / 2``); the control law, the
filter, the Lyapunov function and the L2-gain condition were lost.  This file is the
reconstruction, from the literature the paper builds on; every piece is an assumption,
listed with its source in ``verification/lv2012.toml`` and in the verification report:

* **regulation** to a constant commanded attitude ``q_r`` known to the pinned spacecraft
  (``b_i > 0``), with relative-attitude coupling to the neighbours: "cooperative attitude
  regulation" (the paper's abstract) in the form of Lawton & Beard, Automatica 38 (2002),
  and Abdessameud & Tayebi, IEEE TAC 54(11) (2009);
* relative attitude by the **relative quaternion** ``q_ij = q_j^* (x) q_i`` (its vector
  part), the error to the command ``q_ei = q_r^* (x) q_i = (e_i, eta_i)`` (the abstract);
* a **lead filter** per spacecraft (Caccavale & Villani, Systems & Control Letters 38
  (1999)): ``x_i' = -a_f x_i + a_f e_i`` (``A_f = a_f I``, ``B_f = a_f I``) with the virtual
  rate ``y_i = a_f (e_i - x_i)`` -- the transfer function ``y_i(s) = a_f s/(s + a_f) e_i(s)``,
  ``~ e_i'`` below the filter bandwidth ``a_f``;
* the torque enters through ``E(q_ei)^T = (eta_i I - e_i^) / 2``, the transpose of the error
  kinematics ``e_i' = E(q_ei) w_i``: the passivity form of lead-filter output feedback
  (Lizarralde & Wen, IEEE TAC 41(3) (1996), the filter Lawton & Beard use without rate
  measurement):

      u_i = -k_p ( b_i e_i + sum_j a_ij vec(q_j^* (x) q_i) ) - k_d E(q_ei)^T y_i.

  No angular velocity appears (``MEASURED``: own and neighbours' attitudes, the command).

The storage function (derived, not typed: :func:`conditions` checks it symbolically)

    V = sum_i [ w_i^T J_i w_i / 2 + 2 k_p b_i (1 - eta_i) + k_d |y_i|^2 / (2 a_f) ]
        + sum_{i<j} 2 k_p a_ij (1 - eta_ij)

has ``V' = sum_i ( w_i^T d_i - k_d |y_i|^2 )`` along the nonlinear closed loop on an
undirected graph (``a_ij = a_ji``), for every positive gain: with ``d = 0`` every
trajectory converges to the equilibria (LaSalle), among them the commanded attitude, at
rest, whose local exponential stability and the L2 gain from ``d`` to ``z = (e_1..e_N)``
are certified on the linearisation (:mod:`formsync_design.analysis.l2gain`).

Torque bound (global, every state): ``|vec q| <= 1``, ``||E|| = 1/2`` and, from ``x_i(0)``
in the unit ball, ``|y_i| <= 2 a_f`` give ``|u_i| <= k_p (b_i + sum_j a_ij) + k_d a_f``
(:func:`torque_bound`).
"""

from __future__ import annotations

import sympy as sp

from formsync_design.verify.metrics import register_metric

FORM = "agent"
NAME = "lv2012"
TITLE = ("Lead-filter output feedback for cooperative attitude regulation without rate gyros "
         "(Lv et al. 2012, reconstructed)")
REPRESENTATION = "quaternion"
LEADER = True
GAINS = {
    "k_p": {"range": "0.5:4", "description": "attitude gain (N m): command and neighbours"},
    "k_d": {"range": "2:40", "description": "virtual-rate damping gain (N m s)"},
    "a_f": {"range": "0.1:2", "description": "lead-filter bandwidth (1/s)"},
}
STATES = {"x": 3}
MEASURED = ("attitude", "neighbour-attitude", "reference")
GRAPHS = ("undirected", "leader-reachable")
SAMPLING = "continuous"


def qmul(p, p0, r, r0):
    """``(p, p0) (x) (r, r0)`` as ``(vector, scalar)`` (the toolbox's product, Liang eq. 1)."""
    return p0 * r + r0 * p + p.cross(r), p0 * r0 - (p.T * r)[0, 0]


def conj_mul(a, a0, b, b0):
    """``vec, scalar`` of ``(a, a0)^* (x) (b, b0)``: the attitude of ``b`` relative to ``a``."""
    return qmul(-a, a0, b, b0)


def error(v):
    """``(e_i, eta_i)`` of ``q_r^* (x) q_i`` (the attitude error to the command)."""
    return conj_mul(v.ref.q, v.ref.q0, v.q, v.q0)


def coupling(v):
    """``b_i e_i + sum_j a_ij vec(q_j^* (x) q_i)``."""
    e, _ = error(v)
    s = v.b * e
    for n in v.nbrs:
        s += n.a * conj_mul(n.q, n.q0, v.q, v.q0)[0]
    return s


def virtual_rate(v):
    """``y_i = a_f (e_i - x_i)``, the lead filter's output."""
    e, _ = error(v)
    return v.a_f * (e - v.z["x"])


def controller(v):
    """``u_i = -k_p (b_i e_i + sum_j a_ij vec(q_j^* q_i)) - k_d E(q_ei)^T y_i``."""
    e, eta = error(v)
    Et = (eta * sp.eye(3) - v.hat(e)) / 2
    return -v.k_p * coupling(v) - v.k_d * Et * virtual_rate(v)


def states(v):
    """The lead filter ``x_i' = a_f (e_i - x_i)`` (= ``y_i``)."""
    return {"x": virtual_rate(v)}


def monitors(v):
    """``eta_i`` (the error quaternion's scalar part: ``e_i = 0`` at ``eta = -1`` is the
    commanded attitude reached the long way, the quaternion double cover) and ``|y_i|``."""
    _, eta = error(v)
    y = virtual_rate(v)
    return {"eta": eta, "virtual_rate": sp.sqrt((y.T * y)[0, 0])}


def storage_terms(v):
    """The spacecraft's terms of ``V`` (module docstring): ``(kinetic, command potential,
    filter energy, [edge potential to each neighbour])``."""
    _, eta = error(v)
    y = virtual_rate(v)
    kinetic = (v.w.T * v.J * v.w)[0, 0] / 2
    command = 2 * v.k_p * v.b * (1 - eta)
    filt = v.k_d * (y.T * y)[0, 0] / (2 * v.a_f)
    edges = [2 * v.k_p * n.a * (1 - conj_mul(n.q, n.q0, v.q, v.q0)[1]) for n in v.nbrs]
    return kinetic, command, filt, edges


def dissipation(loop):
    """``D_i``: spacecraft ``i``'s share of ``V'`` along the closed loop ``loop``
    (:func:`~formsync_design.derive.agent.agent_closed_loop`), with every neighbour's and the
    command's motion removed: an edge potential's own part is ``d/dt`` at frozen neighbours,
    so ``sum_i D_i = V'`` on an undirected graph (each edge's two halves add up).

    The kinetic term's derivative is ``(J w)^T w' = w^T (J w')`` with ``J w'`` the loop's own
    right-hand side ``u - w x J w + d`` (the loop's ``w'`` is checked to be ``J^{-1}`` of it,
    so no symbolic ``J J^{-1}`` has to be cancelled); the other terms are differentiated by
    :func:`~formsync_design.derive.agent.time_derivative`.
    """
    from formsync_design.derive.agent import time_derivative
    from formsync_design.errors import DerivationError

    v = loop.view
    _, command, filt, edges = storage_terms(v)
    Jwdot = loop.u - v.w.cross(v.J * v.w) + loop.disturbance
    if v.J.inv() * Jwdot != loop.wdot:
        raise DerivationError("lv2012: the closed loop's w' is not J^-1 (u - w x J w + d)")
    frozen = dict(loop.rates)
    for n in v.nbrs:
        for s in (*n.q, n.q0):
            frozen[s] = sp.Integer(0)
    for s in (*v.ref.q, v.ref.q0):
        frozen[s] = sp.Integer(0)
    rest = command + filt + sum(edges, sp.Integer(0))
    return sp.expand((v.w.T * Jwdot)[0, 0] + time_derivative(rest, frozen))


def conditions(c):
    """The nonlinear storage certificate, derived for every in-degree of the graph.

    For each in-degree ``m``: ``D_i`` (:func:`dissipation`) is computed along the symbolic
    closed loop and checked to be exactly ``w_i^T d_i - k_d |y_i|^2`` (a polynomial identity
    in the view's symbols, after substituting ``x_i = e_i - y_i / a_f``); the Hessian of
    ``-D_i`` in ``y_i`` gives the family ``k_d I_3``, and ``V >= 0`` needs the potential weight
    ``k_p`` and the filter weight ``k_d``: families ``> 0`` on every box of positive gains
    (the global part of the argument; its L2 part is :mod:`formsync_design.analysis.l2gain`).
    """
    from formsync_design.errors import DerivationError

    kp, kd = c.gains["k_p"], c.gains["k_d"]
    g = c.graph
    if not g.is_undirected:
        raise DerivationError("lv2012: conditions(c): expected an undirected graph (a_ij = a_ji: "
                              "the edge potentials' halves pair up), received a directed one")
    degrees = sorted({len(g.receives_from(i)) for i in range(g.n)})
    hess = None
    for m in degrees:
        loop = c.closed_loop(m)
        v = loop.view
        ys = sp.Matrix(sp.symbols("ybar_1:4", real=True))
        e, _ = error(v)
        sub = {v.z["x"][k]: e[k] - ys[k] / v.a_f for k in range(3)}
        sub.update({s: 0 for s in (*v.ref.w, *v.ref.wdot)})
        D = sp.expand(dissipation(loop).xreplace(sub))
        expected = sp.expand((v.w.T * loop.disturbance)[0, 0] - v.k_d * (ys.T * ys)[0, 0])
        if sp.expand(D - expected) != 0:
            raise DerivationError(f"lv2012: conditions(c): V' is not w.d - k_d |y|^2 for "
                                  f"in-degree {m}")
        H = sp.hessian(-D, list(ys)) / 2
        hess = H if hess is None else hess
    assert hess is not None
    return [
        ("dissipation: -V' = k_d |y|^2 at d = 0", hess, ("y_1", "y_2", "y_3")),
        ("storage: potential weight k_p", sp.Matrix([[kp]]), ("k_p",)),
        ("storage: filter weight k_d / a_f (a_f > 0)", sp.Matrix([[kd]]), ("k_d",)),
    ]


def torque_bound(k_p, k_d, a_f, b, degree):
    """``k_p (b_i + sum_j a_ij) + k_d a_f``: a bound of ``|u_i|`` (2-norm, so of every axis)
    valid on the whole state space when ``|x_i(0)| <= 1`` (module docstring)."""
    return k_p * (b + degree) + k_d * a_f


def filter_transfer(design):
    """``(y(s)/e(s) of the first axis as text, whether it is a_f s/(s + a_f) I)``: the lead
    filter's transfer function from the design's own expressions (reference at identity,
    ``e = q``; ``x' = A x + B e``, ``y = C x + D e`` by exact Jacobians)."""
    from formsync_design.spec.agent import agent_expressions

    ex = agent_expressions(design, 0)
    v = ex["view"]
    y = virtual_rate(v)
    xs = list(v.z["x"])
    at = {v.q0: 1, v.ref.q0: 1, **{s: 0 for s in (*v.ref.q, *v.q, *xs)}}
    xd = ex["states"]["x"]
    A, B = xd.jacobian(xs).xreplace(at), xd.jacobian(list(v.q)).xreplace(at)
    C, D = y.jacobian(xs).xreplace(at), y.jacobian(list(v.q)).xreplace(at)
    s = sp.Symbol("s")
    G = sp.simplify(C * (s * sp.eye(3) - A).inv() * B + D)
    a = design.decl.gain("a_f").symbol
    want = a * s / (s + a)
    ok = all(sp.simplify(G[i, j] - (want if i == j else 0)) == 0 for i in range(3)
             for j in range(3))
    return str(sp.factor(G[0, 0])), ok


def _this_law(design):
    return None if design.name == NAME else f"design {design.name} is not {NAME}"


@register_metric("lead_filter_transfer", unit="verdict", evidence="certificate", value="text",
                 applies=_this_law,
                 doc="the lead filter's y(s)/e(s) computed from the design's expressions (exact): "
                 "a_f s/(s + a_f) on every axis, or what it is instead")
def _lead_filter(ctx):
    text, ok = ctx.memo(("lead-filter",), lambda: filter_transfer(ctx.case.design))
    return ctx.value("a_f s/(s + a_f)" if ok else text,
                     f"y_1(s)/e_1(s) = {text}; diagonal, off-diagonal zero: {ok}")
