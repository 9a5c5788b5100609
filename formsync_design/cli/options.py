"""Shared command-line conventions of every ``formsync`` subcommand.

Exit status: 0 success or certified; 1 ran fine but a negative finding; 2 bad
input or usage (one line on stderr naming what was expected and received);
3 a failure that is not the user's input (solver, compiler, cluster; one line
saying what failed and what to try); 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from typing import Any

from formsync_design.errors import InputError

# the one gain-range type and parser live in formsync_design.gains (re-exported here)
from formsync_design.gains import GainRange, json_number, parse_gain_range, parse_number

__all__ = [
    "EXIT_OK",
    "EXIT_NEGATIVE",
    "EXIT_USAGE",
    "EXIT_FAILURE",
    "EXIT_INTERRUPTED",
    "GainRange",
    "parse_gain_range",
    "parse_number",
    "parse_positive",
    "add_format_option",
    "emit_json",
    "to_json_value",
    "Progress",
]

EXIT_OK = 0
EXIT_NEGATIVE = 1
EXIT_USAGE = 2
EXIT_FAILURE = 3  # a failure that is not the user's input (solver, compiler, cluster)
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), as shells report it

def parse_positive(text: str, name: str) -> float:
    """Parse a finite, strictly positive float."""
    v = parse_number(text, name)
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


def to_json_value(obj: Any) -> Any:
    """``obj`` with every number in the toolbox's JSON convention
    (:func:`formsync_design.gains.json_number`: exact rationals as numbers when they
    round-trip, else ``"p/q"``; ``inf``/``-inf``/``nan`` as strings), numpy arrays
    as lists, mappings and sequences walked.

    >>> from fractions import Fraction
    >>> to_json_value({"a": Fraction(1, 3), "b": [float("inf"), Fraction(1, 2)]})
    {'a': '1/3', 'b': ['inf', 0.5]}
    """
    if isinstance(obj, Mapping):
        return {str(k): to_json_value(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json_value(v) for v in obj]
    if hasattr(obj, "tolist") and not isinstance(obj, (int, float)):
        return to_json_value(obj.tolist())
    if hasattr(obj, "to_dict") and callable(obj.to_dict):
        return to_json_value(obj.to_dict())
    if isinstance(obj, (str, type(None))):
        return obj
    return json_number(obj)


def emit_json(obj: Any) -> None:
    """Print ``obj`` as indented JSON, numbers in the toolbox's JSON convention
    (:func:`to_json_value`): a Fraction is never silently rounded and ``inf`` never
    makes the output invalid JSON.

    >>> from fractions import Fraction
    >>> emit_json({"margin": Fraction(1, 3), "t": float("inf")})
    {
      "margin": "1/3",
      "t": "inf"
    }
    """
    json.dump(to_json_value(obj), sys.stdout, indent=2, allow_nan=False)
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
