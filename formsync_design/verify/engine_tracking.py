"""The relative-orbit form of the verification engine: an engine case whose design is on the
relative-orbit plant (``PLANT = "relative-orbit"``: one spacecraft flying a relative orbit
about a target and tracking its reference attitude with thrusters, allocation and PWM).

The engine (:mod:`formsync_design.verify.engine`) hands such a case to this form
(:mod:`formsync_design.verify.engineform`); the claims are judged, and the report written,
by the engine's own judge and writer (:mod:`formsync_design.verify.engine_report`), which
take from here only the sections that depend on the form.  Layout (TOML)::

    [case] [target] [chaser] [spacecraft] [reference] [thrusters] [gains] [simulation]
    [certificate]   the base case (:mod:`formsync_design.verify.tracking_case`)
    [[scenarios]]   name, description, and overrides of the base case: gains = {...},
                    thrusters = {...}, simulation = {...} (not steady_from), spacecraft =
                    {inertia_scale = s} (the plant's inertia scaled, the law's kept)
    [[metrics]]     id, metric (a registered name, formsync_design/verify/metrics_tracking.py
                    and the design file), scenario (default the first), the metric's arguments
    [[claims]]      id, text, source, predicate over metric ids (verify/predicates.py)

There is one spacecraft: the formation column of the report is ``chaser``.  Every scenario
is one simulated run (:func:`~formsync_design.sim.tracking.simulate_flyaround`), computed
when a metric first reads it; its measurements are kept, the run itself only for the first
scenario (the figures) and the last one read (a run holds tens of MB).  Without
``[[scenarios]]`` the one scenario ``nominal`` is the base case.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.notebook import NotebookViews
from formsync_design.verify import metrics_tracking  # noqa: F401 (registered)
from formsync_design.verify.enginecase import ClaimRow, MetricRow
from formsync_design.verify.metrics import MetricContext, check_metric_args, metric_spec
from formsync_design.verify.predicates import KEYWORDS, parse_predicate

__all__ = ["FORMATION", "TrackingScenario", "TrackingBase", "TrackingEngineCase",
           "TrackingResults", "TrackingVerification", "TrackingForm", "FORM"]

#: The name of the one "formation" (the chaser) in the engine's tables.
FORMATION = "chaser"

_ID = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,39}")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,39}")
_SCENARIO_KEYS = {"name", "description", "gains", "thrusters", "simulation", "spacecraft"}
_CLAIM_KEYS = {"id", "text", "source", "predicate"}


@dataclass(frozen=True)
class TrackingScenario:
    """A scenario: ``name``, ``description``, ``overrides`` (as written) and its ``case``
    (the base :class:`~formsync_design.verify.tracking_case.FlyaroundCase` with them)."""

    name: str
    description: str
    overrides: dict[str, Any]
    case: Any


@dataclass(frozen=True)
class TrackingBase:
    """What the report's header reads of the base case: name, title, source, assumptions,
    design (the loaded :class:`~formsync_design.spec.loader.Spec`)."""

    name: str
    title: str
    source: str
    assumptions: tuple[str, ...]
    design: Any


@dataclass(frozen=True)
class TrackingEngineCase:
    """A validated tracking engine case (module docstring); ``tracking``: the base case."""

    path: str
    tracking: Any
    scenarios: tuple[TrackingScenario, ...]
    metrics: tuple[MetricRow, ...]
    claims: tuple[ClaimRow, ...]
    digest: str = ""
    #: a tracking case writes no derivation report of a Lagrangian view (the engine's
    #: ``[report] derivation`` of agent cases)
    report_derivation: str | None = None

    @property
    def form(self) -> TrackingForm:
        return FORM

    @property
    def base(self) -> TrackingBase:
        t = self.tracking
        return TrackingBase(t.name, t.title, t.source, t.assumptions, t.spec)

    def scenario(self, name: str) -> TrackingScenario:
        return next(s for s in self.scenarios if s.name == name)

    def case_for(self, formation: str, scenario: str) -> Any:
        return self.scenario(scenario).case


def _text(row: dict, key: str, where: str, required: bool = True) -> str:
    v = row.get(key, None if required else "")
    if not isinstance(v, str) or (required and not v.strip()) or len(v) > 4000:
        raise InputError(f"expected {where}.{key} as a non-empty text of at most 4000 "
                         f"characters, received {v!r:.60}")
    return " ".join(v.split())


def _unique(row: dict, where: str, key: str, pattern: re.Pattern[str], seen: set[str]) -> str:
    v = row.get(key)
    if not isinstance(v, str) or not pattern.fullmatch(v) or v in KEYWORDS or v in seen:
        raise InputError(f"expected {where}.{key} matching {pattern.pattern}, once (not "
                         f"and/or/not), received {v!r:.60}")
    seen.add(v)
    return v


def _rows(data: dict, key: str, path: str) -> list[dict]:
    v = data.get(key, [])
    if not isinstance(v, list) or not all(isinstance(r, dict) for r in v):
        raise InputError(f"expected [[{key}]] tables in {path}, received {type(v).__name__}")
    return v


def _scenarios(data: dict, base: Any, path: str) -> tuple[TrackingScenario, ...]:
    from formsync_design.verify.tracking_case import apply_variant, parse_variant

    rows = _rows(data, "scenarios", path)
    if not rows:
        return (TrackingScenario("nominal", "the base case", {}, base),)
    out = []
    seen: set[str] = set()
    for k, row in enumerate(rows, 1):
        where = f"scenarios[{k}]"
        extra = sorted(set(row) - _SCENARIO_KEYS)
        if extra:
            raise InputError(f"expected keys {sorted(_SCENARIO_KEYS)} in {where}, received "
                             f"unknown {extra}")
        name = _unique(row, where, "name", _NAME, seen)
        v = parse_variant(row, base.spec, where, name)
        sc, opt = apply_variant(base, v)
        over = {p: dict(row[p]) for p in ("gains", "thrusters", "simulation", "spacecraft")
                if p in row}
        out.append(TrackingScenario(name, _text(row, "description", where, required=False),
                                    over, replace(base, scenario=sc, options=opt)))
    return tuple(out)


def _metrics(data: dict, base: Any, scens: tuple[TrackingScenario, ...], path: str
             ) -> tuple[MetricRow, ...]:
    out = []
    seen: set[str] = set()
    names = [s.name for s in scens]
    for k, row in enumerate(_rows(data, "metrics", path), 1):
        where = f"metrics[{k}]"
        mid = _unique(row, where, "id", _ID, seen)
        name = row.get("metric")
        spec = metric_spec(name, where)
        why = spec.applies(base.spec) if spec.applies is not None else (
            "a metric of agent designs")
        if why is not None or spec.evidence == "montecarlo":
            raise InputError(f"expected a metric that applies to the relative-orbit design in "
                             f"{where}, received {name!r} ({why or 'Monte-Carlo'})")
        s = row.get("scenario", names[0])
        if s not in names:
            raise InputError(f"expected {where}.scenario among {names}, received {s!r:.60}")
        if row.get("formation", FORMATION) != FORMATION:
            raise InputError(f"expected {where}.formation = {FORMATION!r} (one spacecraft), "
                             f"received {row.get('formation')!r:.60}")
        raw = {a: v for a, v in row.items() if a not in ("id", "metric", "scenario", "formation")}
        out.append(MetricRow(mid, spec, FORMATION, s, check_metric_args(spec, raw, where)))
    return tuple(out)


def _claims(data: dict, metrics: tuple[MetricRow, ...], path: str) -> tuple[ClaimRow, ...]:
    kinds = {m.id: m.spec.value for m in metrics}
    out = []
    seen: set[str] = set()
    for k, row in enumerate(_rows(data, "claims", path), 1):
        where = f"claims[{k}]"
        extra = sorted(set(row) - _CLAIM_KEYS)
        if extra:
            raise InputError(f"expected keys {sorted(_CLAIM_KEYS)} in {where}, received "
                             f"unknown {extra}")
        cid = _unique(row, where, "id", _ID, seen)
        pred = _text(row, "predicate", where)
        out.append(ClaimRow(cid, _text(row, "text", where), _text(row, "source", where, False),
                            pred, parse_predicate(pred, kinds, f"claim {cid}'s predicate")))
    return tuple(out)


def parse_tracking_engine_case(data: dict, path: str, design: Any = None) -> TrackingEngineCase:
    """Validate a parsed tracking engine case (module docstring)."""
    from formsync_design.verify.tracking_case import parse_flyaround_case

    if "report" in data:
        raise InputError(f"expected no [report] table in {path} (a tracking case has one run "
                         "per scenario, listed in the report), received one")
    base = parse_flyaround_case(data, path, design)
    scens = _scenarios(data, base, path)
    metrics = _metrics(data, base, scens, path)
    claims = _claims(data, metrics, path)
    if not metrics:
        raise InputError(f"expected [[metrics]] in {path}, received none")
    return TrackingEngineCase(path, base, scens, metrics, claims)


class TrackingResults:
    """The runs of a tracking verification, each computed once (implements
    :class:`~formsync_design.verify.metrics.Results` for one spacecraft; no certificate of a
    formation, no Monte-Carlo)."""

    def __init__(self, case: TrackingEngineCase, progress: Callable[[str], None]) -> None:
        self.case = case
        self.progress = progress
        self._runs: dict[str, Any] = {}
        self._memo: dict[tuple[Any, ...], Any] = {}
        self.series: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
        self.simulated: list[str] = []

    def run(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        from formsync_design.sim.tracking import simulate_flyaround

        if scenario not in self._runs:
            c = self.case.scenario(scenario).case
            self.progress(f"simulate {scenario} ({c.options.tf:g} s)")
            r = simulate_flyaround(c.scenario, c.options, c.spec)
            first = self.case.scenarios[0].name
            for k in [k for k in self._runs if k != first]:
                del self._runs[k]
            self._runs[scenario] = r
            if scenario not in self.simulated:
                self.simulated.append(scenario)
                self.series[scenario] = _series(r)
        return self._runs[scenario]

    def record(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        return {}

    def options(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        return self.case.scenario(scenario).case.options

    def initial(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        return self.case.scenario(scenario).case.scenario

    def certificate(self, formation: str, scenario: str) -> Any:
        return "no formation certificate (one spacecraft: the tracking certificates)"

    def families(self, formation: str) -> Any:
        return None

    def montecarlo(self, formation: str, scenario: str) -> Any:
        raise InputError("expected no Monte-Carlo metric in a tracking case, received one")

    def memo(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]

    def gain_scale(self, scenario: str) -> tuple[Any, Any] | None:
        return None


def _series(run: Any, every: int = 50) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The figure data of a run: the cumulative fuel and the elevation above the plane."""
    from formsync_design.sim.orbit_record import orbit_of
    from formsync_design.verify.tracking_measures import plane_normal

    rec = orbit_of(run)
    n = run.t.size
    cum = np.cumsum(rec.impulses.sum(axis=1)) / rec.options.exhaust_velocity
    rho = rec.states[:n:every, :3]
    e = np.degrees(np.arcsin(np.clip(rho @ plane_normal(rec.scenario.reference)
                                     / np.linalg.norm(rho, axis=1), -1, 1)))
    return {"fuel": (run.t[::every].copy(), cum[::every].copy()),
            "elevation": (run.t[::every].copy(), e)}


@dataclass(frozen=True)
class TrackingVerification(NotebookViews):
    """The verification of a tracking case (the fields the engine's writer reads: ``case``,
    ``metrics``, ``claims``, ``results``)."""

    case: TrackingEngineCase
    metrics: tuple[tuple[MetricRow, Any], ...]
    claims: tuple[Any, ...]
    results: TrackingResults = field(repr=False, compare=False)

    @property
    def all_hold(self) -> bool:
        return all(c.verdict == "holds" for c in self.claims)


class TrackingForm:
    """The relative-orbit form (:class:`~formsync_design.verify.engineform.EngineForm`)."""

    name = "relative-orbit"

    def parse(self, data: dict, path: str, design: Any = None) -> TrackingEngineCase:
        return parse_tracking_engine_case(data, path, design)

    def run(self, case: TrackingEngineCase, progress: Callable[[str], None]
            ) -> TrackingVerification:
        from formsync_design.verify.engine import judge, measure

        res = TrackingResults(case, progress)
        values = {}
        rows = []
        for m in case.metrics:
            ctx = MetricContext(case.case_for(m.formation, m.scenario), m.formation, m.scenario,
                                m.spec, res, m.args)
            v = measure(m, ctx, check=False)
            values[m.id] = v
            rows.append((m, v))
        by_id = {m.id: m for m in case.metrics}
        claims = tuple(judge(c, values, by_id) for c in case.claims)
        return TrackingVerification(case, tuple(rows), claims, res)

    def scenario_section(self, case: TrackingEngineCase) -> list[str]:
        from formsync_design.verify.engine_tracking_report import scenario_section

        return scenario_section(case)

    def certificate_section(self, ver: TrackingVerification) -> list[str]:
        from formsync_design.verify.engine_tracking_report import certificate_section

        return certificate_section(ver)

    def evidence_section(self, ver: TrackingVerification) -> list[str]:
        from formsync_design.verify.engine_tracking_report import evidence_section

        return evidence_section(ver)

    def runs_section(self, ver: TrackingVerification) -> list[str]:
        return []

    def figures(self, ver: TrackingVerification) -> dict[str, Any]:
        from formsync_design.verify.engine_tracking_report import figures

        return figures(ver)

    def json_tables(self, ver: TrackingVerification) -> dict[str, Any]:
        from formsync_design.verify.engine_tracking_report import json_tables

        return json_tables(ver)


#: The tracking form.
FORM = TrackingForm()
