"""Bounds of a triggering rule: the inter-event lower bound of a self-trigger rule (the
mediant inequality) and the disturbance part of a bound on the nonlinear term.

Inter-event bound (:func:`interevent_bound`)
    A self-triggered design's ``next_interval(v)`` written in ``S = |s_i(t_k)|`` and the
    dynamic variable ``h = eta_i(t_k)`` (the design's ``parts(v)["s"]`` and ``eta(v)``,
    replaced structurally).  When it is ``(n0 + n1 S + n2 h) / (d0 + d1 S + d2 h)`` with
    positive coefficients (checked), the mediant inequality gives ``tau >= min(n0/d0, n1/d1,
    n2/d2)`` for every ``S, h >= 0``: a bound on every self-triggered interval, and on every
    event-triggered one of the same measurement error while the nonlinear term stays within
    the rule's bound ``delta`` (the event rule fires no earlier than the self-trigger's worst
    case).  Exact in the gains.  :func:`interevent_origin` says which ratio is active and
    whether the bound is the rule's own interval at rest (``S = 0``, ``h = 0``).

Disturbance part of ``delta`` (:func:`disturbance_delta`)
    A nonlinear term that contains ``D_i J_i^{-1} d_i`` with ``|d_ik| <= ubar_i`` has norm at
    most ``D_i ubar_i max_{v in {-1, 1}^3} |J_i^{-1} v|`` there (a convex function's maximum
    over a box is at a vertex), compared with ``delta`` exactly (squares of rationals).
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

__all__ = ["IntereventBound", "interevent_bound", "interevent_origin", "DeltaCheck",
           "disturbance_delta"]


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
