"""Shared command-line conventions of every ``formsync`` subcommand.

Exit status: 0 success or certified; 1 ran fine but a negative finding; 2 bad
input or usage (one line on stderr naming what was expected and received);
3 a failure that is not the user's input (solver, compiler, cluster; one line
saying what failed and what to try); 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from formsync_design.errors import InputError

__all__ = [
    "EXIT_OK",
    "EXIT_NEGATIVE",
    "EXIT_USAGE",
    "EXIT_FAILURE",
    "EXIT_INTERRUPTED",
    "GainRange",
    "parse_gain_range",
    "parse_positive",
    "add_format_option",
    "emit_json",
    "Progress",
]

EXIT_OK = 0
EXIT_NEGATIVE = 1
EXIT_USAGE = 2
EXIT_FAILURE = 3  # a failure that is not the user's input (solver, compiler, cluster)
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), as shells report it


@dataclass(frozen=True)
class GainRange:
    """A closed gain interval ``[lo, hi]`` (``lo == hi`` for a single value),
    kept exactly as the user typed it (rational, from the decimal text)."""

    name: str
    lo: Fraction
    hi: Fraction

    @property
    def is_point(self) -> bool:
        return self.lo == self.hi

    def __str__(self) -> str:
        return f"{float(self.lo):g}" if self.is_point else f"{float(self.lo):g}:{float(self.hi):g}"


def _exact(text: str, name: str) -> Fraction:
    t = text.strip()
    try:
        f = float(t)
    except ValueError:
        raise InputError(f"expected a number for {name}, received {text!r}") from None
    if not math.isfinite(f):
        raise InputError(f"expected a finite number for {name}, received {text!r}")
    try:
        return Fraction(t)
    except ValueError:
        return Fraction(f)


def parse_gain_range(text: str, name: str, *, positive: bool = True) -> GainRange:
    """Parse ``X`` or ``LO:HI`` into a :class:`GainRange`.

    >>> parse_gain_range("0.1:2", "K_o")
    GainRange(name='K_o', lo=Fraction(1, 10), hi=Fraction(2, 1))
    """
    parts = str(text).split(":")
    if len(parts) == 1:
        lo = hi = _exact(parts[0], name)
    elif len(parts) == 2:
        if not parts[0].strip() or not parts[1].strip():
            raise InputError(f"expected {name} as X or LO:HI, received {text!r} (empty bound)")
        lo, hi = _exact(parts[0], name), _exact(parts[1], name)
    else:
        raise InputError(f"expected {name} as X or LO:HI, received {text!r}")
    if hi < lo:
        raise InputError(f"expected LO <= HI for {name}, received reversed range {text!r}")
    if positive and lo <= 0:
        raise InputError(f"expected a positive {name}, received {text!r}")
    return GainRange(name, lo, hi)


def parse_positive(text: str, name: str) -> float:
    """Parse a finite, strictly positive float."""
    v = _exact(text, name)
    if v <= 0:
        raise InputError(f"expected a positive {name}, received {text!r}")
    return float(v)


def add_format_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="output for people (text, default) or for machines (json)",
    )


def _default(o: Any) -> Any:
    if isinstance(o, Fraction):
        return float(o)
    if hasattr(o, "tolist"):
        return o.tolist()
    if hasattr(o, "item"):
        return o.item()
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


def emit_json(obj: Any) -> None:
    """Print ``obj`` as indented JSON (Fractions and numpy values converted)."""
    json.dump(obj, sys.stdout, indent=2, default=_default, allow_nan=False)
    sys.stdout.write("\n")


class Progress:
    """Progress on stderr for long work (silent when ``enabled`` is False)."""

    def __init__(self, total: int, label: str, enabled: bool = True) -> None:
        import time

        self.total = max(int(total), 1)
        self.label = label
        self.enabled = enabled and sys.stderr.isatty()
        self.done = 0
        self._t0 = time.perf_counter()
        self._last = 0.0

    def update(self, k: int = 1) -> None:
        import time

        self.done += k
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self._last < 0.2 and self.done < self.total:
            return
        self._last = now
        el = now - self._t0
        rate = self.done / el if el > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        sys.stderr.write(
            f"\r{self.label}: {self.done}/{self.total} ({rate:.1f}/s, ETA {eta:.0f}s)   "
        )
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()
