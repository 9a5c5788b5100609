"""Exact per-mode checks shared by the certificates (any design).

A design's box is over its controller gains (:attr:`~.modes.ModeModel.names`); a
multiplier of its Lyapunov candidate may be given too (then it is used as given) or
left out (a certificate that needs it chooses it from :func:`multiplier_candidates`).
The helpers decide ``2 x 2`` matrices polynomial in ``lambda`` exactly over a Laplacian
eigenvalue enclosure, and polynomials in the gains over a box by exact interval bounds.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from functools import lru_cache
from typing import Any

import sympy as sp

from formsync_design.analysis.modes import LAMBDA, ModeModel, poly_coeffs_in_lambda, poly_mul
from formsync_design.analysis.spectrum import SpectrumCluster, poly_range
from formsync_design.errors import InputError
from formsync_design.gains import GainBox, GainRange

__all__ = ["GAINS", "gain_subs", "check_pd_coeffs", "entry_coeffs", "check_pd_2x2", "multi_affine",
           "lam_dict", "vertex_dict", "hurwitz_conditions", "box_poly_range", "split_box",
           "multiplier_candidates", "EXACT_GRID_POINTS", "coefficient_ranges", "psub"]

#: The classic gains of Liang et al. (the default design's box).
GAINS = ("K_o", "K_q", "beta")
#: Values tried per searched multiplier by the ``exact`` certificate (a geometric grid that
#: contains the paper certificate's 13-point grid, so ``paper`` certified implies ``exact``).
EXACT_GRID_POINTS = 49


def gain_subs(mm: ModeModel, vertex: tuple[Fraction, ...]) -> dict:
    """``{gain symbol: value}`` for a vertex in the design's gain order."""
    return dict(zip(mm.gains, vertex))


def psub(a: list[Fraction], b: list[Fraction]) -> list[Fraction]:
    """Difference of two coefficient lists (ascending powers).

    >>> psub([Fraction(1)], [Fraction(0), Fraction(2)])
    [Fraction(1, 1), Fraction(-2, 1)]
    """
    n = max(len(a), len(b))
    return [(a[i] if i < len(a) else Fraction(0)) - (b[i] if i < len(b) else Fraction(0)) for i in range(n)]


def check_pd_coeffs(
    m11: list[Fraction], m12: list[Fraction], m22: list[Fraction], cluster: SpectrumCluster
) -> tuple[int, str, tuple[Fraction, Fraction]]:
    """Decide ``[[m11, m12], [m12, m22]](lambda) > 0`` over the cluster's enclosure.

    Entries are exact coefficient lists in ascending powers of ``lambda``.
    Returns ``(+1 | -1 | 0, which, range)``: ``+1`` certified (``m11 > 0`` and
    ``det > 0`` over the whole enclosure), ``-1`` refuted (one of them ``<= 0``
    over the whole enclosure, hence at the true eigenvalue), ``0`` undecided;
    ``which`` names the deciding quantity and ``range`` its exact enclosure.

    >>> c = SpectrumCluster(Fraction(2), Fraction(2), 1)
    >>> one, lam = [Fraction(1)], [Fraction(0), Fraction(1)]
    >>> check_pd_coeffs(lam, one, one, c)
    (1, 'det', (Fraction(1, 1), Fraction(1, 1)))
    >>> check_pd_coeffs(one, lam, one, c)[0]
    -1
    """
    r11 = poly_range(m11, cluster.lo, cluster.hi)
    det = poly_range(psub(poly_mul(m11, m22), poly_mul(m12, m12)), cluster.lo, cluster.hi)
    if r11[1] <= 0:
        return -1, "M11", r11
    if det[1] <= 0:
        return -1, "det", det
    if r11[0] > 0 and det[0] > 0:
        return 1, "det", det
    return 0, "det" if det[0] <= 0 else "M11", det if det[0] <= 0 else r11


def entry_coeffs(expr: sp.Expr, sub: dict) -> list[Fraction]:
    """Coefficients in ``lambda`` of an entry at rational gains (cached: grid cells share vertices)."""
    return list(_entry_coeffs_cached(sp.sympify(expr), tuple(sub.items())))


@lru_cache(maxsize=65536)
def _entry_coeffs_cached(expr: sp.Expr, items: tuple) -> tuple[Fraction, ...]:
    return tuple(poly_coeffs_in_lambda(expr, dict(items)))


def check_pd_2x2(m: sp.Matrix, subs: dict, cluster: SpectrumCluster) -> tuple[int, str, tuple[Fraction, Fraction]]:
    """:func:`check_pd_coeffs` for a symbolic 2x2 matrix in ``lambda`` at rational gains ``subs``.

    >>> c = SpectrumCluster(Fraction(2), Fraction(2), 1)
    >>> check_pd_2x2(sp.Matrix([[LAMBDA, 1], [1, 1]]), {}, c)[0]
    1
    """
    return check_pd_coeffs(entry_coeffs(m[0, 0], subs), entry_coeffs(m[0, 1], subs),
                           entry_coeffs(m[1, 1], subs), cluster)


def multi_affine(mats: list[sp.Matrix], gains: tuple[sp.Symbol, ...]) -> bool:
    """Whether every entry has degree <= 1 in each gain (then vertices decide a box).

    >>> a, b = sp.symbols("a b")
    >>> multi_affine([sp.Matrix([[a * b, 1]])], (a, b)), multi_affine([sp.Matrix([[a**2]])], (a,))
    (True, False)
    """
    return all(sp.degree(e, g) <= 1 for mat in mats for e in mat for g in gains if e != 0)


def lam_dict(c: SpectrumCluster) -> dict[str, Any]:
    return {"lo": c.lo, "hi": c.hi, "multiplicity": c.multiplicity}


def vertex_dict(names: tuple[str, ...], v: tuple[Fraction, ...]) -> dict[str, Fraction]:
    return dict(zip(names, v))


def hurwitz_conditions(charpoly: tuple[sp.Expr, ...]) -> list[sp.Expr]:
    """Routh-Hurwitz conditions (all ``> 0``) of a real polynomial, leading coefficient first.

    The coefficients and the leading principal minors of the Hurwitz matrix.

    >>> s = sp.Symbol("a")
    >>> hurwitz_conditions((1, 2 * s, 3))
    [1, 2*a, 3, 6*a]
    """
    return list(_hurwitz_cached(tuple(sp.sympify(c) for c in charpoly)))


@lru_cache(maxsize=256)
def _hurwitz_cached(charpoly: tuple[sp.Expr, ...]) -> tuple[sp.Expr, ...]:
    a = list(charpoly)
    n = len(a) - 1
    h = sp.zeros(n, n)
    for i in range(n):
        for j in range(n):
            k = 2 * (j + 1) - (i + 1)
            if 0 <= k <= n:
                h[i, j] = a[k]
    minors = [sp.expand(h[:k, :k].det()) for k in range(1, n + 1)]
    out: list[sp.Expr] = []
    for e in [*a, *minors]:
        e = sp.expand(e)
        if e not in out:
            out.append(e)
    return tuple(out)


def box_poly_range(expr: sp.Expr, mm: ModeModel, box: GainBox, c: SpectrumCluster | None) -> tuple[Fraction, Fraction]:
    """Exact enclosure of a polynomial in the gains (and ``lambda``) over the box (and enclosure).

    All variables are non-negative, so each monomial is monotone in each.  ``c = None``:
    the expression does not contain ``lambda``.

    >>> from formsync_design.analysis.modes import mode_model
    >>> mm = mode_model()
    >>> b = GainBox.parse({"K_o": (1, 2), "K_q": (3, 4), "beta": 1}, GAINS)
    >>> box_poly_range(mm.c_qd * mm.c_s, mm, b, None)
    (Fraction(3, 1), Fraction(8, 1))
    """
    gens = (*mm.gains, LAMBDA)
    lo_v = [r.lo for r in box.ranges] + [c.lo if c is not None else Fraction(0)]
    hi_v = [r.hi for r in box.ranges] + [c.hi if c is not None else Fraction(0)]
    poly = sp.Poly(sp.expand(expr), *gens)
    a = b = Fraction(0)
    for exps, coef in poly.terms():
        q = Fraction(int(sp.Rational(coef).p), int(sp.Rational(coef).q))
        m0 = m1 = Fraction(1)
        for e, l_, h_ in zip(exps, lo_v, hi_v):
            m0 *= l_**e
            m1 *= h_**e
        if q > 0:
            a, b = a + q * m0, b + q * m1
        else:
            a, b = a + q * m1, b + q * m0
    return a, b


def coefficient_ranges(mm: ModeModel, box: GainBox) -> tuple[tuple[Fraction, Fraction], tuple[Fraction, Fraction]]:
    """Exact enclosures of ``d = -c_qd`` and ``k = -c_s`` over a box of the design's gains:
    the whole nominal loop depends on the gains only through ``(d, k)``.

    >>> from formsync_design.analysis.modes import mode_model
    >>> mm = mode_model("pd_consensus")
    >>> coefficient_ranges(mm, GainBox.parse({"k_p": (1, 2), "k_d": 3}, mm.names))
    ((Fraction(3, 1), Fraction(3, 1)), (Fraction(1, 1), Fraction(2, 1)))
    """
    d = box_poly_range(-mm.c_qd, mm, box, None)
    k = box_poly_range(-mm.c_s, mm, box, None)
    return d, k


def split_box(mm: ModeModel, box: Any) -> tuple[GainBox, GainBox | None]:
    """A box of the design's controller gains and, separately, the multipliers given in it.

    ``box`` is a :class:`GainBox` or a mapping over the controller gains, optionally with
    some multipliers (a multiplier given is used as given; one left out is chosen by the
    certificate that needs it).

    >>> from formsync_design.analysis.modes import mode_model
    >>> c, m = split_box(mode_model("pd_consensus"), {"k_p": 1, "k_d": (1, 2), "eps": "0.1"})
    >>> str(c), str(m)
    ('k_p=1, k_d=1:2', 'eps=0.1')
    """
    mnames = tuple(m.name for m in mm.multipliers)
    items: dict[str, Any] = ({r.name: r for r in box.ranges} if isinstance(box, GainBox)
                             else dict(box) if isinstance(box, dict) else dict(zip(mm.names, box)))
    unknown = [k for k in items if k not in mm.names and k not in mnames]
    if unknown:
        extra = ", ".join(mm.names + mnames)
        raise InputError(f"expected the gains of design {mm.spec_name} ({extra}), received {unknown}")
    ctrl = GainBox.parse({n: items[n] for n in mm.names if n in items}, mm.names)
    given = [n for n in mnames if n in items]
    mult = GainBox.parse({n: items[n] for n in given}, given) if given else None
    return ctrl, mult


def multiplier_candidates(mm: ModeModel, given: GainBox | None,
                          points: int = EXACT_GRID_POINTS) -> list[dict[sp.Symbol, GainRange]]:
    """The multiplier values a certificate tries: a given multiplier as given (a value or a
    range, then a box dimension), every other one on a geometric grid over its declared range
    (:func:`~formsync_design.certify.multipliers.multiplier_grid`, exact decimals).

    >>> from formsync_design.analysis.modes import mode_model
    >>> len(multiplier_candidates(mode_model("pd_consensus"), None)), multiplier_candidates(mode_model(), None)
    (49, [{}])
    """
    from formsync_design.certify.multipliers import multiplier_grid

    axes: list[list[GainRange]] = []
    for sym, rng in zip(mm.multipliers, mm.multiplier_ranges):
        if given is not None and sym.name in given.names:
            axes.append([given[sym.name]])
        else:
            assert rng is not None  # a multiplier declares its range (checked at load)
            axes.append([GainRange(sym.name, v, v) for v in multiplier_grid(rng, points)])
    return [dict(zip(mm.multipliers, combo)) for combo in itertools.product(*axes)]
