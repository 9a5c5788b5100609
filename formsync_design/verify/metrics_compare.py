"""Metrics that compare the scenarios of a case: the order in which they reach a bound and
the gain factor of a scenario at equal peak torque (the registry of
:mod:`formsync_design.verify.metrics`; registered when an engine case is read).

==================  =====  ==========  ==========================================================
metric              unit   evidence    value
==================  =====  ==========  ==========================================================
times_in_order      1      simulation  1 when the listed scenarios reach the bound in that order
                                       (strictly), else 0; the order in the detail
gain_scale          1      simulation  the factor of a ``torque_matching`` scenario's gains
==================  =====  ==========  ==========================================================

``times_in_order`` reads the runs of the listed scenarios on the same formation and, in a
``montecarlo = "min" | "mean"`` row, the same draw (so ``mean`` is the fraction of draws in
that order); a scenario that does not reach the bound counts as later than every one that
does, and two that do not are not ordered
(:func:`~formsync_design.analysis.equal_torque.in_order`).  ``gain_scale`` reports the search
of :meth:`~formsync_design.verify.engine.EngineResults.gain_scale`.
"""

from __future__ import annotations

from formsync_design.analysis.equal_torque import in_order, ordering
from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric
from formsync_design.verify.metrics_attitude import euler_error_time

__all__: list[str] = []


def _names(ctx: MetricContext) -> list[str]:
    return [s.strip() for s in str(ctx.args["scenarios"]).split(",") if s.strip()]


@register_metric("times_in_order", unit="1", evidence="simulation",
                 args=(MetricArg("scenarios", "text", doc="the scenarios in the claimed order, "
                                 "comma-separated"),
                       MetricArg("measure", "text", "euler_error",
                                 choices=("euler_error", "angle"),
                                 doc="euler_error: Qa (euler_error_time); angle: the largest "
                                 "pairwise principal angle (time_to_angle)"),
                       MetricArg("threshold_deg", "number", 1.0, quantity="angle", minimum=0.0,
                                 doc="the bound (deg)")),
                 doc="1 when the listed scenarios' runs (same formation, same draw) first stay "
                 "within the bound strictly in the listed order, a run not reaching it counting "
                 "as later than any that does, else 0; the order in the detail")
def _times_in_order(ctx: MetricContext) -> MetricValue:
    names = _names(ctx)
    if len(names) < 2:
        return ctx.value(None, "expected at least two scenarios")
    thr = float(ctx.args["threshold_deg"])
    times: list[float | None] = []
    for s in names:
        r = ctx.run(s)
        if str(r.status) in ("diverged", "stopped"):
            return ctx.value(None, f"the {s} run {r.status}")
        t = (euler_error_time(r, thr) if ctx.args["measure"] == "euler_error" else r.time_to(thr))
        times.append(None if t is None else float(t))
    shown = ordering([f"{s} {'' if t is None else f'{t:.2f} s'}".strip()
                      for s, t in zip(names, times)], times)
    return ctx.value(1.0 if in_order(times) else 0.0, shown)


@register_metric("gain_scale", unit="1", evidence="simulation",
                 doc="the factor on the gains (all but those held) of a torque_matching "
                 "scenario that makes its peak torque on the matching formation equal the "
                 "matched scenario's there (bracketing, then bisection in log c: "
                 "formsync_design/analysis/equal_torque.py); the peak, its relative error, the "
                 "runs of the search and the scaled gains in the detail")
def _gain_scale(ctx: MetricContext) -> MetricValue:
    scale = ctx.results.gain_scale(ctx.scenario)
    if scale is None:
        return ctx.value(None, f"scenario {ctx.scenario} has no torque_matching")
    ep, gains = scale
    g = ", ".join(f"{k} {float(v[0] if isinstance(v, tuple) else v):.4g}"
                  for k, v in gains.as_dict().items())
    return ctx.value(float(ep.scale), f"peak {ep.peak:.4g} N m against {ep.target:.4g} N m "
                     f"(relative error {ep.relative_error:.1e}, {ep.evaluations} search runs); "
                     f"scaled gains {g}")
