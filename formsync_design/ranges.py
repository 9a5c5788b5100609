"""The documented finite range of every kind of number the toolbox reads.

Every number read from a data file or a flag is checked against the range of its
*quantity* before any arithmetic is done with it, and refused with a one-line
:class:`~formsync_design.errors.InputError` naming the field, the range and the value (exit
status 2).  The ranges are wide (they exclude only what no formation has: a gain of 1e400,
an arc weight of 1e308, an inertia of 1e20 kg m^2), so a number inside them keeps every
exact computation small and every float conversion finite.  The ranges bound magnitudes;
whether a value must also be positive (a step, a tolerance, a weight) is the reader's check,
made right after, with its own message.

=================  ===================  =============================================
quantity           magnitude            fields
=================  ===================  =============================================
``number``         |x| <= 1e15          any other number (the bound of every number)
``gain``           |x| <= 1e12          controller gains (``--gain``, ``[gains]``, boxes)
``weight``         |x| <= 1e6           arc weights ``a_ij``, pinning gains ``b_i``
``inertia``        |x| <= 1e9 kg m^2    inertia entries
``rate``           |x| <= 1e3 rad/s     body rates, rate spreads
``angle``          |x| <= 1e4 deg       Euler angles, angle spreads
``tolerance``      |x| <= 1e6           rtol, atol, q_tol, omega_tol, angle/rate tol
``horizon``        |x| <= 1e8 s         tf, max_tf, the claims' horizons, times
``step``           |x| <= 1e6 s         step, output_step, period, sample_period
``boundary_layer`` |x| <= 1e3           boundary_layer (phi)
``torque``         |x| <= 1e9 N m       torque limits and budgets, disturbance bounds
``frequency``      |x| <= 1e6 rad/s     disturbance frequencies
``distance``       |x| <= 1e12 m / km   altitudes, radii, orbit elements
``mu``             |x| <= 1e21          gravitational parameters (m^3/s^2)
=================  ===================  =============================================

>>> check_range(2.5, "gain", "gains.K_o")
2.5
>>> check_range(1e308, "weight", "weight of (1, 2)")
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected weight of (1, 2) (an arc weight or pinning gain) of magnitude at most 1e+06, received 1e+308
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from formsync_design.errors import InputError

__all__ = ["Quantity", "QUANTITIES", "check_range", "quantity_of", "show_number"]


@dataclass(frozen=True)
class Quantity:
    """A kind of number and its range ``|x| <= bound`` (module docstring table)."""

    name: str
    bound: float
    what: str


QUANTITIES: dict[str, Quantity] = {q.name: q for q in (
    Quantity("number", 1e15, "a number"),
    Quantity("gain", 1e12, "a controller gain"),
    Quantity("weight", 1e6, "an arc weight or pinning gain"),
    Quantity("inertia", 1e9, "an inertia entry, kg m^2"),
    Quantity("rate", 1e3, "a body rate, rad/s"),
    Quantity("angle", 1e4, "an angle, deg"),
    Quantity("tolerance", 1e6, "a tolerance"),
    Quantity("horizon", 1e8, "a time, s"),
    Quantity("step", 1e6, "a step, s"),
    Quantity("boundary_layer", 1e3, "a boundary layer"),
    Quantity("torque", 1e9, "a torque, N m"),
    Quantity("frequency", 1e6, "a frequency, rad/s"),
    Quantity("distance", 1e12, "a distance"),
    Quantity("mu", 1e21, "a gravitational parameter, m^3/s^2"),
)}

#: Field names (the last part of a key, without an index) and their quantity.
_BY_KEY: tuple[tuple[str, str], ...] = (
    (r"(?:.*_)?(?:rtol|atol|tol|q_tol|omega_tol|tolerance|fraction|threshold(?:_deg)?)", "tolerance"),
    (r"(?:.*_)?(?:tf|time|at|after_s|from)|max_tf|steady_from", "horizon"),
    (r"(?:.*_)?(?:step|period|sample_period)|periods", "step"),
    (r"(?:.*_)?(?:phi|boundary_layer)|phi_sweep", "boundary_layer"),
    (r"(?:.*_)?(?:torque_limit|torque_budget|budget|rms|vector|amplitude|offset|ubar)|"
     r"torque_limit_sweep", "torque"),
    (r"frequency", "frequency"),
    (r"inertia", "inertia"),
    (r"(?:.*_)?(?:rate|rates|rate_sigma|bias|noise)|rate0", "rate"),
    (r"(?:.*_)?deg|euler_deg|attitude0_deg", "angle"),
    (r"(?:.*_)?km|a|half_size|altitude", "distance"),
    (r"mu", "mu"),
    (r"weight|a_\d+,\d+|b_\d+|pinning|arcs", "weight"),
)


def quantity_of(key: str) -> Quantity:
    """The quantity of a field named ``key`` (``"simulation.tf"``, ``"spacecraft 2 rate"``,
    ``"gains.K_o"``); ``number`` when no rule names it.

    >>> quantity_of("simulation.tf").name, quantity_of("spacecraft 2 inertia").name
    ('horizon', 'inertia')
    >>> quantity_of("gains.k_p").name, quantity_of("claims.gyro_seed").name
    ('gain', 'number')
    """
    k = key.strip()
    if k.startswith(("gains.", "box ", "reference.", "[[box]]")) or ".gains." in k \
            or k.startswith("comparison_gains"):
        return QUANTITIES["gain"]
    last = re.split(r"[ .]", k)[-1]
    last = re.sub(r"\[\d+\]$", "", last)
    for pattern, q in _BY_KEY:
        if re.fullmatch(pattern, last):
            return QUANTITIES[q]
    return QUANTITIES["number"]


def show_number(x: Any) -> str:
    """``x`` as short text (``:g``; an exact value beyond the float range as ``~1e+400``).

    >>> show_number(Fraction(10) ** 400), show_number(0.5)
    ('~1e+400', '0.5')
    """
    if isinstance(x, Fraction):
        try:
            return f"{float(x):g}"
        except OverflowError:
            digits = len(str(abs(x.numerator))) - len(str(x.denominator))
            return f"~{'-' if x < 0 else ''}1e+{digits}"
    if isinstance(x, (int, float)) and not isinstance(x, bool):
        try:
            return f"{float(x):g}"
        except OverflowError:
            return f"~1e+{len(str(abs(int(x)))) - 1}"
    return repr(x)


def check_range(value: Any, quantity: str | Quantity, name: str) -> Any:
    """``value`` (a number: int, float, Fraction) when inside the quantity's range; else a
    one-line :class:`InputError` naming ``name``, the range and the value.  NaN and
    infinities are refused too.  Returns ``value`` unchanged."""
    q = quantity if isinstance(quantity, Quantity) else QUANTITIES[quantity]
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"expected a finite number for {name}, received {value!r}")
    if not -q.bound <= value <= q.bound:
        raise InputError(f"expected {name} ({q.what}) of magnitude at most {q.bound:g}, "
                         f"received {show_number(value)}")
    return value
