"""The fly-around case file, its claims, the certificates and ``formsync verify`` (issue 14).

* case files: strict validation, one-line errors (exit 2), sensitivity variants;
* claim judging rules on constructed metrics (both verdicts reachable);
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
from formsync_design.verify.tracking_case import apply_variant, load_flyaround_case
from formsync_design.verify.tracking_claims import Verdict, judge

CASE = load_flyaround_case()
TEXT = case_file("zhang2014_flyaround").read_text()


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "c.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("old, new, needle", [
    ('kind = "flyaround"', 'kind = "formation2"', "expected [case] kind one of"),
    ("mass = 2000.0", "mass = -1.0", "expected spacecraft.mass > 0"),
    ("r_u = 6400.0", "r_u = 6400.0\nk_x = 1.0", "expected gains among the design's"),
    ('match = "rel:0.10"', 'match = "about"', "expected claims.delta_v.match"),
    ('allocation = "pinv-shift"', 'allocation = "magic"', "expected simulation.allocation"),
    ("half_size = 1.0", "half_size = 1.0\ncolour = 1", "expected keys among"),
    ('quantity = "fuel_kg"', 'quantity = "joy"', "expected claims.published.quantity one of"),
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
        load_flyaround_case(p)
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_case_values_and_variants():
    sc = CASE.scenario
    assert sc.layout.count == 16 and sc.gains["K_d"] == (1628.0, 1461.0, 1752.5)
    assert len(CASE.published) == 6 and len(CASE.qualitative) == 5
    labels = [v.label for v in CASE.sensitivity]
    v = CASE.sensitivity[labels.index("plant inertia +10 % (the law keeps the printed J)")]
    s2, _ = apply_variant(CASE, v)
    assert np.allclose(s2.inertia, 1.1 * sc.inertia) and np.allclose(s2.law_inertia, sc.inertia)
    v = CASE.sensitivity[labels.index("minimum pulse 60 ms")]
    assert apply_variant(CASE, v)[1].min_pulse == 0.06
    v = CASE.sensitivity[labels.index("layout half-edge 1.5 m")]
    assert np.isclose(np.abs(apply_variant(CASE, v)[0].layout.positions).max(), 1.5)


def test_judging_rules():
    metrics = {c["quantity"]: c["value"] for c in CASE.published}
    metrics.update({c["quantity"]: c["bound"] for c in CASE.qualitative})
    assert all(r.verdict == Verdict.HOLDS for r in judge(CASE, metrics))  # on the boundary
    bad = dict(metrics, rate_error_deg_s=0.04 * 2.01, delta_v_m_s=15.8065 * 0.89,
               min_pulse_fraction=0.89, pointing_error_deg=1.01, fuel_kg=math.nan)
    verdicts = {r.id: r.verdict for r in judge(CASE, bad)}
    assert {k for k, v in verdicts.items() if v == Verdict.FAILS} == {
        "rate_error", "delta_v", "min_pulse", "pointing", "fuel"}


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
    text = text[:text.index("[sensitivity]")] + (
        '[sensitivity]\ncases = [{ label = "minimum pulse 60 ms", thrusters = { min_pulse = '
        '0.06 } }]\n\n' + text[text.index("[certificate]"):])
    p = tmp_path / "short.toml"
    p.write_text(text)
    rc = main(["verify", str(p), "--out", str(tmp_path / "o"), "--format", "json"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["attitude_certificate"]["status"] == "certified"
    assert {c["id"] for c in doc["claims"]} >= {"delta_v", "pointing", "min_pulse"}
    md = (tmp_path / "o" / "short-verification.md").read_text()
    assert md.startswith("<!-- formsync verify: case=short.toml -->")
    assert len(list((tmp_path / "o" / "figures" / "short-verification").glob("*.png"))) == 7
    strict = main(["verify", str(p), "--out", str(tmp_path / "o"), "--strict"])
    assert strict == (0 if doc["all_hold"] else 1)
