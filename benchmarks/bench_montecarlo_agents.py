"""Benchmark: the 1000-run Monte-Carlo of an agent design against JAX + diffrax ``vmap``
(issue 35, must-show 3).

Scenario: ``bai2008_passivity`` on ring:4 (the case's inertias), tf = 120 s, output every
0.1 s (1201 outputs a run), gains uniform in the design's ranges (``K`` each axis and ``k_p``
in ``[1, 50]``), attitudes within 90 deg of the identity and rates within 0.01 rad/s, seed 0;
both sides integrate with Dormand-Prince 5(4) at rtol 1e-8 / atol 1e-10 (``--rtol``) and
keep every run's trajectory at the 1201 outputs.

1. ours: :func:`formsync_design.sim.agent_montecarlo.run_agent_montecarlo` (the library
   call behind ``formsync montecarlo``: the draws, the compiled driver on the machine's
   cores, each run's torques, monitors, disagreement and convergence time, the records),
   warm (the design's kernel compiled and cached), best of 3;
2. JAX: :mod:`benchmarks.mc_jax` on the *same* draws (initial states and gains of our
   runs' seeds), in its own venv (``--jax-python``, default ``.venv-jax/bin/python`` in
   the repository; skipped with a note when it is absent): cold (tracing and XLA
   compilation included) and warm (best of 3);
3. accuracy: the final-state max-abs error of both against scipy DOP853 at rtol 1e-13 /
   atol 1e-15 on the numpy right-hand side (:mod:`benchmarks.swarm_numpy`) for the first
   ``--check`` runs.

Wall times are printed with the 1-minute load average; the ratio JAX warm / ours is the
verdict against the target (ours faster).  Run:
``.venv/bin/python benchmarks/bench_montecarlo_agents.py [--runs 1000] [--check 10]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.swarm_baseline import reference_solution  # noqa: E402
from benchmarks.swarm_numpy import graph_arcs, make_rhs  # noqa: E402
from formsync_design.gains import GainBox  # noqa: E402
from formsync_design.sim.agent_montecarlo import (  # noqa: E402
    agent_run_formation,
    run_agent_montecarlo,
)
from formsync_design.sim.agents import simulate_agents  # noqa: E402
from formsync_design.sim.montecarlo_data import MonteCarloSettings  # noqa: E402
from formsync_design.verify.agentcase import load_agent_case  # noqa: E402

_JAX_RUN = r"""
import sys, time, os
import numpy as np
sys.path.insert(0, sys.argv[2])
from benchmarks.mc_jax import jax_montecarlo
d = np.load(sys.argv[1])
x0, K, kp, rtol, check = d["x0"], d["K"], d["kp"], float(d["rtol"]), int(d["check"])
t0 = time.perf_counter()
X = jax_montecarlo(x0, K, kp, rtol=rtol, atol=rtol * 1e-2)
cold = time.perf_counter() - t0
warm = float("inf")
for _ in range(3):
    t0 = time.perf_counter()
    X = jax_montecarlo(x0, K, kp, rtol=rtol, atol=rtol * 1e-2)
    warm = min(warm, time.perf_counter() - t0)
err = float(np.max(np.abs(X[:check, -1, :] - d["ref"])))
print(f"{cold} {warm} {err} {os.getloadavg()[0]}")
"""


def _load() -> str:
    return f"load {os.getloadavg()[0]:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--check", type=int, default=10)
    ap.add_argument("--jax-python", default=str(ROOT / ".venv-jax" / "bin" / "python"))
    a = ap.parse_args(argv)
    case = load_agent_case(ROOT / "verification" / "bai2008_passivity.toml")
    design, base = case.design, case.formation()
    opt = replace(case.options, integrator="dopri5", rtol=a.rtol, atol=a.rtol * 1e-2,
                  output_step=0.1)
    box = GainBox.parse({"K": "1:50", "k_p": "1:50"})
    settings = MonteCarloSettings(runs=a.runs, seed=0, max_angle_deg=90.0, max_rate=0.01)
    run_agent_montecarlo(design, base, box, replace(settings, runs=2), opt, certify=False)
    best, res = float("inf"), None
    for _ in range(3):
        t0 = time.perf_counter()
        res = run_agent_montecarlo(design, base, box, settings, opt, certify=False)
        best = min(best, time.perf_counter() - t0)
    assert res is not None
    print(f"ours: {a.runs} runs, dopri5 rtol {a.rtol:g}, warm best of 3 {best:.2f} s "
          f"({best / a.runs * 1e3:.2f} ms a run; {res.counts}) ({_load()})")

    seeds = settings.run_seeds()
    fl = [agent_run_formation(design, base, box, settings, s) for s in seeds]
    x0 = np.stack([np.concatenate([f.attitudes.ravel(), f.rates.ravel()]) for f in fl])
    K = np.array([f.gains.as_dict()["K"] for f in fl], dtype=float)
    kp = np.array([f.gains.as_dict()["k_p"] for f in fl], dtype=float)
    ai, aj, w = graph_arcs(4, "ring")
    t_eval = np.arange(1201) * 0.1
    refs, ours_err = [], 0.0
    for r in range(min(a.check, a.runs)):
        rhs = make_rhs(base.inertias, ai, aj, w, K[r], float(kp[r]))
        ref = reference_solution(rhs, x0[r], 120.0, t_eval).y[:, -1]
        refs.append(ref)
        one = simulate_agents(design, fl[r], opt)
        xf = np.concatenate([one.quaternions[-1].ravel(), one.rates[-1].ravel()])
        ours_err = max(ours_err, float(np.max(np.abs(xf - ref))))
    print(f"  final-state error of ours against scipy DOP853 rtol 1e-13 (first {len(refs)} "
          f"runs): {ours_err:.2e}")
    jp = Path(a.jax_python)
    if not jp.is_file():
        print(f"JAX: {jp} not found (python3 -m venv .venv-jax && .venv-jax/bin/pip "
              "install jax diffrax): skipped")
        return 0
    with tempfile.TemporaryDirectory() as td:
        npz = Path(td) / "draws.npz"
        np.savez(npz, x0=x0, K=K, kp=kp, rtol=a.rtol, check=len(refs), ref=np.array(refs))
        r = subprocess.run([str(jp), "-c", _JAX_RUN, str(npz), str(ROOT)], capture_output=True,
                           text=True)
    if r.returncode != 0:
        print(f"JAX run failed: {r.stderr.strip().splitlines()[-1:]}")
        return 0
    cold, warm, err, load = (float(v) for v in r.stdout.split()[-4:])
    print(f"JAX + diffrax vmap (same draws): cold {cold:.2f} s, warm best of 3 {warm:.2f} s "
          f"(load {load:.2f}); final-state error {err:.2e}")
    verdict = "met" if best < warm else "NOT met"
    print(f"  ratio JAX warm / ours: {warm / best:.2f}x (target: ours faster: {verdict})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
