"""The metric registry: named measurements of an ``engine`` case, one function each.

A metric is a function of a :class:`MetricContext` (the case under one scenario, one
formation, the metric's arguments, and the run's cached results) returning a frozen
:class:`MetricValue` (value, unit, evidence, detail).  It is registered by name::

    @register_metric("peak_torque", unit="N m", evidence="simulation",
                     doc="largest |u_i,k| over the run", args=(MetricArg("spacecraft", "int", 0),))
    def peak_torque(ctx):
        r = ctx.run()
        ...
        return ctx.value(float(...))

Together with the design file, the registry is **the one extension point** of the engine
(:mod:`formsync_design.verify.engine`): a paper that needs a measurement not listed below
adds one registered function, never a case kind, case parser or report writer: a general
measurement here, beside the built-ins; a paper's own one in its design file (the case
loads its design before it reads ``[[metrics]]``, so a decorated function there is
registered in time, with no change to the library).  A case names a metric in
``[[metrics]] metric = "NAME"``; its arguments are the row's other keys (checked against
``args``: type, range, choices).

``evidence`` says what a value rests on: ``certificate`` (an exact or rigorously rounded
re-check: a proof), ``numerical`` (floating-point linear algebra: evidence), ``simulation``
(one run: evidence), ``montecarlo`` (a seeded batch of runs: evidence).  ``bound``:
``exact`` (the value is the quantity, as measured) or ``lower`` (the quantity is at least
the value: a certified decay rate, a convergence time not reached by the horizon).  A
metric without a value (``value is None``: a certificate undecided, a run that diverged) is
*unknown* and makes the claims that need it undecided
(:mod:`formsync_design.verify.predicates`).  The results behind the metrics (one run, one
certificate, one Monte-Carlo batch per formation and scenario) are computed once per
verification and cached (:class:`Results`).

Built-in metrics (convergence by the scenario's ``angle_tol``/``rate_tol``):

=========================  ========  ===========  ===============================================
metric                     unit      evidence     value
=========================  ========  ===========  ===============================================
formation_certificate      verdict   certificate  ``certified`` or ``refuted`` (text); undecided: unknown
certified_decay_rate       1/s       certificate  the certified exponential rate (lower bound)
largest_real_part          1/s       numerical    largest real part of the disagreement's modes
convergence_time           s         simulation   first time from which the criterion holds
time_to_angle              s         simulation   ... the attitude disagreement stays <= angle_deg
final_attitude_error_deg   deg       simulation   at tf: pairwise, or to the reference
final_rate                 rad/s     simulation   the rate error at tf
peak_torque                N m       simulation   largest torque component (a spacecraft or all)
control_effort             N^2 m^2 s simulation   sum of int |u_i|^2 dt (a spacecraft or all)
transmissions              count     simulation   broadcasts of a sampled design (all spacecraft)
min_inter_event_time       s         simulation   shortest inter-event time of a sampled design
mc_converged_fraction      1         montecarlo   fraction of the runs that converged
mc_convergence_time_max    s         montecarlo   largest convergence time of the runs
mc_peak_torque_max         N m       montecarlo   largest peak torque of the runs
=========================  ========  ===========  ===============================================

>>> {"certified_decay_rate", "control_effort", "convergence_time"} <= set(METRICS)
True
>>> v = MetricValue(12.5, "s", "simulation", "not converged by tf = 12.5 s", bound="lower")
>>> v.text(), v.interval()
('>= 12.5', Interval(lo=12.5, hi=inf))
>>> @register_metric("example_final_speed", unit="rad/s", evidence="simulation",
...                  doc="largest |w_i| at tf")
... def final_speed(ctx):
...     return ctx.value(float(np.linalg.norm(ctx.run().rates[-1], axis=1).max()))
>>> METRICS.pop("example_final_speed").unit
'rad/s'
"""

from __future__ import annotations

import enum
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.ranges import check_range
from formsync_design.textio import check_ascii
from formsync_design.verify.metric_identity import origin, same_metric
from formsync_design.verify.predicates import Interval, closest

__all__ = ["Evidence", "MetricValue", "MetricArg", "MetricSpec", "Results", "MetricContext",
           "METRICS", "register_metric", "check_metric_args", "format_number", "point_gains",
           "metric_spec"]


class Evidence(enum.StrEnum):
    """What a metric's value rests on (module docstring)."""

    CERTIFICATE = "certificate"
    NUMERICAL = "numerical"
    SIMULATION = "simulation"
    MONTECARLO = "montecarlo"


def format_number(x: float) -> str:
    """The report's fixed number format (7 significant digits).

    >>> format_number(1 / 3), format_number(12345678.0), format_number(math.inf)
    ('0.3333333', '1.234568e+07', 'inf')
    """
    return f"{x:.7g}"


@dataclass(frozen=True)
class MetricValue:
    """One metric's value: ``value`` (float, text, or ``None`` when unknown), ``unit``,
    ``evidence`` (:class:`Evidence`), ``detail`` (what was measured, or why unknown),
    ``bound`` (``exact`` or ``lower``)."""

    value: float | str | None
    unit: str
    evidence: str
    detail: str = ""
    bound: str = "exact"

    def __post_init__(self) -> None:
        if self.bound not in ("exact", "lower"):
            raise InputError(f"expected a metric bound exact or lower, received {self.bound!r}")
        if str(self.evidence) not in set(Evidence):
            raise InputError(f"expected a metric evidence among {sorted(Evidence)}, "
                             f"received {self.evidence!r}")
        if isinstance(self.value, (int, float)) and not isinstance(self.value, bool):
            object.__setattr__(self, "value", float(self.value))

    def interval(self) -> Interval | str | None:
        """What :func:`~formsync_design.verify.predicates.evaluate` reads."""
        if self.value is None or isinstance(self.value, str):
            return self.value
        return Interval(self.value, math.inf if self.bound == "lower" else self.value)

    def text(self) -> str:
        """The value as the report prints it (``>= x`` for a lower bound)."""
        if self.value is None:
            return "unknown"
        if isinstance(self.value, str):
            return self.value
        return (">= " if self.bound == "lower" else "") + format_number(self.value)

    def to_dict(self) -> dict[str, Any]:
        v: Any = self.value if not isinstance(self.value, float) else json_number(self.value)
        return {"value": v, "unit": self.unit, "evidence": str(self.evidence),
                "bound": self.bound, "detail": self.detail}


@dataclass(frozen=True)
class MetricArg:
    """An argument of a metric: ``name``, ``kind`` (``number``, ``int``, ``text``),
    ``default`` (``None``: required), ``quantity`` (its range, :mod:`formsync_design.ranges`),
    ``choices`` (texts), ``minimum`` (numbers), ``doc``."""

    name: str
    kind: str
    default: Any = None
    quantity: str = "number"
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    doc: str = ""


@dataclass(frozen=True)
class MetricSpec:
    """A registered metric (:func:`register_metric`)."""

    name: str
    fn: Callable[[MetricContext], MetricValue]
    unit: str
    evidence: str
    doc: str
    value: str = "number"
    args: tuple[MetricArg, ...] = ()
    applies: Callable[[Any], str | None] | None = None
    needs_families: bool = False


#: Metric name -> its :class:`MetricSpec`.
METRICS: dict[str, MetricSpec] = {}

_NAME = re.compile(r"[a-z][a-z0-9_]*")


def register_metric(name: str, *, unit: str, evidence: str, doc: str, value: str = "number",
                    args: tuple[MetricArg, ...] = (),
                    applies: Callable[[Any], str | None] | None = None,
                    families: bool = False
                    ) -> Callable[[Callable[[MetricContext], MetricValue]],
                                  Callable[[MetricContext], MetricValue]]:
    """Register ``fn(ctx) -> MetricValue`` as metric ``name`` (module docstring).

    ``value``: ``number`` or ``text``; ``applies(design)``: ``None`` when the metric applies
    to the design, else why not (the case is refused when it names it); ``families``: the
    metric reads :meth:`MetricContext.families` (the case must have a ``[families]`` box).
    """
    if not _NAME.fullmatch(name):
        raise InputError(f"expected a metric name of lower-case letters, digits and _, "
                         f"received {name!r}")
    if value not in ("number", "text") or str(evidence) not in set(Evidence):
        raise InputError(f"expected value number|text and evidence among {sorted(Evidence)} "
                         f"for metric {name}, received {value!r}, {evidence!r}")

    def deco(fn: Callable[[MetricContext], MetricValue]) -> Callable[[MetricContext], MetricValue]:
        old = METRICS.get(name)
        spec = MetricSpec(name, fn, unit, str(evidence), doc, value, tuple(args), applies,
                          families)
        if old is not None and origin(old.fn) != origin(fn) and not same_metric(old, spec):
            raise InputError(f"expected metric {name!r} registered once, received a second one "
                             f"({origin(fn)[1]}; the first: {origin(old.fn)[1]})")
        if old is None or origin(old.fn) == origin(fn):
            METRICS[name] = spec
        return fn

    return deco


def metric_spec(name: Any, where: str) -> MetricSpec:
    """The registered metric ``name`` of the ``[[metrics]]`` row ``where``; an unknown name is
    a one-line :class:`InputError` naming the closest few registered names (not all of them).

    >>> metric_spec("peak_torqe", "metrics[1]")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected metrics[1].metric among the registered metrics (closest: peak_torque...), received 'peak_torqe'
    """
    if not isinstance(name, str) or name not in METRICS:
        near = closest(name, METRICS) if isinstance(name, str) else f"{len(METRICS)} names"
        raise InputError(f"expected {where}.metric among the registered metrics ({near}), "
                         f"received {name!r:.60}")
    return METRICS[name]


def check_metric_args(spec: MetricSpec, raw: Mapping[str, Any], where: str,
                      n: int | None = None) -> dict[str, Any]:
    """The arguments of a ``[[metrics]]`` row (``raw``: its keys other than id, metric,
    formation, scenario), typed, range-checked and defaulted; ``n``: the number of
    spacecraft of the formation the row reads (a ``spacecraft`` argument is at most ``n``).

    >>> check_metric_args(METRICS["peak_torque"], {"spacecraft": 99}, "metrics[1]", n=3)
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected metrics[1].spacecraft <= 3 (the formation's spacecraft are 1..3), received 99
    """
    known = {a.name: a for a in spec.args}
    extra = sorted(set(raw) - set(known))
    if extra:
        raise InputError(f"expected arguments among {sorted(known)} for metric {spec.name} in "
                         f"{where}, received unknown {extra}")
    out: dict[str, Any] = {}
    for a in spec.args:
        if a.name not in raw:
            if a.default is None:
                raise InputError(f"expected {where}.{a.name} (required by metric {spec.name}), "
                                 "received none")
            out[a.name] = a.default
            continue
        v = raw[a.name]
        if a.kind == "text":
            if not isinstance(v, str) or (a.choices and v not in a.choices):
                raise InputError(f"expected {where}.{a.name} one of {list(a.choices)}, "
                                 f"received {v!r:.60}")
            check_ascii(v, f"{where}.{a.name}")  # numbers in a text ('angles') are ASCII
        else:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or (
                    a.kind == "int" and not isinstance(v, int)):
                raise InputError(f"expected {where}.{a.name} as {'an integer' if a.kind == 'int' else 'a number'}, "
                                 f"received {v!r:.60}")
            check_range(v, a.quantity, f"{where}.{a.name}")
            if a.minimum is not None and v < a.minimum:
                raise InputError(f"expected {where}.{a.name} >= {a.minimum:g}, received {v:g}")
            if a.name == "spacecraft" and n is not None and v > n:
                raise InputError(f"expected {where}.spacecraft <= {n} (the formation's "
                                 f"spacecraft are 1..{n}), received {v}")
        out[a.name] = v
    return out


def point_gains(case: Any) -> tuple[dict[str, Any] | None, str]:
    """The controller gains of ``case`` as exact numbers, one per gain (``None`` and why when
    a diagonal gain has unequal entries: a certificate or a Monte-Carlo box takes one value
    per gain).

    >>> from formsync_design.resources import case_file
    >>> from formsync_design.verify.agentcase import load_agent_case
    >>> point_gains(load_agent_case(case_file("ma_so3")))[0]["K1"]
    Fraction(23, 20)
    """
    from formsync_design.gains import parse_number
    from formsync_design.spec.declarations import GainRole

    point: dict[str, Any] = {}
    given = case.gains.as_dict()
    for g in case.design.decl.gains:
        if g.role != GainRole.CONTROLLER:
            continue
        v = given[g.name]
        if isinstance(v, tuple):
            if len(set(v)) != 1:
                return None, (f"the diagonal gain {g.name} = {list(v)} has unequal entries (a "
                              "certificate or a Monte-Carlo box takes one value per gain)")
            v = v[0]
        point[g.name] = parse_number(v, g.name)
    return point, ""


class Results(Protocol):
    """The cached results a metric reads (implemented by the engine); ``draw``: the index of
    a Monte-Carlo draw (``None``: the scenario's own initial state)."""

    def run(self, formation: str, scenario: str, draw: int | None = None) -> Any: ...

    def record(self, formation: str, scenario: str, draw: int | None = None) -> Any: ...

    def options(self, formation: str, scenario: str, draw: int | None = None) -> Any: ...

    def initial(self, formation: str, scenario: str, draw: int | None = None) -> Any: ...

    def certificate(self, formation: str, scenario: str) -> Any: ...

    def families(self, formation: str) -> Any: ...

    def montecarlo(self, formation: str, scenario: str) -> Any: ...

    def memo(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any: ...

    def gain_scale(self, scenario: str) -> tuple[Any, Any] | None: ...


@dataclass(frozen=True)
class MetricContext:
    """What a metric sees: ``case`` (the :class:`~formsync_design.verify.agentcase.AgentCase`
    of the scenario, resized to the formation), ``formation`` and ``scenario`` names,
    ``args`` (checked), ``spec`` (the metric), ``results`` (cached, :class:`Results`),
    ``draw`` (the Monte-Carlo draw a ``montecarlo = "max"|"min"`` row measures, else
    ``None``), ``graph`` (the formation's :class:`~formsync_design.graphs.digraph.Digraph`)."""

    case: Any
    formation: str
    scenario: str
    spec: MetricSpec
    results: Results
    args: Mapping[str, Any] = field(default_factory=dict)
    draw: int | None = None
    graph: Any = None

    def run(self, scenario: str | None = None) -> Any:
        """The :class:`~formsync_design.sim.result.SimResult` of this formation and draw
        under this scenario (or ``scenario``: another scenario's, for a comparison)."""
        return self.results.run(self.formation, scenario or self.scenario, self.draw)

    def record(self, scenario: str | None = None) -> Any:
        """What the sampled run of :meth:`run` recorded (``hybrid``: the hybrid run,
        ``trigger_evaluations``, ``kept``: the values kept at each broadcast), ``{}`` for a
        continuous run."""
        return self.results.record(self.formation, scenario or self.scenario, self.draw)

    def options(self) -> Any:
        """The :class:`~formsync_design.sim.agents.AgentOptions` of :meth:`run` (a draw's
        horizon, a matched period included)."""
        return self.results.options(self.formation, self.scenario, self.draw)

    def initial(self) -> Any:
        """The :class:`~formsync_design.sim.agents.AgentFormation` :meth:`run` started from
        (the case's, or the draw's)."""
        return self.results.initial(self.formation, self.scenario, self.draw)

    def families(self) -> Any:
        """The design's own families on this formation decided over the case's
        ``[families]`` box (a :class:`~formsync_design.certify.results.CertificationResult`)."""
        return self.results.families(self.formation)

    def memo(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
        """``compute()`` once per verification for ``key`` (a measurement several metrics
        read); the key should name the formation, scenario and draw it depends on."""
        return self.results.memo(key, compute)

    def key(self, scenario: str | None = None) -> tuple[Any, ...]:
        """``(formation, scenario, draw)`` of :meth:`run`, for :meth:`memo`."""
        return (self.formation, scenario or self.scenario, self.draw)

    def certificate(self) -> Any:
        """The formation certificate (or the text saying why there is none)."""
        return self.results.certificate(self.formation, self.scenario)

    def montecarlo(self) -> Any:
        """The :class:`~formsync_design.sim.montecarlo_data.MonteCarloResult` (agent runs)."""
        return self.results.montecarlo(self.formation, self.scenario)

    def value(self, value: float | str | None, detail: str = "", bound: str = "exact") -> MetricValue:
        """A :class:`MetricValue` with this metric's unit and evidence."""
        return MetricValue(value, self.spec.unit, self.spec.evidence, detail, bound)


# ------------------------------------------------------------------------------ built-ins


def _sampled_only(design: Any) -> str | None:
    return None if design.decl.sampling != "continuous" else (
        f"design {design.name} is continuous (no transmissions)")


def _certificate_or(ctx: MetricContext) -> tuple[Any, MetricValue | None]:
    c = ctx.certificate()
    if isinstance(c, str):
        return None, ctx.value(None, c)
    return c, None


@register_metric("formation_certificate", unit="verdict", evidence="certificate", value="text",
                 doc="the formation-level certificate (certify/formation.py) of the scenario's "
                 "gains on the formation's graph: certified or refuted (proven either way); "
                 "undecided is no value (a claim that needs it is undecided)")
def _formation_certificate(ctx: MetricContext) -> MetricValue:
    c, none = _certificate_or(ctx)
    if none is not None:
        return ctx.value(None, f"undecided: {none.detail}")
    if str(c.status) not in ("certified", "refuted"):  # the truth is unknown: no value
        return ctx.value(None, f"{c.status}: {c.reason}")
    sc = c.scope
    return ctx.value(str(c.status), f"{sc.property} stability of {sc.target} on {sc.graph} "
                     f"[{sc.basis}]")


@register_metric("certified_decay_rate", unit="1/s", evidence="certificate",
                 doc="the certified exponential decay rate of the certificate (a lower bound "
                 "of the true rate); unknown unless certified")
def _decay(ctx: MetricContext) -> MetricValue:
    c, none = _certificate_or(ctx)
    if none is not None:
        return none
    if c.decay is None:
        return ctx.value(None, f"certificate {c.status}: no certified rate")
    return ctx.value(float(c.decay), "certified lower bound", bound="lower")


@register_metric("largest_real_part", unit="1/s", evidence="numerical",
                 doc="largest real part of the linearised disagreement's eigenvalues at the "
                 "gain points the certificate checked (LAPACK, floating point: evidence)")
def _abscissa(ctx: MetricContext) -> MetricValue:
    c, none = _certificate_or(ctx)
    if none is not None:
        return none
    a = c.evidence.get("spectral_abscissa")
    if a is None:
        return ctx.value(None, c.reason or "no eigenvalues computed")
    return ctx.value(float(a), "floating-point eigenvalues")


def _ended(r: Any) -> str | None:
    """Why a run has no value at tf (diverged or stopped), else ``None``."""
    if str(r.status) in ("diverged", "stopped"):
        return f"run {r.status}: {r.message}"
    return None


@register_metric("convergence_time", unit="s", evidence="simulation",
                 doc="first output time from which the scenario's criterion holds to tf "
                 "(attitude and rate errors within angle_tol, rate_tol); not converged by tf: "
                 ">= tf; diverged or stopped: unknown")
def _convergence_time(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    if r.convergence_time is None:
        return ctx.value(float(r.t[-1]), f"not converged by tf = {float(r.t[-1]):g} s",
                         bound="lower")
    return ctx.value(float(r.convergence_time))


@register_metric("time_to_angle", unit="s", evidence="simulation",
                 args=(MetricArg("angle_deg", "number", quantity="angle", minimum=0.0,
                                 doc="the attitude disagreement bound (deg)"),),
                 doc="first output time from which the largest pairwise angle stays <= "
                 "angle_deg; not reached by tf: >= tf; diverged or stopped: unknown")
def _time_to_angle(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    t = r.time_to(float(ctx.args["angle_deg"]))
    if t is None:
        return ctx.value(float(r.t[-1]), f"not reached by tf = {float(r.t[-1]):g} s",
                         bound="lower")
    return ctx.value(float(t))


def _to_reference(design: Any, to: str) -> bool:
    return to == "reference" or (to == "auto" and bool(design.decl.leader))


@register_metric("final_attitude_error_deg", unit="deg", evidence="simulation",
                 args=(MetricArg("to", "text", "auto", choices=("auto", "pairwise", "reference"),
                                 doc="pairwise (largest principal angle between two spacecraft) "
                                 "or reference (largest angle to the leader's attitude); auto: "
                                 "reference when the design has a leader"),),
                 doc="the attitude error at tf; diverged or stopped: unknown")
def _final_attitude(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    if _to_reference(ctx.case.design, str(ctx.args["to"])):
        if r.reference_error is None:
            return ctx.value(None, "no reference (the design has no leader)")
        return ctx.value(float(r.reference_error[-1]), f"to the reference at t = {float(r.t[-1]):g} s")
    return ctx.value(float(r.attitude_error[-1]), f"largest pairwise angle at t = {float(r.t[-1]):g} s")


@register_metric("final_rate", unit="rad/s", evidence="simulation",
                 doc="the rate error at tf (largest pairwise body-rate difference; to the "
                 "reference rate with a leader); diverged or stopped: unknown")
def _final_rate(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    return ctx.value(float(r.rate_error[-1]), f"at t = {float(r.t[-1]):g} s")


_SC = MetricArg("spacecraft", "int", 0, minimum=0, doc="1-based spacecraft (0: all)")


def _spacecraft(ctx: MetricContext, arr: np.ndarray) -> tuple[np.ndarray | None, str]:
    k = int(ctx.args["spacecraft"])
    if k == 0:
        return arr, "all spacecraft"
    if k > arr.shape[0]:
        return None, f"spacecraft {k} is not in the formation (N = {arr.shape[0]})"
    return arr[k - 1: k], f"spacecraft {k}"


@register_metric("peak_torque", unit="N m", evidence="simulation", args=(_SC,),
                 doc="largest torque component |u_i,k| over the run (the applied, limited "
                 "torque); diverged: unknown")
def _peak_torque(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    if str(r.status) == "diverged":
        return ctx.value(None, f"run diverged: {r.message}")
    sel, what = _spacecraft(ctx, r.peak_torque)
    return ctx.value(None if sel is None else float(sel.max()), what)


@register_metric("control_effort", unit="N^2 m^2 s", evidence="simulation", args=(_SC,),
                 doc="sum over the spacecraft of int_0^tf |u_i|^2 dt (trapezoid on the output "
                 "grid; exact for held torques); diverged: unknown")
def _effort(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    if str(r.status) == "diverged":
        return ctx.value(None, f"run diverged: {r.message}")
    sel, what = _spacecraft(ctx, np.asarray(r.effort))
    return ctx.value(None if sel is None else float(np.sum(sel)), what)


@register_metric("transmissions", unit="count", evidence="simulation", applies=_sampled_only,
                 doc="broadcasts of a sampled design over the run (every spacecraft)")
def _transmissions(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    if r.transmissions is None:
        return ctx.value(None, "the run records no transmissions")
    return ctx.value(float(np.sum(r.transmissions)), "all spacecraft")


@register_metric("min_inter_event_time", unit="s", evidence="simulation", applies=_sampled_only,
                 doc="shortest time between two updates of one spacecraft of a sampled design")
def _min_interevent(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    if r.min_interevent is None or not np.any(np.isfinite(r.min_interevent)):
        return ctx.value(None, "fewer than two updates per spacecraft")
    return ctx.value(float(np.nanmin(r.min_interevent)), "over every spacecraft")


@register_metric("mc_converged_fraction", unit="1", evidence="montecarlo",
                 doc="fraction of the [montecarlo] runs that converged by the criterion (a "
                 "diverged or stopped run has not)")
def _mc_fraction(ctx: MetricContext) -> MetricValue:
    mc = ctx.montecarlo()
    n = len(mc.runs)
    ok = n - len(mc.failures)
    seeds = ", ".join(str(r.seed) for r in mc.failures[:3])
    return ctx.value(ok / n, f"{ok} of {n} runs" + (f"; failed seeds {seeds}" if seeds else ""))


@register_metric("mc_convergence_time_max", unit="s", evidence="montecarlo",
                 doc="largest convergence time over the [montecarlo] runs; when a run did not "
                 "converge by tf (or diverged): >= tf")
def _mc_time_max(ctx: MetricContext) -> MetricValue:
    mc = ctx.montecarlo()
    tf = float(ctx.case.options.tf)
    if mc.failures:
        return ctx.value(tf, f"{len(mc.failures)} of {len(mc.runs)} runs not converged by "
                         f"tf = {tf:g} s", bound="lower")
    return ctx.value(max(float(r.convergence_time) for r in mc.runs), f"{len(mc.runs)} runs")


@register_metric("mc_peak_torque_max", unit="N m", evidence="montecarlo",
                 doc="largest peak torque component over the [montecarlo] runs")
def _mc_peak(ctx: MetricContext) -> MetricValue:
    mc = ctx.montecarlo()
    vals = [r.peak_torque for r in mc.runs if math.isfinite(r.peak_torque)]
    if len(vals) < len(mc.runs):
        return ctx.value(None, "a run has a non-finite torque")
    return ctx.value(max(vals), f"{len(mc.runs)} runs")
