"""Certificates of a self-triggered design (case kind ``selftrigger``): the design's families
over a gain box, the inter-event lower bound derived from its self-trigger rule, the
disturbance part of its bound ``delta`` and the ISS ultimate bound its certificate predicts.

Inter-event bound (:func:`interevent_bound`)
    The design's ``next_interval(v)`` is written in ``S = |s_i(t_k)|`` and the dynamic
    variable ``h = eta_i(t_k)`` (the design's ``parts(v)["s"]`` and ``eta(v)``, replaced
    structurally).  When it is ``(n0 + n1 S + n2 h) / (d0 + d1 S + d2 h)`` with positive
    coefficients (checked), the mediant inequality gives ``tau >= min(n0/d0, n1/d1, n2/d2)``
    for every ``S, h >= 0``: a bound on every self-triggered interval, and on every
    event-triggered one while ``|f_i| <= delta`` (the event rule fires no earlier than the
    self-trigger's worst case).  Exact in the gains.

Disturbance part of ``delta`` (:func:`disturbance_delta`)
    ``f_i`` contains ``D_i J_i^{-1} d_i``; with ``|d_ik| <= ubar_i`` its norm is at most
    ``D_i ubar_i max_{v in {-1, 1}^3} |J_i^{-1} v|`` (a convex function's maximum over a box
    is at a vertex), compared with ``delta`` exactly (squares of rationals).

ISS ultimate bound (:func:`iss_prediction`)
    From the certified reaching margin ``lambda`` (``V' <= -lambda |w|^2 + a |w| + b`` with
    ``a = m |K| (cbar + xibar) + (1 + theta) |K| Deltabar``, ``b = |K| Deltabar (cbar +
    xibar)``), ``|s| <= sqrt(p_max/p_min) ((1 + theta) R + cbar + xibar)`` ultimately, ``R`` the
    positive root of ``lambda R^2 = a R + b``; ``|z| <= |H^{-1}| |s|``; on the surface
    ``|sigma_i - sigma_d| <= (1 + rho^2)/4 |z_i| / (r (1 - rho^2)/4 - 3/2 rho wbar)``.  The
    measured ``cbar`` (threshold floors), ``xibar`` (staleness) and ``Deltabar`` of a run's
    tail enter (floating point: a prediction to compare with the run, not a certificate).
    It is **vacuous** (:func:`iss_vacuous`) when it exceeds ``2 rho``, the largest
    ``|sigma_i - sigma_d|`` inside the operating region ``|sigma|, |sigma_d| <= rho``.

Invariant-ellipsoid ultimate bound (:func:`iss_ellipsoid`)
    The same loop without the norm chain: per axis (every term is ``X (x) I_3``) the true
    sliding variables obey the linear system ``s' = M (-m w + Delta)``, ``w = s + e + xi`` (the
    held values: ``e`` the measurement error, ``xi`` the staleness), with the inputs bounded
    by the trigger, ``|e_i| <= theta |w_i| + c`` (used as ``|e_i|^2 <= (1 + k) theta^2 |w_i|^2
    + (1 + 1/k) c^2`` for ``k`` in a grid, default 2, 4, 6), and by the run's tail sups ``|xi| <= xibar``,
    ``|Delta| <= Deltabar``.  :func:`~formsync_design.analysis.ellipsoid.invariant_ellipsoid`
    finds an attracting invariant ellipsoid ``{s^T P s <= 1}`` (LMI, exact re-check) and the
    exact ultimate bound of every ``|z_i| = |(H^{-1} s)_i|``; the surface step is the one
    above.  Same measured inputs as the prediction, so the same status: a bound given the
    run's tail input bounds, tight up to the S-procedure and the surface step.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.spec.agent import AgentDesign, agent_expressions

__all__ = ["IntereventBound", "interevent_bound", "DeltaCheck", "disturbance_delta",
           "certify_design", "iss_prediction", "iss_vacuous", "IssEllipsoid", "iss_ellipsoid",
           "interevent_origin"]


@dataclass(frozen=True)
class IntereventBound:
    """``tau >= min(ratios)``: the ratios as SymPy expressions in the gains, the derived
    rule ``tau(S, h)`` and the bound's exact value at the case's gains."""

    tau: sp.Expr
    ratios: tuple[sp.Expr, ...]
    value: Fraction

    @property
    def formula(self) -> str:
        return "min(" + ", ".join(str(r) for r in self.ratios) + ")"


def interevent_bound(design: AgentDesign, gains: dict[str, Any]) -> IntereventBound:
    """The lower bound of every inter-event time (module docstring), exact at ``gains``.

    >>> from formsync_design.spec.loader import load_design
    >>> b = interevent_bound(load_design("selftrigger_mrp"), {"m_f": Fraction(3, 2),
    ...     "delta": Fraction(1, 20), "eps": Fraction(1, 100), "alpha": Fraction(1, 10),
    ...     "eta0": Fraction(1, 20), "r": Fraction(1, 2)})
    >>> b.formula, b.value
    ('min(eps/delta, (m_f - 1)/m_f**2, 1/alpha)', Fraction(1, 5))
    """
    ex = agent_expressions(design, 1)
    v = ex["view"]
    parts, eta = design.module.get("parts"), design.module.get("eta")
    if not (callable(parts) and callable(eta)):
        raise DerivationError(f"{design.path}: expected parts(v) and eta(v) for the inter-event "
                              "bound, received none")
    s = parts(v)["s"]
    S, h = sp.symbols("S h", nonnegative=True)
    tau = ex["next_interval"].xreplace({sp.sqrt((s.T * s)[0, 0]): S}).subs(eta(v), h)
    gsyms = {design.decl.gain(k).symbol for k in design.decl.controller_gains}
    bad = tau.free_symbols - gsyms - {S, h}
    if bad:
        raise DerivationError(f"{design.path}: expected next_interval in |s| and eta only, "
                              f"received the symbols {sorted(map(str, bad))}")
    num, den = sp.fraction(sp.together(tau))
    pn, pd = sp.Poly(sp.expand(num), S, h), sp.Poly(sp.expand(den), S, h)
    if pn.total_degree() > 1 or pd.total_degree() > 1:
        raise DerivationError(f"{design.path}: expected next_interval affine over affine in "
                              f"(|s|, eta), received {tau}")
    ratios = []
    subs = {design.decl.gain(k).symbol: sp.Rational(Fraction(x).numerator, Fraction(x).denominator)
            for k, x in gains.items() if k in design.decl.controller_gains}
    for mono in ((0, 0), (1, 0), (0, 1)):
        a, b = pn.coeff_monomial(mono), pd.coeff_monomial(mono)
        if a == 0 and b == 0:
            continue
        av, bv = a.subs(subs), b.subs(subs)
        if not (av >= 0 and bv > 0):
            raise DerivationError(f"{design.path}: expected positive coefficients in "
                                  f"next_interval, received {a} / {b}")
        ratios.append(sp.factor(sp.cancel(a / b)))
    vals = [Fraction(str(sp.nsimplify(r.subs(subs)))) for r in ratios]
    return IntereventBound(tau=tau, ratios=tuple(ratios), value=min(vals))


@dataclass(frozen=True)
class DeltaCheck:
    """Per spacecraft the disturbance part ``D_i ubar_i max_v |J_i^{-1} v|`` of ``|f_i|``
    (float, for the report) and whether ``delta`` exceeds it (decided exactly)."""

    required: tuple[float, ...]
    holds: tuple[bool, ...]

    @property
    def all_hold(self) -> bool:
        return all(self.holds)


def disturbance_delta(delta: Any, inertias: np.ndarray, ubar: np.ndarray,
                      D: np.ndarray) -> DeltaCheck:
    """``delta >= D_i ubar_i max_{v in {+-1}^3} |J_i^{-1} v|`` per spacecraft, exactly
    (every float taken as its exact binary value).

    >>> c = disturbance_delta(Fraction(1, 10), np.array([np.eye(3) * 10]), np.array([0.1]),
    ...                       np.array([2.0]))
    >>> round(c.required[0], 6), c.holds
    (0.034641, (True,))
    """
    dl = Fraction(delta)
    req, ok = [], []
    for J, u, d in zip(inertias, ubar, D):
        Jf = sp.Matrix([[sp.Rational(Fraction(float(x))) for x in row] for row in J])
        Ji = Jf.inv()
        worst = Fraction(0)
        for sg in itertools.product((-1, 1), repeat=3):
            x = Ji * sp.Matrix(sg)
            n2 = sum((Fraction(str(e)) for e in (x.T * x)), Fraction(0))
            worst = max(worst, n2)
        scale = Fraction(float(d)) ** 2 * Fraction(float(u)) ** 2
        req.append(math.sqrt(float(scale * worst)))
        ok.append(dl * dl >= scale * worst)
    return DeltaCheck(required=tuple(req), holds=tuple(ok))


def certify_design(design: AgentDesign, graph: Any, box: dict[str, Any]) -> Any:
    """The design's families on ``graph`` certified over ``box`` (its multipliers searched
    over their declared ranges): a :class:`~formsync_design.certify.results.CertificationResult`."""
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.derive.agent import agent_conditions

    ac = agent_conditions(design, graph)
    mult = {g.name: g.range for g in design.decl.gains
            if str(g.role) == "multiplier" and g.range is not None}
    return certify_with_multipliers(ac, box, mult, use_sdp=False, points=25)


def iss_prediction(design: AgentDesign, graph: Any, gains: dict[str, float], lam: float,
                   cbar: float, xibar: float, deltabar: float) -> float:
    """The predicted ultimate bound of ``max_i |sigma_i - sigma_d|`` (module docstring)."""
    K = np.array(design.module["graph_weights"](graph), dtype=float)
    H = graph.laplacian + graph.pinning_matrix
    m, r = gains["m_f"], gains["r"]
    th = 1 - 1 / m
    nK = float(np.linalg.norm(K, 2))
    p = np.diag(K)
    a = m * nK * (cbar + xibar) + (1 + th) * nK * deltabar
    b = nK * deltabar * (cbar + xibar)
    R = (a + math.sqrt(a * a + 4 * lam * b)) / (2 * lam)
    s_ult = math.sqrt(p.max() / p.min()) * ((1 + th) * R + cbar + xibar)
    z_ult = float(np.linalg.norm(np.linalg.inv(H), 2)) * s_ult
    reg = design.module["OPERATING_REGION"]
    rho, wbar = float(Fraction(reg["rho"])), float(Fraction(reg["omega_d_max"]))
    kappa = r * (1 - rho**2) / 4 - 1.5 * rho * wbar
    return (1 + rho**2) / 4 * z_ult / kappa if kappa > 0 else math.inf


def _surface_factor(design: AgentDesign, r: float) -> float:
    """``(1 + rho^2)/4 / (r (1 - rho^2)/4 - 3/2 rho wbar)`` (inf outside the surface
    condition): ``|sigma_i - sigma_d| <= factor |z_i|`` ultimately on the operating region."""
    reg = design.module["OPERATING_REGION"]
    rho, wbar = float(Fraction(reg["rho"])), float(Fraction(reg["omega_d_max"]))
    kappa = r * (1 - rho**2) / 4 - 1.5 * rho * wbar
    return (1 + rho**2) / 4 / kappa if kappa > 0 else math.inf


def iss_vacuous(design: AgentDesign, bound: float) -> bool:
    """A bound of ``max_i |sigma_i - sigma_d|`` above ``2 rho`` says nothing: inside the
    operating region ``|sigma_i - sigma_d| <= |sigma_i| + |sigma_d| <= 2 rho`` already.

    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("selftrigger_mrp")
    >>> iss_vacuous(d, 1.21), iss_vacuous(d, 1.19)
    (True, False)
    """
    return bound > 2 * float(Fraction(design.module["OPERATING_REGION"]["rho"]))


@dataclass(frozen=True)
class IssEllipsoid:
    """The invariant-ellipsoid ultimate bound (module docstring): ``sigma_bound`` of
    ``max_i |sigma_i - sigma_d|``, ``z_bounds`` per spacecraft, the split ``k`` used and the
    ellipsoid (``certified`` False: no grid value passed the exact re-check)."""

    certified: bool
    sigma_bound: float
    z_bounds: tuple[float, ...]
    split: float | None
    ellipsoid: Any


def _sector_system(H: np.ndarray, m: float, th: float, split: float, cbar: float,
                   xibar: float, deltabar: float) -> tuple[Any, ...]:
    """``A, B, [G_k], [c_k], C`` of the per-axis loop (module docstring), inputs
    ``(e, xi, Delta)``."""
    n = H.shape[0]
    Mm = H / np.diag(H)[None, :]  # M = H Dbar^{-1}
    A = -m * Mm
    B = np.hstack([-m * Mm, -m * Mm, Mm])
    G, c = [], []
    for i in range(n):
        u = np.zeros(4 * n)
        u[[i, n + i, 2 * n + i]] = 1.0
        ei = np.zeros(4 * n)
        ei[n + i] = 1.0
        G.append((1 + split) * th**2 * np.outer(u, u) - np.outer(ei, ei))
        c.append((1 + 1 / split) * cbar**2)
    for blk, bnd in ((2, xibar), (3, deltabar)):
        g = np.zeros((4 * n, 4 * n))
        g[blk * n:(blk + 1) * n, blk * n:(blk + 1) * n] = -np.eye(n)
        G.append(g)
        c.append(bnd**2)
    return A, B, G, c, np.linalg.inv(H)


def iss_ellipsoid(design: AgentDesign, graph: Any, gains: dict[str, float], cbar: float,
                  xibar: float, deltabar: float,
                  splits: tuple[float, ...] = (2.0, 4.0, 6.0)) -> IssEllipsoid:
    """The invariant-ellipsoid bound of ``max_i |sigma_i - sigma_d|`` (module docstring);
    ``cbar`` the per-spacecraft threshold floor ``eps + eta_i`` over the tail."""
    from formsync_design.analysis.ellipsoid import invariant_ellipsoid

    H = np.asarray(graph.laplacian + graph.pinning_matrix, dtype=float)
    m, r = gains["m_f"], gains["r"]
    th = 1 - 1 / m
    best: IssEllipsoid | None = None
    for k in splits:
        A, B, G, c, C = _sector_system(H, m, th, k, cbar, xibar, deltabar)
        el = invariant_ellipsoid(A, B, G, c, C)
        if not el.certified:
            continue
        sb = _surface_factor(design, r) * max(el.bounds)
        if best is None or sb < best.sigma_bound:
            best = IssEllipsoid(True, sb, el.bounds, k, el)
    if best is None:
        return IssEllipsoid(False, math.inf, tuple([math.inf] * H.shape[0]), None, None)
    return best


def interevent_origin(bound: IntereventBound, gains: dict[str, Any]) -> tuple[str, Fraction, bool]:
    """Where the inter-event bound comes from: ``(active ratio, tau(S = 0, h = 0), floor)``
    with ``floor`` True when the bound is exactly the rule's interval at rest (``|s_i| = 0``,
    ``eta_i = 0``), i.e. the design's own constant floor rather than a closed-loop property.

    >>> from formsync_design.spec.loader import load_design
    >>> g = {"m_f": Fraction(3, 2), "delta": Fraction(1, 20), "eps": Fraction(1, 100),
    ...      "alpha": Fraction(1, 10), "eta0": Fraction(1, 20), "r": Fraction(1, 2)}
    >>> b = interevent_bound(load_design("selftrigger_mrp"), g)
    >>> interevent_origin(b, g)
    ('eps/delta', Fraction(1, 5), True)
    """
    subs = {s: sp.Rational(Fraction(gains[str(s)]).numerator, Fraction(gains[str(s)]).denominator)
            for s in bound.tau.free_symbols if str(s) in gains}
    vals = [Fraction(str(sp.nsimplify(r.subs(subs)))) for r in bound.ratios]
    active = str(bound.ratios[vals.index(min(vals))])
    S, h = sp.symbols("S h", nonnegative=True)
    at_rest = Fraction(str(sp.nsimplify(bound.tau.subs(subs).subs({S: 0, h: 0}))))
    return active, at_rest, at_rest == bound.value
