"""Derivation of agent designs: the symbolic closed loop, time derivatives along it, and the
design's certificate conditions as matrix families in the gains.

:func:`agent_closed_loop` gives, for a spacecraft with ``m`` in-neighbours, the time
derivative of every quantity of the view (:class:`~formsync_design.spec.agent_view.AgentView`):

* own attitude by its kinematics (``q' = E(q) w``, ``q0' = -q.w/2``; ``sigma' = G(sigma) w``;
  ``R' = R w^``), own rate by Euler's equation with the design's torque
  ``w' = J^{-1} (u - w x J w + d)`` (``d``: the disturbance symbols ``d_1..3``), own states by
  ``states(v)``;
* the neighbours' and the reference's attitudes by the same kinematics, their rates'
  derivatives as free symbols (``wdot_n{k}_j``; the reference's ``wdot_ref``), their states'
  derivatives as free symbols (``{name}dot_n{k}_j``).

:func:`time_derivative` differentiates any expression of the view along these rates (the
chain rule, exact), which is how a design's ``conditions`` hook derives ``V'`` of its
Lyapunov candidate instead of typing it.

A design's certificate is the optional hook ``conditions(c)`` of the design file, called with
a :class:`ConditionContext`: it returns ``[(name, M, row_labels), ...]``, symmetric SymPy
matrices polynomial in the gains' scalar symbols (a diagonal gain's symbol stands for each of
its diagonal entries) that must be positive definite on the whole gain box.
:func:`agent_conditions` collects them into :class:`AgentConditions`, which
:func:`~formsync_design.certify.engine.certify_box` decides exactly like ``Theta_i`` and ``Pi``.

>>> from formsync_design.spec.agent import agent_design_from_functions
>>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}})
>>> cl = agent_closed_loop(d, 0)
>>> v = cl.view
>>> V = (v.w.T * v.J * v.w)[0, 0] / 2
>>> sp.simplify(time_derivative(V, cl).subs({s: 0 for s in cl.disturbance}) + v.k * 2 * V)
0
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from formsync_design.derive.families import MatrixFamily, family_from_sympy
from formsync_design.errors import DerivationError
from formsync_design.spec.agent import AgentDesign, agent_expressions
from formsync_design.spec.agent_view import AgentView, AttitudeSymbols

__all__ = [
    "AgentClosedLoop",
    "agent_closed_loop",
    "time_derivative",
    "ConditionContext",
    "AgentConditions",
    "agent_conditions",
]


def _kinematics(a: AttitudeSymbols) -> dict[sp.Symbol, sp.Expr]:
    rates: dict[sp.Symbol, sp.Expr] = {}
    w = a.w
    if a.representation == "quaternion":
        qd = (a.q0 * sp.eye(3) + _hat(a.q)) * w / 2
        for k in range(3):
            rates[a.q[k]] = qd[k]
        rates[a.q0] = -(a.q.T * w)[0, 0] / 2
    elif a.representation == "mrp":
        from formsync_design.spec.agent_view import mrp_G

        sd = mrp_G(a.sigma) * w
        for k in range(3):
            rates[a.sigma[k]] = sd[k]
    else:
        Rd = a.R * _hat(w)
        for i in range(3):
            for j in range(3):
                rates[a.R[i, j]] = Rd[i, j]
    return rates


def _hat(w: Any) -> sp.Matrix:
    return sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


@dataclass(frozen=True)
class AgentClosedLoop:
    """The closed loop of one spacecraft (module docstring).

    Attributes
    ----------
    view : AgentView
    u : 3x1 Matrix (the design's torque)
    wdot : 3x1 Matrix (``J^{-1}(u - w x J w + d)``)
    rates : dict symbol -> derivative (every symbol of the view that moves)
    disturbance : 3x1 Matrix of the symbols ``d_1..3``
    """

    view: AgentView
    u: sp.Matrix
    wdot: sp.Matrix
    rates: Mapping[sp.Symbol, sp.Expr]
    disturbance: sp.Matrix


def agent_closed_loop(design: AgentDesign, m: int) -> AgentClosedLoop:
    """The closed loop of a spacecraft of ``design`` with ``m`` in-neighbours (module docstring)."""
    ex = agent_expressions(design, m)
    v: AgentView = ex["view"]
    d = sp.Matrix(sp.symbols("d_1:4", real=True))
    Jinv = v.J.inv()
    wdot = Jinv * (ex["u"] - v.w.cross(v.J * v.w) + d)
    rates: dict[sp.Symbol, sp.Expr] = dict(_kinematics(v.own))
    for k in range(3):
        rates[v.w[k]] = wdot[k]
    for name, size in design.decl.states:
        for k in range(size):
            rates[v.z[name][k]] = ex["states"][name][k]
    for n in v.nbrs:
        rates.update(_kinematics(n))
        for k in range(3):
            rates[n.w[k]] = sp.Symbol(f"wdot_{n.tag}_{k + 1}", real=True)
        for name, size in design.decl.states:
            for k in range(size):
                rates[n.z[name][k]] = sp.Symbol(f"{name}dot_{n.tag}_{k + 1}", real=True)
    if design.decl.leader:
        rates.update(_kinematics(v.ref))
        for k in range(3):
            rates[v.ref.w[k]] = v.ref.wdot[k]
            rates[v.ref.wdot[k]] = sp.Symbol(f"wddot_ref_{k + 1}", real=True)
    rates[v.t] = sp.Integer(1)
    return AgentClosedLoop(view=v, u=ex["u"], wdot=wdot, rates=rates, disturbance=d)


def time_derivative(expr: Any, loop: AgentClosedLoop | Mapping[sp.Symbol, Any]) -> Any:
    """``d/dt expr`` along the closed loop (chain rule over every moving symbol); a matrix is
    differentiated entrywise.  The switching function ``sgn`` has derivative 0 (its jumps are
    a separate argument of the design)."""
    rates = loop.rates if isinstance(loop, AgentClosedLoop) else loop
    e = sp.sympify(expr)
    if isinstance(e, sp.MatrixBase):
        return e.applyfunc(lambda x: time_derivative(x, rates))
    out = sp.Integer(0)
    for s in e.free_symbols:
        r = rates.get(s)
        if r is not None and r != 0:
            out += sp.diff(e, s) * r
    return out


@dataclass(frozen=True)
class ConditionContext:
    """What a design's ``conditions(c)`` hook receives.

    Attributes
    ----------
    design : AgentDesign
    graph : Digraph
    gains : dict name -> positive scalar symbol (controller gains and multipliers)
    closed_loop : callable ``m -> AgentClosedLoop``
    time_derivative : the function :func:`time_derivative`
    """

    design: AgentDesign
    graph: Any
    gains: Mapping[str, sp.Symbol]
    closed_loop: Callable[[int], AgentClosedLoop]
    time_derivative: Callable[..., Any] = field(default=time_derivative)


@dataclass(frozen=True)
class AgentConditions:
    """An agent design's certificate on a graph (a ``ConditionsLike``): ``families`` that
    must be ``> 0`` on the whole box of ``gains``.

    Attributes
    ----------
    design : str; graph : Digraph; gains : tuple of str (box order)
    families : tuple of MatrixFamily
    source : str (``"agent:<design name>"``)
    """

    design: str
    graph: Any
    gains: tuple[str, ...]
    families: tuple[MatrixFamily, ...]
    source: str = "agent"


def agent_conditions(design: AgentDesign, graph: Any) -> AgentConditions:
    """Call the design's ``conditions(c)`` hook on ``graph`` and build the families.

    Raises
    ------
    DerivationError
        The design has no ``conditions`` hook, or it returns something else than a list of
        ``(name, symmetric matrix, row_labels)`` polynomial in the gains with rational
        coefficients (one line naming the file).

    Examples
    --------
    ``V = w^T J w / 2`` under ``u = -k J w`` gives ``V' = -k w^T J^2 w``: the condition
    ``k > 0`` (a 1x1 family), decided over a box by the exact re-check:

    >>> from formsync_design.certify.engine import certify_box
    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> def conds(c):
    ...     return [("damping", sp.Matrix([[c.gains["k"]]]), ("w",))]
    >>> d = agent_design_from_functions(lambda v: -v.k * v.J * v.w, gains={"k": {}},
    ...                                 conditions=conds)
    >>> ac = agent_conditions(d, "path:2")
    >>> ac.families[0].name, str(certify_box(ac, {"k": "1/2:2"}).status)
    ('damping', 'certified')
    """
    from formsync_design.graphs.theorem import as_digraph

    where = design.path
    hook = design.module.get("conditions")
    if not callable(hook):
        raise DerivationError(f"{where}: expected a function conditions(c) for a certificate of "
                              f"the agent design {design.name}, received none")
    g = as_digraph(graph)
    names = design.decl.family_gains
    syms = {n: design.decl.gain(n).symbol for n in names}
    cache: dict[int, AgentClosedLoop] = {}

    def loop(m: int) -> AgentClosedLoop:
        if m not in cache:
            cache[m] = agent_closed_loop(design, m)
        return cache[m]

    ctx = ConditionContext(design=design, graph=g, gains=syms, closed_loop=loop)
    try:
        raw = hook(ctx)
    except DerivationError:
        raise
    except Exception as e:  # a user's function: report, don't crash
        raise DerivationError(f"{where}: conditions(c): the function raised "
                              f"{type(e).__name__}: {' '.join(str(e).split())}") from None
    if not isinstance(raw, Sequence) or not raw:
        raise DerivationError(f"{where}: conditions(c): expected a non-empty list of "
                              f"(name, matrix, row_labels), received {type(raw).__name__}")
    gens = tuple(syms[n] for n in names)
    fams = []
    for item in raw:
        if not (isinstance(item, tuple) and len(item) in (2, 3)):
            raise DerivationError(f"{where}: conditions(c): expected (name, matrix, row_labels) "
                                  f"items, received {item!r}"[:300])
        name, M = str(item[0]), sp.Matrix(item[1])
        labels = tuple(item[2]) if len(item) == 3 else ()
        extra = sorted(str(s) for s in M.free_symbols - set(gens))
        if extra:
            raise DerivationError(f"{where}: conditions(c): expected {name} in the gains "
                                  f"{list(names)} only, received the symbols {extra}")
        try:
            fams.append(family_from_sympy(name, M, gens, block_size=1, row_labels=labels))
        except ValueError as e:
            raise DerivationError(f"{where}: conditions(c): {name}: {e}") from None
    return AgentConditions(design=design.name, graph=g, gains=names, families=tuple(fams),
                           source=f"agent:{design.name}")
