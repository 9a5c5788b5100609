"""``fs.verify_case`` verifies a case of every kind ``formsync verify`` accepts (issue 25,
item 1), dispatching on ``[case] kind`` like the command line, and returns that kind's
result object."""

from __future__ import annotations

from pathlib import Path

import pytest

import formsync_design as fs
from formsync_design.errors import InputError
from formsync_design.resources import case_file, case_names
from formsync_design.tomlio import load_toml
from formsync_design.verify import dispatch
from formsync_design.verify.kinds import KINDS, case_kind

DATA = Path(__file__).parent / "data"

#: the module attribute each kind's computation is looked up under
COMPUTE = {
    "engine": ("formsync_design.verify.engine", "run_engine"),
}


def _shipped_kinds() -> dict[str, str]:
    """kind -> the smallest shipped case of that kind (by file size)."""
    out: dict[str, Path] = {}
    for name in case_names():
        p = case_file(name)
        k = case_kind(load_toml(p, "case"), name)
        if k not in out or p.stat().st_size < out[k].stat().st_size:
            out[k] = p
    return {k: p.stem for k, p in out.items()}


#: the documented example cases (docs/), checked to be of their kind
DOCUMENTED = {"engine": Path(__file__).resolve().parent.parent / "docs" / "engine" / "example.toml"}


def test_every_kind_has_a_result_and_a_shipped_case() -> None:
    assert set(dispatch.RESULT_KINDS) == set(KINDS)
    # the classic formation kind has no shipped case since liang2016 and pd_consensus run on
    # the engine (issue 23: it is to be deleted); its test case is still of its kind
    assert set(_shipped_kinds()) == set(KINDS) - {"formation"}
    assert case_kind(load_toml(DATA / "case_short_horizon.toml", "case"), "test") == "formation"
    for kind, path in DOCUMENTED.items():
        assert case_kind(load_toml(path, "case"), str(path)) == kind
    assert fs.verify_case is dispatch.verify_case
    assert "verify_case" in fs.__all__


@pytest.mark.parametrize("kind", sorted(COMPUTE))
def test_each_kind_is_routed_to_its_own_verifier(kind, monkeypatch) -> None:
    """The shipped case of each kind reaches that kind's computation (and no other), with
    the design and the progress callback passed on; the real case file is parsed."""
    import importlib

    seen: list[tuple[str, tuple, dict]] = []
    for k, (mod, fn) in COMPUTE.items():
        def fake(*a, _k=k, **kw):
            seen.append((_k, a, kw))
            return ("result of", _k)
        monkeypatch.setattr(importlib.import_module(mod), fn, fake)
    name = _shipped_kinds()[kind]

    def say(msg: str) -> None:
        pass

    assert fs.verify_case(name, progress=say) == ("result of", kind)
    assert [s[0] for s in seen] == [kind]
    _, args, kw = seen[0]
    assert say in (*args, *kw.values())
    if kind == "engine":  # the parsed engine case
        assert type(args[0]).__name__ == "EngineCase"
    else:
        assert Path(args[0]) == case_file(name)


def test_formation_case_returns_the_verification_result() -> None:
    res = fs.verify_case(DATA / "case_short_horizon.toml")
    assert type(res).__name__ == "VerificationResult"
    assert res.claims and all(c.spec.key for c in res.claims)


def test_bad_cases_are_refused_with_one_line() -> None:
    with pytest.raises(InputError, match="expected a case name in"):
        fs.verify_case("no_such_case")
    with pytest.raises(InputError, match="expected an existing case TOML file"):
        fs.verify_case(DATA / "missing.toml")
    with pytest.raises(InputError, match="expected a formation design"):
        fs.verify_case(DATA / "case_short_horizon.toml", spec=DATA / "agent_so3.py")


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
