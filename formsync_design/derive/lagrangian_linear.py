"""The linearisation of a Lagrangian design's formation at consensus (the identity attitude).

A Lagrangian specification (:mod:`formsync_design.spec.loader`, e.g. ``liang2016`` or
``pd_consensus``) cancels the model: its derived closed loop
(:func:`~formsync_design.derive.closed_loop.derive_closed_loop`) is, per spacecraft,

    ``q_i'' = c_qd q_i' + c_s s_i + c_sigma sw(rho_qd q_i' + rho_s s_i) + A_i^-1 Q_i^T d_i``,

``s_i = sum_j (q_i - q_j)`` over the graph's neighbours.  At consensus at the identity
(``q_i = 0``, ``q0_i = 1``, at rest) the linear part is exact except for two terms, both
taken from the derivation, not typed:

* the switching term as realised (``sw = sat(x / phi)`` or ``tanh(x / phi)``: slope ``1 /
  phi`` at 0; the ideal ``sgn`` is not differentiable there and is refused);
* the disturbance input ``A_i^-1 Q_i^T`` of the derived attitude model
  (:func:`~formsync_design.models.attitude.derive_attitude_model`) at ``q = 0``, ``q0 = 1``
  and the spacecraft's inertia (``J_i^-1 / 2``).

The state is ``x = (q_1 .. q_N, qd_1 .. qd_N)`` (vector parts of the attitudes and their
rates, labels ``q1_1 .. q3_N, qd1_1 .. qd3_N``), the input the disturbance torques ``d``
(N m), the output the attitudes ``z = (q_1 .. q_N)``:

    ``x' = A x + B d``,  ``z = C x``,  every entry an exact rational.

>>> import numpy as np
>>> lin = linearize_lagrangian("pd_consensus", "path:2", [np.eye(3) * 2] * 2, {"k_p": 1, "k_d": 3})
>>> lin.labels[:2], lin.labels[6:8], lin.A.shape
(('q1_1', 'q2_1'), ('qd1_1', 'qd2_1'), (12, 12))
>>> float(lin.A[6, 0]), float(lin.A[6, 3]), float(lin.A[6, 6]), float(lin.B[6, 0])  # -k_p, k_p, -k_d, 1/(2 J)
(-1.0, 1.0, -3.0, 0.25)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp

from formsync_design.errors import InputError

__all__ = ["LagrangianLinear", "linearize_lagrangian"]


@dataclass(frozen=True)
class LagrangianLinear:
    """``x' = A x + B d``, ``z = C x`` (module docstring); float arrays of exact rationals.

    Attributes
    ----------
    A, B, C : numpy.ndarray
    labels : tuple of str
        The state order.
    switch : str
        The switching function as realised (``"none"`` for a design without one).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    labels: tuple[str, ...]
    switch: str


def _rational(x: Any, name: str) -> sp.Rational:
    from formsync_design.gains import parse_number

    q = x if isinstance(x, Fraction) else parse_number(x, name)
    return sp.Rational(q.numerator, q.denominator)


def _scalar(expr: Any, sub: Mapping[Any, Any], what: str, design: str) -> Fraction:
    e = sp.Integer(expr) if isinstance(expr, int) else expr  # a derived expression (no text)
    v = sp.nsimplify(sp.expand(e.xreplace(dict(sub))))
    if not v.is_Rational:
        raise InputError(f"expected a number for {what} of {design} at the gains given, "
                         f"received {v}")
    return Fraction(int(v.p), int(v.q))


def linearize_lagrangian(spec: Any, graph: Any, inertias: Any, gains: Mapping[str, Any], *,
                         switch: str = "sat", phi: Any = "1/100") -> LagrangianLinear:
    """The formation linearisation of a Lagrangian design (module docstring).

    Parameters
    ----------
    spec : Spec, str or Path
        A Lagrangian design (its name, file or value).
    graph : Graph or str
        An undirected graph (``"ring:8"``).
    inertias : array_like, shape (N, 3, 3)
    gains : mapping
        Every controller gain, and the switching gain when the design has one.
    switch : {"sat", "tanh", "sgn"}
        How the switching function is realised (``sgn`` is refused when the law has one).
    phi : number
        The boundary layer of ``sat``/``tanh``.
    """
    from formsync_design.derive.closed_loop import derive_closed_loop
    from formsync_design.graphs.build import make_graph
    from formsync_design.models.attitude import derive_attitude_model
    from formsync_design.models.inertia import check_inertias
    from formsync_design.spec.loader import load_spec

    sp_spec = load_spec(spec)
    g = make_graph(graph) if isinstance(graph, str) else graph
    n = g.n
    J = check_inertias(inertias, n)
    decl = sp_spec.decl
    cl = derive_closed_loop(sp_spec)
    names = list(decl.controller_gains)
    sw_name = decl.switching
    switching = sp.expand(cl.c_sigma) != 0 and cl.switch_argument is not None
    need = names + ([sw_name] if switching and sw_name is not None else [])
    missing = [x for x in need if x not in gains]
    if missing:
        raise InputError(f"expected a value for every gain {need} of {sp_spec.name}, "
                         f"missing {missing}")
    sub = {decl.gain(x).symbol: _rational(gains[x], x) for x in need}
    c_qd = _scalar(cl.c_qd, sub, "c_qd", sp_spec.name)
    c_s = _scalar(cl.c_s, sub, "c_s", sp_spec.name)
    slope = Fraction(0)
    rho_qd = rho_s = Fraction(0)
    realised = "none"
    if switching:
        if switch not in ("sat", "tanh"):
            raise InputError(f"expected a law differentiable at consensus for the export of "
                             f"{sp_spec.name} (switch sat or tanh), received switch {switch!r}")
        ph = _rational(phi, "phi")
        if ph <= 0:
            raise InputError(f"expected a boundary layer phi > 0, received {phi}")
        qd = sp.Matrix(sp.symbols("x1 x2 x3"))
        s = sp.Matrix(sp.symbols("y1 y2 y3"))
        arg = cl.switch_argument_explicit(qd, s)
        arg = sp.Matrix(arg).xreplace(sub).applyfunc(sp.expand)
        rq, rs = sp.expand(arg[0].coeff(qd[0])), sp.expand(arg[0].coeff(s[0]))
        if (arg - (rq * qd + rs * s)).applyfunc(sp.expand) != sp.zeros(3, 1):
            raise InputError(f"expected a switching argument of {sp_spec.name} linear in q' and "
                             f"s, received {arg.T}")
        rho_qd, rho_s = _scalar(rq, {}, "rho_qd", sp_spec.name), _scalar(rs, {}, "rho_s", sp_spec.name)
        slope = _scalar(cl.c_sigma, sub, "c_sigma", sp_spec.name) / Fraction(int(ph.p), int(ph.q))
        realised = f"{switch}(x/{float(ph):g})"
    k_qd = c_qd + slope * rho_qd      # q_i''  per unit q_i'
    k_s = c_s + slope * rho_s         # q_i''  per unit s_i
    L = np.asarray(g.laplacian, dtype=float)
    I3 = np.eye(3)
    A = np.zeros((6 * n, 6 * n))
    A[: 3 * n, 3 * n :] = np.eye(3 * n)
    A[3 * n :, : 3 * n] = float(k_s) * np.kron(L, I3)
    A[3 * n :, 3 * n :] = float(k_qd) * np.eye(3 * n)
    m = derive_attitude_model()
    at_rest = {**{x: 0 for x in m.q}, m.q0: 1, **{x: 0 for x in m.qd}}
    Ain = m.A.xreplace(at_rest)
    Qt = m.Q.T.xreplace(at_rest)
    B = np.zeros((6 * n, 3 * n))
    for i in range(n):
        jsub = {sym: sp.Rational(Fraction(float(v)).numerator, Fraction(float(v)).denominator)
                for sym, v in zip(m.inertia_symbols, (J[i][0, 0], J[i][0, 1], J[i][0, 2],
                                                        J[i][1, 1], J[i][1, 2], J[i][2, 2]))}
        G = (Ain.xreplace(jsub).inv() * Qt).applyfunc(sp.nsimplify)
        B[3 * n + 3 * i : 3 * n + 3 * i + 3, 3 * i : 3 * i + 3] = np.array(G.tolist(), dtype=float)
    C = np.zeros((3 * n, 6 * n))
    C[:, : 3 * n] = np.eye(3 * n)
    labels = tuple(f"q{k}_{i + 1}" for i in range(n) for k in (1, 2, 3)) + tuple(
        f"qd{k}_{i + 1}" for i in range(n) for k in (1, 2, 3))
    return LagrangianLinear(A, B, C, labels, realised)
