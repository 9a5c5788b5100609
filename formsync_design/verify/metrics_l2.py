"""L2-gain metrics of an agent design: certified on the linearisation, measured on the loop.

=========================  ========  ===========  ==============================================
metric                     unit      evidence     value
=========================  ========  ===========  ==============================================
certified_l2_gain          1/(N m)   certificate  gamma of the dissipation inequality on the
                                                  linearisation at the reference (``method``)
l2_steady_bound_deg        deg       certificate  ``2 asin(gamma sum_nu |U_nu|)``: the steady
                                                  attitude error bound gamma implies under the
                                                  case's harmonic disturbance
torque_bound               N m       certificate  the design's global torque bound at the gains
l2_gain_design             1/(N m)   certificate  gamma of the gains designed within ``budget``
measured_l2_gain_max       1/(N m)   simulation   the largest measured gain from rest
l2_box_certificate         verdict   certificate  gamma on a whole gain box: certified or
                                                  refuted (exact witness)
=========================  ========  ===========  ==============================================

The linearisation is :func:`~formsync_design.derive.linearize.linearize_agents` of the
scenario's design on the formation's graph and inertias at the commanded attitude (a design
with a leader at rest); ``z`` the attitude errors' vector parts, ``d`` the disturbance
torques.  ``certified_l2_gain`` is :func:`~formsync_design.analysis.l2gain.certify_gamma`
(storage by Riccati or the SDP, exact re-check): unknown unless certified.  The measured
gains (:func:`~formsync_design.sim.l2measure.measured_l2_gain`) start at the commanded
attitude at rest and read ``signals`` random disturbances of each family of
:data:`~formsync_design.sim.l2measure.SIGNALS` (RMS ``rms`` N m per axis, seed ``seed``),
the case's harmonic disturbance and the worst-case sinusoid of the linearisation, over
``tf`` s at the scenario's step: evidence, never a bound.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from formsync_design.verify.metrics import (
    MetricArg,
    MetricContext,
    MetricValue,
    format_number,
    register_metric,
)

__all__ = ["linearisation", "l2_certificate", "steady_bound_deg", "measured_gains", "parse_box"]


def _at_rest(design: Any) -> str | None:
    return None if design.decl.leader and design.decl.sampling == "continuous" else (
        f"design {design.name} is not a continuous design with a commanded attitude")


def linearisation(ctx: MetricContext) -> Any:
    """The linearisation of the scenario's design on the formation (cached)."""
    from formsync_design.derive.linearize import linearize_agents

    c = ctx.case
    key = ("l2-linearise", ctx.formation, c.design.name, c.inertias.tobytes())
    return ctx.memo(key, lambda: linearize_agents(c.design, ctx.graph, c.inertias))


def l2_certificate(ctx: MetricContext, method: str = "auto") -> Any:
    """:func:`~formsync_design.analysis.l2gain.certify_gamma` at the scenario's gains."""
    from formsync_design.analysis.l2gain import certify_gamma

    gains = ctx.case.gains.as_dict()
    key = ("l2-gamma", ctx.formation, ctx.scenario, method)
    return ctx.memo(key, lambda: certify_gamma(linearisation(ctx), gains, method=method))


def steady_bound_deg(gamma: float, harmonic: np.ndarray) -> float:
    """``2 asin(min(1, gamma sum_nu |U_nu|))`` in degrees (``|e_i| <= |z|``, angle ``2 asin |e_i|``).

    >>> h = np.zeros((1, 3, 6)); h[0, 0, 0] = 0.005     # a constant 5e-3 N m on one axis
    >>> round(steady_bound_deg(100.0, h), 6) == round(math.degrees(2 * math.asin(0.5)), 6)
    True
    """
    from formsync_design.analysis.l2gain import harmonic_steady_bound

    return math.degrees(2 * math.asin(min(1.0, harmonic_steady_bound(gamma, harmonic))))


_METHOD = MetricArg("method", "text", "auto", choices=("auto", "riccati", "sdp"),
                    doc="the storage search of the certificate")


@register_metric("certified_l2_gain", unit="1/(N m)", evidence="certificate", applies=_at_rest,
                 args=(_METHOD,),
                 doc="the certified L2 gain gamma from the disturbance torques to the attitude "
                 "errors on the linearisation at the commanded attitude (exact re-check of the "
                 "storage); unknown unless certified")
def _certified_gamma(ctx: MetricContext) -> MetricValue:
    g = l2_certificate(ctx, str(ctx.args["method"]))
    lin = linearisation(ctx)
    detail = (f"{g.status} (storage by {g.method}, {lin.nx} states); numerical H-infinity norm "
              f"{g.hinf:.6g} at {g.peak_frequency:.3g} rad/s")
    return ctx.value(float(g.gamma) if g.certified else None, detail + (
        "" if g.certified else f": {g.reason}"))


@register_metric("l2_steady_bound_deg", unit="deg", evidence="certificate", applies=_at_rest,
                 doc="the steady-state attitude error bound 2 asin(gamma sum_nu |U_nu|) that the "
                 "certified gamma implies for the linearisation under the case's harmonic "
                 "disturbance; unknown unless gamma is certified")
def _steady_bound(ctx: MetricContext) -> MetricValue:
    g = l2_certificate(ctx)
    dist = ctx.initial().disturbance
    if not g.certified or dist is None:
        return ctx.value(None, "no certified gamma" if dist is not None else "no disturbance")
    return ctx.value(steady_bound_deg(float(g.gamma), dist.harmonic),
                     f"gamma {format_number(float(g.gamma))}, disturbance {dist.kind}")


@register_metric("torque_bound", unit="N m", evidence="certificate", applies=_at_rest,
                 doc="the design's global torque bound at the scenario's gains (its "
                 "torque_bound hook, every state)")
def _torque_bound(ctx: MetricContext) -> MetricValue:
    from formsync_design.analysis.l2design import budget_bound

    b = budget_bound(ctx.case.design, linearisation(ctx), ctx.case.gains.as_dict())
    return ctx.value(float(b), f"exact: {b}")


@register_metric("l2_gain_design", unit="1/(N m)", evidence="certificate", applies=_at_rest,
                 args=(MetricArg("budget", "number", None, quantity="torque", minimum=0),
                       MetricArg("grid", "int", 5, minimum=2)),
                 doc="the certified gamma of the gains designed within the torque budget "
                 "(analysis/l2design.design_l2_gains); the gains and their bound in the detail")
def _gain_design(ctx: MetricContext) -> MetricValue:
    from formsync_design.analysis.l2design import design_l2_gains

    lin = linearisation(ctx)
    key = ("l2-design", ctx.formation, ctx.scenario, ctx.args["budget"], ctx.args["grid"])
    des = ctx.memo(key, lambda: design_l2_gains(ctx.case.design, lin, ctx.args["budget"],
                                                grid=int(ctx.args["grid"])))
    g = des.certificate
    gains = ", ".join(f"{k} = {float(v):.4g}" for k, v in des.gains.items())
    detail = (f"{gains}; torque bound {float(des.torque_bound):.4g} N m; {des.evaluations} "
              f"evaluations; {g.status}")
    return ctx.value(float(g.gamma) if g.certified else None, detail)


def measured_gains(ctx: MetricContext, signals: int, rms: float, tf: float, seed: int
                   ) -> list[tuple[str, float]]:
    """``(signal, measured gain)`` from the commanded attitude at rest (module docstring)."""
    from dataclasses import replace

    from formsync_design.sim.agents import AgentOptions, simulate_agents
    from formsync_design.sim.l2measure import (
        SIGNALS,
        harmonic_samples,
        measured_l2_gain,
        random_disturbance,
    )

    c, d = ctx.case, ctx.case.design
    gamma = l2_certificate(ctx)
    opt = c.options
    h, n = opt.step, c.n
    lopt = AgentOptions(tf=tf, output_step=opt.output_step, step=h)
    steps = int(round(tf / h))
    f0 = ctx.initial()
    rest = replace(f0, attitudes=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), rates=np.zeros((n, 3)),
                   states={}, disturbance=None)

    def gain(u: np.ndarray) -> float:
        return measured_l2_gain(simulate_agents(d, rest, lopt, torque_input=u), u, h)

    rng = np.random.default_rng(seed)
    pf = gamma.peak_frequency
    w_max = 4 * max(pf, 0.05) if math.isfinite(pf) else 1.0
    out = [(kind, gain(random_disturbance(rng, kind, steps, n, h, rms=rms, w_max=w_max)))
           for _ in range(signals) for kind in SIGNALS]
    if f0.disturbance is not None:
        out.append(("case disturbance", gain(harmonic_samples(f0.disturbance, steps, h))))
    A, B, C = linearisation(ctx).standard({k: float(v) for k, v in c.gains.as_dict().items()})
    w = pf if math.isfinite(pf) else 0.0
    M = C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B)
    vdir = np.linalg.svd(M)[2][0].conj()
    u = np.real(np.exp(1j * w * np.arange(steps) * h)[:, None] * vdir[None, :]).reshape(steps, n, 3)
    u *= rms / float(np.sqrt(np.mean(u**2)))
    out.append(("worst-case sine", gain(u)))
    return out


@register_metric("measured_l2_gain_max", unit="1/(N m)", evidence="simulation",
                 applies=_at_rest,
                 args=(MetricArg("signals", "int", 3, minimum=1),
                       MetricArg("rms", "number", 1e-3, quantity="torque", minimum=0),
                       MetricArg("tf", "number", 300.0, quantity="horizon", minimum=0),
                       MetricArg("seed", "int", 0, minimum=0)),
                 doc="the largest measured L2 gain from the commanded attitude at rest under "
                 "random disturbances (white, multisine, steps), the case's disturbance and the "
                 "linearisation's worst-case sinusoid; each family's range in the detail")
def _measured(ctx: MetricContext) -> MetricValue:
    a = ctx.args
    key = ("l2-measured", ctx.formation, ctx.scenario, a["signals"], a["rms"], a["tf"], a["seed"])
    gains = ctx.memo(key, lambda: measured_gains(ctx, int(a["signals"]), float(a["rms"]),
                                                 float(a["tf"]), int(a["seed"])))
    fam: dict[str, list[float]] = {}
    for k, v in gains:
        fam.setdefault(k, []).append(v)
    best = max(gains, key=lambda x: x[1])
    parts = "; ".join(f"{k} ({len(v)}): {min(v):.4g} to {max(v):.4g}"
                      for k, v in sorted(fam.items()))
    return ctx.value(best[1], f"{len(gains)} signals of RMS {a['rms']:g} N m per axis over "
                     f"{a['tf']:g} s (seed {a['seed']}), largest: {best[0]}; {parts}")


def parse_box(text: str, gains: list[str], where: str) -> dict[str, tuple[str, str]]:
    """``"k_p = 1:2, k_d = 4"`` -> ``{gain: (lo, hi)}`` over every one of ``gains``.

    >>> parse_box("k_p = 1.5:2, k_d = 4", ["k_p", "k_d"], "box")
    {'k_p': ('1.5', '2'), 'k_d': ('4', '4')}
    """
    from formsync_design.errors import InputError
    from formsync_design.gains import parse_gain_range

    out: dict[str, tuple[str, str]] = {}
    for part in str(text).split(","):
        name, sep, rng = part.partition("=")
        name, rng = name.strip(), rng.strip()
        if not sep or name not in gains or name in out:
            raise InputError(f"expected {where} as 'gain = lo:hi, ...' over {gains}, received "
                             f"{text!r:.80}")
        parse_gain_range(rng, f"{where}.{name}")
        lo, _, hi = rng.partition(":")
        out[name] = (lo.strip(), (hi or lo).strip())
    if set(out) != set(gains):
        raise InputError(f"expected {where} over every gain {gains}, received {sorted(out)}")
    return out


@register_metric("l2_box_certificate", unit="verdict", evidence="certificate", value="text",
                 applies=_at_rest,
                 args=(MetricArg("box", "text", doc="'gain = lo:hi, ...' over every gain"),
                       MetricArg("gamma", "number", None, minimum=0),
                       MetricArg("pieces", "int", 1, minimum=1)),
                 doc="gamma on a whole gain box (one quadratic storage over the vertices by "
                 "the SDP, up to pieces sub-boxes per axis, exact re-check): certified, or "
                 "refuted with an exact frequency witness; undecided is no value")
def _box_certificate(ctx: MetricContext) -> MetricValue:
    from formsync_design.analysis.l2gain import certify_l2_box

    a = ctx.args
    box = parse_box(str(a["box"]), list(ctx.case.design.decl.controller_gains), "box")
    key = ("l2-box", ctx.formation, ctx.scenario, a["box"], a["gamma"], a["pieces"])
    r = ctx.memo(key, lambda: certify_l2_box(linearisation(ctx), box, a["gamma"],
                                             max_pieces=int(a["pieces"])))
    st = str(r.status)
    detail = f"gamma = {a['gamma']:g} on {a['box']}: {st}"
    w = r.witness
    if w is not None:
        pt = ", ".join(f"{k} = {float(v):.6g}" for k, v in w.point.items())
        detail += (f"; exact witness at {pt}, frequency {float(w.omega):.6g} rad/s, |z|^2/|u|^2 "
                   f"= {float(w.z_norm2 / w.u_norm2):.8g} > gamma^2 (gain {w.gain:.4g})")
    elif r.reason:
        detail += f"; {r.reason}"
    return ctx.value(st if st in ("certified", "refuted") else None, detail)
