"""Seeded Monte-Carlo campaigns of agent designs (``formsync montecarlo --design AGENT``).

Each run draws, from its own seed (printed for every failing run, so ``--replay SEED``
re-simulates it in full): the controller gains uniformly from the box (each diagonal entry
of a diagonal gain independently), every spacecraft's initial attitude (random axis, angle
uniform in ``[0, max_angle_deg]`` from the identity) and rate (components uniform in
``[-max_rate, max_rate]``).  The graph, inertias, disturbance, reference and initial
controller states are the base formation's.  When the design has a certificate
(``conditions(c)``) and the graph is inside its theorem, the sampled box is certified too.

Runs share one compiled kernel (the graph structure does not change); they are simulated one
after another in this process.  A run whose state goes non-finite is one failed run with the
status ``diverged`` and its time (its seed replays it); the campaign goes on.  Ctrl-C is
seen between runs (each run is one call of at most a few seconds).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import GainBox, json_number
from formsync_design.notebook import NotebookViews
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Gains

__all__ = ["AgentMonteCarloSettings", "AgentRun", "AgentMonteCarloResult", "agent_run_formation",
           "run_agent_montecarlo", "monte_carlo_agents", "MAX_AGENT_RUNS"]

#: Most runs per campaign.
MAX_AGENT_RUNS = 100_000


@dataclass(frozen=True)
class AgentMonteCarloSettings:
    """``runs``, master ``seed``, ``max_angle_deg`` (initial attitudes), ``max_rate`` (rad/s).

    >>> AgentMonteCarloSettings(runs=10).run_seeds()[:1] == AgentMonteCarloSettings(runs=3).run_seeds()[:1]
    True
    """

    runs: int = 100
    seed: int = 0
    max_angle_deg: float = 90.0
    max_rate: float = 0.01

    def __post_init__(self) -> None:
        if not 1 <= self.runs <= MAX_AGENT_RUNS:
            raise InputError(f"expected 1..{MAX_AGENT_RUNS} runs, received {self.runs}")
        if not 0 <= self.max_angle_deg <= 180:  # a rotation angle: beyond 180 deg is a smaller one
            raise InputError(f"expected max_angle_deg in [0, 180], received {self.max_angle_deg:g}")
        if not (math.isfinite(self.max_rate) and self.max_rate >= 0):
            raise InputError(f"expected max_rate >= 0, received {self.max_rate:g}")

    def run_seeds(self) -> list[int]:
        """The per-run seeds (the first ``k`` do not depend on ``runs``)."""
        ss = np.random.SeedSequence(self.seed)
        return [int(c.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))
                for c in ss.spawn(self.runs)]


def agent_run_formation(design: Any, base: AgentFormation, box: GainBox,
                        settings: AgentMonteCarloSettings, seed: int) -> AgentFormation:
    """The formation of the run with ``seed`` (its gains, attitudes and rates drawn)."""
    rng = np.random.default_rng(seed)
    vals: dict[str, Any] = {}
    for g in design.decl.gains:
        if str(g.role) != "controller":
            continue
        r = box[g.name]
        lo, hi = float(r.lo), float(r.hi)
        if str(g.kind) == "diag":
            vals[g.name] = tuple(float(x) for x in rng.uniform(lo, hi, 3)) if hi > lo \
                else (lo, lo, lo)
        else:
            vals[g.name] = float(rng.uniform(lo, hi)) if hi > lo else lo
    n = base.n
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    ang = np.radians(settings.max_angle_deg) * rng.random(n)
    att = np.column_stack([np.sin(ang / 2)[:, None] * axis, np.cos(ang / 2)])
    rates = rng.uniform(-settings.max_rate, settings.max_rate, size=(n, 3))
    return replace(base, attitudes=att, rates=rates, gains=Gains(vals))


@dataclass(frozen=True)
class AgentRun:
    """One run's metrics (``status`` of :data:`~formsync_design.sim.agents.AGENT_STATUSES`)."""

    seed: int
    gains: dict[str, Any]
    status: str
    convergence_time: float | None
    final_attitude_error: float
    final_rate_error: float
    peak_torque: float
    effort: float
    transmissions: int | None
    min_interevent: float | None
    diverged_time: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            **{f"gain_{k}": (json_number(v) if not isinstance(v, tuple)
                             else "[" + ", ".join(f"{x:.9g}" for x in v) + "]")
               for k, v in self.gains.items()},
            "status": self.status,
            "diverged_time": None if self.diverged_time is None else json_number(self.diverged_time),
            "convergence_time": None if self.convergence_time is None
            else json_number(self.convergence_time),
            "final_attitude_error_deg": json_number(self.final_attitude_error),
            "final_rate_error": json_number(self.final_rate_error),
            "peak_torque": json_number(self.peak_torque), "effort": json_number(self.effort),
            "transmissions": self.transmissions,
            "min_interevent": None if self.min_interevent is None
            else json_number(self.min_interevent),
        }


@dataclass(frozen=True)
class AgentMonteCarloResult(NotebookViews):
    """A campaign: its runs, the settings, the box and the box's certificate status
    (``None`` when not certified here)."""

    design: str
    graph: str
    box: GainBox
    settings: AgentMonteCarloSettings
    runs: tuple[AgentRun, ...]
    certificate: str | None
    certificate_reason: str = ""


    @property
    def failures(self) -> tuple[AgentRun, ...]:
        return tuple(r for r in self.runs if r.status != "converged")

    @property
    def all_converged(self) -> bool:
        return not self.failures

    def to_dict(self) -> dict[str, Any]:
        times = [r.convergence_time for r in self.runs if r.convergence_time is not None]
        return {
            "design": self.design, "graph": self.graph, "box": str(self.box),
            "runs": len(self.runs), "seed": self.settings.seed,
            "max_angle_deg": json_number(self.settings.max_angle_deg),
            "max_rate": json_number(self.settings.max_rate),
            "converged": len(self.runs) - len(self.failures),
            "diverged": sum(r.status == "diverged" for r in self.runs),
            "failed_seeds": [r.seed for r in self.failures],
            "convergence_time_max": json_number(max(times)) if times else None,
            "convergence_time_median": json_number(float(np.median(times))) if times else None,
            "peak_torque_max": json_number(max(r.peak_torque for r in self.runs)),
            "certificate": self.certificate, "certificate_reason": self.certificate_reason,
        }


def run_agent_montecarlo(design: Any, base: AgentFormation, box: GainBox,
                         settings: AgentMonteCarloSettings, options: AgentOptions, *,
                         certify: bool = True,
                         progress: Callable[[int], None] | None = None) -> AgentMonteCarloResult:
    """Run the campaign (module docstring).

    Examples
    --------
    >>> from formsync_design.graphs import load_graph
    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    >>> f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
    ...                    np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3)), Gains(k=1.0))
    >>> box = GainBox.parse({"k": "0.5:1"})
    >>> res = run_agent_montecarlo(d, f, box, AgentMonteCarloSettings(runs=3, max_angle_deg=0,
    ...                            max_rate=0.001), AgentOptions(tf=2, output_step=0.5, step=0.05,
    ...                            rate_tol=1.0))
    >>> len(res.runs), res.all_converged, res.certificate
    (3, True, None)
    """
    cert, reason = None, ""
    if certify and callable(design.module.get("conditions")):
        from formsync_design.certify.engine import certify_box
        from formsync_design.certify.multipliers import certify_with_multipliers
        from formsync_design.derive.agent import agent_conditions

        conds = agent_conditions(design, base.graph)
        mult = {n: design.decl.gain(n).range for n in design.decl.multipliers}
        res = (certify_with_multipliers(conds, box, mult) if mult
               else certify_box(conds, box))
        cert, reason = str(res.status), res.reason
    runs = []
    for k, seed in enumerate(settings.run_seeds()):
        f = agent_run_formation(design, base, box, settings, seed)
        r = simulate_agents(design, f, options)
        runs.append(AgentRun(
            seed=seed, gains=f.gains.as_dict(), status=str(r.status),
            convergence_time=r.convergence_time,
            final_attitude_error=float(r.attitude_error[-1]),
            final_rate_error=float(r.rate_error[-1]), peak_torque=float(r.peak_torque.max()),
            effort=float(np.sum(r.effort)),
            transmissions=None if r.transmissions is None else int(np.sum(r.transmissions)),
            min_interevent=None if r.min_interevent is None
            else float(np.nanmin(r.min_interevent)),
            diverged_time=r.diverged_time))
        if progress is not None:
            progress(k + 1)
    return AgentMonteCarloResult(design=design.name, graph=base.graph.name, box=box,
                                 settings=settings, runs=tuple(runs), certificate=cert,
                                 certificate_reason=reason)


def monte_carlo_agents(design: Any, base: Any, box: Any = None, settings: Any = None,
                       options: Any = None, *, certify: bool = True,
                       progress: Any = None) -> Any:
    """:func:`run_agent_montecarlo` from the generic
    arguments of ``fs.monte_carlo``: ``box`` default the point of ``base.gains``; ``settings``
    an :class:`AgentMonteCarloSettings` or a
    :class:`~formsync_design.sim.montecarlo_data.MonteCarloSettings` (runs, seed, angles, rates
    taken from it); ``options`` an :class:`~formsync_design.sim.agents.AgentOptions`."""
    if box is None:
        vals = {}
        for n, v in base.gains.as_dict().items():
            lo, hi = (min(v), max(v)) if isinstance(v, tuple) else (v, v)
            vals[n] = f"{lo!r}:{hi!r}" if lo != hi else repr(lo)
        box = GainBox.parse(vals)
    elif not isinstance(box, GainBox):
        box = GainBox.parse(box)
    if settings is None:
        settings = AgentMonteCarloSettings()
    elif not isinstance(settings, AgentMonteCarloSettings):
        settings = AgentMonteCarloSettings(runs=int(settings.runs), seed=int(settings.seed),
                                           max_angle_deg=float(settings.max_angle_deg),
                                           max_rate=float(settings.max_rate))
    if options is None:
        options = AgentOptions()
    elif not isinstance(options, AgentOptions):
        raise InputError(f"expected AgentOptions for the agent design {design.name}, received "
                         f"{type(options).__name__}")
    return run_agent_montecarlo(design, base, box, settings, options, certify=certify,
                                progress=progress)
