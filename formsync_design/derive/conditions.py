"""The derivation engine: Lyapunov conditions ``Theta_i`` and ``Pi`` of a graph.

Pipeline (paper section 2, for any specification, see :mod:`.spec`):

1. :func:`~.closed_loop.derive_closed_loop` substitutes the controller ``u_i``
   into the Lagrangian model ``A q'' + B q' = Q^T u + Q^T u_d`` with ``A``,
   ``B``, ``Q`` kept as opaque invertible matrices, and reads off
   ``q_i'' = c_qd q_i' + c_s s_i + c_sigma sigma_i + A^{-1} Q^T u_d``.
2. For each neighbour count ``m`` a *local template* is derived once
   (:func:`~.templates.derive_local_template`): ``Theta`` and ``V_i'`` as a
   bilinear form in the local slots.
3. :func:`derive_conditions` assembles the templates by graph into
   ``V' = -zeta^T (Pi (x) I3) zeta + sum_i rho_i^T (c_sigma sigma_i + d_i)``,
   ``zeta = (q_1'..q_n', s_1..s_n)`` (paper eq. 9), using the undirected-graph
   identity ``sum_i sum_{j in G_i} c e_ij^T q_j' = -c sum_j q_j'^T s_j``.
   When the local coefficients do not depend on the neighbour's index (the
   usual case) the assembly is sparse matrix algebra on the adjacency
   (``D_w A``, ``A D_w A``), so dense graphs scale; otherwise entry by entry.
   :func:`brute_force_vdot` re-derives ``V'`` for a whole small graph by
   full symbolic expansion, to cross-check the assembly.

The three axes decouple (checked: the forms are ``F (x) I3``), so every
matrix is stored per axis as a :class:`~.families.MatrixFamily`.  Every cache
is keyed by the specification's content (:func:`~.closed_loop.spec_cache_key`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np
import scipy.sparse as sps
import sympy as sp

from formsync_design.derive.closed_loop import (
    SpecLike,
    derive_closed_loop,
    registered_spec,
    resolve_spec,
    spec_cache_key,
)
from formsync_design.derive.families import (
    GAIN_NAMES,
    FamilyTerm,
    MatrixFamily,
    family_from_entries,
)
from formsync_design.derive.lyapunov import LyapunovConditions, zeta_labels
from formsync_design.derive.templates import LocalTemplate, template_cached
from formsync_design.errors import DerivationError
from formsync_design.graphs.build import Graph, make_graph
from formsync_design.spec.lagrangian_view import LyapunovView
from formsync_design.spec.loader import gain_symbols

__all__ = [
    "derive_conditions",
    "paper_conditions",
    "brute_force_vdot",
]


# ---------------------------------------------------------------------------
# assembly by graph
# ---------------------------------------------------------------------------
@lru_cache(maxsize=4096)
def _poly_terms(expr: sp.Expr, gens: tuple[sp.Symbol, ...]) -> tuple[tuple[tuple[int, ...], Fraction], ...]:
    expr = sp.expand(expr)
    if expr == 0:
        return ()
    if expr.free_symbols - set(gens):
        raise DerivationError(
            f"expected a polynomial in the gains {tuple(map(str, gens))}, received {expr}"
        )
    out = []
    for mono, c in sp.Poly(expr, *gens).terms():
        if not c.is_Rational:
            raise DerivationError(f"expected rational coefficients, received {c} in {expr}")
        out.append((tuple(int(x) for x in mono), Fraction(int(c.p), int(c.q))))
    return tuple(out)


def _poly_dict(expr: Any, gens: tuple[sp.Symbol, ...]) -> dict[tuple[int, ...], Fraction]:
    return dict(_poly_terms(sp.sympify(expr), tuple(gens)))


def _acc(entries: dict, i: int, j: int, pd: dict, scale: Fraction = Fraction(1)) -> None:
    cell = entries.setdefault((i, j), {})
    for mono, c in pd.items():
        cell[mono] = cell.get(mono, Fraction(0)) + c * scale


def _theta_entries(theta: sp.Matrix, gens: tuple) -> dict:
    entries: dict = {}
    for (a, b), val in theta.todok().items():
        if val != 0:
            _acc(entries, a, b, _poly_dict(val, gens))
    return entries


def _theta_family(theta: sp.Matrix, i: int, graph: Graph, gens: tuple) -> MatrixFamily:
    base = family_from_entries("Theta", theta.shape[0], _theta_entries(theta, gens),
                               gains=tuple(map(str, gens)))
    return _theta_for(base, i, graph)


def _theta_for(base: MatrixFamily, i: int, graph: Graph) -> MatrixFamily:
    """The per-degree family ``base`` relabelled for spacecraft ``i`` (0-based)."""
    labels = (f"qdot_{i + 1}",) + tuple(f"q_{i + 1}-q_{j + 1}" for j in graph.neighbors(i))
    return replace(base, name=f"Theta_{i + 1}", row_labels=labels, spacecraft=i + 1)


class _SparseSum:
    """Per-monomial sums ``sum_k f_k W_k`` (``f_k`` rational, ``W_k`` integer sparse)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.parts: dict[tuple[int, ...], list[tuple[Fraction, Any]]] = {}

    def add(self, mono: tuple[int, ...], factor: Fraction, mat: Any) -> None:
        if factor != 0 and mat.nnz:
            self.parts.setdefault(mono, []).append((factor, mat))

    def family(self, name: str, row_labels: tuple[str, ...],
               gains: tuple[str, ...] = GAIN_NAMES) -> MatrixFamily:
        terms = []
        for mono in sorted(self.parts):
            parts = self.parts[mono]
            den = math.lcm(*(f.denominator for f, _ in parts))
            bound = sum(abs(int(f * den)) * int(abs(m.data).max(initial=0)) for f, m in parts)
            if bound >= 2**62:  # int64 sums stay exact below this
                raise DerivationError(
                    f"expected family coefficients below 2^62 in {name}, received a bound {bound}"
                )
            total = sps.csr_matrix((self.size, self.size), dtype=np.int64)
            for f, m in parts:
                total = total + sps.csr_matrix(m, dtype=np.int64) * int(f * den)
            total.sum_duplicates()
            total.eliminate_zeros()
            if total.nnz == 0:
                continue
            g = math.gcd(den, *(int(x) for x in np.unique(np.abs(total.data))))
            den //= g
            total.data //= g
            mat: Any = sps.csr_matrix(total, dtype=np.int64)
            mat.sort_indices()
            if self.size <= 64:
                mat = np.asarray(mat.todense(), dtype=np.int64)
            terms.append(FamilyTerm(mono, Fraction(1, den), mat))
        return MatrixFamily(name=name, gains=gains, terms=tuple(terms), size=self.size,
                            block_size=3, row_labels=row_labels)


def _uniform(values: list[dict]) -> dict | None:
    """The common value of per-neighbour coefficient dicts, or None if they differ."""
    if not values:
        return {}
    first = values[0]
    return first if all(v == first for v in values[1:]) else None


def _uniform_pieces(cf: dict, m: int) -> dict | None:
    """Per-degree coefficients that do not depend on the neighbour's index, or None."""
    qd_qdn = _uniform([cf["qd_qdn"].get(k, {}) for k in range(1, m + 1)])
    qdn_s = _uniform([cf["qdn_S"].get(k, {}) for k in range(1, m + 1)])
    qq = cf["qdn_qdn"]
    if any(k > k2 for k, k2 in qq):
        return None
    diag = _uniform([qq.get((k, k), {}) for k in range(1, m + 1)])
    offkeys = [key for key in qq if key[0] != key[1]]
    if offkeys and len(offkeys) != m * (m - 1) // 2:
        return None
    off = _uniform([qq[key] for key in offkeys])
    if qd_qdn is None or qdn_s is None or diag is None or off is None:
        return None
    return {"qd_qdn": qd_qdn, "qdn_S": qdn_s, "qdn_diag": diag, "qdn_off": off}


def _assemble_pi_structured(graph: Graph, classified: dict, own_c: dict,
                            gains: tuple[str, ...] = GAIN_NAMES) -> MatrixFamily | None:
    """``Pi`` by sparse algebra on the adjacency ``A`` (per-vertex weights ``D_w``):
    ``-D_w`` on the diagonal blocks, ``-(D_w A + A D_w)/2`` for neighbour rates,
    ``-(A W A - diag(A w))/2`` for pairs of a spacecraft's neighbours."""
    n = graph.n
    uni = {m: _uniform_pieces(cf, m) for m, cf in classified.items()}
    if any(u is None for u in uni.values()):
        return None
    deg = graph.degrees
    A = sps.csr_matrix(graph.adjacency, dtype=np.int64)
    Z = sps.csr_matrix((n, n), dtype=np.int64)
    acc = _SparseSum(2 * n)

    def pieces(get: Any) -> dict[tuple[int, ...], tuple[Fraction, Any]]:
        """Per monomial: (1/den, integer diagonal of the per-vertex weights)."""
        per_deg = {m: get(m) for m in classified}
        out = {}
        for mono in sorted({mono for d in per_deg.values() for mono in d}):
            w = [per_deg[deg[i]].get(mono, Fraction(0)) for i in range(n)]
            den = math.lcm(*(x.denominator for x in w))
            out[mono] = (Fraction(1, den), sps.diags(np.array([int(x * den) for x in w], dtype=np.int64),
                                                    dtype=np.int64).tocsr())
        return out

    def block(a: Any, b: Any, c: Any, d: Any) -> Any:
        return sps.bmat([[a, b], [c, d]], format="csr", dtype=np.int64)

    qd_s = {m: _merge({k: -v / 2 for k, v in classified[m]["qd_S"].items()},
                      {k: v / 2 for k, v in own_c.items()}) for m in classified}
    for mono, (f, W) in pieces(lambda m: classified[m]["qd_qd"]).items():
        acc.add(mono, -f, block(W, Z, Z, Z))
    for mono, (f, W) in pieces(lambda m: classified[m]["S_S"]).items():
        acc.add(mono, -f, block(Z, Z, Z, W))
    for mono, (f, W) in pieces(lambda m: qd_s[m]).items():
        acc.add(mono, f, block(Z, W, W, Z))
    for mono, (f, W) in pieces(lambda m: uni[m]["qd_qdn"]).items():  # type: ignore[index]
        acc.add(mono, -f / 2, block(W @ A + A @ W, Z, Z, Z))
    for mono, (f, W) in pieces(lambda m: uni[m]["qdn_S"]).items():  # type: ignore[index]
        acc.add(mono, -f / 2, block(Z, A @ W, W @ A, Z))
    for mono, (f, W) in pieces(lambda m: uni[m]["qdn_diag"]).items():  # type: ignore[index]
        acc.add(mono, -f, block(sps.diags(np.asarray((A @ W).sum(axis=1)).ravel(), dtype=np.int64),
                                Z, Z, Z))
    for mono, (f, W) in pieces(lambda m: uni[m]["qdn_off"]).items():  # type: ignore[index]
        AWA = A @ W @ A
        acc.add(mono, -f / 2, block(AWA - sps.diags(AWA.diagonal(), dtype=np.int64), Z, Z, Z))
    return acc.family("Pi", zeta_labels(n), gains)


def _assemble_pi_entries(graph: Graph, classified: dict, own_c: dict,
                         gains: tuple[str, ...] = GAIN_NAMES) -> MatrixFamily:
    """``Pi`` entry by entry (any local structure; quadratic in the degree)."""
    n = graph.n
    entries: dict = {}
    for i in range(n):
        cf = classified[graph.degrees[i]]
        nb = graph.neighbors(i)
        si = n + i
        # Pi = -(quadratic part of V'); off-diagonal monomials split in halves
        _acc(entries, i, i, cf["qd_qd"], Fraction(-1))
        _acc(entries, si, si, cf["S_S"], Fraction(-1))
        _acc(entries, i, si, cf["qd_S"], Fraction(-1, 2))
        _acc(entries, si, i, cf["qd_S"], Fraction(-1, 2))
        # own-edge rewrite: sum_{i in G_j} c e_ij^T q_j' = -c q_j'^T s_j
        _acc(entries, i, si, own_c, Fraction(1, 2))
        _acc(entries, si, i, own_c, Fraction(1, 2))
        for k, j in enumerate(nb, start=1):
            c = cf["qd_qdn"].get(k, {})
            _acc(entries, i, j, c, Fraction(-1, 2))
            _acc(entries, j, i, c, Fraction(-1, 2))
            c = cf["qdn_S"].get(k, {})
            _acc(entries, j, si, c, Fraction(-1, 2))
            _acc(entries, si, j, c, Fraction(-1, 2))
            for k2, j2 in enumerate(nb, start=1):
                c = cf["qdn_qdn"].get((k, k2), {})
                if not c:
                    continue
                if k == k2:
                    _acc(entries, j, j, c, Fraction(-1))
                else:
                    _acc(entries, j, j2, c, Fraction(-1, 2))
                    _acc(entries, j2, j, c, Fraction(-1, 2))
    return family_from_entries("Pi", 2 * n, entries, row_labels=zeta_labels(n), gains=gains)


@lru_cache(maxsize=64)
def _conditions_cached(graph: Graph, key: str, structured: bool = True) -> LyapunovConditions:
    spec = registered_spec(key)
    gens = gain_symbols(spec)
    names = spec.gains
    degrees = sorted(set(graph.degrees))
    templates = {m: template_cached(key, m) for m in degrees}
    # classify the local forms once per degree
    classified = {m: _classify(templates[m], gens) for m in degrees}
    # Own-edge terms c e_ij^T q_j' sum into -c q_j'^T s_j only if c is the same for
    # every neighbour count present.  For m >= 2, c = c_diag - c_off; for m = 1
    # (s_i = e_1) the split is free and is chosen to match the others.
    own_exprs = {m: sp.expand(cf["c_diag"] - cf["c_off"]) for m, cf in classified.items()
                 if cf["c_off"] is not None}
    if len(set(own_exprs.values())) > 1:
        raise DerivationError(
            "expected the coefficient of e_ij^T q_j' in V_i' to be the same for every "
            f"neighbour count (to sum it into s_j); received {own_exprs}"
        )
    own_expr = next(iter(own_exprs.values())) if own_exprs else classified[degrees[0]]["c_diag"]
    for m, cf in classified.items():
        c_off = cf["c_off"] if cf["c_off"] is not None else sp.expand(cf["c_diag"] - own_expr)
        if c_off != 0:
            for k in range(1, m + 1):
                cf["qdn_S"][k] = _merge(cf["qdn_S"].get(k, {}), _poly_dict(c_off, gens))
    own_c = _poly_dict(own_expr, gens)
    pi = _assemble_pi_structured(graph, classified, own_c, names) if structured else None
    if pi is None:
        pi = _assemble_pi_entries(graph, classified, own_c, names)
    bases = {m: family_from_entries("Theta", m + 1, _theta_entries(templates[m].theta, gens),
                                    gains=names)
             for m in degrees}
    thetas = tuple(_theta_for(bases[graph.degrees[i]], i, graph) for i in range(graph.n))
    # switching / disturbance part
    cl = derive_closed_loop(spec)
    rho_qd, rho_s = classified[degrees[0]]["rho"]
    for m in degrees[1:]:
        if classified[m]["rho"] != (rho_qd, rho_s):
            raise DerivationError("expected the same disturbance coefficient rho_i for every degree")
    qd = sp.Matrix(sp.symbols("x1 x2 x3"))
    s = sp.Matrix(sp.symbols("y1 y2 y3"))
    arg = cl.switch_argument_explicit(qd, s)
    matches = arg is not None and (arg - (rho_qd * qd + rho_s * s)).applyfunc(sp.expand) == sp.zeros(3, 1)
    return LyapunovConditions(
        graph=graph, source="derived", spec_name=spec.name, gains=names,
        theta=thetas, pi=pi, switching_matches=bool(matches), rho=(rho_qd, rho_s),
    )


def _classify(t: LocalTemplate, gens: tuple) -> dict:
    """Split a local V' form into the pieces that map onto zeta."""
    m = t.m
    out: dict[str, Any] = {
        "qd_qd": {}, "S_S": {}, "qd_S": {}, "qd_qdn": {}, "qdn_S": {},
        "qdn_qdn": {},
    }
    edge_qd: list[sp.Expr] = [sp.Integer(0)] * (m + 1)
    edge_S: list[sp.Expr] = [sp.Integer(0)] * (m + 1)
    edge_qdn: dict[tuple[int, int], sp.Expr] = {}
    rho: dict[str, sp.Expr] = {"qd": sp.Integer(0), "S": sp.Integer(0)}
    rho_edge: list[sp.Expr] = [sp.Integer(0)] * (m + 1)
    sig_terms: dict = {}
    for (a, b), c in t.vdot.items():
        pair = (a[0], b[0])
        if pair == ("qd", "qd"):
            out["qd_qd"] = _merge(out["qd_qd"], _poly_dict(c, gens))
        elif pair == ("S", "S"):
            out["S_S"] = _merge(out["S_S"], _poly_dict(c, gens))
        elif pair == ("qd", "S"):
            out["qd_S"] = _merge(out["qd_S"], _poly_dict(c, gens))
        elif pair == ("qd", "e"):
            edge_qd[b[1]] += c
        elif pair == ("e", "S"):
            edge_S[a[1]] += c
        elif pair == ("qdn", "e"):
            edge_qdn[(b[1], a[1])] = edge_qdn.get((b[1], a[1]), 0) + c
        elif pair == ("qd", "qdn"):
            out["qd_qdn"][b[1]] = _poly_dict(c, gens)
        elif pair == ("qdn", "S"):
            out["qdn_S"][a[1]] = _poly_dict(c, gens)
        elif pair == ("qdn", "qdn"):
            out["qdn_qdn"][(a[1], b[1])] = _poly_dict(c, gens)
        elif pair in (("qd", "d"),):
            rho["qd"] += c
        elif pair in (("S", "d"),):
            rho["S"] += c
        elif pair == ("e", "d"):
            rho_edge[a[1]] += c
        elif pair in (("qd", "sigma"), ("e", "sigma"), ("S", "sigma")):
            sig_terms[(a, b)] = c
        else:
            raise DerivationError(
                f"expected V_i' to be expressible in zeta = (q', s) and the switching terms; "
                f"received the term {c} * {a} * {b}"
            )
    for name, lst, target in (
        ("q_i'^T e_ij", edge_qd, "qd_S"),
        ("e_ij^T s_i", edge_S, "S_S"),
    ):
        vals = {sp.expand(x) for x in lst[1:]}
        if len(vals) > 1:
            raise DerivationError(
                f"expected the coefficient of {name} in V_i' to be equal for all neighbours "
                f"(so it sums to s_i); received {sorted(map(str, vals))}"
            )
        if vals:
            out[target] = _merge(out[target], _poly_dict(vals.pop(), gens))
    # edge l against neighbour rate k: c_diag on l == k, c_off on l != k, so that
    # sum_{l,k} c e_l^T qdn_k = c_off s_i^T sum_k qdn_k + (c_diag - c_off) sum_k e_k^T qdn_k
    diag = {sp.expand(edge_qdn.get((k, k), 0)) for k in range(1, m + 1)}
    offkeys = [key for key in edge_qdn if key[0] != key[1]]
    off = {sp.expand(edge_qdn[key]) for key in offkeys}
    if m > 1 and len(offkeys) < m * (m - 1):  # some (l, k) pairs are absent: coefficient 0
        off.add(sp.Integer(0))
    if len(diag) > 1 or len(off) > 1:
        raise DerivationError(
            "expected the coefficient of e_il^T q_k' in V_i' to depend only on whether l == k "
            f"(so it sums into s); received {sorted(map(str, diag | off))}"
        )
    out["c_diag"] = diag.pop() if diag else sp.Integer(0)
    out["c_off"] = off.pop() if off else None  # undetermined for m == 1 (s_i = e_1)
    vals = {sp.expand(x) for x in rho_edge[1:]}
    if len(vals) > 1:
        raise DerivationError("expected the disturbance coefficient of every edge to be equal")
    rho_s = sp.expand(rho["S"] + (vals.pop() if vals else 0))
    out["rho"] = (sp.expand(rho["qd"]), rho_s)
    return out


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = out.get(k, Fraction(0)) + v
    return {k: v for k, v in out.items() if v != 0}


def derive_conditions(graph: Any, spec: SpecLike = None, *, structured: bool = True) -> LyapunovConditions:
    """Derive ``Theta_i`` (every spacecraft) and ``Pi`` for a graph.

    Parameters
    ----------
    graph : Graph or anything :func:`~.graphs.make_graph` accepts
    spec : Spec, path or None
        Controller + Lyapunov candidate (default: the paper's).
    structured : bool
        Assemble ``Pi`` by sparse algebra on the adjacency when the local
        coefficients allow it (default); ``False`` forces the entry-by-entry
        assembly (a second implementation, for cross-checks).

    Returns
    -------
    LyapunovConditions

    Examples
    --------
    >>> c = derive_conditions("ring:4")
    >>> c.pi.evaluate((2, 1, 0.5))[:4, :4].tolist()[0]
    [1.0, 0.5, 0.0, 0.5]
    >>> [t.size for t in c.theta]
    [3, 3, 3, 3]
    """
    from formsync_design.spec.loader import agent_design_of

    agent = agent_design_of(spec)
    if agent is not None:  # an agent design: its conditions(c) families on the graph
        from formsync_design.derive.agent import agent_conditions

        return agent_conditions(agent, graph)  # type: ignore[return-value]
    g = make_graph(graph)
    return _conditions_cached(g, spec_cache_key(resolve_spec(spec)), bool(structured))


def paper_conditions(graph: Any, printed: Any = None) -> LyapunovConditions:
    """``Theta_i`` and ``Pi`` exactly as printed in the paper (eqs. after (4), (10)).

    The printed expressions are paper data, kept in
    ``derivations/liang2016_printed.py`` (``printed_theta``, ``printed_M``,
    ``printed_N``) and evaluated here; ``printed`` names another such file
    (a path) or module.

    Examples
    --------
    >>> p = paper_conditions("ring:4")
    >>> p.pi.evaluate((2, 1, 0.5))[:4, :4].tolist()[0]
    [1.5, 0.25, 0.0, 0.25]
    """
    from formsync_design.derive.printed import load_printed

    return _paper_cached(make_graph(graph), load_printed(printed))


@lru_cache(maxsize=16)
def _paper_cached(g: Graph, pr: Any) -> LyapunovConditions:
    gens = gain_symbols()
    n = g.n
    bases = {m: family_from_entries("Theta", m + 1, _theta_entries(pr.printed_theta(m, *gens), gens))
             for m in sorted(set(g.degrees))}
    thetas = tuple(_theta_for(bases[g.degrees[i]], i, g) for i in range(n))
    M = pr.printed_M(g.adjacency, *gens)
    N = pr.printed_N(n, *gens)
    entries: dict = {}
    for i in range(n):
        for j in range(n):
            if M[i][j] != 0:
                _acc(entries, i, j, _poly_dict(M[i][j], gens))
            if N[i][j] != 0:
                _acc(entries, n + i, n + j, _poly_dict(N[i][j], gens))
    pi = family_from_entries("Pi", 2 * n, entries, row_labels=zeta_labels(n))
    return LyapunovConditions(
        graph=g, source="paper", spec_name="liang2016 (printed)", gains=GAIN_NAMES,
        theta=thetas, pi=pi,
    )


# ---------------------------------------------------------------------------
# brute force cross-check
# ---------------------------------------------------------------------------
def brute_force_vdot(graph: Any, spec: SpecLike = None) -> tuple[sp.Expr, sp.Expr]:
    """Full symbolic ``V'`` of a (small) graph, and the assembled form.

    Builds ``V = sum_i V_i`` in all ``3n`` attitudes and rates, differentiates
    along the closed loop ``q_i'' = c_qd q_i' + c_s s_i + c_sigma sigma_i + d_i``,
    and returns ``(brute, assembled)`` where ``assembled = -zeta^T (Pi (x) I3)
    zeta + sum_i rho_i^T (c_sigma sigma_i + d_i)``; the two must agree
    identically.

    Examples
    --------
    >>> b, a = brute_force_vdot("path:3")
    >>> sp.expand(b - a)
    0
    """
    g = make_graph(graph)
    spec = resolve_spec(spec)
    cl = derive_closed_loop(spec)
    conds = derive_conditions(g, spec)
    n = g.n
    q = [sp.Matrix(sp.symbols(f"q{i}_x q{i}_y q{i}_z", real=True)) for i in range(1, n + 1)]
    qd = [sp.Matrix(sp.symbols(f"qd{i}_x qd{i}_y qd{i}_z", real=True)) for i in range(1, n + 1)]
    sig = [sp.Matrix(sp.symbols(f"sig{i}_x sig{i}_y sig{i}_z", real=True)) for i in range(1, n + 1)]
    dd = [sp.Matrix(sp.symbols(f"d{i}_x d{i}_y d{i}_z", real=True)) for i in range(1, n + 1)]
    V = sp.Integer(0)
    for i in range(n):
        nb = g.neighbors(i)
        lv = LyapunovView(len(nb), spec.decl)
        Vi = sp.sympify(spec.lyapunov(lv))
        sub = {}
        for ax in range(3):
            sub[lv.qd[ax]] = qd[i][ax]
            for k, j in enumerate(nb):
                sub[lv.edges[k][ax]] = q[i][ax] - q[j][ax]
        V += Vi.xreplace(sub)
    s = [sum((q[i] - q[j] for j in g.neighbors(i)), sp.zeros(3, 1)) for i in range(n)]
    acc = [cl.c_qd * qd[i] + cl.c_s * s[i] + cl.c_sigma * sig[i] + dd[i] for i in range(n)]
    V = sp.expand(V)
    brute = sp.Integer(0)
    for i in range(n):
        for ax in range(3):
            brute += sp.diff(V, q[i][ax]) * qd[i][ax] + sp.diff(V, qd[i][ax]) * acc[i][ax]
    brute = sp.expand(brute)
    P = conds.pi.to_sympy(gain_symbols(spec))
    assembled = sp.Integer(0)
    zeta = [*qd, *s]
    for ax in range(3):
        z = sp.Matrix([v[ax] for v in zeta])
        assembled -= (z.T * P * z)[0, 0]
    assert conds.rho is not None  # always set on derived conditions
    rq, rs = conds.rho
    for i in range(n):
        rho = rq * qd[i] + rs * s[i]
        assembled += (rho.T * (cl.c_sigma * sig[i] + dd[i]))[0, 0]
    return brute, sp.expand(assembled)
