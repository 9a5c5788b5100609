"""Minimum-fuel thruster allocation as a linear program, fast enough for a control loop.

The LP of one sample (thrusts ``f``, configuration matrix ``A`` of
:class:`~formsync_design.models.thrusters.ThrusterLayout`, commanded wrench ``w``)::

    minimize 1^T f   subject to   A f = w,   0 <= f <= F

(fuel is proportional to ``1^T f``: every thruster has the same exhaust velocity).
:class:`MinFuelAllocator` solves it in two ways:

* **explicit** (every sample of a closed-loop run): the dual ``max w^T y`` s.t. ``A^T y
  <= 1`` has its optimum at a vertex of a polytope that does not depend on ``w``; its
  vertices are enumerated once (every 6-subset of columns).  For a wrench, the best vertex
  ``y*`` gives the optimal fuel ``w^T y*``, and the thrusts are a non-negative solution of
  ``A_S f_S = w`` on the constraints active at ``y*`` (complementary slackness; NNLS).  The
  pair ``(f, y*)`` is checked as an optimality certificate every time (primal residual,
  ``f >= 0``, duality gap); when a thrust exceeds ``F`` (the upper bounds bind) the sample
  is solved by the bounded LP instead;
* **cvxpy + Clarabel** (:func:`lp_allocation_cvxpy`): the bounded LP itself, with the
  shortfall minimized first when ``w`` is not reachable within the bounds.

>>> from formsync_design.models.thrusters import cube_pairs_layout
>>> al = MinFuelAllocator(cube_pairs_layout())
>>> r = al.allocate([10.0, 0, 0, 0, 0, 5.0])
>>> r.method, round(r.fuel_thrust, 9), r.certified
('explicit', 10.0, True)
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import nnls

from formsync_design.errors import InputError, SolverError
from formsync_design.gains import json_number
from formsync_design.models.thrusters import ThrusterLayout

__all__ = ["LPAllocation", "MinFuelAllocator", "BoundedLP", "lp_allocation_cvxpy"]


@dataclass(frozen=True)
class LPAllocation:
    """Thrusts of one minimum-fuel allocation.

    Attributes
    ----------
    thrusts : numpy.ndarray
        Per-thruster force (N), in ``[0, F]``.
    method : str
        ``explicit`` (dual vertex + NNLS) or ``cvxpy`` (bounded LP, Clarabel).
    fuel_thrust : float
        ``1^T f`` (N).
    dual_bound : float
        ``w^T y*`` for ``explicit`` (the optimal value of the unbounded LP); nan for cvxpy.
    shortfall : float
        ``max |w - A f|`` (0 when the wrench is reproduced).
    certified : bool
        ``explicit``: primal feasible, non-negative and duality gap below ``1e-9``
        relative; ``cvxpy``: the solver reported optimal.
    """

    thrusts: np.ndarray
    method: str
    fuel_thrust: float
    dual_bound: float
    shortfall: float
    certified: bool

    def to_dict(self) -> dict[str, Any]:
        return {"thrusts": [json_number(v) for v in self.thrusts], "method": self.method,
                "fuel_thrust": json_number(self.fuel_thrust),
                "dual_bound": json_number(self.dual_bound),
                "shortfall": json_number(self.shortfall), "certified": self.certified}


class MinFuelAllocator:
    """Minimum-fuel allocation for one layout (module docstring).

    Attributes
    ----------
    vertices : numpy.ndarray
        ``(V, 6)`` vertices of the dual polytope ``{y : A^T y <= 1}``.
    active : list of numpy.ndarray
        Per vertex, the indices of the thrusters whose dual constraint is active.
    """

    def __init__(self, layout: ThrusterLayout, tol: float = 1e-9) -> None:
        a = layout.matrix
        if np.linalg.matrix_rank(a) < 6:
            raise InputError(f"expected a layout of rank 6 (any wrench), received rank "
                             f"{np.linalg.matrix_rank(a)}")
        self.layout = layout
        self.A = a
        self.tol = tol
        verts: list[np.ndarray] = []
        for cols in itertools.combinations(range(layout.count), 6):
            sub = a[:, cols]
            if abs(np.linalg.det(sub)) < 1e-9:
                continue
            y = np.linalg.solve(sub.T, np.ones(6))
            if np.all(a.T @ y <= 1 + 1e-9) and not any(np.allclose(y, v, atol=1e-9)
                                                       for v in verts):
                verts.append(y)
        if not verts:
            raise InputError("expected a positively spanning layout (a bounded dual), "
                             "received one whose dual polytope has no vertex")
        self.vertices = np.array(verts)
        self.active = [np.flatnonzero(np.abs(a.T @ y - 1) <= 1e-9) for y in verts]
        self._bounded: BoundedLP | None = None

    def allocate(self, wrench: Any) -> LPAllocation:
        """The minimum-fuel thrusts for ``wrench`` (explicit, else the bounded LP)."""
        w = np.asarray(wrench, dtype=float)
        if w.shape != (6,) or not np.all(np.isfinite(w)):
            raise InputError(f"expected a wrench as 6 finite numbers, received shape {w.shape}")
        scale = max(1.0, float(np.abs(w).max()))
        if not np.any(w):
            return LPAllocation(np.zeros(self.layout.count), "explicit", 0.0, 0.0, 0.0, True)
        vals = self.vertices @ w
        j = int(np.argmax(vals))
        idx = self.active[j]
        fs, _ = nnls(self.A[:, idx], w)
        f = np.zeros(self.layout.count)
        f[idx] = fs
        res = float(np.abs(self.A @ f - w).max())
        gap = abs(float(f.sum()) - float(vals[j]))
        ok = res <= self.tol * scale and gap <= self.tol * max(1.0, float(vals[j]))
        if ok and float(f.max()) <= self.layout.thrust:
            return LPAllocation(f, "explicit", float(f.sum()), float(vals[j]), res, True)
        if self._bounded is None:
            self._bounded = BoundedLP(self.layout)
        return self._bounded.solve(w)


class BoundedLP:
    """The two-stage bounded LP of :func:`lp_allocation_cvxpy` for one layout, built once
    (cvxpy parameters: a re-solve only updates the wrench).

    >>> from formsync_design.models.thrusters import cube_pairs_layout
    >>> r = BoundedLP(cube_pairs_layout()).solve(np.array([10.0, 0, 0, 0, 0, 5.0]))
    >>> r.method, round(r.fuel_thrust, 5)
    ('cvxpy', 10.0)
    """

    def __init__(self, layout: ThrusterLayout) -> None:
        import cvxpy as cp

        self.layout = layout
        a = layout.matrix
        self.w = cp.Parameter(6)
        self.s = cp.Parameter(nonneg=True)
        self.f = cp.Variable(layout.count)
        bounds = [self.f >= 0, self.f <= layout.thrust]
        self.p1 = cp.Problem(cp.Minimize(cp.norm1(a @ self.f - self.w)), bounds)
        self.p2 = cp.Problem(cp.Minimize(cp.sum(self.f)),
                             [cp.norm1(a @ self.f - self.w) <= self.s, *bounds])

    def solve(self, w: np.ndarray, tol: float = 1e-7) -> LPAllocation:
        import cvxpy as cp

        lay = self.layout
        self.w.value = w
        try:
            self.p1.solve(solver=cp.CLARABEL)
            if self.p1.status not in ("optimal", "optimal_inaccurate") or self.f.value is None:
                raise SolverError(f"the allocation LP ended with status {self.p1.status}; "
                                  "check the layout")
            short = float(self.p1.value)
            self.s.value = short * (1 + 1e-9) + tol * max(1.0, float(np.abs(w).max()))
            self.p2.solve(solver=cp.CLARABEL)
        except cp.error.SolverError as e:
            raise SolverError(f"the allocation LP failed in Clarabel ({e}); check the wrench "
                              "for huge values") from None
        ok = self.p2.status == "optimal" and self.f.value is not None
        x = np.clip(np.asarray(self.f.value, dtype=float), 0.0, lay.thrust)
        res = float(np.abs(lay.matrix @ x - w).max())
        return LPAllocation(x, "cvxpy", float(x.sum()), math.nan, res, ok)


def lp_allocation_cvxpy(layout: ThrusterLayout, wrench: Any) -> LPAllocation:
    """The bounded minimum-fuel LP by cvxpy + Clarabel (module docstring).

    Stage 1 minimizes the shortfall ``||w - A f||_1`` within ``0 <= f <= F``; stage 2 the
    fuel among allocations reaching that wrench.  A solver failure raises
    :class:`~formsync_design.errors.SolverError` (exit 3).

    >>> from formsync_design.models.thrusters import cube_pairs_layout
    >>> r = lp_allocation_cvxpy(cube_pairs_layout(), [150.0, 0, 0, 0, 0, 0])
    >>> r.method, round(r.shortfall, 4), round(r.fuel_thrust, 4)
    ('cvxpy', 50.0, 100.0)
    """
    w = np.asarray(wrench, dtype=float)
    if w.shape != (6,) or not np.all(np.isfinite(w)):
        raise InputError(f"expected a wrench as 6 finite numbers, received shape {w.shape}")
    return BoundedLP(layout).solve(w)
