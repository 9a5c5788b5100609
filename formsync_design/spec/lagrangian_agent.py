"""The agent form of a Lagrangian design: one design contract for both forms.

A Lagrangian design (``controller(view)`` in the opaque model matrices ``A``, ``B``, ``Q``,
``q'``, ``s`` and a switching term, :mod:`formsync_design.spec.lagrangian_view`) states a
law for the quaternion model ``A_i q_i'' + B_i q_i' = Q_i^T u_i``.  :func:`agent_form` writes
the same law per spacecraft in the agent view (:mod:`formsync_design.spec.agent_view`), so
every engine stage (simulation, the formation certificate, Monte-Carlo, the verification
engine) runs it, with the design as its Lagrangian view (:attr:`AgentDesign.lagrangian
<formsync_design.spec.agent.AgentDesign.lagrangian>`, the Θ_i/Π certificate of
:mod:`formsync_design.verify.metrics_lagrangian`).

The substitution is the model of :mod:`formsync_design.models.attitude`, with the rates
``w`` as the state:

* ``q' = E w``, ``E = (q0 I + q^x)/2``; ``Q = E^{-1} = 2 (q0 I - q^x + q q^T / q0)``;
* ``Q' = -Q E' Q`` with ``E' = (q0' I + q'^x)/2``, ``q0' = -q^T w / 2``;
* ``A = Q^T J Q``, ``B = Q^T J Q' - Q^T (J w)^x Q`` (the derivation's ``B``);
* ``Q^{-1} = E`` wherever the law inverts ``Q``; ``s = sum_j a_ij (q_i - q_j)`` (the
  Lagrangian view's unit weights ``a_ij = 1`` on an undirected graph; the agent form reads
  the graph's weights, an extension to weighted and directed graphs);
* ``sw(arg)`` -> ``sgn(arg)`` (the agent kernels realise it as the case's ``switch``);
* the switching gain (``K_vi``) is one controller gain of the agent form (as in
  ``derivations/liang2016.py``).

>>> from formsync_design.spec.loader import load_spec
>>> d = agent_form(load_spec("liang2016"))
>>> d.form, d.name, d.gains, d.lagrangian.name
('agent', 'liang2016', ('K_o', 'K_q', 'beta', 'K_v'), 'liang2016')
"""

from __future__ import annotations

from typing import Any

import sympy as sp
from sympy.matrices.expressions.matexpr import MatrixElement

from formsync_design.errors import DerivationError, InputError
from formsync_design.spec.declarations import GainRole

__all__ = ["agent_form", "agent_of", "lagrangian_model"]

_FORMS: dict[str, Any] = {}


def lagrangian_model(v: Any) -> dict[str, Any]:
    """The model quantities of spacecraft ``v`` (an agent view) the Lagrangian view names:
    ``E``, ``Q``, its derivative ``Qd``, ``qd``, ``A``, ``B`` and ``s`` (module docstring).

    >>> from formsync_design.spec.agent_view import AgentDeclarations
    >>> from formsync_design.spec.agent_view import AgentView
    >>> m = lagrangian_model(AgentView(AgentDeclarations(), 1))
    >>> q0, q = 2 * m["E"][0, 0], m["q"]
    >>> sp.simplify(m["Q"] * m["E"] - (q0**2 + (q.T * q)[0]) * sp.eye(3)) == sp.zeros(3)  # Q E = I on the unit sphere
    True
    """
    q, q0, w, J = v.q, v.q0, v.w, v.J
    eye = sp.eye(3)
    E = (q0 * eye + v.hat(q)) / 2
    qd = E * w
    q0d = -(q.T * w)[0, 0] / 2
    Ed = (q0d * eye + v.hat(qd)) / 2
    Q = 2 * (q0 * eye - v.hat(q) + q * q.T / q0)
    Qd = -Q * Ed * Q
    A = Q.T * J * Q
    B = Q.T * J * Qd - Q.T * v.hat(J * w) * Q
    s = sp.zeros(3, 1)
    for n in v.nbrs:
        s += n.a * (q - n.q)
    return {"q": q, "E": E, "Q": Q, "Qd": Qd, "qd": qd, "A": A, "B": B, "s": s}


def _cancelled(u: Any, view: Any) -> tuple[sp.Matrix, Any, Any]:
    """``u`` with ``A = Q^T Ah`` and ``B = Q^T Bh`` (``Ah = J Q``, ``Bh = J Q' - (J w)^x Q``),
    the products ``Q^{-T} Q^T`` cancelled exactly (the usual ``u = Q^{-T} (...)`` law then has
    no ``Q`` left to write out), as an explicit matrix in the entries of the matrix symbols;
    ``(u, Ah, Bh)``."""
    ah, bh = sp.MatrixSymbol("Ah__", 3, 3), sp.MatrixSymbol("Bh__", 3, 3)
    e = sp.expand(u.xreplace({view.A: view.Q.T * ah, view.B: view.Q.T * bh})).doit()
    return sp.Matrix(e.as_explicit()), ah, bh


def _entries(sym: Any, value: Any) -> dict[Any, Any]:
    """``{sym[i, j]: value[i, j]}`` for a matrix symbol and an explicit matrix."""
    val = sp.Matrix(value)
    return {sym[i, j]: val[i, j] for i in range(sym.shape[0]) for j in range(sym.shape[1])}


def _explicit(parts: tuple[sp.Matrix, Any, Any], view: Any, v: Any) -> sp.Matrix:
    """The Lagrangian controller (:func:`_cancelled`, in ``view``'s symbols) in the agent
    view ``v``'s symbols."""
    u, ah, bh = parts
    m = lagrangian_model(v)
    J, Q, Qd = v.J, m["Q"], m["Qd"]
    jw = v.hat(v.J * v.w)
    sub: dict[Any, Any] = {}
    for sym, val in ((ah, J * Q), (bh, J * Qd - jw * Q), (view.A, Q.T * J * Q),
                     (view.B, Q.T * (J * Qd - jw * Q)), (view.Q, Q), (view.qd, m["qd"]),
                     (view.s, m["s"])):
        sub.update(_entries(sym, val))
    for name, sym in view.gains.items():
        val = getattr(v, name)
        sub.update(_entries(sym, val) if isinstance(sym, sp.MatrixSymbol) else {sym: val})
    if view.switch_arguments:
        arg = _cancelled(view.switch_arguments[0], view)[0].xreplace(sub)
        sub.update(_entries(view.sigma, v.sgn(arg)))
    out = u.xreplace(sub)
    left = out.atoms(MatrixElement)
    if left:
        raise DerivationError("expected a controller in A, B, Q, qd, s, the gains and sw(); "
                              "received one the agent form cannot write out "
                              f"({sorted({str(a.parent) for a in left})})")
    return out


def _gains(spec: Any) -> dict[str, dict[str, Any]]:
    """The agent form's ``GAINS``: the design's, its switching gain a controller gain."""
    out: dict[str, dict[str, Any]] = {}
    for g in spec.decl.gains:
        role = GainRole.CONTROLLER if g.role == GainRole.SWITCHING else g.role
        row: dict[str, Any] = {"role": str(role), "kind": str(g.kind),
                               "description": g.description}
        if g.range is not None:
            row["range"] = f"{g.range.lo}:{g.range.hi}"
        out[g.name] = row
    return out


def agent_form(spec: Any) -> Any:
    """The agent design of the Lagrangian design ``spec`` (module docstring), cached by its
    key; its :attr:`lagrangian` is ``spec``.  A design in another representation is a
    one-line :class:`~formsync_design.errors.DerivationError`."""
    from dataclasses import replace

    from formsync_design.spec.agent import agent_design_from_functions
    from formsync_design.spec.loader import controller_expression

    hit = _FORMS.get(spec.key)
    if hit is not None:
        return hit
    if spec.decl.representation != "quaternion":
        raise DerivationError(f"{spec.path}: expected a quaternion Lagrangian design for its "
                              f"agent form, received REPRESENTATION {spec.decl.representation!r}")
    view, u = controller_expression(spec)
    parts = _cancelled(u, view)

    def controller(v: Any) -> Any:
        return _explicit(parts, view, v)

    def monitors(v: Any) -> dict[str, Any]:
        return {"q0": v.q0}  # the Lagrangian model is undefined at q0 = 0

    d = agent_design_from_functions(controller, name=spec.name, title=spec.title,
                                    representation="quaternion", gains=_gains(spec),
                                    graphs=spec.decl.graphs, sampling=spec.decl.sampling,
                                    monitors=monitors)
    d = replace(d, path=spec.path, source=spec.source, lagrangian=spec)
    _FORMS[spec.key] = d
    return d


def agent_of(d: Any, where: str = "") -> Any:
    """The agent design that runs for the loaded design ``d``: an agent design as it is, a
    quaternion Lagrangian design in its agent form (:func:`agent_form`, the design its
    Lagrangian view); a design on another plant (the relative-orbit plant) is refused in one line
    (``where``: where it was named, for the message).

    >>> from formsync_design.spec.loader import load_design, load_spec
    >>> agent_of(load_spec("pd_consensus")).lagrangian.name
    'pd_consensus'
    >>> agent_of(load_design("ma_so3")).name
    'ma_so3'
    """
    decl = getattr(d, "decl", None)
    plant = getattr(decl, "plant", "attitude")
    if getattr(d, "form", None) == "agent" and plant == "attitude":
        return d
    if plant != "attitude" or getattr(decl, "representation", None) != "quaternion":
        what = (f"on the {plant} plant" if plant != "attitude"
                else f"in REPRESENTATION {getattr(decl, 'representation', '?')!r}")
        raise InputError(f"expected an agent design on the attitude plant (FORM = 'agent') or a "
                         f"quaternion Lagrangian design{where}, received the design {d.name!r} "
                         f"{what}")
    return agent_form(d)
