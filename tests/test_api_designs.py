"""The curated API on every design (issue 25, item 1): the public functions of ``fs`` that
take a design accept every design the command line accepts - Lagrangian, agent, and design
files that are not shipped (copies of ``derivations/ma_mrp_ft.py`` and ``lv2012.py`` loaded by
path).  A design a stage does not apply to is refused with a one-line
:class:`~formsync_design.errors.FormsyncError` (no IndexError, no TypeError)."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import formsync_design as fs
from formsync_design.cli.defaults import agent_box
from formsync_design.resources import design_file
from formsync_design.verify.defaults import case_source

SHIPPED = ("liang2016", "pd_consensus", "agent:liang2016", "lv2012", "ma_so3", "ma_quat_smc",
           "ma_mrp_ft", "selftrigger_mrp", "zhang2014_flyaround")
FILES = ("file:ma_mrp_ft", "file:lv2012")
FUNCTIONS = ("derive_conditions", "write_derivation_report", "certify_box", "region_map",
             "design_gains", "simulate", "monte_carlo", "to_statespace")

FAST = {("derive_conditions", "file:lv2012"), ("write_derivation_report", "file:ma_mrp_ft"),
        ("certify_box", "lv2012"), ("region_map", "file:lv2012"), ("design_gains", "lv2012"),
        ("simulate", "file:ma_mrp_ft"), ("monte_carlo", "file:lv2012"),
        ("simulate", "pd_consensus"), ("region_map", "pd_consensus"),
        ("to_statespace", "liang2016"), ("to_statespace", "file:lv2012"),
        ("to_statespace", "file:ma_mrp_ft")}


def _design(key: str, tmp_path: Path) -> tuple[object, object]:
    """``(the argument as a user passes it, the loaded design)``."""
    if key.startswith("file:"):
        name = key.split(":", 1)[1]
        path = tmp_path / "mine" / f"{name}.py"
        path.parent.mkdir(exist_ok=True)
        shutil.copy(design_file(name), path)
        return path, fs.load_design(path)
    if key.startswith("agent:"):  # the agent form of a design with a Lagrangian view, as a value
        d = fs.load_design(key.split(":", 1)[1])
        return d, d
    d = fs.load_design(key)
    # a name of a design with a Lagrangian view resolves to that view in every function
    return key, getattr(d, "lagrangian", None) or d


def _case(d: object) -> object:
    """The design's case (agent: its own or where it is compared; Lagrangian: its own)."""
    from formsync_design.cli.agent_inputs import agent_case_for

    if getattr(getattr(d, "decl", None), "plant", "attitude") == "relative-orbit":
        return fs.load_case()  # a formation to hand the formation stages (which refuse it)
    if getattr(d, "form", None) == "agent":
        return agent_case_for(d, None, None)
    src = case_source(d)
    return fs.load_case(src.path if src is not None else None)


def _box(d: object, case: object) -> object:
    if getattr(d, "form", None) == "agent":
        return agent_box(d, None, case, None, free=2)
    vals = case.gains.as_dict()  # type: ignore[attr-defined]
    free = next(iter(vals))
    lo = float(vals[free])
    return {**{n: float(v) for n, v in vals.items()}, free: (0.9 * lo, 1.1 * lo)}


def _cells() -> list:
    out = []
    for fn in FUNCTIONS:
        for key in SHIPPED + FILES:
            marks = () if (fn, key) in FAST else (pytest.mark.slow,)
            out.append(pytest.param(fn, key, marks=marks, id=f"{fn}-{key}"))
    return out


def test_the_fast_cells_cover_every_function() -> None:
    assert {fn for fn, _ in FAST} == set(FUNCTIONS)
    assert {k for _, k in FAST} >= set(FILES)


@pytest.mark.parametrize("fn,key", _cells())
def test_public_functions_accept_every_design(fn: str, key: str, tmp_path: Path) -> None:
    arg, d = _design(key, tmp_path)
    tracking = getattr(getattr(d, "decl", None), "plant", "attitude") == "relative-orbit"
    certified = getattr(d, "form", None) != "agent" or callable(d.module.get("conditions"))
    refused = tracking or (fn in ("derive_conditions", "certify_box", "region_map",
                                  "design_gains") and not certified)
    try:
        _call(fn, arg, d, tmp_path)
    except fs.FormsyncError as e:
        assert refused, f"{fn} refused {key}: {e}"
        assert "\n" not in str(e) and "expected" in str(e)  # one line: expected X, received Y
        return
    assert not refused, f"{fn} ran on {key}, which it should refuse"


def _call(fn: str, arg: object, d: object, tmp_path: Path) -> None:
    agent = getattr(d, "form", None) == "agent"
    if fn == "write_derivation_report":
        graph = "ring:4"
        rep = fs.write_derivation_report(graph, tmp_path / "rep", spec=arg)
        md = Path(rep if isinstance(rep, (str, Path)) else rep.markdown)
        text = md.read_text(encoding="utf-8")
        want = arg.name if hasattr(arg, "form") else str(arg)  # a design value: its name
        assert f"--design {want}" in text, text[:400]
        if isinstance(arg, Path):  # the Regenerate line names the file, which resolves
            assert fs.load_design(want).key == d.key  # type: ignore[attr-defined]
        return
    case = _case(d)
    if fn == "derive_conditions":
        c = fs.derive_conditions(case.graph(), spec=arg)  # type: ignore[attr-defined]
        assert len(c.families) >= 1
        return
    if fn in ("certify_box", "region_map", "design_gains"):
        conds = fs.derive_conditions(case.graph(), spec=arg)  # type: ignore[attr-defined]
        box = _box(d, case)
        if fn == "certify_box":
            res = (fs.certify_agent(d, conds, box) if agent
                   else fs.certify_with_multipliers(conds, box, {
                       n: d.decl.gain(n).range for n in d.decl.multipliers})  # type: ignore[attr-defined]
                   if d.decl.multipliers else fs.certify_box(conds, box))  # type: ignore[attr-defined]
            assert str(res.status) in ("certified", "refuted", "undecided")
        elif fn == "region_map":
            m = fs.region_map(conds, box, resolution=2)
            assert abs(sum(m.fractions.values()) - 1) < 1e-12
        else:
            des = fs.design_gains(conds, box, betas=2, design=d)
            assert str(des.status) in ("recommended", "not-found", "designed", "infeasible",
                                       "not-certified")
        return
    if fn == "simulate":
        if agent:
            opt = replace(case.options, tf=1.0)  # type: ignore[attr-defined]
            r = fs.simulate(case.formation(), opt, spec=arg)  # type: ignore[attr-defined]
        else:
            r = fs.simulate(case.formation(), fs.SimOptions(tf=1.0), spec=arg)  # type: ignore[attr-defined]
        assert np.all(np.isfinite(r.t))
        return
    if fn == "to_statespace":
        pytest.importorskip("control")
        f = case.formation()  # type: ignore[attr-defined]
        gains = case.gains.as_dict()  # type: ignore[attr-defined]
        if not agent:
            sw = d.decl.switching  # type: ignore[attr-defined]
            if sw is not None:
                gains[sw] = case.gains.K_v[0]  # type: ignore[attr-defined]
        sys = fs.to_statespace(arg, f.graph, f.inertias, gains)
        assert sys.ninputs == 3 * f.n and np.all(np.isfinite(sys.A))
        return
    assert fn == "monte_carlo"
    settings = fs.MonteCarloSettings(runs=2, seed=3, max_angle_deg=10, max_rate=0.01)
    if agent:
        opt = replace(case.options, tf=1.0)  # type: ignore[attr-defined]
    else:
        opt = fs.SimOptions(tf=1.0, step=0.1, output_step=0.5)
    res = fs.monte_carlo(case.formation(), None, settings, opt, spec=arg,  # type: ignore[attr-defined]
                         certify=False)
    assert len(res.runs) == 2
    assert [r.seed for r in res.runs] == [r.seed for r in fs.monte_carlo(
        case.formation(), None, settings, opt, spec=arg, certify=False).runs]  # type: ignore[attr-defined]
