"""Metrics of what a design measures: its law's inputs and its runs under gyro models.

=======================  =======  ===========  ==================================================
metric                   unit     evidence     value
=======================  =======  ===========  ==================================================
rate_free_law            verdict  certificate  ``rate-free`` when neither ``MEASURED`` nor the
                                               law's symbols (every in-degree of the graph, its
                                               states included) hold a body rate, else
                                               ``reads-rate``
local_measurements       verdict  certificate  ``local`` when ``MEASURED`` holds only the own and
                                               neighbours' attitudes and the reference, else
                                               ``non-local``
run_difference           1        simulation   ``max |q - q_versus|`` of this scenario's run and
                                               the ``versus`` scenario's (0: bit for bit equal)
tail_disagreement_deg    deg      simulation   the largest pairwise attitude angle over the last
                                               ``fraction`` of the horizon
=======================  =======  ===========  ==================================================

``rate_free_law`` is symbolic (the exact free symbols of the law's expressions,
:func:`~formsync_design.spec.agent.agent_expressions`), so a proof; ``run_difference``
compares two simulations, e.g. the same design under a perfect and a failed gyro
(:mod:`formsync_design.verify.enginesensors`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric
from formsync_design.verify.metrics_sampled import tail_mask

__all__ = ["LOCAL_QUANTITIES", "rate_free_degrees"]

#: The quantities a decentralised attitude law may measure.
LOCAL_QUANTITIES = ("attitude", "neighbour-attitude", "reference")


def rate_free_degrees(design: Any, graph: Any) -> dict[int, bool]:
    """In-degree -> the law (and its states' dynamics) has no rate symbol, for every in-degree
    of ``graph``.

    >>> from formsync_design.spec.loader import load_design
    >>> rate_free_degrees(load_design("lv2012"), "path:3"), rate_free_degrees(load_design("liang2016"), "path:2")
    ({1: True, 2: True}, {1: False})
    """
    from formsync_design.graphs.digraph_io import make_digraph
    from formsync_design.spec.agent import agent_expressions

    g = make_digraph(graph)
    out = {}
    for m in sorted({len(g.receives_from(i)) for i in range(g.n)}):
        ex = agent_expressions(design, m)
        v = ex["view"]
        rates = set(v.w) | {s for n in v.nbrs for s in n.w}
        syms = set(ex["u"].free_symbols) | {s for e in ex.get("states", {}).values()
                                            for s in e.free_symbols}
        out[m] = not (syms & rates)
    return out


@register_metric("rate_free_law", unit="verdict", evidence="certificate", value="text",
                 doc="rate-free when neither MEASURED nor the law's symbols (every in-degree of "
                 "the formation's graph) hold a body rate, own or neighbours'; else reads-rate")
def _rate_free(ctx: MetricContext) -> MetricValue:
    d = ctx.case.design
    deg = ctx.memo(("rate-free", ctx.formation, d.name),
                   lambda: rate_free_degrees(d, ctx.graph))
    meas = list(d.decl.measured)
    ok = all(deg.values()) and "rate" not in meas and "neighbour-rate" not in meas
    return ctx.value("rate-free" if ok else "reads-rate",
                     f"MEASURED = {meas}; no rate symbol in the law for in-degrees "
                     f"{sorted(deg)}: {all(deg.values())}")


@register_metric("local_measurements", unit="verdict", evidence="certificate", value="text",
                 doc="local when MEASURED holds only the own and neighbours' attitudes and the "
                 "reference (checked symbolically by the loader), else non-local")
def _local(ctx: MetricContext) -> MetricValue:
    meas = list(ctx.case.design.decl.measured)
    return ctx.value("local" if set(meas) <= set(LOCAL_QUANTITIES) else "non-local",
                     f"MEASURED = {meas}")


@register_metric("run_difference", unit="1", evidence="simulation",
                 args=(MetricArg("versus", "text", doc="the scenario compared with"),),
                 doc="max |q - q_versus| over the output times of this scenario's run and the "
                 "versus scenario's (same formation and draw; 0: bit for bit equal)")
def _difference(ctx: MetricContext) -> MetricValue:
    a, b = ctx.run(), ctx.run(str(ctx.args["versus"]))
    qa, qb = np.asarray(a.quaternions), np.asarray(b.quaternions)
    if qa.shape != qb.shape:
        return ctx.value(None, f"runs of different lengths ({qa.shape[0]} and {qb.shape[0]} "
                         "output times)")
    diff = float(np.abs(qa - qb).max())
    return ctx.value(diff, f"versus {ctx.args['versus']}; bit for bit equal: {diff == 0.0}")


@register_metric("tail_disagreement_deg", unit="deg", evidence="simulation",
                 args=(MetricArg("fraction", "number", 0.2, quantity="tolerance", minimum=0.0,
                                 doc="the last fraction of the horizon"),),
                 doc="the largest pairwise attitude angle over the last fraction of the "
                 "horizon; diverged or stopped: unknown")
def _tail_disagreement(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    f = float(ctx.args["fraction"])
    if str(r.status) in ("diverged", "stopped"):
        return ctx.value(None, f"the run {r.status}")
    m = tail_mask(np.asarray(r.t), f)
    return ctx.value(float(np.asarray(r.attitude_error)[m].max()),
                     f"over the last {f * 100:g} % of the horizon")
