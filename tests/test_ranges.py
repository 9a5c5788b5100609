"""Numeric range discipline at the readers and paths in data files (formsync_design/ranges.py,
gains.parse_number, graphs, case and campaign readers)."""

from __future__ import annotations

import json
import math
from fractions import Fraction
from pathlib import Path

import pytest

from formsync_design.cli import main
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, parse_gain_range, parse_number
from formsync_design.graphs.digraph_io import digraph_from_edges, make_digraph, read_edge_list
from formsync_design.ranges import QUANTITIES, check_range, quantity_of

ROOT = Path(__file__).resolve().parents[1]


def _one_line_exit_2(argv, capsys):
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    assert rc == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    return err


@pytest.mark.parametrize("value, words", [
    ("1e400", "magnitude at most 1e+15"), ("1e13", "magnitude at most 1e+12"),
    ("nan", "finite"), ("inf", "finite"), ("-1e400", "magnitude"), ("1e-400", "at least"),
    ("1e999999999", "finite"), ("1e9999", "magnitude"),
])
def test_certify_refuses_out_of_range_gains_with_exit_2(capsys, value, words):
    err = _one_line_exit_2(["certify", "--design", "pd_consensus", "--graph", "ring:4",
                            "--gain", f"k_p={value}", "--gain", "k_d=1"], capsys)
    assert "k_p" in err and words in err


def test_parse_number_checks_the_text_before_computing_with_it():
    for text in ("1e999999999", "-1e400", "1e-99999", "9" * 300):
        with pytest.raises(InputError):
            parse_number(text, "x")
    with pytest.raises(InputError, match="magnitude"):
        parse_number(10**400, "x")
    with pytest.raises(InputError, match="magnitude"):
        parse_number(1e300, "x")
    assert parse_number("1e15", "x") == 10**15 and parse_number("1e-300", "x") == Fraction(1, 10**300)
    assert parse_number(0, "x") == 0 and parse_number("0e-5", "x") == 0


def test_gain_range_bounds():
    assert parse_gain_range("1e12", "k").lo == 10**12
    with pytest.raises(InputError, match=r"k \(a controller gain\) of magnitude at most 1e\+12"):
        parse_gain_range("1:2e12", "k")
    with pytest.raises(InputError):
        GainBox.parse({"a": (1, 10**13)})


@pytest.mark.parametrize("w", [1e308, 1e7, "1e400", float("nan"), float("inf"), 10**400])
def test_arc_weights_beyond_range_are_refused(tmp_path, w):
    with pytest.raises(InputError):
        digraph_from_edges([(1, 2, w), (2, 1, 1)])
    with pytest.raises(InputError):
        make_digraph([[0, w], [1, 0]])
    with pytest.raises(InputError):
        digraph_from_edges([(1, 2, 1), (2, 1, 1)], pinning=[w, 0])
    p = tmp_path / "g.txt"
    p.write_text(f"1 2 {w}\n2 1 1\n")
    with pytest.raises(InputError):
        read_edge_list(p)


def test_arc_weight_1e308_in_a_case_file_is_exit_2(tmp_path, capsys):
    text = (ROOT / "verification" / "ma_so3.toml").read_text()
    copy = tmp_path / "c.toml"
    copy.write_text(text.replace('[1, 4, "0.58"], [2, 3', '[1, 4, 1e308], [2, 3', 1))
    assert "1e308" in copy.read_text()
    err = _one_line_exit_2(["simulate", "--case", str(copy), "--tf", "1"], capsys)
    assert "1e+308" in err or "1e308" in err


@pytest.mark.parametrize("old, new, words", [
    ("inertia = [[50, 0, 4]", "inertia = [[1e20, 0, 4]", "inertia"),
    ("inertia = [[50, 0, 4]", "inertia = [[nan, 0, 4]", "finite"),
    ("rate = [0.85, -0.43, 0.77]", "rate = [1" + "0" * 400 + ", -0.43, 0.77]", "rate"),
    ("tf = 200.0", "tf = 1e300", "simulation.tf"),
    ("boundary_layer = 0.01", "boundary_layer = 1e9", "boundary_layer"),
    ("K_o = 1.6", "K_o = 1e300", "gains.K_o"),
    ("altitude_km = 400.0", "altitude_km = inf", "finite"),
])
def test_case_numbers_beyond_range_are_exit_2(tmp_path, capsys, old, new, words):
    text = (ROOT / "verification" / "liang2016.toml").read_text()
    assert old in text
    copy = tmp_path / "c.toml"
    copy.write_text(text.replace(old, new, 1))
    err = _one_line_exit_2(["simulate", "--case", str(copy), "--tf", "1"], capsys)
    assert words in err


def test_quantities_of_the_shipped_keys():
    assert quantity_of("simulation.tf").name == "horizon"
    assert quantity_of("simulation.output_step").name == "step"
    assert quantity_of("simulation.rtol").name == "tolerance"
    assert quantity_of("spacecraft 3 inertia").name == "inertia"
    assert quantity_of("spacecraft 3 rate").name == "rate"
    assert quantity_of("gains.K_v").name == "gain"
    assert quantity_of("orbit.mu").name == "mu"
    assert quantity_of("orbit.altitude_km").name == "distance"
    assert quantity_of("montecarlo.max_angle_deg").name == "angle"
    assert quantity_of("claims.gyro_seed").name == "number"
    for q in QUANTITIES.values():
        assert math.isfinite(q.bound) and 0 < q.bound <= 1e21
        check_range(q.bound, q, "x")
        with pytest.raises(InputError):
            check_range(q.bound * 2, q, "x")


# -- paths in data files ---------------------------------------------------------------------

def _finished_sweep(folder: Path) -> None:
    src = ROOT / "reports" / "sweep-atlas6"
    folder.mkdir(parents=True)
    for name in ("manifest.json", "results.csv"):
        (folder / name).write_bytes((src / name).read_bytes())


def test_compare_resolves_relative_to_the_campaign_file(tmp_path, monkeypatch):
    from formsync_design.sweep import load_campaign

    camp = tmp_path / "camps" / "c.toml"
    _finished_sweep(tmp_path / "camps" / "prior")
    camp.write_text('[campaign]\nname = "c"\ndesign = "pd_consensus"\ngraphs = ["ring:4"]\n'
                    'compare = "prior"\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    c = load_campaign(camp)
    assert c.compare == "prior" and Path(c.base) == camp.parent
    (elsewhere / "prior").mkdir()  # a folder of that name here must not be the one used
    camp.write_text(camp.read_text().replace('"prior"', '"missing"'))
    with pytest.raises(InputError, match="campaign.compare"):
        load_campaign(camp)


def test_shipped_campaign_resolves_from_anywhere_and_keeps_its_fingerprint(tmp_path, monkeypatch):
    from formsync_design.sweep import load_campaign
    from formsync_design.sweep.campaign import campaign_hash
    from formsync_design.sweep.graphsets import expand_graphs

    monkeypatch.chdir(tmp_path)
    c = load_campaign(ROOT / "verification" / "sweep_pd_atlas5.toml")
    assert c.compare == "reports/sweep-atlas6"  # as written: the committed summary prints it
    graphs, _ = expand_graphs(c.graphs, base=Path(c.base))
    manifest = json.loads((ROOT / "reports" / "sweep-pd-atlas5" / "manifest.json").read_text())
    assert campaign_hash(c, graphs) == manifest["sha256"]


def test_campaign_fields_are_validated_in_the_order_written(tmp_path):
    from formsync_design.sweep import load_campaign

    p = tmp_path / "c.toml"
    p.write_text('[campaign]\nname = "x"\ndesign = "pd_consensus"\ngraphs = "ring:4..5"\n'
                 'compare = "nowhere"\n')
    with pytest.raises(InputError, match="campaign.graphs"):
        load_campaign(p)
    p.write_text('[campaign]\nname = "x"\ncompare = "nowhere"\ngraphs = "ring:4..5"\n')
    with pytest.raises(InputError, match="campaign.compare"):
        load_campaign(p)
    p.write_text('[campaign]\nname = "x"\ngraphs = ["ring:4"]\n[design]\nbetas = 0\n'
                 '[region]\nresolution = 0\n')
    with pytest.raises(InputError, match="design.betas"):
        load_campaign(p)


def test_montecarlo_case_resolves_relative_to_the_campaign_file(tmp_path, monkeypatch):
    from formsync_design.sweep import load_campaign
    from formsync_design.sweep.mccase import case_text

    d = tmp_path / "camps"
    d.mkdir()
    (d / "mine.toml").write_text((ROOT / "verification" / "pd_consensus.toml").read_text())
    (d / "c.toml").write_text('[campaign]\nname = "c"\ndesign = "pd_consensus"\n'
                              'graphs = ["ring:4"]\n[montecarlo]\nruns = 1\ncase = "mine.toml"\n')
    monkeypatch.chdir(tmp_path)
    c = load_campaign(d / "c.toml")
    assert c.montecarlo is not None
    path, text = case_text(c.montecarlo, None)
    assert Path(path) == d / "mine.toml" and text == (d / "mine.toml").read_text()


def test_a_case_names_its_graph_file_relative_to_itself(tmp_path, monkeypatch):
    from formsync_design.verify.agentcase import load_agent_case
    from formsync_design.verify.case import load_case

    d = tmp_path / "cases"
    d.mkdir()
    (d / "g.txt").write_text("1 2\n2 3\n3 4\n4 1\n")
    text = (ROOT / "verification" / "pd_consensus.toml").read_text()
    (d / "c.toml").write_text(text.replace('graph = "ring:4"', 'graph = "g.txt"', 1))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "g.txt").write_text("1 2\n")  # a file of that name here is not the one read
    monkeypatch.chdir(elsewhere)
    case = load_case(d / "c.toml")
    assert Path(case.graph_spec) == d / "g.txt" and case.graph().n == 4
    ma = (ROOT / "verification" / "ma_so3.toml").read_text()
    start, end = ma.index("[graph]"), ma.index("[gains]")
    (d / "g5.txt").write_text("1 2\n2 3\n3 4\n4 5\n5 1\n")
    no_table = ma[:start] + ma[end:]  # the [graph] table replaced by [case] graph = FILE
    assert 'kind = "engine"' in no_table
    (d / "a.toml").write_text(no_table.replace('kind = "engine"',
                                               'kind = "engine"\ngraph = "g5.txt"', 1))
    agent = load_agent_case(d / "a.toml")
    assert Path(agent.graph_input) == d / "g5.txt" and agent.graph().n == 5
