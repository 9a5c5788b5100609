"""Invariant-ellipsoid ultimate bounds (formsync_design.analysis.ellipsoid) against closed forms
and simulation, and the self-triggered design's use of them."""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np
import pytest

from formsync_design.analysis.ellipsoid import invariant_ellipsoid, sqrt_up


@pytest.mark.parametrize("a,b,dbar", [(2.0, 1.0, 1.0), (0.3, 2.0, 0.05)])
def test_scalar_bound_is_the_exact_ultimate_bound(a: float, b: float, dbar: float) -> None:
    # x' = -a x + b d, |d| <= dbar: sup of the ultimate |x| is b dbar / a (constant d = dbar)
    r = invariant_ellipsoid(np.array([[-a]]), np.array([[b]]), [np.diag([0.0, -1.0])],
                            [dbar**2], np.array([[1.0]]))
    exact = b * dbar / a
    assert r.certified
    assert exact * (1 - 1e-12) <= r.bounds[0] <= exact * 1.001


def test_sector_input_matches_the_relaxed_closed_form() -> None:
    # x' = -a x + b e with |e|^2 <= (1 + k) th^2 x^2 + (1 + 1/k) c^2: the largest equilibrium
    # of the worst input is x^2 = b^2 (1 + 1/k) c^2 / (a^2 - b^2 (1 + k) th^2), a sound bound of
    # the true |e| <= th |x| + c loop, whose worst equilibrium is b c / (a - b th)
    a, b, th, c, k = 1.0, 1.0, 0.3, 0.1, 2.0
    G = np.array([[(1 + k) * th**2, 0.0], [0.0, -1.0]])
    r = invariant_ellipsoid(np.array([[-a]]), np.array([[b]]), [G], [(1 + 1 / k) * c**2],
                            np.array([[1.0]]))
    relaxed = math.sqrt(b**2 * (1 + 1 / k) * c**2 / (a**2 - b**2 * (1 + k) * th**2))
    assert r.certified
    assert relaxed * (1 - 1e-9) <= r.bounds[0] <= relaxed * 1.01
    assert r.bounds[0] >= b * c / (a - b * th)


def test_bound_contains_simulated_worst_inputs() -> None:
    # a lightly damped oscillator driven by |d| <= 1: constant, sinusoidal at resonance and the
    # V-maximising bang-bang input never leave the certified bound of |x_1|
    A = np.array([[0.0, 1.0], [-1.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    r = invariant_ellipsoid(A, B, [np.diag([0.0, 0.0, -1.0])], [1.0], np.array([[1.0, 0.0]]))
    assert r.certified and r.P is not None
    P = np.array([[float(x) for x in row] for row in r.P])
    h = 1e-3
    inputs = {"constant": lambda t, x: 1.0, "resonant": lambda t, x: math.sin(t * math.sqrt(0.96)),
              "bang-bang": lambda t, x: float(np.sign(B[:, 0] @ P @ x) or 1.0)}
    peaks = {}
    for name, d in inputs.items():
        x = np.zeros(2)
        top = 0.0
        for k in range(int(200 / h)):
            t = k * h

            def f(tt: float, xx: np.ndarray, d: Any = d) -> np.ndarray:
                return A @ xx + B[:, 0] * d(tt, xx)

            k1 = f(t, x)
            k2 = f(t + h / 2, x + h / 2 * k1)
            k3 = f(t + h / 2, x + h / 2 * k2)
            k4 = f(t + h, x + h * k3)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            top = max(top, abs(x[0]))
        peaks[name] = top
    assert max(peaks.values()) <= r.bounds[0]
    # a unit step's peak: static gain 1 times the overshoot 1 + exp(-zeta pi / sqrt(1 - zeta^2))
    assert peaks["constant"] == pytest.approx(1 + math.exp(-0.2 * math.pi / math.sqrt(0.96)),
                                              rel=1e-3)
    assert max(peaks.values()) >= 0.5 * r.bounds[0]          # and the bound is not far off


def test_unstable_or_infeasible_is_not_certified() -> None:
    r = invariant_ellipsoid(np.array([[0.5]]), np.array([[1.0]]), [np.diag([0.0, -1.0])], [1.0],
                            np.array([[1.0]]))
    assert not r.certified and r.bounds == (math.inf,)


def test_sqrt_up_is_an_upper_bound() -> None:
    for q in (Fraction(2), Fraction(1, 3), Fraction(10**20 + 1, 7)):
        b = sqrt_up(q)
        assert Fraction(b) ** 2 >= q and b <= math.sqrt(float(q)) * (1 + 1e-15)


def test_selftrigger_vacuous_label_and_interevent_origin() -> None:
    from formsync_design.analysis.sliding_iss import iss_vacuous
    from formsync_design.analysis.triggering import interevent_bound, interevent_origin
    from formsync_design.spec.loader import load_design

    d = load_design("selftrigger_mrp")
    rho = Fraction(d.module["OPERATING_REGION"]["rho"])
    assert iss_vacuous(d, float(2 * rho) * 1.01) and not iss_vacuous(d, float(2 * rho) * 0.99)
    g = {"m_f": Fraction(3), "delta": Fraction(1, 20), "eps": Fraction(1, 10),
         "alpha": Fraction(1, 10), "eta0": Fraction(1, 20), "r": Fraction(1, 2)}
    b = interevent_bound(d, g)
    active, rest, floor = interevent_origin(b, g)
    # (m - 1)/m^2 = 2/9 < eps/delta = 2: the bound is approached as |s| grows, not at rest
    assert b.value == Fraction(2, 9) and active == "(m_f - 1)/m_f**2"
    assert rest == Fraction(2) and not floor
