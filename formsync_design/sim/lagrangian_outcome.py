"""How a run of the Lagrangian simulator ended: a stopped run classified as the ``q0 -> 0``
singularity, a divergence or an integration failure (:func:`classify_failure`), and the one
line a user can act on (:func:`lagrangian_message`).  Used by
:mod:`formsync_design.sim.simulator`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formsync_design.errors import SimulationError
from formsync_design.sim.formation import SimOptions
from formsync_design.sim.native_c import CFG
from formsync_design.sim.result import SimResult

__all__ = ["SINGULAR_BLOWUP_Q0", "classify_failure", "lagrangian_message"]


#: A blow-up (NaN/inf) right after some ``q0`` fell below this value is attributed to the
#: ``q0 -> 0`` singularity: there ``|omega| ~ 2|q'|/q0`` and the closed loop becomes
#: arbitrarily fast, so a fixed-step integrator fails before ``q0`` reaches ``q0_floor``.
SINGULAR_BLOWUP_Q0 = 0.1


def classify_failure(run: Any, cfg: np.ndarray, opt: SimOptions, X: np.ndarray, info: dict,
                      Ktot: int, kdone: int) -> tuple[int | None, float, float]:  # noqa: C901
    """A run stopped by a non-finite state, a step-size underflow or norm drift:
    ``(spacecraft, time, smallest q0)`` when it is the ``q0 -> 0`` singularity;
    ``(None, time, smallest q0)`` when the state became non-finite elsewhere (the run
    diverged: a finding, status ``diverged``); else (a step-size underflow, too many
    steps or norm drift away from the singularity) a
    :class:`~formsync_design.errors.SimulationError`.

    RK4: re-run from the last output point before the failure (at most 10 intervals)
    with the step divided by 10 and 100: near ``q0 = 0`` the rate ``|omega| ~ 2|q'|/q0``
    grows without bound and a fixed step loses accuracy before ``q0`` reaches the floor.
    A finer step reaching the floor locates the event; one that passes means the coarse
    step was inadequate (an error naming the time); if even ``h/100`` blows up right
    after some ``q0 < SINGULAR_BLOWUP_Q0``, that spacecraft is singular there.
    DOPRI5: a step-size underflow or non-finite state after some ``q0 <
    SINGULAR_BLOWUP_Q0`` is the singularity; norm drift is an error (tighten rtol)."""
    tfail, q0f, sc = float(info["tfail"]), float(info["q0fail"]), int(info["sc"])
    reason = {1: "NaN/inf", 2: "a step-size underflow", 3: "too many steps"}.get(int(info["reason"]),
                                                                                  "norm drift")
    nonfinite = int(info["reason"]) == 1
    if opt.method != "rk4":
        if int(info["status"]) == 2 and int(info["reason"]) != 3 and q0f < SINGULAR_BLOWUP_Q0:
            return sc, tfail, q0f
        if nonfinite:
            return None, tfail, q0f
        raise SimulationError(
            f"expected the adaptive integrator to reach tf = {opt.tf:g} s, received {reason} at "
            f"t = {tfail:.4f} s (smallest q0 {q0f:.3g}, not near the q0 singularity); tighten "
            "rtol/atol or set a max_step"
        )
    n = X.shape[1] // 7
    x0 = X[kdone]
    t0 = kdone * opt.interval
    drift0 = float(np.abs(np.linalg.norm(x0[: 4 * n].reshape(n, 4), axis=1) - 1).max())
    result: tuple[int | None, float, float] = (sc if q0f < SINGULAR_BLOWUP_Q0 else None, tfail, q0f)
    c = cfg.copy()
    c[CFG.index("normtol")] = opt.norm_tol + drift0  # drift before the interval is not its fault
    for refine in (10, 100):
        c[CFG.index("substeps")] = opt.substeps * refine
        o = run(x0, t0, min(10, max(1, Ktot - kdone)), c)
        st = int(o.info["status"])
        if st == 1:
            return int(o.info["sc"]), float(o.info["tevent"]), opt.q0_floor
        if st == 0:  # the finer step passes: the coarse step itself was inadequate
            result = (None, t0, float(np.min(x0[3 : 4 * n : 4])))
            break
        q0r = float(o.info["q0fail"])
        result = (int(o.info["sc"]) if q0r < SINGULAR_BLOWUP_Q0 else None, float(o.info["tfail"]), q0r)
    if result[0] is None and nonfinite:
        return None, tfail, q0f
    if result[0] is None:
        raise SimulationError(
            f"expected finite states with quaternion norm drift <= {opt.norm_tol:g}, received "
            f"NaN/inf or a larger drift at t = {result[1]:.4f} s (smallest q0 just before: "
            f"{result[2]:.3g}, not near the q0 singularity); reduce the step"
        )
    return result[0], result[1], result[2]


def lagrangian_message(r: SimResult) -> str:
    """The one line a user can act on of a Lagrangian run (its ``message``), from its status,
    measures and options."""
    o = r.options
    if r.status == "singular":
        i = int(r.singular_spacecraft or 1)
        assert r.min_q0 is not None
        q0 = float(r.min_q0[i - 1])
        if q0 <= o.q0_floor:
            return (
                f"q0 of spacecraft {i} reached {o.q0_floor:g} at t = {r.singular_time:.4f} s: "
                f"Q is singular at q0 = 0 and controller (4) undefined"
            )
        return (
            f"q0 of spacecraft {i} fell to {q0:.3g} at t = {r.singular_time:.4f} s and the "
            f"integration blew up there (|omega| ~ 2|q'|/q0): the q0 -> 0 singularity of Q, "
            f"where controller (4) is undefined"
        )
    if r.status == "diverged":
        return (f"diverged at t = {r.diverged_time:.4f} s (non-finite state, not near the "
                f"q0 singularity; the trajectory ends at t = {r.t[-1]:g} s): reduce the step "
                "or tighten the tolerances")
    if r.status == "converged":
        return (
            f"converged at t = {r.convergence_time:.2f} s (Q_m <= {o.q_tol:g}, "
            f"Omega_m <= {o.omega_tol:g} rad/s to the end)"
        )
    return (
        f"not converged within tf = {r.t[-1]:g} s: final Q_m = {r.final_q_m:.3e}, "
        f"Omega_m = {r.final_omega_m:.3e} rad/s (tolerances {o.q_tol:g}, {o.omega_tol:g})"
    )
