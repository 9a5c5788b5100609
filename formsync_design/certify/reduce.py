"""Conditions restricted to some gains: the other gains fixed at exact values.

A region map has three axes and the gain design sweeps two gains and a third; a design
with more gains (an agent design's ``K1, K2, P1, P2``) is mapped with the others fixed.
:func:`fix_gains` substitutes exact values into every family (exactly: coefficients times
the fixed values' powers, rebuilt through
:func:`~formsync_design.derive.families.family_from_entries`), :func:`pad_gains` adds gains
the families do not depend on (so a two-gain design has a third, trivial axis).  The result
is a ``ConditionsLike`` the certification functions take as they are.

>>> import sympy
>>> from fractions import Fraction as F
>>> from formsync_design.derive.families import family_from_sympy
>>> a, b, c = sympy.symbols("a b c", positive=True)
>>> fam = family_from_sympy("F", sympy.Matrix([[a * b, c], [c, b]]), (a, b, c), block_size=1)
>>> red = fix_gains(ReducedConditions("x", None, ("a", "b", "c"), (fam,)), {"b": F(2)})
>>> red.gains, red.families[0].evaluate((3, 1)).tolist()
(('a', 'c'), [[6.0, 1.0], [1.0, 2.0]])
>>> pad_gains(red, ("a", "c", "_axis")).families[0].gains
('a', 'c', '_axis')
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from formsync_design.derive.families import MatrixFamily, family_from_entries
from formsync_design.errors import InputError

__all__ = ["ReducedConditions", "fix_gains", "pad_gains", "three_axes"]


@dataclass(frozen=True)
class ReducedConditions:
    """Families in ``gains`` (a ``ConditionsLike``); ``fixed`` the values substituted."""

    source: str
    graph: Any
    gains: tuple[str, ...]
    families: tuple[MatrixFamily, ...]
    fixed: tuple[tuple[str, Fraction], ...] = ()


def _entries(f: MatrixFamily, keep: Sequence[int], values: Mapping[int, Fraction]) -> dict:
    out: dict[tuple[int, int], dict[tuple[int, ...], Fraction]] = {}
    for t in f.terms:
        c = Fraction(t.coefficient)
        for k, v in values.items():
            c *= Fraction(v) ** t.exponents[k]
        if c == 0:
            continue
        mono = tuple(t.exponents[k] for k in keep)
        M = t.dense()
        for i in range(f.size):
            for j in range(f.size):
                if M[i, j]:
                    slot = out.setdefault((i, j), {})
                    slot[mono] = slot.get(mono, Fraction(0)) + c * int(M[i, j])
    return {ij: {m: v for m, v in d.items() if v != 0} for ij, d in out.items()}


def fix_gains(conditions: Any, values: Mapping[str, Any]) -> ReducedConditions:
    """``conditions`` with the gains of ``values`` fixed (exact values, positive)."""
    gains = tuple(conditions.gains)
    unknown = [n for n in values if n not in gains]
    if unknown:
        raise InputError(f"expected gains among {list(gains)} to fix, received {unknown}")
    vals = {gains.index(n): Fraction(v) for n, v in values.items()}
    keep = [k for k in range(len(gains)) if k not in vals]
    names = tuple(gains[k] for k in keep)
    fams = tuple(
        family_from_entries(f.name, f.size, _entries(f, keep, vals), gains=names,
                            block_size=f.block_size, row_labels=tuple(f.row_labels),
                            spacecraft=f.spacecraft)
        for f in conditions.families)
    fixed = tuple(getattr(conditions, "fixed", ())) + tuple(
        (n, Fraction(v)) for n, v in values.items())
    return ReducedConditions(str(getattr(conditions, "source", "?")), conditions.graph, names,
                             fams, fixed)


def pad_gains(conditions: Any, names: Sequence[str]) -> ReducedConditions:
    """``conditions`` over ``names`` (its gains in that order plus gains it does not use)."""
    gains = tuple(conditions.gains)
    missing = [n for n in gains if n not in names]
    if missing:
        raise InputError(f"expected every gain of the conditions in {list(names)}, missing "
                         f"{missing}")
    pos = [gains.index(n) if n in gains else None for n in names]
    fams = []
    for f in conditions.families:
        ent: dict[tuple[int, int], dict[tuple[int, ...], Fraction]] = {}
        for t in f.terms:
            mono = tuple(0 if p is None else t.exponents[p] for p in pos)
            M = t.dense()
            for i in range(f.size):
                for j in range(f.size):
                    if M[i, j]:
                        slot = ent.setdefault((i, j), {})
                        slot[mono] = slot.get(mono, Fraction(0)) + Fraction(t.coefficient) * int(M[i, j])
        fams.append(family_from_entries(f.name, f.size, ent, gains=tuple(names),
                                        block_size=f.block_size, row_labels=tuple(f.row_labels),
                                        spacecraft=f.spacecraft))
    return ReducedConditions(str(getattr(conditions, "source", "?")), conditions.graph,
                             tuple(names), tuple(fams), tuple(getattr(conditions, "fixed", ())))


def three_axes(conditions: Any, box: Any) -> tuple[ReducedConditions, dict[str, Any]]:
    """Conditions over exactly three axes for a region map of ``box``: every free (range) axis,
    then point axes in gain order up to three; the remaining point axes are fixed, and a
    design with fewer than three gains gets trivial axes ``_axis1``, ... (a point at 1).

    Returns the reduced conditions and the box over its three axes.  More than three free axes
    is an :class:`InputError` naming them (fix some with a single value).
    """
    from formsync_design.certify.engine import as_box

    gains = tuple(conditions.gains)
    bx = as_box(box, gains)
    rng = dict(zip(gains, bx.bounds))
    free = [n for n in gains if rng[n][0] != rng[n][1]]
    if len(free) > 3:
        raise InputError(f"expected at most three gain ranges for a region map, received "
                         f"{free}; give the others a single value (--gain NAME=X)")
    points = [n for n in gains if n not in free]
    axes = [n for n in gains if n in free or n in points[: 3 - len(free)]]
    red = fix_gains(conditions, {n: rng[n][0] for n in points if n not in axes})
    pads = [f"_axis{k}" for k in range(1, 4 - len(axes))]
    if pads:
        red = pad_gains(red, tuple(axes) + tuple(pads))
    out_box: dict[str, Any] = {n: rng[n] for n in axes}
    out_box.update({p: (Fraction(1), Fraction(1)) for p in pads})
    return red, out_box
