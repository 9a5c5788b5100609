"""Shared command-line conventions of every ``formsync`` subcommand.

Exit status: 0 success or certified; 1 ran fine but a negative finding; 2 bad
input or usage (one line on stderr naming what was expected and received);
3 a failure that is not the user's input (solver, compiler, cluster; one line
saying what failed and what to try); 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError

__all__ = [
    "closing_lines",
    "EXIT_OK",
    "EXIT_NEGATIVE",
    "EXIT_USAGE",
    "EXIT_FAILURE",
    "EXIT_INTERRUPTED",
    "parse_positive",
    "whole_number",
    "add_format_option",
    "emit_json",
    "to_json_value",
    "add_design_option",
    "design_box",
    "parse_gain_assignments",
    "DESIGN_HELP",
    "add_theorem_option",
    "design_graph",
    "write_summary_and_runs",
    "add_trust_option",
    "with_design_code",
    "design_gains",
    "check_out_dir",
]

DESIGN_HELP = (
    "the design (controller, Lyapunov candidate, gains, graph class): a shipped design's name "
    "(liang2016, pd_consensus) or a design .py file; default liang2016 (--spec is the old name)"
)

EXIT_OK = 0
EXIT_NEGATIVE = 1
EXIT_USAGE = 2
EXIT_FAILURE = 3  # a failure that is not the user's input (solver, compiler, cluster)
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), as shells report it

def add_design_option(p: argparse.ArgumentParser) -> None:
    """``--design NAME|FILE`` (alias ``--spec``), stored as ``args.spec``."""
    p.add_argument("--design", "--spec", dest="spec", default=None, metavar="NAME|FILE",
                   help=DESIGN_HELP)


def add_theorem_option(p: argparse.ArgumentParser) -> None:
    """``--allow-outside-theorem``: run on a graph the design's theorem does not cover."""
    p.add_argument("--allow-outside-theorem", action="store_true",
                   help="run on a graph that lacks a property the design's theorem needs (e.g. a "
                   "directed graph for an undirected-graph design); every output is flagged")


def design_graph(graph: Any, spec: Any, allow_outside: bool = False, *,
                 derivation: bool = True) -> tuple[Any, Any]:
    """The graph of a command and its :class:`~formsync_design.graphs.theorem.TheoremCheck`
    against ``spec``'s declared graph class.

    ``derivation=True`` (derive, certify, region, design): the Lyapunov derivation needs an
    undirected unweighted graph, so a directed or weighted one is refused even with
    ``allow_outside``; simulations take any graph the check allows.

    >>> from formsync_design.spec.loader import load_spec
    >>> g, chk = design_graph("ring:6", load_spec())
    >>> g.name, chk.inside
    ('ring:6', True)
    """
    from formsync_design.errors import GraphError
    from formsync_design.graphs import Graph
    from formsync_design.graphs.theorem import check_theorem_graph, load_graph

    g = load_graph(graph)
    chk = check_theorem_graph(g, spec.decl.graphs, allow_outside=allow_outside, design=spec.name)
    if derivation and not isinstance(g, Graph):
        raise GraphError(
            f"expected an undirected unweighted graph for the Lyapunov derivation of design "
            f"{spec.name}, received {g.name!r} (directed or weighted); simulate it with "
            "--allow-outside-theorem"
        )
    if not isinstance(g, Graph) and g.has_leader and "leader-reachable" not in spec.decl.graphs:
        raise GraphError(
            f"expected no leader for design {spec.name} (its controller has no pinning term), "
            f"received {g.name!r} with pinning gains"
        )
    return g, chk


def parse_gain_assignments(items: Any) -> dict[str, str]:
    """``["k_p=1:2", "k_d=3"]`` as ``{"k_p": "1:2", "k_d": "3"}`` (each name once).

    >>> parse_gain_assignments(["k_p=1:2", "k_d = 3"])
    {'k_p': '1:2', 'k_d': '3'}
    """
    out: dict[str, str] = {}
    for it in items or ():
        name, sep, value = str(it).partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise InputError(f"expected --gain NAME=X or NAME=LO:HI, received {it!r}")
        if name in out:
            raise InputError(f"expected each gain once, received --gain {name}= twice")
        out[name] = value
    return out


def design_box(spec: Any, gains: Any, legacy: Mapping[str, Any] | None = None) -> Any:
    """The gain box of a command: the design's box dimensions from ``--gain`` (and the
    legacy ``--ko/--kq/--beta`` of the classic gains), a controller gain not given
    taking its declared default range; a multiplier not given is left out (searched).

    Returns a :class:`~formsync_design.gains.GainBox` over the design's gains in
    declaration order.

    >>> from formsync_design.spec.loader import load_spec
    >>> str(design_box(load_spec("pd_consensus"), ["k_d=2", "eps=0.1"]))
    'k_p=0.1:2, k_d=2, eps=0.1'
    """
    from formsync_design.gains import GainBox, GainRange, parse_gain_range

    given = dict(gains) if isinstance(gains, Mapping) else parse_gain_assignments(gains)
    for name, val in (legacy or {}).items():
        if val is None:
            continue
        if name not in spec.decl.family_gains:
            raise InputError(
                f"expected the gains of design {spec.name} ({', '.join(spec.gains)}), received "
                f"--{ {'K_o': 'ko', 'K_q': 'kq', 'beta': 'beta'}.get(name, name)} ({name})"
            )
        if name in given:
            raise InputError(f"expected {name} once, received it as --gain and as a flag")
        given[name] = val
    unknown = [n for n in given if n not in spec.decl.family_gains]
    if unknown:
        sw = spec.decl.switching
        extra = f" (the switching gain {sw} is not a box dimension)" if sw in unknown else ""
        raise InputError(
            f"expected the gains of design {spec.name} ({', '.join(spec.gains)}), received "
            f"{unknown}{extra}"
        )
    ranges = []
    for g in spec.decl.gains:
        if g.name not in spec.decl.family_gains:
            continue
        if g.name in given:
            ranges.append(parse_gain_range(given[g.name], g.name))
        elif str(g.role) == "multiplier":
            continue
        elif g.range is not None:
            ranges.append(GainRange(g.name, g.range.lo, g.range.hi))
        else:
            flag = {"K_o": "--ko", "K_q": "--kq", "beta": "--beta"}.get(g.name)
            how = f"{flag} or --gain {g.name}=X|LO:HI" if flag else f"--gain {g.name}=X|LO:HI"
            raise InputError(
                f"expected a value for gain {g.name} of design {spec.name} ({how}), received none"
            )
    return GainBox(tuple(ranges))


def whole_number(text: str) -> int:
    """An integer flag's value: ASCII digits with an optional sign (an argparse ``type``).

    Python's ``int`` reads a Bengali or fullwidth digit as a digit (``int("\u09ea")`` is 4,
    and the Bengali four looks like an 8), so such text is refused naming the character.

    >>> whole_number("12"), whole_number(" -3 ")
    (12, -3)
    >>> whole_number("\u09ea")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected an integer in ASCII digits 0-9, received '৪' (U+09EA at column 1)
    >>> whole_number("4.5")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected an integer in ASCII digits 0-9, received '4.5'
    """
    t = str(text).strip()
    for col, ch in enumerate(t, start=1):
        if ord(ch) > 127:
            raise argparse.ArgumentTypeError(
                f"expected an integer in ASCII digits 0-9, received {ch!r} (U+{ord(ch):04X} at "
                f"column {col})")
    if not re.fullmatch(r"[+-]?[0-9]+", t) or len(t) > 20:
        raise argparse.ArgumentTypeError(
            f"expected an integer in ASCII digits 0-9, received {t[:24]!r}")
    return int(t)


def parse_positive(text: str, name: str) -> float:
    """Parse a finite, strictly positive float."""
    from formsync_design.gains import parse_number

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


def add_trust_option(p: argparse.ArgumentParser) -> None:
    """``--trust-design FILE`` (repeatable): a design file a case or campaign file may name
    (hashed when the command starts; :mod:`formsync_design.spec.trust`)."""
    p.add_argument(
        "--trust-design",
        action="append",
        default=None,
        metavar="FILE",
        help="run the design file FILE when a case, scenario or campaign file names it (a "
        "relative .py path beside that file); it is hashed now and runs only with that "
        "content (repeatable). Shipped designs need no flag",
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
    from formsync_design.gains import json_number

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
    json.dump(to_json_value(with_design_code(obj)), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


def with_design_code(obj: Any) -> Any:
    """``obj`` (a mapping) with the key ``design_code``: the non-shipped design files loaded
    in this command (path and sha256, :func:`~formsync_design.spec.trust.session_design_code`),
    when there are any; else ``obj`` unchanged.

    >>> with_design_code({"a": 1})
    {'a': 1}
    """
    from formsync_design.spec.trust import session_design_code

    code = session_design_code()
    if not code or not isinstance(obj, Mapping) or "design_code" in obj:
        return obj
    return {**obj, "design_code": [c.to_dict() for c in code]}


def write_summary_and_runs(out_dir: Any, summary: Mapping[str, Any], rows: list[Mapping[str, Any]]) -> list[str]:
    """Write ``summary.json`` and ``runs.csv`` (one row per run, the first row's keys as the
    header) under ``out_dir`` (created); return the paths written.

    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()) / "mc"
    >>> [pathlib.Path(p).name for p in write_summary_and_runs(d, {"runs": 1}, [{"seed": 7}])]
    ['summary.json', 'runs.csv']
    """
    import csv
    from pathlib import Path

    from formsync_design.outdir import atomic_path, write_text

    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    write_text(d / "summary.json", json.dumps(with_design_code(summary), indent=2, allow_nan=False) + "\n")
    with atomic_path(d / "runs.csv") as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else [])
        w.writeheader()
        for row in rows:
            w.writerow(row)
    return [str(d / "summary.json"), str(d / "runs.csv")]


def closing_lines(assumptions: list[str] | tuple[str, ...], written: list[str]) -> list[str]:
    """The last lines of a text summary: the case's assumptions and the files written.

    >>> closing_lines(["ring:8 is assumed"], ["a.csv"])
    ['case assumptions:', '  - ring:8 is assumed', 'written: a.csv']
    """
    lines: list[str] = []
    if assumptions:
        lines.append("case assumptions:")
        lines += [f"  - {a}" for a in assumptions]
    if written:
        lines.append("written: " + ", ".join(written))
    return lines


def design_gains(spec: Any, case_gains: Any, given: Any) -> Any:
    """The controller gains of a run of ``spec``: ``--gain NAME=X`` values over the case's.

    Every controller gain of the design needs a value: from ``--gain`` or, when the
    case has a gain of that name, the case's; the switching gains ``K_v`` are the
    case's when the design has a switching term, else none.  Nothing is guessed:
    a gain with neither is an :class:`~formsync_design.errors.InputError`.

    >>> from formsync_design.spec.loader import load_spec
    >>> from formsync_design.sim import Gains
    >>> g = design_gains(load_spec("pd_consensus"), Gains(1.6, 0.4, 0.3, (0.01,) * 4),
    ...                  ["k_p=0.5", "k_d=1.5"])
    >>> g.as_dict(), g.K_v
    ({'k_p': 0.5, 'k_d': 1.5}, ())
    """
    from formsync_design.gains import parse_gain_range
    from formsync_design.sim import Gains

    named = parse_gain_assignments(given)
    ctrl = spec.decl.controller_gains
    unknown = [n for n in named if n not in ctrl]
    if unknown:
        raise InputError(f"expected --gain for the controller gains of design {spec.name} "
                         f"({', '.join(ctrl)}), received {unknown}")
    have = case_gains.as_dict()
    vals: dict[str, Any] = {}
    for n in ctrl:
        if n in named:
            r = parse_gain_range(named[n], n)
            if not r.is_point:
                raise InputError(f"expected a single value for --gain {n}= in a simulation, "
                                 f"received the range {named[n]!r}")
            vals[n] = float(r.lo)
        elif n in have:
            vals[n] = have[n]
        else:
            raise InputError(f"expected --gain {n}=X for design {spec.name} (the case has no gain "
                             f"{n}), received none")
    kv = case_gains.K_v if spec.decl.switching is not None else ()
    return Gains(vals, kv)


def check_out_dir(out: str | None, *, overwrite: bool = False,
                  results: tuple[str, ...] = ("summary.json",)) -> Path | None:
    """Validate ``--out`` before any computation and lock it for this command.

    The folder is created and locked (:func:`formsync_design.outdir.claim`: a second
    writer is refused, exit 2); a folder already holding a run's ``results`` (its
    ``summary.json``) is refused unless ``overwrite``, so two runs never silently
    replace each other's files.  A folder the lock created stays only if results are
    written into it.
    """
    if out is None:
        return None
    d = Path(out)
    if d.exists() and not d.is_dir():
        raise InputError(f"expected --out to be a directory, received the file {str(d)!r}")
    parent = next((a for a in (d, *d.parents) if a.exists()), Path("."))
    if not parent.is_dir():
        raise InputError(f"expected --out under a directory, received {str(d)!r}")
    import os

    if not os.access(parent, os.W_OK):
        raise InputError(f"expected a writable --out, received {str(d)!r} ({str(parent)!r} is read-only)")
    from formsync_design.outdir import claim

    claim(d)
    if not overwrite:
        found = [n for n in results if (d / n).exists()]
        if found:
            raise InputError(
                f"expected --out {str(d)!r} without the results of another run, received a folder "
                f"holding {found[0]}; pass --overwrite to replace them or choose another --out "
                "(nothing overwritten)")
    return d
