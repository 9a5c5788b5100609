"""Symbolic derivation for the attitude law of a design on the relative-orbit plant
(``PLANT = "relative-orbit"``, :mod:`formsync_design.spec.tracking`).

From the design's ``controller(view)`` (the torque ``T_c``) and ``lyapunov(view)``
(``V(sigma, omega)``; ``sigma``, ``omega``, ``omega_s``, ``w_d``, ``a_d`` are the view's
``track.sigma``, ``track.w``, ``w``, ``track.w_ref``, ``track.wdot_ref``), with the MRP kinematics of :mod:`formsync_design.models.mrp` and
Euler's equation written for the error rate ``omega = omega_s - w_d``::

    sigma'  = G(sigma) omega
    J omega' = -omega_s x J omega_s + T_c(J_hat) - J (a_d - omega x w_d),   omega_s = omega + w_d

(``J`` the plant's inertia, ``J_hat`` the inertia the law uses), this module derives

* ``V'`` along the closed loop for ``J_hat = J`` and checks it against the design's
  claim ``V' = -omega^T K_d omega`` exactly (any symmetric inertia, any reference rates);
* the mismatch ``V' + omega^T K_d omega`` when ``J_hat != J`` (printed in the report);
* the linearized error dynamics about ``sigma = omega = 0`` for a diagonal plant inertia,
  with the reference rates ``w_d = R_sd(sigma) omega_di`` and ``a_d = R_sd(sigma)
  omega_di'`` expanded in ``sigma``: ``J x_omega' = -k_p sigma - K_d omega + N x + d``;
  the certificate (:mod:`formsync_design.analysis.tracking`) uses ``N`` and ``d``.

>>> d = derive_tracking_attitude()
>>> d.nominal_holds, d.claim
(True, -K_d_1*omega_1**2 - K_d_2*omega_2**2 - K_d_3*omega_3**2)
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.models.attitude import skew
from formsync_design.models.mrp import mrp_kinematics_matrix
from formsync_design.spec.agent import AgentDesign
from formsync_design.spec.loader import load_design
from formsync_design.spec.tracking import tracking_expressions

__all__ = ["TrackingDerivation", "derive_tracking_attitude", "mrp_matrix_symbolic"]


def mrp_matrix_symbolic(sigma: sp.Matrix) -> sp.Matrix:
    """SymPy ``R(sigma)`` (body to reference) of :func:`~formsync_design.models.mrp.mrp_to_matrix`.

    >>> r = mrp_matrix_symbolic(sp.Matrix([sp.Rational(1, 3), 0, sp.Rational(1, 2)]))
    >>> r * r.T == sp.eye(3), r.det()
    (True, 1)
    """
    n2 = (sigma.T * sigma)[0, 0]
    sx = skew(sigma)
    return sp.eye(3) + (8 * sx * sx + 4 * (1 - n2) * sx) / (1 + n2) ** 2


@dataclass(frozen=True)
class TrackingDerivation:
    """The derivation of the attitude loop of a design on the relative-orbit plant (module
    docstring).

    Attributes
    ----------
    vdot : sympy expression
        ``V'`` along the closed loop with ``J_hat = J`` (simplified).
    claim : sympy expression
        ``-omega^T K_d omega`` (the design's rate-gain term).
    nominal_holds : bool
        ``vdot - claim`` simplifies to exactly 0.
    mismatch : sympy expression
        ``V' - claim`` for ``J_hat != J`` (the inertia-mismatch term).
    mismatch_form : sympy expression
        ``omega^T [omega_s x dJ omega_s + dJ (a_d - omega x w_d)]`` with ``dJ = J_hat - J``.
    mismatch_matches : bool
        ``mismatch - mismatch_form`` simplifies to 0.
    A0 : sympy Matrix
        6x6 linearization for ``omega_di = omega_di' = 0`` (``x = (sigma, omega)``).
    N : sympy Matrix
        3x6: the further linear terms of ``J omega'`` (in ``omega_di``, ``omega_di'``,
        ``J``, ``J_hat``); ``N = 0`` when ``J_hat = J`` is not assumed.
    forcing : sympy Matrix
        3x1: ``J omega'`` at ``x = 0`` (zero when ``J_hat = J``).
    symbols : dict
        The symbols used: ``sigma``, ``omega``, ``omega_di``, ``omega_di_dot`` (3x1
        Matrices), ``J`` and ``J_hat`` (diagonal entries), the gains ``k_p``, ``K_d``.
    """

    vdot: Any
    claim: Any
    nominal_holds: bool
    mismatch: Any
    mismatch_form: Any
    mismatch_matches: bool
    A0: sp.Matrix
    N: sp.Matrix
    forcing: sp.Matrix
    symbols: dict

    def to_dict(self) -> dict[str, Any]:
        return {
            "vdot": str(self.vdot),
            "claim": str(self.claim),
            "nominal_holds": self.nominal_holds,
            "mismatch_matches": self.mismatch_matches,
            "mismatch_form": str(self.mismatch_form),
        }


def _gain_matrix(view: Any, name: str) -> sp.Matrix:
    g = view.gains.get(name)
    if g is None:
        raise DerivationError(f"expected a design on the relative-orbit plant with a gain "
                              f"{name!r}, received gains "
                              f"{sorted(view.gains)}")
    return g if isinstance(g, sp.MatrixBase) else g * sp.eye(3)


def _vdot(ex: Any, torque_of: Any, v: Any, j_plant: sp.Matrix) -> sp.Expr:
    """``V'`` of the design's candidate along the closed loop with plant inertia ``j_plant``."""
    sig, om, wd, ad = v.sigma, v.omega, v.w_d, v.a_d
    om_s = om + wd
    tc = torque_of(om_s)
    force = -om_s.cross(j_plant * om_s) + tc - j_plant * (ad - om.cross(wd))
    lyap = ex.lyapunov.subs({s: j_plant[i, k] for (i, k), s in _jsyms(v).items()})
    grad_s = sp.Matrix([lyap]).jacobian(sig)
    grad_w = sp.Matrix([lyap]).jacobian(om)
    sdot = mrp_kinematics_matrix(sig) * om
    wdot_term = (grad_w * j_plant.inv() * force)[0, 0]
    return sp.expand(sp.cancel((grad_s * sdot)[0, 0] + wdot_term))


def _jsyms(v: Any) -> dict[tuple[int, int], sp.Symbol]:
    return {(i, k): v.J[i, k] for i in range(3) for k in range(i, 3)}


def _paper_names(view: Any) -> SimpleNamespace:
    """The view's quantities under the names of the derivation (module docstring)."""
    tr = view.track
    return SimpleNamespace(sigma=tr.sigma, omega=tr.w, omega_s=view.w, w_d=tr.w_ref,
                           a_d=tr.wdot_ref, J=view.J, gains=view.gains)


_DERIVED: dict[str, TrackingDerivation] = {}


def _derive(spec: AgentDesign) -> TrackingDerivation:
    hit = _DERIVED.get(spec.key)
    if hit is None:
        hit = _DERIVED[spec.key] = _derive_uncached(spec)
    return hit


def _derive_uncached(spec: AgentDesign) -> TrackingDerivation:
    ex = tracking_expressions(spec)
    v = _paper_names(ex.attitude_view)
    kd = _gain_matrix(v, "K_d")
    k_p = v.gains.get("k_p")
    js = _jsyms(v)
    jhat = sp.Matrix(3, 3, lambda i, k: sp.Symbol(f"Jh_{min(i, k) + 1}{max(i, k) + 1}", real=True))

    def torque_with(jlaw: sp.Matrix) -> Any:
        def tq(om_s: sp.Matrix) -> sp.Matrix:
            sub = {s: jlaw[i, k] for (i, k), s in js.items()}
            sub.update({v.omega_s[i]: om_s[i] for i in range(3)})
            return ex.torque.xreplace(sub)
        return tq

    claim = sp.expand(-(v.omega.T * kd * v.omega)[0, 0])
    vdot = _vdot(ex, torque_with(v.J), v, v.J)
    nominal = sp.simplify(vdot - claim) == 0
    mism = sp.expand(sp.cancel(_vdot(ex, torque_with(jhat), v, v.J) - claim))
    dj = jhat - v.J
    om_s = v.omega + v.w_d
    form = sp.expand((v.omega.T * (om_s.cross(dj * om_s) + dj * (v.a_d - v.omega.cross(v.w_d))))[0, 0])
    matches = sp.simplify(mism - form) == 0
    # linearization for a diagonal plant inertia and a diagonal law inertia
    jd = sp.diag(*[sp.Symbol(f"J_{i + 1}", positive=True) for i in range(3)])
    jhd = sp.diag(*[sp.Symbol(f"Jh_{i + 1}", positive=True) for i in range(3)])
    w_di = sp.Matrix(sp.symbols("omega_di_1:4", real=True))
    a_di = sp.Matrix(sp.symbols("omega_di_dot_1:4", real=True))
    c_bd = mrp_matrix_symbolic(v.sigma).T
    wd, ad = c_bd * w_di, c_bd * a_di
    om_s = v.omega + wd
    sub = {s: jhd[i, k] for (i, k), s in js.items()}
    sub.update({v.omega_s[i]: om_s[i] for i in range(3)})
    sub.update({v.w_d[i]: wd[i] for i in range(3)})
    sub.update({v.a_d[i]: ad[i] for i in range(3)})
    tc = ex.torque.xreplace(sub)
    force = -om_s.cross(jd * om_s) + tc - jd * (ad - v.omega.cross(wd))
    x = sp.Matrix([*v.sigma, *v.omega])
    zero = {xi: 0 for xi in x}
    jac = force.jacobian(x).xreplace(zero).applyfunc(sp.expand)
    base = jac.xreplace({**{w: 0 for w in w_di}, **{a: 0 for a in a_di}}).applyfunc(sp.expand)
    kp_m = k_p * sp.eye(3) if k_p is not None else sp.zeros(3)
    if (base - (-kp_m).row_join(-kd)).applyfunc(sp.expand) != sp.zeros(3, 6):
        raise DerivationError(f"{spec.path}: controller(view): expected the linearized loop "
                              f"J omega' = -k_p sigma - K_d omega at rest, received {base}")
    n_mat = (jac - base).applyfunc(sp.expand)
    forcing = force.xreplace(zero).applyfunc(sp.expand)
    a0 = sp.zeros(6, 6)
    a0[:3, 3:] = sp.eye(3) / 4
    a0[3:, :] = jd.inv() * base
    syms = {"sigma": v.sigma, "omega": v.omega, "omega_di": w_di, "omega_di_dot": a_di,
            "J": [jd[i, i] for i in range(3)], "J_hat": [jhd[i, i] for i in range(3)],
            "k_p": k_p, "K_d": [kd[i, i] for i in range(3)]}
    return TrackingDerivation(vdot, claim, bool(nominal), mism, form, bool(matches), a0, n_mat,
                              forcing, syms)


def derive_tracking_attitude(spec: AgentDesign | str | None = None) -> TrackingDerivation:
    """Derive the attitude loop of a design on the relative-orbit plant (default
    ``zhang2014_flyaround``).

    Raises :class:`~formsync_design.errors.DerivationError` (exit 2) for a design that is not
    on the relative-orbit plant or whose law does not linearize to ``-k_p sigma - K_d omega``.

    >>> d = derive_tracking_attitude()
    >>> same = {h: j for h, j in zip(d.symbols["J_hat"], d.symbols["J"])}
    >>> d.mismatch_matches, d.forcing.xreplace(same).T, d.N.xreplace(same).is_zero_matrix
    (True, Matrix([[0, 0, 0]]), True)
    """
    s = load_design(spec if spec is not None else "zhang2014_flyaround")
    if getattr(getattr(s, "decl", None), "plant", None) != "relative-orbit":
        raise DerivationError(f"{s.path}: PLANT: expected a design on the relative-orbit plant, "
                              f"received {s.name} on the "
                              f"{getattr(s.decl, 'plant', 'attitude')} plant")
    return _derive(s)
