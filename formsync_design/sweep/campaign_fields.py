"""The fields of a campaign's ``[campaign]`` table, one validator each, and the folder its
relative paths resolve against (:func:`campaign_base`).

:func:`~formsync_design.sweep.campaign.campaign_from_dict` runs :func:`campaign_field` on each
field in the order written, so the first error named is the first fault of the file.

>>> campaign_field("graphs", ["ring:4", " star:5 "], Path("."))
('ring:4', 'star:5')
>>> campaign_field("graphs", "ring:4", Path("."))
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected campaign.graphs as a list of graph-set specs (graphs = ['ring:4']), received the string 'ring:4'
"""

from __future__ import annotations

import re
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.gains import parse_number
from formsync_design.textio import confined_path

__all__ = ["CAMPAIGN_FIELDS", "campaign_field", "campaign_base", "shown"]


def _name(v: Any, base: Path) -> str:
    if not isinstance(v, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", v):
        raise InputError(f"expected campaign.name made of letters, digits, '_', '.', '-', "
                         f"received {shown(v)}")
    return v


def _title(v: Any, base: Path) -> str:
    if not isinstance(v, str):
        raise InputError(f"expected a string campaign.title, received {shown(v)}")
    return v


def _graphs(v: Any, base: Path) -> tuple[str, ...]:
    if isinstance(v, str):
        raise InputError(f"expected campaign.graphs as a list of graph-set specs (graphs = "
                         f"[{v!r:.40}]), received the string {v!r:.60}")
    if not isinstance(v, list) or not v or not all(isinstance(g, str) and g.strip() for g in v):
        raise InputError(f"expected campaign.graphs as a non-empty list of graph-set specs, "
                         f"received {shown(v)}")
    return tuple(g.strip() for g in v)


def _compare(v: Any, base: Path) -> str:
    """``campaign.compare``: a finished sweep folder, relative to the campaign's base."""
    if not isinstance(v, str):
        raise InputError(f"expected campaign.compare as the path of a sweep results folder, "
                         f"received {shown(v)}")
    v = v.strip()
    if v:
        p = Path(v) if Path(v).is_absolute() else base / v
        if not ((p / "manifest.json").is_file() and (p / "results.csv").is_file()):
            raise InputError(f"expected campaign.compare to name a finished sweep folder "
                             f"(manifest.json and results.csv; relative to the campaign file), "
                             f"received {v!r} (no such folder {str(p)!r})")
    return v


def _conditions(v: Any, base: Path) -> str:
    if v not in ("derived", "paper"):
        raise InputError(f"expected campaign.conditions derived or paper, received {shown(v)}")
    return str(v)


def _margin(v: Any, base: Path) -> Fraction:
    m = parse_number(v, "campaign.margin")
    if m < 0:
        raise InputError(f"expected a non-negative campaign.margin, received {float(m):g}")
    return m


def _design_text(v: Any, base: Path) -> Any:
    return v  # checked with the design (_design_ref), after the fields before it


CAMPAIGN_FIELDS: dict[str, Callable[[Any, Path], Any]] = {"name": _name, "title": _title, "graphs": _graphs, "compare": _compare,
                    "conditions": _conditions, "margin": _margin, "design": _design_text,
                    "spec": _design_text}


def shown(v: Any) -> str:
    """``repr(v)`` cut to 60 characters (a value in a one-line message)."""
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def campaign_field(key: str, value: Any, base: Path, source: str = "") -> Any:
    """The validated value of ``[campaign] key`` (``base``: the folder relative paths
    resolve against; ``source``: the campaign file, whose ``compare`` path must stay inside
    ``base``); a one-line :class:`InputError` naming the field otherwise."""
    if key == "compare" and source and isinstance(value, str) and value.strip():
        for rel in (value.strip(), f"{value.strip()}/manifest.json", f"{value.strip()}/results.csv"):
            confined_path(rel, source, "campaign.compare", base=base)  # a symlink out: refused
    return CAMPAIGN_FIELDS[key](value, base)


def campaign_base(path: str | Path) -> Path:
    """The folder a campaign file's relative paths (``compare``, ``dir:`` graph sets,
    ``montecarlo.case``) resolve against: the file's folder; for a campaign shipped with the
    package (``verification/NAME.toml``) the folder holding ``verification/``, the project
    root its regeneration command names them from.

    >>> from formsync_design.resources import case_file
    >>> shipped = case_file("liang2016").parent / "sweep_pd_atlas5.toml"
    >>> campaign_base(shipped) == shipped.parents[1]
    True
    >>> str(campaign_base("some/where/c.toml"))
    'some/where'
    """
    from formsync_design.resources import case_file

    p = Path(path)
    if p.resolve().parent == case_file("liang2016").resolve().parent:
        return p.parent.parent
    return p.parent
