"""Ma, Dong, Ma, Wang: attitude coordination on SO(3) with backstepping sliding-mode control
on a directed weighted graph (seed paper 002), reconstructed.

The text we work from lost every numbered equation (1)-(32) and both tables; what survives is
the model (4) in words, the remark that the command ``R_di`` is made a rotation by cross
products between its columns and a normalisation (remark 2), the names of the errors
(8)-(10), the words "virtual control" (20) and "sliding surface s_2i" (21), the head of the
reaching law ``M_i = -J_i (K2 s_2i + P2 |s_2i|^{1/2} o sgn(s_2i) + ...`` (26), (28), and the
conclusion: "when the coordination error is large a non-singular sliding surface is used;
when it is small the controller switches to a surface without the compensation term so that
the error converges quickly to zero, which keeps the law non-singular everywhere".  Every
lost equation is reconstructed below; each reconstruction is an assumption ``A1``-``A8``
(the report lists them with their sources):

A1 (eqs. 5-7, command).  ``Mbar_i = sum_j a_ij R_j`` over the in-neighbours; its first two
   columns ``m1, m2`` give ``c1 = m1/|m1|``, ``c3 = (m1 x m2)/|m1 x m2|``, ``c2 = c3 x c1``
   and ``R_di = [c1 c2 c3]`` (the cross-product / normalisation construction of remark 2, as
   in Lee, Leok, McClamroch's construction of a desired attitude from two directions, CDC
   2010).  It is undefined where ``m1 = 0`` or ``m1 || m2`` (neighbours far apart); the monitor
   ``cmd`` (``min(|m1|/d, |m1 x m2|/d^2)``, ``d = sum_j a_ij``, 1 when the neighbours agree)
   records how close a run came.  A spacecraft without in-neighbours holds its attitude: its
   command is its own attitude at rest (``e_R = 0``, ``e_W = W``).
A2 (eqs. 8-10, errors; Lee 2012, the paper's [24]).  ``Rt = R_d^T R``,
   ``e_R = (Rt - Rt^T)^vee / 2``, ``e_W = W - Rt^T W_d`` with ``R_d' = R_d W_d^``.
A3 (eqs. 11-19, error model).  ``e_R' = E(Rt) e_W``, ``E = (tr(Rt^T) I - Rt^T)/2``,
   ``e_W' = J^{-1}(M - W x J W) + gamma``, ``gamma = W^ Rt^T W_d - Rt^T W_d'`` (derived in
   the ``conditions`` hook along the closed loop, not typed).
A4 (eq. 20, virtual control).  ``alpha = -K1 e_R - P1 beta(e_R)``: on ``s = 0``,
   ``Psi' = e_R . e_W = -e_R^T K1 e_R - e_R^T P1 beta(e_R)`` with ``Psi = tr(I - Rt)/2``.
   E is **not inverted** (the "non-singular surface"): ``E`` is singular at 90 deg as well as
   at 180 deg (``det E = cos th (1 + cos th)/2``), and a law with ``E^{-1}`` would be undefined
   there (monitor ``det_E``).
A5 (the second surface).  ``beta`` is ``|x|^{1/2} sgn(x)`` componentwise for ``|x_k| >= eps``
   and its C^1 continuation ``l1 x + l2 x |x|`` (``l1 = 3/(2 sqrt eps)``,
   ``l2 = -1/(2 eps^{3/2})``) inside: the derivative of ``|x|^{1/2}`` is unbounded as
   ``x -> 0``, so the "surface without the singular term" is used near small errors (the
   construction of nonsingular fast terminal sliding modes, Yu, Yu, Shirinzadeh, Man 2005;
   used in finite-time formation control by the paper's [10]).
A6 (eq. 21, surface).  ``s = e_W - alpha``.
A7 (eqs. 25-28, reaching law and torque).  ``s' = -K2 s - P2 sig^{1/2}(s) - e_R``, i.e.
   ``M = W x J W - J (K2 s + P2 sig^{1/2}(s) + e_R + gamma - alpha')``; the ``+ e_R`` term is
   the backstepping cross term that makes ``V = Psi + |s|^2/2`` decrease (Lee 2012;
   Khalil, backstepping).
A8 (the command's rates).  ``W_d`` is exact from the neighbours' attitudes and rates;
   ``W_d'`` takes the neighbours' rates constant over the instant (their angular accelerations
   are not transmitted: including them would couple every torque of a cyclic digraph through
   an algebraic loop).  The omitted term acts on ``s`` as a perturbation that vanishes as the
   neighbours come to rest.

The certificate (``conditions``): ``V_i = mu Psi_i + s_i^T s_i / 2`` on the tracking loop
(command as an exogenous reference, Theorem 1's first part); ``mu`` is a multiplier.

The exact checks only this design defines (the identities of the derivation along the closed
loop, ``det E``'s singular angles, the second surface's properties, the tracking loop's time
constant near consensus) are metrics of the engine case ``verification/ma_so3.toml``,
registered at the end of this file.
"""

from __future__ import annotations

import functools

import numpy as np
import sympy as sp

from formsync_design.spec.sliding import dfpow, fpow
from formsync_design.verify.metrics import register_metric

FORM = "agent"
NAME = "ma_so3"
TITLE = "SO(3) backstepping sliding-mode coordination on a directed graph (Ma, Dong, Ma, Wang)"
REPRESENTATION = "so3"
GAINS = {
    "K1": {"kind": "diag", "range": "0.5:2", "description": "virtual-control (surface) gain"},
    "K2": {"kind": "diag", "range": "0.05:0.5", "description": "linear reaching-law gain"},
    "P1": {"kind": "diag", "range": "0.01:0.1", "description": "fractional-power surface gain"},
    "P2": {"kind": "diag", "range": "0.01:0.1", "description": "fractional-power reaching gain"},
    "eps": {"range": "1/100", "description": "threshold of the second (small-error) surface"},
    "mu": {"role": "multiplier", "range": "1/10:10",
           "description": "weight of Psi in the Lyapunov candidate"},
}
GRAPHS = ("spanning-tree",)
SAMPLING = "continuous"
MEASURED = ("attitude", "rate", "neighbour-attitude", "neighbour-rate")


# ---------------------------------------------------------------------------- the command (A1)


def _columns_to_rotation(X):
    x1, x2 = X[:, 0], X[:, 1]
    c1 = x1 / sp.sqrt(x1.dot(x1))
    x3 = x1.cross(x2)
    c3 = x3 / sp.sqrt(x3.dot(x3))
    c2 = c3.cross(c1)
    return sp.Matrix.hstack(c1, c2, c3)


@functools.lru_cache(maxsize=1)
def _command_template():
    """``R_d``, ``R_d'``, ``R_d''`` of the construction A1 in generic column symbols (the
    first two columns ``x`` of ``Mbar`` and their first two time derivatives), by SymPy."""
    tau = sp.Symbol("tau")
    X = sp.Matrix(3, 2, sp.symbols("x_1:7", real=True))
    XD = sp.Matrix(3, 2, sp.symbols("xd_1:7", real=True))
    XDD = sp.Matrix(3, 2, sp.symbols("xdd_1:7", real=True))
    Rt = _columns_to_rotation(X + tau * XD + tau**2 / 2 * XDD)
    d1 = Rt.diff(tau)
    d2 = d1.diff(tau)
    z = {tau: sp.Integer(0)}
    return X, XD, XDD, _columns_to_rotation(X), d1.xreplace(z), d2.xreplace(z)


def _vee_skew(A):
    return sp.Matrix([A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1]]) / 2


def _hat(w):
    return sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _command_inputs(nbrs):
    """``Mbar`` and its first two time derivatives (neighbours' rates held, A8)."""
    M0, M1, M2 = sp.zeros(3, 3), sp.zeros(3, 3), sp.zeros(3, 3)
    for a, Rj, Wj in nbrs:
        H = _hat(Wj)
        M0 += a * Rj
        M1 += a * Rj * H
        M2 += a * Rj * H * H
    return M0, M1, M2


def command_from_columns():
    """``(R_d, W_d, W_d', cond)`` in the generic column symbols of :func:`_command_template`
    (and the in-weight sum ``d``)."""
    X, XD, XDD, Rd, Rdd, Rddd = _command_template()
    d = sp.Symbol("d_in", positive=True)
    Wd = _vee_skew(Rd.T * Rdd)
    Wdd = _vee_skew(Rd.T * Rddd)
    x1, x2 = X[:, 0], X[:, 1]
    x3 = x1.cross(x2)
    cond = sp.Min(sp.sqrt(x1.dot(x1)) / d, sp.sqrt(x3.dot(x3)) / d**2, evaluate=False)
    return Rd, Wd, Wdd, cond


def _bind(nbrs):
    """The substitution of the generic column symbols by the neighbours' quantities."""
    from formsync_design.spec.dag import xreplace

    X, XD, XDD = _command_template()[:3]
    M0, M1, M2 = _command_inputs(nbrs)
    b = {sp.Symbol("d_in", positive=True): sum((a for a, _, _ in nbrs), sp.Integer(0))}
    for k in range(6):
        i, j = divmod(k, 2)
        b[X[i, j]], b[XD[i, j]], b[XDD[i, j]] = M0[i, j], M1[i, j], M2[i, j]
    return lambda e: xreplace(e, b)


def command(nbrs):
    """``(R_d, W_d, W_d', cond)`` from ``[(a_ij, R_j, W_j), ...]`` (A1, A8)."""
    sub = _bind(nbrs)
    return tuple(sub(e) for e in command_from_columns())


# ------------------------------------------------------------------ the tracking law (A2-A7)


def errors(R, W, Rd, Wd):
    """``(Rt, e_R, e_W, E)`` of A2, A3."""
    Rt = Rd.T * R
    eR = _vee_skew(Rt)
    eW = W - Rt.T * Wd
    E = (Rt.T.trace() * sp.eye(3) - Rt.T) / 2
    return Rt, eR, eW, E


def tracking_law(R, W, J, Rd, Wd, Wdd, g, beta=None, dbeta=None, spow=None):
    """The torque of A4-A7 tracking ``(R_d, W_d, W_d')``; ``g``: the gains by name;
    ``beta``, ``dbeta``, ``spow``: the power functions (markers in the certificate)."""
    eps = g["eps"]
    beta = beta or (lambda x: fpow(x, eps))
    dbeta = dbeta or (lambda x: dfpow(x, eps))
    spow = spow or (lambda x: sp.sqrt(sp.Abs(x, evaluate=False)) * g["sgn"](x))
    Rt, eR, eW, E = errors(R, W, Rd, Wd)
    eRd = E * eW
    alpha = -g["K1"] * eR - g["P1"] * eR.applyfunc(beta)
    alphad = -g["K1"] * eRd - g["P1"] * sp.diag(*[dbeta(x) for x in eR]) * eRd
    s = eW - alpha
    gamma = _hat(W) * Rt.T * Wd - Rt.T * Wdd
    return W.cross(J * W) - J * (g["K2"] * s + g["P2"] * s.applyfunc(spow) + eR + gamma - alphad)


def _gains(v):
    return {"K1": v.K1, "K2": v.K2, "P1": v.P1, "P2": v.P2, "eps": v.eps, "sgn": v.sgn}


@functools.lru_cache(maxsize=4)
def _generic(R, W, J, gains):
    """The torque and the monitors in the own state and the generic command columns (built
    once; each in-degree only substitutes the columns, sharing every sub-expression)."""
    R, W, J = sp.Matrix(3, 3, R), sp.Matrix(W), sp.Matrix(3, 3, J)
    g = dict(gains)
    g["K1"], g["K2"], g["P1"], g["P2"] = (sp.diag(*g[k]) for k in ("K1", "K2", "P1", "P2"))
    from formsync_design.spec.agent_view import sgn_of

    g["sgn"] = sgn_of
    Rd, Wd, Wdd, cond = command_from_columns()
    u = tracking_law(R, W, J, Rd, Wd, Wdd, g)
    Rt = Rd.T * R
    tr = Rt.trace()
    mons = {"det_E": (tr**2 - 1) / 8, "cos_err": (tr - 1) / 2, "cmd": cond}
    return u, mons


def _key(v):
    diag = {k: tuple(getattr(v, k).diagonal()) for k in ("K1", "K2", "P1", "P2")}
    return (tuple(v.R), tuple(v.w), tuple(v.J), tuple(sorted({**diag, "eps": v.eps}.items())))


def controller(v):
    """``M_i`` (A1-A8); without in-neighbours: ``R_d = R_i`` at rest."""
    if not v.nbrs:
        return tracking_law(v.R, v.w, v.J, v.R, sp.zeros(3, 1), sp.zeros(3, 1), _gains(v))
    u, _ = _generic(*_key(v))
    return _bind([(n.a, n.R, n.w) for n in v.nbrs])(u)


def monitors(v):
    """``det_E = (tr(Rt)^2 - 1)/8`` (``E`` singular at 90 and 180 deg), ``cos_err`` (cosine of
    the angle to the command) and ``cmd`` (the command's conditioning, A1)."""
    if not v.nbrs:
        return {"det_E": sp.Integer(1), "cos_err": sp.Integer(1), "cmd": sp.Integer(1)}
    _, mons = _generic(*_key(v))
    sub = _bind([(n.a, n.R, n.w) for n in v.nbrs])
    return {k: sub(e) for k, e in mons.items()}


def conditions(c):
    """The sliding-surface Lyapunov conditions (derived in
    :func:`formsync_design.derive.so3_sliding.sliding_conditions`)."""
    from formsync_design.derive.so3_sliding import sliding_conditions

    return sliding_conditions(c, tracking_law, errors)


# ------------------------------------------------- the design's own measurements (metrics)


def _this_law(design):
    return None if design.module.get("tracking_law") is tracking_law else (
        f"design {design.name} is not this SO(3) design")


@functools.lru_cache(maxsize=1)
def _derivation():
    from formsync_design.derive.so3_sliding import derive_sliding, det_E_factorisation, power_lemmas

    return derive_sliding(tracking_law, errors, GAINS), det_E_factorisation(), power_lemmas()


@register_metric("sliding_identities", unit="verdict", evidence="certificate", value="text",
                 applies=_this_law,
                 doc="the identities of the derivation along the closed loop (e_R' = E e_W, Psi' "
                 "= e_R . e_W, the reaching law s', V') checked in exact arithmetic at seeded "
                 "random rational points (derive/so3_sliding.py): hold or fail")
def sliding_identities(ctx):
    checks = _derivation()[0].checks
    bad = [name for name, _, ok in checks if not ok]
    return ctx.value("fail" if bad else "hold", "; ".join(f"{n} ({w}): {ok}" for n, w, ok in checks))


@register_metric("det_e_singular_angles", unit="verdict", evidence="certificate", value="text",
                 applies=_this_law,
                 doc="where E(Rt) = (tr(Rt^T) I - Rt^T)/2 is singular, derived exactly: det E = "
                 "(tr(Rt)^2 - 1)/8 = cos th (1 + cos th)/2 for every rotation, and det E at Rz(90 "
                 "deg) and Rz(180 deg) with the kernels: '90 and 180 deg' when both vanish")
def det_e_singular_angles(ctx):
    de = _derivation()[1]
    zero = [a for a, k in (("90", "at_90"), ("180", "at_180")) if de[k]["det"] == 0]
    ok = bool(de["identity"]) and bool(de["cos_form"])
    text = (" and ".join(zero) + " deg") if zero and ok else "not derived"
    return ctx.value(text, f"det E = (tr(Rt)^2 - 1)/8: {de['identity']}; = cos th (1 + cos th)/2: "
                     f"{de['cos_form']}; kernel at 90 deg {de['at_90']['kernel']}, at 180 deg "
                     f"{de['at_180']['kernel']}; the law never inverts E (A4)")


@register_metric("power_surface_lemmas", unit="verdict", evidence="certificate", value="text",
                 applies=_this_law,
                 doc="the properties of the second surface's power function beta the certificate "
                 "uses, decided exactly per branch (continuous and C^1 at eps, x beta(x) > 0, "
                 "beta'(0) = 3/(2 sqrt eps)): hold or fail")
def power_surface_lemmas(ctx):
    lem = _derivation()[2]
    return ctx.value("hold" if all(lem.values()) else "fail",
                     "; ".join(f"{k}: {v}" for k, v in lem.items()))


@register_metric("tracking_time_constant", unit="s", evidence="numerical", applies=_this_law,
                 doc="near consensus (E ~ I, |e_R| < eps) the tracking loop of each spacecraft is "
                 "e_R' = s - (K1 + 3 P1 / (2 sqrt eps)) e_R, s' = -e_R - K2 s (the linear parts of "
                 "the derived V' families): 1 / its slowest decay rate, per tracking stage (the "
                 "command moves with the neighbours: several per stage of the digraph)")
def tracking_time_constant(ctx):
    g = ctx.case.gains.as_dict()
    k1, k2, p1, eps = (float(np.mean(g[k])) for k in ("K1", "K2", "P1", "eps"))
    ev = np.linalg.eigvals(np.array([[-(k1 + 1.5 * p1 / np.sqrt(eps)), 1.0], [-1.0, -k2]]))
    slow = float(-np.max(ev.real))
    return ctx.value(1 / slow, f"eigenvalues {', '.join(f'{z:.3g}' for z in ev)}; slowest decay "
                     f"rate {slow:.3g} 1/s")
