"""The curated API on every design form: what the generic functions of ``fs`` do with an
agent design (``FORM = "agent"``) or conditions that are not the three-gain Θ_i/Π families.

The command line reaches the agent paths (``region_agent``, ``design_agent``,
``run_agent_montecarlo``, the agent derivation report); the generic functions route there,
so ``fs.derive_conditions``, ``fs.write_derivation_report``, ``fs.region_map``,
``fs.design_gains``, ``fs.simulate`` and ``fs.monte_carlo`` accept every design the command
line accepts (a shipped name, a design file of one's own, a loaded design):

* :func:`agent_design_of` - the agent design a ``spec`` argument names, else ``None``;
* :func:`region_any` - a region map of conditions over any gains (at most three free axes,
  the multipliers searched per cell);
* :func:`design_any` - the certified grid point with the largest margin (agent conditions);
* :func:`monte_carlo_agents` - the agent Monte-Carlo from the generic arguments;
* :func:`derivation_command` - the ``Regenerate:`` command of a derivation report (a design
  given as a file is named by its path, which resolves; a shipped one by its name).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from formsync_design.errors import InputError

__all__ = ["agent_design_of", "region_any", "design_any", "monte_carlo_agents",
           "derivation_command", "agent_multiplier_ranges"]


def agent_design_of(spec: Any) -> Any:
    """The agent design ``spec`` resolves to (a loaded design, a shipped name, a file), else
    ``None`` (a Lagrangian design or the default).

    >>> agent_design_of("ma_so3").name, agent_design_of("pd_consensus"), agent_design_of(None)
    ('ma_so3', None, None)
    """
    if spec is None:
        return None
    if getattr(spec, "form", None) == "agent":
        return spec
    if getattr(spec, "form", None) is not None or not isinstance(spec, (str, Path)):
        return None
    from formsync_design.spec.loader import load_design

    d = load_design(spec)
    return d if getattr(d, "form", None) == "agent" else None


def agent_multiplier_ranges(conditions: Any, given: Any, design: Any = None) -> dict[str, Any]:
    """The multipliers of ``conditions`` not in ``given`` (``name -> GainRange``): the
    declared ranges of ``design`` (default: the shipped design the conditions name)."""
    gains = tuple(conditions.gains)
    missing = [n for n in gains if n not in given]
    if not missing:
        return {}
    if design is None:
        from formsync_design.resources import design_names
        from formsync_design.spec.loader import load_design

        name = getattr(conditions, "design", getattr(conditions, "spec_name", None))
        if not isinstance(name, str) or name not in design_names():
            raise InputError(f"expected a range for every gain of the conditions "
                             f"({', '.join(gains)}) or design= (whose multipliers are searched), "
                             f"received none for {missing}")
        design = load_design(name)
    out = {}
    for n in missing:
        g = design.decl.gain(n)
        if str(g.role) != "multiplier" or g.range is None:
            raise InputError(f"expected a value or range for the gain {n} of design "
                             f"{design.name}, received none")
        out[n] = g.range
    return out


def _bounds(ranges: Any) -> dict[str, Any]:
    from formsync_design.gains import GainBox

    box = ranges if isinstance(ranges, GainBox) else GainBox.parse(ranges)
    return {r.name: (r.lo, r.hi) for r in box.ranges}


def region_any(conditions: Any, ranges: Any, *, multipliers: Any = None, design: Any = None,
               resolution: int = 32, margin: Any = 0, progress: Any = None) -> Any:
    """A :class:`~formsync_design.certify.region.RegionMap` of ``conditions`` over any gains:
    the free axes of ``ranges`` and the searched ``multipliers`` (default: the design's, for
    the gains ``ranges`` does not give) make at most three axes; point gains are fixed
    (:func:`~formsync_design.certify.reduce.three_axes`), the multipliers searched per cell
    (:func:`~formsync_design.certify.multiregion.region_with_multipliers`)."""
    from formsync_design.certify.multiregion import region_with_multipliers
    from formsync_design.certify.reduce import three_axes

    given = _bounds(ranges)
    mult = dict(multipliers) if multipliers is not None else \
        agent_multiplier_ranges(conditions, given, design)
    full = {**given, **{n: (r.lo, r.hi) for n, r in mult.items()}}
    red, rbox = three_axes(conditions, full)
    fixed = {n: v for n, v in rbox.items() if n not in mult}
    return region_with_multipliers(red, fixed, {n: r for n, r in mult.items() if n in rbox},
                                   resolution=resolution, margin=margin, progress=progress)


def design_any(conditions: Any, ranges: Any, *, design: Any = None, grid: int = 4) -> Any:
    """The agent gain design (:func:`~formsync_design.certify.agent.design_agent`: the grid
    point of ``ranges`` with the largest certified margin, multipliers searched, and the
    largest certified box around it) of agent ``conditions``; ``design`` default: the shipped
    design the conditions name."""
    from formsync_design.certify.agent import design_agent
    from formsync_design.gains import GainBox

    if design is None:
        from formsync_design.resources import design_names
        from formsync_design.spec.loader import load_design

        name = getattr(conditions, "design", None)
        if not isinstance(name, str) or name not in design_names():
            raise InputError(f"expected design= for the conditions of the unshipped design "
                             f"{name!r} (its multipliers' ranges), received none")
        design = load_design(name)
    box = ranges if isinstance(ranges, GainBox) else GainBox.parse(ranges)
    return design_agent(design, conditions, box, grid=grid)


def monte_carlo_agents(design: Any, base: Any, box: Any = None, settings: Any = None,
                       options: Any = None, *, certify: bool = True,
                       progress: Any = None) -> Any:
    """:func:`~formsync_design.sim.agent_montecarlo.run_agent_montecarlo` from the generic
    arguments of ``fs.monte_carlo``: ``box`` default the point of ``base.gains``; ``settings``
    an :class:`~formsync_design.sim.agent_montecarlo.AgentMonteCarloSettings` or a
    :class:`~formsync_design.sim.montecarlo.MonteCarloSettings` (runs, seed, angles, rates
    taken from it); ``options`` an :class:`~formsync_design.sim.agents.AgentOptions`."""
    from formsync_design.gains import GainBox
    from formsync_design.sim.agent_montecarlo import (
        AgentMonteCarloSettings,
        run_agent_montecarlo,
    )
    from formsync_design.sim.agents import AgentOptions

    if box is None:
        vals = {}
        for n, v in base.gains.as_dict().items():
            lo, hi = (min(v), max(v)) if isinstance(v, tuple) else (v, v)
            vals[n] = f"{lo!r}:{hi!r}" if lo != hi else repr(lo)
        box = GainBox.parse(vals)
    elif not isinstance(box, GainBox):
        box = GainBox.parse(box)
    if settings is None:
        settings = AgentMonteCarloSettings()
    elif not isinstance(settings, AgentMonteCarloSettings):
        settings = AgentMonteCarloSettings(runs=int(settings.runs), seed=int(settings.seed),
                                           max_angle_deg=float(settings.max_angle_deg),
                                           max_rate=float(settings.max_rate))
    if options is None:
        options = AgentOptions()
    elif not isinstance(options, AgentOptions):
        raise InputError(f"expected AgentOptions for the agent design {design.name}, received "
                         f"{type(options).__name__}")
    return run_agent_montecarlo(design, base, box, settings, options, certify=certify,
                                progress=progress)


def derivation_command(spec_arg: Any, name: str, graph: Any) -> str:
    """The command that regenerates a derivation report: ``--design NAME`` for a shipped
    design, ``--design PATH`` (as given) for a design file.

    >>> derivation_command("pd_consensus", "pd_consensus", "ring:4")
    'formsync derive --design pd_consensus --graph ring:4'
    >>> derivation_command(Path("my/ma.py"), "ma", "ring:5")
    'formsync derive --design my/ma.py --graph ring:5'
    """
    import shlex

    from formsync_design.resources import design_file, design_names

    if isinstance(spec_arg, (str, Path)) and str(spec_arg) not in design_names():
        ref = str(spec_arg)
    else:
        path = getattr(spec_arg, "path", None)
        shipped = name in design_names() and (
            not path or Path(str(path)).resolve() == design_file(name).resolve())
        ref = name if shipped or not path else str(path)
    gname = getattr(graph, "name", graph)
    return shlex.join(["formsync", "derive", "--design", ref, "--graph", str(gname)])
