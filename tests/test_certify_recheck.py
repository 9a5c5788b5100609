"""The rigorous re-check decides and never crashes (issue 9, item 3).

Independent truth used here: closed forms (``Pi > 0 <=> K_o > beta
lambda_max(L)`` with exact ``lambda_max`` of stars/complete graphs/even rings,
``Theta_i > 0 <=> K_q + beta K_o > 2 m_i beta^2``), ``mpmath`` interval
enclosures of ``lambda_max`` of a path, ``MatrixFamily.evaluate_exact`` for
witnesses, and dense ``numpy`` eigenvalues for random matrices.
"""

from __future__ import annotations

import json
from fractions import Fraction
from types import SimpleNamespace

import mpmath
import numpy as np
import pytest
import sympy as sp

from formsync_design.certify import engine
from formsync_design.certify.exact import exact_ldl, exact_sparse_ldl, quad_value_sign
from formsync_design.certify.results import SolverOutcome, Status, solver_outcome
from formsync_design.derive.conditions import derive_conditions
from formsync_design.derive.families import family_from_sympy
from formsync_design.graphs.build import make_graph

F = Fraction


def _exact_quad(fam, point, x) -> Fraction:
    m = fam.evaluate_exact(point)
    nz = [i for i, v in enumerate(x) if v]
    return sum((Fraction(m[i][j]) * x[i] * x[j] for i in nz for j in nz), Fraction(0))


def _witness_is_exact(conds, r, margin=Fraction(0)) -> None:
    w = r.witness
    fam = next(f for f in conds.families if f.name == w.family)
    pt = tuple(w.point[g] for g in conds.gains)
    xx = sum(v * v for v in w.x)
    assert _exact_quad(fam, pt, w.x) - margin * xx == w.value <= 0


# ---------------------------------------------------------------------------
# exact arithmetic stays exact (no OverflowError)
# ---------------------------------------------------------------------------
def test_huge_witness_integers_are_compared_exactly() -> None:
    """``x^T F x`` with integers far beyond a float: sign decided in integers."""
    big = 10**400
    # 1/2 * q - (1/2) * xx with q == xx: exactly zero
    assert quad_value_sign([(1,)], [F(1)], [big], big, (F(1, 2),), F(1, 2)) == 0
    assert quad_value_sign([(1,)], [F(1)], [big + 1], big, (F(1, 2),), F(1, 2)) == 1
    assert quad_value_sign([(1,)], [F(1)], [big - 1], big, (F(1, 2),), F(1, 2)) == -1


def test_path12_boundary_box_is_decided_not_crashed() -> None:
    """``formsync certify --graph path:12 --ko 1.1795554957734407 --kq 10 --beta 0.3``
    crashed with OverflowError (huge exact-LDL^T witness).  The truth: ``K_o`` vs
    ``beta lambda_max = 0.3 (2 + 2 cos(pi/12))`` from a 400-bit interval enclosure."""
    conds = derive_conditions("path:12")
    ko, beta = F("1.1795554957734407"), F(3, 10)
    mpmath.iv.prec = 400
    lam = 2 + 2 * mpmath.iv.cos(mpmath.iv.pi / 12)
    bound = mpmath.iv.mpf(beta.numerator) / beta.denominator * lam
    kov = mpmath.iv.mpf(ko.numerator) / ko.denominator
    assert kov.b < bound.a or kov.a > bound.b  # separated: the truth is decided
    holds = bool(kov.a > bound.b)
    r = engine.certify_box(conds, {"K_o": ko, "K_q": 10, "beta": beta})
    assert str(r.status) == ("certified" if holds else "refuted")
    if not holds:
        assert r.witness.family == "Pi"
        _witness_is_exact(conds, r)


# ---------------------------------------------------------------------------
# the SDP hint guides, never vetoes
# ---------------------------------------------------------------------------
BIG_BOX = {"K_o": 1.6e5, "K_q": 4e10, "beta": 3e4}


def _closed_form_ring8(ko, kq, beta) -> bool:
    ko, kq, beta = F(repr(ko)), F(repr(kq)), F(repr(beta))
    return ko > 4 * beta and kq + beta * ko > 2 * 2 * beta * beta  # ring: degree 2, lambda_max 4


@pytest.mark.parametrize("raw", ["unbounded", "optimal_inaccurate", "infeasible",
                                 "something_new", "raise"])
def test_bad_hint_never_vetoes_a_rechecked_certificate(monkeypatch, raw) -> None:
    import cvxpy as cp

    conds = derive_conditions("ring:8")
    assert _closed_form_ring8(*BIG_BOX.values())
    orig = cp.Problem.solve

    def fake(self, *a, **k):
        if raw == "raise":
            raise cp.error.SolverError("simulated solver crash")
        orig(self, *a, **k)
        self._status = raw
        return self.value

    monkeypatch.setattr(cp.Problem, "solve", fake)
    r = engine.certify_box(conds, BIG_BOX, use_sdp="always")
    assert r.solver.outcome == solver_outcome("solver_error" if raw == "raise" else raw)
    assert r.solver.outcome != SolverOutcome.OK
    assert r.status == Status.CERTIFIED, r.reason
    assert "re-check alone" in r.reason
    assert r.margin_lower_bound is not None and r.margin_lower_bound > 0


def test_large_gains_certify_with_the_real_solver() -> None:
    """The scaled SDP (or, failing it, the re-check) decides the large-gain box as
    the closed form says, with or without the hint."""
    conds = derive_conditions("ring:8")
    with_sdp = engine.certify_box(conds, BIG_BOX, use_sdp="always")
    without = engine.certify_box(conds, BIG_BOX, use_sdp=False)
    assert with_sdp.solver.outcome == SolverOutcome.OK
    assert with_sdp.status == without.status == Status.CERTIFIED
    # a box violating Pi at the same scale is refuted either way
    bad = {"K_o": 1.1e5, "K_q": 4e10, "beta": 3e4}  # 1.1e5 < 4 * 3e4
    assert not _closed_form_ring8(*bad.values())
    for sdp in ("always", True, False):
        r = engine.certify_box(conds, bad, use_sdp=sdp)
        assert r.status == Status.REFUTED
        _witness_is_exact(conds, r)


# ---------------------------------------------------------------------------
# the SDP hint only when the LAPACK-hinted re-check leaves a block undecided
# ---------------------------------------------------------------------------
def _without_timings(r) -> dict:
    d = r.to_dict()
    for k in ("solver", "elapsed_s"):
        d.pop(k, None)
    return d


@pytest.mark.parametrize("graph, box", [
    ("ring:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}),  # the paper's point: certified
    ("ring:8", {"K_o": (1.5, 1.7), "K_q": (0.3, 0.5), "beta": 0.3}),  # a box: certified
    ("star:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}),  # refuted (Theta_1)
])
def test_decided_boxes_skip_the_sdp_with_the_same_result(graph, box) -> None:
    conds = derive_conditions(graph)
    auto = engine.certify_box(conds, box)
    always = engine.certify_box(conds, box, use_sdp="always")
    assert auto.solver.outcome == SolverOutcome.SKIPPED and "not needed" in auto.solver.note
    assert always.solver.outcome == SolverOutcome.OK
    assert auto.status == (Status.REFUTED if graph.startswith("star") else Status.CERTIFIED)
    a, b = _without_timings(auto), _without_timings(always)
    if isinstance(box["K_o"], float):  # a point: the same shifts, hence the same numbers
        assert a == b
    # a box: the SDP level (min over vertices) may shift the Cholesky test of another
    # vertex lower, so a certified lower bound may differ in its last digits, never the verdict
    assert a["status"] == b["status"] and a["witness"] == b["witness"]
    for fa, fb in zip(a["families"], b["families"], strict=True):
        assert fa["status"] == fb["status"] and fa["worst_vertex"] == fb["worst_vertex"]
        if fa["certified_lower_bound"] is not None:
            assert fa["certified_lower_bound"] == pytest.approx(fb["certified_lower_bound"], rel=1e-8)


def test_undecided_recheck_asks_the_sdp_and_the_recheck_still_decides(monkeypatch) -> None:
    """Forcing the first (LAPACK-hinted) pass to leave every block undecided makes
    certify_box solve the SDP and re-check from its levels; that re-check certifies
    (closed form: ring:8 at the paper's gains holds)."""
    conds = derive_conditions("ring:8")
    box = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    assert _closed_form_ring8(*box.values())
    real = engine.evaluate_vertices
    calls: list[bool] = []

    def first_pass_undecided(st, verts, mg, *, candidates=None, blocks=None):
        vr = real(st, verts, mg, candidates=candidates, blocks=blocks)
        calls.append(candidates is not None)
        if candidates is None and blocks is None:
            for s_ in vr.status:
                s_[:] = 0
        return vr

    monkeypatch.setattr(engine, "evaluate_vertices", first_pass_undecided)
    r = engine.certify_box(conds, box)
    assert calls == [False, True]  # the LAPACK pass, then the re-check from the SDP levels
    assert r.solver.outcome == SolverOutcome.OK and r.status == Status.CERTIFIED
    # with the hint off the same forced pass stays undecided: nothing is guessed
    calls.clear()
    r = engine.certify_box(conds, box, use_sdp=False)
    assert calls == [False] and r.status == Status.UNDECIDED


def test_certifying_the_paper_point_does_not_import_cvxpy() -> None:
    import subprocess
    import sys

    code = ("import sys, formsync_design as fs; r = fs.certify_box(fs.derive_conditions("
            "fs.make_graph('ring:8')), {'K_o': 1.6, 'K_q': 0.4, 'beta': 0.3}); "
            "print(r.status, 'cvxpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["certified", "False"]


def test_use_sdp_is_checked() -> None:
    from formsync_design.errors import InputError

    with pytest.raises(InputError, match="use_sdp"):
        engine.certify_box(derive_conditions("ring:4"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3},
                           use_sdp="sometimes")


def test_unknown_solver_status_maps_to_error() -> None:
    assert solver_outcome("something_new") == SolverOutcome.ERROR
    assert solver_outcome("optimal") == SolverOutcome.OK


# ---------------------------------------------------------------------------
# exact ties and boundary-hugging boxes for N > 24 (exact sparse LDL^T)
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("spec, lam", [("star:30", 30), ("complete:40", 40), ("ring:60", 4),
                                       ("star:120", 120)])
def test_pi_tie_is_refuted_and_just_above_certified(spec, lam) -> None:
    conds = derive_conditions(spec)
    assert abs(max(make_graph(spec).laplacian_eigenvalues) - lam) < 1e-9
    beta = F(67, 1000)
    kq = F(5) + 2 * (lam if spec.startswith(("star", "complete")) else 2) * beta * beta
    for delta, want in ((F(0), Status.REFUTED), (F(1, 10**13), Status.CERTIFIED),
                        (-F(1, 10**13), Status.REFUTED)):
        ko = beta * lam + delta
        r = engine.certify_box(conds, {"K_o": ko, "K_q": kq, "beta": beta})
        assert r.status == want, (spec, delta, r.reason)
        if want == Status.REFUTED:
            assert r.witness.family == "Pi"
            _witness_is_exact(conds, r)
            if delta == 0:
                assert r.witness.value == 0  # the tie: singular, strictly not PD
        else:
            assert r.margin_lower_bound is not None and r.margin_lower_bound >= 0


def test_star30_tie_from_the_issue() -> None:
    conds = derive_conditions("star:30")
    r = engine.certify_box(conds, {"K_o": "2.01", "K_q": 1, "beta": "0.067"})
    assert F("2.01") == F("0.067") * 30
    assert r.status == Status.REFUTED and r.witness.family == "Pi"
    _witness_is_exact(conds, r)
    # with a margin below the tie and the box above it: certified; margin at it: refuted
    r = engine.certify_box(conds, {"K_o": "2.02", "K_q": 1, "beta": "0.067"}, margin="0.01")
    assert r.status == Status.REFUTED  # lambda_min(Pi) = 2.02 - 2.01 = 0.01: not > 0.01
    r = engine.certify_box(conds, {"K_o": "2.02", "K_q": 1, "beta": "0.067"}, margin="0.0099")
    assert r.status == Status.CERTIFIED


def test_sparse_exact_ldl_agrees_with_eigenvalues() -> None:
    rng = np.random.default_rng(17)
    for trial in range(150):
        n = int(rng.integers(1, 30))
        a = np.where(rng.random((n, n)) < 0.15, rng.integers(-3, 4, size=(n, n)), 0)
        a = a + a.T + np.diag(rng.integers(0, 9, size=n))
        rows = [{j: F(int(a[i, j])) for j in range(n) if a[i, j]} for i in range(n)]
        pd, x = exact_sparse_ldl(rows)
        pd_dense, _ = exact_ldl([[F(int(v)) for v in row] for row in a])
        assert pd == pd_dense
        lam = np.linalg.eigvalsh(a.astype(float))[0]
        if abs(lam) > 1e-9:
            assert pd == (lam > 0), trial
        if not pd:
            q = sum(F(int(a[i, j])) * x[i] * x[j] for i in range(n) for j in range(n))
            assert q <= 0
    assert exact_sparse_ldl([{0: F(1), 1: F(2)}, {0: F(2), 1: F(1)}], budget=0) == (None, None)


# ---------------------------------------------------------------------------
# no certified margin beside an undecided result
# ---------------------------------------------------------------------------
def _undecided_tie(monkeypatch) -> tuple:
    import formsync_design.certify.vertices as V

    # without the exact fallback a box 1e-13 above the Pi boundary of path:30 is
    # undecided (as every such box was before the fix): the enclosure of
    # lambda_max(L) is ~1e-12 wide and no witness exists (the box is admissible)
    monkeypatch.setattr(V, "exact_sparse_ldl", lambda rows, **k: (None, None))
    conds = derive_conditions("path:30")
    beta = F(3, 10)
    lam = 2 + 2 * np.cos(np.pi / 30)
    ko = beta * F(float(lam)) + F(1, 10**13)
    r = engine.certify_box(conds, {"K_o": ko, "K_q": 1, "beta": beta})
    assert r.status == Status.UNDECIDED, r.reason
    assert any(f.status == Status.CERTIFIED for f in r.families)  # Theta_i are certified
    monkeypatch.undo()
    assert engine.certify_box(conds, {"K_o": ko, "K_q": 1, "beta": beta}).status == Status.CERTIFIED
    return conds, r


def test_undecided_has_no_certified_margin(monkeypatch) -> None:
    _, r = _undecided_tie(monkeypatch)
    assert r.margin_lower_bound is None
    d = r.to_dict()
    assert d["certified_margin"] is None and d["status"] == "undecided"
    json.dumps(d)


def test_undecided_text_report_has_no_certified_margin(monkeypatch) -> None:
    from formsync_design.cli.certify_text import format_result

    _, r = _undecided_tie(monkeypatch)
    text = format_result(r)
    assert text.startswith("UNDECIDED") and "certified margin" not in text
    ok = engine.certify_box(derive_conditions("ring:8"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    assert "certified margin" in format_result(ok)


def test_not_multiaffine_undecided_has_no_margin(monkeypatch) -> None:
    monkeypatch.setattr(engine, "SUBDIVISION_LIMIT", 64)
    ko, kq, b = sp.symbols("K_o K_q beta")
    fam = family_from_sympy("F", sp.Matrix([[(2 * ko - 3) ** 2, 0], [0, kq]]), (ko, kq, b))
    conds = SimpleNamespace(families=(fam,), gains=("K_o", "K_q", "beta"),
                            graph=make_graph("path:2"), source="test")
    r = engine.certify_box(conds, {"K_o": (1, 2), "K_q": 1, "beta": 1})
    assert r.status == Status.UNDECIDED and r.margin_lower_bound is None
    assert r.to_dict()["certified_margin"] is None


# ---------------------------------------------------------------------------
# results: StrEnum statuses, JSON number convention
# ---------------------------------------------------------------------------
def test_result_json_uses_the_number_convention() -> None:
    conds = derive_conditions("star:8")
    r = engine.certify_box(conds, {"K_o": (1, "4/3"), "K_q": 0.4, "beta": 0.3})
    d = json.loads(json.dumps(r.to_dict()))
    assert d["status"] == "refuted" and isinstance(r.status, Status)
    # exact rationals: a JSON number when the float round-trips, else "p/q"
    assert d["box"]["K_o"] == [1, "4/3"] and d["box"]["beta"] == ["3/10", "3/10"]
    assert d["margin"] == 0
    w = d["witness"]
    assert all(isinstance(v, int) for v in w["x"])
    assert Fraction(w["value"]) == r.witness.value  # "p/q" string or an exact float


def test_verdict_does_not_depend_on_the_hint() -> None:
    """Seeded boxes (some with a margin, some at large gains): the verdict with the
    SDP hint equals the verdict of the re-check alone."""
    rng = np.random.default_rng(31)
    for spec in ("ring:8", "star:6", "path:7", "complete:5"):
        conds = derive_conditions(spec)
        for _ in range(8):
            scale = float(rng.choice([1.0, 1e4]))
            box = {g: (F(repr(round(c * scale, 6))), F(repr(round(c * scale * 1.1, 6))))
                   for g, c in zip(("K_o", "K_q", "beta"),
                                   (rng.uniform(0.1, 5), rng.uniform(0.1, 5) * scale,
                                    rng.uniform(0.05, 1)))}
            margin = F(0) if rng.random() < 0.5 else F(1, 100)
            a = engine.certify_box(conds, box, margin=margin, use_sdp="always")
            b = engine.certify_box(conds, box, margin=margin, use_sdp=False)
            assert a.status == b.status, (spec, box, a.reason, b.reason)


def test_cli_path12_exits_with_the_verdict_not_a_crash(capsys) -> None:
    from formsync_design.cli.main import main

    rc = main(["certify", "--graph", "path:12", "--ko", "1.1795554957734407", "--kq", "10",
               "--beta", "0.3"])
    cap = capsys.readouterr()
    assert cap.err == "" and "Traceback" not in cap.out
    # K_o < beta lambda_max(path:12) (see test_path12_boundary_box_is_decided_not_crashed)
    assert rc == 1 and cap.out.startswith("REFUTED") and "exact rational" in cap.out
    assert "certified margin" not in cap.out
    rc = main(["certify", "--graph", "path:12", "--ko", "1.1795554957734407", "--kq", "10",
               "--beta", "0.3", "--format", "json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 1 and d["status"] == "refuted" and d["certified_margin"] is None


@pytest.mark.slow
@pytest.mark.parametrize("spec, lam", [("complete:500", 500), ("star:1000", 1000)])
def test_closed_form_spectrum_decides_large_ties(spec, lam) -> None:
    """Beyond the sparse exact budget (complete:500 is dense), the closed-form
    spectrum of complete graphs and stars decides ties exactly."""
    conds = derive_conditions(spec)
    beta = F(1, 1000)
    for delta, want in ((F(0), Status.REFUTED), (F(1, 10**13), Status.CERTIFIED)):
        r = engine.certify_box(conds, {"K_o": beta * lam + delta, "K_q": 5 + 2 * lam * beta**2,
                                       "beta": beta}, use_sdp=False)
        assert r.status == want
        if want == Status.REFUTED:
            _witness_is_exact(conds, r)


def test_margin_only_beside_a_certificate() -> None:
    """Families may carry lower bounds while the box is not certified (e.g. an
    unknown solver status with an inconclusive re-check): no certified margin then."""
    from dataclasses import replace

    from formsync_design.cli.certify_text import format_result

    ok = engine.certify_box(derive_conditions("ring:8"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
    assert ok.margin_lower_bound is not None and all(f.lower is not None for f in ok.families)
    for st in (Status.UNDECIDED, Status.ERROR):
        r = replace(ok, status=st, reason="test")
        assert r.margin_lower_bound is None and r.to_dict()["certified_margin"] is None
        assert "certified margin" not in format_result(r)
