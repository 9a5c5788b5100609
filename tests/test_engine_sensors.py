"""The ``sensors`` override of an engine scenario (formsync_design/verify/enginesensors.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.errors import InputError
from formsync_design.verify.engine import run_engine
from formsync_design.verify.enginecase import load_engine_case

_SC = ('[[spacecraft]]\ninertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nrate = [0.1, 0, 0]\n'
       'q = [0, 0, 0]\n')


def _case(tmp_path, scenarios: str, integrator: str = "rk4"):
    (tmp_path / "damper.py").write_text(
        'FORM = "agent"\nMEASURED = ("rate",)\nGAINS = {"k": {}}\n'
        'def controller(v):\n    return -v.k * v.J * v.w\n')
    (tmp_path / "c.toml").write_text(f'''
[case]
kind = "engine"
design = "damper.py"
graph = "path:2"
[gains]
k = 1.0
[simulation]
tf = 5.0
output_step = 0.5
step = 0.05
integrator = "{integrator}"
{scenarios}
[[metrics]]
id = "w"
metric = "final_rate"
''' + _SC + _SC)
    return load_engine_case(tmp_path / "c.toml", trust=[tmp_path / "damper.py"])


def test_failed_gyro_leaves_its_spacecraft_undamped(tmp_path):
    case = _case(tmp_path, '''
[[scenarios]]
name = "perfect"
sensors = {}
[[scenarios]]
name = "failed"
sensors = {failed = [1], failed_at = 0.0}
''')
    ver = run_engine(case)
    res = ver.results
    ok = res.run("case", "perfect").rates[-1]
    bad = res.run("case", "failed").rates[-1]
    # the law reads zero on spacecraft 1: no torque, its rate stays 0.1 rad/s exactly
    assert bad[0, 0] == pytest.approx(0.1, abs=1e-15)
    # spacecraft 2's gyro is healthy: w' = -k w, w(5) = 0.1 e^-5 (RK4 at h = 0.05)
    assert bad[1, 0] == pytest.approx(0.1 * math.exp(-5), rel=1e-6)
    assert ok[0, 0] == pytest.approx(0.1 * math.exp(-5), rel=1e-6)
    assert case.scenario("failed").overrides["sensors"]["failed"] == [1]


def test_bias_matches_the_direct_simulation(tmp_path):
    from formsync_design.sim.agents import simulate_agents
    from formsync_design.sim.sensors import RateSensors

    case = _case(tmp_path, '''
[[scenarios]]
name = "biased"
sensors = {bias = 0.01, noise = 0.002, seed = 3}
''')
    ver = run_engine(case)
    r = ver.results.run("case", "biased")
    c = case.scenario("biased").case
    direct = simulate_agents(c.design, c.formation(case.formation("case").graph), c.options,
                             sensors=RateSensors.of(2, bias=0.01, noise_std=0.002, seed=3))
    assert np.array_equal(r.rates, direct.rates)
    # a biased gyro drives each rate towards minus its bias (w' = -(w + b + n))
    b = RateSensors.of(2, bias=0.01, seed=3).bias
    assert np.all(np.sign(r.rates[-1][:, 1:]) == -np.sign(b[:, 1:]))


@pytest.mark.parametrize("table, integrator, needle", [
    ("{spin = 1}", "rk4", "unknown ['spin']"),
    ("{failed = [3]}", "rk4", "spacecraft numbers in 1..2"),
    ("{bias = -1e-3}", "rk4", "number >= 0"),
    ("{}", "cvodes", "rk4 integrator"),
    ("3", "rk4", "as a table"),
])
def test_bad_sensors_are_refused(tmp_path, table, integrator, needle):
    with pytest.raises(InputError, match=needle.replace("[", r"\[").replace("]", r"\]")):
        _case(tmp_path, f'[[scenarios]]\nname = "s"\nsensors = {table}\n', integrator)


def test_leader_false_drops_the_reference(tmp_path):
    from formsync_design.resources import case_file

    text = case_file("lv2012_small").read_text()
    assert 'leader = false' in text  # the comparison scenarios of the shipped case
    case = load_engine_case(case_file("lv2012_small"))
    assert case.scenario("cmp_perfect").case.reference is None
    assert case.scenario("perfect").case.reference is not None
    bad = text.replace("leader = false", "leader = true", 1)
    (tmp_path / "c.toml").write_text(bad)
    with pytest.raises(InputError, match="leader = false"):
        load_engine_case(tmp_path / "c.toml")
