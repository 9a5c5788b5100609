"""Stage 1 of the derivation: the closed loop of one spacecraft, and the
specification resolution shared by every derivation cache.

Every cache of the derivation stage is keyed by :func:`spec_cache_key` (the
specification's *content* digest ``Spec.key``), never by a file path, so a
variant controller can never be served the paper's derivation.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.spec.declarations import CLASSIC, DERIVABLE, Declarations, GainKind, GainRole
from formsync_design.spec.lagrangian_view import ControllerView
from formsync_design.spec.loader import Spec, controller_expression, load_spec

__all__ = ["ClosedLoop", "SpecLike", "derive_closed_loop", "resolve_spec", "spec_cache_key", "registered_spec",
           "require_derivable"]

SpecLike = Spec | str | Path | None

#: Specifications seen by the derivation caches, by content key.
_SPECS: dict[str, Spec] = {}


@cache
def _default_spec() -> Spec:
    return load_spec(None)


def spec_cache_key(spec: Spec) -> str:
    """The key every derivation cache uses for ``spec``: its content digest.

    Examples
    --------
    >>> k = spec_cache_key(resolve_spec(None))
    >>> k == spec_cache_key(resolve_spec(None))
    True
    """
    key = getattr(spec, "key", "")
    if key:  # the content digest (the name is part of it: it labels the results)
        return f"{key}:{spec.name}"
    # a Spec built without a key: identity of its functions (never shared by accident)
    return f"{spec.name}:{spec.path}:{id(spec.controller)}:{id(spec.lyapunov)}"


def resolve_spec(spec: SpecLike = None) -> Spec:
    """A :class:`~formsync_design.spec.loader.Spec` for ``spec`` (``None``: the paper's,
    loaded once; a path: loaded; a ``Spec``: unchanged), registered for the caches.

    Examples
    --------
    >>> resolve_spec(None).name
    'liang2016'
    """
    if isinstance(spec, Spec):
        s = spec
    elif spec is None:
        s = _default_spec()
    else:
        s = load_spec(spec)
    _SPECS.setdefault(spec_cache_key(s), s)
    return s


def registered_spec(key: str) -> Spec:
    """The specification registered under ``key`` by :func:`resolve_spec`."""
    return _SPECS[key]


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
    decl: Declarations = CLASSIC

    def switch_argument_explicit(self, qd: sp.Matrix, s: sp.Matrix) -> sp.Matrix | None:
        """The switching argument with explicit vectors substituted."""
        if self.switch_argument is None:
            return None
        v = ControllerView(self.decl)
        sub: dict[Any, Any] = {v.qd: qd, v.s: s}
        for g in self.decl.gains:  # a diagonal gain acts per axis through its entry
            if g.kind == GainKind.DIAG and g.role != GainRole.MULTIPLIER:
                sub[g.matrix] = g.symbol * sp.eye(3)
        return sp.Matrix(self.switch_argument.xreplace(sub).doit()).applyfunc(sp.expand)



@cache
def _closed_loop_cached(key: str) -> ClosedLoop:
    return _derive_closed_loop(registered_spec(key))


def derive_closed_loop(spec: SpecLike = None) -> ClosedLoop:
    """Substitute the controller into the Lagrangian model and simplify.

    Parameters
    ----------
    spec : Spec, path or None
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
    return _closed_loop_cached(spec_cache_key(resolve_spec(spec)))


def require_derivable(spec: Spec, stage: str = "the derivation") -> None:
    """Refuse a design whose representation ``stage`` does not support (one line, exit 2).

    >>> require_derivable(resolve_spec(None))
    """
    rep = spec.decl.representation
    if rep not in DERIVABLE:
        raise DerivationError(
            f"{spec.path}: REPRESENTATION: expected one of {list(DERIVABLE)} for {stage} "
            f"(the quaternion-vector Lagrangian form), received {rep!r} (its model is in "
            "formsync_design.models, the Lyapunov derivation for it is not)"
        )


def _derive_closed_loop(spec: Spec) -> ClosedLoop:
    require_derivable(spec)
    v, u = controller_expression(spec)
    ud = sp.MatrixSymbol("u_d", 3, 1)
    qdd = (v.A.I * (v.Q.T * (u + ud) - v.B * v.qd)).expand().doit()
    dist = (v.A.I * v.Q.T * ud).doit()
    coeffs = {"qd": sp.Integer(0), "s": sp.Integer(0), "sigma": sp.Integer(0)}
    dist_seen = False
    diag = {g.matrix: g.symbol for g in spec.decl.gains
            if g.kind == GainKind.DIAG and g.role != GainRole.MULTIPLIER}
    for term in sp.MatAdd.make_args(qdd):
        c, rest = term.as_coeff_mmul()
        if isinstance(rest, sp.MatMul) and len(rest.args) == 1:
            rest = rest.args[0]
        # diagonal gains applied after the cancellation act per axis: K q' -> k q'_axis
        while isinstance(rest, sp.MatMul) and rest.args and rest.args[0] in diag:
            c = c * diag[rest.args[0]]
            tail = rest.args[1:]
            rest = tail[0] if len(tail) == 1 else sp.MatMul(*tail)
        for key, vec in (("qd", v.qd), ("s", v.s), ("sigma", v.sigma)):
            if rest == vec:
                coeffs[key] += c
                break
        else:
            if rest == dist and c == 1:
                dist_seen = True
                continue
            hint = (" (a diagonal gain must act after the model cancellation, e.g. A*K*qd, "
                    "not K*A*qd)" if set(diag) & term.free_symbols else "")
            raise DerivationError(
                "expected the controller to cancel the model so that q'' = c1 q' + c2 s + "
                f"c3 sigma + A^-1 Q^T u_d with scalar c_k; received the term {term}{hint}"
            )
    if not dist_seen:
        raise DerivationError("expected the disturbance term A^-1 Q^T u_d in q''; it cancelled")
    scalars = {g.symbol for g in spec.decl.gains if g.role != GainRole.MULTIPLIER}
    for k, c in coeffs.items():
        if c.free_symbols - scalars:
            raise DerivationError(
                f"expected a coefficient in the gains for {k}, received {c} (a diagonal gain "
                "must act after the model cancellation, e.g. A*K*qd, not K*A*qd)"
            )
    arg = v.switch_arguments[0] if v.switch_arguments else None
    return ClosedLoop(
        spec_name=spec.name,
        control=u,
        acceleration=qdd,
        c_qd=sp.expand(coeffs["qd"]),
        c_s=sp.expand(coeffs["s"]),
        c_sigma=sp.expand(coeffs["sigma"]),
        switch_argument=arg,
        decl=spec.decl,
    )
