"""``formsync verify`` of an ``engine`` case end to end: a tiny case of the shipped agent
design ma_quat_smc, its report, verdicts recomputed independently, a byte-identical rerun,
and bad input refused with one line (exit 2)."""

from __future__ import annotations

import hashlib
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from formsync_design.cli.main import main

CASE = """
[case]
kind = "engine"
name = "tiny"
title = "Quaternion sliding-mode coordination, tiny case"
source = "test"
design = "ma_quat_smc"
graph = "ring:3"
assumptions = ["three spacecraft of the test"]

[gains]
K1 = 1.15
K2 = 0.15
P2 = 0.03

[simulation]
tf = 12.0
output_step = 0.1
step = 0.01
switch = "sat"
boundary_layer = 0.01
angle_tol = 1.0
rate_tol = 0.01

[disturbance]
model = "none"

[[spacecraft]]
inertia = [[50, 0, 0], [0, 55, 0], [0, 0, 60]]
rate = [0.01, 0, 0]
q = [0.1, 0.2, 0.0]

[[spacecraft]]
inertia = [[52, 0, 0], [0, 54, 0], [0, 0, 62]]
rate = [0, 0.01, 0]
q = [-0.1, 0.0, 0.1]

[[spacecraft]]
inertia = [[53, 0, 0], [0, 54, 0], [0, 0, 58]]
rate = [0, 0, 0.01]
q = [0.0, -0.1, 0.1]

[[formations]]
name = "ring3"

[[formations]]
name = "cycle4"
graph = "cycle:4"

[[scenarios]]
name = "nominal"

[[scenarios]]
name = "short"
description = "a horizon too short to converge"
simulation = {tf = 1.0}

[montecarlo]
runs = 2
seed = 7
max_angle = 20
max_rate = 0.01

[[metrics]]
id = "cert"
metric = "formation_certificate"

[[metrics]]
id = "decay"
metric = "certified_decay_rate"
formation = "cycle4"

[[metrics]]
id = "tconv"
metric = "convergence_time"

[[metrics]]
id = "tshort"
metric = "convergence_time"
scenario = "short"

[[metrics]]
id = "err"
metric = "final_attitude_error_deg"

[[metrics]]
id = "peak4"
metric = "peak_torque"
formation = "cycle4"

[[metrics]]
id = "mcfrac"
metric = "mc_converged_fraction"

[[claims]]
id = "certified"
text = "the formation is locally exponentially stable on the directed cycle"
source = "Theorem 1"
predicate = 'cert == "certified" and decay > 0'

[[claims]]
id = "fast"
text = "converges within 11 s"
source = "Fig. 2"
predicate = "tconv < 11"

[[claims]]
id = "short"
text = "converges within 0.5 s"
predicate = "tshort < 0.5"

[[claims]]
id = "later"
text = "takes longer than 20 s"
predicate = "tshort > 20"

[[claims]]
id = "mc"
text = "every run converges, and the torque stays small"
predicate = "mcfrac == 1 and err < 1 and peak4 <= 50"
"""


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


def _write(tmp_path: Path, text: str, name: str = "tiny.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_engine_case_end_to_end(tmp_path, capsys):
    case = _write(tmp_path, CASE)
    out = tmp_path / "out"
    assert main(["verify", str(case), "--out", str(out), "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    md = out / "tiny-verification.md"
    text = md.read_text()
    assert text.startswith("<!-- formsync verify: case=")
    for section in ("## Assumptions", "## Formations and their certificates",
                    "## Scope of the simulation evidence", "## Metrics", "## Claims",
                    "## Semantics", "angle_tol"):
        assert section in text
    assert (out / "figures" / "tiny-verification" / "ring3-nominal-attitude.png").is_file()
    # the two scenarios certify the same system (same gains): one row each formation, naming
    # both scenarios, and one scope line each; the law has sgn, realised by sat in the runs
    rows = [ln for ln in text.splitlines() if ln.startswith("| ring3 |") or
            ln.startswith("| cycle4 |")]
    assert [r.split(" | ")[3] for r in rows if "**" in r] == ["nominal, short"] * 2
    assert text.count("- ring3 / nominal, short: ") == 1
    assert "switch sat, boundary layer 0.01" in text

    # the verdicts, recomputed here from the library's simulation and certificate directly
    from formsync_design.certify.formation import certify_formation
    from formsync_design.gains import GainBox
    from formsync_design.sim.agents import simulate_agents
    from formsync_design.verify.agentcase import parse_agent_case
    from formsync_design.verify.enginegraphs import directed_cycle

    data = tomllib.loads(CASE)
    for k in ("formations", "scenarios", "montecarlo", "metrics", "claims"):
        data.pop(k)
    ac = parse_agent_case(data, str(case))
    r = simulate_agents(ac.design, ac.formation(), ac.options)
    box = GainBox.parse({"K1": "1.15", "K2": "0.15", "P2": "0.03"})
    c4 = ac.cycled(4)
    cert = certify_formation(ac.design, directed_cycle(4), c4.inertias, box, switch="sat",
                             phi="0.01")
    claims = {c["id"]: c for c in doc["claims"]}
    metrics = {m["id"]: m for m in doc["metrics"]}
    assert metrics["tconv"]["value"] == r.convergence_time
    assert claims["fast"]["verdict"] == ("holds" if r.convergence_time < 11 else "fails")
    assert claims["fast"]["basis"] == "evidence" and claims["fast"]["evidence"] == ["simulation"]
    assert str(cert.status) == "certified" and cert.decay > 0
    assert metrics["decay"]["value"] == cert.decay and metrics["decay"]["bound"] == "lower"
    assert claims["certified"]["verdict"] == "holds"
    assert claims["certified"]["basis"] == "proof"
    # the 1 s horizon does not converge: >= 1 s refutes "< 0.5 s", decides nothing on "> 20 s"
    assert metrics["tshort"]["bound"] == "lower" and metrics["tshort"]["value"] == 1.0
    assert claims["short"]["verdict"] == "fails"
    assert claims["later"]["verdict"] == "undecided"
    assert metrics["err"]["value"] == pytest.approx(float(r.attitude_error[-1]), abs=0)
    assert claims["mc"]["evidence"] == ["montecarlo", "simulation"]
    assert doc["all_hold"] is False
    assert np.isfinite(metrics["peak4"]["value"])

    # rerun: byte-identical report and figures; --strict exits 1 (not every claim holds)
    before = _digests(out)
    assert main(["verify", str(case), "--out", str(out)]) == 0
    assert _digests(out) == before
    capsys.readouterr()
    assert main(["verify", str(case), "--out", str(out), "--strict"]) == 1


BAD = [
    ('id = "mcfrac"\nmetric = "mc_converged_fraction"', 'id = "mcfrac"\nmetric = "nonsense"',
     "metric among"),
    ('predicate = "tconv < 11"', 'predicate = "__import__(\'os\').system(\'x\') < 1"', "column"),
    ('predicate = "tconv < 11"', 'predicate = "tconv < 11 < 12"', "one comparison"),
    ('predicate = "tconv < 11"', 'predicate = "nothing < 11"', "metric id of the case"),
    ("max_rate = 0.01", "max_rate = 1e9", "magnitude"),
    ("runs = 2", "runs = 0", "runs"),
    ("runs = 2", "runs = 2.5", "integer"),
    ("seed = 7", "seed = -1", "seed"),
    ('name = "cycle4"', 'name = "../x"', "formations[2].name"),
    ('name = "short"', 'name = "nominal"', "once"),
    ('id = "tshort"', 'id = "tconv"', "once"),
    ('graph = "cycle:4"', 'graph = "cycle:1"', "cycle:N"),
    ('graph = "cycle:4"', 'graph = "nope.txt"', ""),
    ('graph = "cycle:4"', 'graph = "cycle:9999999"', "at most 2000"),
    ('graph = "cycle:4"', 'graph = "cycle:4"\npinning = [1, 0, 0, 0]', "no pinning"),
    ("simulation = {tf = 1.0}", "simulation = {tf = -1.0}", "tf"),
    ("simulation = {tf = 1.0}", "gains = {K9 = 1.0}", "gains"),
    ("simulation = {tf = 1.0}", "colour = 1", "unknown"),
    ('formation = "cycle4"\n\n[[metrics]]\nid = "tconv"',
     'formation = "cycle5"\n\n[[metrics]]\nid = "tconv"', "formation among"),
    ('id = "err"\nmetric = "final_attitude_error_deg"',
     'id = "err"\nmetric = "final_attitude_error_deg"\nto = "moon"', "one of"),
    ('id = "err"\nmetric = "final_attitude_error_deg"', 'id = "err"\nmetric = "transmissions"',
     "continuous"),
    ('id = "peak4"\nmetric = "peak_torque"', 'id = "peak4"\nmetric = "peak_torque"\nspacecraft = -1',
     ">= 0"),
    ('id = "cert"', 'id = "and"', "metrics[1].id"),
    ('name = "cycle4"', 'name = "cycle4"\ncertify = false', "certify = true"),
    ("K1 = 1.15", "K1 = [1.15, 1.2, 1.3]", "montecarlo.box"),
    ('name = "cycle4"', 'name = "cycle4"\ncertify = "no"', "true or false"),
    ('kind = "engine"', 'kind = "engine"\ncolour = 2', "unknown"),
]


@pytest.mark.parametrize("old, new, words", BAD)
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, old, new, words):
    assert old in CASE
    case = _write(tmp_path, CASE.replace(old, new, 1))
    assert main(["verify", str(case), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert not (tmp_path / "out" / "tiny-verification.md").exists()


def test_montecarlo_metric_needs_the_table(tmp_path, capsys):
    text = CASE.replace("[montecarlo]\nruns = 2\nseed = 7\nmax_angle = 20\nmax_rate = 0.01\n", "")
    assert main(["verify", str(_write(tmp_path, text)), "--out", str(tmp_path / "o")]) == 2
    assert "[montecarlo]" in capsys.readouterr().err


def test_the_documented_example_case_is_valid():
    from formsync_design.verify.enginecase import load_engine_case

    root = Path(__file__).resolve().parent.parent
    case = load_engine_case(root / "docs" / "engine" / "example.toml")
    assert [f.name for f in case.formations] == ["ring3", "cycle4"]
    assert case.case_for("cycle4", "disturbed").n == 4
    assert {c.id for c in case.claims} >= {"stable_on_both", "montecarlo"}


DAMPER = '''"""A rate damper; its case measures the final kinetic energy with a metric of its own."""
from formsync_design.verify.metrics import register_metric

FORM = "agent"
GAINS = {"k": {}}


def controller(v):
    return -v.k * v.J * v.w


@register_metric("test_damper_kinetic_energy", unit="J", evidence="simulation",
                 doc="sum of w_i^T J_i w_i / 2 at tf")
def kinetic_energy(ctx):
    r = ctx.run()
    return ctx.value(float(sum(w @ J @ w for w, J in zip(r.rates[-1], ctx.case.inertias)) / 2))
'''

DAMPER_CASE = """
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
[[spacecraft]]
inertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
rate = [0.1, 0, 0]
q = [0, 0, 0]
[[spacecraft]]
inertia = [[2, 0, 0], [0, 2, 0], [0, 0, 2]]
rate = [0, 0.05, 0]
q = [0, 0, 0]
[[metrics]]
id = "energy"
metric = "test_damper_kinetic_energy"
[[metrics]]
id = "cert"
metric = "formation_certificate"
[[claims]]
id = "damped"
text = "the kinetic energy decays below 1e-6 J in 5 s"
predicate = "energy < 1e-6"
[[claims]]
id = "stable"
text = "consensus is locally exponentially stable"
predicate = 'cert == "certified"'
"""


def test_a_design_file_registers_its_own_metric_and_undecided_stays_undecided(tmp_path, capsys):
    """A paper's own measurement without a library change; a marginal certificate (a damper
    has no attitude feedback) leaves the stability claim undecided, never failed."""
    from formsync_design.verify.metrics import METRICS

    (tmp_path / "damper.py").write_text(DAMPER)
    case = _write(tmp_path, DAMPER_CASE, "damper_case.toml")
    try:
        assert main(["verify", str(case), "--out", str(tmp_path / "o"), "--format", "json",
                     "--trust-design", str(tmp_path / "damper.py")]) == 0
        doc = json.loads(capsys.readouterr().out)
    finally:
        METRICS.pop("test_damper_kinetic_energy", None)
    m = {x["id"]: x for x in doc["metrics"]}
    c = {x["id"]: x for x in doc["claims"]}
    # k = 1, J w' = -J w: every rate decays as exp(-t), the energy as exp(-2t)
    want = 0.5 * (1 * 0.1**2 + 2 * 0.05**2) * np.exp(-10)
    assert m["energy"]["value"] == pytest.approx(want, rel=1e-4)
    assert c["damped"]["verdict"] == ("holds" if want < 1e-6 else "fails")
    assert m["cert"]["value"] is None and m["cert"]["detail"].startswith("undecided")
    # a damper's law has no switching function: the run's scope does not name one
    report = (tmp_path / "o" / "damper_case-verification.md").read_text()
    assert "no switching function" in report and "switch sat" not in report
    assert (c["stable"]["verdict"], c["stable"]["basis"]) == ("undecided", "evidence")


def test_design_option_replaces_the_case_design(tmp_path, capsys):
    """``--design`` runs the case with another design file: a damper twice as strong."""
    (tmp_path / "strong.py").write_text(DAMPER.replace("-v.k * v.J * v.w", "-2 * v.k * v.J * v.w")
                                        .replace("test_damper_kinetic_energy", "test_strong_energy"))
    (tmp_path / "damper.py").write_text(DAMPER)
    case = _write(tmp_path, DAMPER_CASE.replace("test_damper_kinetic_energy", "final_rate"),
                  "damper_case.toml")
    try:
        assert main(["verify", str(case), "--out", str(tmp_path / "o"), "--format", "json",
                     "--design", str(tmp_path / "strong.py")]) == 0
    finally:
        from formsync_design.verify.metrics import METRICS

        METRICS.pop("test_strong_energy", None)
    doc = json.loads(capsys.readouterr().out)
    assert doc["design"] == "strong"
    # the largest rate difference at tf: |(0.1, -0.05, 0)| e^(-2 tf)
    want = float(np.hypot(0.1, 0.05) * np.exp(-10))
    assert doc["metrics"][0]["value"] == pytest.approx(want, rel=1e-4)
    bad = _write(tmp_path, CASE.replace('design = "ma_quat_smc"', 'design = "nope"'))
    assert main(["verify", str(bad), "--out", str(tmp_path / "o2")]) == 2
    assert "design" in capsys.readouterr().err


def test_a_scenario_runs_another_design_with_its_own_gains(tmp_path, capsys):
    """``[[scenarios]] design``: a comparison method on the same spacecraft and formation (a
    damper with another gain name, so its gains table replaces the base's whole); each
    scenario's final rate difference is the analytic decay of its own design."""
    (tmp_path / "damper.py").write_text(DAMPER)
    (tmp_path / "other.py").write_text(
        DAMPER.replace('{"k": {}}', '{"c": {}}').replace("-v.k * v.J * v.w", "-v.c * v.J * v.w")
        .replace("test_damper_kinetic_energy", "test_other_energy"))
    text = DAMPER_CASE.replace("test_damper_kinetic_energy", "final_rate").replace(
        "[[metrics]]\nid = \"energy\"", """[[scenarios]]
name = "nominal"
[[scenarios]]
name = "other"
design = "other.py"
gains = {c = 3.0}
[[metrics]]
id = "other_rate"
metric = "final_rate"
scenario = "other"
[[metrics]]
id = "energy\"""", 1)
    case = _write(tmp_path, text, "damper_case.toml")
    try:
        trust = ["--trust-design", str(tmp_path / "damper.py"),
                 "--trust-design", str(tmp_path / "other.py")]
        assert main(["verify", str(case), "--out", str(tmp_path / "o"), "--format", "json",
                     *trust]) == 0
        doc = json.loads(capsys.readouterr().out)
        m = {x["id"]: x["value"] for x in doc["metrics"]}
        # |(0.1, -0.05, 0)| e^(-k tf), tf = 5: k = 1 for the base design, c = 3 for the other
        assert m["energy"] == pytest.approx(float(np.hypot(0.1, 0.05) * np.exp(-5)), rel=1e-4)
        assert m["other_rate"] == pytest.approx(float(np.hypot(0.1, 0.05) * np.exp(-15)),
                                                rel=1e-3)
        assert [s["overrides"].get("design") for s in doc["scenarios"]] == [None, "other.py"]
        # the other design's gains are required whole, and only its own are accepted
        for bad, words in (('gains = {c = 3.0}\n', "gains"), ("c = 3.0", "k = 1.0")):
            case.write_text(text.replace(bad, "" if words == "gains" else words, 1))
            assert main(["verify", str(case), "--out", str(tmp_path / "o2"), *trust]) == 2
            assert capsys.readouterr().err.count("error") == 1
    finally:
        from formsync_design.verify.metrics import METRICS

        METRICS.pop("test_damper_kinetic_energy", None)
        METRICS.pop("test_other_energy", None)


def test_scenarios_of_two_designs_with_the_same_gains_are_certified_apart(tmp_path, capsys):
    """The certificate is of the scenario's design: a damper (no attitude feedback: undecided,
    a marginal mode) and a PD law with the same gain name and value (certified) on the same
    formation must not share one certificate."""
    from formsync_design.verify.engine import run_engine
    from formsync_design.verify.enginecase import load_engine_case

    (tmp_path / "damper.py").write_text(DAMPER)
    (tmp_path / "pd.py").write_text(
        DAMPER.replace("return -v.k * v.J * v.w",
                       "s = sum((n.a * (v.q - n.q) for n in v.nbrs), 0 * v.q)\n"
                       "    return -v.k * v.J * v.w - v.k * s")
        .replace("test_damper_kinetic_energy", "test_pd_energy"))
    text = DAMPER_CASE.replace("[[metrics]]\nid = \"energy\"", """[[scenarios]]
name = "nominal"
[[scenarios]]
name = "pd"
design = "pd.py"
gains = {k = 1.0}
[[metrics]]
id = "cert_pd"
metric = "formation_certificate"
scenario = "pd"
[[metrics]]
id = "energy\"""", 1)
    try:
        ver = run_engine(load_engine_case(_write(tmp_path, text, "damper_case.toml"),
                                          trust=[tmp_path / "damper.py", tmp_path / "pd.py"]))
        certs = {s: c for _, s, c in ver.certificates}
        assert str(certs["nominal"].status) == "undecided"
        assert str(certs["pd"].status) == "certified"
    finally:
        from formsync_design.verify.metrics import METRICS

        METRICS.pop("test_damper_kinetic_energy", None)
        METRICS.pop("test_pd_energy", None)


SAMPLED = """
[case]
kind = "engine"
design = "selftrigger_mrp"
[graph]
arcs = [[1, 2, 1], [2, 1, 1], [2, 3, 1], [3, 2, 1], [1, 0, 1]]
[gains]
r = 0.5
m_f = 1.5
delta = 0.05
eps = 0.01
alpha = 0.1
eta0 = 0.05
[reference]
attitude = [0, 0, 0, 1]
rate = ["0.02*exp(-t/10)", "0", "0"]
[disturbance]
model = "none"
[simulation]
tf = 4.0
output_step = 0.1
rtol = 1e-8
atol = 1e-10
[[spacecraft]]
inertia = [[20, 0, 0], [0, 20, 0], [0, 0, 20]]
rate = [0.01, 0, 0]
q = [0.1, 0, 0]
[[spacecraft]]
inertia = [[25, 0, 0], [0, 25, 0], [0, 0, 25]]
rate = [0, 0.01, 0]
q = [0, 0.1, 0]
[[spacecraft]]
inertia = [[30, 0, 0], [0, 30, 0], [0, 0, 30]]
rate = [0, 0, 0.01]
q = [0, 0, 0.1]
[[formations]]
name = "case"
[[formations]]
name = "ring4"
graph = "ring:4"
pinning = [1, 0, 0, 0]
[[metrics]]
id = "tx"
metric = "transmissions"
[[metrics]]
id = "mie"
metric = "min_inter_event_time"
[[metrics]]
id = "err4"
metric = "final_attitude_error_deg"
formation = "ring4"
[[claims]]
id = "sparse"
text = "updates are at least 10 ms apart"
predicate = "mie >= 0.01 and tx > 0"
"""


def test_a_sampled_design_with_a_leader(tmp_path, capsys):
    """Transmissions and inter-event times of a self-triggered design with a leader, against
    the run's own trigger instants; the 4-ring is pinned and takes the case's spacecraft
    cycled; a formation without pinning is refused for a leader design."""
    from formsync_design.verify.engine import EngineResults, run_engine
    from formsync_design.verify.enginecase import load_engine_case

    case = load_engine_case(_write(tmp_path, SAMPLED, "st.toml"))
    ver = run_engine(case)
    vals = {m.id: v for m, v in ver.metrics}
    r = ver.results.runs[("case", "nominal")]
    times = [np.asarray(t) for t in r.trigger_times]
    assert vals["tx"].value == sum(len(t) for t in times)  # every update is a broadcast
    gaps = [float(np.diff(t).min()) for t in times if len(t) > 1]
    assert vals["mie"].value == pytest.approx(min(gaps), rel=1e-12)
    assert ver.claims[0].verdict == ("holds" if min(gaps) >= 0.01 else "fails")
    assert vals["err4"].detail.startswith("to the reference")
    assert isinstance(ver.results, EngineResults)
    c4 = case.case_for("ring4", "nominal")
    assert c4.n == 4 and (c4.inertias[3] == case.base.inertias[0]).all()
    bad = _write(tmp_path, SAMPLED.replace("pinning = [1, 0, 0, 0]\n", ""), "bad.toml")
    assert main(["verify", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "pinning" in capsys.readouterr().err


def test_results_are_computed_once_and_fs_verify_case_returns_the_engine_result(
        tmp_path, monkeypatch):
    import formsync_design as fs
    import formsync_design.certify.formation as cf
    import formsync_design.sim.agents as sa

    calls = {"sim": 0, "cert": 0}
    sim, cert = sa.simulate_agents, cf.certify_formation

    def counting_sim(*a, **k):
        calls["sim"] += 1
        return sim(*a, **k)

    def counting_cert(*a, **k):
        calls["cert"] += 1
        return cert(*a, **k)

    monkeypatch.setattr(sa, "simulate_agents", counting_sim)
    monkeypatch.setattr(cf, "certify_formation", counting_cert)
    (tmp_path / "damper.py").write_text(DAMPER.replace("test_damper_kinetic_energy",
                                                       "test_damper_energy_once"))
    text = DAMPER_CASE.replace("test_damper_kinetic_energy", "final_rate") + """
[[metrics]]
id = "peak"
metric = "peak_torque"
[[metrics]]
id = "effort"
metric = "control_effort"
[[metrics]]
id = "decay"
metric = "certified_decay_rate"
[[scenarios]]
name = "nominal"
[[scenarios]]
name = "quiet"
disturbance = {model = "none"}
"""
    try:
        ver = fs.verify_case(_write(tmp_path, text, "once.toml"), trust=[tmp_path / "damper.py"])
    finally:
        from formsync_design.verify.metrics import METRICS

        METRICS.pop("test_damper_energy_once", None)
    assert type(ver).__name__ == "EngineVerification"
    # four metrics on one run: one simulation; two scenarios with the same certificate inputs:
    # one certificate
    assert calls == {"sim": 1, "cert": 1}
    assert len(ver.certificates) == 2 and ver.certificates[0][2] is ver.certificates[1][2]


def test_a_metric_returning_the_wrong_kind_is_refused(tmp_path, capsys):
    from formsync_design.verify.metrics import METRICS

    bad = DAMPER.replace("test_damper_kinetic_energy", "test_damper_wrong").replace(
        "return ctx.value(float(sum(w @ J @ w for w, J in zip(r.rates[-1], ctx.case.inertias)) / 2))",
        'return ctx.value("large")')
    assert "large" in bad
    (tmp_path / "damper.py").write_text(bad)
    case = _write(tmp_path, DAMPER_CASE.replace("test_damper_kinetic_energy", "test_damper_wrong"),
                  "wrong.toml")
    try:
        assert main(["verify", str(case), "--out", str(tmp_path / "o"),
                     "--trust-design", str(tmp_path / "damper.py")]) == 2
    finally:
        METRICS.pop("test_damper_wrong", None)
    err = [ln for ln in capsys.readouterr().err.strip().splitlines() if "error" in ln]
    assert len(err) == 1 and "number value" in err[0]


def test_mutated_cases_are_read_or_refused_in_one_line(tmp_path):
    """Seeded mutations of the engine tables (wrong types, huge or non-finite numbers, code
    in texts, missing keys): the reader accepts the case or raises a one-line InputError."""
    from formsync_design.errors import InputError
    from formsync_design.verify.enginecase import parse_engine_case

    base = tomllib.loads(CASE)
    bad_values = ["x", 1e300, float("nan"), -1, 0, True, [1, 2], {"a": 1}, "__import__('os')",
                  "ring:0", "a < ", "", 2**70]
    rng = np.random.default_rng(2023)
    paths = [(t, i, k) for t in ("formations", "scenarios", "metrics", "claims")
             for i, row in enumerate(base[t]) for k in row] + [
                 ("montecarlo", None, k) for k in base["montecarlo"]]
    (tmp_path / "tiny.toml").write_text(CASE)
    refused = 0
    for _ in range(150):
        doc = tomllib.loads(CASE)
        for _ in range(int(rng.integers(1, 3))):
            t, i, k = paths[int(rng.integers(len(paths)))]
            row = doc[t] if i is None else doc[t][i]
            if rng.random() < 0.15:
                row.pop(k, None)
            else:
                row[k] = bad_values[int(rng.integers(len(bad_values)))]
        try:
            parse_engine_case(doc, str(tmp_path / "tiny.toml"))
        except InputError as e:
            refused += 1
            assert "\n" not in str(e) and str(e).startswith("expected"), str(e)
    assert refused > 100


def test_load_agent_case_reads_an_engine_cases_base_case() -> None:
    """Every other command (simulate, montecarlo, ...) reads an engine case's base case: the
    agent tables, without the engine's; the same case the engine itself starts from."""
    from formsync_design.verify.agentcase import load_agent_case
    from formsync_design.verify.enginecase import load_engine_case

    path = Path(__file__).resolve().parent.parent / "docs" / "engine" / "example.toml"
    base = load_agent_case(path)
    eng = load_engine_case(path)
    assert base.n == eng.base.n == 3 and base.gains.as_dict() == eng.base.gains.as_dict()
    np.testing.assert_array_equal(base.attitudes, eng.base.attitudes)
