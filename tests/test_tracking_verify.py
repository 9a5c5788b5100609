"""The fly-around engine case (the tracking form of the engine), the certificates and
``formsync verify`` (issues 14 and 23).

* case files: strict validation, one-line errors (exit 2), the scenarios' overrides;
* the claims' predicates on constructed metric values (both verdicts reachable, unknown is
  undecided);
* the tracking form on a short case: the metrics against the run measured independently;
* the attitude certificate: certified for the case's box; every point sampled inside the
  box satisfies the certified Lyapunov inequality numerically (an independent check of the
  vertex argument); an impossible rate bound is not certified; the LQR margins hold;
* ``formsync verify`` exit statuses; the whole verification on a short case (slow).
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from formsync_design.analysis.tracking import (
    CertStatus,
    attitude_certificate,
    orbit_certificate,
)
from formsync_design.cli.main import main
from formsync_design.derive.tracking import derive_tracking_attitude
from formsync_design.errors import InputError
from formsync_design.models.orbit import MarginStatus
from formsync_design.resources import case_file
from formsync_design.verify.engine import judge, run_engine
from formsync_design.verify.enginecase import load_engine_case
from formsync_design.verify.metrics import MetricValue
from formsync_design.verify.tracking_case import load_flyaround_case

CASE = load_flyaround_case()
TEXT = case_file("zhang2014_flyaround").read_text()
#: the base case of the shipped file (everything before its scenarios)
BASE = TEXT[:TEXT.index("# ------------------------------------------------------------"
                        "---- scenarios")]


def short_case(tf: float, steady: float, rest: str) -> str:
    """The shipped base case over ``tf`` (steady state from ``steady``) with ``rest``."""
    return BASE.replace("tf = 18000.0", f"tf = {tf:.1f}").replace(
        "steady_from = 1000.0", f"steady_from = {steady:.1f}") + rest


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "c.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("old, new, needle", [
    ('kind = "engine"', 'kind = "formation2"', "expected [case] kind one of"),
    ("mass = 2000.0", "mass = -1.0", "expected spacecraft.mass > 0"),
    ("r_u = 6400.0", "r_u = 6400.0\nk_x = 1.0", "expected gains among the design's"),
    ('predicate = "minp_nominal >= 0.9"', 'predicate = "minp_nominal >="', "predicate"),
    ('allocation = "pinv-shift"', 'allocation = "magic"', "expected simulation.allocation"),
    ("half_size = 1.0", "half_size = 1.0\ncolour = 1", "expected keys among"),
    ('metric = "fuel"', 'metric = "joy"', "expected metrics[18].metric among"),
    ('metric = "fuel"', 'metric = "peak_torque"', "applies to the relative-orbit design"),
    ('scenario = "lp"', 'scenario = "nope"', "expected metrics[136].scenario among"),
    ("{ carry = true }", "{ steady_from = 5.0 }", "expected scenarios[10].simulation keys"),
    ("{ half_size = 0.75 }", "{ half_size = -0.75 }", "expected thrusters.half_size > 0"),
    ('name = "r_u-x4"', 'name = "nominal"', "once"),
    ("tf = 18000.0", "tf = 18000.1", "whole number of samples"),
])
def test_bad_case_files_are_one_line_input_errors(tmp_path, old, new, needle):
    assert old in TEXT
    p = _write(tmp_path, TEXT.replace(old, new, 1))
    if "kind one of" in needle:  # checked by formsync verify before the loader
        assert main(["verify", str(p), "--out", str(tmp_path / "o")]) == 2
        assert not (tmp_path / "o").exists()
        return
    with pytest.raises(InputError) as e:
        load_engine_case(p)
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_case_values_and_scenarios():
    case = load_engine_case(case_file("zhang2014_flyaround"))
    assert type(case).__name__ == "TrackingEngineCase" and case.form.name == "relative-orbit"
    sc = case.tracking.scenario
    assert sc.layout.count == 16 and sc.gains["K_d"] == (1628.0, 1461.0, 1752.5)
    assert len(case.scenarios) == 14 and len(case.claims) == 11
    s2 = case.scenario("inertia-1.1").case.scenario
    assert np.allclose(s2.inertia, 1.1 * sc.inertia) and np.allclose(s2.law_inertia, sc.inertia)
    assert case.scenario("min-pulse-60ms").case.options.min_pulse == 0.06
    lay = case.scenario("half-edge-1.5").case.scenario.layout
    assert np.isclose(np.abs(lay.positions).max(), 1.5)
    assert case.scenario("r_u-x4").case.scenario.gains["r_u"] == (25600.0,)
    assert case.scenario("lp").case.options.allocation == "lp"
    # every scenario but its overrides is the base case
    assert case.scenario("nominal").case.options == case.tracking.options


def test_claim_predicates():
    case = load_engine_case(case_file("zhang2014_flyaround"))
    claims = {c.id: c for c in case.claims}

    def verdict(cid: str, **vals: float | None) -> str:
        return judge(claims[cid], {k: MetricValue(v, "1", "simulation")
                                   for k, v in vals.items()}).verdict

    assert verdict("rate_error", rate_nominal=0.04 * 2) == "holds"  # on the boundary
    assert verdict("rate_error", rate_nominal=0.04 / 2) == "holds"
    assert verdict("rate_error", rate_nominal=0.04 * 2.01) == "fails"
    assert verdict("delta_v", dv_nominal=15.8065 * 0.89) == "fails"
    assert verdict("delta_v", dv_nominal=15.8065 * 1.09) == "holds"
    assert verdict("min_pulse", minp_nominal=0.89) == "fails"
    assert verdict("pointing", point_nominal=1.01) == "fails"
    assert verdict("fuel", fuel_nominal=None) == "undecided"  # a diverged run


def test_the_form_measures_a_short_run_as_the_run_itself():
    """The engine's metrics on a 40 s case against the run simulated and measured here."""
    from formsync_design.sim.tracking import simulate_flyaround

    rest = "\n".join([
        '[[scenarios]]', 'name = "base"', '[[scenarios]]', 'name = "clip"',
        'simulation = { allocation = "pinv-clip" }',
        '[[metrics]]', 'id = "dv"', 'metric = "delta_v"',
        '[[metrics]]', 'id = "fuel"', 'metric = "fuel"',
        '[[metrics]]', 'id = "dv_clip"', 'metric = "delta_v"', 'scenario = "clip"',
        '[[metrics]]', 'id = "pos"', 'metric = "steady_position_error"',
        '[[metrics]]', 'id = "gap"', 'metric = "fuel_of_delta_v"', 'delta_v = 1.0',
        '[[claims]]', 'id = "cheap"', 'text = "little fuel"', 'predicate = "fuel < 100 and dv > 0"',
        ""])
    import tempfile

    d = Path(tempfile.mkdtemp())
    p = d / "short.toml"
    p.write_text(short_case(40.0, 20.0, rest))
    ver = run_engine(load_engine_case(p))
    v = {m.id: val.value for m, val in ver.metrics}
    runs = {}
    for sc, key in (("base", "dv"), ("clip", "dv_clip")):
        c = ver.case.scenario(sc).case
        runs[sc] = r = simulate_flyaround(c.scenario, c.options, c.spec)
        # independent: the impulses summed here, over the mass
        assert math.isclose(v[key], float(r.orbit.impulses.sum()) / c.scenario.mass, rel_tol=1e-12)
    assert v["dv_clip"] != v["dv"]
    assert math.isclose(v["fuel"], v["dv"] * 2000.0 / 2900.0, rel_tol=1e-12)
    assert math.isclose(v["gap"], 2000.0 / 2900.0, rel_tol=1e-12)
    t, x = runs["base"].t, runs["base"].orbit.outputs["dX"]
    assert v["pos"] == float(np.abs(x[t >= 20.0][:, :3]).max())
    assert [c.verdict for c in ver.claims] == ["holds"] and ver.claims[0].basis == "evidence"
    assert ver.results.simulated == ["base", "clip"]


def test_attitude_certificate_is_sound_inside_its_box():
    cert = attitude_certificate(CASE, rate_samples=100)
    assert cert.status == CertStatus.CERTIFIED and cert.vertices == 128 and cert.alpha > 0
    der = derive_tracking_attitude(CASE.spec)
    s = der.symbols
    import sympy as sp

    p1, p2, p3 = (float(v) for v in cert.p)
    alpha = float(cert.alpha)
    args = [s["k_p"], *s["K_d"], *s["J"], *s["J_hat"], *s["omega_di"], *s["omega_di_dot"]]
    a0f = sp.lambdify(args, der.A0, "numpy")
    nf = sp.lambdify(args, der.N, "numpy")
    rng = np.random.default_rng(11)
    jh = np.diag(CASE.scenario.inertia)
    box = cert.box
    for _ in range(300):
        kp = rng.uniform(*map(float, box["k_p"]))
        kd = [rng.uniform(*map(float, b)) for b in box["K_d"]]
        j = [rng.uniform(*map(float, b)) for b in box["J"]]
        w = [rng.uniform(-1, 1) * float(b) for b in box["W"]]
        a = [rng.uniform(-1, 1) * float(b) for b in box["A"]]
        vals = [kp, *kd, *j, *jh, *w, *a]
        a_full = np.array(a0f(*vals), float)
        a_full[3:] += np.diag(1 / np.array(j)) @ np.array(nf(*vals), float)
        jd = np.diag(j)
        pm = np.block([[p1 * kp * np.eye(3), p2 * jd], [p2 * jd, p3 * jd]])
        lyap = a_full.T @ pm + pm @ a_full + 2 * alpha * pm
        assert np.linalg.eigvalsh(pm).min() > 0
        assert np.linalg.eigvalsh(lyap).max() < 0


def test_attitude_certificate_refuses_an_impossible_rate_bound():
    huge = replace(CASE, certificate={**CASE.certificate, "rate_margin": 1e5})
    cert = attitude_certificate(huge, rate_samples=50)
    assert cert.status == CertStatus.NOT_CERTIFIED and cert.reason


def test_orbit_certificate():
    oc = orbit_certificate(CASE)
    assert oc.margins.status == MarginStatus.HOLD and oc.riccati_residual < 1e-10
    assert oc.sampled_spectral_radius < 1 and oc.max_real_part < 0


def test_verify_refuses_a_bad_out_folder(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["verify", "zhang2014_flyaround", "--out", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "expected --out to be a folder" in err[0]


@pytest.mark.slow
def test_verify_a_short_case_end_to_end(tmp_path, capsys):
    text = TEXT.replace("tf = 18000.0", "tf = 1200.0").replace("steady_from = 1000.0",
                                                                "steady_from = 200.0")
    p = tmp_path / "short.toml"
    p.write_text(text)
    rc = main(["verify", str(p), "--out", str(tmp_path / "o"), "--format", "json"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    vals = {m["id"]: m["value"] for m in doc["metrics"]}
    assert vals["att_box"] == "certified" and vals["vdot"] == "holds"
    assert vals["fuel_lp"] < vals["fuel_nominal"]
    assert doc["certificates"][0]["attitude"]["status"] == "certified"
    assert {c["id"] for c in doc["claims"]} >= {"delta_v", "pointing", "min_pulse"}
    md = (tmp_path / "o" / "short-verification.md").read_text()
    assert md.startswith("<!-- formsync verify: case=short.toml -->")
    assert len(list((tmp_path / "o" / "figures" / "short-verification").glob("*.png"))) == 7
    strict = main(["verify", str(p), "--out", str(tmp_path / "o"), "--strict"])
    assert strict == (0 if doc["all_hold"] else 1)
