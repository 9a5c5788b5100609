"""The CLI core: exit codes of ``formsync_design.cli.main``, Ctrl-C on any command, the
JSON number convention of ``emit_json`` and the one gain-range type.

Independent truths: ``json.loads`` of the output and exact ``Fraction`` arithmetic
(a value written as a number must equal the rational exactly; a "p/q" string
must parse back to it).
"""

from __future__ import annotations

import importlib
import json
import math
from fractions import Fraction

import numpy as np
import pytest

from formsync_design.cli import options
from formsync_design.errors import ClusterError, CompilerError, GraphError, SolverError

cli_main = importlib.import_module("formsync_design.cli.main")  # the module, not the function


def _run_with(monkeypatch, capsys, exc: BaseException) -> tuple[int, str]:
    """Run ``formsync sweep ...`` whose command body raises ``exc``."""
    from formsync_design.cli import sweep as cmd_sweep

    def boom(args):
        raise exc

    monkeypatch.setattr(cmd_sweep, "run", boom)
    rc = cli_main.main(["sweep", "--graphs", "ring:3", "--out", "unused"])
    return rc, capsys.readouterr().err


@pytest.mark.parametrize("exc, code, words", [
    (KeyboardInterrupt(), 130, "interrupted"),
    (ClusterError("a Dask worker died; rerun with --resume"), 3, "ClusterError"),
    (SolverError("Clarabel crashed; try --no-sdp"), 3, "SolverError"),
    (CompilerError("gcc missing; install gcc"), 3, "CompilerError"),
    (GraphError("expected a connected graph, received 2 components"), 2, "connected"),
    (UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte"), 2, "UTF-8"),
    (FileNotFoundError(2, "No such file or directory", "x.toml"), 2, "x.toml"),
    (PermissionError(13, "Permission denied", "/root/x"), 2, "Permission denied"),
    (OSError(28, "No space left on device"), 3, "disk space"),
    (ValueError(f"bad {np.float64(-1.0)!r}"), 3, "internal error ValueError: bad -1.0 "),
    (SolverError(f"margin {np.float64(-2.5)!r} at {np.int64(3)!r}"), 3, "margin -2.5 at 3"),
])
def test_exit_codes_and_one_line_messages(monkeypatch, capsys, exc, code, words):
    rc, err = _run_with(monkeypatch, capsys, exc)
    assert rc == code and words in err, err
    assert err.count("\n") == 1 and "Traceback" not in err and "Errno" not in err
    assert "np.float64" not in err


def test_ctrl_c_while_building_the_parser(monkeypatch, capsys):
    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_main, "build_parser", interrupted)
    assert cli_main.main(["--version"]) == 130
    err = capsys.readouterr().err
    assert err == "formsync: error: interrupted (Ctrl-C)\n"


def test_emit_json_keeps_rationals_exact_and_writes_inf_as_text(capsys):
    third, quarter, big = Fraction(1, 3), Fraction(1, 4), Fraction(10**30 + 1, 7)
    options.emit_json({
        "third": third, "quarter": quarter, "big": big, "ints": np.arange(3),
        "inf": float("inf"), "ninf": np.float64("-inf"), "nan": float("nan"),
        "np": np.float64(0.1), "nested": [(Fraction(3), None, "x", True)],
    })
    doc = json.loads(capsys.readouterr().out)  # valid JSON (strict parser below too)
    assert doc["third"] == "1/3" and Fraction(doc["third"]) == third
    assert doc["quarter"] == 0.25 and Fraction(doc["quarter"]) == quarter
    assert Fraction(doc["big"]) == big  # not rounded to a float
    assert doc["ints"] == [0, 1, 2]
    assert (doc["inf"], doc["ninf"], doc["nan"]) == ("inf", "-inf", "nan")
    assert doc["np"] == 0.1 and doc["nested"] == [[3, None, "x", True]]


def test_emit_json_output_is_strict_json(capsys):
    options.emit_json({"x": float("inf"), "y": [float("nan")]})
    out = capsys.readouterr().out

    def no_constants(name):
        raise AssertionError(f"non-standard JSON constant {name}")

    json.loads(out, parse_constant=no_constants)


def test_cli_options_have_no_gain_range_type_of_their_own():
    from formsync_design import gains

    own = [v for v in vars(options).values()
           if isinstance(v, type) and v.__name__ == "GainRange" and v is not gains.GainRange]
    assert own == [] and "GainRange" not in options.__all__
    r = gains.parse_gain_range("0.1:2", "K_o")
    assert (r.lo, r.hi) == (Fraction(1, 10), Fraction(2))
    assert options.parse_positive("1e-3", "--timeout") == pytest.approx(1e-3)
    for bad in ("0", "-1", "nan", "inf", "abc"):
        with pytest.raises(ValueError):
            options.parse_positive(bad, "--timeout")
    assert math.isfinite(options.parse_positive("5", "x"))
