"""Derivation of SO(3) backstepping sliding-mode designs: error dynamics, where ``E`` is
singular, and the sliding-surface Lyapunov conditions as matrix families in the gains.

A design of this family (``derivations/ma_so3.py``) provides ``errors(R, W, Rd, Wd) ->
(Rt, e_R, e_W, E)`` and ``tracking_law(R, W, J, Rd, Wd, Wdd, gains, beta, dbeta, spow)``: the
torque that tracks a command ``(R_d, W_d, W_d')``.  Theorem 1's first part is about tracking,
so the derivation works on the *tracking loop*: the same law written as an agent design with
a leader whose reference is the command (:func:`tracking_design`), closed by the engine
(:func:`formsync_design.derive.agent.agent_closed_loop`), differentiated by
:func:`~formsync_design.derive.agent.time_derivative`.  The power functions of the law
(``beta``, its derivative, ``sig^{1/2}``) are replaced by opaque *markers*, so everything else
is rational.

Checked identities (exact, :func:`vanishes`): with the rotations written as the rational
parametrisation :func:`rational_rotation` (exactly orthogonal for every non-zero rational
4-vector) and every other symbol a random rational, each residual is evaluated in exact
arithmetic at :data:`POINTS` seeded random points and must be exactly 0 (a non-zero rational
function vanishes at random rational points with probability 0, Schwartz-Zippel):

* ``e_R' = E(Rt) e_W`` with ``E = (tr(Rt^T) I - Rt^T)/2`` and ``Psi' = e_R . e_W``
  (``Psi = tr(I - Rt)/2``);
* the reaching law ``s' = -K2 s - P2 sig(s) - e_R + J^{-1} d`` along the closed loop;
* ``V' = mu e_R.(s + alpha) + s.s'`` for ``V = mu Psi + s.s/2``.

The families are then extracted from the polynomial ``V'`` in ``(e_R, s, beta, sig)``:
``-1/2`` its Hessian in ``(e_R,k, s_k)`` per axis and the coefficients of ``e_R,k beta_k`` and
``s_k sig_k`` (both products ``>= 0``: :func:`power_lemmas`); the remainder is checked to be 0.

>>> sorted(det_E_factorisation())
['at_180', 'at_90', 'cos_form', 'identity']
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError

__all__ = [
    "POINTS",
    "rational_rotation",
    "vanishes",
    "tracking_design",
    "SlidingDerivation",
    "derive_sliding",
    "sliding_conditions",
    "det_E_factorisation",
    "power_lemmas",
]

#: Random exact points per identity.
POINTS = 3


class _Beta(sp.Function):
    """Marker of ``beta`` (the surface's power function); its derivative is :class:`_DBeta`."""

    nargs = 1

    def fdiff(self, argindex: int = 1) -> Any:
        return _DBeta(self.args[0])


class _DBeta(sp.Function):
    """Marker of ``beta'``."""

    nargs = 1


class _Sig(sp.Function):
    """Marker of ``sig^{1/2}`` in the reaching law."""

    nargs = 1


def rational_rotation(q: Any) -> sp.Matrix:
    """``R(q) = ((q0^2 - |v|^2) I + 2 v v^T + 2 q0 v^) / |q|^2`` for ``q = (v, q0)``: an exact
    rotation for every non-zero ``q`` (rational entries for rational ``q``).

    >>> R = rational_rotation([1, 2, 3, 4])
    >>> R.T * R == sp.eye(3), R.det()
    (True, 1)
    """
    v = sp.Matrix(q[:3])
    q0 = sp.sympify(q[3])
    n = q0**2 + (v.T * v)[0, 0]
    H = sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return ((q0**2 - (v.T * v)[0, 0]) * sp.eye(3) + 2 * v * v.T + 2 * q0 * H) / n


def vanishes(expr: Any, points: Sequence[Mapping[Any, Any]]) -> bool:
    """Whether ``expr`` (a scalar or a matrix) is exactly 0 at every point (exact arithmetic).

    >>> x = sp.Symbol("x")
    >>> vanishes((x + 1)**2 - x**2 - 2*x - 1, [{x: sp.Rational(3, 7)}]), vanishes(x, [{x: 1}])
    (True, False)
    """
    M = sp.Matrix([expr]) if not isinstance(expr, sp.MatrixBase) else expr
    for p in points:
        for e in M:
            val = sp.expand(e.xreplace(dict(p)))
            if val != 0:
                return False
    return True


def tracking_design(law: Callable[..., Any], gains: Mapping[str, Any]) -> Any:
    """The tracking loop's agent design: ``law`` with the command as a leader's reference
    (``R_d = v.ref.R``, ``W_d = v.ref.w``, ``W_d' = v.ref.wdot``) and the power functions as
    markers.  ``gains``: the design's controller ``GAINS`` declarations."""
    from formsync_design.spec.agent import agent_design_from_functions

    def ctrl(v: Any) -> Any:
        g = {k: getattr(v, k) for k in gains}
        g["sgn"] = v.sgn
        return law(v.R, v.w, v.J, v.ref.R, v.ref.w, v.ref.wdot, g,
                   beta=_Beta, dbeta=_DBeta, spow=_Sig)

    return agent_design_from_functions(ctrl, name="tracking-loop", representation="so3",
                                       leader=True, gains=dict(gains))


@dataclass(frozen=True)
class SlidingDerivation:
    """What :func:`derive_sliding` derived and checked.

    Attributes
    ----------
    checks : tuple of (name, statement, holds)
        The identities along the tracking loop (exact at :data:`POINTS` random points).
    vdot : sympy.Expr
        ``V'`` in the reduced symbols ``x`` (``e_R``), ``s``, ``beta``, ``sig`` (per axis 1..3),
        the multiplier ``mu`` and the per-axis gains.
    families : list of (name, Matrix, row_labels)
        In the scalar gain symbols.
    """

    checks: tuple[tuple[str, str, bool], ...]
    vdot: Any
    families: tuple[tuple[str, Any, tuple[str, ...]], ...]

    @property
    def all_hold(self) -> bool:
        return all(h for _, _, h in self.checks)


def _points(view: Any, loop: Any, gains_diag: Mapping[str, Any], seed: int) -> list[dict]:
    rng = random.Random(seed)

    def r(lo: int = -9, hi: int = 9) -> sp.Rational:
        return sp.Rational(rng.randint(lo, hi), rng.randint(1, 7))

    out = []
    for _ in range(POINTS):
        p: dict[Any, Any] = {}
        for A in (view.R, view.ref.R):
            q = [r() for _ in range(3)] + [sp.Rational(rng.randint(1, 9), rng.randint(1, 5))]
            Rq = rational_rotation(q)
            for i in range(3):
                for j in range(3):
                    p[A[i, j]] = Rq[i, j]
        for s in [*view.w, *view.ref.w, *view.ref.wdot, *loop.disturbance]:
            p[s] = r()
        for s in loop.rates.values():
            for f in sp.sympify(s).free_symbols:
                if str(f).startswith("wddot_ref"):
                    p[f] = r()
        # a symmetric positive definite inertia (diagonally dominant)
        off = [r(-3, 3) for _ in range(3)]
        diag = [sp.Integer(rng.randint(20, 60)) for _ in range(3)]
        Jn = sp.Matrix([[diag[0], off[0], off[1]], [off[0], diag[1], off[2]],
                        [off[1], off[2], diag[2]]])
        for i in range(3):
            for j in range(3):
                p[view.J[i, j]] = Jn[i, j]
        for val in gains_diag.values():
            syms = val.free_symbols if isinstance(val, sp.MatrixBase) else {val}
            for s in syms:
                p[s] = sp.Rational(rng.randint(1, 40), rng.randint(1, 20))
        out.append(p)
    return out


def derive_sliding(law: Callable[..., Any], errors: Callable[..., Any],
                   gains: Mapping[str, Any], seed: int = 2) -> SlidingDerivation:
    """Derive and check the tracking loop of ``law`` (module docstring)."""
    from formsync_design.derive.agent import agent_closed_loop, time_derivative

    ctrl = {k: v for k, v in gains.items() if v.get("role", "controller") == "controller"}
    d = tracking_design(law, ctrl)
    loop = agent_closed_loop(d, 0)
    v: Any = loop.view
    g = dict(v.gains)
    Rt, eR, eW, E = errors(v.R, v.w, v.ref.R, v.ref.w)
    alpha = -g["K1"] * eR - g["P1"] * eR.applyfunc(_Beta)
    s = eW - alpha
    mu = sp.Symbol("mu", positive=True)
    Psi = (sp.eye(3) - Rt).trace() / 2
    Jinv_d = v.J.inv() * loop.disturbance
    pts = _points(v, loop, g, seed)
    checks = []
    eRd = time_derivative(eR, loop)
    checks.append(("e_R' = E(Rt) e_W", "E = (tr(Rt^T) I - Rt^T)/2", vanishes(eRd - E * eW, pts)))
    Psid = time_derivative(Psi, loop)
    checks.append(("Psi' = e_R . e_W", "Psi = tr(I - Rt)/2", vanishes(Psid - eR.dot(eW), pts)))
    sd = time_derivative(s, loop)
    reach = -g["K2"] * s - g["P2"] * s.applyfunc(_Sig) - eR + Jinv_d
    checks.append(("s' = -K2 s - P2 sig(s) - e_R + J^-1 d", "along the closed loop",
                   vanishes(sd - reach, pts)))
    V = mu * Psi + s.dot(s) / 2
    Vd = time_derivative(V, loop)
    red = mu * eR.dot(s + alpha) + s.dot(reach)
    checks.append(("V' = mu e_R.(s + alpha) + s.s'", "V = mu Psi + |s|^2/2",
                   vanishes(Vd - red, [{**p, mu: sp.Rational(3, 2)} for p in pts])))
    # the reduced V' in the symbols x = e_R, s, b = beta(x), z = sig(s); disturbance free
    x = sp.Matrix(sp.symbols("x_1:4", real=True))
    sv = sp.Matrix(sp.symbols("s_1:4", real=True))
    b = sp.Matrix(sp.symbols("b_1:4", real=True))
    z = sp.Matrix(sp.symbols("z_1:4", real=True))
    al = -g["K1"] * x - g["P1"] * b
    Vr = sp.expand(mu * x.dot(sv + al) + sv.dot(-g["K2"] * sv - g["P2"] * z - x))
    fams = _families(Vr, x, sv, b, z, g, mu)
    return SlidingDerivation(checks=tuple(checks), vdot=Vr, families=fams)


def _families(Vr: Any, x: Any, sv: Any, b: Any, z: Any, g: Mapping[str, Any],
              mu: Any) -> tuple[tuple[str, Any, tuple[str, ...]], ...]:
    """Per-axis quadratic form and power coefficients of ``-V'``, remainder checked 0."""
    scalar = {}
    for name in ("K1", "K2", "P1", "P2"):
        for sym in (g[name].diagonal() if isinstance(g[name], sp.MatrixBase)
                    else [g[name]] * 3):
            scalar[sym] = sp.Symbol(name, positive=True)
    rebuilt = sp.Integer(0)
    quad = None
    power = None
    for k in range(3):
        zk = [x[k], sv[k]]
        H = sp.Matrix([[-sp.diff(Vr, a, c) / 2 for c in zk] for a in zk])
        cb = -sp.diff(Vr, x[k], b[k])
        cz = -sp.diff(Vr, sv[k], z[k])
        rebuilt += -(sp.Matrix([zk]) * H * sp.Matrix(zk))[0, 0] - cb * x[k] * b[k] - cz * sv[k] * z[k]
        Hs, Ps = H.xreplace(scalar), sp.diag(cb, cz).xreplace(scalar)
        if quad is None:
            quad, power = Hs, Ps
        elif Hs != quad or Ps != power:
            raise DerivationError(f"expected the same conditions on every axis, received axis "
                                  f"{k + 1}: {Hs.tolist()} vs {quad.tolist()}")
    rest = sp.expand(Vr - rebuilt)
    if rest != 0:
        raise DerivationError(f"expected V' to be a quadratic form in (e_R, s) plus power "
                              f"terms, received the remainder {rest}")
    assert quad is not None and power is not None
    return (("Vdot_quadratic", sp.simplify(quad), ("e_R,k", "s_k")),
            ("Vdot_power", power, ("e_R,k beta(e_R,k)", "s_k sig(s_k)")),
            ("V_positive", sp.Matrix([[mu]]), ("Psi",)))


_CACHE: dict[str, SlidingDerivation] = {}


def sliding_conditions(c: Any, law: Callable[..., Any], errors: Callable[..., Any]) -> list:
    """The ``conditions(c)`` hook of an SO(3) sliding-mode design: the families of
    :func:`derive_sliding` (every check must hold, else a :class:`DerivationError`)."""
    gains = c.design.module.get("GAINS", {})
    der = _CACHE.get(c.design.key)
    if der is None:
        der = _CACHE[c.design.key] = derive_sliding(law, errors, gains)
    if not der.all_hold:
        bad = [n for n, _, h in der.checks if not h]
        raise DerivationError(f"{c.design.path}: conditions(c): expected the error dynamics "
                              f"of the tracking loop to hold, received failing checks {bad}")
    return list(der.families)


def det_E_factorisation() -> dict[str, Any]:
    """``det E(Rt)`` derived: the identity ``det E = (tr(Rt)^2 - 1)/8`` (exact, for the rational
    parametrisation), the unit-quaternion form ``q0^2 (2 q0^2 - 1) = cos th (1 + cos th)/2``,
    and the kernels at 90 and 180 degrees (about ``z``)."""
    q = sp.symbols("q1 q2 q3 q0", real=True)
    R = rational_rotation(q)
    E = (R.T.trace() * sp.eye(3) - R.T) / 2
    ident = sp.cancel(E.det() - (R.trace() ** 2 - 1) / 8) == 0
    th = sp.Symbol("theta", real=True)
    q0 = sp.cos(th / 2)
    unit = sp.simplify((((4 * q0**2 - 1) ** 2 - 1) / 8) - sp.cos(th) * (1 + sp.cos(th)) / 2) == 0
    out: dict[str, Any] = {"identity": ident, "cos_form": unit}
    for name, ang in (("at_90", sp.pi / 2), ("at_180", sp.pi)):
        Rz = sp.Matrix([[sp.cos(ang), -sp.sin(ang), 0], [sp.sin(ang), sp.cos(ang), 0], [0, 0, 1]])
        Ez = (Rz.T.trace() * sp.eye(3) - Rz.T) / 2
        out[name] = {"det": sp.simplify(Ez.det()), "kernel": [list(k) for k in Ez.nullspace()]}
    return out


def power_lemmas() -> dict[str, bool]:
    """The properties of ``beta`` (``derivations/ma_so3.py``) the certificate uses, decided
    on its two branches exactly: continuity of value and slope at ``|x| = eps``,
    ``x beta(x) > 0`` for ``x != 0``, ``beta'`` the derivative of ``beta`` on each branch and
    bounded by ``3/(2 sqrt eps)``."""
    x, eps = sp.symbols("x eps", positive=True)
    outer = sp.sqrt(x)
    inner = sp.Rational(3, 2) / sp.sqrt(eps) * x - x**2 / (2 * eps ** sp.Rational(3, 2))
    cont = sp.simplify((outer - inner).subs(x, eps)) == 0
    slope = sp.simplify((sp.diff(outer, x) - sp.diff(inner, x)).subs(x, eps)) == 0
    # x beta(x) = x^2 (l1 - x/(2 eps^{3/2})) >= x^2 / sqrt(eps) on 0 < x < eps
    t = sp.Symbol("t", positive=True)  # x = t eps, 0 < t < 1
    pos = sp.simplify(inner.subs(x, t * eps) / (t * sp.sqrt(eps)) - (sp.Rational(3, 2) - t / 2)) == 0
    bound = sp.simplify(sp.diff(inner, x).subs(x, 0) - sp.Rational(3, 2) / sp.sqrt(eps)) == 0
    return {"continuous at eps": bool(cont), "C^1 at eps": bool(slope),
            "x beta(x) > 0 inside": bool(pos), "beta'(0) = 3/(2 sqrt eps) (the bound)": bool(bound)}
