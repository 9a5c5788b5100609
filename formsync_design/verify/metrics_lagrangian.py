"""Metrics of a design's Lagrangian view and of the relative-attitude measurements it is
judged by (the registry of :mod:`formsync_design.verify.metrics`; registered when an engine
case is read).

============================  =======  ===========  ==========================================
metric                        unit     evidence     value
============================  =======  ===========  ==========================================
lagrangian_certificate        verdict  certificate  ``certified`` / ``refuted``: every
                                                    ``Theta_i`` (``family = "Theta"``), ``Pi``
                                                    (``"Pi"``) or both (``"all"``) positive
                                                    definite at the scenario's gains
lagrangian_margin             1        certificate  rigorous lower bound of min
                                                    ``lambda_min`` (certified only)
switching_gain_ratio          1        certificate  ``min_i K_vi / K_vi*``; the exact check
                                                    ``K_vi >= K_vi*`` decides it
required_switching_gain       1        certificate  ``K_vi*`` of one spacecraft
disturbance_bound             N m      certificate  ``ubar_i`` of the disturbance model
relative_convergence_time     s        simulation   first time from which ``Q_m <= q_tol`` and
                                                    ``Omega_m <= omega_tol`` hold to tf
tail_q_m, tail_omega_m        1, rad/s simulation   max ``Q_m`` / ``Omega_m`` over the last
                                                    ``fraction`` of the run
final_abs_rate                rad/s    simulation   ``max_i |w_i|`` at tf (absolute rates)
saturation_end_time           s        simulation   last time a component is at the limit
chatter_end_time              s        simulation   last time a torque component reverses 3+
                                                    times within 1 s
tail_torque_reversals         count    simulation   reversals in the last ``fraction``
printed_certificate           verdict  certificate  the paper's printed ``Theta_i`` / ``Pi``
                                                    (``<design>_printed.py``) at the gains
derivation_finding            verdict  certificate  one paper-versus-derivation verdict
============================  =======  ===========  ==========================================

The certificate metrics apply to a design that carries a Lagrangian view
(:func:`~formsync_design.spec.loader.lagrangian_view`); they derive its ``Theta_i`` and
``Pi`` on the formation's graph (:func:`~formsync_design.derive.conditions.derive_conditions`)
and decide them at the scenario's gains (a diagonal gain: the hull of its entries, sound for
every axis), searching the view's declared multipliers
(:func:`~formsync_design.certify.multipliers.certify_with_multipliers`); the exact
re-check decides, an SDP is only a hint.  ``Q_m`` and ``Omega_m`` are the relative measures
of :func:`~formsync_design.sim.metrics.linear_metrics` (RMS over the pairs of the relative
quaternion's vector part, and of the body-rate differences).

Conventions of the simulation metrics: a run that diverged or stopped (the ``q0 -> 0``
singularity of a quaternion law) has no value; a steady-state quantity (``tail_*``,
``final_abs_rate``) has a value only when the run converged by the relative criterion before
its tail began (else unknown: the steady state was not reached); the end time of an event
that never happens is 0 s (it satisfies every upper bound); one still going at the end of
the horizon is ``>= tf``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric

__all__ = ["relative_measures", "relative_convergence_time", "chatter_end_time", "printed_file",
           "torque_reversals", "lagrangian_graph"]


def _view(design: Any) -> Any:
    from formsync_design.spec.loader import lagrangian_view

    return lagrangian_view(design)


def _has_view(design: Any) -> str | None:
    return None if _view(design) is not None else (
        f"design {design.name} has no Lagrangian view (lagrangian_controller, lyapunov)")


def _has_switching(design: Any) -> str | None:
    why = _has_view(design)
    if why is not None:
        return why
    return None if _view(design).decl.switching is not None else (
        f"design {design.name} has no switching gain")


def lagrangian_graph(graph: Any) -> Any:
    """The undirected :class:`~formsync_design.graphs.Graph` of a formation's digraph (its
    name kept when it is a graph spec such as ``ring:8``)."""
    from formsync_design.errors import InputError
    from formsync_design.graphs.build import make_graph

    if not graph.is_undirected:
        raise InputError(f"expected an undirected formation graph for a Lagrangian view, "
                         f"received {graph.name}")
    try:
        g = make_graph(graph.name)
        if g.n == graph.n and np.array_equal(np.asarray(g.adjacency) != 0,
                                             np.asarray(graph.adjacency) != 0):
            return g
    except InputError:
        pass
    return make_graph((np.asarray(graph.adjacency) != 0).astype(int))


def relative_measures(r: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(Omega_m, Q_m)`` of a run at every output time."""
    from formsync_design.sim.metrics import linear_metrics

    T, n = r.quaternions.shape[:2]
    X = np.hstack([np.asarray(r.quaternions).reshape(T, 4 * n), np.asarray(r.rates).reshape(T, 3 * n)])
    return linear_metrics(X, n)


def relative_convergence_time(t: np.ndarray, om: np.ndarray, qm: np.ndarray, q_tol: float,
                              omega_tol: float) -> float | None:
    """First output time from which ``Q_m <= q_tol`` and ``Omega_m <= omega_tol`` hold to the
    end (``None``: not at the end).

    >>> relative_convergence_time(np.arange(4.0), np.zeros(4), np.array([1, 0, 1, 0.0]), 0.5, 1)
    3.0
    """
    ok = (np.asarray(qm) <= q_tol) & (np.asarray(om) <= omega_tol)
    if not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return float(t[0] if bad.size == 0 else t[bad[-1] + 1])


def torque_reversals(u: np.ndarray, rel: float = 1e-3) -> np.ndarray:
    """Boolean ``(T, C)``: a direction reversal of a torque component at grid point ``k`` (a
    sign change of consecutive increments both larger than ``rel`` times the component's
    peak, so noise and smooth extrema do not count).

    >>> torque_reversals(np.array([[0.0], [1.0], [0.0], [1.0]]))[:, 0].tolist()
    [False, True, True, False]
    """
    u = np.asarray(u, float)
    du = np.diff(u, axis=0)
    thr = rel * np.maximum(np.max(np.abs(u), axis=0), 1e-300)
    big = np.abs(du) > thr
    flips = (du[1:] * du[:-1] < 0) & big[1:] & big[:-1]
    out = np.zeros_like(u, dtype=bool)
    out[1:-1] = flips
    return out


def chatter_end_time(t: np.ndarray, u: np.ndarray, window: float = 1.0, count: int = 3) -> float | None:
    """Last time at which some torque component reverses ``count`` or more times within
    ``window`` seconds (``None``: it never chatters).

    >>> t = np.arange(0, 10, 0.1)
    >>> u = np.where(t < 3, np.sign(np.sin(40 * t)), np.exp(-t))[:, None]
    >>> 2.0 < chatter_end_time(t, u) < 3.0
    True
    """
    idx = np.flatnonzero(torque_reversals(u).any(axis=1))
    if idx.size < count:
        return None
    times = np.asarray(t)[idx]
    last = None
    for k in range(count - 1, idx.size):
        if times[k] - times[k - count + 1] <= window:
            last = float(times[k])
    return last


def _ended(r: Any) -> str | None:
    if str(r.status) in ("diverged", "stopped"):
        return f"run {r.status}: {r.message}"
    return None


def _tail_start(t: np.ndarray, frac: float) -> int:
    """Index of the first sample of the last ``frac`` of the samples."""
    return min(len(t) - 1, int(np.floor((1 - frac) * len(t))))


_Q_TOL = MetricArg("q_tol", "number", quantity="tolerance", minimum=0.0, doc="the bound on Q_m")
_OMEGA_TOL = MetricArg("omega_tol", "number", quantity="tolerance", minimum=0.0,
                       doc="the bound on Omega_m (rad/s)")
_FRACTION = MetricArg("fraction", "number", 0.2, minimum=0.0,
                      doc="the steady-state tail: the last fraction of the output samples")


def _measures(ctx: MetricContext) -> tuple[np.ndarray, np.ndarray]:
    return ctx.memo(("relative_measures", *ctx.key()), lambda: relative_measures(ctx.run()))


def _converged(ctx: MetricContext) -> float | None:
    om, qm = _measures(ctx)
    return relative_convergence_time(ctx.run().t, om, qm, float(ctx.args["q_tol"]),
                                     float(ctx.args["omega_tol"]))


@register_metric("relative_convergence_time", unit="s", evidence="simulation",
                 args=(_Q_TOL, _OMEGA_TOL),
                 doc="first output time from which Q_m <= q_tol and Omega_m <= omega_tol hold "
                 "to tf; not converged by tf: >= tf; diverged or stopped: unknown")
def _relative_convergence(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    ct = _converged(ctx)
    tf = float(r.t[-1])
    if ct is None:
        return ctx.value(tf, f"not converged by tf = {tf:g} s", bound="lower")
    return ctx.value(ct, f"horizon {tf:g} s")


def _steady(ctx: MetricContext, measure: Any) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    t = np.asarray(r.t)
    k0 = _tail_start(t, float(ctx.args["fraction"]))
    ct = _converged(ctx)
    if ct is None or ct > float(t[k0]):
        return ctx.value(None, f"steady state not reached within {float(t[-1]):g} s (not "
                         f"converged before the tail from {float(t[k0]):g} s)")
    return ctx.value(float(measure(r, k0)), f"from {float(t[k0]):g} s to {float(t[-1]):g} s")


_STEADY_ARGS = (_Q_TOL, _OMEGA_TOL, _FRACTION)


@register_metric("tail_q_m", unit="1", evidence="simulation", args=_STEADY_ARGS,
                 doc="max Q_m over the steady-state tail; unknown unless the run converged "
                 "(q_tol, omega_tol) before the tail began")
def _tail_q_m(ctx: MetricContext) -> MetricValue:
    return _steady(ctx, lambda r, k0: np.max(_measures(ctx)[1][k0:]))


@register_metric("tail_omega_m", unit="rad/s", evidence="simulation", args=_STEADY_ARGS,
                 doc="max Omega_m over the steady-state tail; unknown unless the run converged "
                 "before the tail began")
def _tail_omega_m(ctx: MetricContext) -> MetricValue:
    return _steady(ctx, lambda r, k0: np.max(_measures(ctx)[0][k0:]))


@register_metric("final_abs_rate", unit="rad/s", evidence="simulation", args=_STEADY_ARGS,
                 doc="max_i |w_i| at tf (absolute body rates: a common drift counts); unknown "
                 "unless the run converged before its steady-state tail")
def _final_abs_rate(ctx: MetricContext) -> MetricValue:
    return _steady(ctx, lambda r, k0: np.max(np.linalg.norm(np.asarray(r.rates)[-1], axis=1)))


def _event(ctx: MetricContext, t: np.ndarray, value: float | None, what: str) -> MetricValue:
    tf = float(t[-1])
    if value is None:
        return ctx.value(0.0, f"never {what} (reported as 0 s)")
    dt = float(t[-1] - t[-2]) if len(t) > 1 else 0.0
    if value >= tf - 0.5 * dt:
        return ctx.value(tf, f"still {what} at {tf:g} s", bound="lower")
    return ctx.value(float(value), f"horizon {tf:g} s")


@register_metric("saturation_end_time", unit="s", evidence="simulation",
                 doc="last output time with some torque component at the scenario's per-axis "
                 "torque_limit (never: 0 s; at tf: >= tf); unknown without a limit, or when "
                 "the run diverged or stopped")
def _saturation_end(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    lim = ctx.options().torque_limit
    if lim is None:
        return ctx.value(None, "the scenario has no torque limit")
    u = np.asarray(r.torques).reshape(len(r.t), -1)
    at = np.flatnonzero((np.abs(u) >= float(lim) * (1 - 1e-12)).any(axis=1))
    return _event(ctx, np.asarray(r.t), float(r.t[at[-1]]) if at.size else None,
                  f"at the limit of {float(lim):g} N m")


@register_metric("chatter_end_time", unit="s", evidence="simulation",
                 doc="last output time at which a torque component reverses direction 3 or more "
                 "times within 1 s (never: 0 s); diverged or stopped: unknown")
def _chatter_end(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    u = np.asarray(r.torques).reshape(len(r.t), -1)
    return _event(ctx, np.asarray(r.t), chatter_end_time(r.t, u), "chattering")


@register_metric("tail_torque_reversals", unit="count", evidence="simulation", args=(_FRACTION,),
                 doc="direction reversals of the torque components over the last fraction of "
                 "the run; diverged or stopped: unknown")
def _tail_reversals(ctx: MetricContext) -> MetricValue:
    r = ctx.run()
    why = _ended(r)
    if why is not None:
        return ctx.value(None, why)
    k0 = _tail_start(np.asarray(r.t), float(ctx.args["fraction"]))
    u = np.asarray(r.torques).reshape(len(r.t), -1)
    return ctx.value(float(torque_reversals(u)[k0:].sum()), f"from {float(r.t[k0]):g} s")


# ------------------------------------------------------------------ the Lagrangian view


def _box(ctx: MetricContext, view: Any) -> dict[str, Any]:
    """The scenario's controller gains as exact numbers (a diagonal gain: its hull)."""
    given = ctx.case.gains.as_dict()
    box: dict[str, Any] = {}
    for n in view.decl.controller_gains:
        v = given[n]
        box[n] = ((Fraction(str(min(v))), Fraction(str(max(v)))) if isinstance(v, tuple)
                  else Fraction(str(v)))
    return box


def lagrangian_certificate(ctx: MetricContext) -> Any:
    """The :class:`~formsync_design.certify.results.CertificationResult` of the design's
    Lagrangian conditions on the formation's graph at the scenario's gains (cached)."""
    def compute() -> Any:
        from formsync_design.certify.multipliers import certify_with_multipliers
        from formsync_design.derive.conditions import derive_conditions
        from formsync_design.graphs.theorem import check_theorem_graph

        view = _view(ctx.case.design)
        g = lagrangian_graph(ctx.graph)
        check_theorem_graph(g, view.decl.graphs, design=view.name)
        mult = {n: r for n in view.decl.multipliers if (r := view.decl.gain(n).range) is not None}
        return certify_with_multipliers(derive_conditions(g, spec=view), _box(ctx, view), mult)

    gains = tuple(sorted((k, str(v)) for k, v in ctx.case.gains.as_dict().items()))
    return ctx.memo(("lagrangian_certificate", ctx.formation, ctx.case.design.name, gains), compute)


def _families(res: Any, family: str) -> list[Any]:
    return [fm for fm in res.families
            if family == "all" or (family == "Pi" and fm.name == "Pi")
            or (family == "Theta" and fm.name.startswith("Theta"))]


_FAMILY = MetricArg("family", "text", "all", choices=("all", "Theta", "Pi"),
                    doc="which conditions: every Theta_i, Pi, or all")


@register_metric("lagrangian_certificate", unit="verdict", evidence="certificate", value="text",
                 args=(_FAMILY,), applies=_has_view,
                 doc="the design's Lagrangian conditions (Theta_i, Pi) on the formation's graph "
                 "at the scenario's gains: certified (every family positive definite, exact "
                 "re-check) or refuted (one is not); undecided: unknown")
def _lagrangian_certificate(ctx: MetricContext) -> MetricValue:
    res = lagrangian_certificate(ctx)
    fams = _families(res, str(ctx.args["family"]))
    names = ", ".join(fm.name for fm in fams[:3]) + (", ..." if len(fams) > 3 else "")
    where = f"{names} on {lagrangian_graph(ctx.graph).name}"
    if fams and all(str(fm.status) == "certified" for fm in fams):
        return ctx.value("certified", f"{where}: exact re-check")
    if any(str(fm.status) == "refuted" for fm in fams):
        return ctx.value("refuted", f"{where}: a point of the box violates it (exact)")
    return ctx.value(None, f"{where}: undecided")


@register_metric("lagrangian_margin", unit="1", evidence="certificate", applies=_has_view,
                 doc="rigorous lower bound of min lambda_min over the Lagrangian families at the "
                 "scenario's gains; unknown unless certified (the detail gives the "
                 "floating-point hint)")
def _lagrangian_margin(ctx: MetricContext) -> MetricValue:
    res = lagrangian_certificate(ctx)
    if res.margin_lower_bound is not None:
        return ctx.value(float(res.margin_lower_bound), "certified lower bound", bound="lower")
    hints = [float(fm.hint) for fm in res.families if fm.hint is not None]
    return ctx.value(None, f"{res.status}" + (f"; floating-point hint {min(hints):.3g}" if hints else ""))


def _kv_parts(ctx: MetricContext) -> tuple[list[float], list[float], list[float], Any]:
    """``(K_vi, K_vi*, ubar_i, exact check)`` of the scenario on the formation."""
    def compute() -> Any:
        from formsync_design.certify.engine import check_kv
        from formsync_design.derive.closed_form import required_kv

        view = _view(ctx.case.design)
        name = view.decl.switching
        J = list(ctx.case.inertias)
        ubar = [float(x) for x in ctx.initial().disturbance.bound(np.asarray(J))]
        kv = ctx.case.gains.as_dict()[name]
        kvs = [float(x) for x in kv] if isinstance(kv, tuple) else [float(kv)] * len(J)
        req = [required_kv(Ji, u) for Ji, u in zip(J, ubar, strict=True)]
        return kvs, req, ubar, check_kv(kvs, J, ubar)

    return ctx.memo(("switching_gain", *ctx.key()), compute)


@register_metric("switching_gain_ratio", unit="1", evidence="certificate", applies=_has_switching,
                 doc="min_i K_vi / K_vi* with K_vi* = (ubar_i/2) max_v |J_i^-1 v| the derived "
                 "tight bound for the disturbance model's bound ubar_i; K_vi >= K_vi* decided "
                 "exactly (a ratio >= 1 is then proven)")
def _kv_ratio(ctx: MetricContext) -> MetricValue:
    kvs, req, _, chk = _kv_parts(ctx)
    ratio = min(k / r for k, r in zip(kvs, req, strict=True))
    return ctx.value(ratio, "exact check K_vi >= K_vi*: " + ("holds" if chk.holds else "fails"))


_SC = MetricArg("spacecraft", "int", minimum=1, doc="1-based spacecraft")


def _one(ctx: MetricContext, vals: list[float], what: str) -> MetricValue:
    k = int(ctx.args["spacecraft"])
    if k > len(vals):
        return ctx.value(None, f"spacecraft {k} is not in the formation (N = {len(vals)})")
    return ctx.value(vals[k - 1], f"{what} of spacecraft {k}")


@register_metric("required_switching_gain", unit="1", evidence="certificate", args=(_SC,),
                 applies=_has_switching,
                 doc="K_vi* of one spacecraft: the smallest switching gain with eps_i >= 0 for "
                 "every attitude and every disturbance within the model's bound")
def _kv_required(ctx: MetricContext) -> MetricValue:
    return _one(ctx, _kv_parts(ctx)[1], "K_vi*")


@register_metric("disturbance_bound", unit="N m", evidence="certificate", args=(_SC,),
                 applies=_has_switching,
                 doc="ubar_i, the per-axis bound of the scenario's disturbance model on one "
                 "spacecraft")
def _ubar(ctx: MetricContext) -> MetricValue:
    return _one(ctx, _kv_parts(ctx)[2], "ubar")


# ------------------------------------------------- the paper's printed conditions


def printed_file(design: Any) -> Any:
    """The file of the paper's printed expressions shipped beside the design's file
    (``<design>_printed.py``), or ``None``."""
    from pathlib import Path

    view = _view(design)
    if view is None or not view.path:
        return None
    p = Path(str(view.path)).with_name(f"{view.name}_printed.py")
    return p if p.is_file() else None


def _has_printed(design: Any) -> str | None:
    why = _has_view(design)
    if why is not None:
        return why
    return None if printed_file(design) is not None else (
        f"design {design.name} ships no printed expressions ({design.name}_printed.py)")


@register_metric("printed_certificate", unit="verdict", evidence="certificate", value="text",
                 args=(_FAMILY,), applies=_has_printed,
                 doc="the paper's printed Theta_i and Pi (<design>_printed.py beside the design "
                 "file) on the formation's graph at the scenario's gains: certified or refuted "
                 "(exact re-check); undecided: unknown")
def _printed_certificate(ctx: MetricContext) -> MetricValue:
    def compute() -> Any:
        from formsync_design.certify.engine import certify_box
        from formsync_design.derive.conditions import paper_conditions

        view = _view(ctx.case.design)
        return certify_box(paper_conditions(lagrangian_graph(ctx.graph), printed_file(ctx.case.design)),
                           _box(ctx, view))

    gains = tuple(sorted((k, str(v)) for k, v in ctx.case.gains.as_dict().items()))
    res = ctx.memo(("printed_certificate", ctx.formation, ctx.case.design.name, gains), compute)
    fams = _families(res, str(ctx.args["family"]))
    where = f"printed conditions on {lagrangian_graph(ctx.graph).name}"
    if fams and all(str(fm.status) == "certified" for fm in fams):
        return ctx.value("certified", f"{where}: exact re-check")
    if any(str(fm.status) == "refuted" for fm in fams):
        return ctx.value("refuted", f"{where}: a point of the box violates them (exact)")
    return ctx.value(None, f"{where}: undecided")


@register_metric("derivation_finding", unit="verdict", evidence="certificate", value="text",
                 args=(MetricArg("key", "text", doc="the finding's key (B-skew, Pi-M, ...)"),),
                 applies=_has_printed,
                 doc="the verdict of one paper-versus-derivation finding of the design's "
                 "Lagrangian view on the formation's graph (symbolic, exact: "
                 "derive/compare.py)")
def _derivation_finding(ctx: MetricContext) -> MetricValue:
    def compute() -> Any:
        from formsync_design.derive.compare import all_findings

        return all_findings(lagrangian_graph(ctx.graph), _view(ctx.case.design),
                            printed_file(ctx.case.design))

    found = ctx.memo(("derivation_findings", ctx.formation, ctx.case.design.name), compute)
    key = str(ctx.args["key"])
    f = next((x for x in found if x.key == key), None)
    if f is None:
        return ctx.value(None, f"no finding {key!r} (the findings: "
                         f"{', '.join(x.key for x in found)})")
    return ctx.value(str(f.verdict), str(f.meaning or f.item))
