"""Delay requirement decided over a whole gain cell, any design (issue 15, items 2-3, 6).

The nominal loop ``q'' = c_qd q' + c_s s`` depends on the gains only through
``d = -c_qd`` and ``k = -c_s``; over a cell both lie in exact enclosures
``[d_lo, d_hi]``, ``[k_lo, k_hi]`` (:func:`~.modecheck.coefficient_ranges`, interval
bounds of the derived polynomials; for Liang et al. ``d = K_o``, ``k = K_q``, for the PD
baseline ``d = k_d``, ``k = k_p``).  Every gain of the cell, not only its corners, is
covered by monotonicity in ``(d, k)`` proven here (``d_lo, k_lo > 0`` required):

``processing`` (any graph)
    per mode ``s^2 + d s + k lambda e^{-s tau}``: the only crossing frequency
    solves ``w^4 + d^2 w^2 = b^2`` (``b = k lambda``) and the margin is
    ``atan(d / w) / w``.  ``w`` decreases in ``d`` and increases in ``b``;
    hence the margin increases in ``d`` (``atan(d/w)`` and ``1/w`` both grow) and
    decreases in ``k`` (both shrink).  The smallest margin over the cell is at most
    the one at ``(d_lo, k_hi)``, the largest at least the one at ``(d_hi, k_lo)`` (which
    need not be gain points: they bound every gain's margin).  A single crossing
    frequency crosses into the right half plane at every crossing delay, so beyond
    the margin the loop is unstable.  Certified: margin at the worst corner
    ``> tau``; refuted: margin at the best corner ``< tau`` (each by
    :func:`.delay.coefficient_delay_margin`, exact per mode).
``transmission`` (regular graph of degree ``m``)
    per mode ``|P_0(iw)|^2 - |P_1(iw)|^2 = w^4 + (d^2 - 2 k m) w^2 +
    k^2 (m^2 - (m - lambda)^2)``; for ``0 < lambda <= 2 m`` the last coefficient
    is ``>= 0``, so ``d^2 >= 2 k m`` leaves no crossing frequency: stable for
    every delay (Atay 2013).  Checked exactly in rationals at ``(d_lo, k_hi)``
    (the condition is monotone: hardest at that corner); otherwise, and on
    irregular graphs (sufficient Lyapunov-Krasovskii bound only, no monotonicity
    proven), the cell is undecided.
"""

from __future__ import annotations

import math
from typing import Any

from formsync_design.analysis.delay import DelayModel, coefficient_delay_margin
from formsync_design.analysis.modecheck import coefficient_ranges, split_box
from formsync_design.analysis.modes import mode_model
from formsync_design.analysis.requirements import RequirementCheck
from formsync_design.analysis.results import Verdict
from formsync_design.graphs import make_graph

__all__ = ["delay_cell_check"]


def delay_cell_check(graph: Any, box: Any, tau: float, model: str = "processing", *,
                     spec: Any = None) -> RequirementCheck:
    """Decide ``delay margin > tau`` for every gain of the cell ``box`` (the design's gains).

    Examples
    --------
    >>> b = {"K_o": "1.5:1.7", "K_q": "0.3:0.4", "beta": "0.2:0.3"}
    >>> delay_cell_check("ring:8", b, 0.5).status.value
    'certified'
    >>> delay_cell_check("ring:8", b, 5.0).status.value
    'refuted'
    >>> delay_cell_check("ring:8", {"k_p": "0.3:0.4", "k_d": "1.5:1.7"}, 0.5, spec="pd_consensus").status.value
    'certified'
    """
    g = make_graph(graph)
    m = DelayModel(str(model))
    mm = mode_model(spec)
    bx, _ = split_box(mm, box)
    (d_lo, d_hi), (k_lo, k_hi) = coefficient_ranges(mm, bx)
    if d_lo <= 0 or k_lo <= 0:
        return RequirementCheck("delay", Verdict.UNDECIDED, tau, None,
                                f"cell-level delay check needs d = -c_qd > 0 and k = -c_s > 0 on the cell "
                                f"(d in [{float(d_lo):g}, {float(d_hi):g}], k in [{float(k_lo):g}, {float(k_hi):g}])")
    if m is DelayModel.PROCESSING:
        lo = coefficient_delay_margin(g, -float(d_lo), -float(k_hi), m)[0]
        if lo > tau:
            return RequirementCheck("delay", Verdict.CERTIFIED, tau, lo,
                                    f"processing delay margin >= {lo:.6g} s over the cell (monotone in d = -c_qd, "
                                    f"k = -c_s: worst at d lo, k hi) exceeds tau = {tau:g} s")
        hi = coefficient_delay_margin(g, -float(d_hi), -float(k_lo), m)[0]
        if hi * (1 + 1e-8) < tau:  # margin is rounded down by 1e-9 relative
            return RequirementCheck("delay", Verdict.REFUTED, tau, hi,
                                    f"processing delay margin <= {hi:.6g} s over the cell (best at d hi, "
                                    f"k lo) is below tau = {tau:g} s")
        return RequirementCheck("delay", Verdict.UNDECIDED, tau, [lo, hi],
                                f"processing delay margin in [{lo:.6g}, {hi:.6g}] s over the cell straddles "
                                f"tau = {tau:g} s")
    if len(set(g.degrees)) == 1:
        deg = g.degrees[0]
        if d_lo**2 >= 2 * k_hi * deg:
            return RequirementCheck("delay", Verdict.CERTIFIED, tau, math.inf,
                                    f"d^2 >= 2 k m (d = -c_qd, k = -c_s, m = {deg}) on the whole cell: "
                                    "transmission delay margin infinite (delay-independent)")
    return RequirementCheck("delay", Verdict.UNDECIDED, tau, None,
                            "transmission delay over a cell: decided only where d^2 >= 2 k m (d = -c_qd, "
                            "k = -c_s) on a regular graph; use a gain point otherwise")
