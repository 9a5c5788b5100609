"""Rigorous enclosures of a graph Laplacian's spectrum, and exact interval arithmetic.

Every certificate of :mod:`formsync_design.analysis` decouples the nominal
closed loop by the Laplacian's eigenvectors (the loop is ``L (x) I3``-structured,
so each eigenvalue ``lambda_k`` of ``L`` gives an independent small block; see
Ren & Beard 2008, ch. 4, for this standard decomposition of second-order
consensus).  The blocks are then decided over an *enclosure* of each eigenvalue,
never a bare floating-point value:

* eigenvalues are computed with LAPACK (``eigvalsh``), clustered, and each
  cluster gets a rational interval ``[lo, hi]``;
* an integer cluster value ``t`` whose exact nullity of ``L - t I`` (rational
  Gaussian elimination) equals the cluster's multiplicity becomes the point
  interval ``[t, t]`` (star and complete graphs have integer spectra);
* for ``N <= EXACT_SPECTRUM_MAX`` every interval is *verified* by Sylvester's
  law of inertia: the number of eigenvalues below ``lo`` and below ``hi``
  (signs of exact rational ``LDL^T`` pivots of ``L - t I``) differ by the
  cluster's multiplicity, so the enclosure is exact mathematics;
* above that size the interval is the a-posteriori bound
  ``|lambda_k - mu_k| <= ||L V - V M||_F / (1 - ||V^T V - I||_F)`` (Weyl's
  theorem applied after orthonormalising ``V``), inflated by a factor 4 plus
  ``64 N u ||L||_1`` for the rounding of its own evaluation; the largest upper
  end is additionally confirmed with the engine's rigorous Cholesky bound
  (:func:`formsync_design.certify.engine.rigorous_lower_bound`).  The method is
  recorded in :attr:`LaplacianSpectrum.method`.

Nothing here forms a dense ``3N x 3N`` matrix: one ``N x N`` symmetric
eigen-decomposition per graph (not per gain point).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.errors import GraphError
from formsync_design.graphs import make_graph

__all__ = [
    "EXACT_SPECTRUM_MAX",
    "SpectrumCluster",
    "LaplacianSpectrum",
    "laplacian_spectrum",
    "inertia_below",
    "exact_nullity",
    "poly_range",
]

#: Graphs up to this order get exactly verified eigenvalue enclosures.
EXACT_SPECTRUM_MAX = 40

_U = 2.0**-53


@dataclass(frozen=True)
class SpectrumCluster:
    """Eigenvalues of ``L`` in the rational interval ``[lo, hi]`` (``multiplicity`` of them)."""

    lo: Fraction
    hi: Fraction
    multiplicity: int

    @property
    def is_point(self) -> bool:
        return self.lo == self.hi

    @property
    def mid(self) -> float:
        return float((self.lo + self.hi) / 2)


@dataclass(frozen=True)
class LaplacianSpectrum:
    """The nonzero (disagreement-subspace) Laplacian spectrum as enclosed clusters.

    ``method`` is ``"exact-inertia"`` (verified with rational arithmetic) or
    ``"a-posteriori"`` (see the module docstring).
    """

    graph: str
    n: int
    clusters: tuple[SpectrumCluster, ...]
    method: str

    @property
    def lambda_max_hi(self) -> Fraction:
        return max(c.hi for c in self.clusters)

    @property
    def lambda_2_lo(self) -> Fraction:
        return min(c.lo for c in self.clusters)


def _frac_matrix(a: np.ndarray, shift: Fraction) -> list[list[Fraction]]:
    n = a.shape[0]
    return [[Fraction(int(a[i, j])) - (shift if i == j else 0) for j in range(n)] for i in range(n)]


def inertia_below(lap: np.ndarray, t: Fraction) -> int | None:
    """Exact number of eigenvalues of the integer symmetric ``lap`` below ``t``.

    Signs of the pivots of an unpivoted rational ``LDL^T`` of ``lap - t I``
    (Sylvester's law of inertia).  ``None`` when a zero pivot occurs (``t`` is
    an eigenvalue of a leading block); move ``t`` and retry.

    >>> import numpy as np
    >>> lap = np.array([[1, -1], [-1, 1]])
    >>> inertia_below(lap, Fraction(1, 2)), inertia_below(lap, Fraction(3))
    (1, 2)
    """
    m = _frac_matrix(np.asarray(lap), Fraction(t))
    n = len(m)
    neg = 0
    for k in range(n):
        piv = m[k][k]
        if piv == 0:
            return None
        if piv < 0:
            neg += 1
        row = m[k]
        for i in range(k + 1, n):
            f = m[i][k]
            if f == 0:
                continue
            f = f / piv
            ri = m[i]
            for j in range(k + 1, n):
                if row[j]:
                    ri[j] -= f * row[j]
    return neg


def exact_nullity(lap: np.ndarray, t: Fraction) -> int:
    """Exact dimension of the null space of ``lap - t I`` (rational elimination).

    >>> import numpy as np
    >>> exact_nullity(np.array([[1, -1], [-1, 1]]), Fraction(0))
    1
    """
    m = _frac_matrix(np.asarray(lap), Fraction(t))
    n = len(m)
    rank = 0
    rows = list(range(n))
    for col in range(n):
        piv = next((r for r in rows if m[r][col] != 0), None)
        if piv is None:
            continue
        rows.remove(piv)
        rank += 1
        pr = m[piv]
        for r in rows:
            if m[r][col]:
                f = m[r][col] / pr[col]
                m[r] = [a - f * b for a, b in zip(m[r], pr)]
    return n - rank


def _round_down(x: float) -> Fraction:
    return Fraction(np.nextafter(x, -np.inf)).limit_denominator(10**12) - Fraction(1, 10**12)


def _round_up(x: float) -> Fraction:
    return Fraction(np.nextafter(x, np.inf)).limit_denominator(10**12) + Fraction(1, 10**12)


def laplacian_spectrum(graph: Any) -> LaplacianSpectrum:
    """Enclosed nonzero Laplacian eigenvalues of a connected graph.

    Raises :class:`GraphError` for a disconnected graph (a second zero
    eigenvalue: the disagreement subspace then has a mode no gain can move).

    >>> s = laplacian_spectrum("star:4")
    >>> [(c.lo, c.hi, c.multiplicity) for c in s.clusters]
    [(Fraction(1, 1), Fraction(1, 1), 2), (Fraction(4, 1), Fraction(4, 1), 1)]
    >>> s.method
    'exact-inertia'
    """
    g = make_graph(graph)
    lap = np.asarray(g.laplacian)
    n = g.n
    mu, vec = np.linalg.eigh(lap.astype(float))
    norm1 = float(np.abs(lap).sum(axis=1).max())
    res = np.linalg.norm(lap @ vec - vec * mu, "fro")
    orth = np.linalg.norm(vec.T @ vec - np.eye(n), "fro")
    delta = float(4.0 * (res + orth * norm1) / max(1.0 - float(orth), 0.5) + 64 * n * _U * max(norm1, 1.0))
    if n <= EXACT_SPECTRUM_MAX and exact_nullity(lap, Fraction(0)) != 1:
        raise GraphError(f"expected a connected graph, received {g.name} with a repeated zero eigenvalue")
    if n > EXACT_SPECTRUM_MAX and mu[1] <= 2 * delta:
        raise GraphError(f"expected a connected graph, received {g.name} with lambda_2 = {mu[1]:g}")
    # cluster the nonzero part (index 0 is the consensus mode)
    groups: list[list[float]] = []
    for m in mu[1:]:
        if groups and m - groups[-1][-1] <= 4 * delta + 1e-9 * max(norm1, 1.0):
            groups[-1].append(float(m))
        else:
            groups.append([float(m)])
    clusters = []
    exact = n <= EXACT_SPECTRUM_MAX
    for grp in groups:
        t = round(sum(grp) / len(grp))
        lo: Fraction | None = None
        hi: Fraction | None = None
        if abs(grp[0] - t) <= 1e-6 and abs(grp[-1] - t) <= 1e-6 and exact:
            if exact_nullity(lap, Fraction(t)) == len(grp):
                lo = hi = Fraction(t)
        if lo is None or hi is None:
            lo = max(_round_down(grp[0] - delta), Fraction(0))  # L is positive semidefinite
            hi = _round_up(grp[-1] + delta)
        clusters.append(SpectrumCluster(lo, hi, len(grp)))
    method = "exact-inertia" if exact else "a-posteriori"
    if exact:
        _verify_exact(lap, clusters)
    else:
        _confirm_top(lap, clusters)
    return LaplacianSpectrum(g.name, n, tuple(clusters), method)


def _count(lap: np.ndarray, t: Fraction, up: bool) -> tuple[Fraction, int]:
    step = Fraction(1, 10**13)
    for _ in range(50):
        c = inertia_below(lap, t)
        if c is not None:
            return t, c
        t = t + step if up else t - step
    raise GraphError("expected a Laplacian whose spectrum can be enclosed, received a degenerate one")


def _verify_exact(lap: np.ndarray, clusters: Sequence[SpectrumCluster]) -> None:
    """Sylvester inertia check that each interval holds exactly its multiplicity."""
    seen = 1  # the zero eigenvalue
    for c in clusters:
        if c.is_point:
            # nullity already matched; check nothing else is below it unaccounted
            below = _count(lap, c.lo - Fraction(1, 10**9), up=False)[1]
            ok = below == seen
        else:
            below = _count(lap, c.lo, up=False)[1]
            upto = _count(lap, c.hi, up=True)[1]
            ok = below == seen and upto - below == c.multiplicity
        if not ok:
            raise GraphError(
                "expected the Laplacian eigenvalue enclosures to pass the exact inertia check, "
                "received a failure (report this graph)"
            )
        seen += c.multiplicity


def _confirm_top(lap: np.ndarray, clusters: Sequence[SpectrumCluster]) -> None:
    from formsync_design.certify.engine import rigorous_lower_bound

    hi = float(max(c.hi for c in clusters))
    # hi I - L >= 0  <=>  lambda_min(-L) >= -hi
    ell = rigorous_lower_bound([-np.asarray(lap)], np.array([[1.0]]), np.array([-hi - 1e-9 * max(hi, 1.0)]))[0]
    if not ell >= -hi - 1e-6 * max(hi, 1.0):  # pragma: no cover - would be a LAPACK failure
        raise GraphError("expected a confirmed upper bound of lambda_max(L), received a failed check")


def poly_range(coeffs: Sequence[Fraction], lo: Fraction, hi: Fraction) -> tuple[Fraction, Fraction]:
    """Exact enclosure of ``sum_k coeffs[k] x**k`` for ``x`` in ``[lo, hi]``, ``lo >= 0``.

    Each monomial is monotone on a non-negative interval, so the sum of the
    monomials' ranges encloses the polynomial's range (exact at a point).

    >>> poly_range([Fraction(-1), Fraction(0), Fraction(1)], Fraction(2), Fraction(3))
    (Fraction(3, 1), Fraction(8, 1))
    """
    if lo < 0:
        raise ValueError("poly_range needs a non-negative interval")
    a = b = Fraction(0)
    for k, c in enumerate(coeffs):
        if c == 0:
            continue
        x0, x1 = lo**k, hi**k
        if c > 0:
            a += c * x0
            b += c * x1
        else:
            a += c * x1
            b += c * x0
    return a, b
