"""Certification over gain boxes: soundness against an independent dense
evaluation, exact witnesses, rigorous bounds, solver-status mapping, CLI."""

from __future__ import annotations

import json
from fractions import Fraction
from types import SimpleNamespace

import numpy as np
import pytest
import sympy as sp

from formsync_design.certify.engine import as_box, box_vertices, certify_box, check_kv
from formsync_design.certify.exact import exact_ldl, rigorous_lower_bound
from formsync_design.cli.main import main
from formsync_design.derive.closed_form import required_kv
from formsync_design.derive.conditions import derive_conditions, paper_conditions
from formsync_design.derive.families import family_from_sympy
from formsync_design.errors import InputError
from formsync_design.graphs.build import make_graph

GRAPHS = ["ring:5", "star:6", "path:5", "complete:5", "random:7:0.5:3", "circulant:8:1,3"]


def _conds(spec: str, which: str):
    return derive_conditions(spec) if which == "derived" else paper_conditions(spec)


def _dense_min_eig(conds, point) -> tuple[float, str]:
    """Smallest eigenvalue over all families at a point, by dense numpy (independent
    of the certification code: MatrixFamily.evaluate + numpy.linalg.eigvalsh)."""
    best = (np.inf, "")
    for f in conds.families:
        lam = float(np.linalg.eigvalsh(f.evaluate(point))[0])
        if lam < best[0]:
            best = (lam, f.name)
    return best


def _exact_quad(fam, point, x) -> Fraction:
    """x^T F(point) x in exact rationals via MatrixFamily.evaluate_exact."""
    m = [[Fraction(int(v.numerator), int(v.denominator)) for v in row]
         for row in fam.evaluate_exact(point)]  # plain ints: numpy ints overflow
    return sum(
        (m[i][j] * x[i] * x[j] for i in range(fam.size) for j in range(fam.size) if x[i] and x[j]),
        Fraction(0),
    )


def _random_box(rng: np.random.Generator) -> dict[str, tuple[float, float]]:
    out = {}
    for g, (lo, hi) in {"K_o": (0.05, 5.0), "K_q": (0.05, 5.0), "beta": (0.01, 1.0)}.items():
        c = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        w = c * float(rng.choice([0.0, 0.02, 0.2, 0.6]))
        out[g] = (round(max(lo, c - w), 4), round(c + w, 4))
    return out


def _points_in(box: dict, rng: np.random.Generator, k: int) -> np.ndarray:
    lo = np.array([box[g][0] for g in ("K_o", "K_q", "beta")])
    hi = np.array([box[g][1] for g in ("K_o", "K_q", "beta")])
    return lo + (hi - lo) * rng.random((k, 3))


# ---------------------------------------------------------------------------
# soundness: certified boxes contain no non-PD point
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["derived", "paper"])
def test_certified_boxes_are_pd_everywhere(which: str) -> None:
    rng = np.random.default_rng(20261123)
    counts = {"certified": 0, "refuted": 0, "undecided": 0}
    for spec in GRAPHS:
        conds = _conds(spec, which)
        for _ in range(14):
            box = _random_box(rng)
            margin = float(rng.choice([0.0, 0.0, 0.01]))
            r = certify_box(conds, box, margin=margin, use_sdp=bool(rng.random() < 0.3))
            counts[r.status] += 1
            if r.status == "certified":
                pts = np.vstack([_points_in(box, rng, 25),
                                 [[float(v) for v in vx] for vx in box_vertices(as_box(box))]])
                for p in pts:
                    lam, name = _dense_min_eig(conds, p)
                    assert lam > margin - 1e-9, (spec, box, p, name, lam)
                assert r.margin_lower_bound is not None
                assert r.margin_lower_bound > margin
            elif r.status == "refuted":
                w = r.witness
                fam = next(f for f in conds.families if f.name == w.family)
                xx = sum(v * v for v in w.x)
                pt = tuple(w.point[g] for g in conds.gains)
                # exact, with the library's independent rational evaluation
                assert _exact_quad(fam, pt, w.x) - Fraction(margin).limit_denominator(10**9) * xx <= 0
                assert w.value <= 0
                if w.covers_box:
                    for vx in box_vertices(as_box(box)):
                        assert _exact_quad(fam, vx, w.x) - r.margin * xx <= 0
    # the random boxes exercise all outcomes that can occur
    assert counts["certified"] > 10 and counts["refuted"] > 10


def test_boxes_near_the_boundary() -> None:
    """Boxes ending just before/after the Pi boundary K_o = beta lambda_max(L)."""
    conds = derive_conditions("ring:8")  # lambda_max(L) = 4
    lam = max(make_graph("ring:8").laplacian_eigenvalues)
    for eps, want in ((Fraction(1, 10**9), "certified"), (Fraction(0), "refuted"),
                      (Fraction(-1, 10**9), "refuted")):
        beta = Fraction(3, 10)
        ko_lo = beta * 4 + eps
        r = certify_box(conds, {"K_o": (ko_lo, ko_lo + 1), "K_q": (Fraction(2), Fraction(3)),
                                "beta": (Fraction(1, 10), beta)})
        assert r.status == want, (eps, r.reason)
        if want == "refuted":
            assert r.witness.family == "Pi"
            lam_dense = _dense_min_eig(conds, [float(v) for v in r.witness.point.values()])[0]
            assert lam_dense < 1e-8
    assert abs(lam - 4) < 1e-12


@pytest.mark.parametrize("spec", ["ring:40", "random:40:0.25:2", "star:60"])
def test_large_blocks_pencil_and_dense_paths(spec: str) -> None:
    """Blocks above EXACT_MAX use the pencil enclosure / blocked Cholesky: still sound."""
    rng = np.random.default_rng(7)
    for which in ("derived", "paper"):
        conds = _conds(spec, which)
        seen = set()
        for _ in range(6):
            box = _random_box(rng)
            r = certify_box(conds, box, use_sdp=False)
            seen.add(r.status)
            if r.status == "certified":
                for p in _points_in(box, rng, 6):
                    assert _dense_min_eig(conds, p)[0] > 0
            if r.status == "refuted":
                fam = next(f for f in conds.families if f.name == r.witness.family)
                pt = tuple(r.witness.point[g] for g in conds.gains)
                assert _exact_quad(fam, pt, r.witness.x) <= 0
    assert "certified" in seen or "refuted" in seen


def test_paper_gains_verdicts_follow_the_closed_forms() -> None:
    """Expected verdicts from the closed forms, not typed in: Pi > 0 iff K_o > beta
    lambda_max(L) (lambda_max integer for ring:8, star:8, complete:8: checked against
    numpy), Theta_i > 0 iff K_q + beta K_o > 2 m_i beta^2."""
    ko, kq, beta = Fraction("1.6"), Fraction("0.4"), Fraction("0.3")
    pt = {"K_o": "1.6", "K_q": "0.4", "beta": "0.3"}
    seen = set()
    for spec in ("ring:8", "star:8", "complete:8"):
        g = make_graph(spec)
        lam = round(max(g.laplacian_eigenvalues))
        assert abs(max(g.laplacian_eigenvalues) - lam) < 1e-9
        holds = ko > beta * lam and all(kq + beta * ko > 2 * m * beta**2 for m in g.degrees)
        r = certify_box(derive_conditions(spec), pt)
        assert r.status == ("certified" if holds else "refuted"), spec
        seen.add(str(r.status))
        if not holds:
            fam = next(f for f in derive_conditions(spec).families if f.name == r.witness.family)
            assert _exact_quad(fam, tuple(r.witness.point.values()), r.witness.x) <= 0
    assert seen == {"certified", "refuted"}


def test_margin_is_tight_against_dense_minimum() -> None:
    conds = derive_conditions("circulant:8:1,3")
    box = {"K_o": (2.0, 2.5), "K_q": (0.5, 1.0), "beta": (0.1, 0.2)}
    r = certify_box(conds, box)
    assert r.status == "certified"
    dense = min(_dense_min_eig(conds, [float(v) for v in vx])[0]
                for vx in box_vertices(as_box(box)))
    assert float(r.margin_lower_bound) <= dense
    assert float(r.margin_lower_bound) >= dense - 1e-9
    # a required margin above the true minimum is refuted with a witness
    r2 = certify_box(conds, box, margin=dense + 1e-3)
    assert r2.status == "refuted" and r2.witness.rayleigh <= Fraction(dense + 1e-3)


def test_witness_covers_box_means_every_vertex_violates() -> None:
    conds = derive_conditions("star:8")
    box = {"K_o": (0.1, 0.5), "K_q": (0.1, 0.2), "beta": (0.5, 0.9)}
    r = certify_box(conds, box)
    assert r.status == "refuted" and r.witness.covers_box
    fam = next(f for f in conds.families if f.name == r.witness.family)
    rng = np.random.default_rng(1)
    for p in _points_in(box, rng, 20):
        v = np.array(r.witness.x, dtype=float)
        assert v @ fam.evaluate(p) @ v <= 1e-9 * (v @ v)


# ---------------------------------------------------------------------------
# exact and rigorous arithmetic
# ---------------------------------------------------------------------------
def test_exact_ldl_agrees_with_eigenvalues_and_witness_is_exact() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 7))
        a = rng.integers(-4, 5, size=(n, n))
        a = a + a.T + np.diag(rng.integers(0, 12, size=n))
        fa = [[Fraction(int(v)) for v in row] for row in a]
        pd, x = exact_ldl(fa)
        lam = np.linalg.eigvalsh(a.astype(float))[0]
        if abs(lam) > 1e-9:
            assert pd == (lam > 0)
        if not pd:
            q = sum(fa[i][j] * x[i] * x[j] for i in range(n) for j in range(n))
            assert q <= 0


def test_rigorous_lower_bound_is_a_lower_bound_exactly() -> None:
    """ell from the float Cholesky bound satisfies A - ell I > 0 in exact arithmetic,
    including nearly singular matrices (Laplacian + tiny shift)."""
    rng = np.random.default_rng(11)
    for trial in range(60):
        n = int(rng.integers(2, 30))
        if trial % 3 == 0:
            g = make_graph("path:2")
            for seed in range(50):
                try:
                    g = make_graph(f"random:{max(n, 3)}:0.5:{seed}")
                    break
                except InputError:
                    continue
            mats = [g.laplacian, np.eye(g.n, dtype=np.int64)]
            w = np.array([[1.0, float(rng.choice([1e-12, 1e-6, 0.3]))]])
            n = g.n
        else:
            a = rng.integers(-5, 6, size=(n, n))
            mats = [a + a.T, np.eye(n, dtype=np.int64)]
            w = np.array([[float(rng.uniform(0.1, 2)), float(rng.uniform(5, 40))]])
        exact_w = [Fraction(float(v)) for v in w[0]]
        A = sum(float(wk) * m for wk, m in zip(w[0], mats))
        lam = np.linalg.eigvalsh(A)[0]
        sigma = np.array([lam - 1e-9 * max(1.0, abs(lam))])
        ell = rigorous_lower_bound(mats, w, sigma)[0]
        if not np.isfinite(ell):
            continue
        assert ell <= lam + 1e-12
        ex = [[sum((wk * int(m[i, j]) for wk, m in zip(exact_w, mats)), Fraction(0))
               - (Fraction(float(ell)) if i == j else 0) for j in range(n)] for i in range(n)]
        assert exact_ldl(ex)[0], (trial, ell, lam)


def test_rigorous_lower_bound_refuses_wrong_hints() -> None:
    a = np.array([[2, 1], [1, 2]])  # eigenvalues 1, 3
    ell = rigorous_lower_bound([a], np.array([[1.0]]), np.array([1.5]))
    assert ell[0] == -np.inf  # Cholesky of A - 1.5 I breaks down: nothing claimed


# ---------------------------------------------------------------------------
# structure, status mapping, non-multi-affine families
# ---------------------------------------------------------------------------
def test_unknown_status_is_error_but_never_vetoes(monkeypatch: pytest.MonkeyPatch) -> None:
    """An unknown solver status maps to outcome ``error``; the re-check still decides
    (truth, closed forms: Pi > 0 iff K_o > beta lambda_max(L), lambda_max(ring:5) < 4,
    lambda_max(star:5) = 5; Theta_i > 0 iff K_q + beta K_o > 2 m_i beta^2)."""
    import cvxpy as cp

    orig = cp.Problem.solve

    def fake(self, *a, **k):
        orig(self, *a, **k)
        self._status = "something_new"
        return self.value

    monkeypatch.setattr(cp.Problem, "solve", fake)
    r = certify_box(derive_conditions("ring:5"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3},
                    use_sdp="always")
    assert r.solver.outcome == "error" and r.solver.raw_status == "something_new"
    assert r.status == "certified" and "re-check alone" in r.reason
    r = certify_box(derive_conditions("star:5"), {"K_o": 1.4, "K_q": 0.4, "beta": 0.3},
                    use_sdp="always")
    assert r.status == "refuted" and r.witness.family == "Pi"  # 1.4 < 0.3 * 5


def test_inaccurate_solve_gives_the_recheck_verdict(monkeypatch: pytest.MonkeyPatch) -> None:
    import cvxpy as cp

    orig = cp.Problem.solve

    def fake(self, *a, **k):
        orig(self, *a, **k)
        self._status = "optimal_inaccurate"
        return self.value

    box = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    alone = certify_box(derive_conditions("ring:5"), box, use_sdp=False)
    monkeypatch.setattr(cp.Problem, "solve", fake)
    r = certify_box(derive_conditions("ring:5"), box, use_sdp="always")
    assert r.solver.outcome == "inaccurate" and "inaccurate" in r.reason
    assert r.status == alone.status == "certified"


def _toy(matrix) -> SimpleNamespace:
    ko, kq, b = sp.symbols("K_o K_q beta")
    fam = family_from_sympy("F", sp.Matrix(matrix(ko, kq, b)), (ko, kq, b))
    assert not fam.is_multiaffine
    return SimpleNamespace(families=(fam,), gains=("K_o", "K_q", "beta"),
                           graph=make_graph("path:2"), source="test")


def test_not_multiaffine_interval_subdivision_is_sound() -> None:
    """A family with beta^2 (not multi-affine): certified only through the interval
    argument, checked against dense eigenvalues on random points."""
    conds = _toy(lambda ko, kq, b: [[ko, b**2], [b**2, kq]])
    rng = np.random.default_rng(5)
    for box, want in (({"K_o": (1, 2), "K_q": (1, 2), "beta": (0.5, 0.9)}, "certified"),
                      ({"K_o": (1, 1.1), "K_q": (1, 1.1), "beta": (0.5, 0.99)}, "certified"),
                      ({"K_o": 1, "K_q": 1, "beta": (0.5, 1.2)}, "refuted")):
        r = certify_box(conds, box)
        assert r.status == want
        if want == "certified":
            assert "non-multi-affine" in r.argument
            for p in _points_in({g: (v, v) if not isinstance(v, tuple) else v
                                 for g, v in box.items()}, rng, 200):
                lam = np.linalg.eigvalsh(conds.families[0].evaluate(p))[0]
                assert lam >= float(r.margin_lower_bound) - 1e-12
        else:
            assert not r.witness.covers_box  # no multi-affinity: only the point is refuted


def test_not_multiaffine_singular_inside_is_undecided(monkeypatch) -> None:
    import formsync_design.certify.engine as C

    monkeypatch.setattr(C, "SUBDIVISION_LIMIT", 64)
    # (2 K_o - 3)^2 vanishes at K_o = 3/2 inside the box, positive at both vertices
    conds = _toy(lambda ko, kq, b: [[(2 * ko - 3) ** 2, 0], [0, kq]])
    r = certify_box(conds, {"K_o": (1, 2), "K_q": 1, "beta": 1})
    assert r.status == "undecided" and "inconclusive" in r.reason and r.witness is None


def test_dedupe_by_content_scales_to_500() -> None:
    conds = derive_conditions("ring:500")
    r = certify_box(conds, {"K_o": (1.3, 1.7), "K_q": 0.4, "beta": (0.2, 0.3)})
    assert r.status == "certified"
    assert [f.size for f in r.families] == [3, 1000]
    assert r.recheck.get("pencil", 0) > 0


def test_as_box_validation() -> None:
    with pytest.raises(InputError, match="expected LO <= HI"):
        as_box({"K_o": (2, 1), "K_q": 1, "beta": 1})
    with pytest.raises(InputError, match="positive"):
        as_box({"K_o": (0, 1), "K_q": 1, "beta": 1})
    with pytest.raises(InputError, match="finite"):
        as_box({"K_o": float("nan"), "K_q": 1, "beta": 1})
    with pytest.raises(InputError, match="missing"):
        as_box({"K_o": 1, "K_q": 1})
    assert as_box({"K_o": 0.1, "K_q": 1, "beta": 1}).bounds[0] == (Fraction(1, 10), Fraction(1, 10))


def test_kv_check_against_required_kv() -> None:
    J = np.array([[50, 0, 4], [0, 55, 0], [4, 0, 60]], dtype=float)
    need = required_kv(J, 0.5)
    assert check_kv(need * 1.001, [J] * 3, 0.5).holds
    bad = check_kv([need * 1.001, need * 0.999, need * 2], [J] * 3, 0.5)
    assert not bad.holds and bad.failing == (2,)
    with pytest.raises(InputError, match="expected 3 K_v values"):
        check_kv([1, 2], [J] * 3, 0.5)


# ---------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------
def _run(capsys, *argv):
    rc = main(list(argv))
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_cli_exit_codes(capsys, tmp_path) -> None:
    base = ["certify", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3"]
    assert _run(capsys, *base, "--graph", "ring:8")[0] == 0
    rc, out, _ = _run(capsys, *base, "--graph", "star:8")
    assert rc == 1 and "witness" in out and "spacecraft 1" in out
    rc, out, _ = _run(capsys, *base, "--graph", "ring:8", "--conditions", "paper")
    assert rc == 0
    J = tmp_path / "J.txt"
    J.write_text("# inertia, kg m^2\n50 0 4\n0 55 0\n4 0 60\n")
    ok = _run(capsys, *base, "--graph", "ring:8", "--ud", "0.5", "--inertia", str(J), "--kv", "0.05")
    assert ok[0] == 0 and "K_v check (holds)" in ok[1]
    low = _run(capsys, *base, "--graph", "ring:8", "--ud", "0.5", "--inertia", str(J), "--kv", "0.001")
    assert low[0] == 1 and "FAILS" in low[1]


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--ko", "2:1"], "reversed"),
        (["--ko", ":1"], "empty"),
        (["--kq", "-1"], "positive"),
        (["--kq", "0"], "positive"),
        (["--beta", "nan"], "finite"),
        (["--beta", "inf"], "finite"),
        (["--conditions", "printed"], "derived or paper"),
        (["--margin", "-0.1"], "non-negative margin"),
        (["--ud", "0.5"], "missing"),
        (["--graph", "ring:2"], "N >= 3"),
    ],
)
def test_cli_bad_input_one_line(capsys, extra, needle) -> None:
    argv = {"--graph": "ring:8", "--ko": "1.6", "--kq": "0.4", "--beta": "0.3"}
    rest = []
    it = iter(extra)
    for k in it:
        v = next(it)
        if k in argv:
            argv[k] = v
        else:
            rest += [k, v]
    args = ["certify"] + [t for kv in argv.items() for t in kv] + rest
    rc, _, err = _run(capsys, *args)
    assert rc == 2
    assert err.count("\n") == 1 and needle in err and "expected" in err


def test_cli_bad_inertia(capsys, tmp_path) -> None:
    base = ["certify", "--graph", "ring:8", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3",
            "--ud", "0.5", "--kv", "0.1", "--inertia"]
    bad = tmp_path / "asym.txt"
    bad.write_text("50 1 0\n0 50 0\n0 0 50\n")
    rc, _, err = _run(capsys, *base, str(bad))
    assert rc == 2 and "symmetric" in err
    npd = tmp_path / "npd.txt"
    npd.write_text("1 2 0\n2 1 0\n0 0 1\n")
    rc, _, err = _run(capsys, *base, str(npd))
    assert rc == 2 and "positive definite" in err
    six = tmp_path / "six.txt"
    six.write_text("50 0 0\n0 50 0\n0 0 50\n" * 2)
    rc, _, err = _run(capsys, *base, str(six))
    assert rc == 2 and "24 rows" in err and "received 6" in err


def test_cli_json_shape(capsys) -> None:
    rc, out, _ = _run(capsys, "certify", "--graph", "star:8", "--ko", "1:2", "--kq", "0.4",
                      "--beta", "0.3", "--format", "json")
    assert rc == 1
    d = json.loads(out)
    assert d["status"] == "refuted"
    assert set(d) >= {"status", "box", "families", "witness", "solver", "argument", "recheck",
                      "margin", "certified_margin", "conditions", "graph", "n"}
    w = d["witness"]
    assert w["family"] == "Theta_1" and w["spacecraft"] == 1 and all(isinstance(v, int) for v in w["x"])
    # the witness of the LAPACK-hinted re-check refutes: the SDP hint is not needed
    assert d["solver"]["raw_status"] == "skipped" and d["solver"]["outcome"] == "skipped"
    assert d["box"]["K_o"] == [1, 2]  # exact rationals as JSON numbers (they round-trip)


def test_cli_case_file(capsys) -> None:
    from pathlib import Path

    case = Path(__file__).resolve().parents[1] / "verification" / "liang2016.toml"
    if not case.is_file():
        pytest.skip("case file not present")
    base = ["certify", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3", "--case", str(case)]
    rc, out, _ = _run(capsys, *base, "--graph", "ring:8")
    assert rc == 0 and "K_v check (holds)" in out
    rc, _, err = _run(capsys, *base, "--graph", "ring:4")
    assert rc == 2 and "8" in err


def test_exact_boundary_decided_by_rationals() -> None:
    """On the Theta boundary (from derive.closed_form_conditions, solved for K_q) the
    matrix is singular: refuted with an exact witness of value 0; 1e-15 above it the
    float test is inconclusive and exact LDL^T certifies."""
    from formsync_design.derive.closed_form import closed_form_conditions
    from formsync_design.spec.loader import gain_symbols

    conds = derive_conditions("star:3")
    ko, kq, b = gain_symbols()
    schur = [c for c in closed_form_conditions(conds) if c.family == "Theta(m=2)"
             and "Schur" in c.how][0].expression
    kq_star = sp.solve(schur.subs({ko: sp.Rational(7, 2), b: 1}), kq)[0]
    kq_star = Fraction(int(kq_star.p), int(kq_star.q))
    r = certify_box(conds, {"K_o": Fraction(7, 2), "K_q": kq_star, "beta": 1})
    assert r.status == "refuted" and r.witness.family == "Theta_1" and r.witness.value == 0
    r = certify_box(conds, {"K_o": Fraction(7, 2), "K_q": kq_star + Fraction(1, 10**15), "beta": 1})
    assert r.status == "certified" and r.recheck.get("exact-ldl", 0) >= 1


def test_inertia_per_spacecraft_and_case_override(capsys, tmp_path) -> None:
    base = ["certify", "--graph", "path:2", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3"]
    J = tmp_path / "J.csv"
    J.write_text("50,0,4\n0,55,0\n4,0,60\n10,0,0\n0,10,0\n0,0,10\n")
    need = [required_kv(np.array([[50, 0, 4], [0, 55, 0], [4, 0, 60]]), 0.5),
            required_kv(10 * np.eye(3), 0.5)]
    kv = (need[0] + need[1]) / 2  # enough for spacecraft 1, not for the lighter 2
    rc, out, _ = _run(capsys, *base, "--ud", "0.5", "--inertia", str(J), "--kv", f"{kv:.6f}")
    assert rc == 1 and "failing spacecraft [2]" in out


def test_uniform_refutation_matches_rational_evaluation() -> None:
    """The integer-arithmetic sign test agrees with MatrixFamily.evaluate_exact,
    including vectors whose quadratic form is (nearly) zero."""
    from formsync_design.certify.structure import analyze
    from formsync_design.certify.vertices import uniform_refutation

    rng = np.random.default_rng(9)
    for spec in ("ring:5", "star:4"):
        conds = derive_conditions(spec)
        st = analyze(conds.families)
        for blk in st.blocks:
            gi, rows = blk.places[0]
            fam = st.groups[gi].family
            for _ in range(30):
                pt = tuple(Fraction(int(rng.integers(1, 40)), int(rng.integers(1, 20)))
                           for _ in range(3))
                lam, vec = np.linalg.eigh(fam.evaluate([float(v) for v in pt]))
                v = vec[:, 0][rows] if rng.random() < 0.7 else rng.normal(size=len(rows))
                if np.abs(v).max() < 1e-9:
                    continue
                x = [int(round(t * 2**int(rng.integers(2, 20)))) for t in v / np.abs(v).max()]
                if not any(x):
                    continue
                full = [0] * fam.size
                for loc, r in enumerate(rows.tolist()):
                    full[r] = x[loc]
                want = _exact_quad(fam, pt, full) <= 0
                assert uniform_refutation(blk, x, [pt], Fraction(0)) == want
