"""The defaults of a ``formsync`` command given only ``--design NAME`` (the command-line side
of :mod:`formsync_design.verify.defaults`): the design's case, graph, gains, box and
convergence criterion, each said in one line on stderr (``formsync CMD: gains from
verification/X.toml: ...``), and the one-line refusal of a command that does not apply to a
design (exit status 1).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from formsync_design.cli.options import EXIT_NEGATIVE
from formsync_design.verify.defaults import (
    Defaults,
    case_source,
    cycle_case,
    is_tracking,
    resize_note,
)

__all__ = [
    "not_applicable",
    "refuse_tracking",
    "refuse_uncertified",
    "agent_case",
    "agent_graph",
    "case_pinning",
    "agent_box",
    "gains_text",
    "agent_criterion",
    "undisturbed_convergence",
    "lagrangian_defaults",
    "lagrangian_graph",
    "lagrangian_point_box",
    "default_out",
    "lagrangian_range_gains",
    "case_label",
]


def not_applicable(command: str, reason: str) -> int:
    """Say in one line on stderr why ``command`` does not apply; return exit status 1."""
    sys.stderr.write(f"formsync {command}: not applicable: {' '.join(reason.split())}\n")
    return EXIT_NEGATIVE


def refuse_tracking(command: str, design: Any, what: str) -> int | None:
    """Exit status 1 with the reason when ``design`` is a single spacecraft tracking its
    reference on the relative-orbit plant (``what`` names the formation stage), else ``None``."""
    if not is_tracking(design):
        return None
    return not_applicable(command, f"design {design.name} is one spacecraft tracking its "
                          f"reference (PLANT = 'relative-orbit', no communication graph): {what} "
                          f"applies to formation designs; run formsync verify --design "
                          f"{design.name}")


def refuse_uncertified(command: str, design: Any) -> int | None:
    """Exit status 1 with the reason when the agent ``design`` has no certificate (no
    ``conditions(c)`` hook), else ``None``."""
    if getattr(design, "form", None) != "agent" or callable(design.module.get("conditions")):
        return None
    return not_applicable(command, f"design {design.name} declares no certificate (no "
                          f"conditions(c) hook in {Path(str(design.path)).name}): there is "
                          "nothing to certify; simulate it or run formsync montecarlo")


def gains_text(values: Any) -> str:
    """``K_o=1.6, K_q=0.4`` (a diagonal gain as its entries)."""
    parts = []
    for n, v in dict(values).items():
        if isinstance(v, (tuple, list)):
            parts.append(f"{n}=(" + ", ".join(f"{float(x):g}" for x in v) + ")")
        else:
            parts.append(f"{n}={float(v):g}")
    return ", ".join(parts)


def agent_case(design: Any, case_arg: Any, gains: Any, defaults: Defaults | None) -> Any:
    """The :class:`~formsync_design.verify.agentcase.AgentCase` of an agent run without
    ``--case``: the design's shipped case (its own, or the case where it is the comparison
    design, with the comparison's gains), ``None`` when no shipped case names it."""
    from formsync_design.verify.agentcase import load_agent_case, parse_agent_case
    from formsync_design.verify.defaults import agent_case_source_doc

    if case_arg is not None:
        return None
    src = case_source(design)
    if src is None:
        return None
    if src.role == "design":
        case = load_agent_case(src.path, design=design)
    else:
        case = parse_agent_case(agent_case_source_doc(design, src), str(src.path), design=design)
    if defaults is not None:
        defaults.add(f"case from {src.describe()}")
        if not gains:
            defaults.add(f"gains from {src.label}: {gains_text(case.gains.as_dict())}")
    return case


def case_pinning(design: Any, case: Any, graph: Any, defaults: Defaults | None) -> Any:
    """``graph`` with the pinning of ``case`` when ``design`` has a leader and ``graph`` (from
    ``--graph``) has no pinning gains: the case's rule resized to the graph
    (:meth:`~formsync_design.verify.agentcase.AgentCase.pinning_rule`), said in ``defaults``.
    Any other graph is returned as it is.

    >>> from formsync_design.spec.loader import load_design
    >>> lv = load_design("lv2012")
    >>> d = Defaults()
    >>> g = case_pinning(lv, agent_case(lv, None, None, None), "ring:4", d)
    >>> g.name, [str(b) for b in g.pinning], d.lines
    ('ring:4', ['1', '1', '1', '1'], ['pinning for --graph ring:4: every spacecraft pinned with b = 1 (the rule of the case lv2012)'])
    """
    from formsync_design.graphs.digraph_io import make_digraph
    from formsync_design.graphs.theorem import load_graph

    if case is None or not getattr(design.decl, "leader", False):
        return graph
    g = make_digraph(load_graph(graph))
    if g.has_leader:
        return graph
    rule = case.pinning_rule(g.n)
    if rule is None:
        return graph
    pins, text = rule
    if defaults is not None:
        defaults.add(f"pinning for --graph {g.name}: {text}")
    return make_digraph(g, pinning=pins)


def agent_graph(case: Any, graph_arg: Any, defaults: Defaults | None,
                design: Any = None) -> tuple[Any, Any]:
    """``(case, graph)``: ``--graph`` (the case resized to its size when it differs, said in
    ``defaults``; a leader ``design``'s graph without pinning takes the case's pinning rule,
    :func:`case_pinning`), else the case's graph."""
    from formsync_design.graphs.theorem import load_graph

    if graph_arg is None:
        g = case.graph()
        if defaults is not None:
            defaults.add(f"graph from the case {case.name}: {g.name} ({g.n} spacecraft)")
        return case, g
    g = case_pinning(design, case, load_graph(graph_arg), defaults) if design is not None \
        else load_graph(graph_arg)
    if g.n != case.n:
        if defaults is not None:
            defaults.add(resize_note(case.name, case.n, g.name, g.n).replace(
                "rate)", "rate, controller states)"))
        case = case.cycled(g.n)
    return case, case.graph(g)


def agent_box(design: Any, gains: Any, case: Any, defaults: Defaults | None, *,
              free: int = 0) -> Any:
    """The gain box of an agent certificate: ``--gain`` values; a controller gain not given
    takes the case's value, except (``free > 0``) the first ``free`` family gains with a
    declared range, minus one per searched multiplier (a region map has at most three free
    axes), which span that range.  Without a case a gain not given takes its declared range."""
    from formsync_design.cli.options import design_box, parse_gain_assignments

    named = parse_gain_assignments(gains)
    given = dict(named)
    have = case.gains.as_dict() if case is not None else {}
    mult = [n for n in design.decl.multipliers if n not in named]
    nfree = max(0, min(free, 3 - len(mult))) if free else 0
    spans: list[str] = []
    fixed: dict[str, Any] = {}
    for g in design.decl.gains:
        n = g.name
        if n in named or n not in design.decl.family_gains or str(g.role) == "multiplier":
            continue
        if nfree and g.range is not None and g.range.lo != g.range.hi and len(spans) < nfree:
            spans.append(n)
            continue
        if n in have:
            v = have[n]
            lo, hi = (min(v), max(v)) if isinstance(v, tuple) else (v, v)
            given[n] = f"{lo!r}:{hi!r}" if lo != hi else repr(lo)
            fixed[n] = v
    box = design_box(design, given)
    if defaults is not None and not named:
        if fixed and case is not None:
            defaults.add(f"gains from {case_label(case)}: {gains_text(fixed)}")
        if spans:
            defaults.add("gains over their declared ranges: " + ", ".join(
                f"{n}={box[n].lo}:{box[n].hi}" for n in spans))
        if mult:
            defaults.add("multipliers searched over their declared ranges: " + ", ".join(mult))
    return box


def agent_criterion(case: Any, opt: Any, disturbance: Any) -> tuple[str, Any]:
    """``(the criterion in words, the disturbance model to run)`` of an agent run of ``case``
    with options ``opt``: the case's ``angle_tol``/``rate_tol``; a case that judges convergence
    on the undisturbed loop (:func:`undisturbed_convergence`: e.g. lv2012's claim
    'asymptotically stable without external disturbance'; under disturbance it claims ultimate
    boundedness) has its runs undisturbed unless ``--disturbance`` is given."""
    ref = " and error to the reference" if case.reference is not None else ""
    text = (f"attitude disagreement{ref} <= {opt.angle_tol:g} deg and rate error <= "
            f"{opt.rate_tol:g} rad/s from some time to tf = {opt.tf:g} s")
    src = case_label(case)
    if undisturbed_convergence(case):
        if disturbance is None:
            return (f"{text}, without disturbance (the criterion of {src}: its convergence claim "
                    "is judged on the undisturbed loop; under its disturbance the design is "
                    "ultimately bounded, judged by formsync verify; --disturbance paper runs "
                    "it disturbed)", "none")
        return (f"{text}, with disturbance {disturbance} (the tolerances of {src}, whose "
                "convergence claim is judged on the undisturbed loop: a bounded error above "
                "them counts as not converged)", disturbance)
    return f"{text} (the criterion of {src})", disturbance


def undisturbed_convergence(case: Any) -> bool:
    """Whether an engine case judges its design's convergence on the undisturbed loop: its
    base case has a disturbance and every ``convergence_time`` metric of a scenario running
    the base design reads one with ``disturbance = {model = "none"}`` (at least one).

    >>> from formsync_design.resources import case_file
    >>> from formsync_design.verify.agentcase import load_agent_case
    >>> [undisturbed_convergence(load_agent_case(case_file(n))) for n in ("lv2012", "ma_so3")]
    [True, False]
    """
    from formsync_design.tomlio import load_toml

    if case.kind != "engine" or not case.path or case.path == "<memory>":
        return False
    data = load_toml(case.path, "case TOML file")
    if str(dict(data.get("disturbance", {})).get("model", "none")) == "none":
        return False
    rows = [r for r in data.get("scenarios", []) if isinstance(r, dict)]
    scen = {str(r.get("name")): r for r in rows}
    first = str(rows[0].get("name")) if rows else "nominal"
    read = [scen.get(str(m.get("scenario", first)), {}) for m in data.get("metrics", [])
            if isinstance(m, dict) and m.get("metric") == "convergence_time"]
    own = [r for r in read if "design" not in r]
    return bool(own) and all(
        str(dict(r.get("disturbance", {})).get("model", "")) == "none" for r in own)


def case_label(case: Any) -> str:
    from formsync_design.verify.output import display_path

    return display_path(case.path) if case.path and case.path != "<memory>" else case.name


def lagrangian_defaults(spec: Any, case_arg: Any, defaults: Defaults) -> Any:
    """The Lagrangian case of a run (``--case``, else the design's shipped case, else the
    paper's), said in ``defaults``."""
    from formsync_design.verify.defaults import lagrangian_case_for

    return lagrangian_case_for(spec, case_arg, defaults)


def lagrangian_graph(args: Any, case: Any, spec: Any, defaults: Defaults) -> tuple[Any, Any, Any]:
    """``(case, graph, theorem check)`` of a Lagrangian simulation: ``--graph`` (the case
    resized to its size when it differs, said in ``defaults``), else the case's graph."""
    from formsync_design.cli.options import design_graph

    if args.graph is None:
        g, chk = design_graph(case.graph(), spec, getattr(args, "allow_outside_theorem", False),
                              derivation=False)
        defaults.add(f"graph from the case {case.name}: {g.name} ({g.n} spacecraft)")
        return case, case.graph(g), chk
    g, chk = design_graph(args.graph, spec, getattr(args, "allow_outside_theorem", False),
                          derivation=False)
    if g.n != case.n:
        defaults.add(resize_note(case.name, case.n, g.name, g.n).replace(
            "rate)", "rate, switching gain K_v)"))
        case = cycle_case(case, g.n)
    return case, case.graph(g), chk


def lagrangian_point_box(spec: Any, defaults: Defaults) -> Any:
    """The point box of the design's shipped case's gains (``None`` without a shipped case
    giving every controller gain), said in ``defaults``."""
    from formsync_design.gains import GainBox, GainRange, parse_number
    from formsync_design.verify.case import load_case

    src = case_source(spec)
    if src is None or src.role != "design":
        return None
    have = load_case(src.path).gains.as_dict()
    if any(n not in have for n in spec.decl.controller_gains):
        return None
    ranges = []
    for n in spec.gains:
        if n in have:
            v = parse_number(repr(float(have[n])), n)
            ranges.append(GainRange(n, v, v))
    defaults.add(f"gains from {src.label}: {gains_text({n: have[n] for n in have})}"
                 + ("; multipliers searched over their declared ranges: "
                    + ", ".join(spec.decl.multipliers) if spec.decl.multipliers else ""))
    return GainBox(tuple(ranges))


def lagrangian_range_gains(args: Any, spec: Any, defaults: Defaults) -> None:
    """Without any gain option, a gain of the Lagrangian ``spec`` that declares no range takes
    the sweep's standard range (:data:`~formsync_design.sweep.designs.DEFAULT_BOX`: liang2016's
    ``K_o, K_q`` in 0.05:5, ``beta`` in 0.01:1), set as ``--gain`` and said in ``defaults``."""
    if getattr(args, "gain", None) or any(getattr(args, f, None) is not None
                                          for f in ("ko", "kq", "beta")):
        return
    from formsync_design.sweep.designs import DEFAULT_BOX

    std = {g.name: DEFAULT_BOX[g.name] for g in spec.decl.gains
           if g.name in spec.decl.family_gains and str(g.role) != "multiplier"
           and g.range is None and g.name in DEFAULT_BOX}
    declared = [f"{g.name}={g.range.lo}:{g.range.hi}" for g in spec.decl.gains
                if g.name in spec.decl.family_gains and str(g.role) != "multiplier"
                and g.range is not None]
    if std:
        args.gain = [f"{n}={lo}:{hi}" for n, (lo, hi) in std.items()]
        defaults.add("gains over the standard box: " + ", ".join(args.gain))
    if declared:
        defaults.add("gains over their declared ranges: " + ", ".join(declared))


def default_out(command: str, design: Any, graph: Any = None) -> Path:
    """The default output folder of ``command``: ``out/<command>-<design>[-<graph>]`` under
    the working directory (graph names made file-safe)."""
    name = str(getattr(design, "name", design))
    tail = ""
    if graph is not None:
        tail = "-" + "".join(c if c.isalnum() or c in "._-" else "_" for c in str(graph))
    return Path("out") / f"{command}-{name}{tail}"

