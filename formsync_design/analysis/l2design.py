"""Gains minimising the certified L2 gain under a torque budget (lead-filter designs).

For a design with the gains ``k_p, k_d, a_f`` and a global torque bound ``|u_i| <= k_p D_i +
k_d a_f`` (``D_i = b_i + sum_j a_ij``; the design file's ``torque_bound``, e.g.
``derivations/lv2012.py``), the budget ``max_i |u_i| <= U`` holds on the whole state space
when ``k_p max_i D_i + k_d a_f <= U``.  :func:`design_l2_gains` searches that budget's
boundary (``k_p = f U / D_max``, ``k_d a_f = (1 - f) U``: spending less of the budget never
lowered the gain on the cases tried, a restriction of the search, not of the certificate),
over ``f`` and ``a_f`` within the design's ranges: a grid, then Nelder-Mead on the numerical
H-infinity norm (a hint); the chosen gains are rounded *down* to three significant digits
(so the budget still holds exactly) and their ``gamma`` is certified by
:func:`~formsync_design.analysis.l2gain.certify_gamma` (exact re-check).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.analysis.l2freq import hinf_norm
from formsync_design.analysis.l2gain import L2Certificate, certify_gamma
from formsync_design.derive.linearize import LinearLoop
from formsync_design.errors import InputError
from formsync_design.gains import json_number, parse_number

__all__ = ["L2Design", "design_l2_gains", "budget_bound", "round_down"]


def round_down(x: float, digits: int = 3) -> Fraction:
    """The largest decimal with ``digits`` significant digits that is ``<= x`` (``x > 0``).

    >>> str(round_down(3.14159)), str(round_down(0.0271828, 2))
    ('157/50', '27/1000')
    """
    e = math.floor(math.log10(x)) - digits + 1
    q = Fraction(10) ** e
    return math.floor(Fraction(x) / q) * q


def budget_bound(design: Any, lin: LinearLoop, gains: dict[str, Any]) -> Fraction:
    """``max_i`` of the design's ``torque_bound(k_p, k_d, a_f, b_i, D_i - b_i)`` (exact)."""
    fn = design.module.get("torque_bound")
    if not callable(fn):
        raise InputError(f"expected a function torque_bound(k_p, k_d, a_f, b, degree) in design "
                         f"{design.name}, received none")
    g = lin.graph
    vals = [parse_number(gains[k], k) for k in ("k_p", "k_d", "a_f")]
    b = g.pinning if g.has_leader else (Fraction(0),) * g.n
    return max(Fraction(fn(*vals, b[i], g.in_weights[i])) for i in range(g.n))


@dataclass(frozen=True)
class L2Design:
    """The designed gains, their certificate and the search record."""

    gains: dict[str, Fraction]
    budget: Fraction
    torque_bound: Fraction
    certificate: L2Certificate
    evaluations: int
    grid: tuple[tuple[float, float, float], ...]   # (f, a_f, numerical gamma)

    def to_dict(self) -> dict[str, Any]:
        return {"gains": {k: json_number(v) for k, v in self.gains.items()},
                "budget": json_number(self.budget), "torque_bound": json_number(self.torque_bound),
                "certificate": self.certificate.to_dict(), "evaluations": self.evaluations}


def design_l2_gains(design: Any, lin: LinearLoop, budget: Any, *, grid: int = 7) -> L2Design:
    """Gains within ``budget`` (N m) minimising the certified L2 gain (module docstring).

    >>> from formsync_design.derive.linearize import linearize_agents
    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("lv2012")
    >>> lin = linearize_agents(d, "path:2", [np.eye(3) * 20] * 2, pinning=[1, 1])
    >>> r = design_l2_gains(d, lin, 4, grid=4)
    >>> str(r.certificate.status), r.torque_bound <= 4
    ('certified', True)
    """
    from scipy.optimize import minimize

    U = parse_number(budget, "torque budget")
    if U <= 0:
        raise InputError(f"expected a positive torque budget, received {float(U):g}")
    if set(lin.gains) != {"k_p", "k_d", "a_f"}:
        raise InputError(f"expected a design with the gains k_p, k_d, a_f, received {lin.gains}")
    g = lin.graph
    b = g.pinning if g.has_leader else (Fraction(0),) * g.n
    D = float(max(b[i] + g.in_weights[i] for i in range(g.n)))
    rng = design.decl.gain("a_f").range
    lo_a, hi_a = (float(rng.lo), float(rng.hi)) if rng is not None else (0.05, 5.0)
    count = 0
    record: list[tuple[float, float, float]] = []

    def gains_of(f: float, la: float) -> dict[str, float]:
        a = math.exp(la)
        return {"k_p": f * float(U) / D, "k_d": (1 - f) * float(U) / a, "a_f": a}

    def cost(x: np.ndarray) -> float:
        nonlocal count
        f, la = float(np.clip(x[0], 0.02, 0.98)), float(np.clip(x[1], math.log(lo_a),
                                                                 math.log(hi_a)))
        count += 1
        A, B, C = lin.standard(gains_of(f, la))
        h, _ = hinf_norm(A, B, C, rtol=1e-6)
        return h if math.isfinite(h) else 1e12

    best = None
    for f in np.linspace(0.1, 0.9, grid):
        for la in np.linspace(math.log(lo_a), math.log(hi_a), grid):
            c = cost(np.array([f, la]))
            record.append((float(f), math.exp(la), c))
            if best is None or c < best[0]:
                best = (c, np.array([f, la]))
    assert best is not None
    opt = minimize(cost, best[1], method="Nelder-Mead",
                   options={"xatol": 1e-3, "fatol": 1e-4, "maxfev": 60})
    x = opt.x if opt.fun < best[0] else best[1]
    f, la = float(np.clip(x[0], 0.02, 0.98)), float(np.clip(x[1], math.log(lo_a), math.log(hi_a)))
    raw = gains_of(f, la)
    chosen = {k: round_down(v) for k, v in raw.items()}
    tb = budget_bound(design, lin, chosen)
    if tb > U:  # rounding a_f down and k_d down keeps k_d a_f below; k_p too: cannot happen
        raise InputError(f"the rounded gains exceed the budget ({float(tb):g} > {float(U):g})")
    cert = certify_gamma(lin, chosen)
    return L2Design(gains=chosen, budget=U, torque_bound=tb, certificate=cert,
                    evaluations=count, grid=tuple(record))
