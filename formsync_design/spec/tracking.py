"""The relative-orbit plant of the one design contract: one spacecraft tracking its reference
in relative orbit and attitude, with thrusters (Zhang et al. 2014 is the first).

A design on this plant is an agent design (:mod:`formsync_design.spec.agent`) that declares
``FORM = "agent"``, ``PLANT = "relative-orbit"`` (``ACTUATORS = "thrusters"``, the
default there), ``REPRESENTATION = "mrp"``, ``LEADER = True`` (the reference: the desired
frame), ``SAMPLING = "periodic"`` and ``GRAPHS = ()``; its ``GAINS`` (roles ``controller``
and ``weight``) and four functions of a view, each returning explicit SymPy expressions
(the relative orbit of :mod:`formsync_design.models.orbit`, the MRP attitude of
:mod:`formsync_design.models.mrp`):

``controller(v: TrackingView) -> 3x1 Matrix``
    the body torque ``T_c``.  ``v.w`` is the spacecraft's inertial body rate and ``v.J`` the
    inertia the law uses (a symmetric 3x3 Matrix of symbols ``J_ij``), as in every agent
    view; ``v.track`` is the tracking error with respect to the reference, measured by the
    plant: ``v.track.sigma`` (MRP of the body frame relative to the reference frame, short
    set), ``v.track.w`` (body rate relative to the reference frame, body axes),
    ``v.track.w_ref`` (the reference's inertial rate in body axes) and
    ``v.track.wdot_ref`` (its derivative, body axes); one attribute per controller gain (a
    scalar gain is a positive symbol, a diagonal gain ``K`` is ``diag(K_1, K_2, K_3)``) and
    the helpers ``hat``, ``vee``, ``G``, ``sgn``, ``sig``;
``lyapunov(v: TrackingView) -> scalar``
    the candidate ``V`` of the attitude law in the same quantities (``v.J`` is then the
    plant's inertia);
``orbit_controller(v: OrbitView) -> 3x1 Matrix``
    the commanded specific force in the relative orbit frame from ``v.dX`` (6x1, the
    state error ``X - X_d``), ``v.ff`` (3x1, the feedforward ``l_T'' - f(l_T, l_T')``
    of the design model) and ``v.K`` (3x6, the state-feedback gain, a Matrix of
    symbols ``K_i_j``);
``lqr_weights(v: WeightView) -> (Q 6x6, R 3x3)``
    the LQR weights in the design's ``weight`` gains (a diagonal weight ``q`` is
    ``diag(q_1, q_2, q_3)``); the engine computes ``K = R^-1 B^T P`` on the CW model.

Each function is called on its view when the design is loaded: a missing function, a
wrong shape or a symbol the view does not provide is a one-line
:class:`~formsync_design.errors.DerivationError` naming the file and the function.  The
plant measures the tracking error itself, so the view has no absolute attitude (``v.sigma``
is not provided: a law on this plant is written in ``v.track``).

>>> v = TrackingView(_demo_decl())
>>> v.K_d
Matrix([
[K_d_1,     0,     0],
[    0, K_d_2,     0],
[    0,     0, K_d_3]])
>>> v.track.sigma.T, v.w.T
(Matrix([[sigma_1, sigma_2, sigma_3]]), Matrix([[omega_s_1, omega_s_2, omega_s_3]]))
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.spec.agent_view import AgentDeclarations, hat, mrp_G, sgn_of, sig, vee
from formsync_design.spec.declarations import Declarations, GainDecl, GainKind, GainRole

__all__ = [
    "TRACKING_FUNCTIONS",
    "TrackingError",
    "TrackingView",
    "OrbitView",
    "WeightView",
    "validate_tracking",
    "tracking_expressions",
    "TrackingExpressions",
]

#: The functions a design on the relative-orbit plant defines (module docstring).
TRACKING_FUNCTIONS: tuple[str, ...] = ("controller", "lyapunov", "orbit_controller",
                                       "lqr_weights")


def _vec(name: str, n: int = 3) -> sp.Matrix:
    return sp.Matrix([sp.Symbol(f"{name}_{i + 1}", real=True) for i in range(n)])


def _gain_value(g: GainDecl) -> Any:
    if g.kind == GainKind.DIAG:
        return sp.diag(*[sp.Symbol(f"{g.name}_{i + 1}", positive=True) for i in range(3)])
    return sp.Symbol(g.name, positive=True)


def gain_entry_symbols(g: GainDecl) -> tuple[sp.Symbol, ...]:
    """The symbols of a gain in the tracking views: ``(k,)`` or ``(K_1, K_2, K_3)``."""
    v = _gain_value(g)
    return tuple(v[i, i] for i in range(3)) if isinstance(v, sp.MatrixBase) else (v,)


class _View:
    """Common part: one attribute per gain of ``roles``."""

    def __init__(self, decl: Declarations, roles: tuple[GainRole, ...]) -> None:
        self.decl = decl
        self.gains: dict[str, Any] = {}
        for g in decl.gains:
            if g.role in roles:
                self.gains[g.name] = _gain_value(g)
                setattr(self, g.name, self.gains[g.name])

    def _base(self) -> list[str]:
        return []

    def attributes(self) -> str:
        return ", ".join([*self._base(), *self.gains])

    def symbols(self) -> set[Any]:
        out: set[Any] = set()
        for v in self.gains.values():
            out |= set(v.free_symbols)
        return out


class TrackingError:
    """The tracking error of the reference that the relative-orbit plant measures (3x1 each):
    ``sigma`` (MRP, body relative to the reference frame), ``w`` (body rate relative to the
    reference frame, body axes), ``w_ref`` and ``wdot_ref`` (the reference's inertial rate
    and its derivative, body axes)."""

    def __init__(self) -> None:
        self.sigma = _vec("sigma")
        self.w = _vec("omega")
        self.w_ref = _vec("w_d")
        self.wdot_ref = _vec("a_d")

    def matrices(self) -> tuple[sp.Matrix, ...]:
        return (self.sigma, self.w, self.w_ref, self.wdot_ref)


class TrackingView(_View):
    """What ``controller(v)`` and ``lyapunov(v)`` of a design on the relative-orbit plant
    may use (module docstring)."""

    def __init__(self, decl: Declarations) -> None:
        super().__init__(decl, (GainRole.CONTROLLER,))
        self.track = TrackingError()
        self.w = _vec("omega_s")
        j = {(i, k): sp.Symbol(f"J_{min(i, k) + 1}{max(i, k) + 1}", real=True)
             for i in range(3) for k in range(3)}
        self.J = sp.Matrix(3, 3, lambda i, k: j[(i, k)])

    # the helpers of every agent view
    sgn = staticmethod(sgn_of)
    sig = staticmethod(sig)
    hat = staticmethod(hat)
    vee = staticmethod(vee)
    G = staticmethod(mrp_G)

    def _base(self) -> list[str]:
        return ["w", "J", "track (sigma, w, w_ref, wdot_ref)", "sgn", "sig", "hat", "vee", "G"]

    def symbols(self) -> set[Any]:
        out = super().symbols()
        for m in (self.w, self.J, *self.track.matrices()):
            out |= set(m.free_symbols)
        return out


class OrbitView(_View):
    """What ``orbit_controller(view)`` may use: ``dX`` (6x1), ``ff`` (3x1), ``K`` (3x6)."""

    def __init__(self, decl: Declarations) -> None:
        super().__init__(decl, (GainRole.CONTROLLER,))
        self.dX = _vec("dX", 6)
        self.ff = _vec("ff")
        self.K = sp.Matrix(3, 6, lambda i, k: sp.Symbol(f"K_{i + 1}_{k + 1}", real=True))

    def _base(self) -> list[str]:
        return ["dX", "ff", "K"]

    def symbols(self) -> set[Any]:
        out = super().symbols()
        for m in (self.dX, self.ff, self.K):
            out |= set(m.free_symbols)
        return out


class WeightView(_View):
    """What ``lqr_weights(view)`` may use: the design's ``weight`` gains."""

    def __init__(self, decl: Declarations) -> None:
        super().__init__(decl, (GainRole.WEIGHT,))


def _call(where: str, name: str, f: Callable[[Any], Any], view: _View) -> Any:
    try:
        return f(view)
    except AttributeError as e:
        attr = getattr(e, "name", None)
        if getattr(e, "obj", None) is view and attr:
            raise DerivationError(
                f"{where}: {name}(view): expected an attribute of the view "
                f"({view.attributes()}), received view.{attr}") from None
        raise DerivationError(f"{where}: {name}(view): the function raised "
                              f"{type(e).__name__}: {e}") from None
    except DerivationError:
        raise
    except Exception as e:  # a user's function: report, don't crash
        msg = " ".join(str(e).split())
        raise DerivationError(f"{where}: {name}(view): the function raised "
                              f"{type(e).__name__}: {msg}") from None


def _matrix(where: str, name: str, value: Any, shape: tuple[int, int], view: _View) -> sp.Matrix:
    if not isinstance(value, sp.MatrixBase) or value.shape != shape:
        got = getattr(value, "shape", None)
        raise DerivationError(f"{where}: {name}(view): expected an explicit {shape[0]}x{shape[1]} "
                              f"sympy Matrix, received "
                              f"{'shape ' + str(tuple(got)) if got else type(value).__name__}")
    extra = {str(s) for s in value.free_symbols} - {str(s) for s in view.symbols()}
    if extra:
        raise DerivationError(f"{where}: {name}(view): expected only the view's quantities "
                              f"({view.attributes()}), received unknown symbols {sorted(extra)}")
    return sp.Matrix(value)


class TrackingExpressions:
    """The SymPy expressions a design on the relative-orbit plant returns on its views.

    Attributes
    ----------
    attitude_view : TrackingView; orbit_view : OrbitView; weight_view : WeightView
    torque : 3x1 Matrix; lyapunov : scalar; acceleration : 3x1 Matrix
    Q, R : 6x6 and 3x3 Matrices in the weight symbols
    """

    def __init__(self, av: TrackingView, ov: OrbitView, wv: WeightView, torque: sp.Matrix,
                 lyap: sp.Expr, acc: sp.Matrix, q: sp.Matrix, r: sp.Matrix) -> None:
        self.attitude_view, self.orbit_view, self.weight_view = av, ov, wv
        self.torque, self.lyapunov, self.acceleration, self.Q, self.R = torque, lyap, acc, q, r

    def canonical(self) -> str:
        """A canonical text of every expression (``sympy.srepr``)."""
        return "\n".join(sp.srepr(e) for e in (self.torque, self.lyapunov, self.acceleration,
                                                self.Q, self.R))


def validate_tracking(functions: Mapping[str, Any], where: str,
                      decl: Declarations) -> TrackingExpressions:
    """Check the four functions of a design on the relative-orbit plant on their views
    (module docstring).

    Examples
    --------
    >>> fns = {"controller": lambda v: -v.k * v.track.sigma,
    ...        "lyapunov": lambda v: v.track.sigma.dot(v.track.sigma),
    ...        "orbit_controller": lambda v: -v.K * v.dX + v.ff,
    ...        "lqr_weights": lambda v: (sp.eye(6) * v.q, sp.eye(3))}
    >>> ex = validate_tracking(fns, "demo.py", _demo_decl())
    >>> ex.torque.T
    Matrix([[-k*sigma_1, -k*sigma_2, -k*sigma_3]])
    >>> validate_tracking({**fns, "controller": lambda v: v.track.sigma.T}, "demo.py", _demo_decl())
    Traceback (most recent call last):
    ...
    formsync_design.errors.DerivationError: demo.py: controller(view): expected an explicit 3x1 sympy Matrix, received shape (1, 3)
    """
    for name in TRACKING_FUNCTIONS:
        if not callable(functions.get(name)):
            got = "none" if name not in functions else f"a {type(functions[name]).__name__}"
            raise DerivationError(f"{where}: expected a function {name}(view) on the "
                                  f"relative-orbit plant, received {got}")
    av, ov, wv = TrackingView(decl), OrbitView(decl), WeightView(decl)
    torque = _matrix(where, "controller", _call(where, "controller", functions["controller"], av),
                     (3, 1), av)
    lv = TrackingView(decl)
    lyap = sp.sympify(_call(where, "lyapunov", functions["lyapunov"], lv))
    if isinstance(lyap, sp.MatrixBase):
        if lyap.shape != (1, 1):
            raise DerivationError(f"{where}: lyapunov(view): expected a scalar expression, "
                                  f"received shape {tuple(lyap.shape)}")
        lyap = lyap[0, 0]
    if not isinstance(lyap, sp.Expr):
        raise DerivationError(f"{where}: lyapunov(view): expected a scalar expression, "
                              f"received a {type(lyap).__name__}")
    extra = {str(s) for s in lyap.free_symbols} - {str(s) for s in lv.symbols()}
    if extra:
        raise DerivationError(f"{where}: lyapunov(view): expected only the view's quantities "
                              f"({lv.attributes()}), received unknown symbols {sorted(extra)}")
    acc = _matrix(where, "orbit_controller",
                  _call(where, "orbit_controller", functions["orbit_controller"], ov), (3, 1), ov)
    w = _call(where, "lqr_weights", functions["lqr_weights"], wv)
    if not (isinstance(w, tuple) and len(w) == 2):
        raise DerivationError(f"{where}: lqr_weights(view): expected a pair (Q, R), received "
                              f"a {type(w).__name__}")
    q = _matrix(where, "lqr_weights", w[0], (6, 6), wv)
    r = _matrix(where, "lqr_weights", w[1], (3, 3), wv)
    return TrackingExpressions(av, ov, wv, torque, lyap, acc, q, r)


def tracking_expressions(design: Any) -> TrackingExpressions:
    """The expressions of a loaded design on the relative-orbit plant (an
    :class:`~formsync_design.spec.agent.AgentDesign` with ``PLANT = "relative-orbit"``).

    >>> from formsync_design.spec.loader import load_design
    >>> ex = tracking_expressions(load_design("zhang2014_flyaround"))
    >>> ex.torque.shape, ex.acceleration.shape
    ((3, 1), (3, 1))
    """
    plant = getattr(getattr(design, "decl", None), "plant", None)
    if plant != "relative-orbit":
        raise DerivationError(f"{getattr(design, 'path', design)}: PLANT: expected "
                              f"'relative-orbit', received {plant or 'attitude'!r}")
    return validate_tracking(dict(design.functions), design.path, design.decl)


def _demo_decl() -> AgentDeclarations:
    """Declarations used by the doctests: gains ``k`` (scalar), ``K_d`` (diagonal), ``q``."""
    return AgentDeclarations(
        representation="mrp", graphs=(), sampling="periodic", leader=True,
        plant="relative-orbit", actuators="thrusters",
        gains=(GainDecl("k"), GainDecl("K_d", kind=GainKind.DIAG),
               GainDecl("q", GainRole.WEIGHT)))
