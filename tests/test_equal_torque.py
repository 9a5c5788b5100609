"""Equal-peak-torque scaling (formsync_design.analysis.equal_torque) against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.analysis.equal_torque import (
    equal_peak_scale,
    ordering,
    scaled_gains,
)
from formsync_design.errors import InputError
from formsync_design.graphs import load_graph
from formsync_design.sim.agents import AgentFormation, AgentOptions, simulate_agents
from formsync_design.sim.formation import Gains
from formsync_design.spec.agent import agent_design_from_functions


def test_scale_hits_a_simulated_peak_torque_known_in_closed_form() -> None:
    # u = -k vec(q) - c w from rest, rotated theta about x: the largest torque component is
    # k sin(theta/2) at t = 0 (the damping term only opposes it afterwards), so the factor on k
    # that gives the peak P is P / (k sin(theta/2))
    d = agent_design_from_functions(lambda v: -v.k * v.q - v.c * v.w, gains={"k": {}, "c": {}},
                                    name="pd-peak")
    th = math.radians(100.0)
    q = np.array([[math.sin(th / 2), 0, 0, math.cos(th / 2)], [0, 0, 0, 1.0]])
    opt = AgentOptions(tf=5.0, output_step=0.05, step=0.01)
    gains = Gains({"k": 1.0, "c": 2.0})

    def peak(c: float) -> float:
        g = scaled_gains(gains, c, ["c"])
        f = AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2), q, np.zeros((2, 3)), g)
        return float(simulate_agents(d, f, opt).peak_torque.max())

    target = 2.5
    r = equal_peak_scale(peak, target, rtol=1e-4, start=0.3)
    assert abs(peak(r.scale) / target - 1) <= 1e-4
    assert r.relative_error <= 1e-4
    assert r.scale == pytest.approx(target / math.sin(th / 2), rel=2e-4)


def test_search_on_a_nonlinear_map_and_refusals() -> None:
    r = equal_peak_scale(lambda c: 10 * math.log1p(c), 20.0, rtol=1e-6, start=100.0, step=1.5)
    assert abs(10 * math.log1p(r.scale) - 20) <= 2e-5
    with pytest.raises(InputError):
        equal_peak_scale(lambda c: c, -1.0)
    with pytest.raises(InputError):
        equal_peak_scale(lambda c: c, 1.0, step=1.0)


def test_scaled_gains_keep_held_and_scale_diagonal_entries() -> None:
    g = scaled_gains(Gains({"K1": (1.0, 2.0, 3.0), "eps": 0.01, "K2": 0.5}), 2.0,
                     ["eps"]).as_dict()
    assert g["eps"] == 0.01 and g["K2"] == 1.0
    assert tuple(float(x) for x in g["K1"]) == (2.0, 4.0, 6.0)


def test_ordering_text() -> None:
    assert ordering(["a", "b"], [1.0, 1.0]) == "a = b"
    assert ordering(["a", "b", "c"], [3.0, 1.0, 2.0]) == "b < c < a"
    assert ordering(["a", "b"], [None, None]) == "a (not reached) < b (not reached)"


@pytest.mark.slow
def test_ma_so3_comparison_designs_scale_to_the_main_peak_torque() -> None:
    from dataclasses import replace

    from formsync_design.resources import case_file
    from formsync_design.spec.loader import load_design
    from formsync_design.verify.agentcase import load_agent_case

    case = load_agent_case(case_file("ma_so3"))
    target = float(simulate_agents(case.design, case.formation(), case.options).peak_torque.max())
    quat = load_design("ma_quat_smc")
    lit = Gains({"K1": 1.15, "K2": 0.15, "P2": 0.03})
    opt = replace(case.options, switch="tanh", phi=0.01)

    def peak(c: float) -> float:
        f = case.formation(gains=scaled_gains(lit, c, ["eps"]))
        return float(simulate_agents(quat, f, opt).peak_torque.max())

    r = equal_peak_scale(peak, target, rtol=1e-3, start=3.0, step=1.1)
    assert abs(peak(r.scale) / target - 1) <= 1e-3
    assert r.scale > 1  # the literal quaternion gains spend less peak torque than ma_so3's
