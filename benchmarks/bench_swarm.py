"""Benchmark: the compiled agent driver against plain scipy on swarms (issue 35, item 4).

Scenario: ``bai2008_passivity`` (K = 20 per axis, k_p = 10, the case file's gains) on ring:N,
N = 8, 100, 1000 (``--sizes``), seeded random attitudes within 30 deg of the identity and
rates within 0.05 rad/s (:func:`benchmarks.swarm_numpy.initial_state`), the case's four
inertias cycled, tf = 100 s, output every 0.1 s.  Everything is measured in this run, each
wall time printed with the 1-minute load average beside it:

1. reference: scipy DOP853 at rtol 1e-13 / atol 1e-15 on the vectorised numpy right-hand side
   (:mod:`benchmarks.swarm_numpy`, checked against the kernel in ``tests/test_swarm_numpy.py``);
2. ours: :func:`formsync_design.sim.agents.simulate_agents` with ``integrator="dopri5"`` at
   ``--rtol`` (default 1e-8, atol rtol * 1e-2), the whole call (the driver, the torques and
   monitors at every output, the disagreement metrics, the result), warm (the design's kernel
   compiled and cached), best of 3, and the driver's own time in that call (``stats``); its
   final-state max-abs error against the reference;
3. baseline: DOP853 on the numpy right-hand side with the same output grid, its rtol tightened
   along three steps per decade until its final-state error is no larger than ours (equal
   accuracy; :func:`benchmarks.swarm_baseline.scipy_ladder`), best of 3; the ratio of the
   whole call is the verdict against the targets (N = 8: 300x, N = 100: 30x, N = 1000: 10x),
   the driver's ratio is printed beside it;
4. cold: ``formsync simulate --design bai2008_passivity --graph ring:1000 --tf 100
   --integrator dopri5`` as a process with an empty kernel cache (build included, target
   under 15 s), then warm, and its peak resident memory (target under 1 GB).

Run: ``.venv/bin/python benchmarks/bench_swarm.py [--sizes 8,100,1000] [--no-cold]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.swarm_baseline import reference_solution, scipy_ladder  # noqa: E402
from benchmarks.swarm_numpy import case_data, graph_arcs, initial_state, make_rhs  # noqa: E402
from formsync_design.graphs import load_graph  # noqa: E402
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents  # noqa: E402
from formsync_design.sim.formation import Gains  # noqa: E402
from formsync_design.spec.loader import load_design  # noqa: E402

TARGETS = {8: 300.0, 100: 30.0, 1000: 10.0}


def _load() -> str:
    return f"load {os.getloadavg()[0]:.2f}"


def _ours(n: int, x0: np.ndarray, J: np.ndarray, tf: float, dt: float, rtol: float,
          repeats: int = 3) -> tuple[float, np.ndarray, dict]:
    design = load_design("bai2008_passivity")
    _, K, kp = case_data()
    q = x0[: 4 * n].reshape(n, 4)
    w = x0[4 * n:].reshape(n, 3)
    f = AgentFormation(load_graph(f"ring:{n}"), J, q / np.linalg.norm(q, axis=1, keepdims=True),
                       w, Gains(K=tuple(K), k_p=kp))
    opt = AgentOptions(tf=tf, output_step=dt, integrator="dopri5", rtol=rtol, atol=rtol * 1e-2,
                       angle_tol=0.01, rate_tol=1e-4)
    simulate_agents(design, f, opt)  # builds (or loads) the kernel: not timed
    best, r = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = simulate_agents(design, f, opt)
        best = min(best, time.perf_counter() - t0)
    assert r is not None
    xf = np.concatenate([r.quaternions[-1].ravel(), r.rates[-1].ravel()])
    return best, xf, r.stats


def bench_size(n: int, tf: float, dt: float, rtol: float) -> float:
    x0, J = initial_state(n, seed=0)
    _, K, kp = case_data()
    ai, aj, a = graph_arcs(n, "ring")
    rhs = make_rhs(J, ai, aj, a, K, kp)
    t_eval = np.arange(int(round(tf / dt)) + 1) * dt
    t0 = time.perf_counter()
    ref = reference_solution(rhs, x0, tf, t_eval)
    print(f"N = {n}: reference DOP853 rtol 1e-13 {time.perf_counter() - t0:.2f} s ({_load()})")
    ours, xf, st = _ours(n, x0, J, tf, dt, rtol)
    err = float(np.max(np.abs(xf - ref.y[:, -1])))
    print(f"  ours: dopri5 rtol {rtol:g}, {st['steps']} steps, {st['rhs_evaluations']} rhs "
          f"evaluations, whole call {ours * 1e3:.1f} ms (driver {st['wall_seconds'] * 1e3:.1f} "
          f"ms), final-state error {err:.2e} ({_load()})")
    srtol, serr, sbest, nfev = scipy_ladder(rhs, x0, tf, t_eval, max(err, 1e-14), ref)
    ratio = sbest / ours
    target = TARGETS.get(n)
    verdict = "" if target is None else (f" target >= {target:g}x: "
                                         f"{'met' if ratio >= target else 'NOT met'}")
    print(f"  scipy DOP853 + vectorised numpy: rtol {srtol:.3g}, {nfev} rhs evaluations, "
          f"{sbest * 1e3:.1f} ms, error {serr:.2e} ({_load()})")
    print(f"  ratio scipy / ours at equal accuracy: {ratio:.1f}x of the whole call{verdict}; "
          f"{sbest / st['wall_seconds']:.1f}x of the driver alone (the trajectory, torques and "
          "monitors at every output, as scipy's run gives the trajectory)")
    return ours


def cold_run(n: int, tf: float) -> None:
    cmd = [sys.executable, "-m", "formsync_design", "simulate", "--design", "bai2008_passivity",
           "--graph", f"ring:{n}", "--tf", f"{tf:g}", "--integrator", "dopri5"]
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "FORMSYNC_CACHE_DIR": cache}
        for label in ("cold (empty kernel cache)", "warm"):
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            t0 = time.perf_counter()
            r = subprocess.run(cmd, env=env, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            mem = f"peak resident {peak / 1024:.0f} MB" if peak > before else "peak resident: as above"
            print(f"  {' '.join(cmd[3:])}: {label} {wall:.2f} s, exit {r.returncode}, {mem} "
                  f"({_load()})")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="8,100,1000")
    ap.add_argument("--tf", type=float, default=100.0)
    ap.add_argument("--output-step", type=float, default=0.1)
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--no-cold", action="store_true")
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",")]
    times = {}
    for n in sizes:
        times[n] = bench_size(n, a.tf, a.output_step, a.rtol)
    if len(sizes) > 1:
        print("growth of the whole call with N: " + ", ".join(
            f"N = {n}: {times[n] * 1e3:.1f} ms ({times[n] / n * 1e6:.1f} us per spacecraft)"
            for n in sizes))
    if not a.no_cold:
        print("cold and warm process runs:")
        cold_run(max(sizes), a.tf)
    return 0


if __name__ == "__main__":
    sys.exit(main())
