"""Gain design: SDP optimum against an independent grid search, certificates of
the recommended point and box, penalty effect, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from formsync_design.certify.design import design_gains
from formsync_design.certify.engine import as_box, box_vertices
from formsync_design.cli.main import main
from formsync_design.derive.conditions import derive_conditions
from formsync_design.errors import InputError

RANGES = {"K_o": (0.1, 3), "K_q": (0.1, 3), "beta": (0.05, 0.5)}


def _min_eig(conds, p) -> float:
    return min(float(np.linalg.eigvalsh(f.evaluate(p))[0]) for f in conds.families)


@pytest.fixture(scope="module")
def ring_design():
    c = derive_conditions("ring:6")
    return c, design_gains(c, RANGES, betas=4)


def test_sdp_beats_grid_search(ring_design) -> None:
    c, d = ring_design
    assert d.status == "designed"
    for step in d.sweep:
        assert step.outcome == "ok"
        b = float(step.beta)
        grid = max(_min_eig(c, (ko, kq, b)) for ko in np.linspace(0.1, 3, 25)
                   for kq in np.linspace(0.1, 3, 25))
        # the SDP maximizes the margin: no grid point may beat it
        assert step.t >= grid - 1e-6
        # and its point attains it (independent dense evaluation)
        assert _min_eig(c, (step.K_o, step.K_q, b)) >= step.t - 1e-5


def test_recommended_point_and_box_certified(ring_design) -> None:
    c, d = ring_design
    assert d.point.status == "certified"
    assert d.margin is not None and d.margin > 0
    assert float(d.margin) <= _min_eig(c, [float(v) for v in d.gains.values()]) + 1e-12
    assert d.box_result is not None and d.box_result.status == "certified"
    rng = np.random.default_rng(0)
    lo = np.array([float(a) for a, _ in d.box])
    hi = np.array([float(b) for _, b in d.box])
    for p in lo + (hi - lo) * rng.random((40, 3)):
        assert _min_eig(c, p) > 0
    for lo_hi, rg in zip(d.box, as_box(RANGES).bounds):
        assert rg[0] <= lo_hi[0] <= lo_hi[1] <= rg[1]
    assert 0 < d.box_half_width < 1
    # the box is maximal up to the bisection resolution: a slightly larger one fails
    if d.box_half_width < 0.98:
        s = d.box_half_width + 0.02
        bigger = {g: (max(rg[0], v * (1 - s)), min(rg[1], v * (1 + s)))
                  for (g, v), rg in zip(d.gains.items(), as_box(RANGES).bounds)}
        worst = min(_min_eig(c, [float(x) for x in vx]) for vx in box_vertices(as_box(bigger)))
        assert worst <= 1e-9


def test_penalty_reduces_gain_size() -> None:
    c = derive_conditions("ring:6")
    d0 = design_gains(c, RANGES, betas=3)
    d1 = design_gains(c, RANGES, betas=3, penalty=0.2)
    size = [float(d.gains["K_o"]) / 3 + float(d.gains["K_q"]) / 3 for d in (d0, d1)]
    assert size[1] < size[0]
    assert d1.status == "designed"


def test_infeasible_ranges() -> None:
    c = derive_conditions("star:8")
    d = design_gains(c, {"K_o": (0.05, 0.1), "K_q": (0.05, 0.1), "beta": (0.5, 1)}, betas=3)
    assert d.status == "infeasible" and d.gains == {}


def test_design_input_errors() -> None:
    c = derive_conditions("ring:5")
    with pytest.raises(InputError, match="penalty"):
        design_gains(c, RANGES, penalty=-1)
    with pytest.raises(InputError, match="beta values"):
        design_gains(c, RANGES, betas=[0.9])


def test_cli_design(capsys) -> None:
    rc = main(["design", "--graph", "ring:6", "--ko", "0.1:3", "--kq", "0.1:3", "--beta",
               "0.05:0.5", "--betas", "3", "--format", "json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0 and d["status"] == "designed"
    assert set(d["gains"]) == {"K_o", "K_q", "beta"} and d["certified_margin"] > 0
    rc = main(["design", "--graph", "star:8", "--ko", "0.05:0.1", "--kq", "0.05:0.1", "--beta",
               "0.5:1", "--betas", "2"])
    assert rc == 1
    rc = main(["design", "--graph", "ring:6", "--ko", "0.1:3", "--kq", "0.1:3", "--beta",
               "0.05:0.5", "--penalty", "-2"])
    assert rc == 2 and "penalty" in capsys.readouterr().err
