"""Certificate metrics of a design's own families and of its declared graph class (the
registry of :mod:`formsync_design.verify.metrics`; registered when an engine case is read).

=====================  =======  ===========  ====================================================
metric                 unit     evidence     value
=====================  =======  ===========  ====================================================
family_certificate     verdict  certificate  the design's families over the [families] box
family_margin          1        certificate  the certified margin (overall, or of one family)
theorem_graph_class    verdict  certificate  ``refuted`` when a graph of the declared class is
=====================  =======  ===========  ====================================================

``family_certificate`` decides the design's ``conditions(c)`` families on the formation's
graph over the case's ``[families]`` box (exact re-checks, its multipliers searched:
:meth:`~formsync_design.verify.engine.EngineResults.families`): ``certified`` or ``refuted``
(proven), undecided is no value.  ``theorem_graph_class`` is the check of the design's
declared graph class on graph families (:func:`~formsync_design.verify.theoremcheck.check_theorem`):
a refuted graph of the class is a counterexample (``refuted``, a proof); none refuted
decides nothing (no value: a claim that the class suffices stays undecided).
"""

from __future__ import annotations

from typing import Any

from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric

__all__: list[str] = []


def _has_conditions(design: Any) -> str | None:
    return None if callable(design.module.get("conditions")) else (
        f"design {design.name} has no conditions(c)")


@register_metric("family_certificate", unit="verdict", evidence="certificate", value="text",
                 applies=_has_conditions, families=True,
                 doc="the design's own certificate families (conditions(c)) on the formation's "
                 "graph, decided over the [families] box with exact re-checks (multipliers "
                 "searched): certified or refuted; undecided is no value")
def _family_certificate(ctx: MetricContext) -> MetricValue:
    c = ctx.families()
    st = str(c.status)
    if st not in ("certified", "refuted"):
        return ctx.value(None, f"{st}: {c.reason}")
    return ctx.value(st, c.reason)


@register_metric("family_margin", unit="1", evidence="certificate", applies=_has_conditions,
                 families=True,
                 args=(MetricArg("family", "text", "", doc="a family's name (empty: the "
                                 "certificate's overall margin)"),),
                 doc="the certified lower bound of the margin over the [families] box: overall "
                 "(the smallest of the families) or of one family; unknown unless certified")
def _family_margin(ctx: MetricContext) -> MetricValue:
    c = ctx.families()
    name = str(ctx.args["family"])
    if str(c.status) != "certified":
        return ctx.value(None, f"certificate {c.status}: no certified margin")
    if not name:
        m = c.margin_lower_bound
        return ctx.value(None if m is None else float(m), "the smallest family margin")
    fam = next((f for f in c.families if f.name == name), None)
    if fam is None or fam.lower is None:
        names = [f.name for f in c.families]
        return ctx.value(None, f"no certified family {name!r} (families {names})")
    return ctx.value(float(fam.lower), f"family {name}")


@register_metric("theorem_graph_class", unit="verdict", evidence="certificate", value="text",
                 doc="the design's declared graph class (GRAPHS) checked on graph families by "
                 "the formation-level certificate at the scenario's gains: refuted when a graph "
                 "of the class is (a counterexample, proven); none refuted is no value (finite "
                 "families decide nothing in favour of the theorem)")
def _theorem(ctx: MetricContext) -> MetricValue:
    from formsync_design.verify.theoremcheck import check_theorem

    tc = ctx.memo(("theorem",) + ctx.key(), lambda: check_theorem(ctx.case))
    cls = ", ".join(tc.declared) or "any graph"
    cert = [r for r in tc.rows if r.status == "certified"]
    low = min((r.decay for r in cert if r.decay is not None), default=None)
    fams = sorted({r.family for r in tc.rows})
    summary = (f"class: {cls}; {len(tc.rows)} graphs ({', '.join(fams)}), {len(cert)} certified"
               + (f" (smallest certified decay rate {low:.3g} 1/s)" if low is not None else ""))
    bad = tc.counterexamples
    if bad:
        first = (f", first failing directed cycle C{tc.first_failing_cycle}"
                 if tc.first_failing_cycle else "")
        return ctx.value("refuted", f"{len(bad)} of {len(tc.rows)} graphs of the class refuted "
                         f"({bad[0].graph} first{first}); {summary}")
    return ctx.value(None, f"none of the {len(tc.rows)} graphs of the class refuted (decides "
                     f"nothing); {summary}")
