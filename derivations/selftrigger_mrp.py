"""Self-triggered MRP attitude coordination with a leader under disturbances (seed 001).

Source: the patent text of seed 001 (``001_de7425a80ad5ec92.txt``, not shipped; self-triggered
attitude cooperative control of a spacecraft formation under disturbances).  Its words
survive, every formula was lost in extraction; each formula below is a **reconstruction**
(R1-R7), written down with its source and checked by the derivation
(:func:`conditions`, ``formsync verify selftrigger_mrp``).

Plant (patent s1; MRP kinematics as the issue restates them)
    ``sigma_i' = G(sigma_i) w_i``, ``G = 1/4 [(1 - |sigma|^2) I + 2 sigma^x + 2 sigma sigma^T]``,
    ``J_i w_i' = -w_i^x J_i w_i + u_i + d_i`` (``d_i`` the lumped disturbance).  The toolbox
    integrates the unit quaternion and hands the design the short-set MRP (the shadow switch
    happens where the integrated ``q0`` changes sign).

R1 errors (patent s22-s24, words exact: neighbours' states *at their own last trigger*)
    ``chi_1i = sum_j a_ij (sigma_i - sigma_j(t^j_k)) + b_i (sigma_i - sigma_d)``,
    ``chi_2i = sum_j a_ij (w_i - w_j(t^j_k)) + b_i (w_i - w_d)``, ``s_i = r chi_1i + chi_2i``.
    With ``y = r sigma + w``: ``s_i = D_i y_i - sum_j a_ij y_j(t^j_k) - b_i y_d``,
    ``D_i = sum_j a_ij + b_i`` (> 0 on a graph where the leader reaches every spacecraft).
R2 intermediate variable (patent s2: "built from the derivative of chi_1i, the rate and
    w_d' at the trigger time")
    ``upsilon_i = r chi_1i' - b_i w_d'`` with ``chi_1i' = D_i G(sigma_i) w_i - b_i G(sigma_d) w_d``
    (the neighbours' broadcasts are constant between their triggers).
R3 control law (patent s2, "feedback coefficient m > 1"; a feedback-linearising sliding-mode
    law of the kind used for MRP formation control with leaders, e.g. Ren, "Distributed
    cooperative attitude synchronization and tracking for multiple rigid bodies", IEEE TCST
    18(2), 2010, evaluated at the trigger and held, as in Dimarogonas, Frazzoli, Johansson,
    IEEE TAC 57(5), 2012)
    ``u_i(t) = [w_i^x J_i w_i - J_i (upsilon_i + m s_i) / D_i]`` at ``t = t^i_k``, held until
    ``t^i_{k+1}``.  Continuously applied it gives ``s_i' = -m s_i + D_i J_i^{-1} d_i`` (derived
    and checked in :func:`conditions`).
R4 measurement error (patent s2: "between s_i at the last trigger and now")
    ``e_i(t) = s_i(t^i_k) - sbar_i(t)``, ``sbar_i`` = ``s_i`` with the neighbours'
    broadcasts *as used at* ``t^i_k`` (own state and the leader now).  It depends only on the
    spacecraft's own motion and the leader's, as the patent's "the trigger mechanism does not
    need the neighbours' continuous states" requires, and it is continuous between own
    triggers.  Under the held law ``e_i' = m s_i(t^i_k) - f_i`` with the **nonlinear term**
    ``f_i(t) = F_i(t) - F_i(t^i_k) + D_i J_i^{-1} d_i(t)``, ``F_i = upsilon_i - D_i J_i^{-1}
    w_i^x J_i w_i``; ``delta >= |f_i|`` (patent: "delta is the upper bound of |f_i|").
R5 dynamic variable (patent: "eta_i, eta_i(0), eta_i', alpha and one more positive
    constant"; Girard, "Dynamic triggering mechanisms for event-triggered control", IEEE TAC
    60(7), 2015, with the state-dependent input set to zero, i.e. the exponentially decaying
    threshold of Seyboth, Dimarogonas, Johansson, Automatica 49(1), 2013)
    ``eta_i' = -alpha eta_i``, ``eta_i(0) = eta0``; the other constant is the floor ``eps``.
R6 trigger threshold (the role of ``m > 1``)
    keep ``|e_i(t)| <= (1 - 1/m) |s_i(t^i_k)| + eps + eta_i(t)``.  With the threshold
    ``theta = 1 - 1/m`` the held loop decreases ``|sbar_i|^2 / 2`` at least like the
    unit-rate loop at the held value (``-m|w|^2 + m|e||w| <= -|w|^2``): ``m > 1`` is exactly
    the condition for a positive relative threshold.
R7 self-trigger (patent s3-s4: next time from the state at the current one, no logarithm)
    ``|e_i(t)| <= (m |s_i(t_k)| + delta)(t - t_k)`` and ``eta_i(t) >= eta_i(t_k)(1 - alpha
    (t - t_k))`` (``exp(-x) >= 1 - x``) give the largest safe interval in closed form,
    ``tau_i = ((1 - 1/m)|s_i| + eps + eta_i) / (m |s_i| + delta + alpha eta_i)`` at ``t_k``
    (earlier self-triggered rules solve for an exponential bound's crossing, i.e. take
    logarithms: Dimarogonas, Frazzoli, Johansson 2012, section IV).  By the mediant
    inequality ``tau_i >= min((m - 1)/m^2, eps/delta, 1/alpha)``: no Zeno behaviour.

The event-triggered variant checks the same ``|e_i|`` against the same threshold
continuously (:func:`event_rule`, with :func:`hold` storing ``s_i(t_k)`` and the
neighbours' part at each broadcast); the periodic variant holds the same law with a fixed
period.  Both are built by :func:`formsync_design.spec.agent.rule_variant` (an engine
scenario's ``sampling = "event" | "periodic"``).

The certificate (:func:`conditions`) and the inter-event bound
(:func:`formsync_design.analysis.triggering.interevent_bound`) are derived from these
expressions; the case-dependent conditions (the leader's rate bound, the disturbance part of
``delta``) are metrics of the engine case ``verification/selftrigger_mrp.toml``.  The
measurements only this design defines (the nonlinear term ``f_i`` against ``delta``, the
measurement error against its threshold, the staleness and ``Delta`` over the tail, and the
two ISS ultimate bounds they feed: :mod:`formsync_design.analysis.sliding_iss`) are metrics
registered at the end of this file (:func:`sliding_measurements`).
"""

import math

import numpy as np
import sympy as sp

from formsync_design.verify.metrics import register_metric

FORM = "agent"
NAME = "selftrigger_mrp"
TITLE = "Self-triggered MRP attitude coordination with a leader (patent seed 001, reconstructed)"
REPRESENTATION = "mrp"
LEADER = True
SAMPLING = "self-triggered"
GRAPHS = ("leader-reachable",)
#: Kept at each broadcast (:func:`hold`): ``s_i(t_k)`` and the neighbours' part ``c_i(t_k)``.
HOLD = {"s": 3, "c": 3}
GAINS = {
    "r": {"range": "1/10:2", "description": "sliding-surface slope r > 0 (s = r chi_1 + chi_2)"},
    "m_f": {"range": "21/20:3", "description": "the patent's feedback coefficient m > 1 (m_f here: m is the view's in-degree)"},
    "delta": {"range": "1/10000:1/10",
              "description": "bound delta >= |f_i| on the nonlinear term (rad/s^2)"},
    "eps": {"range": "1/100000:1/100", "description": "constant floor of the threshold (rad/s)"},
    "alpha": {"range": "1/100:1", "description": "decay rate of the dynamic variable eta_i (1/s)"},
    "eta0": {"range": "1/10000:1", "description": "initial value eta_i(0) (rad/s)"},
    "mu": {"role": "multiplier", "range": "1/100000:1",
           "description": "S-procedure multiplier of the triggered reaching condition"},
}
#: The theorem's operating region: short-set MRPs of norm <= rho, a leader rate <= omega_d_max.
OPERATING_REGION = {"rho": "3/5", "omega_d_max": "1/20"}


def _norm(x):
    return sp.sqrt((x.T * x)[0, 0])


def parts(v):
    """The quantities R1-R2 of the view ``v``: ``D``, the neighbours' part ``c = sum_j a_ij
    y_j(t^j_k)``, ``y = r sigma + w``, ``y_d``, ``s``, ``upsilon``."""
    D = v.b + sum((n.a for n in v.nbrs), sp.Integer(0))
    c = sp.zeros(3, 1)
    chi1 = v.b * (v.sigma - v.ref.sigma)
    chi2 = v.b * (v.w - v.ref.w)
    for n in v.nbrs:
        c += n.a * (v.r * n.sigma + n.w)
        chi1 += n.a * (v.sigma - n.sigma)
        chi2 += n.a * (v.w - n.w)
    s = v.r * chi1 + chi2
    chi1_dot = D * v.G(v.sigma) * v.w - v.b * v.G(v.ref.sigma) * v.ref.w
    upsilon = v.r * chi1_dot - v.b * v.ref.wdot
    y = v.r * v.sigma + v.w
    y_d = v.r * v.ref.sigma + v.ref.w
    return {"D": D, "c": c, "s": s, "upsilon": upsilon, "y": y, "y_d": y_d}


def theta(m):
    """R6: the relative threshold ``1 - 1/m``."""
    return 1 - 1 / m


def eta(v):
    """R5: ``eta_i(t) = eta0 exp(-alpha t)``."""
    return v.eta0 * sp.exp(-v.alpha * v.t)


def controller(v):
    """R3 (evaluated at the trigger, held)."""
    p = parts(v)
    return v.w.cross(v.J * v.w) - v.J * (p["upsilon"] + v.m_f * p["s"]) / p["D"]


def next_interval(v):
    """R7: the self-trigger interval from the state at the current trigger."""
    S = _norm(parts(v)["s"])
    h = eta(v)
    return (theta(v.m_f) * S + v.eps + h) / (v.m_f * S + v.delta + v.alpha * h)


def hold(v):
    """Kept at each broadcast (every variant; the event rule reads them): ``s_i(t_k)`` and
    the neighbours' part ``c_i(t_k)`` (so ``sbar_i(t) = D y_i(t) - c - b y_d(t)``)."""
    p = parts(v)
    return {"s": p["s"], "c": p["c"]}


def measurement_error(v, s_k, c_k):
    """R4: ``e_i(t) = s_i(t_k) - sbar_i(t)``."""
    p = parts(v)
    return s_k - (p["D"] * p["y"] - c_k - v.b * p["y_d"])


def event_rule(v):
    """The event-triggered variant: broadcast when ``|e_i|^2 >= threshold^2`` (R4, R6)."""
    e = measurement_error(v, v.kept["s"], v.kept["c"])
    thr = theta(v.m_f) * _norm(v.kept["s"]) + v.eps + eta(v)
    return (e.T * e)[0, 0] - thr**2


def graph_weights(graph):
    """``K = P (L + B) Dbar^{-1}`` (exact) of a digraph with pinning: ``Dbar = diag(D_i)``
    and ``P = diag(w_i / v_i)`` with ``v = M^{-1} 1``, ``w = M^{-T} 1`` for the nonsingular
    M-matrix ``M = (L + B) Dbar^{-1}`` (Zhang, Lewis, Das, "Optimal design for
    synchronization of cooperative systems", IEEE TAC 56(8), 2011, Lemma 3 / Qu 2009:
    ``P M + M^T P`` is then positive definite)."""
    n = graph.n
    H = sp.zeros(n, n)
    for i, j, a in graph.arcs:
        H[i, j] -= sp.Rational(a.numerator, a.denominator)
        H[i, i] += sp.Rational(a.numerator, a.denominator)
    for i, b in enumerate(graph.pinning):
        H[i, i] += sp.Rational(b.numerator, b.denominator)
    Dbar = sp.diag(*[H[i, i] for i in range(n)])
    if any(Dbar[i, i] == 0 for i in range(n)):
        raise ValueError("a spacecraft receives nothing (D_i = 0): the leader does not reach it")
    M = H * Dbar.inv()
    one = sp.ones(n, 1)
    v = M.LUsolve(one)
    w = M.T.LUsolve(one)
    P = sp.diag(*[w[i] / v[i] for i in range(n)])
    return P * M


def _check_law(c):
    """Derivation checks of R2-R3 on the closed loop of every in-degree of the graph, by the
    engine's chain rule (``c.time_derivative``), with the rate derivative ``w'`` a free symbol
    ``W`` and the neighbours' broadcasts frozen (the local sliding variable ``sbar``):

    * the drift of ``sbar`` (``W = 0``) is exactly ``upsilon`` (R2), and
    * ``D (u - w x J w) = -J (upsilon + m s)`` (R3),

    hence ``J sbar' = J(-m s) + D d`` under the continuously applied law, i.e.
    ``sbar' = -m s + D J^{-1} d``, and under the held law ``sbar' = -m s(t_k) + f``."""
    g = c.graph
    for deg in sorted({len(g.receives_from(i)) for i in range(g.n)}):
        cl = c.closed_loop(deg)
        v = cl.view
        p = parts(v)
        frozen = {n_s for n in v.nbrs for n_s in (*n.sigma, *n.w)}
        W = sp.Matrix(sp.symbols("W_1:4", real=True))
        rates = {k: val for k, val in cl.rates.items() if k not in frozen}
        for k in range(3):
            rates[v.w[k]] = W[k]
        drift = c.time_derivative(p["s"], rates).subs({W[k]: 0 for k in range(3)})
        if (drift - p["upsilon"]).applyfunc(sp.expand) != sp.zeros(3, 1):
            raise ValueError(f"the drift of s (in-degree {deg}) is not upsilon")
        lhs = p["D"] * (cl.u - v.w.cross(v.J * v.w)) + v.J * (p["upsilon"] + v.m_f * p["s"])
        if lhs.applyfunc(sp.expand) != sp.zeros(3, 1):
            raise ValueError(f"the law does not cancel the model (in-degree {deg})")


def surface_identity(c):
    """The sliding-surface derivative, derived: on ``s = 0`` (``w = w_d - r (sigma - sigma_d)``)
    ``W = |sigma - sigma_d|^2 / 2`` has ``W' = -r/4 [(1 - |sigma|^2)|e|^2 + 2 (sigma.e)^2]
    + e^T (G(sigma) - G(sigma_d)) w_d`` (``e = sigma - sigma_d``); checked exactly.  With
    ``|sigma|, |sigma_d| <= rho`` and ``|w_d| <= wbar`` the last term is at most
    ``3/2 rho wbar |e|^2`` (tested numerically), so ``r (1 - rho^2) > 6 rho wbar`` makes the
    surface attractive."""
    cl = c.closed_loop(0)
    v = cl.view
    e = v.sigma - v.ref.sigma
    Wf = (e.T * e)[0, 0] / 2
    dW = c.time_derivative(Wf, cl).subs(
        {v.w[k]: (v.ref.w - v.r * e)[k] for k in range(3)}, simultaneous=True)
    ss = (v.sigma.T * v.sigma)[0, 0]
    se = (v.sigma.T * e)[0, 0]
    claim = (-v.r / 4 * ((1 - ss) * (e.T * e)[0, 0] + 2 * se**2)
             + (e.T * (v.G(v.sigma) - v.G(v.ref.sigma)) * v.ref.w)[0, 0])
    if sp.expand(dW - claim) != 0:
        raise ValueError("the sliding-surface derivative differs from its closed form")
    return dW


def conditions(c):
    """The certificate (module docstring; derivation in the verification report):

    ``reaching``: with ``V = s^T (P (x) I) s / 2`` over the true sliding variables, the held
    law ``s' = (M (x) I)(-m w + Delta)`` (``w`` the held values) and a trigger keeping
    ``|e_i| <= theta |w_i| (+ eps + eta_i)``, ``theta = 1 - 1/m``, the S-procedure on
    ``ehat = e/theta`` (``|ehat_i| <= |w_i|``) gives ``V' <= -lambda (|w|^2 + |ehat|^2) + ...``
    when ``m [[Sym K - mu P, -theta K^T/2], [-theta K/2, mu P]] > lambda I``
    (``K = P M``, :func:`graph_weights`; S-procedure multipliers ``mu p_i``);
    ``m > 1``: the relative threshold is positive; ``surface``: :func:`surface_identity`.
    """
    _check_law(c)
    surface_identity(c)
    m, mu, r = c.gains["m_f"], c.gains["mu"], c.gains["r"]
    K = graph_weights(c.graph)
    n = K.shape[0]
    th = sp.expand(theta(m) * m)  # m theta = m - 1: the family stays affine in m
    sym = (K + K.T) / 2
    P = sp.diag(*[K[i, i] for i in range(n)])  # diag(K) = P (M_ii = 1)
    top = m * (sym - mu * P)
    off = -th * K.T / 2
    Phi = sp.BlockMatrix([[top, off], [off.T, m * mu * P]]).as_explicit()
    rho = sp.Rational(OPERATING_REGION["rho"])
    wbar = sp.Rational(OPERATING_REGION["omega_d_max"])
    labels = tuple(f"w_{i + 1}" for i in range(n)) + tuple(f"ehat_{i + 1}" for i in range(n))
    return [
        ("reaching", Phi, labels),
        ("threshold", sp.Matrix([[m - 1]]), ("m-1",)),
        ("surface", sp.Matrix([[r * (1 - rho**2) - 6 * rho * wbar]]), ("r",)),
    ]


# ------------------------------------------------------------------ measurements (metrics)


def _gain(formation, name):
    v = formation.gains.as_dict()[name]
    return float(v[0] if isinstance(v, tuple) else v)


def sliding_measurements(design, f, opt, res, rec, tail):
    """Measured on the output grid of a run of this law (any sampling rule; ``design``: this
    self-triggered design, whose kernel's plant gives the rate derivatives), with ``k`` the
    spacecraft's last update: the measurement error ``e_i = s_i(t_k) - sbar_i(t)`` against the
    threshold ``(1 - 1/m)|s_i(t_k)| + eps + eta0 exp(-alpha t)`` (``e_ratio``: the largest
    ratio); the nonlinear term ``f_i = sbar_i' + m s_i(t_k)`` against ``delta`` (``f_ratio``;
    ``sbar_i' = D_i y_i' - b_i y_d'``, the rate derivative from the plant, disturbance
    included); over the last ``tail`` of the horizon the staleness ``xi_i = sum_j a_ij y_j(t)
    - c_i(t_k)``, ``Delta_i = f_i - d_i y_d'`` (sups of the stacked 2-norms), the threshold
    floors ``c_norm = sqrt(N) (eps + eta_i)`` and the largest ``|sigma_i - sigma_d|``
    (``tail_sigma_error``); ``sigma_max`` the largest ``|sigma_i|`` and ``|sigma_d|`` seen."""
    from formsync_design.models.mrp import mrp_rate_matrix
    from formsync_design.sim.agent_kernel import agent_parameters, get_agent_kernel
    from formsync_design.sim.agent_sampled import attitude_entries_np, reference_trajectory

    n = f.n
    r, m = _gain(f, "r"), _gain(f, "m_f")
    delta, eps, alpha, eta0 = (_gain(f, k) for k in ("delta", "eps", "alpha", "eta0"))
    g = f.graph
    A = g.adjacency
    b = g.pinning_matrix.diagonal()
    D = A.sum(axis=1) + b
    t = res.t
    T = len(t)
    sig = np.array([[attitude_entries_np("mrp", res.quaternions[k, i]) for i in range(n)]
                    for k in range(T)])
    W = res.rates
    ref_at = reference_trajectory(f.reference, float(t[-1]))
    sig_d = np.array([attitude_entries_np("mrp", q) for q in res.reference])
    wd = np.array([ref_at(tk)[1] for tk in t])
    wdd = np.array([ref_at(tk)[2] for tk in t])
    y = r * sig + W
    y_d = r * sig_d + wd
    yd_dot = np.array([r * mrp_rate_matrix(sig_d[k]) @ wd[k] + wdd[k] for k in range(T)])
    kern = get_agent_kernel(design, f.neighbours(), opt.switch, 1, 1, f.reference.rate,
                            compile=False)
    p = agent_parameters(design, f, opt, kern.layout)
    wdot = np.empty_like(W)
    for k in range(T):
        x = np.concatenate([res.quaternions[k].ravel(), W[k].ravel(), [0.0, 0.0, 0.0, 1.0]])
        dx = np.asarray(kern.plant(x, res.torques[k].ravel(), t[k], p)).ravel()
        wdot[k] = dx[4 * n: 7 * n].reshape(n, 3)
    y_dot = np.array([[r * mrp_rate_matrix(sig[k, i]) @ W[k, i] + wdot[k, i] for i in range(n)]
                      for k in range(T)])
    hyb = rec["hybrid"]
    kept = rec["kept"]
    trig = [np.asarray(ts) for ts in hyb.trigger_times]
    s_k = np.empty((T, n, 3))
    c_k = np.empty((T, n, 3))
    for i in range(n):
        idx = np.searchsorted(trig[i], t, side="right") - 1  # the update in force (right-continuous)
        s_k[:, i] = kept[i][idx, :3]
        c_k[:, i] = kept[i][idx, 3:6]
    sbar = D[None, :, None] * y - c_k - b[None, :, None] * y_d[:, None, :]
    e = s_k - sbar
    thr = (1 - 1 / m) * np.linalg.norm(s_k, axis=2) + eps + eta0 * np.exp(-alpha * t)[:, None]
    f_term = D[None, :, None] * y_dot - b[None, :, None] * yd_dot[:, None, :] + m * s_k
    xi = np.einsum("ij,tjk->tik", A, y) - c_k
    Delta = f_term - A.sum(axis=1)[None, :, None] * yd_dot[:, None, :]
    tail_mask = t >= t[-1] * (1 - tail) - 1e-9
    sig_err = np.linalg.norm(sig - sig_d[:, None, :], axis=2)

    def sup_norm(X):
        return float(np.linalg.norm(X[tail_mask].reshape(int(tail_mask.sum()), -1), axis=1).max())

    return {
        "tail_sigma_error": float(sig_err[tail_mask].max()),
        "f_ratio": float((np.linalg.norm(f_term, axis=2) / delta).max()),
        "e_ratio": float((np.linalg.norm(e, axis=2) / thr).max()),
        "sigma_max": float(max(np.linalg.norm(sig, axis=2).max(), np.linalg.norm(sig_d, axis=1).max())),
        "staleness": sup_norm(xi), "delta_norm": sup_norm(Delta),
        "c_norm": float(math.sqrt(n) * (eps + eta0 * math.exp(-alpha * t[tail_mask][0]))),
    }


def _this_law(design):
    return None if design.name == NAME else f"the metric measures {NAME}'s law, not {design.name}"


def _measured(ctx):
    """The measurements of the run of ``ctx`` (cached per formation, scenario and draw)."""

    def compute():
        return sliding_measurements(ctx.case.design, ctx.initial(), ctx.options(), ctx.run(),
                                    ctx.record(), TAIL)

    return ctx.memo(("sliding",) + ctx.key(), compute)


#: The tail (last fraction of the horizon) of the ISS measurements.
TAIL = 0.2


@register_metric("nonlinear_term_ratio", unit="1", evidence="simulation", applies=_this_law,
                 doc="max over the run of |f_i| / delta: at most 1 is the rule's assumption "
                 "delta >= |f_i| (the self-trigger's and tau_min's premise)")
def nonlinear_term_ratio(ctx):
    return ctx.value(_measured(ctx)["f_ratio"], "on the output grid, every spacecraft")


@register_metric("error_threshold_ratio", unit="1", evidence="simulation", applies=_this_law,
                 doc="max over the run of |e_i| / ((1 - 1/m)|s_i(t_k)| + eps + eta_i): at most "
                 "1 is the trigger's guarantee")
def error_threshold_ratio(ctx):
    return ctx.value(_measured(ctx)["e_ratio"], "on the output grid, every spacecraft")


@register_metric("tail_mrp_error", unit="1", evidence="simulation", applies=_this_law,
                 doc="max |sigma_i - sigma_d| over the last 20 % of the horizon (the quantity "
                 "the ISS bounds bound)")
def tail_mrp_error(ctx):
    return ctx.value(_measured(ctx)["tail_sigma_error"], "every spacecraft")


@register_metric("mrp_norm_max", unit="1", evidence="simulation", applies=_this_law,
                 doc="the largest |sigma_i| and |sigma_d| seen in the run (the operating region "
                 "needs it <= rho)")
def mrp_norm_max(ctx):
    return ctx.value(_measured(ctx)["sigma_max"], f"rho = {OPERATING_REGION['rho']}")


@register_metric("min_inter_event_within_delta", unit="s", evidence="simulation",
                 applies=_this_law,
                 doc="the run's shortest inter-event time when |f_i| <= delta held throughout "
                 "(where tau_min bounds an event-triggered interval); unknown otherwise")
def min_inter_event_within_delta(ctx):
    fr = _measured(ctx)["f_ratio"]
    r = ctx.run()
    if fr > 1:
        return ctx.value(None, f"outside the delta assumption (max |f|/delta = {fr:.4g})")
    v = np.asarray(r.min_interevent, float)
    v = v[np.isfinite(v)]
    if not v.size:
        return ctx.value(None, "fewer than two updates per spacecraft")
    return ctx.value(float(v.min()), f"max |f|/delta = {fr:.4g} <= 1")


def _iss_inputs(ctx):
    fam = ctx.families()
    reach = next((x for x in fam.families if x.name == "reaching"), None)
    if str(fam.status) != "certified" or reach is None or reach.lower is None:
        return None, f"no certified reaching margin ({fam.status})"
    gains = {k: float(v[0] if isinstance(v, tuple) else v)
             for k, v in ctx.case.gains.as_dict().items()}
    return (float(reach.lower), gains, _measured(ctx)), ""


def _vacuous(design, bound):
    from fractions import Fraction

    from formsync_design.analysis.sliding_iss import iss_vacuous

    two_rho = 2 * float(Fraction(OPERATING_REGION["rho"]))
    return f"{'vacuous' if iss_vacuous(design, bound) else 'not vacuous'} (2 rho = {two_rho:g})"


@register_metric("iss_norm_chain", unit="1", evidence="simulation", applies=_this_law,
                 families=True,
                 doc="the ultimate bound of max_i |sigma_i - sigma_d| predicted by the norm chain "
                 "(analysis/sliding_iss.py) from the certified reaching margin over the "
                 "[families] box and the run's measured tail threshold floors, staleness and "
                 "Delta: a prediction from measured inputs (evidence), vacuous above 2 rho")
def iss_norm_chain(ctx):
    from formsync_design.analysis.sliding_iss import iss_prediction

    inp, why = _iss_inputs(ctx)
    if inp is None:
        return ctx.value(None, why)
    lam, gains, ms = inp
    v = iss_prediction(ctx.case.design, ctx.graph, gains, lam, ms["c_norm"], ms["staleness"],
                       ms["delta_norm"])
    return ctx.value(v, f"lambda = {lam:.4g}; {_vacuous(ctx.case.design, v)}; measured "
                     f"{ms['tail_sigma_error']:.4g}")


@register_metric("iss_ellipsoid", unit="1", evidence="simulation", applies=_this_law,
                 families=True,
                 doc="the invariant-ellipsoid ultimate bound of max_i |sigma_i - sigma_d| "
                 "(analysis/sliding_iss.py: LMI solved by cvxpy + Clarabel and re-checked "
                 "exactly) from the run's measured tail inputs: a bound given those inputs "
                 "(evidence), vacuous above 2 rho; unknown when no ellipsoid passes the re-check")
def iss_ellipsoid_metric(ctx):
    from formsync_design.analysis.sliding_iss import iss_ellipsoid

    inp, why = _iss_inputs(ctx)
    if inp is None:
        return ctx.value(None, why)
    _, gains, ms = inp
    e = iss_ellipsoid(ctx.case.design, ctx.graph, gains, ms["c_norm"] / math.sqrt(ctx.graph.n),
                      ms["staleness"], ms["delta_norm"])
    if not e.certified:
        return ctx.value(None, "no ellipsoid passed the exact re-check")
    return ctx.value(e.sigma_bound, f"split k = {e.split:g}; "
                     f"{_vacuous(ctx.case.design, e.sigma_bound)}; measured "
                     f"{ms['tail_sigma_error']:.4g}")
