"""Delay requirement decided over a whole gain cell (issue 15, items 2-3, 6).

Every gain of the cell, not only its corners, by monotonicity proven here for the
derived loop ``c_qd = -K_o``, ``c_s = -K_q`` (checked symbolically on the
specification; otherwise the cell is undecided).

``processing`` (any graph)
    per mode ``s^2 + K_o s + K_q lambda e^{-s tau}``: the only crossing frequency
    solves ``w^4 + K_o^2 w^2 = b^2`` (``b = K_q lambda``) and the margin is
    ``atan(K_o / w) / w``.  ``w`` decreases in ``K_o`` and increases in ``b``;
    hence the margin increases in ``K_o`` (``atan(K_o/w)`` and ``1/w`` both grow) and
    decreases in ``K_q`` (both shrink), and does not depend on ``beta``.  The
    smallest margin over the cell is at ``(K_o lo, K_q hi)``, the largest at
    ``(K_o hi, K_q lo)``.  A single crossing frequency crosses into the right half
    plane at every crossing delay, so beyond the margin the loop is unstable.
    Certified: margin at the worst corner ``> tau``; refuted: margin at the best
    corner ``< tau`` (each by :func:`.delay.delay_margin`, exact per mode).
``transmission`` (regular graph of degree ``d``)
    per mode ``|P_0(iw)|^2 - |P_1(iw)|^2 = w^4 + (K_o^2 - 2 K_q d) w^2 +
    K_q^2 (d^2 - (d - lambda)^2)``; for ``0 < lambda <= 2 d`` the last coefficient
    is ``>= 0``, so ``K_o^2 >= 2 K_q d`` leaves no crossing frequency: stable for
    every delay (Atay 2013).  Checked exactly in rationals at ``(K_o lo, K_q hi)``
    (the condition is monotone: hardest at that corner); otherwise, and on
    irregular graphs (sufficient Lyapunov-Krasovskii bound only, no monotonicity
    proven), the cell is undecided.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import sympy as sp

from formsync_design.analysis.delay import DelayModel, delay_margin
from formsync_design.analysis.requirements import RequirementCheck
from formsync_design.analysis.results import Verdict
from formsync_design.derive.closed_loop import derive_closed_loop
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph
from formsync_design.spec.loader import gain_symbols

__all__ = ["delay_cell_check", "loop_is_standard_pd"]


def loop_is_standard_pd(spec: Any = None) -> bool:
    """``True`` when the derived loop has ``c_qd = -K_o`` and ``c_s = -K_q`` (symbolically).

    >>> loop_is_standard_pd()
    True
    """
    cl = derive_closed_loop(spec)
    ko, kq, _ = gain_symbols()
    return bool(sp.simplify(cl.c_qd + ko) == 0 and sp.simplify(cl.c_s + kq) == 0)


def delay_cell_check(graph: Any, box: Any, tau: float, model: str = "processing", *,
                     spec: Any = None) -> RequirementCheck:
    """Decide ``delay margin > tau`` for every gain of the cell ``box``.

    Examples
    --------
    >>> b = GainBox.parse({"K_o": "1.5:1.7", "K_q": "0.3:0.4", "beta": "0.2:0.3"}, ("K_o", "K_q", "beta"))
    >>> delay_cell_check("ring:8", b, 0.5).status.value
    'certified'
    >>> delay_cell_check("ring:8", b, 5.0).status.value
    'refuted'
    """
    g = make_graph(graph)
    m = DelayModel(str(model))
    bx = box if isinstance(box, GainBox) else GainBox.parse(box, ("K_o", "K_q", "beta"))
    ko, kq, beta = bx.ranges
    worst = (ko.lo, kq.hi, beta.lo)
    best = (ko.hi, kq.lo, beta.lo)
    if not loop_is_standard_pd(spec):
        return RequirementCheck("delay", Verdict.UNDECIDED, tau, None,
                                "cell-level delay check needs c_qd = -K_o, c_s = -K_q (monotonicity)")
    if m is DelayModel.PROCESSING:
        lo = delay_margin(g, worst, m, spec=spec).margin
        if lo > tau:
            return RequirementCheck("delay", Verdict.CERTIFIED, tau, lo,
                                    f"processing delay margin >= {lo:.6g} s over the cell (monotone: worst "
                                    f"at K_o lo, K_q hi) exceeds tau = {tau:g} s")
        hi = delay_margin(g, best, m, spec=spec).margin
        if hi * (1 + 1e-8) < tau:  # margin is rounded down by 1e-9 relative
            return RequirementCheck("delay", Verdict.REFUTED, tau, hi,
                                    f"processing delay margin <= {hi:.6g} s over the cell (best at K_o hi, "
                                    f"K_q lo) is below tau = {tau:g} s")
        return RequirementCheck("delay", Verdict.UNDECIDED, tau, [lo, hi],
                                f"processing delay margin in [{lo:.6g}, {hi:.6g}] s over the cell straddles "
                                f"tau = {tau:g} s")
    if len(set(g.degrees)) == 1:
        d = g.degrees[0]
        if Fraction(ko.lo) ** 2 >= 2 * Fraction(kq.hi) * d:
            return RequirementCheck("delay", Verdict.CERTIFIED, tau, math.inf,
                                    f"K_o^2 >= 2 K_q d (d = {d}) on the whole cell: transmission delay "
                                    "margin infinite (delay-independent)")
    return RequirementCheck("delay", Verdict.UNDECIDED, tau, None,
                            "transmission delay over a cell: decided only where K_o^2 >= 2 K_q d on a "
                            "regular graph; use a gain point otherwise")
