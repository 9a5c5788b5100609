"""Metrics of a run on the relative-orbit plant: errors, fuel, pulses, allocation,
certificates.

Registered in :data:`~formsync_design.verify.metrics.METRICS` for the engine cases whose
design is on the relative-orbit plant (``PLANT = "relative-orbit"``: one spacecraft flying a
relative orbit about a target with thrusters, :mod:`formsync_design.verify.engine_tracking`); a metric here
names the measurement, never a paper.  The run of a scenario is
:func:`~formsync_design.sim.tracking.simulate_flyaround`'s; its measurements are
:func:`~formsync_design.verify.tracking_measures.run_metrics` (the rules are in that module:
steady state ``t >= steady_from``, per-axis maxima, the minimum-pulse share and the pointing
error after 100 s, the plane and radius of the last fly-around period).  A run that
diverged has no value (the claims that read it are undecided).

=============================  =====  ===========  ==========================================
metric                         unit   evidence     value
=============================  =====  ===========  ==========================================
steady_position_error          m      simulation   max per-axis relative-position error
steady_velocity_error          m/s    simulation   max per-axis relative-velocity error
steady_attitude_error          deg    simulation   max per-axis attitude error (rotation vector)
steady_attitude_error_axis     axis   simulation   the body axis of that maximum (text)
steady_rate_error              deg/s  simulation   max per-axis attitude-rate error
delta_v, delta_v_net, fuel     m/s    simulation   thruster impulse / mass (net: vector sum) ...
min_pulse_fraction, ...        1      simulation   share of the pulses after 100 s at the minimum
lp_fuel_recheck                1      numerical    the LP run's fuel against cvxpy + Clarabel
printed_phi_span, ...          rad    numerical    the printed transition law's span and gap
fuel_of_delta_v                kg     numerical    a delta-V's fuel (rocket or impulse rule)
orbit_lqr_margins, ...         -      numerical    the LQR's margins, residual, eigenvalues
attitude_box_certificate       -      certificate  the attitude law's box certificate
attitude_lyapunov_derivative   -      certificate  V' = -w^T K_d w derived exactly (SymPy)
=============================  =====  ===========  ==========================================

>>> from formsync_design.verify.metrics import METRICS
>>> {"steady_position_error", "lp_fuel_recheck", "attitude_box_certificate"} <= set(METRICS)
True
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from formsync_design.verify.metrics import (
    MetricArg,
    MetricContext,
    MetricValue,
    register_metric,
)

if TYPE_CHECKING:
    from formsync_design.sim.result import SimResult

__all__ = ["tracking_only", "measures", "certificates", "lp_recheck", "RUN_METRICS"]


def tracking_only(design: Any) -> str | None:
    """``None`` when ``design`` is on the relative-orbit plant, else why a fly-around metric
    does not apply."""
    plant = getattr(getattr(design, "decl", None), "plant", None)
    return None if plant == "relative-orbit" else (
        f"design {getattr(design, 'name', design)} is not on the relative-orbit plant")


def measures(ctx: MetricContext) -> dict[str, float]:
    """The measurements of the context's run (computed once per scenario)."""
    from formsync_design.verify.tracking_measures import run_metrics

    return ctx.memo(("tracking-measures", ctx.scenario),
                    lambda: run_metrics(ctx.run(), ctx.case.steady_from))


def certificates(results: Any, case: Any) -> tuple[Any, Any, Any]:
    """``(orbit, attitude, derivation)``: the LQR evidence, the attitude box certificate
    (:mod:`formsync_design.analysis.tracking`) and the attitude law's exact derivation
    (:mod:`formsync_design.derive.tracking`) of the base ``case``, computed once."""
    from formsync_design.analysis.tracking import attitude_certificate, orbit_certificate
    from formsync_design.derive.tracking import derive_tracking_attitude

    return results.memo(("tracking-certificates",), lambda: (
        orbit_certificate(case), attitude_certificate(case),
        derive_tracking_attitude(case.spec)))


#: ``(metric, measurement of run_metrics, unit, doc)`` of the per-run metrics.
RUN_METRICS = (
    ("steady_position_error", "position_error_m", "m",
     "steady-state (t >= steady_from) maximum per-axis relative-position tracking error"),
    ("steady_velocity_error", "velocity_error_m_s", "m/s",
     "steady-state maximum per-axis relative-velocity tracking error"),
    ("steady_attitude_error", "attitude_error_deg", "deg",
     "steady-state maximum per-axis attitude error (rotation-vector component of sigma_sd)"),
    ("steady_rate_error", "rate_error_deg_s", "deg/s",
     "steady-state maximum per-axis attitude-rate error (omega_sd)"),
    ("delta_v", "delta_v_m_s", "m/s", "total thruster impulse over the mass"),
    ("delta_v_net", "delta_v_net_m_s", "m/s",
     "the vector sum of the thruster impulses over the mass (opposed pulses cancel)"),
    ("fuel", "fuel_kg", "kg", "total thruster impulse over the exhaust velocity"),
    ("min_pulse_fraction", "min_pulse_fraction", "1",
     "share of the pulses fired at t >= 100 s that are minimum pulses"),
    ("pulses_fired", "pulses_after_100s", "count", "pulses fired at t >= 100 s"),
    ("pointing_error", "pointing_error_deg", "deg",
     "largest angle between the body x axis and the line of sight to the target after 100 s"),
    ("plane_tilt_error", "final_plane_error_deg", "deg",
     "tilt of the plane fitted (SVD) to the last fly-around period's positions minus alpha_rT"),
    ("radius_error", "final_radius_error_m", "m",
     "largest ||rho| - a| over the last fly-around period"),
    ("transition_overshoot", "transition_overshoot_deg", "deg",
     "largest rise of the elevation above the fly-around plane over its running minimum"),
    ("final_elevation", "final_elevation_deg", "deg",
     "elevation of the chaser above the fly-around plane at tf"),
    ("shadow_switches", "shadow_switches", "count", "switches of the MRP to its shadow set"),
    ("raw_min_thrust", "raw_min_thrust_n", "N",
     "most negative thrust the pseudo-inverse commands before the allocation removes it"),
    ("negative_thrust_fraction", "negative_samples_fraction", "1",
     "share of the samples in which the pseudo-inverse commands a negative thrust"),
    ("allocation_shortfall_max", "allocation_shortfall_max", "N, N m",
     "largest component of the commanded minus the allocated wrench over the run"),
    ("allocation_shortfall_late", "allocation_shortfall_after_100s", "N, N m",
     "... after 100 s"),
    ("saturated_samples", "saturated_samples", "count",
     "samples in which a thruster is on for the whole sample"),
    ("fallback_frames", "fallback_frames", "count",
     "samples in which the desired frame used its fallback (straight-line or no motion)"),
)


def _run_metric(name: str, key: str, unit: str, doc: str) -> None:
    def fn(ctx: MetricContext) -> MetricValue:
        from formsync_design.verify.tracking_measures import diverged_time

        v = measures(ctx)[key]
        if not math.isfinite(v):
            r = ctx.run()
            t = diverged_time(r)
            return ctx.value(None, f"the run diverged at t = {t:g} s" if t is not None
                             else "not measured (an empty window)")
        return ctx.value(v)

    fn.__qualname__ = f"tracking_{name}"
    register_metric(name, unit=unit, evidence="simulation", doc=doc, applies=tracking_only)(fn)


for _row in RUN_METRICS:
    _run_metric(*_row)


@register_metric("steady_attitude_error_axis", unit="axis", evidence="simulation", value="text",
                 applies=tracking_only,
                 doc="the body axis (x, y, z) of the steady-state maximum attitude error")
def _axis(ctx: MetricContext) -> MetricValue:
    v = measures(ctx)["attitude_error_axis"]
    return ctx.value("xyz"[int(v)] if math.isfinite(v) else None,
                     "x is the sensor axis" if math.isfinite(v) else "not measured")


@register_metric("lp_fallback_samples", unit="count", evidence="simulation",
                 applies=tracking_only,
                 doc="samples of an lp allocation solved by the bounded LP (cvxpy + Clarabel) "
                 "because a thrust bound binds")
def _lp_fallbacks(ctx: MetricContext) -> MetricValue:
    if ctx.case.options.allocation != "lp":
        return ctx.value(None, f"allocation {ctx.case.options.allocation} (not lp)")
    from formsync_design.sim.orbit_record import orbit_of

    return ctx.value(float(orbit_of(ctx.run()).lp_fallbacks))


def lp_recheck(run: SimResult, samples: int) -> float:
    """Largest relative difference between the fuel of ``samples`` evenly spaced samples of
    an ``lp`` run and the bounded LP re-solved by cvxpy + Clarabel."""
    from formsync_design.models.allocation import BoundedLP
    from formsync_design.sim.orbit_record import orbit_of

    rec = orbit_of(run)
    lay = rec.scenario.layout
    lp = BoundedLP(lay)
    diff = 0.0
    for k in np.linspace(0, run.t.size - 1, samples).astype(int):
        ref = lp.solve(rec.outputs["wrench_cmd"][k])
        ours = float(rec.outputs["thrust_cmd"][k, :lay.count].sum())
        diff = max(diff, abs(ours - ref.fuel_thrust) / max(1.0, ref.fuel_thrust))
    return diff


@register_metric("lp_fuel_recheck", unit="1", evidence="numerical", applies=tracking_only,
                 args=(MetricArg("samples", "int", 60, quantity="number", minimum=1,
                                 doc="samples re-solved"),),
                 doc="largest relative fuel difference between samples of an lp run and the "
                 "bounded LP re-solved by cvxpy + Clarabel (floating point: evidence)")
def _lp_recheck(ctx: MetricContext) -> MetricValue:
    from formsync_design.verify.tracking_measures import diverged_time

    if ctx.case.options.allocation != "lp":
        return ctx.value(None, f"allocation {ctx.case.options.allocation} (not lp)")
    r = ctx.run()
    if diverged_time(r) is not None:
        return ctx.value(None, "the run diverged")
    n = int(ctx.args["samples"])
    return ctx.value(lp_recheck(r, n), f"{n} samples")


def _phi(ctx: MetricContext) -> Any:
    from formsync_design.models.relative_reference import printed_phi_finding

    return printed_phi_finding(ctx.case.scenario.reference, ctx.case.options.tf)


@register_metric("printed_phi_span", unit="rad", evidence="numerical", applies=tracking_only,
                 doc="span over the run of the printed transition law phi_r = (phi_r0 - "
                 "phi_rinf) exp(-1/P1) + phi_rinf (0: a constant)")
def _phi_span(ctx: MetricContext) -> MetricValue:
    return ctx.value(float(_phi(ctx).printed_span), "on 1001 times of [0, tf]")


@register_metric("printed_phi_gap", unit="deg", evidence="numerical", applies=tracking_only,
                 doc="how far short of the fly-around plane the printed law leaves phi_r at tf")
def _phi_gap(ctx: MetricContext) -> MetricValue:
    return ctx.value(math.degrees(float(_phi(ctx).printed_final_gap)), "at tf")


@register_metric("fuel_of_delta_v", unit="kg", evidence="numerical", applies=tracking_only,
                 args=(MetricArg("delta_v", "number", quantity="number", minimum=0.0,
                                 doc="the velocity change (m/s)"),
                       MetricArg("rule", "text", "impulse", choices=("impulse", "rocket"),
                                 doc="impulse: m dv / v_e; rocket: m (1 - exp(-dv / v_e))")),
                 doc="the fuel of a delta-V at the case's mass and exhaust velocity")
def _fuel_of(ctx: MetricContext) -> MetricValue:
    from formsync_design.models.pwm import rocket_fuel

    dv, m, ve = float(ctx.args["delta_v"]), ctx.case.scenario.mass, ctx.case.options.exhaust_velocity
    if ctx.args["rule"] == "rocket":
        return ctx.value(rocket_fuel(dv, m, ve), f"m0 (1 - exp(-dv / v_e)), m0 = {m:g} kg")
    return ctx.value(dv * m / ve, f"m dv / v_e, v_e = {ve:g} m/s")


@register_metric("orbit_lqr_margins", unit="verdict", evidence="numerical", value="text",
                 applies=tracking_only,
                 doc="the guaranteed margins of an LQR with diagonal R (gain in [1/2, inf), "
                 "phase +-60 deg per channel) checked on a frequency grid and at the vertices")
def _margins(ctx: MetricContext) -> MetricValue:
    oc = certificates(ctx.results, ctx.case)[0]
    mg = oc.margins
    return ctx.value(str(mg.status), f"return difference >= {mg.min_return_difference:.4g}")


@register_metric("orbit_riccati_residual", unit="1", evidence="numerical", applies=tracking_only,
                 doc="relative residual of the LQR's Riccati solution")
def _riccati(ctx: MetricContext) -> MetricValue:
    return ctx.value(float(certificates(ctx.results, ctx.case)[0].riccati_residual))


@register_metric("orbit_largest_real_part", unit="1/s", evidence="numerical",
                 applies=tracking_only,
                 doc="largest real part of the continuous CW closed loop's eigenvalues")
def _orbit_re(ctx: MetricContext) -> MetricValue:
    return ctx.value(float(certificates(ctx.results, ctx.case)[0].max_real_part))


@register_metric("orbit_sampled_spectral_radius", unit="1", evidence="numerical",
                 applies=tracking_only,
                 doc="spectral radius of the CW loop sampled with a zero-order hold (no PWM)")
def _orbit_rho(ctx: MetricContext) -> MetricValue:
    return ctx.value(float(certificates(ctx.results, ctx.case)[0].sampled_spectral_radius))


@register_metric("attitude_box_certificate", unit="verdict", evidence="certificate",
                 value="text", applies=tracking_only,
                 doc="the attitude law's Lyapunov certificate over the [certificate] box of "
                 "gains, plant inertia and reference rates (linearized, exact re-check at the "
                 "vertices): certified, else no value")
def _box(ctx: MetricContext) -> MetricValue:
    ac = certificates(ctx.results, ctx.case)[1]
    if str(ac.status) != "certified":
        return ctx.value(None, f"{ac.status}: {ac.reason}")
    return ctx.value("certified", f"{ac.vertices} vertices; local, continuous loop without "
                     "the sampling and the PWM")


@register_metric("attitude_certified_rate", unit="1/s", evidence="certificate",
                 applies=tracking_only,
                 doc="the box certificate's exponential rate alpha (V decreases at 2 alpha)")
def _alpha(ctx: MetricContext) -> MetricValue:
    ac = certificates(ctx.results, ctx.case)[1]
    if str(ac.status) != "certified":
        return ctx.value(None, f"{ac.status}: {ac.reason}")
    return ctx.value(float(ac.alpha), "certified lower bound", bound="lower")


@register_metric("attitude_lyapunov_derivative", unit="verdict", evidence="certificate",
                 value="text", applies=tracking_only,
                 doc="whether V' = -w^T K_d w along the closed loop with the law's inertia "
                 "equal to the plant's, derived exactly (SymPy): holds or fails")
def _vdot(ctx: MetricContext) -> MetricValue:
    der = certificates(ctx.results, ctx.case)[2]
    return ctx.value("holds" if der.nominal_holds else "fails", f"V' = {der.vdot}")


@register_metric("attitude_mismatch_derivative", unit="verdict", evidence="certificate",
                 value="text", applies=tracking_only,
                 doc="whether with a mismatched inertia V' gains w^T[w_s x dJ w_s + dJ (a_d - "
                 "w x w_d)], dJ = J_law - J (derived exactly): matches or differs")
def _mismatch(ctx: MetricContext) -> MetricValue:
    der = certificates(ctx.results, ctx.case)[2]
    return ctx.value("matches" if der.mismatch_matches else "differs")

