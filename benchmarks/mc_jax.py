"""The JAX + diffrax ``vmap`` baseline of a 1000-run Monte-Carlo of ``bai2008_passivity``.

What a researcher fluent in JAX would write for the Monte-Carlo (no toolbox code): the closed
loop of :mod:`benchmarks.swarm_numpy` (same law, same state order, quaternions vector part
first) as a ``jax.numpy`` right-hand side in float64, integrated by ``diffrax.diffeqsolve``
with ``Dopri5`` and ``PIDController(rtol, atol)``, ``SaveAt(ts=0, dt, ..., tf)`` (dense
output at the 1201 output times of ``tf = 120 s``, ``dt = 0.1 s``, like the toolbox's
outputs), the solve wrapped in ``jax.jit(jax.vmap(...))`` over the runs.

The Monte-Carlo: graph ``ring:4`` (spacecraft ``i`` receives from ``i - 1`` and ``i + 1``
mod 4, weight 1), the four inertias of ``verification/bai2008_passivity.toml``, ``tf = 120
s``; run ``r`` draws from ``numpy.random.default_rng(seed0 + r)`` (:func:`draws`, which
documents the order of the draws) its gains ``K`` (three values, uniform in ``[1, 50]``) and
``k_p`` (uniform in ``[1, 50]``), each spacecraft's initial attitude (uniformly random axis,
angle uniform in ``[0, 90]`` deg from the identity) and rate (components uniform in
``[-0.01, 0.01]`` rad/s).

What :func:`main` measures, for 1000 runs (``--runs``) at ``rtol 1e-8`` and at ``rtol 1e-6``
(``atol = rtol * 1e-2``):

* cold: the wall time of the first call of :func:`jax_montecarlo` with a new tolerance
  (tracing, XLA compilation and the run), the trajectories copied back to numpy;
* warm: the best wall time of 3 further calls with the same shapes and tolerance (the
  compiled function reused from ``jax.jit``'s cache);
* the accepted / rejected step counts of diffrax (min, median, max over the runs; under
  ``vmap`` the batch's ``while`` loop runs until its slowest run is done, every run paying
  for the largest step count);
* the final-state (``t = 120 s``) max-abs error of the JAX solution against a reference for
  the first 20 runs (``--check``): scipy ``solve_ivp`` DOP853 at ``rtol 1e-13``, ``atol
  1e-15`` on :func:`benchmarks.swarm_numpy.make_rhs` with the run's ``K`` and ``k_p``
  (:func:`benchmarks.swarm_baseline.reference_solution`); the max over those runs is printed.

The 1-minute load average is printed beside every time; nothing asserts a timing.

Run (JAX lives in its own venv; the project does not depend on it)::

    python3 -m venv .venv-jax && .venv-jax/bin/pip install jax diffrax numpy scipy
    PYTHONPATH=. .venv-jax/bin/python benchmarks/mc_jax.py [--runs 1000] [--check 20]

from the repository root (``main`` also puts the repository root on ``sys.path``, as
``swarm_baseline.py`` does).  This module imports without JAX; only
:func:`jax_montecarlo` (and :func:`main`) import ``jax`` and ``diffrax``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["N", "draws", "jax_montecarlo", "main"]

#: Spacecraft in the Monte-Carlo (graph ``ring:4``).
N = 4

_GAIN_RANGE = (1.0, 50.0)
_MAX_ANGLE_DEG = 90.0
_MAX_RATE = 0.01


def draws(runs: int, seed0: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x0 (runs, 28), K (runs, 3), kp (runs,))`` of the Monte-Carlo; needs no JAX.

    Run ``r`` uses ``rng = numpy.random.default_rng(seed0 + r)`` and calls it in this order:

    1. ``K = rng.uniform(1, 50, size=3)``;
    2. ``kp = rng.uniform(1, 50)``;
    3. ``axis = rng.normal(size=(4, 3))``, each row normalised (a uniformly random axis per
       spacecraft);
    4. ``angle = radians(90) * rng.uniform(size=4)``;
    5. ``w = rng.uniform(-0.01, 0.01, size=(4, 3))`` rad/s.

    Quaternion of spacecraft ``i``: ``(sin(angle_i / 2) axis_i, cos(angle_i / 2))``; ``x0`` in
    the toolbox's order (the four quaternions, then the four rates).

    >>> x0, K, kp = draws(3)
    >>> x0.shape, K.shape, kp.shape
    ((3, 28), (3, 3), (3,))
    >>> bool(np.allclose(np.linalg.norm(x0[:, :16].reshape(3, 4, 4), axis=2), 1.0))
    True
    >>> bool(np.all(x0[:, 3:16:4] >= np.cos(np.radians(45)))), bool(np.all(abs(x0[:, 16:]) <= 0.01))
    (True, True)
    >>> bool(np.array_equal(draws(2, seed0=1)[0][0], x0[1]))
    True
    """
    x0 = np.empty((runs, 7 * N))
    K = np.empty((runs, 3))
    kp = np.empty(runs)
    lo, hi = _GAIN_RANGE
    for r in range(runs):
        rng = np.random.default_rng(seed0 + r)
        K[r] = rng.uniform(lo, hi, size=3)
        kp[r] = rng.uniform(lo, hi)
        axis = rng.normal(size=(N, 3))
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        ang = np.radians(_MAX_ANGLE_DEG) * rng.uniform(size=N)
        w = rng.uniform(-_MAX_RATE, _MAX_RATE, size=(N, 3))
        qb = np.column_stack([np.sin(ang / 2)[:, None] * axis, np.cos(ang / 2)])
        x0[r] = np.concatenate([qb.ravel(), w.ravel()])
    return x0, K, kp


def _jax() -> tuple[Any, Any, Any]:
    """``(jax, jax.numpy, diffrax)`` with float64 enabled (imported on first use)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import diffrax
    import jax.numpy as jnp

    return jax, jnp, diffrax


_SOLVERS: dict[tuple[Any, ...], Any] = {}


def _solver(tf: float, dt: float, rtol: float, atol: float, max_steps: int) -> Any:
    """The ``jax.jit(jax.vmap(solve))`` of one setting, built once per setting (inertias:
    the case file's four; graph ``ring:4``)."""
    key = (tf, dt, rtol, atol, max_steps)
    if key in _SOLVERS:
        return _SOLVERS[key]
    jax, jnp, diffrax = _jax()
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from benchmarks.swarm_numpy import case_data, graph_arcs

    J_np = case_data()[0]
    ai, aj, a = graph_arcs(N, "ring")
    A_np = np.zeros((N, N))
    np.add.at(A_np, (ai, aj), a)
    J = jnp.asarray(J_np)
    Jinv = jnp.asarray(np.linalg.inv(J_np))
    A = jnp.asarray(A_np)
    n_out = int(round(tf / dt)) + 1
    ts = jnp.linspace(0.0, tf, n_out)

    def rhs(t: Any, x: Any, args: Any) -> Any:
        Kd, kp = args
        qb = x[: 4 * N].reshape(N, 4)
        w = x[4 * N:].reshape(N, 3)
        q, q0 = qb[:, :3], qb[:, 3:]
        S = A @ qb                                  # (N, 4): sum_j a_ij [q_j | q0_j]
        s = S[:, :3]
        u = kp * (q0 * s - S[:, 3:] * q - jnp.cross(q, s)) - Kd * w
        Jw = jnp.einsum("nij,nj->ni", J, w)
        qv_dot = 0.5 * (q0 * w + jnp.cross(q, w))
        q0_dot = -0.5 * jnp.sum(q * w, axis=1, keepdims=True)
        w_dot = jnp.einsum("nij,nj->ni", Jinv, u - jnp.cross(w, Jw))
        return jnp.concatenate([jnp.concatenate([qv_dot, q0_dot], axis=1).ravel(),
                                w_dot.ravel()])

    term = diffrax.ODETerm(rhs)
    solver = diffrax.Dopri5()
    controller = diffrax.PIDController(rtol=rtol, atol=atol)
    saveat = diffrax.SaveAt(ts=ts)

    def one(x0: Any, Kd: Any, kp: Any) -> tuple[Any, Any, Any]:
        sol = diffrax.diffeqsolve(term, solver, t0=0.0, t1=tf, dt0=None, y0=x0,
                                  args=(Kd, kp), saveat=saveat, stepsize_controller=controller,
                                  max_steps=max_steps)
        return sol.ys, sol.stats["num_accepted_steps"], sol.stats["num_rejected_steps"]

    fn = jax.jit(jax.vmap(one))
    _SOLVERS[key] = fn
    return fn


def jax_montecarlo(x0: np.ndarray, K: np.ndarray, kp: np.ndarray, tf: float = 120.0,
                   dt: float = 0.1, rtol: float = 1e-8, atol: float = 1e-10,
                   max_steps: int = 200_000, return_steps: bool = False) -> Any:
    """The trajectories ``(runs, round(tf / dt) + 1, 28)`` (numpy, float64) at ``t = 0, dt,
    ..., tf`` of the runs ``(x0[r], K[r], kp[r])`` (as from :func:`draws`): diffrax ``Dopri5``,
    ``PIDController(rtol, atol)``, ``SaveAt(ts=...)``, under ``jax.jit(jax.vmap(...))``.

    With ``return_steps``: ``(trajectories, accepted steps (runs,), rejected steps (runs,))``.
    The first call of a setting traces and compiles (cached per ``(tf, dt, rtol, atol,
    max_steps)`` and per batch shape by ``jax.jit``)."""
    _, jnp, _ = _jax()
    fn = _solver(float(tf), float(dt), float(rtol), float(atol), int(max_steps))
    ys, acc, rej = fn(jnp.asarray(x0, dtype=jnp.float64), jnp.asarray(K, dtype=jnp.float64),
                      jnp.asarray(kp, dtype=jnp.float64))
    out = np.asarray(ys)
    if not np.all(np.isfinite(out)):
        raise RuntimeError("diffrax returned non-finite states (max_steps reached?)")
    if return_steps:
        return out, np.asarray(acc), np.asarray(rej)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from benchmarks.swarm_baseline import reference_solution
    from benchmarks.swarm_numpy import case_data, graph_arcs, make_rhs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--check", type=int, default=20, help="runs checked against the reference")
    ap.add_argument("--tf", type=float, default=120.0)
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-8, 1e-6])
    args = ap.parse_args(argv)

    def load() -> str:
        return f"load {os.getloadavg()[0]:.2f}"

    jax, _, diffrax = _jax()
    print(f"bai2008_passivity Monte-Carlo, ring:{N}, tf = {args.tf:g} s, {args.runs} runs; "
          f"jax {jax.__version__} ({jax.default_backend()}, {jax.device_count()} device), "
          f"diffrax {diffrax.__version__}, numpy {np.__version__}, {os.cpu_count()} CPUs")
    x0, K, kp = draws(args.runs)

    J, _, _ = case_data()
    ai, aj, a = graph_arcs(N, "ring")
    nchk = min(args.check, args.runs)
    t0 = time.perf_counter()
    refs = np.array([reference_solution(make_rhs(J, ai, aj, a, K[r], kp[r]), x0[r],
                                        args.tf).y[:, -1] for r in range(nchk)])
    print(f"reference (scipy DOP853 rtol 1e-13 atol 1e-15), {nchk} runs: "
          f"{time.perf_counter() - t0:.1f} s  [{load()}]")

    for rtol in args.rtols:
        atol = rtol * 1e-2
        t0 = time.perf_counter()
        ys, acc, rej = jax_montecarlo(x0, K, kp, tf=args.tf, rtol=rtol, atol=atol,
                                      return_steps=True)
        cold = time.perf_counter() - t0
        print(f"\nrtol {rtol:g}, atol {atol:g}: output {ys.shape}")
        print(f"  cold (trace + compile + run): {cold:8.2f} s  [{load()}]")
        warm = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            jax_montecarlo(x0, K, kp, tf=args.tf, rtol=rtol, atol=atol)
            warm = min(warm, time.perf_counter() - t0)
        print(f"  warm (best of 3):             {warm:8.2f} s  [{load()}]  "
              f"({warm / args.runs * 1e3:.2f} ms a run)")
        print(f"  accepted steps min/median/max {acc.min()}/{int(np.median(acc))}/{acc.max()}, "
              f"rejected {rej.min()}/{int(np.median(rej))}/{rej.max()}")
        err = np.max(np.abs(ys[:nchk, -1, :] - refs), axis=1)
        print(f"  final-state max-abs error vs reference, first {nchk} runs: max {err.max():.2e}, "
              f"median {np.median(err):.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
