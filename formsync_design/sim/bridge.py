"""The one numeric bridge from the symbolic derivation (SymPy) to CasADi.

Everything the simulator evaluates about the attitude model and the
controller goes through this module, so that there is exactly one source of
truth for the formulas: :func:`formsync_design.models.attitude.derive_attitude_model`
(``E``, ``Q``, ``A``, ``B`` as explicit SymPy matrices in ``q, q0, qd, J``)
and the controller specification (``derivations/liang2016.py``: a SymPy
*matrix expression* in the opaque ``MatrixSymbol`` s ``A, B, Q, qd, s,
sigma`` and scalar gains).  Nothing here re-types a model formula.

Two translators are provided:

* :func:`sympy_to_casadi` - explicit scalar expressions (``Add``, ``Mul``,
  ``Pow``, numbers, ``sin``/``cos``/``tanh``/``sign``/``sqrt``...) and
  ``sympy.Matrix`` of them, with memoisation on sub-expressions so shared
  sub-trees become shared CasADi nodes;
* :func:`matrix_expr_to_casadi` - matrix expressions (``MatrixSymbol``,
  ``MatAdd``, ``MatMul`` with scalar coefficients, ``Transpose``,
  ``Inverse``) evaluated on bound CasADi matrices.

``Q^{-1}`` in the controller
----------------------------
Controller (4) contains ``Q^{-T}``.  With ``inverse="E"`` (default) the
bridge maps ``Inverse(Q)`` to the model's ``E = (q0 I + q^x)/2`` and
``Inverse(Transpose(Q))`` to ``E^T``.  This is exact on the unit sphere
``q0^2 + |q|^2 = 1``: the model derivation checks symbolically that its
closed-form ``Q = 2(q0 I - q^x + q q^T/q0)`` equals ``E^{-1}`` modulo that
constraint.  Off the sphere (integration drift of the quaternion norm) the
two differ by ``O(| |q_bar|^2 - 1 |)``, which the simulator reports.  With
``inverse="solve"`` the bridge instead solves with the numeric ``Q``
(``casadi.solve``), which is exact for any state but costs more operations.

Named inputs and outputs
------------------------
:func:`model_function` returns a CasADi ``Function`` ``formsync_model`` with
inputs ``q`` (3x1), ``q0`` (1x1), ``qd`` (3x1), ``J`` (3x3 symmetric) and
outputs ``E``, ``Q``, ``A``, ``B`` (3x3).  :func:`controller_function`
returns ``formsync_controller`` with inputs ``q, q0, qd, J, s, K_o, K_q,
beta, K_v, phi`` and outputs ``u`` (body torque), ``tau`` (switching
argument) and ``sigma`` (switching term ``sw(tau)``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import sympy as sp

from formsync_design.errors import DerivationError, InputError
from formsync_design.models.attitude import AttitudeModel, derive_attitude_model
from formsync_design.spec.declarations import GainKind
from formsync_design.spec.loader import Spec, controller_expression, load_spec

__all__ = [
    "SWITCHES",
    "sympy_to_casadi",
    "matrix_expr_to_casadi",
    "switch_function",
    "model_function",
    "controller_function",
    "controller_gain_names",
    "ControllerBridge",
    "build_controller",
]

#: Switching-term substitutes for ``sgn`` (paper section 2.3, discussion 1).
SWITCHES = ("sgn", "sat", "tanh")

_UNARY = {
    sp.sin: ca.sin,
    sp.cos: ca.cos,
    sp.tan: ca.tan,
    sp.tanh: ca.tanh,
    sp.exp: ca.exp,
    sp.log: ca.log,
    sp.sign: ca.sign,
    sp.Abs: ca.fabs,
    sp.asin: ca.asin,
    sp.acos: ca.acos,
    sp.atan: ca.atan,
}


def sympy_to_casadi(expr: Any, bindings: Mapping[sp.Symbol, Any], _memo: dict | None = None) -> Any:
    """Translate an explicit SymPy expression (or ``Matrix``) to CasADi.

    Parameters
    ----------
    expr : sympy.Expr or sympy.MatrixBase
        Built from symbols, numbers, ``Add``, ``Mul``, ``Pow`` and the usual
        elementary functions.
    bindings : mapping
        ``Symbol -> casadi expression`` (``SX``/``MX``) or number, for every
        free symbol of ``expr``.

    Returns
    -------
    casadi.SX or casadi.MX (matching the bindings)

    Raises
    ------
    DerivationError
        An unbound symbol or an unsupported construct.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> X = ca.SX.sym("x")
    >>> f = ca.Function("f", [X], [sympy_to_casadi(2 * x**2 / (1 + x), {x: X})])
    >>> float(f(3.0))
    4.5
    """
    memo: dict = {} if _memo is None else _memo
    if isinstance(expr, sp.MatrixBase):
        rows = [
            ca.horzcat(*[sympy_to_casadi(expr[i, j], bindings, memo) for j in range(expr.cols)])
            for i in range(expr.rows)
        ]
        return ca.vertcat(*rows)
    return _scalar(sp.sympify(expr), bindings, memo)


def _scalar(e: sp.Expr, b: Mapping[sp.Symbol, Any], memo: dict) -> Any:
    hit = memo.get(e)
    if hit is not None:
        return hit
    if e.is_Symbol:
        if e not in b:
            raise DerivationError(f"expected a binding for symbol {e}, received none")
        out = b[e]
    elif e.is_Integer or e.is_Rational or e.is_Float:
        out = float(e)
    elif e is sp.pi:
        out = float(sp.pi)
    elif e.is_Add:
        terms = [_scalar(a, b, memo) for a in e.args]
        out = terms[0]
        for t in terms[1:]:
            out = out + t
    elif e.is_Mul:
        num: list[Any] = []
        den: list[Any] = []
        for a in e.args:
            if a.is_Pow and a.exp.is_Integer and a.exp < 0:
                den.append(_scalar(a.base ** (-a.exp), b, memo))
            else:
                num.append(_scalar(a, b, memo))
        out = num[0] if num else 1.0
        for t in num[1:]:
            out = out * t
        if den:
            d = den[0]
            for t in den[1:]:
                d = d * t
            out = out / d
    elif e.is_Pow:
        base = _scalar(e.base, b, memo)
        ex = e.exp
        if ex == sp.Rational(1, 2):
            out = ca.sqrt(base)
        elif ex.is_Integer:
            k = int(ex)
            if k == 0:
                out = 1.0
            elif k < 0:
                out = 1.0 / _ipow(base, -k)
            else:
                out = _ipow(base, k)
        else:
            out = base ** _scalar(ex, b, memo)
    elif isinstance(e, sp.Function) and e.func in _UNARY and len(e.args) == 1:
        out = _UNARY[e.func](_scalar(e.args[0], b, memo))
    elif e.func in (sp.Max, sp.Min):  # MinMaxBase is not a sympy Function
        args = [_scalar(a, b, memo) for a in e.args]
        op = ca.fmax if e.func is sp.Max else ca.fmin
        out = args[0]
        for a in args[1:]:
            out = op(out, a)
    else:
        raise DerivationError(f"expected an explicit scalar expression, received {type(e).__name__}: {e}")
    memo[e] = out
    return out


def _ipow(x: Any, k: int) -> Any:
    """``x**k`` for a positive integer ``k`` by repeated products (exact, cheap)."""
    out = x
    for _ in range(k - 1):
        out = out * x
    return out


def matrix_expr_to_casadi(
    expr: Any,
    matrices: Mapping[str, Any],
    scalars: Mapping[sp.Symbol, Any],
    inverses: Mapping[str, Any] | None = None,
) -> Any:
    """Evaluate a SymPy matrix expression on bound CasADi matrices.

    Parameters
    ----------
    expr : sympy matrix expression
        ``MatrixSymbol``, ``MatAdd``, ``MatMul`` (scalar coefficients allowed),
        ``Transpose``, ``Inverse``, explicit ``Matrix``.
    matrices : mapping
        ``MatrixSymbol name -> casadi matrix`` of the right shape.
    scalars : mapping
        ``Symbol -> casadi scalar or number`` for the scalar coefficients.
    inverses : mapping, optional
        ``name -> casadi matrix`` used for ``Inverse(MatrixSymbol(name))``
        (and its transpose for ``Inverse(Transpose(...))``).  Inverses not
        listed are evaluated with ``casadi.inv``.

    Examples
    --------
    >>> M = sp.MatrixSymbol("M", 2, 2); v = sp.MatrixSymbol("v", 2, 1); k = sp.Symbol("k")
    >>> Mx, vx = ca.SX.sym("M", 2, 2), ca.SX.sym("v", 2)
    >>> out = matrix_expr_to_casadi(k * M.T * v, {"M": Mx, "v": vx}, {k: 3.0})
    >>> f = ca.Function("f", [Mx, vx], [out])
    >>> f(ca.DM([[1, 2], [3, 4]]), ca.DM([1, 1])).full().ravel().tolist()
    [12.0, 18.0]
    """
    inv = dict(inverses or {})
    memo: dict = {}

    def rec(e: Any) -> Any:
        if isinstance(e, sp.MatrixSymbol):
            name = str(e.name)
            if name not in matrices:
                raise DerivationError(f"expected a binding for matrix {name}, received none")
            m = matrices[name]
            if tuple(m.shape) != (int(e.shape[0]), int(e.shape[1])):
                raise DerivationError(
                    f"expected {name} of shape {tuple(e.shape)}, received {tuple(m.shape)}"
                )
            return m
        if isinstance(e, sp.Transpose):
            return rec(e.arg).T
        if isinstance(e, sp.Inverse):
            a = e.arg
            if isinstance(a, sp.MatrixSymbol) and str(a.name) in inv:
                return inv[str(a.name)]
            if (
                isinstance(a, sp.Transpose)
                and isinstance(a.arg, sp.MatrixSymbol)
                and str(a.arg.name) in inv
            ):
                return inv[str(a.arg.name)].T
            return ca.inv(rec(a))
        if isinstance(e, sp.MatAdd):
            terms = [rec(a) for a in e.args]
            out = terms[0]
            for t in terms[1:]:
                out = out + t
            return out
        if isinstance(e, sp.MatMul):
            coeff: Any = 1.0
            mats: list[Any] = []
            for a in e.args:
                if getattr(a, "is_Matrix", False) or isinstance(a, sp.MatrixExpr):
                    mats.append(rec(a))
                else:
                    coeff = coeff * sympy_to_casadi(a, scalars, memo)
            out = mats[0]
            for m in mats[1:]:
                out = ca.mtimes(out, m)
            return coeff * out
        if isinstance(e, sp.MatPow) and e.exp.is_Integer and int(e.exp) != 0:
            base = rec(e.base) if int(e.exp) > 0 else rec(sp.Inverse(e.base))
            out = base
            for _ in range(abs(int(e.exp)) - 1):
                out = ca.mtimes(out, base)
            return out
        if isinstance(e, sp.MatrixBase):
            return sympy_to_casadi(e, scalars, memo)
        if isinstance(e, sp.ZeroMatrix):
            return ca.DM.zeros(int(e.shape[0]), int(e.shape[1]))
        if isinstance(e, sp.Identity):
            return ca.DM.eye(int(e.shape[0]))
        raise DerivationError(
            f"expected a matrix expression of MatrixSymbol/MatAdd/MatMul/Transpose/Inverse, "
            f"received {type(e).__name__}: {e}"
        )

    return rec(expr)


def switch_function(kind: str, tau: Any, phi: Any) -> Any:
    """Componentwise switching term ``sw(tau)``.

    ``sgn``: ``sign(tau)`` (the paper's (4); ``phi`` unused);
    ``sat``: ``clip(tau/phi, -1, 1)`` (boundary layer of half-width ``phi``);
    ``tanh``: ``tanh(tau/phi)``.

    >>> t = ca.SX.sym("t")
    >>> f = ca.Function("f", [t], [switch_function("sat", t, 0.5)])
    >>> float(f(0.1)), float(f(-3.0))
    (0.2, -1.0)
    """
    if kind == "sgn":
        return ca.sign(tau)
    if kind == "sat":
        return ca.fmin(1.0, ca.fmax(-1.0, tau / phi))
    if kind == "tanh":
        return ca.tanh(tau / phi)
    raise InputError(f"expected a switch in {SWITCHES}, received {kind!r}")


def _inertia_bindings(model: AttitudeModel, J: Any) -> dict:
    return {model.J[i, k]: J[i, k] for i in range(3) for k in range(3)}


def model_function(model: AttitudeModel | None = None) -> ca.Function:
    """``formsync_model(q, q0, qd, J) -> (E, Q, A, B)`` from the derived model.

    >>> import numpy as np
    >>> f = model_function()  # J is read as a symmetric matrix (lower triangle used)
    >>> q = np.array([0.1, 0.2, -0.3]); q0 = float(np.sqrt(1 - q @ q))
    >>> out = f(q=q, q0=q0, qd=[0.0, 0.0, 0.0], J=np.diag([1.0, 2.0, 3.0]))
    >>> bool(np.allclose(out["E"].full() @ out["Q"].full(), np.eye(3)))
    True
    """
    m = model if model is not None else derive_attitude_model()
    hit = _MODEL_CACHE.get(id(m))
    if hit is not None and hit[0] is m:
        return hit[1]
    q = ca.SX.sym("q", 3)
    q0 = ca.SX.sym("q0")
    qd = ca.SX.sym("qd", 3)
    J = ca.SX.sym("J", 3, 3)
    b = {m.q[k]: q[k] for k in range(3)}
    b.update({m.qd[k]: qd[k] for k in range(3)})
    b[m.q0] = q0
    b.update(_inertia_bindings(m, J))
    memo: dict = {}
    outs = [sympy_to_casadi(getattr(m, name), b, memo) for name in ("E", "Q", "A", "B")]
    fn = ca.Function(
        "formsync_model", [q, q0, qd, J], outs, ["q", "q0", "qd", "J"], ["E", "Q", "A", "B"]
    )
    _MODEL_CACHE[id(m)] = (m, fn)
    return fn


_MODEL_CACHE: dict = {}


@dataclass(frozen=True)
class ControllerBridge:
    """The translated controller: symbolic pieces kept for inspection.

    Attributes
    ----------
    function : casadi.Function
        ``formsync_controller(q, q0, qd, J, s, K_o, K_q, beta, K_v, phi) -> (u, tau, sigma)``.
    spec_name : str
    spec_key : str
        The specification's content key.
    switch : str
    inverse : str
    """

    function: ca.Function
    spec_name: str
    spec_key: str
    switch: str
    inverse: str


def build_controller(
    spec: Spec | str | Path | None = None,
    model: AttitudeModel | None = None,
    switch: str = "sat",
    inverse: str = "E",
) -> ControllerBridge:
    """Translate the specification's controller to a CasADi function.

    Parameters
    ----------
    spec : Spec, str, Path or None
        Default: the paper's (resolved with ``load_spec``); the translation is
        cached by ``spec.key`` (the specification's content).
    model : AttitudeModel, optional
        Default: ``derive_attitude_model()``.
    switch : {"sgn", "sat", "tanh"}
        Substitute for the switching term (see :func:`switch_function`).
    inverse : {"E", "solve"}
        How ``Q^{-1}`` is evaluated (see module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> f = build_controller(switch="sat").function
    >>> q = np.array([0.1, 0.4, -0.3]); q0 = float(np.sqrt(1 - q @ q))
    >>> out = f(q=q, q0=q0, qd=np.zeros(3), J=np.eye(3) * 50, s=np.zeros(3),
    ...         K_o=1.6, K_q=0.4, beta=0.3, K_v=0.01, phi=0.01)
    >>> bool(np.allclose(out["u"].full(), 0.0))
    True
    """
    if switch not in SWITCHES:
        raise InputError(f"expected a switch in {SWITCHES}, received {switch!r}")
    if inverse not in ("E", "solve"):
        raise InputError(f"expected inverse 'E' or 'solve', received {inverse!r}")
    sp_spec = load_spec(spec)
    if sp_spec.decl.representation != "quaternion":
        raise DerivationError(
            f"{sp_spec.path}: REPRESENTATION: expected 'quaternion' for the compiled simulator "
            f"(the quaternion formation kernel), received {sp_spec.decl.representation!r}"
        )
    m = model if model is not None else derive_attitude_model()
    fn = _controller_cached(sp_spec, m, switch, inverse)
    return ControllerBridge(
        function=fn, spec_name=sp_spec.name, spec_key=sp_spec.key, switch=switch, inverse=inverse
    )


def controller_gain_names(spec: Spec) -> tuple[str, ...]:
    """The controller gains of ``spec`` in the order the controller function takes them
    (after ``q, q0, qd, J, s``; a diagonal gain is a 3-vector input), then ``K_v, phi``.

    >>> controller_gain_names(load_spec(None))
    ('K_o', 'K_q', 'beta')
    """
    return spec.decl.controller_gains


def controller_function(switch: str = "sat", inverse: str = "E") -> ca.Function:
    """The paper's controller (4) as ``formsync_controller`` (see :func:`build_controller`).

    >>> controller_function("tanh").name_in()[:5]
    ['q', 'q0', 'qd', 'J', 's']
    """
    return build_controller(switch=switch, inverse=inverse).function


_SPEC_CACHE: dict = {}


def _controller_cached(spec: Spec, m: AttitudeModel, switch: str, inverse: str) -> ca.Function:
    key = (spec.key, id(m), switch, inverse)
    hit = _SPEC_CACHE.get(key)
    if hit is not None:
        return hit
    view, expr = controller_expression(spec)
    mf = model_function(m)
    q = ca.SX.sym("q", 3)
    q0 = ca.SX.sym("q0")
    qd = ca.SX.sym("qd", 3)
    J = ca.SX.sym("J", 3, 3)
    s = ca.SX.sym("s", 3)
    names = controller_gain_names(spec)
    gsyms = {}
    for g in spec.decl.gains:
        if g.name in names:
            gsyms[g.name] = ca.SX.sym(g.name, 3 if g.kind == GainKind.DIAG else 1)
    K_v, phi = ca.SX.sym("K_v"), ca.SX.sym("phi")
    E, Qm, A, B = mf(q, q0, qd, J)
    mats = {"A": A, "B": B, "Q": Qm, "qd": qd, "s": s}
    scal = {}
    for g in spec.decl.gains:
        if g.name not in names:
            continue
        if g.kind == GainKind.DIAG:
            mats[g.name] = ca.diag(gsyms[g.name])
        else:
            scal[view.gains[g.name]] = gsyms[g.name]
    sw_name = spec.decl.switching
    if sw_name is not None:
        scal[view.gains[sw_name]] = K_v
    if view.switch_arguments:
        tau = matrix_expr_to_casadi(view.switch_arguments[0], mats, scal)
        sigma = switch_function(switch, tau, phi)
    else:  # a controller without a switching term
        tau = ca.SX.zeros(3)
        sigma = ca.SX.zeros(3)
    mats["sigma"] = sigma
    inverses = {"Q": E} if inverse == "E" else {}
    if inverse == "solve":
        # Inverse(X) -> casadi.inv(X) is replaced by a linear solve below
        u = _solve_form(expr, mats, scal)
    else:
        u = matrix_expr_to_casadi(expr, mats, scal, inverses)
    fn = ca.Function(
        "formsync_controller",
        [q, q0, qd, J, s, *(gsyms[n] for n in names), K_v, phi],
        [u, tau, sigma],
        ["q", "q0", "qd", "J", "s", *names, "K_v", "phi"],
        ["u", "tau", "sigma"],
    )
    _SPEC_CACHE[key] = fn
    return fn


def _solve_form(expr: Any, mats: dict, scal: dict) -> Any:
    """``Inverse(X) * Y`` evaluated as ``solve(X, Y)`` (leading inverse only)."""
    if isinstance(expr, sp.MatMul):
        args = list(expr.args)
        for k, a in enumerate(args):
            if isinstance(a, sp.Inverse):
                left = sp.MatMul(*args[:k]) if k > 0 else None
                right = sp.MatMul(*args[k + 1 :]).doit() if k + 1 < len(args) else None
                X = matrix_expr_to_casadi(a.arg, mats, scal)
                Y = matrix_expr_to_casadi(right, mats, scal) if right is not None else ca.SX.eye(3)
                out = ca.solve(X, Y)
                if left is not None:
                    out = ca.mtimes(matrix_expr_to_casadi(left, mats, scal), out)
                return out
    return matrix_expr_to_casadi(expr, mats, scal)
