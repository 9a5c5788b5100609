"""Gains: the one exact-number parser and the one gain-box type.

Every gain value the toolbox receives (command line, case file, campaign file,
Python call) goes through :func:`parse_number`, which keeps it **exact**: a
decimal string or a float is taken as the decimal it prints as (``0.1`` is
``1/10``), an integer or :class:`~fractions.Fraction` as itself.  A gain box
is a :class:`GainBox`: named closed intervals of exact rationals, in a fixed
order, a point where ``lo == hi``.

JSON convention (shared by every ``to_dict()`` of the toolbox): an exact
rational is written as a JSON number when it is a finite binary float that
round-trips (``float(q) == q``), else as the string ``"p/q"``; ``±inf`` and
``nan`` are written as the strings ``"inf"``, ``"-inf"``, ``"nan"``
(:func:`json_number`).

>>> box = GainBox.parse({"K_o": "1.3:2", "K_q": 0.4, "beta": (0.1, 0.3)})
>>> box.names
('K_o', 'K_q', 'beta')
>>> box["K_o"].lo, box["K_q"].is_point
(Fraction(13, 10), True)
>>> len(box.vertices())
4
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from itertools import product
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.ranges import check_range, show_number
from formsync_design.textio import check_ascii

__all__ = [
    "parse_number",
    "parse_real",
    "GainRange",
    "GainBox",
    "parse_gain_range",
    "json_number",
]


#: The magnitude every number read must stay within (``|x| <= MAX_MAGNITUDE``, and a
#: nonzero ``|x| >= MIN_MAGNITUDE``, so that it converts to a finite, nonzero float);
#: the narrower range of each quantity is in :mod:`formsync_design.ranges`.
MAX_MAGNITUDE = 1e15
MIN_MAGNITUDE = 1e-300
_MAX_EXACT, _MIN_EXACT = Fraction(10**15), Fraction(1, 10**300)
_MAX_TEXT = 200
_NUMBER_TEXT = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE]([+-]?\d{1,4}))?|[+-]?\d+/\d+", re.ASCII)


def parse_number(value: Any, name: str) -> Fraction:
    """The one exact-number parser: ``value`` as an exact :class:`Fraction`.

    Accepts ``int``, ``Fraction``, finite ``float``/numpy floats (taken as the
    decimal they print as), numpy integers and decimal/fraction strings
    (``"0.1"``, ``"1e-3"``, ``"3/7"``).  Raises :class:`InputError` naming
    ``name`` for anything else (booleans, NaN, inf, text) and for a magnitude beyond
    :data:`MAX_MAGNITUDE` (or a nonzero one below :data:`MIN_MAGNITUDE`), checked
    before any arithmetic (``"1e999999999"`` is refused without computing its power).

    >>> parse_number("0.1", "K_o"), parse_number(0.1, "K_o"), parse_number("3/7", "x")
    (Fraction(1, 10), Fraction(1, 10), Fraction(3, 7))
    >>> parse_number("nan", "K_o")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a finite number for K_o, received 'nan'
    >>> parse_number("1e400", "k_p")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected k_p of magnitude at most 1e+15, received '1e400'
    """
    q = _exact(value, name)
    if q and not _MIN_EXACT <= abs(q) <= _MAX_EXACT:
        shown = repr(value) if isinstance(value, str) else show_number(q)
        bound = (f"at most {MAX_MAGNITUDE:g}" if abs(q) > MAX_MAGNITUDE
                 else f"0 or at least {MIN_MAGNITUDE:g}")
        raise InputError(f"expected {name} of magnitude {bound}, received {shown}")
    return q


def _exact(value: Any, name: str) -> Fraction:
    if isinstance(value, Fraction):
        return value
    if isinstance(value, (bool, np.bool_)):
        raise InputError(f"expected a number for {name}, received {value!r}")
    if isinstance(value, (int, np.integer)):
        if abs(int(value)) > MAX_MAGNITUDE:
            raise InputError(f"expected {name} of magnitude at most {MAX_MAGNITUDE:g}, received "
                             f"{show_number(int(value))}")
        return Fraction(int(value))
    if isinstance(value, (float, np.floating)):
        f = float(value)
        if not math.isfinite(f):
            raise InputError(f"expected a finite number for {name}, received {f!r}")
        return Fraction(repr(f))
    if isinstance(value, str):
        t = value.strip()
        shown = repr(value) if len(value) <= 40 else repr(value[:37] + "...")
        check_ascii(value[:_MAX_TEXT], name)  # float() reads '\u09ea' (Bengali 4) as 4
        m = _NUMBER_TEXT.fullmatch(t) if len(t) <= _MAX_TEXT else None
        if m is None:
            try:
                f = float(t) if len(t) <= _MAX_TEXT else 0.0
            except ValueError:
                raise InputError(f"expected a number for {name}, received {shown}") from None
            if not math.isfinite(f):
                raise InputError(f"expected a finite number for {name}, received {shown}") from None
            raise InputError(f"expected a number for {name}, received {shown}") from None
        if m.group(4) is not None and abs(int(m.group(4))) > 400:
            raise InputError(f"expected {name} of magnitude at most {MAX_MAGNITUDE:g}, received "
                             f"{shown}" if int(m.group(4)) > 0 else
                             f"expected {name} of magnitude 0 or at least {MIN_MAGNITUDE:g}, "
                             f"received {shown}")
        try:
            return Fraction(t)
        except (ValueError, ZeroDivisionError):
            raise InputError(f"expected a number for {name}, received {shown}") from None
    raise InputError(f"expected a number for {name}, received {type(value).__name__} "
                     f"{repr(value)[:40]}")


def parse_real(value: Any, name: str) -> float:
    """A finite real number as a ``float`` (through :func:`parse_number`, the one parser).

    >>> parse_real("1e3", "a"), parse_real(2, "b")
    (1000.0, 2.0)
    """
    return float(parse_number(value, name))


@dataclass(frozen=True)
class GainRange:
    """A closed gain interval ``[lo, hi]`` (``lo == hi`` for a single value), exact.

    >>> GainRange("K_o", Fraction(1), Fraction(2)).mid
    Fraction(3, 2)
    """

    name: str
    lo: Fraction
    hi: Fraction

    def __post_init__(self) -> None:
        lo, hi = parse_number(self.lo, self.name), parse_number(self.hi, self.name)
        if hi < lo:
            raise InputError(
                f"expected LO <= HI for {self.name}, received reversed range {float(lo):g}:{float(hi):g}"
            )
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    @property
    def is_point(self) -> bool:
        return self.lo == self.hi

    @property
    def mid(self) -> Fraction:
        return (self.lo + self.hi) / 2

    @property
    def width(self) -> Fraction:
        return self.hi - self.lo

    def contains(self, value: Any) -> bool:
        v = parse_number(value, self.name)
        return self.lo <= v <= self.hi

    def __str__(self) -> str:
        return f"{float(self.lo):g}" if self.is_point else f"{float(self.lo):g}:{float(self.hi):g}"

    def to_dict(self) -> dict[str, Any]:
        return {"lo": json_number(self.lo), "hi": json_number(self.hi)}


def parse_gain_range(
    text: Any, name: str, *, positive: bool = True, nonnegative: bool = False
) -> GainRange:
    """Parse ``X`` or ``LO:HI`` (or a number, a pair, a :class:`GainRange`) into a range.

    ``positive`` requires ``lo > 0``; ``nonnegative`` (which overrides it)
    requires ``lo >= 0``.  Both bounds must lie in the range of a gain
    (:mod:`formsync_design.ranges`: ``|x| <= 1e6``).

    >>> parse_gain_range("0.1:2", "K_o")
    GainRange(name='K_o', lo=Fraction(1, 10), hi=Fraction(2, 1))
    >>> parse_gain_range("0:1", "K_v", nonnegative=True).lo
    Fraction(0, 1)
    """
    if isinstance(text, GainRange):
        lo, hi = text.lo, text.hi
    elif isinstance(text, (tuple, list)):
        if len(text) != 2:
            raise InputError(f"expected {name} as (lo, hi), received {len(text)} values")
        lo, hi = parse_number(text[0], name), parse_number(text[1], name)
    elif isinstance(text, str):
        parts = text.split(":")
        if len(parts) == 1:
            lo = hi = parse_number(parts[0], name)
        elif len(parts) == 2:
            if not parts[0].strip() or not parts[1].strip():
                raise InputError(f"expected {name} as X or LO:HI, received {text!r} (empty bound)")
            lo, hi = parse_number(parts[0], name), parse_number(parts[1], name)
        else:
            raise InputError(f"expected {name} as X or LO:HI, received {text!r}")
    else:
        lo = hi = parse_number(text, name)
    check_range(lo, "gain", name)
    check_range(hi, "gain", name)
    if hi < lo:
        raise InputError(f"expected LO <= HI for {name}, received reversed range {text!r}")
    if nonnegative:
        if lo < 0:
            raise InputError(f"expected a non-negative {name}, received {_show(text)}")
    elif positive and lo <= 0:
        raise InputError(f"expected a positive {name}, received {_show(text)}")
    return GainRange(name, lo, hi)


def _show(text: Any) -> str:
    if isinstance(text, GainRange):
        return str(text)
    if isinstance(text, (tuple, list)):
        return ":".join(f"{float(parse_number(v, 'x')):g}" for v in text)
    if isinstance(text, str):
        return repr(text)
    return f"{float(parse_number(text, 'x')):g}"


@dataclass(frozen=True)
class GainBox:
    """Named closed gain intervals in a fixed order: the one gain-box type.

    Build with :meth:`parse` (from a mapping of names to values, ``"LO:HI"``
    strings, ``(lo, hi)`` pairs or :class:`GainRange`; or from a sequence in
    ``names`` order).  ``bounds`` gives the exact ``((lo, hi), ...)`` tuple.
    """

    ranges: tuple[GainRange, ...]

    def __post_init__(self) -> None:
        names = [r.name for r in self.ranges]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"expected each gain once in a box, received {dup} more than once")

    # -- construction -------------------------------------------------------
    @classmethod
    def parse(
        cls,
        box: Any,
        names: Sequence[str] | None = None,
        *,
        positive: bool | Sequence[str] = True,
    ) -> GainBox:
        """Normalize ``box`` to a :class:`GainBox` over ``names`` (default: the mapping's keys).

        ``positive``: ``True`` (every gain ``> 0``), ``False`` (``>= 0``), or the
        names of the gains that must be ``> 0`` (the rest ``>= 0``).

        >>> GainBox.parse([1, (2, 3)], ["a", "b"]).bounds
        ((Fraction(1, 1), Fraction(1, 1)), (Fraction(2, 1), Fraction(3, 1)))
        >>> GainBox.parse({"a": 1}, ["a", "b"])
        Traceback (most recent call last):
        ...
        formsync_design.errors.InputError: expected a range for every gain ('a', 'b'), missing ['b']
        """
        if isinstance(box, GainBox):
            if names is None or tuple(names) == box.names:
                return box
            box = {r.name: r for r in box.ranges}
        if isinstance(box, Mapping):
            keys = list(box)
            order = list(names) if names is not None else keys
            unknown = [k for k in keys if k not in order]
            if unknown:
                raise InputError(f"expected gains {tuple(order)}, received unknown {unknown}")
            missing = [g for g in order if g not in box]
            if missing:
                raise InputError(f"expected a range for every gain {tuple(order)}, missing {missing}")
            items = [box[g] for g in order]
        else:
            if names is None:
                raise InputError("expected gain names with a sequence of ranges, received none")
            order = list(names)
            items = list(box)
            if len(items) != len(order):
                raise InputError(
                    f"expected {len(order)} gain ranges {tuple(order)}, received {len(items)}"
                )
        out = []
        for g, it in zip(order, items):
            strict = positive if isinstance(positive, bool) else g in positive
            out.append(parse_gain_range(it, g, positive=strict, nonnegative=not strict))
        return cls(tuple(out))

    # -- access -------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.ranges)

    @property
    def bounds(self) -> tuple[tuple[Fraction, Fraction], ...]:
        return tuple((r.lo, r.hi) for r in self.ranges)

    @property
    def is_point(self) -> bool:
        return all(r.is_point for r in self.ranges)

    def __getitem__(self, name: str) -> GainRange:
        for r in self.ranges:
            if r.name == name:
                return r
        raise KeyError(name)

    def __iter__(self) -> Iterator[GainRange]:
        return iter(self.ranges)

    def __len__(self) -> int:
        return len(self.ranges)

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def center(self) -> tuple[Fraction, ...]:
        return tuple(r.mid for r in self.ranges)

    def vertices(self) -> list[tuple[Fraction, ...]]:
        """Distinct vertices (a degenerate axis contributes one value), in product order."""
        axes = [(r.lo,) if r.is_point else (r.lo, r.hi) for r in self.ranges]
        return [tuple(v) for v in product(*axes)]

    def contains(self, point: Mapping[str, Any] | Iterable[Any]) -> bool:
        vals = [point[n] for n in self.names] if isinstance(point, Mapping) else list(point)
        return len(vals) == len(self) and all(r.contains(v) for r, v in zip(self.ranges, vals))

    def as_floats(self) -> dict[str, tuple[float, float]]:
        return {r.name: (float(r.lo), float(r.hi)) for r in self.ranges}

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` uniform samples, shape ``(n, len(self))`` (point axes constant)."""
        lo = np.array([float(r.lo) for r in self.ranges])
        hi = np.array([float(r.hi) for r in self.ranges])
        return lo + (hi - lo) * rng.random((int(n), len(self)))

    def with_range(self, rng: GainRange) -> GainBox:
        """A copy with ``rng`` replacing (or appended as) the range of its name."""
        if rng.name in self:
            return GainBox(tuple(rng if r.name == rng.name else r for r in self.ranges))
        return GainBox((*self.ranges, rng))

    def __str__(self) -> str:
        return ", ".join(f"{r.name}={r}" for r in self.ranges)

    def to_dict(self) -> dict[str, Any]:
        return {r.name: [json_number(r.lo), json_number(r.hi)] for r in self.ranges}


def json_number(x: Any) -> Any:
    """The toolbox's JSON number convention (module docstring).

    >>> json_number(Fraction(1, 4)), json_number(Fraction(1, 3)), json_number(float("inf"))
    (0.25, '1/3', 'inf')
    """
    if isinstance(x, Fraction):
        try:
            f = float(x)
        except OverflowError:  # beyond the float range: exact as "p/q"
            return f"{x.numerator}/{x.denominator}"
        if math.isfinite(f) and Fraction(f) == x:
            return int(x) if x.denominator == 1 and abs(x) < 2**53 else f
        return f"{x.numerator}/{x.denominator}"
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        f = float(x)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return f
    return x
