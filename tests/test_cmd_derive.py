"""`formsync derive`: numbers, report, exit codes, one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from formsync_design.cli.main import main


def test_numeric_json_order_and_values(capsys):
    assert main(["derive", "--graph", "ring:4", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3",
                 "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["pi"]["zeta_order"][:4] == ["qdot_1.x", "qdot_1.y", "qdot_1.z", "qdot_2.x"]
    assert doc["pi"]["zeta_order"][12] == "s_1.x"
    P = np.array(doc["pi"]["matrix"])
    assert P.shape == (24, 24) and np.allclose(P, P.T)
    # M = K_o I - beta L per axis: diagonal K_o - 2 beta for a ring, edge entries +beta
    assert P[0, 0] == pytest.approx(1.6 - 0.6) and P[0, 3] == pytest.approx(0.3)
    assert len(doc["theta"]) == 4 and np.array(doc["theta"][0]["matrix"]).shape == (9, 9)


def test_report_mode(tmp_path, capsys):
    assert main(["derive", "--graph", "path:3", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "liang2016-derivation-path3.md").is_file()
    assert (tmp_path / "liang2016-derivation-path3.tex").is_file()
    assert "decided by" in capsys.readouterr().out


def _verdicts(graph, tmp_path, capsys):
    assert main(["derive", "--graph", graph, "--out", str(tmp_path / graph.replace(":", "")),
                 "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert all(f["computation"]["kind"] and f["meaning"] for f in doc["findings"])
    return {f["key"]: f["verdict"] for f in doc["findings"]}


def test_large_graph_verdicts_are_computed_like_small_ones(tmp_path, capsys):
    """ring:41 exceeds the old 40-spacecraft dense limit; Pi-N must be compared, not assumed."""
    small = _verdicts("ring:8", tmp_path, capsys)
    large = _verdicts("ring:41", tmp_path, capsys)
    assert large == small and large["Pi-N"] == "agrees"


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["derive", "--graph", "ring:2"], "ring"),
        (["derive", "--graph", "nonsense"], "graph spec"),
        (["derive", "--ko", "1"], "all of --ko"),
        (["derive", "--ko", "1", "--kq", "1", "--beta", "nan"], "finite"),
        (["derive", "--ko", "1", "--kq", "-1", "--beta", "1"], "positive"),
        (["derive", "--ko", "1:2", "--kq", "1", "--beta", "1"], "single values"),
        (["derive", "--spec", "/no/such.py"], "no such file"),
        (["derive", "--frobnicate"], "unrecognized"),
    ],
)
def test_bad_input_exit_2_one_line(argv, fragment, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert fragment in err and err.count("\n") == 1


def test_help_exits_0(capsys):
    assert main(["derive", "--help"]) == 0
    assert "zeta" in capsys.readouterr().out
