"""Metrics of sampled designs and comparisons of two scenarios (the registry of
:mod:`formsync_design.verify.metrics`; registered when an engine case is read).

=============================  =======  ============  ==========================================
metric                         unit     evidence      value
=============================  =======  ============  ==========================================
trigger_evaluations            count    simulation    evaluations of the trigger function (all)
evaluations_per_broadcast      1        simulation    max/min over spacecraft of evaluations/broadcasts
transmissions_ratio            1        simulation    broadcasts / those of the ``versus`` scenario
evaluations_ratio              1        simulation    evaluations / those of the ``versus`` scenario
tail_reference_angle_deg       deg      simulation    largest angle to the leader over the tail
tail_angle_ratio               1        simulation    that accuracy / the ``versus`` scenario's
mean_inter_event_time          s        simulation    mean inter-event time (mean over spacecraft)
sampling_period                s        simulation    the period of a periodic run (matched or set)
reference_rate_max             rad/s    numerical     largest leader rate over the horizon
certified_interevent_bound     s        certificate   the self-trigger rule's inter-event bound
disturbance_bound_covered      verdict  certificate   whether a gain bounds |D_i J_i^-1 d_i|
=============================  =======  ============  ==========================================

A ``versus`` scenario is run on the same formation and, in a ``montecarlo = "max"|"min"``
row, on the same draw: the ratio compares the two runs pair by pair.  The trigger
evaluations are counted by the sampled simulator (one per broadcast for a self-trigger; every
evaluation of the crossing detection and root finding for an event trigger; none for
periodic sampling).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric

__all__ = ["tail_mask"]


def _sampled(design: Any) -> str | None:
    return None if design.decl.sampling != "continuous" else (
        f"design {design.name} is continuous (no broadcasts)")


def _leader(design: Any) -> str | None:
    return None if design.decl.leader else f"design {design.name} has no leader"


def _self_triggered(design: Any) -> str | None:
    if design.decl.sampling != "self-triggered" or not design.has("next_interval"):
        return f"design {design.name} is not self-triggered"
    if not (callable(design.module.get("parts")) and callable(design.module.get("eta"))):
        return f"design {design.name} has no parts(v) and eta(v) (the rule's |s| and eta)"
    return None


_VERSUS = MetricArg("versus", "text", doc="the scenario compared with (same formation, same draw)")
_FRACTION = MetricArg("fraction", "number", 0.2, quantity="tolerance", minimum=0.0,
                      doc="the last fraction of the horizon")
_STAT = MetricArg("stat", "text", "max", choices=("max", "min"), doc="over the spacecraft")


def tail_mask(t: np.ndarray, fraction: float) -> np.ndarray:
    """The output times of the last ``fraction`` of the horizon (``t >= t_end (1 - f)``, to
    1e-9 s).

    >>> tail_mask(np.arange(11.0), 0.2).nonzero()[0].tolist()
    [8, 9, 10]
    """
    return t >= t[-1] * (1 - fraction) - 1e-9


def _evaluations(ctx: MetricContext, scenario: str | None = None) -> np.ndarray | None:
    rec = ctx.record(scenario)
    ev = rec.get("trigger_evaluations")
    return None if ev is None else np.asarray(ev, dtype=np.int64)


@register_metric("trigger_evaluations", unit="count", evidence="simulation", applies=_sampled,
                 doc="evaluations of the trigger function over the run, every spacecraft (one "
                 "per broadcast for a self-trigger; the exact integrator's crossing detection "
                 "and root finding for an event trigger; none for periodic sampling)")
def _trigger_evaluations(ctx: MetricContext) -> MetricValue:
    ev = _evaluations(ctx)
    if ev is None:
        return ctx.value(None, "the run is not sampled")
    return ctx.value(float(ev.sum()), f"per spacecraft {int(ev.min())}-{int(ev.max())}")


@register_metric("evaluations_per_broadcast", unit="1", evidence="simulation", applies=_sampled,
                 args=(_STAT,),
                 doc="the largest (or smallest) over the spacecraft of trigger evaluations / own "
                 "broadcasts: 1 for every spacecraft means the rule is evaluated exactly once per "
                 "broadcast and never in between (no continuous monitoring)")
def _per_broadcast(ctx: MetricContext) -> MetricValue:
    ev = _evaluations(ctx)
    tx = ctx.run().transmissions
    if ev is None or tx is None:
        return ctx.value(None, "the run is not sampled")
    tx = np.asarray(tx, dtype=np.int64)
    if np.any(tx == 0):
        return ctx.value(None, "a spacecraft never broadcast")
    r = ev / tx
    v = float(r.max() if ctx.args["stat"] == "max" else r.min())
    return ctx.value(v, f"{int(ev.sum())} evaluations for {int(tx.sum())} broadcasts")


def _ratio(ctx: MetricContext, a: float | None, b: float | None, what: str) -> MetricValue:
    if a is None or b is None:
        return ctx.value(None, f"no {what} in one of the runs")
    if b == 0:
        return ctx.value(None, f"the {ctx.args['versus']} run has no {what}")
    return ctx.value(a / b, f"{a:g} / {b:g} ({ctx.scenario} / {ctx.args['versus']})")


@register_metric("transmissions_ratio", unit="1", evidence="simulation", applies=_sampled,
                 args=(_VERSUS,),
                 doc="broadcasts of this scenario's run / those of the versus scenario's run "
                 "(same formation, same draw)")
def _tx_ratio(ctx: MetricContext) -> MetricValue:
    a, b = ctx.run().transmissions, ctx.run(ctx.args["versus"]).transmissions
    return _ratio(ctx, None if a is None else float(np.sum(a)),
                  None if b is None else float(np.sum(b)), "broadcasts")


@register_metric("evaluations_ratio", unit="1", evidence="simulation", applies=_sampled,
                 args=(_VERSUS,),
                 doc="trigger evaluations of this scenario's run / those of the versus "
                 "scenario's run (same formation, same draw)")
def _ev_ratio(ctx: MetricContext) -> MetricValue:
    a, b = _evaluations(ctx), _evaluations(ctx, ctx.args["versus"])
    return _ratio(ctx, None if a is None else float(a.sum()),
                  None if b is None else float(b.sum()), "trigger evaluations")


def _tail_angle(ctx: MetricContext, scenario: str | None = None) -> float | None:
    r = ctx.run(scenario)
    if r.reference_error is None or str(r.status) in ("diverged", "stopped"):
        return None
    return float(np.asarray(r.reference_error)[tail_mask(np.asarray(r.t),
                                                         float(ctx.args["fraction"]))].max())


@register_metric("tail_reference_angle_deg", unit="deg", evidence="simulation", applies=_leader,
                 args=(_FRACTION,),
                 doc="accuracy: the largest principal angle between a spacecraft and the "
                 "leader over the last fraction of the horizon; diverged or stopped: unknown")
def _tail_ref(ctx: MetricContext) -> MetricValue:
    v = _tail_angle(ctx)
    f = float(ctx.args["fraction"])
    return ctx.value(v, f"over the last {f * 100:g} % of the horizon" if v is not None
                     else "no reference error (diverged or stopped)")


@register_metric("tail_angle_ratio", unit="1", evidence="simulation", applies=_leader,
                 args=(_VERSUS, _FRACTION),
                 doc="the tail accuracy (tail_reference_angle_deg) of this scenario's run / the "
                 "versus scenario's (same formation, same draw): below 1 is better")
def _tail_ratio(ctx: MetricContext) -> MetricValue:
    return _ratio(ctx, _tail_angle(ctx), _tail_angle(ctx, ctx.args["versus"]), "tail accuracy")


@register_metric("mean_inter_event_time", unit="s", evidence="simulation", applies=_sampled,
                 doc="the mean time between two updates of one spacecraft, averaged over the "
                 "spacecraft")
def _mean_interevent(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    if r.mean_interevent is None or not np.any(np.isfinite(r.mean_interevent)):
        return ctx.value(None, "fewer than two updates per spacecraft")
    return ctx.value(float(np.nanmean(r.mean_interevent)), "mean over the spacecraft")


@register_metric("sampling_period", unit="s", evidence="simulation",
                 doc="the sampling period of a periodic run: the scenario's simulation.period, "
                 "or the period its period_matching derived from the matched run (tf / round("
                 "mean broadcasts per spacecraft))")
def _period(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    rec = ctx.record()
    h = rec.get("hybrid")
    tt = getattr(h, "trigger_times", None) if h is not None else None
    if not tt or len(tt[0]) < 2:
        return ctx.value(None, "not a periodic run with two updates")
    d = np.diff(np.asarray(tt[0]))
    if not np.allclose(d, d[0], rtol=1e-9, atol=1e-12):
        return ctx.value(None, f"the run's updates are not periodic ({r.design})")
    return ctx.value(float(d[0]), f"{len(tt[0])} updates of spacecraft 1")


@register_metric("reference_rate_max", unit="rad/s", evidence="numerical", applies=_leader,
                 doc="the largest leader body rate |w_d(t)| on 2001 points of [0, tf] (the "
                 "reference's formulas, floating point)")
def _ref_rate(ctx: MetricContext) -> MetricValue:
    from formsync_design.sim.agent_sampled import reference_trajectory

    tf = float(ctx.case.options.tf)
    ref = reference_trajectory(ctx.case.reference, tf)
    w = max(float(np.linalg.norm(ref(t)[1])) for t in np.linspace(0, tf, 2001))
    return ctx.value(w, f"over [0, {tf:g}] s")


@register_metric("certified_interevent_bound", unit="s", evidence="certificate",
                 applies=_self_triggered,
                 doc="tau_min: the lower bound of every self-triggered inter-event time derived "
                 "from the design's next_interval by the mediant inequality, exact at the "
                 "scenario's gains (analysis/triggering.py); it bounds an event-triggered "
                 "interval of the same error while |f_i| <= delta")
def _tau_min(ctx: MetricContext) -> MetricValue:
    from formsync_design.analysis.triggering import interevent_bound, interevent_origin
    from formsync_design.verify.metrics import point_gains

    point, why = point_gains(ctx.case)
    if point is None:
        return ctx.value(None, why)
    b = interevent_bound(ctx.case.design, point)
    active, rest, floor = interevent_origin(b, point)
    what = ("the design's own floor (the rule's interval at rest, guaranteed by its closed form "
            "for every state)" if floor else "not the rule's value at rest")
    return ctx.value(float(b.value), f"tau = {b.tau}; tau_min = {b.formula} = {b.value} "
                     f"(exact); active: {active}; at rest (S = 0, h = 0): {rest} s: {what}")


@register_metric("disturbance_bound_covered", unit="verdict", evidence="certificate",
                 value="text",
                 args=(MetricArg("gain", "text", "delta", doc="the gain that bounds the "
                                 "nonlinear term"),),
                 doc="whether the gain (delta) bounds the disturbance part D_i ubar_i max_v "
                 "|J_i^-1 v| of the nonlinear term for every spacecraft, decided exactly "
                 "(analysis/triggering.py): covered or not covered")
def _delta_covered(ctx: MetricContext) -> MetricValue:
    from formsync_design.analysis.triggering import disturbance_delta
    from formsync_design.verify.metrics import point_gains

    name = str(ctx.args["gain"])
    point, why = point_gains(ctx.case)
    if point is None or name not in point:
        return ctx.value(None, why or f"the design has no gain {name}")
    f = ctx.case.formation(ctx.graph)
    if f.disturbance is None:
        return ctx.value("covered", "no disturbance")
    g = f.graph
    D = g.adjacency.sum(axis=1) + g.pinning_matrix.diagonal()
    chk = disturbance_delta(point[name], ctx.case.inertias, f.disturbance.bound(ctx.case.inertias), D)
    req = ", ".join(f"{v:.4g}" for v in chk.required)
    return ctx.value("covered" if chk.all_hold else "not covered",
                     f"{name} = {point[name]} against the disturbance parts {req} (per spacecraft)")
