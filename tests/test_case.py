"""Case files: the paper's transcription and strict validation."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from formsync_design.errors import InputError
from formsync_design.models.disturbances import Orbit, paper_umg_magnitude
from formsync_design.verify.case import default_case_path, load_case, parse_case


@pytest.fixture(scope="module")
def raw():
    """The paper's case in the formation layout (the engine case file without its engine
    tables, its design key and the agent kernel's integrator keys)."""
    d = tomllib.loads(default_case_path().read_text())
    out = {k: d[k] for k in ("case", "gains", "orbit", "disturbance", "simulation", "spacecraft")}
    out["case"] = {k: v for k, v in d["case"].items() if k not in ("kind", "design")}
    out["simulation"] = {k: v for k, v in d["simulation"].items()
                         if k not in ("integrator", "rtol", "atol")}
    return out


def test_paper_case_transcription():
    c = load_case()
    assert c.n == 8 and c.graph_spec == "ring:8"
    # spot checks against the paper's section 3 (Table 1, J_1, J_7, gains)
    np.testing.assert_array_equal(c.inertias[0], [[50, 0, 4], [0, 55, 0], [4, 0, 60]])
    np.testing.assert_array_equal(c.inertias[6], [[61, 2, 0.3], [2, 54, 0.2], [0.3, 0.2, 60]])
    np.testing.assert_array_equal(c.rates[0], [0.85, -0.43, 0.77])
    np.testing.assert_array_equal(c.attitudes[7, :3], [-0.3, 0.2, 0.6])
    assert (c.gains.K_q, c.gains.K_o, c.gains.beta, c.gains.K_v) == (0.4, 1.6, 0.3, (0.01,) * 8)
    assert c.orbit.altitude == 400e3
    assert c.options.switch == "sat" and c.options.phi == 0.01 and c.options.tf == 200.0
    assert c.options.torque_limit is None
    assert any("phi" in a for a in c.assumptions) and any("ring:8" in a for a in c.assumptions)


def test_q0_is_positive_root():
    c = load_case()
    q = c.attitudes[:, :3]
    np.testing.assert_allclose(c.attitudes[:, 3], np.sqrt(1 - (q**2).sum(1)), rtol=0, atol=1e-16)
    assert np.all(c.attitudes[:, 3] > 0)


def test_paper_disturbance_magnitude():
    c = load_case()
    f = c.formation()
    for i in range(8):
        m = float(np.linalg.eigvalsh(c.inertias[i])[-1]) * 30 * 3.986004418e14 / (6778137.0**3)
        assert f.disturbance.harmonic[i, 0, 0] == pytest.approx(m, rel=1e-12)
        assert paper_umg_magnitude(c.inertias[i], Orbit()) == pytest.approx(m, rel=1e-12)
    np.testing.assert_allclose(f.disturbance.bound(), 1.2 * f.disturbance.harmonic[:, 0, 0])


def test_a_claims_table_of_a_simulation_case_is_refused_not_dropped(raw):
    # nothing reads claims outside an engine case: a [claims] table would be silently ignored
    d = dict(raw)
    d["claims"] = {"convergence": {"paper": 100.0}}
    with pytest.raises(InputError, match=r"received unknown \[claims\]"):
        parse_case(d)
    # an engine case's [[claims]] are the engine's, not read by the simulation case reader
    d["case"] = {**d.get("case", {}), "kind": "engine"}
    d["claims"] = [{"id": "c", "text": "t", "predicate": "x < 1"}]
    assert parse_case(d).n == parse_case(dict(raw)).n


def _mutate(raw, fn):
    import copy

    d = copy.deepcopy(raw)
    fn(d)
    return d


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d.update(extra={}), "unknown \\[extra\\]"),
        (lambda d: d["gains"].update(K_x=1), "unknown \\['K_x'\\]"),
        (lambda d: d["spacecraft"][0].update(q=[0.9, 0.5, 0.1]), "\\|q\\| < 1 for spacecraft 1"),
        (lambda d: (d["spacecraft"][1].pop("q"), d["spacecraft"][1].update(quaternion=[0, 0, 0.6, 0.8 * 1.1])),
         "unit quaternion for spacecraft 2"),
        (lambda d: (d["spacecraft"][1].pop("q"), d["spacecraft"][1].update(quaternion=[0, 0, 0.6, -0.8])),
         "q0 > 0 for spacecraft 2"),
        (lambda d: d["spacecraft"][2].update(quaternion=[0, 0, 0, 1]), "exactly one of"),
        (lambda d: d["spacecraft"][3].update(inertia=[[1, 0, 0], [0, -1, 0], [0, 0, 1]]),
         "positive definite inertia for spacecraft 4"),
        (lambda d: d["spacecraft"][3].update(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]),
         "symmetric inertia for spacecraft 4"),
        (lambda d: d["spacecraft"][3].update(inertia=[[1, 0], [0, 1]]), "3x3 matrix"),
        (lambda d: d["spacecraft"][0].update(rate=[1, "a", 2]), "finite number"),
        (lambda d: d["case"].update(graph="ring:5"), "graph of 8 spacecraft"),
        (lambda d: d["gains"].update(K_v=[0.01] * 3), "8 numbers for gains.K_v"),
        (lambda d: d["gains"].update(K_o=-1.0), "positive finite gain K_o"),
        (lambda d: d["gains"].pop("beta"), "gains.beta"),
        (lambda d: d["simulation"].update(tf=-5.0), "positive finite tf"),
        (lambda d: d["simulation"].update(switch="relay"), "switch"),
        (lambda d: d["simulation"].update(boundary_layer=0), "positive finite phi"),
        (lambda d: d["disturbance"].update(model="solar"), "disturbance.model"),
        (lambda d: d["disturbance"].update(signs=[1, 2, 1]), "signs"),
        (lambda d: d["orbit"].update(altitude_km=-3.0), "altitude"),
        (lambda d: d.update(spacecraft=[]), "at least two"),
    ],
)
def test_bad_cases(raw, mutate, match):
    with pytest.raises(InputError, match=match):
        parse_case(_mutate(raw, mutate))


def test_other_disturbance_tables(raw):
    c = parse_case(_mutate(raw, lambda d: d.update(disturbance={"model": "constant", "vector": [1e-3, 0, 0]})))
    assert c.formation().disturbance.kind == "constant"
    c = parse_case(_mutate(raw, lambda d: d.update(
        disturbance={"model": "harmonic", "amplitude": [1e-3, 1e-3, 0], "frequency": [0.1, 0.2, 0.3]})))
    assert c.formation().disturbance.bound().max() == pytest.approx(1e-3)
    c = parse_case(_mutate(raw, lambda d: d.update(disturbance={"model": "gravity-gradient"})))
    d = c.formation().disturbance
    assert d.gravity_gradient and d.bound(c.inertias).max() > 0
    with pytest.raises(InputError, match="vector"):
        parse_case(_mutate(raw, lambda d: d.update(disturbance={"model": "constant"})))


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_case(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[case\nname = 1")
    with pytest.raises(InputError, match="valid TOML"):
        load_case(bad)


def test_formation_overrides():
    c = load_case()
    f = c.formation("complete:8", "gravity-gradient")
    assert f.graph.name == "complete:8" and f.disturbance.gravity_gradient
    assert math.isclose(float(f.initial_state()[3]), float(c.attitudes[0, 3]))


# ---------------------------------------------------------------------------
# the one TOML loader and the [case] spec key
# ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "content, match",
    [
        (b"\x00\x01\x02binary", "a binary file"),
        ("[case]\nname = 'caf\u00e9'\n".encode("latin-1"), "UTF-8"),
        (b"[case]\nname = \"x\"\ngraph = \n", r"line 3"),
    ],
)
def test_unreadable_case_files_give_one_line(tmp_path, content, match):
    p = tmp_path / "c.toml"
    p.write_bytes(content)
    with pytest.raises(InputError, match=match) as e:
        load_case(p)
    assert "\n" not in str(e.value)
    with pytest.raises(InputError, match="not a file"):
        load_case(tmp_path)


def test_case_spec_is_resolved_against_the_case_file(raw, tmp_path):
    import hashlib

    from formsync_design.tomlio import load_toml

    (tmp_path / "sub").mkdir()
    from formsync_design.resources import design_file

    (tmp_path / "sub" / "d.py").write_text(design_file("liang2016").read_text())
    from formsync_design.spec.trust import trusting

    with trusting(tmp_path / "sub" / "d.py"):  # a design file a case names runs only if trusted
        c = parse_case(_mutate(raw, lambda d: d["case"].update(spec="sub/d.py")),
                       str(tmp_path / "c.toml"))
    assert c.spec == str(tmp_path / "sub" / "d.py")
    with pytest.raises(InputError, match="case.spec"):
        parse_case(_mutate(raw, lambda d: d["case"].update(spec="nope.py")), str(tmp_path / "c.toml"))
    assert load_case().spec == "liang2016"
    assert load_case().digest == hashlib.sha256(default_case_path().read_bytes()).hexdigest()
    assert load_toml(default_case_path())["case"]["name"] == "liang2016"


def test_unlimited_torque_word(raw):
    c = parse_case(_mutate(raw, lambda d: d["simulation"].update(torque_limit="unlimited")))
    assert c.options.torque_limit is None


def test_an_engine_case_file_is_read_in_the_formation_layout(raw):
    """The paper's engine case (verification/liang2016.toml) gives the formation readers the
    same case as its formation-layout tables: the engine tables and the agent kernel's
    integrator keys are not theirs."""
    full = load_case()
    alone = parse_case(raw)
    assert full.options == alone.options and full.options.integrator == "auto"
    assert full.gains == alone.gains
    assert np.array_equal(full.inertias, alone.inertias)
    assert np.array_equal(full.attitudes, alone.attitudes)
