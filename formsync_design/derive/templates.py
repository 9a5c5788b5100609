"""Stage 2 of the derivation: the local template of a spacecraft with ``m``
neighbours (``Theta`` and ``V_i'`` as a bilinear form in local slots)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import sympy as sp

from formsync_design.derive.closed_loop import (
    SpecLike,
    derive_closed_loop,
    registered_spec,
    resolve_spec,
    spec_cache_key,
)
from formsync_design.errors import DerivationError, InputError
from formsync_design.spec.lagrangian_view import LyapunovView

__all__ = ["LocalTemplate", "derive_local_template", "template_cached", "SLOT_QD", "SLOT_S",
           "SLOT_SIGMA", "SLOT_D"]

# slot names of the local bilinear forms
SLOT_QD = ("qd",)
SLOT_S = ("S",)
SLOT_SIGMA = ("sigma",)
SLOT_D = ("d",)
_QD, _S, _SIG, _D = SLOT_QD, SLOT_S, SLOT_SIGMA, SLOT_D


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
def template_cached(key: str, m: int) -> LocalTemplate:
    """The local template of the specification registered under ``key`` (see
    :func:`~.closed_loop.spec_cache_key`) for ``m`` neighbours, derived once."""
    spec = registered_spec(key)
    cl = derive_closed_loop(spec)
    lv = LyapunovView(m, spec.decl)
    V = spec.lyapunov(lv)
    V = sp.sympify(V)
    extra = V.free_symbols - lv.symbols()
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


def derive_local_template(m: int, spec: SpecLike = None) -> LocalTemplate:
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
    return template_cached(spec_cache_key(resolve_spec(spec)), m)
