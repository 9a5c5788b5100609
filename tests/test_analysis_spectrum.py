"""Rigorous Laplacian spectrum enclosures (issue 15: N up to 500).

Independent truth: closed-form spectra of ring, path, complete and star graphs
(evaluated with mpmath at 40 digits), a dense mpmath eigen-decomposition of random
graphs at 40 digits, exact Sylvester inertia counts (rational ``LDL^T``) and the dense
rational nullity.  Every check compares exact rational interval ends with the truth.
"""

from __future__ import annotations

import bisect
from fractions import Fraction

import mpmath
import numpy as np
import pytest

from formsync_design.analysis import spectrum as spectrum_mod
from formsync_design.analysis.spectrum import (
    exact_nullity,
    inertia_below,
    laplacian_spectrum,
    sparse_nullity,
)
from formsync_design.errors import GraphError
from formsync_design.graphs import make_graph
from formsync_design.graphs.build import Graph

mpmath.mp.dps = 40


def _analytic(kind: str, n: int) -> list[mpmath.mpf]:
    """Nonzero Laplacian eigenvalues (with multiplicity) from the closed forms."""
    if kind == "ring":
        vals = [2 - 2 * mpmath.cos(2 * mpmath.pi * k / n) for k in range(1, n)]
    elif kind == "path":
        vals = [2 - 2 * mpmath.cos(mpmath.pi * k / n) for k in range(1, n)]
    elif kind == "complete":
        vals = [mpmath.mpf(n)] * (n - 1)
    elif kind == "star":
        vals = [mpmath.mpf(1)] * (n - 2) + [mpmath.mpf(n)]
    else:  # pragma: no cover
        raise ValueError(kind)
    # cos(pi/2), cos(pi/3), ... are exact rationals: snap the 40-digit values onto them
    return sorted(mpmath.nint(v) if abs(v - mpmath.nint(v)) < mpmath.mpf(10) ** -35 else v for v in vals)


def _check_against(s, truth: list, max_width: float) -> None:
    """Every cluster holds exactly its multiplicity of true eigenvalues, all are covered."""
    assert sum(c.multiplicity for c in s.clusters) == len(truth)
    covered = 0
    prev_hi = Fraction(0)
    for c in s.clusters:
        assert c.lo > prev_hi or (c.lo == prev_hi == 0)  # disjoint, increasing, away from 0
        lo = mpmath.mpf(c.lo.numerator) / c.lo.denominator
        hi = mpmath.mpf(c.hi.numerator) / c.hi.denominator
        inside = bisect.bisect_right(truth, hi) - bisect.bisect_left(truth, lo)
        assert inside == c.multiplicity, (c, inside)
        assert float(c.hi - c.lo) <= max_width
        covered += inside
        prev_hi = c.hi
    assert covered == len(truth)


@pytest.mark.parametrize("n", [50, 200, 500])
@pytest.mark.parametrize("kind", ["ring", "path", "complete", "star"])
def test_closed_form_spectra(kind: str, n: int) -> None:
    s = laplacian_spectrum(f"{kind}:{n}")
    assert s.method == "verified-weyl-ostrowski"
    _check_against(s, _analytic(kind, n), max_width=1e-8)
    if kind in ("complete", "star"):  # integer spectra are proven exactly
        assert all(c.is_point for c in s.clusters)
        assert [c.multiplicity for c in s.clusters] == ([n - 1] if kind == "complete" else [n - 2, 1])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_graphs_against_dense_mpmath(seed: int) -> None:
    g = make_graph(f"random:30:0.2:{seed}")
    lap = mpmath.matrix(g.laplacian.tolist())
    ev = mpmath.eigsy(lap, eigvals_only=True)
    truth = sorted(ev[i] for i in range(g.n))
    assert abs(truth[0]) < mpmath.mpf(10) ** -30
    truth = truth[1:]
    for method in ("exact", "verified"):
        s = laplacian_spectrum(g, method=method)
        _check_against(s, truth, max_width=1e-6)


def test_verified_clusters_pass_exact_sylvester_counts() -> None:
    """Above the exact-size limit: the number of eigenvalues below each interval end
    (signs of exact rational LDL^T pivots) changes by the cluster's multiplicity."""
    g = make_graph("random:45:0.12:7")
    lap = np.asarray(g.laplacian)
    s = laplacian_spectrum(g)
    assert s.method == "verified-weyl-ostrowski"
    seen = 1
    nudge = Fraction(1, 10**18)
    checked = 0
    for k, c in enumerate(s.clusters):
        if k % 4 == 0 or k == len(s.clusters) - 1:  # a spread of clusters (exact LDL^T is O(N^3))
            below = inertia_below(lap, c.lo - nudge)
            upto = inertia_below(lap, c.hi + nudge)
            assert below == seen and upto is not None and upto - below == c.multiplicity
            checked += 1
        seen += c.multiplicity
    assert seen == g.n and checked >= 10


def test_sparse_nullity_matches_dense_rational_elimination() -> None:
    for name in ("star:9", "complete:7", "ring:6", "path:5", "random:12:0.4:3"):
        lap = np.asarray(make_graph(name).laplacian)
        for t in range(0, 8):
            assert sparse_nullity(lap, t) == exact_nullity(lap, Fraction(t)), (name, t)
    assert sparse_nullity(np.asarray(make_graph("random:60:0.5:1").laplacian), 3, budget=10) is None


def test_disconnected_and_failed_proof(monkeypatch: pytest.MonkeyPatch) -> None:
    edges = tuple((i, i + 1) for i in range(29)) + tuple((i, i + 1) for i in range(30, 59))
    with pytest.raises(GraphError):
        laplacian_spectrum(Graph(60, edges, name="two paths"))
    with pytest.raises(ValueError):
        laplacian_spectrum("ring:50", method="magic")

    def failed(lap):
        return np.linalg.eigvalsh(np.asarray(lap, float)), Fraction(1), Fraction(1)

    monkeypatch.setattr(spectrum_mod, "verified_enclosures", failed)
    s = laplacian_spectrum("path:60")
    assert s.method == "bounds-only" and len(s.clusters) == 1
    # Mohar's and Anderson-Morley's bounds, still a true enclosure
    _check_against(s, _analytic("path", 60), max_width=4.0)
