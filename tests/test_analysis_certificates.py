"""Four certificates (issue 15, item 1): nesting and independent checks."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from formsync_design.analysis.certificates import certify
from formsync_design.analysis.modes import LAMBDA, mode_model
from formsync_design.analysis.spectrum import laplacian_spectrum
from formsync_design.derive.closed_loop import derive_closed_loop, resolve_spec
from formsync_design.errors import GraphError, InputError
from formsync_design.graphs import make_graph
from formsync_design.spec.lagrangian_view import LyapunovView
from formsync_design.spec.loader import gain_symbols

ORDER = ("paper", "exact", "searched", "spectral")


def _random_graph(rng: np.random.Generator, n: int) -> str:
    """A connected random graph as an edge-list spec: random tree plus random chords."""
    edges = {(int(rng.integers(0, i)), i) for i in range(1, n)}
    for _ in range(int(rng.integers(0, n))):
        i, j = sorted(int(x) for x in rng.choice(n, 2, replace=False))
        edges.add((i, j))
    return make_graph_from_edges(n, edges)


def make_graph_from_edges(n: int, edges: set[tuple[int, int]]):
    from formsync_design.graphs.build import Graph

    return Graph(n, tuple(sorted(edges)), name=f"random:{n}")


def _random_box(rng: np.random.Generator) -> dict:
    out = {}
    for name, (lo, hi) in {"K_o": (0.1, 5.0), "K_q": (0.01, 1.0), "beta": (0.02, 0.9)}.items():
        a = Fraction(int(rng.integers(int(lo * 100), int(hi * 100))), 100)
        w = Fraction(int(rng.integers(0, 40)), 100) * (Fraction(1) if name != "beta" else Fraction(1, 4))
        out[name] = (a, a + w)
    return out


def _full_loop(graph, gains):
    """Dense 2N x 2N nominal closed loop from the derived coefficients (per axis)."""
    cl = derive_closed_loop()
    sub = dict(zip(gain_symbols(), gains))
    cqd, cs = float(cl.c_qd.subs(sub)), float(cl.c_s.subs(sub))
    lap = make_graph(graph).laplacian.astype(float)
    n = lap.shape[0]
    return np.block([[np.zeros((n, n)), np.eye(n)], [cs * lap, cqd * np.eye(n)]])


def _paper_v_matrix(graph, gains):
    """Hessian/2 of sum_i V_i built from the specification's lyapunov() (per axis)."""
    g = make_graph(graph)
    spec = resolve_spec(None)
    n = g.n
    q = sp.symbols(f"q0:{n}")
    w = sp.symbols(f"w0:{n}")
    total = 0
    for i in range(n):
        nb = g.neighbors(i)
        view = LyapunovView(len(nb))
        V = sp.sympify(spec.lyapunov(view))
        rep = {view.qd[0]: w[i], view.qd[1]: 0, view.qd[2]: 0}
        for k, j in enumerate(nb):
            rep[view.edges[k][0]] = q[i] - q[j]
            rep[view.edges[k][1]] = 0
            rep[view.edges[k][2]] = 0
        total += V.xreplace(rep)
    total = total.xreplace(dict(zip(gain_symbols(), [sp.Rational(str(x)) for x in gains])))
    xs = [*q, *w]
    H = sp.hessian(sp.expand(total), xs)
    return np.array(H, dtype=float) / 2


def test_mode_reduction_matches_brute_force_v_and_loop():
    """Sum over modes of (x,y) P_k (x,y) equals the brute-force sum of V_i; A_k's
    eigenvalues are the full loop's (second implementation: dense matrices)."""
    graph, gains = "circulant:6:1,2", (1.7, 0.45, 0.3)
    mm = mode_model()
    P = _paper_v_matrix(graph, gains)
    lap = make_graph(graph).laplacian.astype(float)
    lam, U = np.linalg.eigh(lap)
    sub = dict(zip(mm.gains, gains))
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, w = rng.normal(size=6), rng.normal(size=6)
        brute = np.concatenate([q, w]) @ P @ np.concatenate([q, w])
        x, y = U.T @ q, U.T @ w
        modal = 0.0
        for k in range(6):
            Pk = np.array(mm.p_paper.subs({**sub, LAMBDA: lam[k]}), dtype=float) if lam[k] > 1e-9 else \
                np.array(mm.p_paper.subs({**sub, LAMBDA: 0}), dtype=float)
            modal += np.array([x[k], y[k]]) @ Pk @ np.array([x[k], y[k]])
        assert modal == pytest.approx(brute, rel=1e-10)
    full = np.linalg.eigvals(_full_loop(graph, gains))
    modes = np.concatenate([np.linalg.eigvals(np.array(mm.a.subs({**sub, LAMBDA: lk}), dtype=complex))
                            for lk in lam])
    key = lambda z: (round(z.real, 6), round(z.imag, 6))  # noqa: E731
    assert np.allclose(sorted(full, key=key), sorted(modes, key=key), atol=1e-7)


def test_exact_certificate_is_the_closed_form_boundary():
    """For Liang's V the exact region is K_o > beta lambda_max (README closed form): the
    boundary point is refuted (V' only semidefinite), a point just inside certified."""
    lmax = 4  # ring:8
    beta = Fraction(3, 10)
    on = {"K_o": beta * lmax, "K_q": Fraction(2, 5), "beta": beta}
    inside = {**on, "K_o": beta * lmax + Fraction(1, 10**9)}
    assert certify("ring:8", on, "exact").status.value == "refuted"
    assert certify("ring:8", on, "searched").status.value == "refuted"
    assert certify("ring:8", inside, "exact").status.value == "certified"
    assert certify("ring:8", inside, "searched").status.value == "certified"
    assert certify("ring:8", on, "spectral").status.value == "certified"


def test_nesting_on_random_graphs_and_boxes():
    """(a) certified => (b) => (c) => (d), on seeded random graphs and boxes; every
    refutation of (b)/(c) and every (d) certificate confirmed numerically."""
    rng = np.random.default_rng(20261123)
    seen = {c: 0 for c in ORDER}
    gaps = 0
    for trial in range(16):
        graph = _random_graph(rng, int(rng.integers(4, 8)))
        box = _random_box(rng)
        res = {c: certify(graph, box, c, seed_with_paper=False) for c in ORDER}
        st = [res[c].status.value for c in ORDER]
        for i in range(3):
            if st[i] == "certified":
                assert st[i + 1] == "certified", (trial, graph.edges, box, st)
        for c in ORDER:
            seen[c] += st[ORDER.index(c)] == "certified"
        gaps += st[1] == "refuted" and st[3] == "certified"
        # independent truth at random points of the box: the full dense loop
        pts = [[float(lo + (hi - lo) * Fraction(int(rng.integers(0, 11)), 10)) for lo, hi in
                (box["K_o"], box["K_q"], box["beta"])] for _ in range(3)]
        for p in pts:
            ev = np.linalg.eigvals(_full_loop(graph, p))
            n = graph.n
            # drop the two consensus eigenvalues (0 and -K_o)
            ev = sorted(ev, key=lambda z: abs(z))[1:]
            if st[3] == "certified":
                assert max(e.real for e in ev) < 0
            if st[1] == "certified":
                P = _paper_v_matrix(graph, p)
                A = _full_loop(graph, p)
                # restrict to the disagreement subspace of q and all of q'
                lap = graph.laplacian.astype(float)
                _, U = np.linalg.eigh(lap)
                B = np.block([[U[:, 1:], np.zeros((n, n))], [np.zeros((n, n - 1)), np.eye(n)]])
                assert np.linalg.eigvalsh(B.T @ P @ B).min() > 0
                assert np.linalg.eigvalsh(B.T @ (A.T @ P + P @ A) @ B).max() < 0
        if st[1] == "refuted":
            w = res["exact"].witness
            assert w is not None
            g = [float(w["gains"][k]) for k in ("K_o", "K_q", "beta")]
            assert g[0] <= g[2] * graph.laplacian_spectral_radius + 1e-9
    assert seen["paper"] >= 1 and gaps >= 1, (seen, gaps)


def test_searched_certificate_checked_inside_the_box():
    """The searched V (rounded coefficients) is a Lyapunov function at interior points too,
    checked with dense matrices built independently from the coefficients."""
    box = {"K_o": (Fraction(13, 10), Fraction(2)), "K_q": (Fraction(1, 5), Fraction(1)),
           "beta": (Fraction(1, 10), Fraction(3, 10))}
    r = certify("ring:6", box, "searched", seed_with_paper=False)
    assert r.status.value == "certified"
    assert "p_over_lambda" in r.evidence  # the LMI search ran
    coeffs = r.evidence["p_over_lambda"]
    monos = r.evidence["monomials"]
    rng = np.random.default_rng(5)
    for _ in range(20):
        g = {k: float(lo + (hi - lo) * Fraction(rng.random())) for k, (lo, hi) in box.items()}
        for entry in coeffs:
            lam = float(entry["lambda"]["lo"])
            pi = sum(float(c) * np.prod([g[n] for n in m.split("*")] if m != "1" else [1.0])
                     for c, m in zip(entry["coefficients"], monos))
            P = np.array([[lam * pi, g["beta"] * lam], [g["beta"] * lam, 1.0]])
            A = np.array([[0, 1], [-g["K_q"] * lam, -g["K_o"]]])
            assert np.linalg.eigvalsh(P).min() > 0
            assert np.linalg.eigvalsh(A.T @ P + P @ A).max() < 0


def test_star_and_complete_paper_gains():
    """The paper's gains: refuted by (a)-(c) on star:8 and complete:8, certified by (d);
    certified by all four on ring:8."""
    pt = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    for g in ("star:8", "complete:8"):
        st = [certify(g, pt, c).status.value for c in ORDER]
        assert st == ["refuted", "refuted", "refuted", "certified"]
    assert [certify("ring:8", pt, c).status.value for c in ORDER] == ["certified"] * 4


def test_paper_test_stricter_than_its_own_v():
    """star:5 (hub degree 4, lambda_max 5) at (3, 0.3, 0.5): the hub's Theta fails
    (K_q + beta K_o = 1.8 <= 2 m beta^2 = 2, README closed form) while K_o > beta lambda_max
    (3 > 2.5): (a) refutes, (b)-(d) certify."""
    pt = {"K_o": 3, "K_q": 0.3, "beta": 0.5}
    assert 0.3 + 0.5 * 3 <= 2 * 4 * 0.25 and 3 > 0.5 * 5
    st = [certify("star:5", pt, c).status.value for c in ORDER]
    assert st == ["refuted", "certified", "certified", "certified"]


def test_spectrum_enclosures_and_errors():
    s = laplacian_spectrum("path:7")
    true = np.array([2 - 2 * np.cos(np.pi * k / 7) for k in range(1, 7)])  # analytic
    for c, t in zip(s.clusters, true):
        assert float(c.lo) <= t <= float(c.hi)
    assert s.method == "exact-inertia"
    big = laplacian_spectrum("ring:200")
    tb = np.sort(np.array([2 - 2 * np.cos(2 * np.pi * k / 200) for k in range(1, 200)]))
    assert sum(c.multiplicity for c in big.clusters) == 199
    # tb is float (cos(pi/2) is off by 1 ulp) while a cluster can be the exact point [2, 2]
    assert all(any(float(c.lo) - 1e-12 <= t <= float(c.hi) + 1e-12 for c in big.clusters) for t in tb)
    with pytest.raises(InputError):
        certify("ring:8", {"K_o": 1, "K_q": 1, "beta": 1}, "magic")
    from formsync_design.graphs.build import Graph
    with pytest.raises(GraphError):
        laplacian_spectrum(Graph(4, ((0, 1), (2, 3)), name="two"))


def test_to_dict_is_json():
    import json

    r = certify("star:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}, "searched")
    d = json.loads(json.dumps(r.to_dict()))
    assert d["status"] == "refuted" and d["certificate"] == "searched"
    assert "np.float64" not in json.dumps(d)
