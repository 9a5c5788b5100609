"""Bai, Arcak, Wen, *Rigid body attitude coordination without inertial frame information*,
Automatica 44(12) (2008) 3170-3175: passivity-based attitude coordination from relative
attitudes only, reconstructed.

The paper's text was not available to us: the ``search`` corpora hold its citation only (e.g.
the reference list of HAL hal-02394405; Sarlette, Sepulchre, Leonard, *Autonomous rigid body
attitude synchronization*, Automatica 45 (2009) 572-577, cite the same line of work), not its
body, nor that of the authors' book *Cooperative Control Design* (Springer 2011).  What we take
from the title and from the passivity framework the paper applies (Arcak, *Passivity as a
design tool for group coordination*, IEEE TAC 52 (2007) 1380-1390): every rigid body ``i``
measures its own body rate ``w_i`` and, for each link of an undirected connected graph, the
relative attitude to the neighbour, never an attitude in an inertial frame; the torque is a
passive rate feedback plus, per link, the gradient of a link potential of the relative
attitude, expressed in body frame ``i``; the storage function (kinetic energy + link
potentials) is non-increasing, and the trajectories converge to the set where every
spacecraft's link terms cancel (Arcak 2007: ``(D x I) psi = 0``), which is ``psi = 0``
(synchronisation) on a tree and may contain other points on a graph with cycles.  Each detail
we could not read is an assumption ``P1``-``P6`` (the case file repeats them):

P1 (relative attitude, link variable).  The unit quaternion of the relative attitude
   ``R_i^T R_j`` of neighbour ``j`` seen from ``i``: ``q_ji = q_i^* (x) q_j``, vector part
   ``e_ij = q0_i q_j - q0_j q_i - q_i x q_j``, scalar part ``c_ij = q0_i q0_j + q_i . q_j``
   (Hamilton product; ``R(q)`` body to inertial, the toolbox's convention).  ``e_ij`` has
   the same coordinates in body frames ``i`` and ``j`` (it is the axis of ``R_i^T R_j``
   times ``sin(theta/2)``), and ``e_ji = -e_ij``.  Both depend on ``R_i^T R_j`` only: a
   common rotation of every attitude (``q_k -> p (x) q_k``) leaves them unchanged, which is
   the "without inertial frame information" of the title.  The unit quaternion is one of the
   parametrisations a passivity design of this kind admits (Arcak 2007's link variables; the
   quaternion passivity of P2); which one the paper's simulation uses we could not read.
P2 (link potential).  ``P_ij = 2 k_p (1 - c_ij)`` per link, whose gradient along the
   relative-attitude kinematics is ``k_p e_ij``: ``c_ij' = e_ij . (w_i - w_j) / 2``.  This is
   the passivity of the quaternion kinematics from the rate to the vector part with storage
   ``(1 - q0)^2 + |q|^2 = 2 (1 - q0)`` (Wen, Kreutz-Delgado, IEEE TAC 36 (1991);
   Lizarralde, Wen, IEEE TAC 41 (1996)), the choice of the paper's third author.
P3 (passive rate feedback).  ``f_i(w_i) = K w_i`` with ``K`` diagonal positive (the
   framework of Arcak 2007 allows any strictly passive rate feedback; linear is the simplest
   member).
P4 (reference rate, desired relative attitudes).  No reference angular velocity
   (``w^d = 0``: the group comes to rest) and identity desired relative attitudes
   (synchronisation).  From our recollection of the paper's abstract (not checked against its
   text) it also treats a common reference rate and prescribed relative attitudes; both are
   outside this file.
P5 (weights).  The link weight is the graph's ``a_ij`` (1 on the toolbox's graph specs); on an
   undirected graph ``a_ij = a_ji``, so each link's potential is ``2 k_p a_ij (1 - c_ij)``.
P6 (double cover).  The quaternions are used as integrated (not sign-chosen per step), so
   ``c_ij`` is continuous along a run; ``c_ij = -1`` is the same physical relative attitude as
   ``c_ij = 1`` but a maximum of ``P_ij`` (the unwinding of quaternion feedback).

The law (spacecraft ``i``, in-neighbours ``j``):

    ``u_i = -K w_i + k_p sum_j a_ij e_ij``.

Storage ``V = sum_i w_i^T J_i w_i / 2 + sum_links 2 k_p a_ij (1 - c_ij)``; along the closed
loop ``V' = -sum_i w_i^T K w_i <= 0`` (the gyroscopic term does no work).  Linearised at
synchronisation (``q_i ~ theta_i / 2``): ``J_i theta_i'' = -K theta_i' - (k_p / 2) sum_j a_ij
(theta_i - theta_j)``, a damped Laplacian oscillator on the graph.
"""

import numpy as np
import sympy as sp

from formsync_design.verify.metrics import register_metric

FORM = "agent"
NAME = "bai2008_passivity"
TITLE = ("Passivity-based attitude coordination from relative attitudes only "
         "(Bai, Arcak, Wen, Automatica 2008)")
REPRESENTATION = "quaternion"
GAINS = {
    "K": {"kind": "diag", "range": "1:50", "description": "passive rate-feedback (damping) gain"},
    "k_p": {"range": "1:50", "description": "link-potential (relative-attitude) gain"},
}
GRAPHS = ("undirected", "weakly-connected")  # the passivity framework: an undirected connected graph
SAMPLING = "continuous"
MEASURED = ("attitude", "rate", "neighbour-attitude")


def relative(v, n):
    """``(e_ij, c_ij)``: vector and scalar part of ``q_i^* (x) q_j`` (P1)."""
    e = v.q0 * n.q - n.q0 * v.q - v.q.cross(n.q)
    c = v.q0 * n.q0 + v.q.dot(n.q)
    return e, c


def controller(v):
    """``u_i = -K w_i + k_p sum_j a_ij e_ij`` (P1-P5): the own rate and relative attitudes only."""
    coupling = sp.zeros(3, 1)
    for n in v.nbrs:
        coupling += n.a * relative(v, n)[0]
    return -v.K * v.w + v.k_p * coupling


def monitors(v):
    """``q0_rel``: the scalar part ``c_ij`` of the relative quaternion to the first neighbour
    (P6: negative means the law turns the long way round); ``storage``: this spacecraft's
    share of the storage function, ``w^T J w / 2 + sum_j k_p a_ij (1 - c_ij)`` (each link's
    potential split between its two ends; the shares sum to ``V``)."""
    kinetic = (v.w.T * v.J * v.w)[0, 0] / 2
    potential = sum((v.k_p * n.a * (1 - relative(v, n)[1]) for n in v.nbrs), sp.Integer(0))
    q0_rel = relative(v, v.nbrs[0])[1] if v.nbrs else sp.Integer(1)
    return {"q0_rel": q0_rel, "storage": kinetic + potential}


def storage_terms(v):
    """Spacecraft ``i``'s terms of the storage function: ``(kinetic, [link potential to each
    neighbour])``, the potential ``2 k_p a_ij (1 - c_ij)`` of P2."""
    kinetic = (v.w.T * v.J * v.w)[0, 0] / 2
    links = [2 * v.k_p * n.a * (1 - relative(v, n)[1]) for n in v.nbrs]
    return kinetic, links


def dissipation(loop):
    """``D_i``: spacecraft ``i``'s share of ``V'`` along the closed loop ``loop``
    (:func:`~formsync_design.derive.agent.agent_closed_loop`): its kinetic energy's derivative
    plus the derivative of each of its link potentials with the neighbour's motion removed.
    With ``V = sum_i KE_i + sum_links P_ij`` (each link once) and an undirected graph,
    ``sum_i D_i = V'``: the link ``(i, j)`` enters ``D_i`` with ``-k_p a_ij e_ij . w_i`` (``c_ij'
    = e_ij . w_i / 2`` at frozen ``q_j``) and ``D_j`` with ``-k_p a_ij e_ji . w_j = +k_p a_ij
    e_ij . w_j``, together ``P_ij' = -k_p a_ij e_ij . (w_i - w_j)``.

    ``J w'`` is the loop's own right-hand side ``u - w x J w + d`` (checked to be ``J`` times
    the loop's ``w'``), so no symbolic ``J J^{-1}`` has to be cancelled.
    """
    from formsync_design.derive.agent import time_derivative
    from formsync_design.errors import DerivationError

    v = loop.view
    _, links = storage_terms(v)
    Jwdot = loop.u - v.w.cross(v.J * v.w) + loop.disturbance
    if v.J.inv() * Jwdot != loop.wdot:
        raise DerivationError("bai2008_passivity: the closed loop's w' is not J^-1 (u - w x J w + d)")
    frozen = dict(loop.rates)
    for n in v.nbrs:
        for s in (*n.q, n.q0):
            frozen[s] = sp.Integer(0)
    own = (v.w.T * Jwdot)[0, 0]
    return sp.expand(own + time_derivative(sum(links, sp.Integer(0)), frozen))


def conditions(c):
    """The passivity (storage) certificate, derived for every in-degree of the graph.

    Undirected graph: for each in-degree ``m``, ``D_i`` (:func:`dissipation`) is computed
    along the symbolic closed loop and checked to be exactly ``w_i^T d_i - w_i^T K w_i`` (a
    polynomial identity in the view's symbols); so ``V' = sum_i (w_i^T d_i - w_i^T K w_i)``.
    The Hessian of ``-D_i`` in ``w_i`` at ``d = 0`` gives the family ``K`` (each axis the
    box's ``K``), and ``V >= 0`` with its minimum exactly at synchronisation needs the link
    weight ``k_p > 0``: families ``> 0`` on a box prove ``V' <= 0`` on the whole box (the
    passivity part of the argument; convergence of the relative attitudes is the invariance
    argument, not decided here).

    Directed graph (outside the design's class): :func:`directed_families`, the storage
    argument's failure there, derived (every box refuted, with an exact witness).
    """
    from formsync_design.errors import DerivationError

    g = c.graph
    if not g.is_undirected:
        return directed_families(c)
    K, kp = c.gains["K"], c.gains["k_p"]
    degrees = sorted({len(g.receives_from(i)) for i in range(g.n)})
    hess = None
    for m in degrees:
        loop = c.closed_loop(m)
        v = loop.view
        D = dissipation(loop)
        expected = sp.expand((v.w.T * loop.disturbance)[0, 0] - (v.w.T * v.K * v.w)[0, 0])
        if sp.expand(D - expected) != 0:
            raise DerivationError(f"bai2008_passivity: conditions(c): V' is not w.d - w^T K w "
                                  f"for in-degree {m}")
        H = sp.hessian(-D.xreplace({s: 0 for s in loop.disturbance}), list(v.w)) / 2
        H = H.xreplace({s: K for s in v.K.diagonal()})
        hess = H if hess is None else hess
    if hess is None:
        raise DerivationError("bai2008_passivity: conditions(c): expected a graph with at least "
                              "one spacecraft, received none")
    return [
        ("dissipation: -V' = w^T K w at d = 0", hess, ("w_1", "w_2", "w_3")),
        ("storage: link-potential weight k_p", sp.Matrix([[kp]]), ("k_p",)),
    ]


def directed_families(c):
    """On a digraph the link potentials do not pair up: the storage with each arc's potential
    at its receiver, ``V = sum_i (w_i^T J_i w_i / 2 + sum_j 2 k_p a_ij (1 - c_ij))``, has
    ``V' = sum_i D_i`` with ``D_i`` the derivative of spacecraft ``i``'s terms with every
    neighbour moving; ``D_i`` is checked to be exactly ``w_i^T d_i - w_i^T K w_i + k_p sum_j
    a_ij e_ij . w_j`` (the torque's coupling work no longer cancels the potentials' motion).
    With ``e_ij`` as free variables (near synchronisation they range over a ball, independent
    of the rates), ``-D_i`` at ``d = 0`` is a quadratic form in ``(w_i, w_j, e_ij)`` whose
    ``(w_j, e_ij)`` block is ``[[0, -k_p a_ij / 2], [-k_p a_ij / 2, 0]]``: indefinite for
    every gain.  One family per in-degree (the first spacecraft of that in-degree's weights).
    This refutes this storage argument on the digraph, not the formation's stability, which
    ``formsync certify`` decides separately on the linearisation."""
    from formsync_design.derive.agent import time_derivative
    from formsync_design.errors import DerivationError

    g = c.graph
    K = c.gains["K"]
    out = []
    for m in sorted({len(g.receives_from(i)) for i in range(g.n)} - {0}):
        i = next(k for k in range(g.n) if len(g.receives_from(k)) == m)
        weights = [a for r, _, a in g.arcs if r == i]
        loop = c.closed_loop(m)
        v = loop.view
        Jwdot = loop.u - v.w.cross(v.J * v.w) + loop.disturbance
        if v.J.inv() * Jwdot != loop.wdot:
            raise DerivationError("bai2008_passivity: the closed loop's w' is not "
                                  "J^-1 (u - w x J w + d)")
        _, links = storage_terms(v)
        D = sp.expand((v.w.T * Jwdot)[0, 0] + time_derivative(sum(links, sp.Integer(0)),
                                                              loop.rates))
        coupling = sum((n.a * relative(v, n)[0].dot(n.w) for n in v.nbrs), sp.Integer(0))
        expected = ((v.w.T * loop.disturbance)[0, 0] - (v.w.T * v.K * v.w)[0, 0]
                    + v.k_p * coupling)
        if sp.expand(D - expected) != 0:
            raise DerivationError(f"bai2008_passivity: conditions(c): on a digraph V' is not "
                                  f"w.d - w^T K w + k_p sum_j a_ij e_ij . w_j for in-degree {m}")
        ebar = [sp.Matrix(sp.symbols(f"e_{n.tag}_1:4", real=True)) for n in v.nbrs]
        form = ((v.w.T * v.K * v.w)[0, 0]
                - v.k_p * sum((n.a * eb.dot(n.w) for n, eb in zip(v.nbrs, ebar)), sp.Integer(0)))
        xs = [*v.w, *(s for n, eb in zip(v.nbrs, ebar) for s in (*n.w, *eb))]
        H = sp.hessian(form, xs) / 2
        H = H.xreplace({**{s: K for s in v.K.diagonal()},
                        **{n.a: sp.Rational(a) for n, a in zip(v.nbrs, weights)}})
        labels = tuple(str(x) for x in xs)
        out.append((f"digraph storage, in-degree {m}: -V' = w^T K w - k_p sum_j a_ij e_ij . w_j "
                     "at d = 0", H, labels))
    if not out:
        raise DerivationError("bai2008_passivity: conditions(c): expected a graph with at least "
                              "one arc, received none")
    return out


@register_metric("storage_rise", unit="1", evidence="simulation",
                 doc="largest rise of the storage function V = sum_i storage_i (the monitor) "
                 "along the run above its running minimum, relative to V(0): 0 for a "
                 "non-increasing V (rounding and the integrator's error aside)")
def storage_rise(ctx):
    """The passivity claim's measurement: ``max_t (V(t) - min_{s <= t} V(s)) / V(0)`` from the
    run's ``storage`` monitor summed over the spacecraft (each link's potential is split
    between its two ends, so the sum is ``V``)."""
    r = ctx.run()
    V = np.asarray(r.monitors["storage"], dtype=float).sum(axis=1)
    if not np.all(np.isfinite(V)) or V[0] <= 0:
        return ctx.value(None, f"storage not positive and finite along the run (V(0) = {V[0]:g})")
    rise = float(np.max(V - np.minimum.accumulate(V)) / V[0])
    return ctx.value(rise, f"V(0) = {V[0]:.6g} J, V(tf) = {V[-1]:.6g} J over {len(V)} samples")
