"""The largest certified box around a gain point: the box ``g_i [1 - s, 1 + s]`` (clipped to
the ranges) with the largest ``s`` that :func:`~formsync_design.certify.engine.certify_box`
certifies (bisection on the re-check, the final box certified with the SDP hint)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from formsync_design.certify.engine import Bounds, certify_box
from formsync_design.certify.results import CertificationResult

__all__ = ["largest_certified_box"]


def largest_certified_box(
    conditions: Any,
    point: dict[str, Fraction],
    ranges: Bounds,
    *,
    margin: Any = 0,
    iterations: int = 12,
) -> tuple[Bounds | None, float, CertificationResult | None]:
    """Largest ``s`` (bisection, ``iterations`` steps) such that the box
    ``g_i [1 - s, 1 + s]`` (clipped to ``ranges``) is certified.

    Returns ``(box, s, certificate)``; ``(None, 0, None)`` when even the point
    is not certified.  The bisection uses the re-check only; the final box
    is certified by :func:`~formsync_design.certify.engine.certify_box` with the SDP.

    >>> from fractions import Fraction as F
    >>> from formsync_design.derive.conditions import derive_conditions
    >>> pt = {"K_o": F(8, 5), "K_q": F(2, 5), "beta": F(3, 10)}
    >>> rng = ((F(1, 10), F(5)), (F(1, 10), F(5)), (F(1, 100), F(1)))
    >>> box, s, res = largest_certified_box(derive_conditions("ring:8"), pt, rng, iterations=6)
    >>> str(res.status), 0 < s < 1
    ('certified', True)
    """
    gains = tuple(conditions.gains)

    def box_of(s: Fraction) -> Bounds:
        out = []
        for g, (lo, hi) in zip(gains, ranges):
            v = point[g]
            out.append((max(lo, v * (1 - s)), min(hi, v * (1 + s))))
        return tuple(out)

    if not certify_box(conditions, box_of(Fraction(0)), margin=margin, use_sdp=False).certified:
        return None, 0.0, None
    lo, hi = Fraction(0), Fraction(99, 100)
    if certify_box(conditions, box_of(hi), margin=margin, use_sdp=False).certified:
        lo = hi
    else:
        for _ in range(iterations):
            mid = (lo + hi) / 2
            if certify_box(conditions, box_of(mid), margin=margin, use_sdp=False).certified:
                lo = mid
            else:
                hi = mid
    bx = box_of(lo)
    res = certify_box(conditions, bx, margin=margin)
    if not res.certified:  # the SDP gate failed on the final box: shrink once more
        return bx, float(lo), res
    return bx, float(lo), res
