"""The hybrid integrator reports a state that goes non-finite as the status ``diverged``
with its time (a finding), and keeps ``solver-failed`` for a failure with finite values."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from formsync_design.sim.hybrid import HybridStatus, periodic, simulate_hybrid


@pytest.fixture(autouse=True)
def _quiet() -> None:
    warnings.simplefilter("ignore", RuntimeWarning)  # numpy on the non-finite trial steps


def test_growth_past_a_non_finite_bound_is_diverged_at_that_time() -> None:
    # x' = x, x(0) = 1: finite while x <= 1000 (t <= ln 1000), not finite beyond
    def f(t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return np.where(np.abs(x) > 1e3, np.nan, x)

    t_eval = np.linspace(0.0, 20.0, 41)
    r = simulate_hybrid(f, lambda t, i, xi, held: np.zeros(1), [periodic(0.5)], [[1.0]],
                        (0.0, 20.0), t_eval)
    assert r.status is HybridStatus.DIVERGED and r.to_dict()["status"] == "diverged"
    assert r.diverged_time is not None and abs(r.diverged_time - math.log(1e3)) < 1e-6
    assert r.stop_time == r.diverged_time and "diverged at t = " in r.message
    # the outputs up to the divergence are kept, finite and exact
    assert np.array_equal(r.t, t_eval[t_eval <= r.diverged_time])
    assert np.allclose(r.x[:, 0, 0], np.exp(r.t), rtol=1e-8)
    assert r.to_dict()["diverged_time"] == r.diverged_time


def test_a_non_finite_held_input_is_diverged_at_its_update() -> None:
    def law(t: float, i: int, xi: np.ndarray, held: np.ndarray) -> np.ndarray:
        return np.array([math.inf]) if t > 2.2 else -xi

    r = simulate_hybrid(lambda t, x, u: u, law, [periodic(0.5)], [[1.0]], (0.0, 5.0),
                        np.linspace(0.0, 5.0, 11))
    assert r.status == "diverged" and r.diverged_time == 2.5
    assert r.t.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5] and np.isfinite(r.x).all()


def test_a_failure_with_finite_values_stays_solver_failed() -> None:
    # x' = x^2, x(0) = 1 escapes at t = 1; the integrator fails there on finite values
    r = simulate_hybrid(lambda t, x, u: x**2, lambda t, i, xi, held: np.zeros(1),
                        [periodic(10.0)], [[1.0]], (0.0, 2.0), [0.5, 2.0])
    assert r.status is HybridStatus.SOLVER_FAILED and r.diverged_time is None
    assert r.x.shape[0] == 0 or np.isfinite(r.x).all()


def test_a_completed_run_has_no_diverged_time() -> None:
    r = simulate_hybrid(lambda t, x, u: u, lambda t, i, xi, held: -xi, [periodic(0.5)] * 2,
                        [[1.0], [2.0]], (0.0, 1.0), [1.0])
    assert r.status is HybridStatus.COMPLETED and r.diverged_time is None
