"""Case files of kind ``engine``: one verification of any agent design, driven by the file.

A new paper is verified by a design file (``FORM = "agent"``, :mod:`formsync_design.spec.agent`)
and one case file; the engine (:mod:`formsync_design.verify.engine`) derives, certifies,
simulates, measures and judges what the file declares.  Layout (TOML; every number
range-checked, :mod:`formsync_design.ranges`; bad input is one line, exit 2)::

    [case]          kind = "engine", design, name, title, source, assumptions, graph
    [gains] [[spacecraft]] [simulation] [disturbance] [reference] [orbit] [graph]
                    the agent case tables (:mod:`formsync_design.verify.agentcase`)
    [[formations]]  name, and one of: graph = "ring:6" | "cycle:8" | "edges.txt" (relative
                    to the case file) | "case" (the case's own graph, the default), or
                    arcs = [[i, j, a_ij], ...] with n; pinning = [b_1, ..., b_N] (leader);
                    certify = false (no certificate: for a formation too large to certify);
                    initial = [{euler_deg | q | quaternion, rate}, ...], tf (its own initial
                    state and horizon: formsync_design.verify.enginekeys)
    [[scenarios]]   name, description, and overrides of the base case: gains = {K1 = 2.0},
                    simulation = {tf = 40, switch = "sat", period = 0.2}, disturbance =
                    {model = "none"} (the disturbance table replaced whole); sampling =
                    "periodic" | "event" | "self-triggered" | "continuous" (the design's law
                    under another sampling rule: spec.agent.rule_variant); period_matching =
                    "SCENARIO" (periodic sampling at the period giving, on each formation and
                    draw, the broadcasts per spacecraft of that scenario's run: tf / round(mean
                    broadcasts per spacecraft)); design = "NAME" | "file.py" (the scenario
                    runs another agent design, resolved like [case] design: a comparison
                    method on the same spacecraft, formations and simulation; its gains
                    table is then required and replaces the base gains whole);
                    torque_matching = {scenario, formation, hold, rtol} (its gains scaled to
                    that scenario's peak torque: formsync_design.verify.enginekeys)
    [montecarlo]    runs, seed, max_angle (deg), max_rate (rad/s), box = {K1 = "1:2", ...}
                    (the gains drawn; default the scenario's gains), tf (the draws' horizon;
                    default the scenario's), draws = "box" | "about-reference" (with
                    rate_sigma, rad/s) | "euler-uniform" (each 3-2-1 Euler angle uniform in
                    +-max_angle, each rate component in +-max_rate: verify/enginedraws.py)
    [families]      box = {gain = "lo:hi" | number, ...}: every controller gain, the box over
                    which the design's own certificate families (conditions(c)) are decided
                    by the metrics family_certificate and family_margin
    [report]        runs = true: the report lists every simulated run (and Monte-Carlo draw);
                    derivation = "FORMATION": the derivation report of the design's
                    Lagrangian view on that formation's graph is written beside it
                    (verify/engine_derivation.py); figures = [["FORMATION", "SCENARIO"],
                    ...]: the runs whose figures the report shows (default: every run)
    [[metrics]]     id, metric (a name of the registry, formsync_design/verify/metrics.py),
                    formation, scenario (default the first of each), the metric's arguments;
                    montecarlo = "max" | "min" | "mean" (a simulation metric measured on every
                    draw's run and aggregated; skip_unknown = true leaves out the runs without a
                    value, else one makes the aggregate unknown)
    [[claims]]      id, text (the paper's words), source (where in the paper),
                    predicate over metric ids (formsync_design/verify/predicates.py)

A design on another plant than the attitude plant (``PLANT = "relative-orbit"``) has its own
form of these tables (:mod:`formsync_design.verify.engineform`, :mod:`formsync_design.verify.engine_tracking`).

Without ``[[formations]]`` the one formation ``case`` is the case's graph; without
``[[scenarios]]`` the one scenario ``nominal`` is the base case (list it as a scenario
without overrides to keep it beside others).  ``cycle:N`` is the directed cycle (spacecraft
``i`` receives from ``i - 1``, spacecraft 1 from ``N``, unit weights); every other graph
specification is :func:`~formsync_design.graphs.digraph_io.make_digraph`'s.  A formation of
another size than the case takes the case's spacecraft cycled (spacecraft ``i`` is the
case's ``i mod N``: :meth:`~formsync_design.verify.agentcase.AgentCase.cycled`).  A scenario
is the base case's tables with its overrides, validated by the same agent case parser.
Ids of metrics and claims are a letter then letters, digits, ``_``; names of formations and
scenarios are letters, digits, ``_ . -`` (they name figure files).
"""

from __future__ import annotations

import copy
import hashlib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.ranges import check_range
from formsync_design.textio import read_bytes
from formsync_design.tomlio import load_toml
from formsync_design.verify import metric_modules  # noqa: F401 (registers the metrics)
from formsync_design.verify.agentcase import ENGINE_TABLES, AgentCase, parse_agent_case
from formsync_design.verify.enginegraphs import formation_graph
from formsync_design.verify.enginekeys import (
    MonteCarloSpec,
    check_torque_matching,
    formation_initial,
    parse_montecarlo,
    torque_matching,
)
from formsync_design.verify.enginesensors import scenario_leader, scenario_sensors
from formsync_design.verify.metrics import MetricSpec, check_metric_args, metric_spec, point_gains
from formsync_design.verify.predicates import KEYWORDS, Node, parse_predicate

__all__ = ["FormationSpec", "ScenarioSpec", "MetricRow",
           "ClaimRow", "EngineCase", "load_engine_case", "parse_engine_case"]

_ID = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,39}")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,39}")
_TEXT_MAX = 4000
_KEYS = {
    "formations": {"name", "graph", "arcs", "n", "pinning", "certify", "initial", "tf"},
    "scenarios": {"name", "description", "design", "gains", "simulation", "disturbance",
                  "sampling", "period_matching", "torque_matching", "sensors", "leader"},
    "families": {"box"},
    "report": {"runs", "derivation", "figures"},
    "claims": {"id", "text", "source", "predicate"},
}


@dataclass(frozen=True)
class FormationSpec:
    """A formation: ``name``, its :class:`~formsync_design.graphs.digraph.Digraph`, ``source``
    (the graph as the file wrote it), ``certify`` (whether its certificate is computed),
    ``initial`` (``(attitudes (N, 4), rates (N, 3))`` it starts from, ``None``: the case's)
    and ``tf`` (its horizon, ``None``: the scenario's)."""

    name: str
    graph: Any
    source: str
    certify: bool = True
    initial: tuple[Any, Any] | None = None
    tf: float | None = None


@dataclass(frozen=True)
class ScenarioSpec:
    """A scenario: ``name``, ``description``, the validated ``case`` (base + overrides), the
    ``overrides`` as written, the ``design`` its runs use (the case's, or its
    :func:`~formsync_design.spec.agent.rule_variant` under ``sampling``) and
    ``period_matching`` (the scenario whose broadcasts its period matches, or ``None``),
    ``torque_matching`` (``scenario``, ``formation``, ``hold``, ``rtol``: its gains scaled to
    that scenario's peak torque, or ``None``)."""

    name: str
    description: str
    case: AgentCase
    overrides: dict[str, Any]
    design: Any = None
    period_matching: str | None = None
    torque_matching: dict[str, Any] | None = None

    @property
    def run_design(self) -> Any:
        return self.case.design if self.design is None else self.design


@dataclass(frozen=True)
class MetricRow:
    """A ``[[metrics]]`` row: ``id``, the registered ``spec``, ``formation``, ``scenario``,
    ``args`` (checked), ``aggregate`` (``max``/``min`` over the Monte-Carlo draws, or
    ``None``: the scenario's run) and ``skip_unknown``."""

    id: str
    spec: MetricSpec
    formation: str
    scenario: str
    args: dict[str, Any]
    aggregate: str | None = None
    skip_unknown: bool = False

    @property
    def evidence(self) -> str:
        """The row's evidence: ``montecarlo`` for an aggregate, else the metric's."""
        return "montecarlo" if self.aggregate else self.spec.evidence


@dataclass(frozen=True)
class ClaimRow:
    """A ``[[claims]]`` row: ``id``, ``text``, ``source``, ``predicate`` (as written) and its
    parsed ``node``."""

    id: str
    text: str
    source: str
    predicate: str
    node: Node


@dataclass(frozen=True)
class EngineCase:
    """A validated engine case (module docstring)."""

    path: str
    base: AgentCase
    formations: tuple[FormationSpec, ...]
    scenarios: tuple[ScenarioSpec, ...]
    montecarlo: MonteCarloSpec | None
    metrics: tuple[MetricRow, ...]
    claims: tuple[ClaimRow, ...]
    digest: str = ""
    families_box: dict[str, str] | None = None
    report_runs: bool = False
    report_derivation: str | None = None
    report_figures: tuple[tuple[str, str], ...] | None = None

    def formation(self, name: str) -> FormationSpec:
        return next(f for f in self.formations if f.name == name)

    def scenario(self, name: str) -> ScenarioSpec:
        return next(s for s in self.scenarios if s.name == name)

    def case_for(self, formation: str, scenario: str) -> AgentCase:
        """The scenario's case resized to the formation (spacecraft cycled when it differs),
        from the formation's initial state and with its horizon when it declares them."""
        from dataclasses import replace

        f = self.formation(formation)
        c = self.scenario(scenario).case
        c = c if f.graph.n == c.n else c.cycled(f.graph.n)
        if f.initial is not None:
            c = replace(c, attitudes=f.initial[0], rates=f.initial[1])
        if f.tf is not None:
            c = replace(c, options=replace(c.options, tf=f.tf))
        return c


def _rows(data: dict, key: str, path: str) -> list[dict]:
    v = data.get(key, [])
    if not isinstance(v, list) or not all(isinstance(r, dict) for r in v):
        raise InputError(f"expected [[{key}]] tables in {path}, received {type(v).__name__}")
    return v


def _text(row: dict, key: str, where: str, *, required: bool = True, default: str = "") -> str:
    if key not in row:
        if required:
            raise InputError(f"expected {where}.{key}, received none")
        return default
    v = row[key]
    if not isinstance(v, str) or (required and not v.strip()) or len(v) > _TEXT_MAX:
        raise InputError(f"expected {where}.{key} as a non-empty text of at most {_TEXT_MAX} "
                         f"characters, received {v!r:.60}")
    return " ".join(v.split())


def _unique(row: dict, key: str, where: str, pattern: re.Pattern[str], seen: set[str]) -> str:
    v = row.get(key)
    if not isinstance(v, str) or not pattern.fullmatch(v) or v in KEYWORDS:
        raise InputError(f"expected {where}.{key} matching {pattern.pattern} (not and/or/not), "
                         f"received {v!r:.60}")
    if v in seen:
        raise InputError(f"expected each {where}.{key} once, received {v!r} twice")
    seen.add(v)
    return v


def _check_keys(row: dict, table: str, where: str) -> None:
    extra = sorted(set(row) - _KEYS[table])
    if extra:
        raise InputError(f"expected keys {sorted(_KEYS[table])} in {where}, received unknown {extra}")


def _formations(data: dict, base: AgentCase, path: str) -> tuple[FormationSpec, ...]:
    rows = _rows(data, "formations", path)
    if not rows:
        return (FormationSpec("case", base.graph(), "the case's graph"),)
    out: list[Any] = []
    seen: set[str] = set()
    for k, row in enumerate(rows, 1):
        where = f"formations[{k}]"
        _check_keys(row, "formations", where)
        name = _unique(row, "name", where, _NAME, seen)
        g, src = formation_graph(row, where, base.graph, path)
        d = base.design
        if d.decl.leader and not g.has_leader:
            raise InputError(f"expected {where}.pinning (design {d.name} has a leader), received "
                             f"graph {g.name!r} without pinning gains")
        if not d.decl.leader and g.has_leader:
            raise InputError(f"expected no pinning in {where} (design {d.name} has no leader), "
                             "received pinning gains")
        cert = row.get("certify", True)
        if not isinstance(cert, bool):
            raise InputError(f"expected {where}.certify = true or false, received {cert!r:.30}")
        agent = {k: v for k, v in data.items() if k not in ENGINE_TABLES}
        init = formation_initial(row, where, agent, g.n, path)
        tf = None if "tf" not in row else _number(row["tf"], f"{where}.tf", "horizon")
        out.append(FormationSpec(name, g, src, cert, init, tf))
    return tuple(out)


def _scenarios(data: dict, agent: dict, base: AgentCase, path: str) -> tuple[ScenarioSpec, ...]:
    rows = _rows(data, "scenarios", path)
    if not rows:
        return (ScenarioSpec("nominal", "the base case", base, {}),)
    out: list[Any] = []
    seen: set[str] = set()
    for k, row in enumerate(rows, 1):
        where = f"scenarios[{k}]"
        _check_keys(row, "scenarios", where)
        name = _unique(row, "name", where, _NAME, seen)
        desc = _text(row, "description", where, required=False)
        merged = copy.deepcopy(agent)
        over: dict[str, Any] = {}
        other = _other_design(row, where, merged, over)
        scenario_leader(row, where, merged, over)  # leader = false: the reference dropped
        for table in ("gains", "simulation", "disturbance"):
            if table not in row:
                continue
            t = row[table]
            if not isinstance(t, dict):
                raise InputError(f"expected {where}.{table} as a table, received {t!r:.60}")
            over[table] = dict(t)
            if table == "disturbance" or (table == "gains" and other):
                merged[table] = dict(t)
            else:
                merged[table] = {**merged.get(table, {}), **t}
        case = parse_agent_case(merged, path, design=None if other else base.design)
        design, match = _sampling(row, where, case, over)
        over.update(scenario_sensors(row, where, case))  # a gyro model: verify/enginesensors
        torque = torque_matching(row, where, case, over)
        out.append(ScenarioSpec(name, desc, case, over, design, match, torque))
    names = [s.name for s in out]
    for s in out:
        m = s.period_matching
        if m is not None and (m not in names or m == s.name
                              or next(x for x in out if x.name == m).period_matching):
            raise InputError(f"expected scenarios[{names.index(s.name) + 1}].period_matching "
                             f"naming another scenario among {names} that has no "
                             f"period_matching itself, received {m!r:.60}")
    return tuple(out)


def _other_design(row: dict, where: str, merged: dict, over: dict[str, Any]) -> bool:
    """Whether a scenario row runs another design (``design = "NAME" | "file.py"``): it then names
    that design in the merged case (resolved like ``[case] design``) with its ``gains`` whole."""
    if "design" not in row:
        return False
    ref = row["design"]
    if not isinstance(ref, str) or not _NAME.fullmatch(ref.removesuffix(".py")):
        raise InputError(f"expected {where}.design as a design name or a .py file beside the "
                         f"case, received {ref!r:.60}")
    if not isinstance(row.get("gains"), dict):
        raise InputError(f"expected {where}.gains (the whole gains table of design {ref!r}), "
                         f"received {row.get('gains')!r:.60}")
    merged["case"] = {**merged.get("case", {}), "design": ref}
    over["design"] = ref
    return True


def _sampling(row: dict, where: str, case: AgentCase, over: dict[str, Any]
              ) -> tuple[Any, str | None]:
    """The run design and ``period_matching`` of a scenario row (module docstring)."""
    from formsync_design.errors import DerivationError
    from formsync_design.spec.agent import SAMPLING_RULES, rule_variant

    rule = row.get("sampling")
    match = row.get("period_matching")
    design = None
    if rule is not None:
        if not isinstance(rule, str) or rule not in SAMPLING_RULES:
            raise InputError(f"expected {where}.sampling among {list(SAMPLING_RULES)}, received "
                             f"{rule!r:.40}")
        try:
            design = rule_variant(case.design, rule)
        except DerivationError as e:
            raise InputError(f"expected {where}.sampling = {rule!r} offered by the design: "
                             f"{e}") from None
        over["sampling"] = rule
    if match is not None:
        if not isinstance(match, str):
            raise InputError(f"expected {where}.period_matching as a scenario name, received "
                             f"{match!r:.40}")
        if (design or case.design).decl.sampling != "periodic" or case.options.period is not None:
            raise InputError(f"expected {where}.period_matching with sampling = \"periodic\" and "
                             "no simulation.period, received another rule or a period")
        over["period_matching"] = match
    elif (design or case.design).decl.sampling == "periodic" and case.options.period is None:
        raise InputError(f"expected simulation.period or period_matching for the periodic "
                         f"{where}, received neither")
    return design, match


def _number(v: Any, where: str, quantity: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"expected {where} as a number, received {v!r:.40}")
    check_range(v, quantity, where)
    return float(v)


def _families(data: dict, base: AgentCase) -> dict[str, str] | None:
    from formsync_design.gains import parse_gain_range

    t = data.get("families")
    if t is None:
        return None
    if not isinstance(t, dict):
        raise InputError(f"expected a [families] table, received {t!r:.60}")
    _check_keys(t, "families", "[families]")
    box = t.get("box")
    ctrl = list(base.design.decl.controller_gains)
    if not isinstance(box, dict) or set(box) != set(ctrl):
        raise InputError(f"expected families.box with every controller gain {ctrl}, received "
                         f"{sorted(box) if isinstance(box, dict) else box!r:.60}")
    out = {}
    for k in ctrl:
        v = box[k]
        if isinstance(v, bool) or not isinstance(v, (str, int, float)):
            raise InputError(f"expected families.box.{k} as \"lo:hi\" or a number, received {v!r:.40}")
        parse_gain_range(str(v), f"families.box.{k}")
        out[k] = str(v)
    return out


def _metrics(data: dict, base: AgentCase, forms: tuple[FormationSpec, ...],
             scens: tuple[ScenarioSpec, ...], mc: MonteCarloSpec | None,
             fam: dict[str, str] | None = None) -> tuple[MetricRow, ...]:
    out: list[Any] = []
    seen: set[str] = set()
    fnames, snames = [f.name for f in forms], [s.name for s in scens]
    for k, row in enumerate(_rows(data, "metrics", base.path), 1):
        where = f"metrics[{k}]"
        mid = _unique(row, "id", where, _ID, seen)
        name = row.get("metric")
        spec = metric_spec(name, where)
        s = row.get("scenario", snames[0])
        run = next((x.case.design for x in scens if x.name == s), base.design)
        why = spec.applies(run) if spec.applies is not None else None
        if why is not None:
            raise InputError(f"expected a metric that applies to the design in {where}, received "
                             f"{name!r} ({why})")
        agg = row.get("montecarlo")
        skip = row.get("skip_unknown", False)
        if agg is not None and (agg not in ("max", "min", "mean") or spec.evidence != "simulation"
                                or spec.value != "number"):
            raise InputError(f"expected {where}.montecarlo = \"max\", \"min\" or \"mean\" on a simulation "
                             f"metric, received {agg!r:.30} on {name!r} ({spec.evidence})")
        if not isinstance(skip, bool) or (skip and agg is None):
            raise InputError(f"expected {where}.skip_unknown = true or false with montecarlo, "
                             f"received {skip!r:.30}")
        if (spec.evidence == "montecarlo" or agg) and mc is None:
            raise InputError(f"expected a [montecarlo] table for the metric {name!r} of {where}, "
                             "received none")
        if spec.evidence == "montecarlo" and mc is not None and mc.draws != "box":
            raise InputError(f"expected montecarlo.draws = \"box\" for the batch metric {name!r} "
                             f"of {where}, received {mc.draws!r}")
        f = row.get("formation", fnames[0])
        if f not in fnames:
            raise InputError(f"expected {where}.formation among {fnames}, received {f!r:.60}")
        if s not in snames:
            raise InputError(f"expected {where}.scenario among {snames}, received {s!r:.60}")
        if spec.evidence in ("certificate", "numerical") and not next(
                x for x in forms if x.name == f).certify:
            raise InputError(f"expected a formation with certify = true for the certificate "
                             f"metric {name!r} of {where}, received {f!r} (certify = false)")
        if spec.evidence == "montecarlo" and mc is not None:
            point, why = point_gains(next(x for x in scens if x.name == s).case)
            missing = [g for g in run.decl.controller_gains if g not in mc.box]
            if point is None and missing:
                raise InputError(f"expected montecarlo.box for {missing} ({why}) for the metric "
                                 f"{name!r} of {where}, received none")
        if spec.needs_families and fam is None:
            raise InputError(f"expected a [families] table for the metric {name!r} of {where}, "
                             "received none")
        raw = {a: v for a, v in row.items() if a not in (
            "id", "metric", "formation", "scenario", "montecarlo", "skip_unknown")}
        args = check_metric_args(spec, raw, where, next(x for x in forms if x.name == f).graph.n)
        vs = args.get("versus")
        if vs is not None and vs not in snames:
            raise InputError(f"expected {where}.versus among {snames}, received {vs!r:.60}")
        listed = [x.strip() for x in str(args.get("scenarios", "")).split(",") if x.strip()]
        if any(x not in snames for x in listed):
            raise InputError(f"expected {where}.scenarios (comma-separated) among {snames}, "
                             f"received {args['scenarios']!r:.60}")
        out.append(MetricRow(mid, spec, f, s, args, agg, skip))
    return tuple(out)


def _claims(data: dict, metrics: tuple[MetricRow, ...], path: str) -> tuple[ClaimRow, ...]:
    kinds = {m.id: m.spec.value for m in metrics}
    out: list[Any] = []
    seen: set[str] = set()
    for k, row in enumerate(_rows(data, "claims", path), 1):
        where = f"claims[{k}]"
        _check_keys(row, "claims", where)
        cid = _unique(row, "id", where, _ID, seen)
        text = _text(row, "text", where)
        source = _text(row, "source", where, required=False, default="")
        pred = row.get("predicate")
        if not isinstance(pred, str) or not pred.strip():
            raise InputError(f"expected {where}.predicate as a non-empty text, received "
                             f"{pred!r:.60}")
        pred = pred.strip()
        node = parse_predicate(pred, kinds, f"claim {cid}'s predicate")
        out.append(ClaimRow(cid, text, source, pred, node))
    return tuple(out)


def parse_engine_case(data: dict, path: str = "<memory>", design: Any = None) -> EngineCase:
    """Validate a parsed engine case document (module docstring); a case whose design is of
    another plant (the relative-orbit plant) is that plant's form's case (:mod:`formsync_design.verify.engineform`)."""
    meta = data.get("case", {})
    if not isinstance(meta, dict) or meta.get("kind") != "engine":
        got = meta.get("kind") if isinstance(meta, dict) else meta
        raise InputError(f"expected [case] kind = \"engine\" in {path}, received {got!r:.40}")
    from formsync_design.verify.engineform import design_form

    other = design_form(data, path, design)
    if other is not None:  # a design of another form (verify/engineform.py)
        return other.parse(data, path, design)
    agent = {k: v for k, v in data.items() if k not in ENGINE_TABLES}
    base = parse_agent_case(copy.deepcopy(agent), path, design=design)
    forms = _formations(data, base, path)
    scens = _scenarios(data, agent, base, path)
    check_torque_matching(scens, [f.name for f in forms])
    mc = parse_montecarlo(data, base)
    fam = _families(data, base)
    metrics = _metrics(data, base, forms, scens, mc, fam)
    claims = _claims(data, metrics, path)
    if not claims and not metrics:
        raise InputError(f"expected [[metrics]] and [[claims]] in {path}, received neither")
    rep = data.get("report", {})
    if not isinstance(rep, dict):
        raise InputError(f"expected a [report] table, received {rep!r:.60}")
    _check_keys(rep, "report", "[report]")
    runs = rep.get("runs", False)
    if not isinstance(runs, bool):
        raise InputError(f"expected report.runs = true or false, received {runs!r:.30}")
    der = rep.get("derivation")
    if der is not None:
        from formsync_design.spec.loader import lagrangian_view

        if not isinstance(der, str) or der not in [f.name for f in forms]:
            raise InputError(f"expected report.derivation among the formations "
                             f"{[f.name for f in forms]}, received {der!r:.60}")
        if lagrangian_view(base.design) is None:
            raise InputError(f"expected a design with a Lagrangian view for report.derivation, "
                             f"received {base.design.name} (none)")
    figs = rep.get("figures")
    pairs: tuple[tuple[str, str], ...] | None = None
    if figs is not None:
        fn, sn = [f.name for f in forms], [s.name for s in scens]
        if not isinstance(figs, list) or not all(
                isinstance(x, list) and len(x) == 2 and x[0] in fn and x[1] in sn for x in figs):
            raise InputError(f"expected report.figures = [[formation, scenario], ...] with "
                             f"formations among {fn} and scenarios among {sn}, received "
                             f"{figs!r:.80}")
        pairs = tuple((str(x[0]), str(x[1])) for x in figs)
    return EngineCase(path, base, forms, scens, mc, metrics, claims, families_box=fam,
                      report_runs=runs, report_derivation=der, report_figures=pairs)


def load_engine_case(path: str | Path, design: Any = None, *, trust: Any = ()) -> EngineCase:
    """Load and validate an engine case file (``design``: overrides ``[case] design``;
    ``trust``: the design files, paths, the case and its scenarios may name:
    :mod:`formsync_design.spec.trust`)."""
    from dataclasses import replace

    from formsync_design.spec.trust import trusting

    p = Path(path)
    with trusting(*trust):
        case = parse_engine_case(load_toml(p, "case TOML file"), str(p), design=design)
    return replace(case, digest=hashlib.sha256(read_bytes(p, "case TOML file")).hexdigest())
