"""Engine case keys for comparisons of designs: a formation's own initial state and horizon,
the euler-uniform Monte-Carlo draws, a scenario's gains scaled to another scenario's peak
torque (torque_matching) and the mean over the draws; against independent constructions
(SciPy's rotations, a peak torque known in closed form)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from formsync_design.errors import InputError
from formsync_design.verify.engine import EngineResults, run_engine
from formsync_design.verify.enginecase import load_engine_case

DESIGN = '''FORM = "agent"
GAINS = {"k": {}, "c": {}}
def controller(v):
    return -v.k * v.q - v.c * v.w
'''

TH = math.radians(100.0)

CASE = f"""
[case]
kind = "engine"
design = "pd.py"
graph = "path:2"
[gains]
k = 1.0
c = 2.0
[simulation]
tf = 4.0
output_step = 0.05
step = 0.01
[[spacecraft]]
inertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
rate = [0, 0, 0]
quaternion = [{math.sin(TH / 2)!r}, 0, 0, {math.cos(TH / 2)!r}]
[[spacecraft]]
inertia = [[2, 0, 0], [0, 2, 0], [0, 0, 2]]
rate = [0, 0, 0]
q = [0, 0, 0]
[[formations]]
name = "pair"
[[formations]]
name = "moved"
tf = 2.0
initial = [{{euler_deg = [10, -20, 30], rate = [0.1, 0, 0]}}, {{q = [0, 0, 0], rate = [0, 0.2, 0]}}]
[[scenarios]]
name = "ref"
gains = {{k = 3.0, c = 2.0}}
[[scenarios]]
name = "matched"
torque_matching = {{scenario = "ref", formation = "pair", hold = ["c"], rtol = 1e-4}}
[montecarlo]
runs = 3
seed = 11
draws = "euler-uniform"
max_angle = 60.0
max_rate = 0.5
[[metrics]]
id = "peak_ref"
metric = "peak_torque"
[[metrics]]
id = "peak_matched"
metric = "peak_torque"
scenario = "matched"
[[metrics]]
id = "err_mean"
metric = "final_rate"
montecarlo = "mean"
[[claims]]
id = "equal"
text = "equal peak torque"
predicate = "peak_matched <= 1.001 * peak_ref and peak_matched >= 0.999 * peak_ref"
"""


def _load(case: Path) -> Any:
    """The engine case, its design file trusted (a data file's design code needs it)."""
    return load_engine_case(case, trust=[case.with_name("pd.py")])


def _case(tmp_path: Path, text: str = CASE) -> Path:
    (tmp_path / "pd.py").write_text(DESIGN)
    p = tmp_path / "c.toml"
    p.write_text(text)
    return p


def test_formation_initial_state_and_horizon(tmp_path: Path) -> None:
    case = _load(_case(tmp_path))
    res = EngineResults(case)
    c = res.case_for("moved", "ref")
    want = Rotation.from_euler("ZYX", [30, -20, 10], degrees=True).as_quat()  # x y z w
    got = c.attitudes[0]
    assert min(np.abs(got - want).max(), np.abs(got + want).max()) < 1e-12
    assert c.rates.tolist() == [[0.1, 0, 0], [0, 0.2, 0]]
    assert res.options("moved", "ref").tf == 2.0 and res.options("pair", "ref").tf == 4.0
    assert res.case_for("pair", "ref").attitudes[0][0] == pytest.approx(math.sin(TH / 2))
    assert float(res.run("moved", "ref").t[-1]) == pytest.approx(2.0)


def test_euler_uniform_draws_match_an_independent_generator(tmp_path: Path) -> None:
    res = EngineResults(_load(_case(tmp_path)))
    rng = np.random.default_rng(11)
    for k in range(3):
        E = rng.uniform(-60, 60, size=(2, 3))
        W = rng.uniform(-0.5, 0.5, size=(2, 3))
        f = res.initial("pair", "matched", k)
        for i in range(2):
            want = Rotation.from_euler("ZYX", E[i, ::-1], degrees=True).as_quat()
            got = f.attitudes[i]
            assert min(np.abs(got - want).max(), np.abs(got + want).max()) < 1e-12
        assert np.array_equal(f.rates, W)
    assert res.initial("pair", "ref", 1).attitudes.tolist() == \
        res.initial("pair", "matched", 1).attitudes.tolist()


def test_torque_matching_finds_the_closed_form_factor(tmp_path: Path) -> None:
    # u = -k vec(q) - c w from rest: the peak is k sin(theta/2) at t = 0 whatever c, so the
    # factor on k (c held) that gives the ref scenario's peak (k = 3) is exactly 3
    ver = run_engine(_load(_case(tmp_path)))
    ep, gains = ver.results.gain_scale("matched")
    assert ep.scale == pytest.approx(3.0, rel=2e-4) and ep.relative_error <= 1e-4
    assert gains.as_dict()["c"] == 2.0 and gains.as_dict()["k"] == pytest.approx(ep.scale)
    assert ver.results.case_for("pair", "matched").gains.as_dict() == gains.as_dict()
    assert [c.verdict for c in ver.claims] == ["holds"]
    peaks = dict((m.id, v.value) for m, v in ver.metrics)
    assert peaks["peak_ref"] == pytest.approx(3 * math.sin(TH / 2), rel=1e-9)
    mean = next(v for m, v in ver.metrics if m.id == "err_mean")
    per = [float(ver.results.run("pair", "ref", k).rate_error[-1]) for k in range(3)]
    assert mean.value == pytest.approx(float(np.mean(per))) and mean.evidence == "montecarlo"


@pytest.mark.parametrize("old, new, match", [
    ('scenario = "ref", formation', 'scenario = "nope", formation', "torque_matching.scenario"),
    ('formation = "pair", hold', 'formation = "nope", hold', "torque_matching.formation"),
    ('hold = ["c"]', 'hold = ["x"]', "hold as gains"),
    ("rtol = 1e-4", "rtol = 2.0", "rtol"),
    (', {q = [0, 0, 0], rate = [0, 0.2, 0]}]', ']', "initial"),
    ('draws = "euler-uniform"', 'draws = "euler-uniform"\nrate_sigma = 0.1', "euler-uniform"),
    ('montecarlo = "mean"', 'montecarlo = "median"', "montecarlo"),
])
def test_bad_keys_are_refused_in_one_line(tmp_path: Path, old: str, new: str, match: str) -> None:
    assert old in CASE
    with pytest.raises(InputError, match=match):
        _load(_case(tmp_path, CASE.replace(old, new)))


ORDER = """
[[metrics]]
id = "order"
metric = "times_in_order"
scenarios = "ref, matched"
measure = "angle"
threshold_deg = 5.0
[[metrics]]
id = "order_mc"
metric = "times_in_order"
scenarios = "matched, ref"
measure = "euler_error"
threshold_deg = 5.0
montecarlo = "mean"
[[metrics]]
id = "scale"
metric = "gain_scale"
scenario = "matched"
[[metrics]]
id = "noscale"
metric = "gain_scale"
"""


def test_times_in_order_and_gain_scale(tmp_path: Path) -> None:
    from formsync_design.analysis.equal_torque import in_order
    from formsync_design.verify.metrics_attitude import euler_error_time

    ver = run_engine(_load(_case(tmp_path, CASE + ORDER)))
    v = {m.id: x for m, x in ver.metrics}
    res = ver.results
    t = [res.run("pair", s).time_to(5.0) for s in ("ref", "matched")]
    assert v["order"].value == (1.0 if in_order(t) else 0.0)
    per = [in_order([euler_error_time(res.run("pair", s, k), 5.0) for s in ("matched", "ref")])
           for k in range(3)]
    assert v["order_mc"].value == pytest.approx(sum(per) / 3)
    assert v["scale"].value == pytest.approx(3.0, rel=2e-4) and v["noscale"].value is None
    with pytest.raises(InputError, match="scenarios"):
        _load(_case(tmp_path, CASE + ORDER.replace('"ref, matched"', '"ref, x"')))
