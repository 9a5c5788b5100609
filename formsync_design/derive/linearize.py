"""The linearisation of an agent design's formation closed loop at the commanded attitude.

For a quaternion agent design with a leader (:mod:`formsync_design.spec.agent`), the
equilibrium studied is: every spacecraft at the reference attitude (taken as the identity:
a design written in relative quaternions is invariant under a common rotation of the
reference and the formation), at rest, its controller states at a given value (zero by
default), the reference at rest.  The state of the linearisation is the kernel's order
(:mod:`formsync_design.sim.agent_kernel`) without the scalar parts: ``xi = (q_1..q_N,
w_1..w_N, z_1..z_N)`` (``q0 = sqrt(1 - |q|^2)`` is second order).  The output is ``z = (q_1
.. q_N)`` (the attitude errors' vector parts), the input the disturbance torques ``d``.

Because ``w' = J^{-1}(...)``, the loop is returned in the *descriptor* form

    T xi' = F xi + G d,     T = diag(I_3N, J_1 .. J_N, I),   z = C xi

whose ``F`` and ``G`` hold no ``J^{-1}``: exact rationals with small denominators, so that a
quadratic storage ``V = (T xi)^T P (T xi)`` gives dissipation matrices with integer-sized
entries (:mod:`formsync_design.analysis.l2gain`).

Every row comes from the design's symbolic closed loop (:func:`~formsync_design.derive.agent.
agent_closed_loop`): ``q'`` by the kinematics, ``J w' = u - w x J w + d`` from the loop's own
torque (checked to be ``J`` times the loop's ``w'``), ``z'`` from ``states(v)``; the Jacobian is
exact (SymPy), the equilibrium is checked exactly (a non-zero residual is a
:class:`~formsync_design.errors.DerivationError`), and ``F`` is a polynomial matrix in the
design's controller gains (:class:`PolyMatrix`).

>>> from formsync_design.spec.loader import load_design
>>> lin = linearize_agents(load_design("lv2012"), "path:2", [[[2, 0, 0], [0, 2, 0], [0, 0, 2]]] * 2,
...                        pinning=[1, 0])
>>> lin.nx, lin.gains, lin.labels[:2]
(18, ('k_p', 'k_d', 'a_f'), ('q1_1', 'q2_1'))
>>> lin.F.evaluate({"k_p": 1, "k_d": 2, "a_f": 3})[6, :2].tolist()   # J w1' row: -k_p (b + 1) - k_d a_f / 2
[-5.0, 0.0]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.errors import DerivationError, InputError

__all__ = ["PolyMatrix", "LinearLoop", "poly_entries", "formation_data", "linearize_agents"]

Exponents = tuple[int, ...]


@dataclass(frozen=True)
class PolyMatrix:
    """A matrix polynomial in named gains with exact rational coefficients:
    ``sum_k p^{e_k} M_k``, each ``M_k`` a sparse ``{(row, col): Fraction}``.

    >>> m = PolyMatrix((2, 2), ("k",), {(0,): {(0, 0): Fraction(1)}, (1,): {(1, 1): Fraction(1, 2)}})
    >>> m.evaluate({"k": 4}).tolist(), m.evaluate_exact({"k": 4})[1][1]
    ([[1.0, 0.0], [0.0, 2.0]], Fraction(2, 1))
    """

    shape: tuple[int, int]
    gains: tuple[str, ...]
    terms: Mapping[Exponents, Mapping[tuple[int, int], Fraction]]

    def _weights(self, point: Mapping[str, Any], exact: bool) -> dict[Exponents, Any]:
        missing = [g for g in self.gains if g not in point]
        if missing:
            raise InputError(f"expected values for the gains {list(self.gains)}, missing {missing}")
        vals = [Fraction(point[g]) if exact else float(point[g]) for g in self.gains]
        out: dict[Exponents, Any] = {}
        for e in self.terms:
            w: Any = Fraction(1) if exact else 1.0
            for v, k in zip(vals, e):
                w = w * v**k
            out[e] = w
        return out

    def evaluate(self, point: Mapping[str, Any]) -> np.ndarray:
        """Floating-point value at ``point`` (gain name -> number)."""
        out = np.zeros(self.shape)
        for e, w in self._weights(point, False).items():
            for (r, c), v in self.terms[e].items():
                out[r, c] += w * float(v)
        return out

    def evaluate_exact(self, point: Mapping[str, Any]) -> list[list[Fraction]]:
        """Exact rational value at ``point`` (rows of :class:`~fractions.Fraction`)."""
        out = [[Fraction(0)] * self.shape[1] for _ in range(self.shape[0])]
        for e, w in self._weights(point, True).items():
            for (r, c), v in self.terms[e].items():
                out[r][c] += w * v
        return out

    def coefficient(self, exponents: Exponents) -> np.ndarray:
        """The float coefficient matrix of one monomial (zeros if absent)."""
        out = np.zeros(self.shape)
        for (r, c), v in self.terms.get(tuple(exponents), {}).items():
            out[r, c] = float(v)
        return out


@dataclass(frozen=True)
class LinearLoop:
    """The linearised formation ``T xi' = F xi + G d``, ``z = C xi`` (module docstring).

    Attributes
    ----------
    design : str; graph : Digraph; n : spacecraft; nz : controller states per spacecraft
    gains : tuple of str (the design's controller gains, ``F``'s variables)
    labels : state names (``q1_1 .. w3_N .. x3_N``)
    F : PolyMatrix (nx x nx); T : list of Fraction rows (nx x nx, block diagonal);
    G : numpy (nx x 3N, 0/1); C : numpy (3N x nx, 0/1)
    inertias : (N, 3, 3) exact rationals as floats (the ``J_i`` of ``T``)
    """

    design: str
    graph: Any
    n: int
    nz: int
    gains: tuple[str, ...]
    labels: tuple[str, ...]
    F: PolyMatrix
    T: tuple[tuple[Fraction, ...], ...]
    G: np.ndarray
    C: np.ndarray
    inertias: np.ndarray

    @property
    def nx(self) -> int:
        return 3 * 2 * self.n + self.nz * self.n

    @property
    def nw(self) -> int:
        return 3 * self.n

    def T_float(self) -> np.ndarray:
        return np.array([[float(x) for x in row] for row in self.T])

    def standard(self, gains: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)`` of ``xi' = A xi + B d`` (floats) at ``gains``."""
        Ti = np.linalg.inv(self.T_float())
        return Ti @ self.F.evaluate(gains), Ti @ self.G, self.C


_CACHE: dict[tuple[str, int], tuple[Any, Any, list[sp.Symbol], Any]] = {}


def _rows(design: Any, m: int) -> tuple[Any, Any, list[sp.Symbol], Any]:
    """Symbolic Jacobians (rows ``q', J w', z'`` of the own spacecraft) w.r.t. the own and
    the neighbours' states and ``d``, at the equilibrium, for in-degree ``m`` (cached)."""
    key = (design.key, m)
    if key in _CACHE:
        return _CACHE[key]
    from formsync_design.derive.agent import agent_closed_loop

    loop = agent_closed_loop(design, m)
    v = loop.view
    names = [n for n, _ in design.decl.states]
    Jwdot = loop.u - v.w.cross(v.J * v.w) + loop.disturbance
    if v.J.inv() * Jwdot != loop.wdot:
        raise DerivationError(f"{design.path}: the closed loop's w' is not J^-1 (u - w x J w + d)")
    rows = [loop.rates[s] for s in v.own.q] + list(Jwdot)
    rows += [loop.rates[s] for n in names for s in v.z[n]]
    own_z = [s for n in names for s in v.z[n]]
    cols = [*v.own.q, *v.w, *own_z]
    for nb in v.nbrs:
        cols += [*nb.q, *nb.w, *[s for n in names for s in nb.z[n]]]
    point: dict[Any, Any] = {s: 0 for s in cols}
    point.update({v.own.q0: 1, **{nb.q0: 1 for nb in v.nbrs}})
    if design.decl.leader:
        point.update({s: 0 for s in (*v.ref.q, *v.ref.w, *v.ref.wdot)})
        point[v.ref.q0] = 1
    point.update({s: 0 for s in loop.disturbance})
    point[v.t] = 0
    R = sp.Matrix(rows)
    res = R.xreplace(point).applyfunc(sp.simplify)
    if any(x != 0 for x in res):
        raise DerivationError(f"{design.path}: expected the reference attitude at rest (states 0) "
                              f"to be an equilibrium, received a residual {list(res)}"[:300])
    Jx = R.jacobian(cols).xreplace(point)
    Jd = R.jacobian(list(loop.disturbance)).xreplace(point)
    if (Jx.free_symbols | Jd.free_symbols) & {v.t}:
        raise DerivationError(f"{design.path}: the linearisation depends on time t: expected a "
                              "time-invariant law at the equilibrium")
    out = (Jx, Jd, cols, v)
    _CACHE[key] = out
    return out


def poly_entries(expr: Any, gens: Sequence[sp.Symbol], where: str) -> dict[Exponents, Fraction]:
    e = sp.expand(expr)
    if e == 0:
        return {}
    if not gens:
        if not e.is_Rational:
            raise DerivationError(f"{where}: expected rational coefficients in the "
                                  f"linearisation, received {e}")
        return {(): Fraction(int(e.p), int(e.q))}
    try:
        poly = sp.Poly(e, *gens)
    except sp.PolynomialError:
        raise DerivationError(f"{where}: expected a linearisation polynomial in the gains, "
                              f"received {e}") from None
    out = {}
    for mono, c in poly.terms():
        if not c.is_Rational:
            raise DerivationError(f"{where}: expected rational coefficients in the linearisation, "
                                  f"received {c}")
        out[tuple(int(x) for x in mono)] = Fraction(int(c.p), int(c.q))
    return out


def formation_data(design: Any, graph: Any, inertias: Any, pinning: Any = None
                   ) -> tuple[Any, list[list[list[Fraction]]]]:
    """The digraph (with pinning gains for a leader design) and the inertias as exact
    rationals (the decimals they print as) of a formation to linearise.

    >>> from formsync_design.spec.loader import load_design
    >>> g, Jq = formation_data(load_design("ma_so3"), "ring:3", [[[2, 0, 0], [0, 2, 0], [0, 0, 2]]] * 3)
    >>> g.n, Jq[0][0][0]
    (3, Fraction(2, 1))
    """
    from formsync_design.gains import parse_number
    from formsync_design.graphs.digraph_io import make_digraph

    g = make_digraph(graph, pinning=pinning)
    if design.decl.leader and not g.has_leader:
        raise InputError(f"expected pinning gains b_i for the leader design {design.name}, "
                         f"received graph {g.name!r} without a leader")
    J = np.asarray(inertias, dtype=float)
    if J.shape != (g.n, 3, 3):
        raise InputError(f"expected {g.n} inertias (N, 3, 3), received shape {J.shape}")
    return g, [[[parse_number(float(x), "inertia") for x in row] for row in Ji] for Ji in J]


def linearize_agents(design: Any, graph: Any, inertias: Any, *, pinning: Any = None) -> LinearLoop:
    """Linearise ``design`` on ``graph`` with ``inertias`` at the reference attitude.

    Parameters
    ----------
    design : AgentDesign (quaternion representation, scalar controller gains)
    graph : a graph specification, Graph or Digraph (with pinning gains for a leader design)
    inertias : (N, 3, 3), taken as the exact decimals they print as
    pinning : optional pinning gains ``b_i`` (replace the graph's)

    Raises
    ------
    DerivationError
        Not a quaternion agent design, a diagonal gain, the reference not an equilibrium,
        a linearisation that is not polynomial in the gains.
    """
    from formsync_design.spec.declarations import GainKind, GainRole

    where = design.path
    if getattr(design, "form", None) != "agent" or design.representation != "quaternion":
        raise DerivationError(f"{where}: expected a quaternion agent design (FORM = 'agent') for "
                              f"the linearisation, received {getattr(design, 'name', design)!r}")
    ctrl = [g for g in design.decl.gains if g.role == GainRole.CONTROLLER]
    if any(g.kind == GainKind.DIAG for g in ctrl):
        raise DerivationError(f"{where}: expected scalar controller gains for the linearisation, "
                              "received a diagonal gain")
    g, Jq = formation_data(design, graph, inertias, pinning)
    n = g.n
    gens = [g_.symbol for g_ in ctrl]
    names = tuple(g_.name for g_ in ctrl)
    nz = design.decl.state_size
    nx = 6 * n + nz * n

    def at(i: int, part: str) -> int:
        return {"q": 3 * i, "w": 3 * n + 3 * i, "z": 6 * n + nz * i}[part]

    terms: dict[Exponents, dict[tuple[int, int], Fraction]] = {}
    Gm = np.zeros((nx, 3 * n))
    for i in range(n):
        nb = g.receives_from(i)
        Jx, Jd, cols, v = _rows(design, len(nb))
        num: dict[Any, Any] = {}
        for r in range(3):
            for c in range(3):
                num[v.J[r, c]] = sp.Rational(Jq[i][min(r, c)][max(r, c)])
        w = {(a, b): wt for a, b, wt in g.arcs}
        for k, j in enumerate(nb):
            num[v.nbrs[k].a] = sp.Rational(w[(i, j)])
        if design.decl.leader:
            num[v.b] = sp.Rational(g.pinning[i])
        row0 = [at(i, "q") + r for r in range(3)] + [at(i, "w") + r for r in range(3)]
        row0 += [at(i, "z") + r for r in range(nz)]
        col0 = [at(i, "q") + r for r in range(3)] + [at(i, "w") + r for r in range(3)]
        col0 += [at(i, "z") + r for r in range(nz)]
        for j in nb:
            col0 += [at(j, "q") + r for r in range(3)] + [at(j, "w") + r for r in range(3)]
            col0 += [at(j, "z") + r for r in range(nz)]
        Jn = Jx.xreplace(num)
        for a in range(Jn.shape[0]):
            for b in range(Jn.shape[1]):
                ent = poly_entries(Jn[a, b], gens, where)
                for mono, coef in ent.items():
                    cell = terms.setdefault(mono, {})
                    key = (row0[a], col0[b])
                    cell[key] = cell.get(key, Fraction(0)) + coef
        Jdn = Jd.xreplace(num)
        for a in range(Jdn.shape[0]):
            for b in range(3):
                val = sp.nsimplify(Jdn[a, b])
                if val != 0:
                    if val.free_symbols:
                        raise DerivationError(f"{where}: expected the disturbance to enter "
                                              "without gains, received " + str(val))
                    Gm[row0[a], 3 * i + b] = float(val)
    terms = {e: {k: c for k, c in cells.items() if c != 0} for e, cells in terms.items()}
    terms = {e: cells for e, cells in terms.items() if cells}
    T = [[Fraction(0)] * nx for _ in range(nx)]
    for r in range(nx):
        T[r][r] = Fraction(1)
    for i in range(n):
        for r in range(3):
            for c in range(3):
                T[at(i, "w") + r][at(i, "w") + c] = Jq[i][min(r, c)][max(r, c)]
    C = np.zeros((3 * n, nx))
    C[:, : 3 * n] = np.eye(3 * n)
    labels = [f"q{k}_{i + 1}" for i in range(n) for k in (1, 2, 3)]
    labels += [f"w{k}_{i + 1}" for i in range(n) for k in (1, 2, 3)]
    labels += [f"{name}{k + 1}_{i + 1}" for i in range(n) for name, s in design.decl.states
               for k in range(s)]
    return LinearLoop(design=design.name, graph=g, n=n, nz=nz, gains=names, labels=tuple(labels),
                      F=PolyMatrix((nx, nx), names, terms), T=tuple(tuple(r) for r in T),
                      G=Gm, C=C, inertias=np.array([[[float(x) for x in row] for row in Ji]
                                                     for Ji in Jq]))
