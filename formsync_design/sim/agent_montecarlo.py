"""Seeded Monte-Carlo campaigns of agent designs (``formsync montecarlo --design AGENT``).

Each run draws, from its own seed (printed for every failing run, so ``--replay SEED``
re-simulates it in full): the controller gains uniformly from the box (each diagonal entry
of a diagonal gain independently), every spacecraft's initial attitude (random axis, angle
uniform in ``[0, max_angle_deg]`` from the identity) and rate (components uniform in
``[-max_rate, max_rate]``).  The graph, inertias, disturbance, reference and initial
controller states are the base formation's.  When the design has a certificate
(``conditions(c)``) and the graph is inside its theorem, the sampled box is certified too.

Runs share one compiled kernel (the graph structure does not change).  With the ``rk4``
integrator and a continuous law, :data:`BATCH` draws at a time advance together: one call of
the compiled kernel mapped over the runs per chunk of output intervals, on the machine's
cores (:func:`~formsync_design.sim.agents.simulate_agents_batch`; every run equals its single
run bitwise); otherwise they are simulated one after another.  A run whose state goes
non-finite is one failed run with the status ``diverged`` and its time (its seed replays
it); the campaign goes on.  Ctrl-C is seen between kernel calls (each at most a few seconds).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import GainBox
from formsync_design.sim.agents import (
    AGENT_STATUSES,
    AgentFormation,
    AgentOptions,
    simulate_agents_batch,
)
from formsync_design.sim.formation import Gains
from formsync_design.sim.montecarlo_data import (
    MonteCarloResult,
    MonteCarloRun,
    MonteCarloSettings,
    RunStatus,
)

__all__ = ["BATCH", "agent_run_formation", "run_agent_montecarlo", "monte_carlo_agents"]


def agent_run_formation(design: Any, base: AgentFormation, box: GainBox,
                        settings: MonteCarloSettings, seed: int) -> AgentFormation:
    """The formation of the run with ``seed`` (its gains, attitudes and rates drawn; a
    setting not given: the agent path's default, :meth:`MonteCarloSettings.resolved_for`)."""
    _, max_angle_deg, max_rate = settings.resolved_for("agent").numbers()
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
    ang = np.radians(max_angle_deg) * rng.random(n)
    att = np.column_stack([np.sin(ang / 2)[:, None] * axis, np.cos(ang / 2)])
    rates = rng.uniform(-max_rate, max_rate, size=(n, 3))
    return replace(base, attitudes=att, rates=rates, gains=Gains(vals))


#: Draws advanced together by :func:`~formsync_design.sim.agents.simulate_agents_batch` (their
#: trajectories are held until each run's record is taken: about 1.6 MB per run of the shipped
#: ma_so3 case).
BATCH = 64


def _record(seed: int, f: AgentFormation, r: Any) -> MonteCarloRun:
    """The record of one run (a :class:`~formsync_design.sim.result.SimResult`)."""
    return MonteCarloRun(
        seed=seed, gains=tuple(f.gains.as_dict().items()), status=RunStatus(str(r.status)),
        convergence_time=r.convergence_time,
        final_attitude_error=float(r.attitude_error[-1]),
        final_rate_error=float(r.rate_error[-1]), peak_torque=float(r.peak_torque.max()),
        effort=float(np.sum(r.effort)),
        transmissions=None if r.transmissions is None else int(np.sum(r.transmissions)),
        min_interevent=None if r.min_interevent is None
        else float(np.nanmin(r.min_interevent)),
        diverged_time=r.diverged_time)


def run_agent_montecarlo(design: Any, base: AgentFormation, box: GainBox,
                         settings: MonteCarloSettings, options: AgentOptions, *,
                         certify: bool = True,
                         progress: Callable[[int], None] | None = None) -> MonteCarloResult:
    """Run the campaign (module docstring): the worker of ``fs.monte_carlo`` for an agent
    design (:func:`monte_carlo_agents`); a setting not given is the agent path's default
    (:meth:`~formsync_design.sim.montecarlo_data.MonteCarloSettings.resolved_for`).

    Examples
    --------
    >>> from formsync_design.graphs import load_graph
    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
    >>> f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
    ...                    np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3)), Gains(k=1.0))
    >>> box = GainBox.parse({"k": "0.5:1"})
    >>> res = run_agent_montecarlo(d, f, box, MonteCarloSettings(runs=3, max_angle_deg=0,
    ...                            max_rate=0.001), AgentOptions(tf=2, output_step=0.5, step=0.05,
    ...                            rate_tol=1.0))
    >>> len(res.runs), res.all_converged, res.certificate, res.settings.max_rate
    (3, True, None, 0.001)
    """
    settings = settings.resolved_for("agent")
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
    t0 = time.perf_counter()
    seeds = settings.run_seeds()
    for at in range(0, len(seeds), BATCH):  # draws advanced together in the compiled kernel
        part = seeds[at: at + BATCH]
        drawn = [agent_run_formation(design, base, box, settings, seed) for seed in part]
        for seed, f, r in zip(part, drawn, simulate_agents_batch(design, drawn, options),
                              strict=True):
            runs.append(_record(seed, f, r))
            if progress is not None:  # the runs finished since the last call, as the batch path
                progress(1)
    wall = time.perf_counter() - t0

    ct = np.array([r.convergence_time for r in runs if r.convergence_time is not None])
    ct_stats = (
        {"min": float(ct.min()), "median": float(np.median(ct)),
         "p95": float(np.percentile(ct, 95)), "max": float(ct.max())}
        if ct.size else {"min": None, "median": None, "p95": None, "max": None}
    )
    return MonteCarloResult(
        runs=tuple(runs), box=box, settings=settings, options=options,
        counts={str(s): sum(r.status == s for r in runs) for s in AGENT_STATUSES},
        convergence_time_stats=ct_stats, wall_seconds=wall, design=design.name,
        graph=base.graph.name, certificate=cert, certificate_reason=reason)


def monte_carlo_agents(design: Any, base: Any, box: Any = None,
                       settings: MonteCarloSettings | None = None, options: Any = None, *,
                       certify: bool = True, progress: Any = None) -> MonteCarloResult:
    """:func:`run_agent_montecarlo` from the generic arguments of ``fs.monte_carlo``:
    ``box`` default the point of ``base.gains``; ``settings`` a
    :class:`~formsync_design.sim.montecarlo_data.MonteCarloSettings` (default: the agent
    path's defaults, as is every value it leaves unset); ``options`` an
    :class:`~formsync_design.sim.agents.AgentOptions`."""
    if box is None:
        vals = {}
        for n, v in base.gains.as_dict().items():
            lo, hi = (min(v), max(v)) if isinstance(v, tuple) else (v, v)
            vals[n] = f"{lo!r}:{hi!r}" if lo != hi else repr(lo)
        box = GainBox.parse(vals)
    elif not isinstance(box, GainBox):
        box = GainBox.parse(box)
    if settings is None:
        settings = MonteCarloSettings()
    elif not isinstance(settings, MonteCarloSettings):
        raise InputError(f"expected MonteCarloSettings for the agent design {design.name}, "
                         f"received {type(settings).__name__}")
    else:  # the spreads given as floats (as the summary has always written them)
        a, m = settings.max_angle_deg, settings.max_rate
        settings = replace(settings, max_angle_deg=None if a is None else float(a),
                           max_rate=None if m is None else float(m))
    if options is None:
        options = AgentOptions()
    elif not isinstance(options, AgentOptions):
        raise InputError(f"expected AgentOptions for the agent design {design.name}, received "
                         f"{type(options).__name__}")
    return run_agent_montecarlo(design, base, box, settings, options, certify=certify,
                                progress=progress)
