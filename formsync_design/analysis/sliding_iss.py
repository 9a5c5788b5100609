"""Ultimate bounds of a triggered sliding-variable loop: the norm chain and the invariant
ellipsoid (the ISS bounds of a self- or event-triggered sliding-mode coordination law).

The loop (per axis, every term is ``X (x) I_3``): the true sliding variables obey
``s' = M (-m w + Delta)``, ``M = H Dbar^{-1}`` (``H = L + B``, ``Dbar`` its diagonal),
``w = s + e + xi`` the held values (``e`` the measurement error, ``xi`` the neighbours'
staleness), with the trigger's sector ``|e_i| <= theta |w_i| + c`` (``theta = 1 - 1/m``,
``c`` the threshold floor) and the bounds ``|xi| <= xibar``, ``|Delta| <= Deltabar``.  The
design provides ``graph_weights(graph)`` (the weight ``K = P M`` of its certificate) and
``OPERATING_REGION = {"rho": ..., "omega_d_max": ...}`` (the surface step from
``z = H^{-1} s`` to ``|sigma_i - sigma_d|``), and the gains ``m_f`` (``m``) and ``r``.

Norm chain (:func:`iss_prediction`)
    From a certified reaching margin ``lambda`` (``V' <= -lambda |w|^2 + a |w| + b`` with
    ``a = m |K| (cbar + xibar) + (1 + theta) |K| Deltabar``, ``b = |K| Deltabar (cbar +
    xibar)``), ``|s| <= sqrt(p_max/p_min) ((1 + theta) R + cbar + xibar)`` ultimately, ``R`` the
    positive root of ``lambda R^2 = a R + b``; ``|z| <= |H^{-1}| |s|``; on the surface
    ``|sigma_i - sigma_d| <= (1 + rho^2)/4 |z_i| / (r (1 - rho^2)/4 - 3/2 rho wbar)``.
    Measured tail values of ``cbar``, ``xibar`` and ``Deltabar`` make it a prediction to
    compare with the run (floating point), not a certificate.  It is **vacuous**
    (:func:`iss_vacuous`) above ``2 rho``, the largest ``|sigma_i - sigma_d|`` inside the
    operating region ``|sigma|, |sigma_d| <= rho``.

Invariant ellipsoid (:func:`iss_ellipsoid`)
    The same loop without the norm chain: the sector used as ``|e_i|^2 <= (1 + k) theta^2
    |w_i|^2 + (1 + 1/k) c^2`` for ``k`` in a grid (default 2, 4, 6);
    :func:`~formsync_design.analysis.ellipsoid.invariant_ellipsoid` finds an attracting
    invariant ellipsoid ``{s^T P s <= 1}`` (LMI, exact re-check) and the exact ultimate bound
    of every ``|z_i| = |(H^{-1} s)_i|``; the surface step is the one above.  Same inputs as the
    norm chain, so the same status: a bound given those input bounds, tight up to the
    S-procedure and the surface step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

__all__ = ["iss_prediction", "iss_vacuous", "surface_factor", "IssEllipsoid", "iss_ellipsoid"]


def iss_prediction(design: Any, graph: Any, gains: dict[str, float], lam: float,
                   cbar: float, xibar: float, deltabar: float) -> float:
    """The predicted ultimate bound of ``max_i |sigma_i - sigma_d|`` (module docstring)."""
    K = np.array(design.module["graph_weights"](graph), dtype=float)
    H = graph.laplacian + graph.pinning_matrix
    m, r = gains["m_f"], gains["r"]
    th = 1 - 1 / m
    nK = float(np.linalg.norm(K, 2))
    p = np.diag(K)
    a = m * nK * (cbar + xibar) + (1 + th) * nK * deltabar
    b = nK * deltabar * (cbar + xibar)
    R = (a + math.sqrt(a * a + 4 * lam * b)) / (2 * lam)
    s_ult = math.sqrt(p.max() / p.min()) * ((1 + th) * R + cbar + xibar)
    z_ult = float(np.linalg.norm(np.linalg.inv(H), 2)) * s_ult
    reg = design.module["OPERATING_REGION"]
    rho, wbar = float(Fraction(reg["rho"])), float(Fraction(reg["omega_d_max"]))
    kappa = r * (1 - rho**2) / 4 - 1.5 * rho * wbar
    return (1 + rho**2) / 4 * z_ult / kappa if kappa > 0 else math.inf


def surface_factor(design: Any, r: float) -> float:
    """``(1 + rho^2)/4 / (r (1 - rho^2)/4 - 3/2 rho wbar)`` (inf outside the surface
    condition): ``|sigma_i - sigma_d| <= factor |z_i|`` ultimately on the operating region."""
    reg = design.module["OPERATING_REGION"]
    rho, wbar = float(Fraction(reg["rho"])), float(Fraction(reg["omega_d_max"]))
    kappa = r * (1 - rho**2) / 4 - 1.5 * rho * wbar
    return (1 + rho**2) / 4 / kappa if kappa > 0 else math.inf


def iss_vacuous(design: Any, bound: float) -> bool:
    """A bound of ``max_i |sigma_i - sigma_d|`` above ``2 rho`` says nothing: inside the
    operating region ``|sigma_i - sigma_d| <= |sigma_i| + |sigma_d| <= 2 rho`` already.

    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("selftrigger_mrp")
    >>> iss_vacuous(d, 1.21), iss_vacuous(d, 1.19)
    (True, False)
    """
    return bound > 2 * float(Fraction(design.module["OPERATING_REGION"]["rho"]))


@dataclass(frozen=True)
class IssEllipsoid:
    """The invariant-ellipsoid ultimate bound (module docstring): ``sigma_bound`` of
    ``max_i |sigma_i - sigma_d|``, ``z_bounds`` per spacecraft, the split ``k`` used and the
    ellipsoid (``certified`` False: no grid value passed the exact re-check)."""

    certified: bool
    sigma_bound: float
    z_bounds: tuple[float, ...]
    split: float | None
    ellipsoid: Any


def _sector_system(H: np.ndarray, m: float, th: float, split: float, cbar: float,
                   xibar: float, deltabar: float) -> tuple[Any, ...]:
    """``A, B, [G_k], [c_k], C`` of the per-axis loop (module docstring), inputs
    ``(e, xi, Delta)``."""
    n = H.shape[0]
    Mm = H / np.diag(H)[None, :]  # M = H Dbar^{-1}
    A = -m * Mm
    B = np.hstack([-m * Mm, -m * Mm, Mm])
    G, c = [], []
    for i in range(n):
        u = np.zeros(4 * n)
        u[[i, n + i, 2 * n + i]] = 1.0
        ei = np.zeros(4 * n)
        ei[n + i] = 1.0
        G.append((1 + split) * th**2 * np.outer(u, u) - np.outer(ei, ei))
        c.append((1 + 1 / split) * cbar**2)
    for blk, bnd in ((2, xibar), (3, deltabar)):
        g = np.zeros((4 * n, 4 * n))
        g[blk * n:(blk + 1) * n, blk * n:(blk + 1) * n] = -np.eye(n)
        G.append(g)
        c.append(bnd**2)
    return A, B, G, c, np.linalg.inv(H)


def iss_ellipsoid(design: Any, graph: Any, gains: dict[str, float], cbar: float,
                  xibar: float, deltabar: float,
                  splits: tuple[float, ...] = (2.0, 4.0, 6.0)) -> IssEllipsoid:
    """The invariant-ellipsoid bound of ``max_i |sigma_i - sigma_d|`` (module docstring);
    ``cbar`` the per-spacecraft threshold floor ``eps + eta_i`` over the tail."""
    from formsync_design.analysis.ellipsoid import invariant_ellipsoid

    H = np.asarray(graph.laplacian + graph.pinning_matrix, dtype=float)
    m, r = gains["m_f"], gains["r"]
    th = 1 - 1 / m
    best: IssEllipsoid | None = None
    for k in splits:
        A, B, G, c, C = _sector_system(H, m, th, k, cbar, xibar, deltabar)
        el = invariant_ellipsoid(A, B, G, c, C)
        if not el.certified:
            continue
        sb = surface_factor(design, r) * max(el.bounds)
        if best is None or sb < best.sigma_bound:
            best = IssEllipsoid(True, sb, el.bounds, k, el)
    if best is None:
        return IssEllipsoid(False, math.inf, tuple([math.inf] * H.shape[0]), None, None)
    return best


