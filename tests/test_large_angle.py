"""Large-angle scope study (formsync_design.verify.metrics_scope) against laws whose region of
convergence is known in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from formsync_design.graphs import load_graph
from formsync_design.sim.agents import AgentFormation, AgentOptions
from formsync_design.sim.formation import Gains
from formsync_design.spec.agent import agent_design_from_functions
from formsync_design.verify.metrics_scope import (
    ScopeVerdict,
    large_angle_attitudes,
    scope_study,
)


def _formation(gains: dict[str, float]) -> AgentFormation:
    # two uncoupled unit-inertia bodies: the disagreement is the angle between their attitudes
    return AgentFormation(load_graph("path:2"), np.array([np.eye(3)] * 2),
                          np.array([[0, 0, 0, 1.0]] * 2), np.zeros((2, 3)), Gains(**gains))


OPT = AgentOptions(tf=60.0, output_step=0.5, step=0.05, angle_tol=0.1, rate_tol=1e-4)


def test_attitudes_angle_and_sign() -> None:
    for ang in (120.0, 179.0, 180.0):
        for sg in (1, -1):
            q = large_angle_attitudes(5, ang, sg, 3)
            assert np.allclose(np.linalg.norm(q, axis=1), 1)
            # principal angle 2 acos |q0| is the requested angle, the sign is q0's
            assert np.allclose(2 * np.degrees(np.arccos(np.abs(q[:, 3]))), ang)
            if ang < 180:
                assert np.all(np.sign(q[:, 3]) == sg)
    assert not np.allclose(large_angle_attitudes(2, 150, 1, 1), large_angle_attitudes(2, 150, 1, 2))


def test_spurious_equilibrium_is_found() -> None:
    # u = -k (2 q0^2 - 1) vec(q) - c w: about the axis the torque is -k cos(theta) sin(theta/2),
    # so the attitude at 90 deg from identity (theta = 270 deg the long way) is stable, and from
    # rest every start beyond 90 deg ends there; below 90 deg it returns to the identity
    d = agent_design_from_functions(lambda v: -v.k * (2 * v.q0**2 - 1) * v.q - v.c * v.w,
                                    gains={"k": {}, "c": {}}, name="spurious")
    sc = scope_study(d, _formation({"k": 1.0, "c": 2.0}), OPT, [30.0, 150.0], signs=(1,), seed=5)
    conv = {r.angle_deg: r.converged for r in sc.runs}
    assert conv == {30.0: True, 150.0: False}
    assert sc.verdict is ScopeVerdict.LOCAL
    assert sc.summary.startswith("local: 1 of 1 runs from >= 150 deg do not converge")
    bad = sc.failures[0]
    assert bad.final_disagreement_deg > 1.0


def test_pd_law_no_counterexample() -> None:
    # quaternion PD u = -k vec(q) - c w converges from every state but the measure-zero q0 = 0
    # set, both signs of q0 (the long way for q0 < 0)
    d = agent_design_from_functions(lambda v: -v.k * v.q - v.c * v.w, gains={"k": {}, "c": {}},
                                    name="pd")
    sc = scope_study(d, _formation({"k": 1.0, "c": 2.0}), OPT, [120.0, 179.0], seed=1)
    assert len(sc.runs) == 4 and all(r.converged for r in sc.runs)
    assert sc.verdict is ScopeVerdict.NO_COUNTEREXAMPLE
    assert "evidence, not proof" in sc.summary
    assert sc.to_dict()["verdict"] == "no-counterexample"


def test_bad_angle_refused() -> None:
    from formsync_design.errors import InputError

    with pytest.raises(InputError):
        large_angle_attitudes(2, 190.0, 1, 0)
