"""Verification of published claims: parsing, measured quantities, verdict logic, CLI."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.derive.conditions import derive_conditions
from formsync_design.errors import InputError
from formsync_design.sim.simulator import simulate
from formsync_design.verify.case import load_case
from formsync_design.verify.verification import (
    chatter_end_time,
    parse_claims,
    verify_case,
    write_verification_report,
)

SMALL = Path(__file__).parent / "data" / "small_case.toml"
ITEM = {"text": "t", "paper": "p", "quantity": "tail_q_m", "op": "<=", "value": 1e-4}


@pytest.mark.parametrize(
    "table, fragment",
    [
        ({}, "[claims]"),
        ({"topologies": []}, "non-empty"),
        ({"topologies": ["ring:3"]}, "claims.items"),
        ({"topologies": ["ring:3"], "items": {"a": {**ITEM, "quantity": "magic"}}}, "quantity"),
        ({"topologies": ["ring:3"], "items": {"a": {**ITEM, "op": "~"}}}, "op"),
        ({"topologies": ["ring:3"], "items": {"a": {**ITEM, "value": float("nan")}}}, "finite"),
        ({"topologies": ["ring:3"], "items": {"a": {"text": "t"}}}, "missing"),
        ({"topologies": ["ring:3"], "colour": 1, "items": {"a": ITEM}}, "unknown"),
        ({"topologies": ["ring:3"], "tail_fraction": 1.5, "items": {"a": ITEM}}, "tail_fraction"),
        ({"topologies": ["ring:3"], "phi_sweep": [0], "items": {"a": ITEM}}, "phi_sweep"),
    ],
)
def test_bad_claims_tables(table, fragment):
    with pytest.raises(InputError, match=fragment.replace("[", r"\[")):
        parse_claims(table)


def test_chatter_measure_on_known_signals():
    t = np.arange(0.0, 20.0, 0.1)
    chat = np.where(t < 6, (-1.0) ** np.arange(t.size), 0.01 * np.exp(-t))
    end = chatter_end_time(t, chat[:, None])
    assert 5.5 <= end < 6.0
    assert chatter_end_time(t, np.exp(-t)[:, None]) is None


def test_small_case_verdicts_are_consistent_with_direct_runs(tmp_path):
    res = verify_case(SMALL)
    case = load_case(SMALL)
    by = {t.graph: t for t in res.topologies}
    for g in ("ring:3", "path:3"):
        r = simulate(case.formation(g), case.options)
        expected = r.convergence_time if r.convergence_time is not None else math.inf
        assert by[g].quantities["convergence_time"] == expected
        lam = min(np.linalg.eigvalsh(derive_conditions(g).pi.evaluate((1.6, 0.4, 0.3))))
        assert by[g].quantities["pi_pd"] == (1.0 if lam > 0 else 0.0)
    for c in res.claims:
        assert c.holds_on == {k: c.spec.check(v) for k, v in c.measured.items()}
        n_ok = sum(c.holds_on.values())
        assert c.verdict == ("holds" if n_ok == 2 else "fails" if n_ok == 0 else "depends on topology")
    # sensitivity rows: one per swept value, and unlimited torque equals the plain run
    assert [r.parameter for r in res.sensitivity] == ["boundary_layer"] * 2 + ["torque_limit"] * 2
    plain = simulate(case.formation("ring:3"), replace(case.options, torque_limit=None))
    assert res.sensitivity[2].convergence_time == plain.convergence_time
    md, figs = write_verification_report(res, tmp_path, command="x")
    text = md.read_text()
    assert "## Claims" in text and "## Sensitivity study" in text
    assert all(p.is_file() for p in figs)


def test_cli_json_strict_and_bad_input(tmp_path, capsys):
    rc = main(["verify", str(SMALL), "--out", str(tmp_path), "--format", "json", "--strict"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == (0 if doc["all_claims_hold"] else 1)
    assert {c["key"] for c in doc["claims"]} == {"convergence", "pi_pd", "kv"}
    assert (tmp_path / "small3-verification.md").is_file()
    assert main(["verify", "no-such-case"]) == 2
    assert "expected a case name" in capsys.readouterr().err
