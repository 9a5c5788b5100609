"""Region maps: tiling, agreement with the closed-form conditions, soundness of
classes against an independent dense evaluation, JSON and figure output, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from formsync_design.certify.plots import write_region
from formsync_design.certify.region import closed_form_agreement, region_map
from formsync_design.certify.subdivision import map_to_dict, rasterize
from formsync_design.cli.main import main
from formsync_design.derive.closed_form import closed_form_conditions
from formsync_design.derive.conditions import derive_conditions, paper_conditions
from formsync_design.errors import InputError

RANGES = {"K_o": ("0.05", "5"), "K_q": ("0.05", "5"), "beta": ("0.01", "1")}


def _min_eig(conds, p) -> float:
    return min(float(np.linalg.eigvalsh(f.evaluate(p))[0]) for f in conds.families)


@pytest.fixture(scope="module")
def ring_map():
    c = derive_conditions("ring:6")
    return c, region_map(c, RANGES, resolution=8)


def test_boxes_tile_the_domain(ring_map) -> None:
    _, m = ring_map
    cells = np.zeros((8, 8, 8), dtype=int)
    for b in m.boxes:
        i0, i1, j0, j1, k0, k1 = b.index
        cells[i0:i1, j0:j1, k0:k1] += 1
    assert np.all(cells == 1)
    assert abs(sum(m.fractions.values()) - 1) < 1e-12
    assert m.fractions["certified"] > 0.3 and m.fractions["refuted"] > 0.1
    assert set(np.unique(rasterize(m))) <= {-1, 0, 1}


@pytest.mark.parametrize("spec, which", [("ring:6", "derived"), ("star:5", "derived"),
                                         ("ring:6", "paper"), ("complete:4", "paper")])
def test_map_agrees_with_closed_form(spec, which) -> None:
    c = derive_conditions(spec) if which == "derived" else paper_conditions(spec)
    m = region_map(c, RANGES, resolution=8)
    ag = closed_form_agreement(m, c, samples=6, seed=5)
    assert ag["conditions"] >= 3 and ag["checked"] > 500
    assert ag["disagree"] == 0
    # undecided boxes are never entirely admissible: some point violates a condition
    # (they straddle a boundary, or different matrices fail in different parts)
    import sympy as sp

    from formsync_design.spec.loader import gain_symbols

    fns = [sp.lambdify(gain_symbols(), cf.substituted(), "numpy") for cf in closed_form_conditions(c)]
    for b in m.boxes:
        if b.cls != "undecided":
            continue
        lo = np.array([float(v) for v in b.lo])
        hi = np.array([float(v) for v in b.hi])
        grid = lo + (hi - lo) * np.stack(np.meshgrid(*[np.linspace(0, 1, 5)] * 3), -1).reshape(-1, 3)
        worst = np.min([np.broadcast_to(f(*grid.T), len(grid)) for f in fns], axis=0)
        assert worst.min() <= 1e-9


def test_classes_against_dense_eigenvalues(ring_map) -> None:
    c, m = ring_map
    rng = np.random.default_rng(42)
    for b in m.boxes:
        lo = np.array([float(v) for v in b.lo])
        hi = np.array([float(v) for v in b.hi])
        for p in lo + (hi - lo) * rng.random((3, 3)):
            lam = _min_eig(c, p)
            if b.cls == "certified":
                assert lam > 0
            elif b.cls == "refuted":
                assert lam <= 1e-12


def test_margin_shrinks_certified_region() -> None:
    c = derive_conditions("ring:5")
    r = {"K_o": (0.1, 3), "K_q": (0.1, 3), "beta": 0.3}
    m0 = region_map(c, r, resolution=8)
    m1 = region_map(c, r, resolution=8, margin=0.05)
    assert m1.fractions["certified"] < m0.fractions["certified"]
    assert m0.resolution == (8, 8, 0)


def test_json_shape_and_files(tmp_path, ring_map) -> None:
    c, m = ring_map
    d = map_to_dict(m)
    assert set(d) >= {"graph", "conditions", "ranges", "resolution", "fractions", "boxes", "counts"}
    assert sum(d["counts"].values()) == len(d["boxes"])
    assert {b["class"] for b in d["boxes"]} <= {"certified", "refuted", "undecided"}
    assert all(len(b["lo"]) == 3 and len(b["hi"]) == 3 for b in d["boxes"])
    json.dumps(d, allow_nan=False)


@pytest.mark.slow
def test_figures_are_byte_reproducible(tmp_path, ring_map) -> None:
    c, m = ring_map
    p1 = write_region(tmp_path / "a", [m], conditions=[c], timing=False)
    p2 = write_region(tmp_path / "b", [m], conditions=[c], timing=False)
    assert [p.name for p in p1] == ["region.json", "region-ko-kq.png", "region-beta-ko.png",
                                    "region-3d.png"]
    for a, b in zip(p1, p2):
        assert a.read_bytes() == b.read_bytes()


def test_region_input_errors() -> None:
    c = derive_conditions("ring:5")
    with pytest.raises(InputError, match="resolution"):
        region_map(c, RANGES, resolution=0)
    with pytest.raises(InputError, match="(?i)lo <= hi"):
        region_map(c, {"K_o": (2, 1), "K_q": 1, "beta": 1})


def test_cli_region(tmp_path, capsys) -> None:
    out = tmp_path / "map"
    rc = main(["region", "--graph", "ring:5", "--graph", "star:5", "--ko", "0.1:3", "--kq",
               "0.1:3", "--beta", "0.05:0.8", "--resolution", "6", "--conditions", "both",
               "--out", str(out), "--format", "json", "--no-progress"])
    cap = capsys.readouterr()
    assert rc == 0
    d = json.loads(cap.out)
    assert len(d["maps"]) == 4
    doc = json.loads((out / "region.json").read_text())
    assert len(doc["maps"]) == 2 and len(doc["overlay"]) == 2
    assert (out / "region-ko-kq.png").is_file() and (out / "region-3d.png").is_file()


@pytest.mark.parametrize("extra, needle", [
    (["--resolution", "0"], "resolution"),
    (["--beta-slices", "5"], "beta slices"),
    (["--conditions", "nope"], "derived, paper or both"),
    (["--ko", "3:1"], "reversed"),
])
def test_cli_region_bad_input(tmp_path, capsys, extra, needle) -> None:
    argv = ["region", "--graph", "ring:5", "--ko", "0.1:3", "--kq", "0.1:3", "--beta", "0.05:0.8",
            "--out", str(tmp_path / "x")]
    for k, v in zip(extra[::2], extra[1::2]):
        if k in argv:
            argv[argv.index(k) + 1] = v
        else:
            argv += [k, v]
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2 and needle in err and err.count("\n") == 1
