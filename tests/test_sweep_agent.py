"""``formsync sweep`` of agent designs (``FORM = "agent"``).

Independent truths: each row's certificate status and region fractions are recomputed
here for the same graph and box through the library the agent commands use
(:func:`~formsync_design.derive.agent.agent_conditions`,
:func:`~formsync_design.certify.multipliers.certify_with_multipliers` /
:func:`~formsync_design.certify.engine.certify_box`,
:func:`~formsync_design.certify.reduce.three_axes` +
:func:`~formsync_design.certify.multiregion.region_with_multipliers`), and
``formsync certify --design`` itself for the reference point; the region fractions of the
test design ``tests/data/agent_so3.py`` (families ``diag(k_R, k_w) > 0`` and
``k_w > k_R / 2``) have a closed form.  The Monte-Carlo cells are recomputed by
:func:`~formsync_design.sim.agent_montecarlo.run_agent_montecarlo` on a formation whose
spacecraft data are cycled here from the case file.
"""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import pytest
import sympy as sp

from formsync_design.certify.engine import certify_box
from formsync_design.certify.multipliers import certify_with_multipliers
from formsync_design.certify.multiregion import region_with_multipliers
from formsync_design.certify.reduce import three_axes
from formsync_design.cli.main import main
from formsync_design.derive.agent import agent_conditions
from formsync_design.errors import FormsyncError
from formsync_design.spec.loader import load_design
from formsync_design.sweep import campaign_from_dict, run_sweep
from formsync_design.sweep.schema import fmt_cell
from formsync_design.sweep.store import read_results
from formsync_design.sweep.tasks import run_task

DATA = Path(__file__).resolve().parent / "data"
SO3 = str(DATA / "agent_so3.py")
MA_BOX = {"name": "b", "K1": [1, 2], "K2": ["1/10", "1/5"], "P1": "3/100", "P2": "3/100",
          "eps": "1/100"}


@pytest.fixture(autouse=True)
def _trust_agent_so3():
    """The agent case of these tests names the design file agent_so3.py beside it: trusted
    (a data file's design code runs only on the user's word, spec.trust)."""
    from formsync_design.spec.trust import trusting

    with trusting(SO3):
        yield


def _campaign(design, graphs, box=None, reference=None):
    doc = {"campaign": {"name": "a", "graphs": list(graphs), "design": design},
           "region": {"resolution": 2}, "design": {"betas": 2}}
    if box is not None:
        doc["box"] = [box]
    if reference is not None:
        doc["reference"] = reference
    return campaign_from_dict(doc)


def _truth(design, graph, box, ref, resolution=2):
    """(reference status, region fractions) through the library, as the agent commands do."""
    d = load_design(design)
    conds = agent_conditions(d, graph)
    mult = {n: d.decl.gain(n).range for n in d.decl.multipliers}
    point = {g: (v, v) for g, v in ref.items()}
    cert = (certify_with_multipliers(conds, point, mult) if mult else certify_box(conds, point))
    full = {**box, **{n: (r.lo, r.hi) for n, r in mult.items()}}
    red, rbox = three_axes(conds, full)
    rm = region_with_multipliers(red, {n: v for n, v in rbox.items() if n not in mult},
                                 {n: r for n, r in mult.items() if n in rbox},
                                 resolution=resolution)
    return str(cert.status), rm.fractions


def _f(x):
    return Fraction(x) if not isinstance(x, list) else (Fraction(x[0]), Fraction(x[1]))


def test_serial_sweep_of_ma_so3_matches_the_agent_library(tmp_path):
    c = _campaign("ma_so3", ["ring:4"], MA_BOX)
    res = run_sweep(c, tmp_path / "r", n_workers=0)
    rows = read_results(tmp_path / "r" / "results.csv")
    assert res.design == "ma_so3" and len(rows) == 1
    r = rows[0]
    # default reference: the shipped case's gains (verification/ma_so3.toml)
    ref = {"K1": Fraction("1.15"), "K2": Fraction("0.15"), "P1": Fraction("0.03"),
           "P2": Fraction("0.03"), "eps": Fraction("0.01")}
    box = {g: _f(v) if isinstance(v, list) else (_f(v), _f(v))
           for g, v in MA_BOX.items() if g != "name"}
    status, fr = _truth("ma_so3", "ring:4", box, ref)
    assert r["theorem"] == "inside" and r["ref_status"] == status
    for k in ("certified", "refuted", "undecided"):
        assert float(r[f"frac_{k}"]) == pytest.approx(fr[k], abs=1e-9)
    assert [float(r[f"ref_{g}"]) for g in ref] == [float(v) for v in ref.values()]
    assert r["ref_cert_mu"] != "" and r["design_status"] == "designed"
    md = (tmp_path / "r" / "summary.md").read_text()
    assert "conditions(c) families" in md and "outside the design's theorem" in md


def test_sweep_rows_equal_formsync_certify_and_resume(tmp_path, capsys):
    box = {"name": "std", "k_R": ["1/10", 2], "k_w": ["1/2", 3]}
    ref = {"k_R": "1", "k_w": "1/4"}  # k_w < k_R / 2: refuted
    c = _campaign(SO3, ["ring:4", "path:3"], box, ref)
    out = tmp_path / "r"
    run_sweep(c, out, n_workers=0)
    rows = read_results(out / "results.csv")
    assert [r["graph"] for r in rows] == ["ring:4", "path:3"]
    for r in rows:
        capsys.readouterr()
        rc = main(["certify", "--design", SO3, "--graph", r["graph"], "--gain", "k_R=1",
                   "--gain", "k_w=0.25", "--format", "json"])
        doc = json.loads(capsys.readouterr().out)
        cond = doc["design_conditions"]
        assert r["ref_status"] == cond["status"] == "refuted"
        assert r["ref_refuted_by"] == cond["witness"]["family"]
        assert r["formation"] == doc["status"] == doc["formation"]["status"]
        assert rc == (0 if doc["status"] == "certified" else 1)
        status, fr = _truth(SO3, r["graph"], {"k_R": (Fraction(1, 10), Fraction(2)),
                                              "k_w": (Fraction(1, 2), Fraction(3))},
                            {"k_R": Fraction(1), "k_w": Fraction(1, 4)})
        assert status == r["ref_status"]
        assert {k: float(r[f"frac_{k}"]) for k in fr} == pytest.approx(fr)
        # closed form: every certified cell lies in k_w > k_R / 2 (the box's top-left half)
        assert 0 < float(r["frac_certified"]) < 1
        assert Fraction(r["rec_k_w"]) > Fraction(r["rec_k_R"]) / 2
    # resume of a complete folder: the same rows, nothing recomputed
    before = (out / "results.csv").read_bytes()
    again = run_sweep(c, out, n_workers=0, resume=True)
    assert again.computed == 0 and (out / "results.csv").read_bytes() == before


def test_graph_outside_the_theorem_is_a_row_flag_not_a_refusal(tmp_path, capsys):
    # lv2012's theorem needs a leader-reachable graph; path:3 has no leader
    out = tmp_path / "r"
    rc = main(["sweep", "--design", "lv2012", "--graphs", "path:3", "--resolution", "2",
               "--design-betas", "2", "--workers", "0", "--no-progress", "--out", str(out)])
    assert rc == 0
    (r,) = read_results(out / "results.csv")
    assert r["theorem"].startswith("outside: lacks leader-reachable")
    d = load_design("lv2012")
    status, fr = _truth("lv2012", "path:3", {n: (d.decl.gain(n).range.lo, d.decl.gain(n).range.hi)
                                             for n in d.decl.controller_gains},
                        {"k_p": Fraction(r["ref_k_p"]), "k_d": Fraction(r["ref_k_d"]),
                         "a_f": Fraction(r["ref_a_f"])})
    assert r["ref_status"] == status and float(r["frac_certified"]) == pytest.approx(fr["certified"])
    md = (out / "summary.md").read_text()
    assert "outside the design's theorem (column `theorem`; their statuses decide the families " \
           "only): path:3" in md
    # formsync certify keeps the case's pinning rule on --graph path:3 (every spacecraft
    # pinned, issue 34 item 6), so there it is inside the theorem; a graph file whose leader
    # reaches no one past spacecraft 1 is refused unless asked (the sweep flags it instead)
    capsys.readouterr()
    assert main(["certify", "--design", "lv2012", "--graph", "path:3"]) == 0
    assert "pinning for --graph path:3: every spacecraft pinned" in capsys.readouterr().err
    g = tmp_path / "unreached.txt"
    g.write_text("1 0 1\n1 2 1\n2 3 1\n3 2 1\n")
    assert main(["certify", "--design", "lv2012", "--graph", str(g)]) == 2
    assert "leader-reachable: spacecraft {2,3} not reachable" in capsys.readouterr().err


def test_python_agent_design_travels_by_value_and_dask_equals_serial(tmp_path):
    def conds(c):
        return [("damping", sp.Matrix([[c.gains["k"] - 1]]), ("w",))]

    from formsync_design.spec.agent import agent_design_from_functions

    d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, name="damper",
                                    gains={"k": {"range": "1/2:2"}}, conditions=conds)
    doc = {"campaign": {"name": "p", "graphs": ["ring:3", "path:3"]},
           "reference": {"k": "3/2"}, "region": {"resolution": 2}, "design": {"betas": 2}}
    c = campaign_from_dict(doc, spec=d)
    run_sweep(c, tmp_path / "serial", n_workers=0)
    rows = read_results(tmp_path / "serial" / "results.csv")
    assert [r["ref_status"] for r in rows] == ["certified", "certified"]
    assert [float(r["frac_certified"]) for r in rows] == [0.5, 0.5]  # k > 1 on [1/2, 2]
    res = run_sweep(c, tmp_path / "dask", n_workers=2, timeout=30)
    assert res.executor.startswith("dask LocalCluster")
    for name in ("results.csv", "manifest.json", "summary.md"):
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes()


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--design", "ma_so3", "--gain", "K7=1:2"], "(K1, K2, P1, P2, eps) in --gain, received unknown ['K7']"),
        (["--design", "ma_so3", "--gain", "mu=1:2"], "received mu (a multiplier"),
        (["--design", "ma_so3"], "at most three free axes in box 'standard'"),
        (["--design", SO3, "--ref", "k_R=1"], "missing ['k_w']"),
        (["--design", SO3, "--ref", "1,1", "--mc-runs", "2"], "expected montecarlo.case (--mc-case)"),
        (["--design", SO3, "--ref", "1,1", "--mc-runs", "2", "--mc-case", "liang2016"],
         "received the Lagrangian case liang2016"),
        (["--design", "pd_consensus", "--mc-runs", "2", "--mc-case", "ma_so3"],
         "received the agent case ma_so3"),
        (["--design", "lv2012", "--mc-runs", "2"], "declares a leader and a sweep's graphs pin no"),
        (["--design", "ma_quat_smc"], "conditions(c) hook"),
    ],
)
def test_bad_agent_sweep_input_is_exit_2_one_line(tmp_path, capsys, argv, words):
    out = tmp_path / "r"
    rc = main(["sweep", "--graphs", "ring:4", *argv, "--workers", "0", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and words in err and err.count(": error: ") == 1, err
    assert not out.exists()


SO3_CASE = str(DATA / "agent_so3_case.toml")  # five spacecraft
SO3_MC = {"campaign": {"name": "m", "graphs": ["ring:3", "path:7"], "design": SO3},
          "reference": {"k_R": "4/5", "k_w": "3/2"},
          "box": {"name": "b", "k_R": ["1/10", 2], "k_w": ["1/2", 3]},
          "region": {"resolution": 2}, "design": {"betas": 2},
          "montecarlo": {"runs": 2, "seed": 1, "case": SO3_CASE, "tf": 15.0,
                         "max_angle_deg": 20.0, "max_rate": 0.01}}


def _mc_truth(graph, n):
    """The agent Monte-Carlo of the case's spacecraft cycled onto ``graph`` (n spacecraft)."""
    from dataclasses import replace

    import numpy as np

    from formsync_design.gains import GainBox
    from formsync_design.graphs import load_graph
    from formsync_design.sim.agent_montecarlo import run_agent_montecarlo
    from formsync_design.sim.agents import AgentFormation
    from formsync_design.sim.montecarlo_data import MonteCarloSettings
    from formsync_design.verify.agentcase import load_agent_case

    d = load_design(SO3)
    case = load_agent_case(SO3_CASE, design=d)
    idx = [i % 5 for i in range(n)]
    f = AgentFormation(load_graph(graph), case.inertias[idx], case.attitudes[idx],
                       case.rates[idx], case.gains)
    box = GainBox.parse({"k_R": Fraction(4, 5), "k_w": Fraction(3, 2)})
    st = MonteCarloSettings(runs=2, seed=1, max_angle_deg=20.0, max_rate=0.01)
    res = run_agent_montecarlo(d, f, box, st, replace(case.options, tf=15.0), certify=False)
    times = [r.convergence_time for r in res.runs if r.convergence_time is not None]
    status = [r.status for r in res.runs]
    return {"mc_runs": "2", "mc_converged": str(status.count("converged")),
            "mc_not_converged": str(status.count("not-converged")),
            "mc_stopped": str(status.count("stopped")),
            "mc_diverged": str(status.count("diverged")),
            "mc_conv_time_median": fmt_cell(float(np.median(times)) if times else None),
            "mc_conv_time_max": fmt_cell(max(times) if times else None),
            "mc_failed_seeds": ";".join(str(r.seed) for r in res.failures)}


def test_agent_monte_carlo_cells_equal_the_agent_library_with_cycled_spacecraft(tmp_path):
    c = campaign_from_dict(SO3_MC)
    run_sweep(c, tmp_path / "r", n_workers=0)
    rows = read_results(tmp_path / "r" / "results.csv")
    assert [(r["graph"], r["n"]) for r in rows] == [("ring:3", "3"), ("path:7", "7")]  # case: 5
    for r in rows:
        truth = _mc_truth(r["graph"], int(r["n"]))
        assert r["mc_status"] == "ran" and r["mc_gains"] == "reference"
        assert {k: r[k] for k in truth} == truth
        assert r["mc_singular"] == r["mc_inaccurate"] == ""  # Lagrangian only
    assert rows[0]["mc_converged"] == "2" and rows[1]["mc_not_converged"] == "2"
    md = (tmp_path / "r" / "summary.md").read_text()
    assert "2 of 4 runs converged over 2 tasks" in md and "| stopped |" in md
    assert f"case {SO3_CASE}, spacecraft data cycled" in md and "tf = 15 s, the case's other" in md


def test_interrupted_agent_monte_carlo_sweep_resumes_to_identical_rows(tmp_path):
    c = campaign_from_dict(SO3_MC)
    run_sweep(c, tmp_path / "ref", n_workers=0)

    def dies_on_second(task):
        if task["graph_index"] == 1:
            raise RuntimeError("simulated kill")
        return run_task(task)

    out = tmp_path / "r"
    with pytest.raises(FormsyncError, match="simulated kill"):
        run_sweep(c, out, n_workers=0, task_fn=dies_on_second)
    res = run_sweep(c, out, n_workers=0, resume=True)
    assert res.reused == 1 and res.computed == 1
    for name in ("results.csv", "manifest.json", "summary.md"):
        assert (out / name).read_bytes() == (tmp_path / "ref" / name).read_bytes(), name


@pytest.mark.parametrize("key, value", [("phases", False), ("K_v", 0.1)])
def test_lagrangian_monte_carlo_keys_for_an_agent_design_are_exit_2(tmp_path, capsys, key, value):
    p = tmp_path / "c.toml"
    p.write_text(f'[campaign]\nname = "m"\ngraphs = ["ring:3"]\ndesign = "ma_so3"\n'
                 f'[montecarlo]\nruns = 2\n{key} = {str(value).lower()}\n')
    rc = main(["sweep", "--campaign", str(p), "--workers", "0", "--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert f"expected no montecarlo.{key} for the agent design ma_so3" in err
    assert not (tmp_path / "r").exists()


def test_agent_monte_carlo_options_default_to_the_case_and_reach_the_payload(tmp_path):
    from formsync_design.sweep.graphsets import expand_graphs
    from formsync_design.sweep.tasks import agent_mc_inputs, build_tasks

    doc = {**SO3_MC, "montecarlo": {"runs": 1, "case": SO3_CASE, "step": 0.005}}
    c = campaign_from_dict(doc)
    assert c.montecarlo.tf is None and c.montecarlo.output_step is None
    gs, _ = expand_graphs(["path:7"])
    (task,) = build_tasks(c, gs)
    assert task["montecarlo"]["case_text"] == Path(SO3_CASE).read_text()  # no file on workers
    g = load_design(SO3)
    from formsync_design.graphs.build import Graph

    base, box, st, opt = agent_mc_inputs(Graph(7, tuple(gs[0].graph.edges), "path:7"),
                                         task["montecarlo"], g, [Fraction(1), Fraction(1)])
    assert (opt.tf, opt.output_step, opt.step) == (30.0, 0.1, 0.005)  # the case's, step given
    assert base.n == 7 and (base.inertias[6] == base.inertias[1]).all()
    shipped = campaign_from_dict({"campaign": {"name": "s", "graphs": ["ring:3"], "design": "ma_so3"},
                                  "box": MA_BOX, "montecarlo": {"runs": 1}})
    assert Path(build_tasks(shipped, gs)[0]["montecarlo"]["case_path"]).name == "ma_so3.toml"
    with pytest.raises(FormsyncError, match="step to divide output_step"):
        campaign_hash_of({**SO3_MC, "montecarlo": {"runs": 1, "case": SO3_CASE, "step": 0.03}})


def campaign_hash_of(doc):
    from formsync_design.sweep.campaign import campaign_hash
    from formsync_design.sweep.graphsets import expand_graphs

    c = campaign_from_dict(doc)
    return campaign_hash(c, expand_graphs(c.graphs)[0])
