"""Monte-Carlo validation of gains on the full nonlinear formation.

Each run draws, from its own seed, a gain point in a box (uniform; the design's
controller gains in declaration order, then its switching gain ``K_v`` when it has
one - ``K_o, K_q, beta, K_v`` for the paper's design; a diagonal gain draws its three
entries independently; a multiplier of the Lyapunov candidate is never sampled),
initial attitudes (uniform random axis, rotation angle
uniform in ``[0, max_angle]``, so ``q0 = cos(angle/2) > 0``), initial body
rates (each component uniform in ``[-max_rate, max_rate]``) and - with
``phases=True`` - random phases of every oscillating disturbance factor and of
the orbit.  Inertias, graph and disturbance model come from the case.

All runs are integrated in batches by the compiled whole-horizon kernel
(:mod:`formsync_design.sim.native`, one call per batch, the runs spread over
threads) with the same integrator and events as :func:`simulate`; each run is
reduced in the kernel to its summary (convergence time on the output grid, final
``Omega_m`` and ``Q_m``, minimum ``q0`` over every step, peak ``|u|`` on the output
grid, quaternion norm drift, event time), so a batched run gives exactly the record
of a single simulation of its seed (tested).  Defaults (:data:`DEFAULT_OPTIONS`)
differ from ``simulate`` for speed: DOPRI5 at ``rtol = 1e-6``, ``atol = 1e-10`` on an
``output_step = 0.5`` s grid, ``norm_tol = 1e-5``.  Measured by
``benchmarks/bench_simulate.py`` on 20 runs of the paper's case against rtol 1e-11:
identical statuses and convergence times on the 0.5 s grid, final ``Q_m`` within
7e-5 and final ``Omega_m`` within 4e-5 (relative), about 5 ms of CPU per run.  Without
a C compiler the runs go one at a time through the driver's Python mirror.

A run that does not converge (``not-converged``, ``singular`` - some
``q0`` reached ``q0_floor`` -, ``diverged`` - NaN/inf -, or ``inaccurate`` -
norm drift above ``norm_tol``) is reported with its ``seed``;
:func:`replay` rebuilds exactly that run for a full :func:`simulate`.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError, SimulationError
from formsync_design.gains import GainBox, GainRange
from formsync_design.sim.adaptive import run_vm
from formsync_design.sim.formation import Formation, Gains, SimOptions
from formsync_design.sim.kernels import get_kernel, pack_params
from formsync_design.sim.metrics import convergence_time
from formsync_design.sim.montecarlo_data import (
    RUN_STATUSES,
    MonteCarloResult,
    MonteCarloRun,
    MonteCarloSettings,
    RunStatus,
)
from formsync_design.sim.native import get_native
from formsync_design.sim.native_c import SUMMARY
from formsync_design.sim.simulator import driver_config, simulate
from formsync_design.spec.declarations import GainKind
from formsync_design.spec.loader import Spec, load_spec

__all__ = [
    "DEFAULT_OPTIONS",
    "MC_GAINS",
    "BATCH_SECONDS",
    "mc_gain_names",
    "sample_formations",
    "mc_box",
    "point_box",
    "sample_formation",
    "replay",
    "run_montecarlo",
    "certify_sampled_box",
]

#: Wall seconds of one call of the compiled batch kernel (a Ctrl-C waits for the call).
BATCH_SECONDS = 0.25

#: The gains of a Monte-Carlo box, in order (``K_v`` may be 0, the others must be > 0).
MC_GAINS = ("K_o", "K_q", "beta", "K_v")

#: Options of a Monte-Carlo run when none are given: DOPRI5 at rtol 1e-6 / atol 1e-10 on a
#: 0.5 s output grid (module docstring: the accuracy this buys, measured).
DEFAULT_OPTIONS = SimOptions(output_step=0.5, rtol=1e-6, atol=1e-10, norm_tol=1e-5)


def _design(spec: Spec | str | Path | None) -> tuple[tuple[str, ...], str | None, frozenset[str]]:
    """Controller gains, switching gain (or None) and diagonal gains of ``spec``
    (``None``: the paper's design, without loading it)."""
    if spec is None:
        return MC_GAINS[:3], MC_GAINS[3], frozenset()
    sp = spec if isinstance(spec, Spec) else load_spec(spec)
    d = sp.decl
    diag = frozenset(n for n in d.controller_gains if d.gain(n).kind == GainKind.DIAG)
    return tuple(d.controller_gains), d.switching, diag


def mc_gain_names(spec: Spec | str | Path | None = None) -> tuple[str, ...]:
    """The dimensions of a Monte-Carlo box of ``spec`` (default: the paper's design): its
    controller gains in declaration order, then its switching gain when it has one.
    Multipliers of the Lyapunov candidate are not dimensions (they are not controller gains).

    >>> mc_gain_names(), mc_gain_names("pd_consensus")
    (('K_o', 'K_q', 'beta', 'K_v'), ('k_p', 'k_d'))
    """
    ctrl, sw, _ = _design(spec)
    return ctrl + ((sw,) if sw is not None else ())


def mc_box(box: Any, spec: Spec | str | Path | None = None) -> GainBox:
    """``box`` as the one gain-box type over :func:`mc_gain_names` of ``spec`` (default:
    the paper's ``K_o, K_q, beta, K_v``): controller gains ``> 0``, the switching gain ``>= 0``.

    Accepts a :class:`~formsync_design.gains.GainBox` or anything
    :meth:`GainBox.parse <formsync_design.gains.GainBox.parse>` accepts.

    >>> mc_box({"K_o": "1.5:1.7", "K_q": 0.4, "beta": 0.3, "K_v": 0}).as_floats()["K_o"]
    (1.5, 1.7)
    >>> str(mc_box({"k_p": "0.5:1", "k_d": 2}, "pd_consensus"))
    'k_p=0.5:1, k_d=2'
    """
    ctrl, _, _ = _design(spec)
    return GainBox.parse(box, mc_gain_names(spec), positive=ctrl)


def point_box(g: Gains, spec: Spec | str | Path | None = None) -> GainBox:
    """The point box of the gains ``g`` for ``spec`` (default: the paper's design);
    ``K_v`` (when the design has a switching gain) and a diagonal gain from their smallest to
    their largest entry.

    >>> point_box(Gains(1.6, 0.4, 0.3, (0.01, 0.02))).as_floats()["K_v"]
    (0.01, 0.02)
    >>> str(point_box(Gains(k_p=0.5, k_d=1.5), "pd_consensus"))
    'k_p=0.5, k_d=1.5'
    """
    ctrl, sw, _ = _design(spec)
    have = g.as_dict()
    missing = [n for n in ctrl if n not in have]
    if missing:
        raise InputError(f"expected the controller gains of the design ({', '.join(ctrl)}), "
                         f"received {', '.join(g.names)}")
    box: dict[str, Any] = {n: (min(have[n]), max(have[n])) if isinstance(have[n], tuple) else have[n]
                           for n in ctrl}
    if sw is not None:
        box[sw] = (min(g.K_v), max(g.K_v))
    return mc_box(box, spec)


def _run_seeds(settings: MonteCarloSettings) -> np.ndarray:
    """Per-run seeds (63-bit) derived from the master seed (stable across versions of numpy)."""
    ss = np.random.SeedSequence(settings.seed)
    return ss.generate_state(settings.resolved_for("lagrangian").numbers()[0],
                             dtype=np.uint64) >> np.uint64(1)


def sample_formation(base: Formation, box: Any, settings: MonteCarloSettings, run_seed: int,
                     spec: Spec | str | Path | None = None) -> Formation:
    """The formation of one run (deterministic in ``run_seed``): gains of the design ``spec``
    (default: the paper's) drawn from ``box`` (:func:`mc_box`), attitudes, rates and phases
    (a setting not given: the Lagrangian path's default,
    :meth:`~formsync_design.sim.montecarlo_data.MonteCarloSettings.resolved_for`).

    >>> from formsync_design.verify.case import load_case
    >>> f = load_case().formation()
    >>> box = point_box(f.gains); s = MonteCarloSettings(runs=1)
    >>> a = sample_formation(f, box, s, 12345); b = sample_formation(f, box, s, 12345)
    >>> bool(np.array_equal(a.attitudes, b.attitudes)), bool((a.attitudes[:, 3] > 0).all())
    (True, True)
    >>> g = sample_formation(f, {"k_p": "0.5:1", "k_d": 2}, s, 7, "pd_consensus").gains
    >>> g.names, bool(0.5 <= g.k_p <= 1), g.k_d, g.K_v[0]  # no switching gain: K_v = 0
    (('k_p', 'k_d'), True, 2.0, 0.0)
    """
    return sample_formations(base, box, settings, [run_seed], spec)[0]


def sample_formations(base: Formation, box: Any, settings: MonteCarloSettings,
                      run_seeds: Any, spec: Spec | str | Path | None = None) -> list[Formation]:
    """The formations of the runs ``run_seeds``: :func:`sample_formation` of each seed, with
    the design and the box read once for the campaign.

    >>> from formsync_design.verify.case import load_case
    >>> f = load_case().formation()
    >>> box = point_box(f.gains); s = MonteCarloSettings(runs=1)
    >>> a, b = sample_formations(f, box, s, [3, 4])
    >>> bool(np.array_equal(b.attitudes, sample_formation(f, box, s, 4).attitudes))
    True
    """
    n = base.n
    ctrl, sw, diag = _design(spec)
    b = mc_box(box, spec).as_floats()
    dims = [name for name in ctrl for _ in range(3 if name in diag else 1)]
    dims += [sw] if sw is not None else []
    lo = np.array([b[name][0] for name in dims])
    hi = np.array([b[name][1] for name in dims])
    st = settings.resolved_for("lagrangian")
    _, max_angle_deg, max_rate = st.numbers()
    max_angle = math.radians(max_angle_deg)
    out: list[Formation] = []
    for run_seed in run_seeds:
        rng = np.random.default_rng(int(run_seed))
        g = [float(v) for v in rng.uniform(lo, hi)]  # one draw for every dimension, in box order
        vals: dict[str, Any] = {}
        k = 0
        for name in ctrl:
            if name in diag:
                vals[name], k = (g[k], g[k + 1], g[k + 2]), k + 3
            else:
                vals[name], k = g[k], k + 1
        gains = Gains(vals, (g[k],) * n if sw is not None else ())
        axis = rng.normal(size=(n, 3))
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        ang = rng.uniform(0.0, max_angle, size=n)
        att = np.column_stack([axis * np.sin(ang / 2)[:, None], np.cos(ang / 2)])
        att /= np.linalg.norm(att, axis=1, keepdims=True)
        rates = rng.uniform(-max_rate, max_rate, size=(n, 3))
        dist = base.disturbance.with_phases(rng) if st.phases else base.disturbance
        out.append(Formation(base.graph, base.inertias, att, rates, gains, dist))
    return out


def replay(base: Formation, box: Any, settings: MonteCarloSettings, run_seed: int,
           spec: Spec | str | Path | None = None) -> Formation:
    """Alias of :func:`sample_formation`: rebuild a flagged run from its seed."""
    return sample_formation(base, box, settings, run_seed, spec)


def certify_sampled_box(base: Formation, box: Any, spec: Spec | str | Path | None = None) -> dict[str, Any]:
    """Certification of the sampled box of controller gains with the conditions derived for
    ``spec`` (default: the paper's), the design's multipliers searched over their declared
    ranges (:func:`~formsync_design.certify.multipliers.certify_with_multipliers`), and -
    when the design has a switching gain - of the smallest ``K_v`` against the disturbance
    bound; ``{"status": "unavailable"}`` when the certification modules are not available.

    For a design without a switching gain ``kv_holds`` and ``required_kv`` are None and
    ``gains_and_kv_certified`` is true only for a certified box under no disturbance
    (``ubar == 0``): the certificate covers the undisturbed loop only.

    >>> from formsync_design.verify.case import load_case
    >>> f = load_case().formation(disturbance="none")
    >>> c = certify_sampled_box(f, {"k_p": "0.5:1", "k_d": "1:2"}, "pd_consensus")
    >>> str(c["status"]), c["kv_holds"], c["gains_and_kv_certified"]
    ('certified', None, True)
    """
    try:
        from formsync_design.certify.engine import certify_box, check_kv
        from formsync_design.certify.multipliers import certify_with_multipliers
        from formsync_design.derive.closed_form import required_kv
        from formsync_design.derive.conditions import derive_conditions
    except ImportError as e:  # pragma: no cover - depends on the other modules
        return {"status": "unavailable", "reason": str(e)}
    sp = load_spec(spec)
    ctrl, sw, _ = _design(sp)
    ubar = float(np.max(base.disturbance.bound(base.inertias)))
    b = mc_box(box, sp)
    mult: dict[str, GainRange] = {}
    for m in sp.decl.multipliers:
        r = sp.decl.gain(m).range
        if r is None:
            return {"status": "unavailable",
                    "reason": f"the multiplier {m} has no declared range to search"}
        mult[m] = r
    conds = derive_conditions(base.graph, sp)
    gbox = {g: (b[g].lo, b[g].hi) for g in ctrl}
    res = certify_with_multipliers(conds, gbox, mult) if mult else certify_box(conds, gbox)
    status = res.status
    if sw is None:
        return {
            "status": status,
            "reason": getattr(res, "reason", ""),
            "kv_holds": None,
            "ubar": ubar,
            "required_kv": None,
            "gains_and_kv_certified": status == "certified" and ubar == 0,
        }
    kv_lo = float(b[sw].lo)
    if ubar > 0 and kv_lo > 0:
        kv = check_kv(kv_lo, list(base.inertias), ubar)
        holds, required = bool(kv.holds), [float(v) for v in kv.required]
    elif ubar > 0:  # K_v = 0 is in the box: K_v >= K_v* > 0 fails there
        holds, required = False, [float(required_kv(J, ubar)) for J in base.inertias]
    else:  # no disturbance: K_v* = 0, which every K_v >= 0 meets
        holds, required = True, [0.0] * base.n
    return {
        "status": status,
        "reason": getattr(res, "reason", ""),
        "kv_holds": holds,
        "ubar": ubar,
        "required_kv": required,
        "gains_and_kv_certified": status == "certified" and holds,
    }


def run_montecarlo(
    base: Formation,
    box: Any = None,
    settings: MonteCarloSettings | None = None,
    options: SimOptions | None = None,
    threads: int | None = None,
    batch: int = 2000,
    certify: bool = True,
    *,
    spec: Spec | str | Path | None = None,
    progress: Callable[[int], None] | None = None,
) -> MonteCarloResult:
    """Run a seeded Monte-Carlo campaign.

    Parameters
    ----------
    base : Formation
        Graph, inertias and disturbance model (its gains/attitudes/rates are replaced).
    box : GainBox or mapping, optional
        Over the design's :func:`mc_gain_names` (``K_o, K_q, beta, K_v`` for the paper's;
        see :func:`mc_box`).  Default: the point box of ``base.gains``.
    settings : MonteCarloSettings, optional
        A value not given is the default of the path that runs
        (:meth:`~formsync_design.sim.montecarlo_data.MonteCarloSettings.resolved_for`).
    options : SimOptions, optional
        Default ``SimOptions(step=0.1, output_step=0.5, norm_tol=1e-5)``.
    threads : int, optional
        CasADi thread-map width (default: number of CPUs).
    batch : int
        Most runs per call of the compiled kernel (the calls are sized to about
        :data:`BATCH_SECONDS` of wall time each, so Ctrl-C is seen within a second;
        the runs' records do not depend on the batching).
    certify : bool
        Also report :func:`certify_sampled_box` (the conditions derived for ``spec``).
    spec : Spec, AgentDesign, str, Path or None
        The design whose controller is simulated and whose gains are sampled (default:
        the paper's); its kernel is cached under ``spec.key``.  An agent design runs
        :func:`~formsync_design.sim.agent_montecarlo.monte_carlo_agents` (``base`` an
        ``AgentFormation``, ``options`` ``AgentOptions``); its result is a
        :class:`~formsync_design.sim.montecarlo_data.MonteCarloResult` too, of agent runs.
    progress : callable, optional
        Called with the number of runs finished since its last call, after every batch (an
        agent design: after every run), e.g. ``Progress.update`` of a progress bar; a
        smaller ``batch`` moves it more often, with identical runs.

    Examples
    --------
    >>> from formsync_design.verify.case import load_case
    >>> f = load_case().formation()
    >>> r = run_montecarlo(f, settings=MonteCarloSettings(runs=2, seed=1),
    ...                    options=SimOptions(tf=5.0, step=0.1, output_step=0.5, norm_tol=1e-5,
    ...                                       compile=False), certify=False)
    >>> len(r.runs), str(r.runs[0].status)  # 5 s is too short to synchronise
    (2, 'not-converged')
    """
    from formsync_design.sim.agent_montecarlo import monte_carlo_agents
    from formsync_design.spec.loader import agent_design_of

    agent = agent_design_of(spec)
    if agent is not None:  # an agent design: its own campaign (agent runs)
        return monte_carlo_agents(agent, base, box, settings, options,
                                  certify=certify, progress=progress)
    sp_spec = load_spec(spec)
    bx = mc_box(box, sp_spec) if box is not None else point_box(base.gains, sp_spec)
    st = (settings if settings is not None else MonteCarloSettings()).resolved_for("lagrangian")
    runs_total = st.numbers()[0]
    opt = options if options is not None else DEFAULT_OPTIONS
    if opt.method == "cvodes":
        raise InputError(f"expected the rk4 or dopri5 integrator for Monte-Carlo runs, received {opt.integrator!r}")
    nthreads = int(threads) if threads is not None else (os.cpu_count() or 1)
    if nthreads < 1:
        raise InputError(f"expected threads >= 1, received {threads}")
    if batch < 1:
        raise InputError(f"expected batch >= 1, received {batch}")
    n = base.n
    Ktot = round(opt.tf / opt.interval)
    if Ktot < 1 or abs(Ktot * opt.interval - opt.tf) > 1e-9 * max(1.0, opt.tf):
        raise InputError(f"expected tf to be a multiple of the output interval {opt.interval:g} s, received {opt.tf:g}")
    t_build = time.perf_counter()
    nk = get_native(sp_spec, opt.switch, opt.inverse, opt.compile)
    kern = None if nk is not None else get_kernel(
        n, opt.switch, opt.sample_period is not None, 1, 1, opt.inverse, False, spec=sp_spec)
    build = time.perf_counter() - t_build
    cfg = driver_config(opt, sp_spec)
    seeds = _run_seeds(st)
    forms = sample_formations(base, bx, st, seeds, sp_spec)
    # the box's certificate is computed while the compiled kernel runs the campaign (the
    # kernel releases the GIL); a daemon thread, so that a Ctrl-C is not held up by it
    cert_job = _Background(certify_sampled_box, base, bx, sp_spec) if certify else None
    runs: list[MonteCarloRun] = []
    t0 = time.perf_counter()
    # batches of about BATCH_SECONDS of wall time (at most ``batch`` runs): a Ctrl-C, seen by
    # Python only between calls of the compiled kernel, ends the campaign within a second
    size = min(batch, 4 * nthreads)
    b0 = 0
    while b0 < runs_total:
        fb = forms[b0 : b0 + size]
        tb = time.perf_counter()
        P = np.stack([pack_params(f, opt, sp_spec) for f in fb])
        X0 = np.stack([f.initial_state() for f in fb])
        if nk is not None:
            S = nk.batch(n, P, cfg, X0, Ktot, nthreads)
        else:  # no compiler: the driver's Python mirror, one run at a time
            S = np.stack([_reduce(run_vm(kern, n, P[j], cfg, X0[j], 0.0, Ktot), opt) for j in range(len(fb))])
        per_run = (time.perf_counter() - tb) / len(fb)
        if cert_job is not None and np.any(S[:, SUMMARY.index("status")] > 1):
            cert_job.wait()  # a failed run is replayed by simulate: not beside the certificate
        for j, f in enumerate(fb):
            runs.append(_summarize_run(b0 + j, int(seeds[b0 + j]), f, S[j], opt, bx.names, sp_spec))
        if progress is not None:
            progress(len(fb))
        b0 += len(fb)
        size = max(1, min(batch, int(BATCH_SECONDS / per_run) if per_run > 0 else batch))
    wall = time.perf_counter() - t0
    counts = {s: sum(r.status == s for r in runs) for s in RUN_STATUSES}
    ct = np.array([r.convergence_time for r in runs if r.convergence_time is not None])
    ct_stats = (
        {"min": float(ct.min()), "median": float(np.median(ct)), "p95": float(np.percentile(ct, 95)),
         "max": float(ct.max())}
        if ct.size else {"min": None, "median": None, "p95": None, "max": None}
    )
    cert = cert_job.result() if cert_job is not None else {"status": "skipped"}
    return MonteCarloResult(
        runs=tuple(runs), box=bx, settings=st, options=opt, counts=counts,
        convergence_time_stats=ct_stats, wall_seconds=wall, build_seconds=build,
        certification=cert, spec_key=sp_spec.key,
    )


class _Background:
    """``fn(*args)`` on a daemon thread; :meth:`result` joins it and returns its value or
    raises its exception."""

    def __init__(self, fn: Callable[..., Any], *args: Any) -> None:
        self._value: Any = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(fn, args), daemon=True)
        self._thread.start()

    def _run(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
        try:
            self._value = fn(*args)
        except BaseException as e:  # re-raised in the caller's thread by result()
            self._error = e

    def wait(self) -> None:
        self._thread.join()

    def result(self) -> Any:
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


def _reduce(out: Any, opt: SimOptions) -> np.ndarray:
    """The batch summary (:data:`~formsync_design.sim.native_c.SUMMARY`) of one run of the
    Python mirror (what the compiled batch reduces in C)."""
    info = out.info
    t = np.arange(out.X.shape[0]) * opt.interval
    om, qm = out.MET[:, 0], out.MET[:, 1]
    ct = convergence_time(t, om, qm, opt.q_tol, opt.omega_tol) if info["status"] == 0 else None
    vals = {
        "status": info["status"], "tevent": info["tevent"], "sc": info["sc"],
        "conv_time": math.nan if ct is None else ct, "final_om": om[-1], "final_qm": qm[-1],
        "min_q0": float(np.min(out.MINQ)), "peak_u": float(np.max(np.abs(out.U))) if out.U.size else 0.0,
        "normerr": info["normerr"], "steps": info["steps"], "rejected": info["rejected"],
        "nfev": info["nfev"], "kdone": info["kdone"], "tfail": info["tfail"],
        "q0fail": info["q0fail"], "reason": info["reason"],
    }
    return np.array([float(vals[k]) for k in SUMMARY])


def _summarize_run(index: int, seed: int, f: Formation, S: np.ndarray, opt: SimOptions,
                   names: tuple[str, ...], spec: Spec) -> MonteCarloRun:
    """One run's record from its summary; a run the driver stopped on a failure (non-finite
    state, step-size underflow, norm drift) is replayed with :func:`simulate`, which
    decides it exactly as a single simulation does (the ``q0 -> 0`` singularity or not)."""
    s = dict(zip(SUMMARY, (float(v) for v in S), strict=True))
    status_code = int(s["status"])
    event = ctime = None
    fin = lambda v: float(v) if math.isfinite(v) else float("nan")  # noqa: E731
    final_q, final_om, minq = fin(s["final_qm"]), fin(s["final_om"]), fin(s["min_q0"])
    peak, nerr = fin(s["peak_u"]), fin(s["normerr"])
    if status_code == 0:
        ctime = None if math.isnan(s["conv_time"]) else s["conv_time"]
        status = RunStatus.CONVERGED if ctime is not None else RunStatus.NOT_CONVERGED
    elif status_code == 1:
        status, event = RunStatus.SINGULAR, s["tevent"]
    else:
        try:
            r = simulate(f, opt, spec=spec)
        except SimulationError:
            status = RunStatus.INACCURATE if status_code == 3 else RunStatus.DIVERGED
            event = None if status_code == 3 else s["tfail"]
        else:
            if r.status == "diverged":
                status, event = RunStatus.DIVERGED, r.diverged_time
            else:
                status, event = RunStatus.SINGULAR, r.singular_time
            assert r.q_m is not None and r.omega_m is not None and r.min_q0 is not None
            final_q, final_om = float(r.q_m[-1]), float(r.omega_m[-1])
            minq, peak = float(r.min_q0.min()), float(r.peak_torque.max())
            nerr = float(r.stats["max_norm_error"])
    return MonteCarloRun(
        seed=seed, gains=_run_gains(f.gains, names), status=status, convergence_time=ctime,
        peak_torque=peak, index=index, final_q_m=final_q, final_omega_m=final_om,
        min_q0=minq, norm_error=nerr, event_time=event,
    )


def _run_gains(g: Gains, names: tuple[str, ...]) -> tuple[tuple[str, Any], ...]:
    """The sampled gains of a run in box order (a box name that is not a controller gain of
    ``g`` is the switching gain: every spacecraft has the same sampled ``K_v``)."""
    have = g.as_dict()
    return tuple((n, have[n]) if n in have else (n, g.K_v[0]) for n in names)
