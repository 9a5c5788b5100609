"""Monte-Carlo of any design the simulator takes (issue #10): the PD baseline end to end.

Independent truths: the nominal PD closed loop ``q'' = -k_d q' - k_p L q`` is stable modulo
the consensus mode for every positive gain (checked here on the linear loop's eigenvalues
with numpy), so every sampled run must synchronise; a replayed run is integrated again by
``simulate`` (a different kernel entry point) and must reproduce the batch's metrics.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.cli.montecarlo import montecarlo_box
from formsync_design.errors import InputError
from formsync_design.sim import Gains
from formsync_design.sim.formation import SimOptions
from formsync_design.sim.montecarlo import (
    mc_box,
    mc_gain_names,
    point_box,
    replay,
    run_montecarlo,
    sample_formation,
)
from formsync_design.sim.montecarlo_data import MonteCarloSettings, RunStatus
from formsync_design.sim.simulator import simulate
from formsync_design.spec.loader import load_spec
from formsync_design.verify.case import load_case

PD = load_spec("pd_consensus")
# step 0.05 s: at the Monte-Carlo default 0.1 s the high-gain corner of this box drifts the
# quaternion norm past 1e-5 (flagged "inaccurate", not a convergence failure)
OPT = SimOptions(tf=60.0, step=0.05, output_step=0.5, norm_tol=1e-5, compile=False)
BOX = {"k_p": "0.2:1", "k_d": "1:2"}
LO, HI = np.array([0.2, 1.0]), np.array([1.0, 2.0])


@pytest.fixture(scope="module")
def base():
    case = load_case("pd_consensus")  # ring:4, no disturbance
    assert case.graph().name == "ring:4"
    return case.formation()


@pytest.fixture(scope="module")
def campaign(base):
    return run_montecarlo(base, mc_box(BOX, PD), MonteCarloSettings(runs=8, seed=21), OPT,
                          certify=True, spec=PD)


def test_pd_box_has_the_controller_gains_only():
    assert mc_gain_names(PD) == ("k_p", "k_d")  # no K_v (no switching term), no eps (multiplier)
    assert mc_gain_names() == ("K_o", "K_q", "beta", "K_v")
    with pytest.raises(InputError, match="unknown"):
        mc_box({**BOX, "K_v": 0.01}, PD)
    with pytest.raises(InputError, match="unknown"):
        mc_box({**BOX, "eps": 0.1}, PD)
    assert str(point_box(Gains(k_p=0.4, k_d=1.6), PD)) == "k_p=0.4, k_d=1.6"


def test_pd_every_run_converges_with_gains_in_the_box(base, campaign):
    L = base.graph.laplacian.astype(float)
    n = L.shape[0]
    ks = np.array([[r.k_p, r.k_d] for r in campaign.runs])
    assert np.all(ks >= LO) and np.all(ks <= HI) and len({tuple(k) for k in ks}) == len(ks)
    for kp, kd in ks:  # the premise: the nominal linear loop is stable modulo consensus
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-kp * L, -kd * np.eye(n)]])
        ev = np.sort_complex(np.linalg.eigvals(A))
        assert np.all(ev.real[:-1] < -1e-9) and abs(ev[-1]) < 1e-9  # one zero: the consensus mode
    assert campaign.counts["converged"] == len(campaign.runs) == 8 and campaign.all_converged
    for r in campaign.runs:
        assert r.status == RunStatus.CONVERGED and r.final_q_m <= OPT.q_tol
        d = r.to_dict()
        assert list(d)[:4] == ["index", "seed", "k_p", "k_d"] and "K_v" not in d
    doc = campaign.to_dict()
    assert set(doc["box"]) == {"k_p", "k_d"}
    c = doc["certification"]  # nominal loop, no disturbance: the certificate covers the runs
    assert c["status"] == "certified" and c["kv_holds"] is None and c["ubar"] == 0
    assert c["gains_and_kv_certified"] is True and "eps" in c["reason"]


def test_pd_replay_reproduces_a_run(base, campaign):
    for run in (campaign.runs[0], campaign.runs[-1]):
        f = replay(base, campaign.box, campaign.settings, run.seed, PD)
        assert f.gains.as_dict() == {"k_p": run.k_p, "k_d": run.k_d}
        r = simulate(f, OPT, spec=PD)
        assert str(r.status) == str(run.status)
        assert r.final_q_m == pytest.approx(run.final_q_m, rel=1e-12, abs=0)
        assert r.final_omega_m == pytest.approx(run.final_omega_m, rel=1e-12, abs=1e-300)
        assert r.convergence_time == run.convergence_time


def test_diagonal_gain_draws_three_entries(tmp_path):
    p = tmp_path / "diag.py"
    p.write_text('''
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3", "kind": "diag"}}
def controller(v):
    return v.Q.I.T * (v.B * v.qd - v.A * v.k_d * v.qd - v.k_p * v.A * v.s)
def lyapunov(v):
    return v.k_p / 4 * sum((e.dot(e) for e in v.edges), 0) + v.qd.dot(v.qd) / 2
''')
    spec = load_spec(str(p))
    base = load_case("pd_consensus").formation()
    f = sample_formation(base, {"k_p": 1, "k_d": "1:2"}, MonteCarloSettings(runs=1), 5, spec)
    kd = f.gains.k_d
    assert isinstance(kd, tuple) and len(set(kd)) == 3 and all(1 <= x <= 2 for x in kd)
    assert str(point_box(f.gains, spec)) == f"k_p=1, k_d={min(kd):g}:{max(kd):g}"


# --------------------------------------------------------------------------- command line
def test_cli_box_defaults():
    liang = load_case().formation().gains
    pdg = load_case("pd_consensus").formation().gains
    # the case's values where the case has the gain, else the declared range
    assert str(montecarlo_box(PD, pdg)) == "k_p=0.4, k_d=1.6"
    assert str(montecarlo_box(PD, liang)) == "k_p=0.1:2, k_d=0.5:3"
    assert str(montecarlo_box(PD, pdg, ["k_d=1:2"])) == "k_p=0.4, k_d=1:2"
    assert str(montecarlo_box(load_spec(None), liang, ["K_v=0:0.02"], {"K_o": "1:2"})) == \
        "K_o=1:2, K_q=0.4, beta=0.3, K_v=0:0.02"


def test_cli_pd_montecarlo_and_replay(capsys):
    args = ["montecarlo", "--case", "pd_consensus", "--gain", "k_p=0.2:1", "--gain", "k_d=1:2",
            "--runs", "3", "--seed", "4", "--tf", "60", "--step", "0.05", "--no-compile",
            "--no-certify"]
    assert main([*args, "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["specification"] == "pd_consensus" and doc["graph"] == "ring:4"
    assert doc["counts"]["converged"] == 3 and set(doc["box"]) == {"k_p", "k_d"}
    seed = 12345
    assert main([*args, "--replay", str(seed), "--format", "json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert set(rep["gains"]) == {"k_p", "k_d"} and 0.2 <= rep["gains"]["k_p"] <= 1
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "box: k_p [0.2, 1], k_d [1, 2]" in text and "switch none" in text


@pytest.mark.parametrize("extra, needle", [
    (["--gain", "k_q=1"], "received ['k_q']"),
    (["--kv", "0.01"], "no --kv for design pd_consensus"),
    (["--gain", "eps=0.1"], "multiplier"),
    (["--ko", "1.6"], "received --ko (K_o)"),
    (["--gain", "k_p=0:1"], "positive k_p"),
])
def test_cli_bad_gains_exit_2_one_line(capsys, extra, needle):
    rc = main(["montecarlo", "--case", "pd_consensus", "--runs", "1", "--no-compile", *extra])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and needle in err and "Traceback" not in err


def test_cli_design_option_overrides_the_case(capsys):
    rc = main(["montecarlo", "--design", "pd_consensus", "--gain", "k_p=0.5",
               "--gain", "k_d=1.5", "--runs", "1", "--tf", "5", "--no-compile", "--no-certify",
               "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    # without --case, the design's shipped case (verification/pd_consensus.toml)
    assert rc == 1 and doc["specification"] == "pd_consensus" and doc["case"] == "pd_consensus"
    assert doc["box"] == {"k_p": [0.5, 0.5], "k_d": [1.5, 1.5]}
