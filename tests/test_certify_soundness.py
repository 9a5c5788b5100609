"""Seeded soundness fuzz of ``certify_box`` against independent truth.

Every verdict is checked against a computation that shares no code with the
certification engine:

* the closed forms ``Theta_i > 0  <=>  K_q + beta K_o > 2 m_i beta^2`` (``m_i``
  the degree of spacecraft ``i``) and ``Pi > 0  <=>  K_o > beta lambda_max(L)``,
  decided in exact rationals at every vertex of the box; ``lambda_max(L)`` is
  exact for the graph families with a closed-form spectrum (``star:n`` and
  ``complete:n``: ``n``; ``ring:n``: ``2 - 2 cos(2 pi floor(n/2) / n)``;
  ``path:n``: ``2 - 2 cos(pi (n-1) / n)``), the cosine compared with a rational
  through a rigorous ``mpmath.iv`` enclosure (Niven's theorem covers equality);
* for a required margin ``> 0``: dense ``numpy.linalg.eigvalsh`` of
  ``MatrixFamily.evaluate`` at the vertices, used only where it is far from the
  margin;
* witnesses re-evaluated exactly with ``MatrixFamily.evaluate_exact``.

Boxes: log-uniform random boxes, boxes hugging the ``Pi`` and ``Theta``
boundaries from both sides (``1e-13``, ``1e-9``) and exactly tied boxes
(``K_o = beta lambda_max``, ``K_q + beta K_o = 2 m beta^2``).  For margin 0
the closed forms decide every box exactly, so the test also requires the
certification to *decide* (certified or refuted, never undecided) and to agree.
"""

from __future__ import annotations

from fractions import Fraction
from math import gcd

import mpmath
import numpy as np
import pytest

from formsync_design.certify.engine import certify_box
from formsync_design.derive.conditions import derive_conditions
from formsync_design.graphs.build import make_graph

GAINS = ("K_o", "K_q", "beta")


# ---------------------------------------------------------------------------
# independent truth
# ---------------------------------------------------------------------------
def _cos_pi_vs(p: int, q: int, r: Fraction) -> int:
    """Sign of ``cos(p pi / q) - r``, exactly."""
    g = gcd(p, q)
    p, q = p // g, q // g
    exact = {1: {0: 1, 1: -1}, 2: {1: 0, 3: 0}, 3: {1: Fraction(1, 2), 2: Fraction(-1, 2),
                                                    4: Fraction(-1, 2), 5: Fraction(1, 2)}}
    if q in exact and p % (2 * q) in exact[q]:
        c = Fraction(exact[q][p % (2 * q)])
        return (c > r) - (c < r)
    # irrational (Niven): a tight rigorous enclosure separates it from r
    mpmath.iv.prec = 400
    enc = mpmath.iv.cos(mpmath.iv.pi * p / q)
    rr = mpmath.iv.mpf(r.numerator) / r.denominator
    if enc.a > rr.b:
        return 1
    if enc.b < rr.a:
        return -1
    raise AssertionError("enclosure too wide")  # pragma: no cover


class Truth:
    """Exact ``Theta``/``Pi`` verdicts of a graph with a closed-form ``lambda_max(L)``."""

    def __init__(self, spec: str) -> None:
        fam, n = spec.split(":")[0], int(spec.split(":")[1])
        self.g = make_graph(spec)
        self.degrees = sorted(set(self.g.degrees))
        if fam in ("star", "complete"):
            self.lam = ("rational", Fraction(n))
        elif fam == "ring":
            self.lam = ("cos", 2 * (n // 2), n)  # 2 - 2 cos(pi * p / q)
        elif fam == "path":
            self.lam = ("cos", n - 1, n)
        else:  # pragma: no cover
            raise ValueError(spec)
        lam_f = float(np.linalg.eigvalsh(self.g.laplacian.astype(float))[-1])
        assert abs(lam_f - self.lam_float()) < 1e-9  # the closed form is the graph's

    def lam_float(self) -> float:
        if self.lam[0] == "rational":
            return float(self.lam[1])
        return 2 - 2 * float(np.cos(np.pi * self.lam[1] / self.lam[2]))

    def lam_rational(self) -> Fraction | None:
        if self.lam[0] == "rational":
            return self.lam[1]
        for c in (Fraction(1), Fraction(-1), Fraction(0), Fraction(1, 2), Fraction(-1, 2)):
            if _cos_pi_vs(self.lam[1], self.lam[2], c) == 0:
                return 2 - 2 * c
        return None

    def pi_pd(self, ko: Fraction, beta: Fraction) -> bool:
        """``K_o > beta lambda_max`` exactly."""
        c = ko / beta
        if self.lam[0] == "rational":
            return c > self.lam[1]
        # 2 - 2 cos < c  <=>  cos > 1 - c/2
        return _cos_pi_vs(self.lam[1], self.lam[2], 1 - c / 2) > 0

    def theta_pd(self, ko: Fraction, kq: Fraction, beta: Fraction) -> bool:
        return all(kq + beta * ko > 2 * m * beta * beta for m in self.degrees)

    def holds(self, vertex: tuple[Fraction, ...]) -> bool:
        ko, kq, beta = vertex
        return self.pi_pd(ko, beta) and self.theta_pd(ko, kq, beta)


def _vertices(box: dict[str, tuple[Fraction, Fraction]]) -> list[tuple[Fraction, ...]]:
    out = [()]
    for g in GAINS:
        lo, hi = box[g]
        out = [v + (x,) for v in out for x in ((lo,) if lo == hi else (lo, hi))]
    return out


def _exact_quad(fam, point, x) -> Fraction:
    m = fam.evaluate_exact(point)
    nz = [i for i, v in enumerate(x) if v]
    return sum((Fraction(m[i][j]) * x[i] * x[j] for i in nz for j in nz), Fraction(0))


# ---------------------------------------------------------------------------
# box generators (seeded)
# ---------------------------------------------------------------------------
def _q(x: float) -> Fraction:
    return Fraction(repr(round(x, 6)))


def _random_box(rng: np.random.Generator) -> dict[str, tuple[Fraction, Fraction]]:
    out = {}
    for g, (lo, hi) in {"K_o": (0.05, 8.0), "K_q": (0.05, 8.0), "beta": (0.01, 1.0)}.items():
        c = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        w = c * float(rng.choice([0.0, 0.02, 0.2]))
        out[g] = (_q(max(lo, c - w)), _q(c + w))
    return out


def _pi_boundary_box(rng, truth: Truth, delta: Fraction) -> dict | None:
    lam = truth.lam_rational()
    beta = _q(float(rng.uniform(0.02, 0.4)))
    if lam is None:  # irrational lambda_max: hug it through its float, never tied
        lam = Fraction(truth.lam_float())
    ko = beta * lam + delta
    kq = _q(float(rng.uniform(2.0, 6.0))) + 2 * max(truth.degrees) * beta * beta
    wide = bool(rng.random() < 0.5)
    return {"K_o": (ko, ko + (1 if wide else 0)), "K_q": (kq, kq),
            "beta": (beta / 2 if wide else beta, beta)}


def _theta_boundary_box(rng, truth: Truth, delta: Fraction) -> dict | None:
    m = max(truth.degrees)
    beta = _q(float(rng.uniform(0.3, 1.0)))
    lam = truth.lam_float()
    ko = _q(float(beta) * (lam + float(rng.uniform(0.5, 2.0))))  # Pi holds
    kq = 2 * m * beta * beta - beta * ko + delta
    if kq <= 0:
        return None
    return {"K_o": (ko, ko), "K_q": (kq, kq), "beta": (beta, beta)}


DELTAS = (Fraction(0), Fraction(1, 10**13), -Fraction(1, 10**13), Fraction(1, 10**9),
          -Fraction(1, 10**9))


def _boxes(rng, truth: Truth, count: int):
    made = 0
    while made < count:
        kind = int(rng.integers(0, 3))
        delta = DELTAS[int(rng.integers(0, len(DELTAS)))]
        if kind == 0:
            box = _random_box(rng)
        elif kind == 1:
            box = _pi_boundary_box(rng, truth, delta)
        else:
            box = _theta_boundary_box(rng, truth, delta)
        if box is None or any(lo <= 0 for lo, _ in box.values()):
            continue
        made += 1
        yield box


# ---------------------------------------------------------------------------
# the check of one verdict
# ---------------------------------------------------------------------------
def _check(conds, truth: Truth, box, margin: Fraction, use_sdp: bool, counts: dict) -> None:
    r = certify_box(conds, box, margin=margin, use_sdp=use_sdp)
    counts[str(r.status)] = counts.get(str(r.status), 0) + 1
    verts = _vertices(box)
    if margin == 0:
        want = all(truth.holds(v) for v in verts)
        assert str(r.status) == ("certified" if want else "refuted"), (truth.g.name, box, r.reason)
    else:
        for v in verts:
            lam = min(float(np.linalg.eigvalsh(f.evaluate([float(x) for x in v]))[0])
                      for f in conds.families)
            if abs(lam - float(margin)) > 1e-7 * max(1.0, abs(lam)):
                if str(r.status) == "certified":
                    assert lam > float(margin), (truth.g.name, box, v, lam)
    if str(r.status) == "certified":
        # a lower bound (lambda_min >= it); "> margin" itself is proven by the re-check
        assert r.margin_lower_bound is not None and r.margin_lower_bound >= margin
        assert r.witness is None
    else:
        assert r.margin_lower_bound is None  # no certified margin beside a non-certificate
    if str(r.status) == "refuted":
        w = r.witness
        fam = next(f for f in conds.families if f.name == w.family)
        pt = tuple(w.point[g] for g in GAINS)
        xx = sum(v * v for v in w.x)
        assert _exact_quad(fam, pt, w.x) - margin * xx <= 0
        assert w.value == _exact_quad(fam, pt, w.x) - margin * xx
        if margin == 0:
            assert not truth.holds(pt)
        if w.covers_box:
            for v in verts:
                assert _exact_quad(fam, v, w.x) - margin * xx <= 0


def _fuzz(specs, per_graph: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    counts: dict[str, int] = {}
    for spec in specs:
        truth = Truth(spec)
        conds = derive_conditions(spec)
        for box in _boxes(rng, truth, per_graph):
            margin = Fraction(0) if rng.random() < 0.8 else Fraction(1, 100)
            _check(conds, truth, box, margin, bool(rng.random() < 0.1), counts)
    return counts


SMALL = ["ring:5", "ring:8", "path:6", "path:12", "star:6", "star:30", "complete:5", "ring:31",
         "path:27", "complete:26"]


def test_fuzz_no_false_verdict() -> None:
    counts = _fuzz(SMALL, 30, seed=20261123)
    assert sum(counts.values()) == 300
    assert counts.get("certified", 0) > 30 and counts.get("refuted", 0) > 30


@pytest.mark.slow
def test_fuzz_no_false_verdict_large() -> None:
    specs = ["ring:64", "ring:101", "path:80", "path:200", "star:120", "star:200", "ring:200",
             "complete:60"]
    counts = _fuzz(specs, 40, seed=9)
    assert counts.get("certified", 0) > 20 and counts.get("refuted", 0) > 20


def test_truth_closed_forms_match_dense_eigenvalues() -> None:
    """The test's own truth agrees with dense eigenvalues away from the boundary."""
    rng = np.random.default_rng(4)
    for spec in ("ring:7", "path:9", "star:6", "complete:5"):
        truth, conds = Truth(spec), derive_conditions(spec)
        for _ in range(40):
            v = tuple(_q(float(x)) for x in (rng.uniform(0.1, 6), rng.uniform(0.1, 6),
                                             rng.uniform(0.05, 1)))
            lam = min(float(np.linalg.eigvalsh(f.evaluate([float(x) for x in v]))[0])
                      for f in conds.families)
            if abs(lam) > 1e-8:
                assert truth.holds(v) == (lam > 0), (spec, v, lam)
