"""The plain-scipy baseline of the swarm benchmarks of ``bai2008_passivity``: measurement helpers.

``scipy.integrate.solve_ivp`` with the vectorised numpy right-hand side of
:mod:`benchmarks.swarm_numpy` (any ``f(t, x)`` works), nothing from the toolbox:

* :func:`reference_solution`: DOP853 at ``rtol 1e-13``, ``atol 1e-15``, the accuracy
  reference; :func:`reference_check` gives its uncertainty (the difference to a second
  solution, DOP853 at a looser tolerance or Radau);
* :func:`time_scipy`: one setting of DOP853 timed (best of ``repeats`` wall times), with its
  number of right-hand-side evaluations and final state;
* :func:`scipy_ladder`: DOP853's ``rtol`` tightened along three steps per decade from
  ``1e-4`` (``atol = rtol * 1e-3``) until the final-state max-abs error against the
  reference is at most ``target_error``, that setting timed: ``(rtol, error, best wall
  time, nfev)``;
* :func:`time_rhs`: the wall time of one ``f(t, x)`` evaluation.

Everything is seeded; nothing asserts a timing (wall times on a shared machine vary; the
1-minute load average is printed beside them by :func:`main`).

Run ``.venv/bin/python benchmarks/swarm_baseline.py [--n 1000] [--tf 100]`` for the report
(per-evaluation cost at N = 8, 100, 1000; the reference and its check; DOP853 at rtol 1e-6
and 1e-9 on ring:N with their errors).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["REF_RTOL", "REF_ATOL", "reference_solution", "reference_check", "time_scipy",
           "scipy_ladder", "time_rhs", "ladder_rtols", "main"]

#: Tolerances of the reference solution (DOP853).
REF_RTOL = 1e-13
REF_ATOL = 1e-15

Rhs = Callable[[float, np.ndarray], np.ndarray]


def _final(ref: Any) -> np.ndarray:
    """The final state of a reference: a ``solve_ivp`` result or a state vector."""
    return np.asarray(ref.y[:, -1] if hasattr(ref, "y") else ref, dtype=float)


def _solve(f: Rhs, x0: np.ndarray, tf: float, t_eval: Any, method: str, rtol: float,
           atol: float) -> Any:
    sol = solve_ivp(f, (0.0, tf), np.asarray(x0, dtype=float), method=method, t_eval=t_eval,
                    rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"solve_ivp {method} rtol {rtol:g} failed: {sol.message}")
    return sol


def reference_solution(f: Rhs, x0: np.ndarray, tf: float, t_eval: Any = None) -> Any:
    """The accuracy reference: ``solve_ivp`` DOP853, ``rtol 1e-13``, ``atol 1e-15`` (the
    ``OdeResult``; ``.y[:, -1]`` is the final state)."""
    return _solve(f, x0, tf, t_eval, "DOP853", REF_RTOL, REF_ATOL)


def reference_check(f: Rhs, x0: np.ndarray, tf: float, t_eval: Any = None,
                    ref: Any = None, method: str = "DOP853", rtol: float = 1e-12,
                    atol: float | None = None) -> float:
    """The reference's uncertainty: max-abs difference of the final states of
    :func:`reference_solution` (or ``ref``) and a second solution (``method`` at ``rtol``,
    ``atol = rtol * 1e-2`` unless given; ``Radau`` is practical for small N only: its
    Jacobian is dense and finite-differenced)."""
    ref = reference_solution(f, x0, tf, t_eval) if ref is None else ref
    other = _solve(f, x0, tf, t_eval, method, rtol, rtol * 1e-2 if atol is None else atol)
    return float(np.max(np.abs(other.y[:, -1] - _final(ref))))


def time_scipy(f: Rhs, x0: np.ndarray, tf: float, t_eval: Any, rtol: float,
               atol: float | None = None, repeats: int = 3) -> tuple[float, int, np.ndarray]:
    """``(best wall time of repeats, nfev, final state)`` of DOP853 at ``rtol`` (``atol =
    rtol * 1e-3`` unless given), the whole ``solve_ivp`` call timed."""
    atol = rtol * 1e-3 if atol is None else atol
    best = np.inf
    sol = None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        sol = _solve(f, x0, tf, t_eval, "DOP853", rtol, atol)
        best = min(best, time.perf_counter() - t0)
    assert sol is not None
    return float(best), int(sol.nfev), sol.y[:, -1].copy()


def ladder_rtols(start: float = 1e-4, stop: float = 1e-13) -> list[float]:
    """``start * 10**(-k / 3)`` for ``k = 0, 1, ...`` down to ``stop`` (three steps per decade).

    >>> [f"{r:.3g}" for r in ladder_rtols(1e-4, 1e-5)]
    ['0.0001', '4.64e-05', '2.15e-05', '1e-05']
    """
    out = []
    k = 0
    while True:
        r = start * 10 ** (-k / 3)
        if r < stop * (1 - 1e-9):
            return out
        out.append(r)
        k += 1


def scipy_ladder(f: Rhs, x0: np.ndarray, tf: float, t_eval: Any, target_error: float,
                 ref: Any, repeats: int = 3) -> tuple[float, float, float, int]:
    """``(rtol, error, best wall time, nfev)`` of the loosest DOP853 setting on the ladder
    (:func:`ladder_rtols` from ``1e-4``, ``atol = rtol * 1e-3``) whose final-state max-abs
    error against ``ref`` (a :func:`reference_solution` or a final state) is at most
    ``target_error``; that setting is timed ``repeats`` times (its first, accuracy-finding
    run counts as one).  A ``RuntimeError`` when no rung down to ``1e-13`` reaches it."""
    xf = _final(ref)
    for rtol in ladder_rtols():
        t0 = time.perf_counter()
        sol = _solve(f, x0, tf, t_eval, "DOP853", rtol, rtol * 1e-3)
        first = time.perf_counter() - t0
        err = float(np.max(np.abs(sol.y[:, -1] - xf)))
        if err <= target_error:
            best = first
            if repeats > 1:
                best = min(first, time_scipy(f, x0, tf, t_eval, rtol, repeats=repeats - 1)[0])
            return rtol, err, best, int(sol.nfev)
    raise RuntimeError(f"DOP853 did not reach a final-state error of {target_error:g} down to "
                       f"rtol 1e-13")


def time_rhs(f: Rhs, x: np.ndarray, number: int | None = None, repeats: int = 5) -> float:
    """Seconds per ``f(0, x)`` call: the best of ``repeats`` batches of ``number`` calls
    (``number`` chosen for about 0.1 s a batch unless given)."""
    f(0.0, x)
    if number is None:
        t0 = time.perf_counter()
        f(0.0, x)
        one = max(time.perf_counter() - t0, 1e-7)
        number = max(1, int(0.1 / one))
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(number):
            f(0.0, x)
        best = min(best, (time.perf_counter() - t0) / number)
    return float(best)


def main(argv: Sequence[str] | None = None) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from benchmarks.swarm_numpy import case_data, graph_arcs, initial_state, make_rhs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="spacecraft on the ring (default 1000)")
    ap.add_argument("--tf", type=float, default=100.0, help="horizon, s (default 100)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rtols", type=float, nargs="*", default=[1e-6, 1e-9])
    ap.add_argument("--radau-n", type=int, default=8,
                    help="also check the reference against Radau (rtol 1e-12) on ring:N")
    ap.add_argument("--target", type=float, default=None,
                    help="also run scipy_ladder to this final-state max-abs error")
    args = ap.parse_args(argv)

    def load() -> str:
        return f"load {os.getloadavg()[0]:.2f}"

    _, K, kp = case_data()
    print(f"bai2008_passivity, K = {K.tolist()}, k_p = {kp}; numpy {np.__version__}")
    for n in (8, 100, 1000):
        x0, J = initial_state(n, args.seed)
        f = make_rhs(J, *graph_arcs(n, "ring"), K, kp)
        print(f"f(t, x) ring:{n}: {time_rhs(f, x0) * 1e6:.1f} us per call  ({load()})")

    if args.radau_n:
        n = args.radau_n
        x0, J = initial_state(n, args.seed)
        f = make_rhs(J, *graph_arcs(n, "ring"), K, kp)
        d = reference_check(f, x0, args.tf, method="Radau", rtol=1e-12, atol=1e-14)
        print(f"ring:{n} reference vs Radau rtol 1e-12 atol 1e-14: final max-abs {d:.2e}")

    n = args.n
    x0, J = initial_state(n, args.seed)
    f = make_rhs(J, *graph_arcs(n, "ring"), K, kp)
    t_eval = np.linspace(0.0, args.tf, int(round(args.tf / 0.1)) + 1)
    t0 = time.perf_counter()
    ref = reference_solution(f, x0, args.tf, t_eval)
    tref = time.perf_counter() - t0
    print(f"ring:{n} tf {args.tf:g}: reference DOP853 rtol 1e-13 atol 1e-15: {tref:.2f} s, "
          f"nfev {ref.nfev}  ({load()})")
    d = reference_check(f, x0, args.tf, t_eval, ref=ref, rtol=1e-12, atol=1e-14)
    print(f"  reference vs DOP853 rtol 1e-12 atol 1e-14: final max-abs {d:.2e}")
    xf = ref.y[:, -1]
    print(f"  final state: max |w| {np.max(np.abs(xf[4 * n:])):.2e} rad/s, "
          f"min q0 {np.min(xf[3:4 * n:4]):.6f}")
    for rtol in args.rtols:
        wall, nfev, x = time_scipy(f, x0, args.tf, t_eval, rtol)
        err = float(np.max(np.abs(x - xf)))
        print(f"  DOP853 rtol {rtol:g} atol {rtol * 1e-3:g}: best of 3 {wall:.3f} s, nfev {nfev}, "
              f"final max-abs error {err:.2e}  ({load()})")
    if args.target is not None:
        rtol, err, wall, nfev = scipy_ladder(f, x0, args.tf, t_eval, args.target, ref)
        print(f"  ladder to {args.target:g}: rtol {rtol:.3g}, error {err:.2e}, best of 3 "
              f"{wall:.3f} s, nfev {nfev}  ({load()})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
