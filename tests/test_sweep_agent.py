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
``k_w > k_R / 2``) have a closed form.
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
from formsync_design.spec.loader import load_design
from formsync_design.sweep import campaign_from_dict, run_sweep
from formsync_design.sweep.store import read_results

DATA = Path(__file__).resolve().parent / "data"
SO3 = str(DATA / "agent_so3.py")
MA_BOX = {"name": "b", "K1": [1, 2], "K2": ["1/10", "1/5"], "P1": "3/100", "P2": "3/100",
          "eps": "1/100"}


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
        assert rc == 1 and r["ref_status"] == doc["status"] == "refuted"
        assert r["ref_refuted_by"] == doc["witness"]["family"]
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
    # formsync certify refuses that graph unless asked (the sweep flags it instead)
    capsys.readouterr()
    assert main(["certify", "--design", "lv2012", "--graph", "path:3"]) == 2


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
        (["--design", SO3, "--ref", "1,1", "--mc-runs", "2"], "no [montecarlo]"),
        (["--design", "ma_quat_smc"], "conditions(c) hook"),
    ],
)
def test_bad_agent_sweep_input_is_exit_2_one_line(tmp_path, capsys, argv, words):
    out = tmp_path / "r"
    rc = main(["sweep", "--graphs", "ring:4", *argv, "--workers", "0", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and words in err and err.count("\n") == 1, err
    assert not out.exists()
