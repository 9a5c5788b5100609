"""Comparisons of designs at equal peak torque: a common gain scale factor per design.

A comparison of control laws at their literal gains mixes the law with the size of its gains:
a design with larger gains converges sooner and spends more torque.  Here each comparison
design's gains (all but the ones the case holds, e.g. a threshold ``eps``) are multiplied by
one factor ``c``, and ``c`` is found by a 1-D search so that the design's peak torque on the
reference run equals the main design's (:func:`equal_peak_scale`: bracketing by doubling or
halving, then bisection in ``log c``, until the peak is within ``rtol`` of the target).  The
comparisons are then rerun with the scaled gains; :func:`ordering` and :func:`in_order` say in
which order the designs reached a threshold.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from formsync_design.errors import InputError, SimulationError

__all__ = ["EqualPeak", "equal_peak_scale", "scaled_gains", "ordering", "in_order"]


@dataclass(frozen=True)
class EqualPeak:
    """The factor ``scale`` found, the peak torque it gives, the target and the number of
    runs the search took."""

    scale: float
    peak: float
    target: float
    evaluations: int

    @property
    def relative_error(self) -> float:
        return abs(self.peak / self.target - 1)


def equal_peak_scale(peak_of: Callable[[float], float], target: float, *, rtol: float = 1e-3,
                     start: float = 1.0, step: float = 2.0,
                     max_evaluations: int = 60) -> EqualPeak:
    """The factor ``c`` with ``peak_of(c)`` within ``rtol`` of ``target`` (module docstring).

    ``peak_of`` need not be linear, only continuous with ``peak_of(lo) < target <
    peak_of(hi)`` on the bracket found by multiplying or dividing ``start`` by ``step``
    (bisection keeps the sign change).

    >>> r = equal_peak_scale(lambda c: 2 * c**1.5 + 1, 55.0, rtol=1e-6)
    >>> abs(2 * r.scale**1.5 + 1 - 55) <= 55e-6, round(r.scale, 4)
    (True, 9.0)
    """
    if not (target > 0 and math.isfinite(target) and 0 < rtol < 1 and step > 1):
        raise InputError(f"expected a positive target peak and 0 < rtol < 1, received {target!r}, "
                         f"{rtol!r} (step {step!r} > 1)")
    n = 0

    def f(c: float) -> float:
        nonlocal n
        n += 1
        return peak_of(c)

    c = start
    p = f(c)
    if abs(p / target - 1) <= rtol:
        return EqualPeak(c, p, target, n)
    lo = hi = c
    plo = phi = p
    while (phi < target) and n < max_evaluations:
        lo, plo = hi, phi
        hi *= step
        phi = f(hi)
    while (plo > target) and n < max_evaluations:
        hi, phi = lo, plo
        lo /= step
        plo = f(lo)
    if not plo <= target <= phi:
        raise SimulationError(f"no gain scale brackets the peak torque {target:g} N m within "
                              f"{max_evaluations} runs (last {plo:g} to {phi:g} N m)")
    for pc, cc in ((plo, lo), (phi, hi)):
        if abs(pc / target - 1) <= rtol:
            return EqualPeak(cc, pc, target, n)
    while n < max_evaluations:
        c = math.sqrt(lo * hi)
        p = f(c)
        if abs(p / target - 1) <= rtol:
            return EqualPeak(c, p, target, n)
        if p < target:
            lo = c
        else:
            hi = c
    raise SimulationError(f"the gain-scale search did not reach the peak torque {target:g} N m "
                          f"within rtol {rtol:g} in {max_evaluations} runs")


def scaled_gains(gains: Any, scale: float, hold: Sequence[str] = ()) -> Any:
    """``gains`` (a :class:`~formsync_design.sim.formation.Gains`) with every gain but those
    in ``hold`` multiplied by ``scale`` (a diagonal gain: each entry).

    >>> from formsync_design.sim.formation import Gains
    >>> scaled_gains(Gains({"K1": 1.5, "eps": 0.01}), 2.0, ["eps"]).as_dict()
    {'K1': 3.0, 'eps': 0.01}
    """
    from formsync_design.sim.formation import Gains

    out: dict[str, Any] = {}
    for k, v in gains.as_dict().items():
        if k in hold:
            out[k] = v
        elif isinstance(v, tuple):
            out[k] = tuple(float(x) * scale for x in v)
        else:
            out[k] = float(v) * scale
    return Gains(out)


def ordering(labels: Sequence[str], times: Sequence[float | None]) -> str:
    """The labels in the order of their times (``<``; equal times ``=``; not reached last).

    >>> ordering(["a", "b", "c"], [2.0, None, 1.0])
    'c < a < b (not reached)'
    """
    key = [(math.inf if t is None else t, i) for i, t in enumerate(times)]
    key.sort()
    parts = []
    for j, (t, i) in enumerate(key):
        name = labels[i] + (" (not reached)" if times[i] is None else "")
        if j:
            parts.append(" = " if t == key[j - 1][0] and math.isfinite(t) else " < ")
        parts.append(name)
    return "".join(parts)


def in_order(times: list[float | None]) -> bool:
    """Strictly increasing, a time not reached (``None``) counting as later than any reached
    one; two unreached times are not ordered.

    >>> in_order([1.0, 2.0, None]), in_order([1.0, None, None]), in_order([2.0, 1.0, 3.0])
    (True, False, False)
    """
    v = [math.inf if t is None else t for t in times]
    return all(a < b for a, b in zip(v, v[1:]))
