"""The exact linearisation of any agent design's formation on a graph, at consensus.

The equilibrium: every spacecraft at the identity attitude and at rest, controller states
zero; with a leader, the reference there too (at rest).  A design written in relative
attitudes is invariant under a common rotation, so this is every consensus attitude; for
any other design it is the one stated.  Each spacecraft's attitude is taken in a chart at
the identity (quaternion: the vector part ``q``; MRP: ``sigma``; SO(3): ``R = exp(theta^)``)
whose kinematics linearise to ``q' = w/2``, ``sigma' = w/4``, ``theta' = w``.

The state order is the agent kernels' without the redundant coordinates: ``xi = (a_1 ..
a_N, w_1 .. w_N, z_1 .. z_N)`` (``a_i`` the chart coordinates), the input the disturbance
torques ``d``, the output the chart coordinates; in the descriptor form of
:class:`~formsync_design.derive.linearize.LinearLoop`:

    T xi' = F xi + G d,   T = diag(I_3N, J_1 .. J_N, I)

Every entry comes from the design's own expressions (``controller(view)``,
``states(view)``) through :class:`~formsync_design.derive.locallinear.LinearPart`, which
also reports what the linearisation does not cover: a law not differentiable at the
equilibrium (an ideal ``sgn``, a fractional power ``|s|^(1/2)``) is named, with the
switching function realised as the simulator realises it (``sgn`` / ``sat(x/phi)`` /
``tanh(x/phi)``).  A sampled design is linearised as its continuous-time emulation (its
held values equal to the current ones).

>>> from formsync_design.spec.loader import load_design
>>> lin = linearize_formation(load_design("ma_mrp_ft"), "ring:3", [[[1, 0, 0], [0, 1, 0], [0, 0, 1]]] * 3,
...                           switch="sat", phi="1/100", fixed={"eps": "1/100"})
>>> lin.loop.nx, lin.loop.gains, lin.covered
(18, ('K1', 'K2', 'P1', 'P2'), True)
>>> ideal = linearize_formation(load_design("ma_mrp_ft"), "ring:3", [[[1, 0, 0], [0, 1, 0], [0, 0, 1]]] * 3,
...                             switch="sgn")
>>> ideal.covered, ideal.why.split(":")[0]
(False, 'u_1')
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.derive.linearize import LinearLoop, PolyMatrix, formation_data, poly_entries
from formsync_design.derive.locallinear import Chart, LinearPart, as_expr
from formsync_design.errors import DerivationError

__all__ = ["FormationLinearization", "linearize_formation", "KINEMATIC_GAIN"]

#: ``a' = c w`` of each chart at the identity.
KINEMATIC_GAIN: dict[str, Fraction] = {"quaternion": Fraction(1, 2), "mrp": Fraction(1, 4),
                                       "so3": Fraction(1)}

_HAT = {(0, 1): (2, -1), (0, 2): (1, 1), (1, 0): (2, 1), (1, 2): (0, -1), (2, 0): (1, -1),
        (2, 1): (0, 1)}


@dataclass(frozen=True)
class FormationLinearization:
    """The formation's linearisation and what it covers.

    ``loop``: the :class:`LinearLoop`; ``covered``: whether the law is differentiable at
    the equilibrium (else ``loop`` is ``None`` and ``why`` names the term); ``switch``,
    ``phi``: how ``sgn`` was realised; ``fixed``: the gains substituted by their value;
    ``emulation``: a sampled design linearised with held values equal to current ones;
    ``switching``: whether the law has a switching function ``sgn`` at all.
    """

    design: str
    graph: Any
    loop: LinearLoop | None
    covered: bool
    why: str
    switch: str
    phi: Fraction | None
    fixed: Mapping[str, Fraction]
    emulation: bool
    representation: str
    switching: bool = True


def _charts(att: Any, rep: str, w: Any, z: Sequence[Any], base: int) -> dict[Any, Chart]:
    out: dict[Any, Chart] = {}
    if rep == "quaternion":
        for k in range(3):
            out[att.q[k]] = Chart(0, {base + k: 1})
        out[att.q0] = Chart(1, {})
    elif rep == "mrp":
        for k in range(3):
            out[att.sigma[k]] = Chart(0, {base + k: 1})
    else:
        for i in range(3):
            for j in range(3):
                if i == j:
                    out[att.R[i, j]] = Chart(1, {})
                else:
                    k, sgn_ = _HAT[(i, j)]
                    out[att.R[i, j]] = Chart(0, {base + k: sgn_})
    for k in range(3):
        out[w[k]] = Chart(0, {base + 3 + k: 1})
    for k, s in enumerate(z):
        out[s] = Chart(0, {base + 6 + k: 1})
    return out


def _rest(att: Any, rep: str) -> dict[Any, Any]:
    out: dict[Any, Any] = {}
    if rep == "quaternion":
        out.update({s: 0 for s in att.q})
        out[att.q0] = 1
    elif rep == "mrp":
        out.update({s: 0 for s in att.sigma})
    else:
        out.update({att.R[i, j]: int(i == j) for i in range(3) for j in range(3)})
    out.update({s: 0 for s in att.w})
    if hasattr(att, "wdot"):
        out.update({s: 0 for s in att.wdot})
    return out


_CACHE: dict[tuple[Any, ...], Any] = {}


def _agent_rows(design: Any, m: int, switch: str, phi: Fraction | None) -> Any:
    """Rows ``(J w', z')`` of a spacecraft with ``m`` in-neighbours: their linear parts in
    the own and the neighbours' coordinates (symbolic weights, inertia, gains), or the
    reason the law is not differentiable at the equilibrium (cached)."""
    key = (design.key, m, switch, phi)
    if key in _CACHE:
        return _CACHE[key]
    from formsync_design.spec.agent import agent_expressions
    from formsync_design.spec.dag import free_symbols

    ex = agent_expressions(design, m)
    v = ex["view"]
    rep = design.representation
    names = [n for n, _ in design.decl.states]
    own_z = [s for n in names for s in v.z[n]]
    p = 6 + len(own_z)
    charts = _charts(v.own, rep, v.w, own_z, 0)
    charts.update(_charts(v.held, rep, v.held.w, [], 0))        # emulation: held = current
    for k, nb in enumerate(v.nbrs, start=1):
        charts.update(_charts(nb, rep, nb.w, [s for n in names for s in nb.z[n]], k * p))
    values: dict[Any, Any] = {}
    if design.decl.leader:
        values.update(_rest(v.ref, rep))
    exprs = list(ex["u"]) + [e for n in names for e in ex["states"][n]]
    if v.t in free_symbols(sp.Matrix(exprs)):
        raise DerivationError(f"{design.path}: expected a time-invariant law for the "
                              "linearisation at consensus, received one in t")
    phi_s = sp.Rational(phi.numerator, phi.denominator) if phi is not None else None
    lp = LinearPart(charts, values, switch=switch, phi=phi_s)
    rows = []
    for k, e in enumerate(exprs):
        r = lp.result(e)
        what = f"u_{k + 1}" if k < 3 else f"the controller state {k - 2}"
        if r.lin is None:
            out: Any = ("not-covered", f"{what}: {r.why}")
            _CACHE[key] = out
            return out
        if not lp.is_zero(r.v0):
            raise DerivationError(f"{design.path}: expected consensus at rest to be an "
                                  f"equilibrium, received {what} = {r.v0} there")
        rows.append(r.lin)
    from formsync_design.spec.agent_view import sgn

    out = ("ok", rows, v, p, sp.Matrix(exprs).has(sgn))
    _CACHE[key] = out
    return out


def linearize_formation(design: Any, graph: Any, inertias: Any, *, switch: str = "sat",
                        phi: Any = "1/100", fixed: Mapping[str, Any] | None = None,
                        pinning: Any = None) -> FormationLinearization:
    """Linearise ``design`` on ``graph`` at consensus (module docstring).

    Parameters
    ----------
    design : AgentDesign
    graph : a graph specification, Graph or Digraph (pinning gains for a leader design)
    inertias : (N, 3, 3), taken as the exact decimals they print as
    switch, phi : how ``sgn`` is realised (the simulator's ``switch`` and boundary layer)
    fixed : gains substituted by their exact value (the others stay variables of ``F``)

    Raises
    ------
    DerivationError
        Consensus at rest not an equilibrium, a value the linearisation cannot decide, a
        linearisation that is not polynomial in the free gains.
    """
    from formsync_design.gains import parse_number
    from formsync_design.spec.declarations import GainKind, GainRole

    if getattr(design, "form", None) != "agent":
        raise DerivationError(f"expected an agent design (FORM = 'agent') for the formation "
                              f"linearisation, received {getattr(design, 'name', design)!r}")
    g, Jq = formation_data(design, graph, inertias, pinning)
    n = g.n
    phi_q = None if switch == "sgn" else parse_number(phi, "boundary layer phi")
    fixed_q = {k: parse_number(v, k) for k, v in (fixed or {}).items()}
    ctrl = [x for x in design.decl.gains if x.role == GainRole.CONTROLLER]
    free = [x for x in ctrl if x.name not in fixed_q]
    gains_sub: dict[Any, Any] = {}
    for x in ctrl:
        val = sp.Rational(fixed_q[x.name].numerator, fixed_q[x.name].denominator) \
            if x.name in fixed_q else x.symbol
        if x.kind == GainKind.DIAG:
            for s in sp.symbols(f"{x.name}_1:4", positive=True):
                gains_sub[s] = val
        else:
            gains_sub[x.symbol] = val
    gens = [x.symbol for x in free]
    names = tuple(x.name for x in free)
    nz = design.decl.state_size
    p = 6 + nz
    nx = p * n
    rep = design.representation
    kin = KINEMATIC_GAIN[rep]
    emulation = design.decl.sampling != "continuous"

    def at(i: int, c: int) -> int:
        return 3 * i + c if c < 3 else (3 * n + 3 * i + c - 3 if c < 6 else 6 * n + nz * i + c - 6)

    terms: dict[tuple[int, ...], dict[tuple[int, int], Fraction]] = {}
    switching = False
    Gm = np.zeros((nx, 3 * n))
    arcw = {(a, b): wt for a, b, wt in g.arcs}
    for i in range(n):
        nb = g.receives_from(i)
        got = _agent_rows(design, len(nb), switch, phi_q)
        if got[0] != "ok":
            return FormationLinearization(design.name, g, None, False, got[1], switch, phi_q,
                                          fixed_q, emulation, rep)
        _, rows, v, _, has_sgn = got
        switching = switching or has_sgn
        num: dict[Any, Any] = dict(gains_sub)
        for r in range(3):
            for c in range(3):
                num[v.J[r, c]] = sp.Rational(Jq[i][min(r, c)][max(r, c)])
        for k, j in enumerate(nb):
            num[v.nbrs[k].a] = sp.Rational(arcw[(i, j)])
        if design.decl.leader:
            num[v.b] = sp.Rational(g.pinning[i])
        slots = [i, *nb]
        for c in range(3):
            cell = terms.setdefault((0,) * len(gens), {})
            cell[(at(i, c), at(i, 3 + c))] = kin
        for r_idx, lin in enumerate(rows):
            row = at(i, 3 + r_idx) if r_idx < 3 else at(i, 6 + r_idx - 3)
            for d_idx, coef in lin.items():
                slot, c = divmod(d_idx, p)
                col = at(slots[slot], c)
                val = as_expr(coef).xreplace(num)
                for mono, q in poly_entries(val, gens, design.path).items():
                    cell = terms.setdefault(mono, {})
                    cell[(row, col)] = cell.get((row, col), Fraction(0)) + q
            if r_idx < 3:
                Gm[row, 3 * i + r_idx] = 1.0
    terms = {e: {k: c for k, c in cells.items() if c != 0} for e, cells in terms.items()}
    terms = {e: cells for e, cells in terms.items() if cells}
    T = [[Fraction(0)] * nx for _ in range(nx)]
    for r in range(nx):
        T[r][r] = Fraction(1)
    for i in range(n):
        for r in range(3):
            for c in range(3):
                T[at(i, 3 + r)][at(i, 3 + c)] = Jq[i][min(r, c)][max(r, c)]
    C = np.zeros((3 * n, nx))
    C[:, : 3 * n] = np.eye(3 * n)
    chart = {"quaternion": "q", "mrp": "sigma", "so3": "theta"}[rep]
    labels = [f"{chart}{k}_{i + 1}" for i in range(n) for k in (1, 2, 3)]
    labels += [f"w{k}_{i + 1}" for i in range(n) for k in (1, 2, 3)]
    labels += [f"{name}{k + 1}_{i + 1}" for i in range(n) for name, s in design.decl.states
               for k in range(s)]
    loop = LinearLoop(design=design.name, graph=g, n=n, nz=nz, gains=names, labels=tuple(labels),
                      F=PolyMatrix((nx, nx), names, terms), T=tuple(tuple(r) for r in T),
                      G=Gm, C=C, inertias=np.array([[[float(x) for x in row] for row in Ji]
                                                     for Ji in Jq]))
    return FormationLinearization(design.name, g, loop, True, "", switch, phi_q, fixed_q,
                                  emulation, rep, switching)
