"""The derivation engine: closed loop, Lyapunov derivative, Theta_i and Pi.

Pipeline (paper section 2, for any specification, see :mod:`.spec`):

1. :func:`derive_closed_loop` substitutes the controller ``u_i`` into the
   Lagrangian model ``A q'' + B q' = Q^T u + Q^T u_d`` with ``A``, ``B``,
   ``Q`` kept as opaque invertible matrices, and reads off
   ``q_i'' = c_qd q_i' + c_s s_i + c_sigma sigma_i + A^{-1} Q^T u_d``.
   A controller that does not cancel the dynamics this way is rejected.
2. For each neighbour count ``m`` a *local template* is derived once: the
   Hessian of ``V_i`` over ``chi_i = (q_i', q_i - q_j ...)`` gives ``Theta_i``;
   ``V_i'`` along the closed loop is a bilinear form in the local slots
   ``q_i'``, neighbour rates ``q_j'``, edges ``e_ij``, ``s_i``, ``sigma_i``
   and the disturbance ``d_i = A_i^{-1}Q_i^T u_di``.
3. :func:`derive_conditions` assembles the templates by graph into
   ``V' = -zeta^T (Pi (x) I3) zeta + sum_i rho_i^T (c_sigma sigma_i + d_i)``,
   ``zeta = (q_1'..q_n', s_1..s_n)`` (paper eq. 9), using the undirected-graph
   identity ``sum_i sum_{j in G_i} c e_ij^T q_j' = -c sum_j q_j'^T s_j``.
   :func:`brute_force_vdot` re-derives ``V'`` for a whole small graph by
   full symbolic expansion, to cross-check the assembly.

The three axes decouple (checked: the forms are ``F (x) I3``), so every
matrix is stored per axis as a :class:`~.families.MatrixFamily`.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cache, lru_cache
from itertools import product
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.derive.families import GAIN_NAMES, MatrixFamily, family_from_entries
from formsync_design.errors import DerivationError, InputError
from formsync_design.graphs.build import Graph, make_graph
from formsync_design.spec.loader import ControllerView, LyapunovView, Spec, gain_symbols, load_spec

__all__ = [
    "ClosedLoop",
    "LocalTemplate",
    "LyapunovConditions",
    "ClosedFormCondition",
    "derive_closed_loop",
    "derive_local_template",
    "derive_conditions",
    "paper_conditions",
    "closed_form_conditions",
    "brute_force_vdot",
    "zeta_labels",
    "required_kv",
    "kv_condition_holds",
]


# ---------------------------------------------------------------------------
# 1. closed loop
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ClosedLoop:
    """Closed loop of one spacecraft under a specification's controller.

    ``q_i'' = c_qd * q_i' + c_s * s_i + c_sigma * sigma_i + A_i^{-1} Q_i^T u_di``
    with ``sigma_i = sw(switch_argument)``.

    Attributes
    ----------
    spec_name : str
    control : sympy matrix expression
        ``u_i`` in the opaque ``A, B, Q, qd, s, sigma`` (3x1).
    acceleration : sympy matrix expression
        ``q_i''`` after cancellation.
    c_qd, c_s, c_sigma : sympy.Expr
        Scalar coefficients (gains).
    switch_argument : sympy matrix expression or None
        The argument of ``sw`` in the controller (``None`` if it has none).
    """

    spec_name: str
    control: Any
    acceleration: Any
    c_qd: sp.Expr
    c_s: sp.Expr
    c_sigma: sp.Expr
    switch_argument: Any

    def switch_argument_explicit(self, qd: sp.Matrix, s: sp.Matrix) -> sp.Matrix | None:
        """The switching argument with explicit vectors substituted."""
        if self.switch_argument is None:
            return None
        v = ControllerView()
        return sp.Matrix(self.switch_argument.xreplace({v.qd: qd, v.s: s}).doit()).applyfunc(
            sp.expand
        )


@cache
def _closed_loop_cached(spec_path: str) -> ClosedLoop:
    return _derive_closed_loop(load_spec(spec_path))


def derive_closed_loop(spec: Spec | None = None) -> ClosedLoop:
    """Substitute the controller into the Lagrangian model and simplify.

    Parameters
    ----------
    spec : Spec, optional
        Default: the paper's specification.

    Returns
    -------
    ClosedLoop

    Raises
    ------
    DerivationError
        If ``q''`` is not of the form above (the controller does not cancel
        ``A`` and ``B``, or its gains are not scalars).

    Examples
    --------
    >>> cl = derive_closed_loop()
    >>> cl.c_qd, cl.c_s, cl.c_sigma
    (-K_o, -K_q, -K_v)
    """
    if spec is None:
        return _closed_loop_cached(str(load_spec().path))
    return _closed_loop_cached(str(spec.path))


def _derive_closed_loop(spec: Spec) -> ClosedLoop:
    v = ControllerView()
    u = spec.controller(v)
    if getattr(u, "shape", None) != (3, 1):
        raise DerivationError(
            f"expected controller() to return a 3x1 matrix expression, received shape "
            f"{getattr(u, 'shape', None)}"
        )
    ud = sp.MatrixSymbol("u_d", 3, 1)
    qdd = (v.A.I * (v.Q.T * (u + ud) - v.B * v.qd)).expand().doit()
    dist = (v.A.I * v.Q.T * ud).doit()
    coeffs = {"qd": sp.Integer(0), "s": sp.Integer(0), "sigma": sp.Integer(0)}
    dist_seen = False
    for term in sp.MatAdd.make_args(qdd):
        c, rest = term.as_coeff_mmul()
        if isinstance(rest, sp.MatMul) and len(rest.args) == 1:
            rest = rest.args[0]
        for key, vec in (("qd", v.qd), ("s", v.s), ("sigma", v.sigma)):
            if rest == vec:
                coeffs[key] += c
                break
        else:
            if rest == dist and c == 1:
                dist_seen = True
                continue
            raise DerivationError(
                "expected the controller to cancel the model so that q'' = c1 q' + c2 s + "
                f"c3 sigma + A^-1 Q^T u_d with scalar c_k; received the term {term}"
            )
    if not dist_seen:
        raise DerivationError("expected the disturbance term A^-1 Q^T u_d in q''; it cancelled")
    for k, c in coeffs.items():
        if c.free_symbols - {v.K_o, v.K_q, v.beta, v.K_v}:
            raise DerivationError(f"expected a gain coefficient for {k}, received {c}")
    arg = v.switch_arguments[0] if v.switch_arguments else None
    return ClosedLoop(
        spec_name=spec.name,
        control=u,
        acceleration=qdd,
        c_qd=sp.expand(coeffs["qd"]),
        c_s=sp.expand(coeffs["s"]),
        c_sigma=sp.expand(coeffs["sigma"]),
        switch_argument=arg,
    )


# ---------------------------------------------------------------------------
# 2. local templates (one per neighbour count m)
# ---------------------------------------------------------------------------
# slot names of the local bilinear forms
_QD = ("qd",)
_S = ("S",)
_SIG = ("sigma",)
_D = ("d",)


def _e(k: int) -> tuple[str, int]:
    return ("e", k)


def _n(k: int) -> tuple[str, int]:
    return ("qdn", k)


def _add(form: dict, a: Any, b: Any, c: sp.Expr) -> None:
    key = (a, b) if _slot_order(a) <= _slot_order(b) else (b, a)
    form[key] = form.get(key, 0) + c


def _slot_order(s: Any) -> tuple:
    rank = {"qd": 0, "qdn": 1, "e": 2, "S": 3, "sigma": 4, "d": 5}
    return (rank[s[0]], s[1] if len(s) > 1 else -1)


@dataclass(frozen=True)
class LocalTemplate:
    """Per-spacecraft structure for a spacecraft with ``m`` neighbours.

    Attributes
    ----------
    m : int
    theta : sympy.Matrix
        Per-axis ``Theta`` ((m+1) x (m+1)), ``V_i = chi^T (Theta (x) I3) chi``.
    vdot : dict
        ``V_i'`` per axis as a bilinear form ``{(slot_a, slot_b): coeff}`` over
        the slots ``qd``, ``(qdn, k)``, ``(e, k)``, ``S``, ``sigma``, ``d``
        (``k = 1..m``); a pair ``(a, a)`` means ``a*a``.
    """

    m: int
    theta: sp.Matrix
    vdot: dict


def _quadratic_form_per_axis(expr: sp.Expr, slots: list[sp.Matrix], what: str) -> sp.Matrix:
    """Per-axis symmetric matrix H with expr = sum_axis x_axis^T H x_axis.

    Checks that expr is a homogeneous quadratic form and isotropic
    (identical on the three axes, no cross-axis terms).
    """
    ns = len(slots)
    sym_index = {}
    for a, vec in enumerate(slots):
        for ax in range(3):
            sym_index[vec[ax]] = (a, ax)
    H: dict[tuple[int, int, int], sp.Expr] = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        if term == 0:
            continue
        coeff: sp.Expr = sp.Integer(1)
        idx: list[sp.Symbol] = []
        for f in sp.Mul.make_args(term):
            base, e = f.as_base_exp()
            if base in sym_index and e.is_Integer and e > 0:
                idx.extend([base] * int(e))
            else:
                coeff *= f
        if coeff.free_symbols & set(sym_index):
            raise DerivationError(f"expected {what} to be polynomial in its vectors, received {term}")
        if len(idx) != 2:
            raise DerivationError(
                f"expected {what} to be a homogeneous quadratic form, received a term of degree "
                f"{len(idx)}: {term}"
            )
        (a, ax), (b, bx) = sym_index[idx[0]], sym_index[idx[1]]
        if ax != bx:
            raise DerivationError(
                f"expected {what} to treat the x, y, z axes identically (no cross-axis terms), "
                f"received the term {term}"
            )
        a, b = min(a, b), max(a, b)
        H[(a, b, ax)] = H.get((a, b, ax), 0) + coeff
    out = sp.zeros(ns, ns)
    for a, b in sorted({(a, b) for a, b, _ in H}):
        vals = [sp.expand(H.get((a, b, ax), 0)) for ax in range(3)]
        if not (vals[0] == vals[1] == vals[2]):
            raise DerivationError(
                f"expected {what} to be identical on the three axes, received {vals}"
            )
        if a == b:
            out[a, a] = vals[0]
        else:
            out[a, b] = out[b, a] = vals[0] / 2
    return out


@cache
def _template_cached(spec_path: str, m: int) -> LocalTemplate:
    spec = load_spec(spec_path)
    cl = derive_closed_loop(spec)
    lv = LyapunovView(m)
    V = spec.lyapunov(lv)
    V = sp.sympify(V)
    allowed = set(lv.qd) | {x for e in lv.edges for x in e} | {lv.K_o, lv.K_q, lv.beta}
    extra = V.free_symbols - allowed
    if extra:
        raise DerivationError(
            "expected V_i in q_i', the edges q_i - q_j and the gains only, received "
            f"other symbols {sorted(map(str, extra))}"
        )
    theta = _quadratic_form_per_axis(V, [lv.qd, *lv.edges], "V_i")
    # gradient per axis: dV/dx_a = 2 * sum_b theta[a, b] x_b
    slots = [_QD] + [_e(k) for k in range(1, m + 1)]
    grad: dict = {a: {} for a in slots}
    for (ia, ib), val in theta.todok().items():
        if val != 0:
            grad[slots[ia]][slots[ib]] = 2 * val
    # q'' = c_qd qd + c_s S + c_sigma sigma + d ; e_k' = qd - qdn_k
    acc = {_QD: cl.c_qd, _S: cl.c_s, _SIG: cl.c_sigma, _D: sp.Integer(1)}
    form: dict = {}
    for b, cb in grad[_QD].items():
        for a, ca in acc.items():
            if ca != 0:
                _add(form, b, a, cb * ca)
    for k in range(1, m + 1):
        for b, cb in grad[_e(k)].items():
            _add(form, b, _QD, cb)
            _add(form, b, _n(k), -cb)
    form = {k: sp.expand(v) for k, v in form.items() if sp.expand(v) != 0}
    return LocalTemplate(m=m, theta=theta, vdot=form)


def derive_local_template(m: int, spec: Spec | None = None) -> LocalTemplate:
    """Derive ``Theta`` and the local ``V_i'`` form for ``m`` neighbours.

    Examples
    --------
    >>> t = derive_local_template(2)
    >>> t.theta
    Matrix([
    [   1/2,             beta/2,             beta/2],
    [beta/2, K_o*beta/4 + K_q/4,                  0],
    [beta/2,                  0, K_o*beta/4 + K_q/4]])
    """
    if not isinstance(m, int) or m < 1:
        raise InputError(f"expected a neighbour count m >= 1, received {m!r}")
    path = str((spec or load_spec()).path)
    return _template_cached(path, m)


# ---------------------------------------------------------------------------
# 3. assembly by graph
# ---------------------------------------------------------------------------
def _poly_dict(expr: sp.Expr, gens: tuple[sp.Symbol, ...]) -> dict[tuple[int, ...], Fraction]:
    expr = sp.expand(expr)
    if expr == 0:
        return {}
    if expr.free_symbols - set(gens):
        raise DerivationError(
            f"expected a polynomial in the gains {GAIN_NAMES}, received {expr}"
        )
    out = {}
    for mono, c in sp.Poly(expr, *gens).terms():
        if not c.is_Rational:
            raise DerivationError(f"expected rational coefficients, received {c} in {expr}")
        out[tuple(int(x) for x in mono)] = Fraction(int(c.p), int(c.q))
    return out


def _acc(entries: dict, i: int, j: int, pd: dict, scale: Fraction = Fraction(1)) -> None:
    cell = entries.setdefault((i, j), {})
    for mono, c in pd.items():
        cell[mono] = cell.get(mono, Fraction(0)) + c * scale


def zeta_labels(n: int) -> tuple[str, ...]:
    """Row labels of ``Pi`` in the paper's eq. (9) order (1-based spacecraft)."""
    return tuple(f"qdot_{i}" for i in range(1, n + 1)) + tuple(f"s_{i}" for i in range(1, n + 1))


@dataclass(frozen=True)
class LyapunovConditions:
    """``Theta_i`` and ``Pi`` of a graph, ready for certification.

    Attributes
    ----------
    graph : Graph
    source : str
        ``"derived"`` (from the derivation) or ``"paper"`` (as printed).
    spec_name : str
    gains : tuple of str
        ``("K_o", "K_q", "beta")``.
    theta : tuple of MatrixFamily
        ``theta[i]`` is ``Theta`` of spacecraft ``i+1`` (per axis, size ``m_i + 1``,
        rows ``(qdot_i, e_i,j ...)``).
    pi : MatrixFamily
        Per-axis ``Pi`` (size ``2n``), rows ``zeta_labels(n)``.
    switching_matches : bool or None
        Whether the switching term's argument equals ``rho_i`` (the
        coefficient of the disturbance in ``V'``); needed for the ``K_vi``
        argument.  ``None`` for printed conditions.
    rho : tuple of (sympy.Expr, sympy.Expr)
        ``rho_i = rho_qd * q_i' + rho_s * s_i`` (coefficients), derived only.
    """

    graph: Graph
    source: str
    spec_name: str
    gains: tuple[str, ...]
    theta: tuple[MatrixFamily, ...]
    pi: MatrixFamily
    switching_matches: bool | None = None
    rho: tuple[Any, Any] | None = None

    @property
    def families(self) -> tuple[MatrixFamily, ...]:
        """``theta + (pi,)``."""
        return (*self.theta, self.pi)

    @property
    def zeta_order(self) -> tuple[str, ...]:
        return zeta_labels(self.graph.n)


def _theta_family(theta: sp.Matrix, i: int, graph: Graph, gens: tuple) -> MatrixFamily:
    m = theta.shape[0] - 1
    entries: dict = {}
    for (a, b), val in theta.todok().items():
        if val != 0:
            _acc(entries, a, b, _poly_dict(val, gens))
    nb = graph.neighbors(i)
    labels = (f"qdot_{i + 1}",) + tuple(f"q_{i + 1}-q_{j + 1}" for j in nb)
    return family_from_entries(
        f"Theta_{i + 1}", m + 1, entries, row_labels=labels, spacecraft=i + 1
    )


@lru_cache(maxsize=64)
def _conditions_cached(graph: Graph, spec_path: str) -> LyapunovConditions:
    spec = load_spec(spec_path)
    gens = gain_symbols()
    n = graph.n
    degrees = sorted(set(graph.degrees))
    templates = {m: _template_cached(spec_path, m) for m in degrees}
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
    pi = family_from_entries("Pi", 2 * n, entries, row_labels=zeta_labels(n))
    theta_by_degree: dict[int, sp.Matrix] = {m: templates[m].theta for m in degrees}
    thetas = tuple(_theta_family(theta_by_degree[graph.degrees[i]], i, graph, gens)
                   for i in range(n))
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
        graph=graph, source="derived", spec_name=spec.name, gains=GAIN_NAMES,
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
    off = {sp.expand(edge_qdn.get((r, k), 0)) for r in range(1, m + 1)
           for k in range(1, m + 1) if r != k}
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


def derive_conditions(graph: Any, spec: Spec | None = None) -> LyapunovConditions:
    """Derive ``Theta_i`` (every spacecraft) and ``Pi`` for a graph.

    Parameters
    ----------
    graph : Graph or anything :func:`~.graphs.make_graph` accepts
    spec : Spec, optional
        Controller + Lyapunov candidate (default: the paper's).

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
    g = make_graph(graph)
    path = str((spec or load_spec()).path)
    return _conditions_cached(g, path)


def paper_conditions(graph: Any) -> LyapunovConditions:
    """``Theta_i`` and ``Pi`` exactly as printed in the paper (eqs. after (4), (10)).

    The printed expressions are paper data, kept in ``derivations/liang2016.py``
    (``printed_theta``, ``printed_M``, ``printed_N``) and evaluated here.

    Examples
    --------
    >>> p = paper_conditions("ring:4")
    >>> p.pi.evaluate((2, 1, 0.5))[:4, :4].tolist()[0]
    [1.5, 0.25, 0.0, 0.25]
    """
    from formsync_design.derive.printed import load_printed

    pr = load_printed()
    g = make_graph(graph)
    gens = gain_symbols()
    n = g.n
    thetas = tuple(
        _theta_family(pr.printed_theta(g.degrees[i], *gens), i, g, gens) for i in range(n)
    )
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
def brute_force_vdot(graph: Any, spec: Spec | None = None) -> tuple[sp.Expr, sp.Expr]:
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
    spec = spec or load_spec()
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
        lv = LyapunovView(len(nb))
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
    P = conds.pi.to_sympy(gain_symbols())
    assembled = sp.Integer(0)
    zeta = [*qd, *s]
    for ax in range(3):
        z = sp.Matrix([v[ax] for v in zeta])
        assembled -= (z.T * P * z)[0, 0]
    rq, rs = conds.rho
    for i in range(n):
        rho = rq * qd[i] + rs * s[i]
        assembled += (rho.T * (cl.c_sigma * sig[i] + dd[i]))[0, 0]
    return brute, sp.expand(assembled)


# ---------------------------------------------------------------------------
# closed-form conditions
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ClosedFormCondition:
    """A closed-form necessary-and-sufficient condition ``expression > 0``.

    Attributes
    ----------
    family : str
        ``"Theta(m)"`` or ``"Pi"`` block name.
    expression : sympy.Expr
        Polynomial in the gains (and possibly ``m``, ``lambda``) that must be > 0.
    constants : dict
        Graph constants substituted (e.g. ``{"lambda_max(L)": 4.0}``).
    how : str
        How it was obtained (Schur complement, pencil spectrum).
    """

    family: str
    expression: sp.Expr
    constants: dict
    how: str

    def holds(self, point: tuple[float, float, float]) -> bool:
        """Evaluate at ``(K_o, K_q, beta)`` in floating point."""
        ko, kq, b = gain_symbols()
        sub = {ko: point[0], kq: point[1], b: point[2]}
        sub.update({sp.Symbol(k): v for k, v in self.constants.items()})
        return float(self.expression.subs(sub)) > 0

    def substituted(self) -> sp.Expr:
        """The expression with the graph constants substituted (floating point)."""
        return self.expression.subs({sp.Symbol(k): v for k, v in self.constants.items()})


def closed_form_conditions(conds: LyapunovConditions) -> tuple[ClosedFormCondition, ...]:
    """Closed-form PD conditions where the structure allows them.

    ``Theta(m)``: when its edge block is ``c I_m`` and its coupling column is
    ``b 1``, Schur: ``Theta > 0  <=>  c > 0  and  c*Theta_00 - m b^2 > 0``.
    ``Pi``: block-diagonal with blocks in a pencil ``alpha I + gamma G``
    (``G`` the Laplacian or adjacency): PD iff ``alpha + gamma mu > 0`` at the
    extreme eigenvalues ``mu`` of ``G``.

    Examples
    --------
    >>> cf = closed_form_conditions(derive_conditions("ring:6"))
    >>> [str(c.expression) for c in cf if c.family.startswith("Theta")]
    ['K_o*beta/4 + K_q/4', 'K_o*beta/8 + K_q/8 - beta**2/2']
    """
    gens = gain_symbols()
    out: list[ClosedFormCondition] = []
    seen: set[int] = set()
    for fam in conds.theta:
        m = fam.size - 1
        if m in seen:
            continue
        seen.add(m)
        T = fam.to_sympy(gens)
        c = T[1, 1]
        b = T[0, 1]
        if T[1:, 1:] == c * sp.eye(m) and all(T[0, k] == b for k in range(1, m + 1)):
            out.append(ClosedFormCondition(f"Theta(m={m})", sp.expand(c), {}, "edge block c I_m"))
            out.append(ClosedFormCondition(
                f"Theta(m={m})", sp.expand(c * T[0, 0] - m * b**2), {},
                "Schur complement of the edge block c I_m",
            ))
    blocks = _pi_pencils(conds)
    for label, (alpha, gamma, gname, lo, hi) in blocks.items():
        for mu, which in ((lo, "min"), (hi, "max")):
            if gamma == 0 and which == "max":
                continue
            lam = sp.Symbol(f"lambda_{which}({gname})")
            expr = sp.expand(alpha + gamma * lam) if gamma != 0 else sp.expand(alpha)
            consts = {str(lam): mu} if gamma != 0 else {}
            how = (f"{label} = alpha I + gamma {gname}: eigenvalues alpha + gamma mu, "
                   f"extreme at lambda_min/lambda_max({gname})" if gamma != 0 else
                   f"{label} = alpha I")
            out.append(ClosedFormCondition(f"Pi[{label}]", expr, consts, how))
    # remove duplicates (gamma == 0 gives the same expression twice)
    uniq: list[ClosedFormCondition] = []
    for c in out:
        if not any(u.family == c.family and sp.expand(u.expression - c.expression) == 0 for u in uniq):
            uniq.append(c)
    return tuple(uniq)


def _pi_pencils(conds: LyapunovConditions) -> dict:
    """Decompose Pi's diagonal blocks as alpha I + gamma G when possible.

    Works term by term on the family (no dense symbolic matrix), so it scales
    to large graphs.  Returns ``{block: (alpha, gamma, G name, lambda_min(G),
    lambda_max(G))}``; empty when Pi has a cross block or a block outside
    such a pencil.
    """
    import scipy.sparse as sps

    g = conds.graph
    n = g.n
    gens = gain_symbols()
    cands = {"L": sps.csr_matrix(g.laplacian), "Adj": sps.csr_matrix(g.adjacency)}
    eye = sps.identity(n, dtype=np.int64, format="csr")
    out = {}
    for label, sl in (("M", slice(0, n)), ("N", slice(n, 2 * n))):
        chosen = None
        for gname, G in cands.items():
            alpha: sp.Expr = sp.Integer(0)
            gamma: sp.Expr = sp.Integer(0)
            ok = True
            for t in conds.pi.terms:
                full = sps.csr_matrix(t.matrix)
                if label == "M" and (full[:n, n:].count_nonzero() or full[n:, :n].count_nonzero()):
                    return {}
                blk = full[sl, sl]
                if blk.count_nonzero() == 0:
                    continue
                i, j = g.edges[0]
                b = Fraction(int(blk[i, j]), int(G[i, j])) if G[i, j] != 0 else Fraction(0)
                a = Fraction(int(blk[0, 0])) - b * int(G[0, 0])
                den = a.denominator * b.denominator
                resid = blk * den - eye * int(a * den) - G * int(b * den)
                if resid.count_nonzero() != 0:
                    ok = False
                    break
                mono = sp.Integer(1)
                for sym, e in zip(gens, t.exponents):
                    mono *= sym**e
                c = sp.Rational(t.coefficient.numerator, t.coefficient.denominator) * mono
                alpha += c * sp.Rational(a.numerator, a.denominator)
                gamma += c * sp.Rational(b.numerator, b.denominator)
            if ok:
                ev = np.linalg.eigvalsh(G.toarray().astype(float)) if n <= 1500 else None
                if ev is None:  # pragma: no cover - very large graphs
                    return {}
                # a connected graph's Laplacian has lambda_min = 0 exactly
                lo = 0.0 if gname == "L" else float(ev[0])
                chosen = (sp.expand(alpha), sp.expand(gamma), gname, lo, float(ev[-1]))
                break
        if chosen is None:
            return {}
        out[label] = chosen
    return out


# ---------------------------------------------------------------------------
# disturbance bound (K_vi condition)
# ---------------------------------------------------------------------------
def _check_inertia(J: Any) -> np.ndarray:
    Jm = np.asarray(J, dtype=float)
    if Jm.shape != (3, 3):
        raise InputError(f"expected a 3x3 inertia matrix, received shape {Jm.shape}")
    if not np.all(np.isfinite(Jm)):
        raise InputError("expected a finite inertia matrix, received NaN or inf")
    if not np.allclose(Jm, Jm.T, rtol=0, atol=1e-12 * max(1.0, np.abs(Jm).max())):
        raise InputError(f"expected a symmetric inertia matrix, received {Jm.tolist()}")
    if np.linalg.eigvalsh(Jm)[0] <= 0:
        raise InputError(
            f"expected a positive definite inertia, received eigenvalues {np.linalg.eigvalsh(Jm).tolist()}"
        )
    return Jm


def required_kv(J: Any, ubar: float) -> float:
    """Smallest ``K_vi`` with ``eps_i >= 0`` for every attitude and every
    disturbance with ``|u_d,k| <= ubar``.

    ``A^{-1} Q^T u_d = E J^{-1} u_d`` (``E = (q0 I + q^x)/2``); ``2E`` has
    singular values ``{1, 1, q0}`` and rotates a vector by at most 90 degrees,
    so ``sup_q ||E y||_inf = ||y||_2 / 2``; the convex ``||J^{-1}u||_2`` is
    maximal at a vertex of the disturbance box.  Hence
    ``K_vi* = (ubar/2) max_{v in {-1,1}^3} ||J^{-1} v||_2``.

    Examples
    --------
    >>> round(required_kv(50 * np.eye(3), 1.0), 6)
    0.017321
    """
    Jm = _check_inertia(J)
    if not (np.isfinite(ubar) and ubar > 0):
        raise InputError(f"expected a positive finite disturbance bound, received {ubar!r}")
    Ji = np.linalg.inv(Jm)
    best = max(float(np.linalg.norm(Ji @ np.array(v, dtype=float))) for v in product((-1, 1), repeat=3))
    return 0.5 * ubar * best


def kv_condition_holds(kv: Any, J: Any, ubar: Any) -> bool:
    """Exact check of ``K_vi >= K_vi*`` in rational arithmetic.

    Compares ``K_vi^2 >= (ubar^2/4) v^T J^{-2} v`` for all sign vectors ``v``
    with ``J``, ``ubar``, ``K_vi`` converted exactly to rationals.

    Examples
    --------
    >>> kv_condition_holds(0.01, 50 * np.eye(3), 0.5)
    True
    """
    Jm = _check_inertia(J)
    kv_f = Fraction(kv) if not isinstance(kv, float) else Fraction(kv)
    if kv_f <= 0:
        raise InputError(f"expected a positive K_vi, received {kv!r}")
    Jq = sp.Matrix(3, 3, [sp.Rational(Fraction(float(x))) for x in Jm.flatten()])
    Ji = Jq.inv()
    ub = sp.Rational(Fraction(ubar) if not isinstance(ubar, float) else Fraction(ubar))
    k = sp.Rational(kv_f)
    for v in product((-1, 1), repeat=3):
        w = Ji * sp.Matrix(v)
        if k**2 < ub**2 / 4 * (w.T * w)[0, 0]:
            return False
    return True
