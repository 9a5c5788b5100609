"""The attitude-display and torque metrics (formsync_design/verify/metrics_attitude.py) on
hand-made runs whose values are known in closed form (rotations about one axis)."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from formsync_design.verify.enginecase import load_engine_case  # noqa: F401 (registers)
from formsync_design.verify.metrics import METRICS, MetricContext, check_metric_args


def _about(axis: int, deg: float) -> list[float]:
    q = [0.0, 0.0, 0.0, math.cos(math.radians(deg) / 2)]
    q[axis] = math.sin(math.radians(deg) / 2)
    return q


def _run(Q: Any, U: Any = None, W: Any = None, monitors: Any = None) -> Any:
    Q = np.asarray(Q, float)
    T, n = Q.shape[:2]
    return SimpleNamespace(t=np.arange(T, dtype=float), quaternions=Q, status="converged",
                           message="", torques=np.zeros((T, n, 3)) if U is None else np.asarray(U),
                           rates=np.zeros((T, n, 3)) if W is None else np.asarray(W),
                           monitors=monitors or {})


class _Results:
    def __init__(self, run: Any) -> None:
        self._run = run

    def run(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        return self._run


def _value(name: str, run: Any, **args: Any) -> Any:
    spec = METRICS[name]
    ctx = MetricContext(SimpleNamespace(), "f", "s", spec, _Results(run),  # type: ignore[arg-type]
                        check_metric_args(spec, args, "test"))
    return spec.fn(ctx)


def test_euler_error_time_is_the_last_entry_into_the_bound() -> None:
    # spacecraft 2 rotated about z (pitch) by a_k from spacecraft 1 at rest: Qa = a_k
    a = [5.0, 0.5, 2.0, 0.5, 0.2]
    run = _run([[_about(2, 0), _about(2, x)] for x in a])
    v = _value("euler_error_time", run, threshold_deg=1.0)
    assert v.value == 3.0 and v.bound == "exact"
    v = _value("euler_error_time", run, threshold_deg=0.1)
    assert v.value == 4.0 and v.bound == "lower"


def test_jumps_and_the_rotation_element_step() -> None:
    # about z through 180 deg: pitch 170, 178, -174 (one jump, spacecraft 1's pitch); R_23 = 0
    run = _run([[_about(2, x)] for x in (170.0, 178.0, 186.0)])
    v = _value("euler_angle_jumps", run)
    assert v.value == 1.0 and "spacecraft 1, pitch" in v.detail and "t = 2.00 s" in v.detail
    assert _value("rotation_element_step", run).value == pytest.approx(0.0, abs=1e-15)
    # about x: R_23 = -sin(a)
    a = [0.0, 30.0, 90.0]
    run = _run([[_about(0, x)] for x in a])
    want = np.abs(np.diff(-np.sin(np.radians(a)))).max()
    assert _value("rotation_element_step", run).value == pytest.approx(want, rel=1e-12)
    assert _value("euler_angle_jumps", run).value == 0.0


def test_torque_rate_and_monitor_metrics() -> None:
    Q = [[_about(2, 0)] * 2] * 4
    U = np.zeros((4, 2, 3))
    U[:, 1, 0] = [4.0, 2.0, 0.1, 0.03]      # spacecraft 2: peak 4, after t = 2: 0.1
    U[3, 0, :] = [np.nan, 0, 0]
    W = np.zeros((4, 2, 3))
    W[-1] = [[0.1, 0.2, 0.0], [0.3, 0.0, 0.0]]
    run = _run(Q, U, W, {"m": np.array([[1.0, -2.0], [0.5, 3.0], [np.nan, 0.0], [1, 1]])})
    v = _value("late_torque_ratio", run, spacecraft=2, after_s=2.0, fraction=0.01)
    assert v.value == pytest.approx(0.1 / 4) and v.detail.endswith("from 3.00 s")
    assert _value("late_torque_ratio", run, spacecraft=2, after_s=2.0,
                  fraction=0.05).detail.endswith("from 2.00 s")
    assert _value("common_rate", run).value == pytest.approx(math.hypot(0.2, 0.1))
    assert _value("monitor_min", run, monitor="m").value == -2.0
    assert _value("monitor_max", run, monitor="m").value == 3.0
    assert _value("monitor_min", run, monitor="x").value is None
    assert _value("nonfinite_torques", run).value == 1.0
    assert _value("orthonormality_error", run).value < 1e-15
