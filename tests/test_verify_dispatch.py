"""``fs.verify_case`` verifies every case ``formsync verify`` accepts: a shipped case's name
or a case file, read by the engine's case reader and computed by the engine, returning the
engine's result (issue 25, item 1; issue 23: one engine, no case kinds)."""

from __future__ import annotations

from pathlib import Path

import pytest

import formsync_design as fs
from formsync_design.errors import InputError
from formsync_design.resources import case_file, case_names
from formsync_design.tomlio import load_toml
from formsync_design.verify import dispatch

DATA = Path(__file__).parent / "data"
DOCUMENTED = Path(__file__).resolve().parent.parent / "docs" / "engine" / "example.toml"


def test_every_shipped_and_documented_case_is_an_engine_case() -> None:
    for path in [*(case_file(n) for n in case_names()), DOCUMENTED]:
        assert load_toml(path, "case")["case"]["kind"] == "engine", path
    assert fs.verify_case is dispatch.verify_case
    assert "verify_case" in fs.__all__


def test_a_case_is_routed_to_the_engine(monkeypatch) -> None:
    """The shipped case reaches the engine with the parsed case and the progress callback;
    the real case file is parsed."""
    import formsync_design.verify.engine as engine

    seen: list[tuple[tuple, dict]] = []

    def fake(*a, **kw):
        seen.append((a, kw))
        return "result"

    monkeypatch.setattr(engine, "run_engine", fake)

    def say(msg: str) -> None:
        pass

    assert fs.verify_case("lv2012_small", progress=say) == "result"
    (args, kw), = seen
    assert type(args[0]).__name__ == "EngineCase" and say in (*args, *kw.values())
    assert args[0].path == str(case_file("lv2012_small"))


def test_small_case_returns_the_engine_result() -> None:
    res = fs.verify_case(DATA / "case_short_horizon.toml")
    assert isinstance(res, fs.EngineVerification)
    assert [c.claim.id for c in res.claims] == ["convergence", "accuracy", "late"]


def test_bad_cases_are_refused_with_one_line() -> None:
    with pytest.raises(InputError, match="expected a case name in"):
        fs.verify_case("no_such_case")
    with pytest.raises(InputError, match="expected an existing case TOML file"):
        fs.verify_case(DATA / "missing.toml")
    with pytest.raises(InputError, match='expected \\[case\\] kind = "engine"'):
        fs.verify_case(DATA / "case_with_spec.toml")  # a simulation case, not a verification case
    with pytest.raises(InputError) as e:  # a tracking design cannot run a formation's case
        fs.verify_case(DATA / "case_short_horizon.toml", spec="zhang2014_flyaround")
    assert "\n" not in str(e.value)  # read in the tracking form: its tables are missing


@pytest.mark.slow
def test_lv2012_small_is_verified_from_python() -> None:
    """The small lv2012 case as ``formsync verify lv2012_small`` judges it
    (reports/lv2012_small-verification.md): every claim holds but the theorem's graph class
    (no counterexample decides nothing)."""
    res = fs.verify_case("lv2012_small")
    assert type(res).__name__ == "EngineVerification" and res.case.base.name == "lv2012_small"
    verdicts = {c.claim.id: c.verdict for c in res.claims}
    assert verdicts.pop("theorem") == "undecided"
    assert verdicts and set(verdicts.values()) == {"holds"}
