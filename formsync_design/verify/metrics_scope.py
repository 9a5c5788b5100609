"""Global or local? A metric from seeded runs started at large initial attitudes.

A certificate on the linearisation at the commanded attitude (an L2 gain, exponential
stability) is a **local** statement.  Whether the nonlinear formation converges from far away
is a separate question that a finite set of simulations can only give evidence on:
:func:`scope_study` starts the formation at rest from rotation angles chosen by the caller
(every spacecraft about its own seeded random axis, with either sign of the quaternion's
scalar part ``q0``, since a law written in ``vec(q)`` distinguishes ``q`` from ``-q``) and
records for each run whether it converged within the horizon and its final error.

The metric ``large_angle_scope`` (text, evidence simulation) is the verdict computed from
the runs: ``local`` when some run does not converge (a counterexample to global
convergence, replayable from its seed and angle), else ``no-counterexample`` (evidence,
never a proof of global convergence); the runs are in its detail.  Arguments: ``angles``
(degrees in [0, 180], comma-separated), ``signs`` (``both``, ``+``, ``-``), ``seed`` (run
``k`` draws its axes from ``seed + k``), ``tf`` (0: the scenario's horizon).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.verify.metrics import MetricArg, MetricContext, MetricValue, register_metric

__all__ = ["ScopeVerdict", "LargeAngleRun", "ScopeStudy", "large_angle_attitudes",
           "scope_study", "parse_angles"]


class ScopeVerdict(enum.StrEnum):
    """What the large-angle runs say about the region of convergence."""

    LOCAL = "local"
    NO_COUNTEREXAMPLE = "no-counterexample"


@dataclass(frozen=True)
class LargeAngleRun:
    """One run: its seed, the initial rotation angle of every spacecraft, the sign of
    ``q0(0)``, whether it converged (the case's tolerances) and the final errors (deg)."""

    seed: int
    angle_deg: float
    q0_sign: int
    converged: bool
    convergence_time: float | None
    final_error_deg: float
    final_disagreement_deg: float

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.gains import json_number

        return {"seed": self.seed, "angle_deg": json_number(self.angle_deg),
                "q0_sign": self.q0_sign, "converged": self.converged,
                "convergence_time": None if self.convergence_time is None
                else json_number(self.convergence_time),
                "final_error_deg": json_number(self.final_error_deg),
                "final_disagreement_deg": json_number(self.final_disagreement_deg)}


@dataclass(frozen=True)
class ScopeStudy:
    """The runs of :func:`scope_study` and the verdict computed from them."""

    runs: tuple[LargeAngleRun, ...]
    tf: float

    @property
    def failures(self) -> tuple[LargeAngleRun, ...]:
        return tuple(r for r in self.runs if not r.converged)

    @property
    def verdict(self) -> ScopeVerdict:
        return ScopeVerdict.LOCAL if self.failures else ScopeVerdict.NO_COUNTEREXAMPLE

    @property
    def summary(self) -> str:
        """The verdict in words, with the counts it rests on.

        >>> r = LargeAngleRun(1, 170.0, -1, False, None, 90.0, 5.0)
        >>> ScopeStudy((r, replace(r, converged=True)), 100.0).summary
        'local: 1 of 2 runs from >= 170 deg do not converge within 100 s'
        """
        n = len(self.runs)
        lo = min((r.angle_deg for r in self.runs), default=math.nan)
        hi = max((r.angle_deg for r in self.runs), default=math.nan)
        if self.failures:
            a = min(r.angle_deg for r in self.failures)
            k = sum(1 for r in self.runs if r.angle_deg >= a)
            return (f"local: {len(self.failures)} of {k} runs from >= {a:g} deg do not converge "
                    f"within {self.tf:g} s")
        return (f"no counterexample found in {n} runs from {lo:g} to {hi:g} deg, both signs of "
                f"q0 (evidence, not proof)")

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.gains import json_number

        return {"verdict": str(self.verdict), "summary": self.summary, "tf": json_number(self.tf),
                "runs": [r.to_dict() for r in self.runs]}


def large_angle_attitudes(n: int, angle_deg: float, q0_sign: int, seed: int) -> np.ndarray:
    """``(n, 4)`` unit quaternions ``(q1, q2, q3, q0)``: each a rotation by ``angle_deg``
    about a seeded uniformly random axis, with ``q0`` of sign ``q0_sign`` (``q0 = 0`` at
    180 deg for either sign).

    >>> q = large_angle_attitudes(3, 120.0, -1, 7)
    >>> bool(np.allclose(np.linalg.norm(q, axis=1), 1)), bool(np.allclose(q[:, 3], -0.5))
    (True, True)
    """
    if q0_sign not in (1, -1) or not 0 <= angle_deg <= 180:
        raise InputError(f"expected an angle in [0, 180] deg and q0 sign +-1, received "
                         f"{angle_deg!r}, {q0_sign!r}")
    rng = np.random.default_rng(seed)
    ax = rng.normal(size=(n, 3))
    ax /= np.linalg.norm(ax, axis=1)[:, None]
    h = math.radians(angle_deg) / 2
    return q0_sign * np.hstack([ax * math.sin(h), np.full((n, 1), math.cos(h))])


def scope_study(design: Any, formation: Any, options: Any, angles: list[float],
                signs: tuple[int, ...] = (1, -1), seed: int = 0,
                tf: float | None = None) -> ScopeStudy:
    """Simulate ``formation`` (its graph, inertias, gains, reference; at rest, controller
    states zero) from every ``angle x sign`` of :func:`large_angle_attitudes`, run ``k``
    seeded ``seed + k``; ``tf`` replaces the options' horizon when given."""
    from formsync_design.sim.agents import simulate_agents

    opt = options if tf is None else replace(options, tf=float(tf))
    runs = []
    k = 0
    for a in angles:
        for sg in signs:
            q = large_angle_attitudes(formation.n, float(a), int(sg), seed + k)
            f = replace(formation, attitudes=q, rates=np.zeros((formation.n, 3)), states={})
            r = simulate_agents(design, f, opt)
            err = r.reference_error if r.reference_error is not None else r.attitude_error
            runs.append(LargeAngleRun(seed=seed + k, angle_deg=float(a), q0_sign=int(sg),
                                      converged=r.convergence_time is not None,
                                      convergence_time=r.convergence_time,
                                      final_error_deg=float(err[-1]),
                                      final_disagreement_deg=float(r.attitude_error[-1])))
            k += 1
    return ScopeStudy(runs=tuple(runs), tf=float(opt.tf))


def parse_angles(text: str, where: str) -> list[float]:
    """Comma-separated degrees in [0, 180].

    >>> parse_angles("120, 179.9", "metrics[1].angles")
    [120.0, 179.9]
    """
    out = []
    for part in str(text).split(","):
        try:
            a = float(part)
        except ValueError:
            a = math.nan
        if not 0 <= a <= 180:
            raise InputError(f"expected {where} as comma-separated degrees in [0, 180], "
                             f"received {text!r:.60}")
        out.append(a)
    return out


_SIGNS = {"both": (1, -1), "+": (1,), "-": (-1,)}


@register_metric("large_angle_scope", unit="verdict", evidence="simulation", value="text",
                 args=(MetricArg("angles", "text", "120,150,170,179,179.9",
                                 doc="initial rotation angles, deg"),
                       MetricArg("signs", "text", "both", choices=tuple(_SIGNS)),
                       MetricArg("seed", "int", 0, minimum=0),
                       MetricArg("tf", "number", 0.0, quantity="horizon", minimum=0,
                                 doc="the runs' horizon (0: the scenario's)")),
                 doc="global or local: local when a run from rest at a large initial attitude "
                 "(each spacecraft about its own seeded axis, both signs of q0) does not "
                 "converge, else no-counterexample (evidence, not proof); the runs in the detail")
def _scope(ctx: MetricContext) -> MetricValue:
    a = ctx.args
    angles = parse_angles(a["angles"], "large_angle_scope.angles")
    tf = float(a["tf"]) or None
    key = ("scope", *ctx.key(), a["angles"], a["signs"], a["seed"], tf)
    st = ctx.memo(key, lambda: scope_study(ctx.case.design, ctx.initial(), ctx.options(), angles,
                                           _SIGNS[str(a["signs"])], seed=int(a["seed"]), tf=tf))
    runs = "; ".join(f"seed {r.seed} {r.angle_deg:g} deg q0 {'+' if r.q0_sign > 0 else '-'}: "
                     + (f"converged at {r.convergence_time:g} s" if r.converged
                        else f"not converged, final error {r.final_error_deg:.3g} deg")
                     for r in st.runs)
    return ctx.value(str(st.verdict), f"{st.summary}; {runs}")
