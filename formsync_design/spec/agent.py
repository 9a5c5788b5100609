"""Agent designs: a controller written per spacecraft, in any attitude representation.

A design's *Lagrangian view* (:mod:`formsync_design.spec.loader`) writes the torque in the
opaque model matrices ``A, B, Q`` of the quaternion-vector Lagrangian form; a design file may
provide it besides its agent controller (liang2016, pd_consensus: ``lagrangian_controller``
and ``lyapunov``, see :attr:`AgentDesign.lagrangian`).  An **agent design** (module
attribute ``FORM = "agent"``) writes the
torque of spacecraft ``i`` as explicit SymPy expressions in the quantities of its
representation, its in-neighbours' information on a (directed, weighted) graph, a
leader's reference, controller states (filters) and the declared gains.  This is the form
of the SO(3), MRP and output-feedback designs of the source papers.

What a design file declares (besides ``NAME``, ``TITLE``)
---------------------------------------------------------
``FORM = "agent"``
``REPRESENTATION``
    ``"quaternion"`` (``v.q`` 3x1 vector part, ``v.q0``), ``"mrp"`` (``v.sigma``, the
    short set ``|sigma| <= 1``: the shadow switch happens where ``q0`` changes sign) or
    ``"so3"`` (``v.R``, 3x3, body to inertial).  Every spacecraft's body rate is ``v.w``
    and its inertia ``v.J`` (symmetric 3x3 symbols; the numbers of the formation are bound
    at simulation).
``GAINS``, ``GRAPHS``, ``SAMPLING``
    As for every design (:mod:`formsync_design.spec.declarations`); roles ``controller``
    and ``multiplier`` (an agent design has no separate ``switching`` role: a switching
    gain is a controller gain; a design that also provides a Lagrangian view declares its
    ``K_vi`` with role ``switching`` for that view, and it is one controller gain here).  A diagonal gain is ``diag(g_1, g_2, g_3)`` in the view.
``STATES = {"x": 3, ...}`` (optional)
    Controller states per spacecraft (e.g. a lead filter); ``states(v)`` returns their
    derivatives; ``v.z["x"]`` (3x1) in every function, ``v.nbrs[k].z["x"]`` the
    neighbours' (for designs that exchange them).  Initial values: zero unless a case sets them.
``LEADER = True`` (optional, default False)
    The design uses a reference (virtual leader): ``v.b`` (pinning gain ``b_i >= 0``),
    ``v.ref`` with the reference attitude in the same representation, ``v.ref.w`` and
    ``v.ref.wdot`` (the reference body rate and its derivative).
``MEASURED`` (optional)
    The quantities the law may use, among :data:`QUANTITIES` (default: all).  The loader
    checks the controller's (and the states' and trigger's) free symbols against it, so
    e.g. an output-feedback design declaring ``("attitude", "neighbour-attitude")`` is
    proven not to use any angular velocity.
``PLANT`` (optional, default ``"attitude"``) and ``ACTUATORS`` (default ``"torque"``)
    What the law drives.  ``"attitude"``: each spacecraft's rigid-body attitude, with body
    torques, on a communication graph (every function below).  ``"relative-orbit"`` with
    ``ACTUATORS = "thrusters"``: one spacecraft flying a relative orbit about its reference
    (a target) and tracking the reference attitude (``LEADER = True``), in MRPs, sampled
    periodically (``SAMPLING = "periodic"``), no graph (``GRAPHS = ()``); the commanded force
    and torque are realised by the case's thrusters (allocation and pulse-width modulation).
    Its functions are ``controller(v)`` (the torque, from the tracking error ``v.track``),
    ``lyapunov(v)``, ``orbit_controller(v)`` and ``lqr_weights(v)``, and it may declare gains
    of role ``weight``: the contract of :mod:`formsync_design.spec.tracking`.  The attitude
    plant's stages (graph certificates, formation simulation, sweeps) refuse it in one line;
    ``formsync verify`` on its case and ``fs.simulate`` of its scenario run it.

Functions (``v`` is an :class:`AgentView` of spacecraft ``i`` with ``m`` in-neighbours)
--------------------------------------------------------------------------------------
``controller(v)`` (required)
    The body torque ``u_i``, an explicit 3x1 SymPy ``Matrix``.
``states(v)`` (required when ``STATES`` is declared)
    ``{name: derivative}`` (each of the declared size).
``event(v)`` (``SAMPLING = "event"``)
    A scalar ``g``; spacecraft ``i`` broadcasts when ``g >= 0``, monitored continuously.
    ``v.held`` is the spacecraft's own last broadcast (attitude and rate), ``v.nbrs[k]`` the
    neighbours' last broadcasts; ``v`` itself is the current state.
``next_interval(v)`` (``SAMPLING = "self-triggered"``)
    ``tau > 0``: the next broadcast is ``tau`` after this one, computed from the state at
    this broadcast (nothing is monitored in between).
``monitors(v)`` (optional)
    ``{name: scalar}`` quantities recorded along a simulation (e.g. a determinant that
    vanishes where the law is undefined): the result reports each one's extremes.
``HOLD = {"s": 3, ...}`` + ``hold(v)`` (optional, sampled designs)
    Quantities a spacecraft computes and keeps at each of its own updates (e.g. its
    sliding variable at the trigger, built from the neighbours' broadcasts of that instant):
    ``hold(v)`` returns ``{name: kx1}`` from the view of the update instant; ``event(v)`` and
    ``next_interval(v)`` read the kept values as ``v.kept[name]``.  This is how a trigger
    compares "the state error at the last trigger" with "now" (Girard 2015; the patent of
    seed 001).  Designs built from another one's functions with another sampling rule:
    :func:`sampling_variant`.
Under a sampled rule the torque is held between the spacecraft's own updates, and the
neighbours' quantities are their last broadcasts (see :mod:`formsync_design.sim.agents`).

Helpers for the expressions (:mod:`formsync_design.spec.agent_view`, also on every view:
``v.hat``, ``v.sgn``, ...): ``hat``, ``vee``, ``sgn`` (the switching function: ``sign`` in
a derivation, ``sgn``/``sat``/``tanh`` with a boundary layer at simulation time), ``sig``
(``|x|^p sgn(x)`` componentwise), ``mrp_G``, ``quat_E``.

>>> d = agent_design_from_functions(lambda v: -v.k * v.w, name="damper", gains={"k": {}})
>>> d.name, d.decl.representation, d.decl.controller_gains
('damper', 'quaternion', ('k',))
>>> v = AgentView(d.decl, 1)
>>> d.controller(v).T
Matrix([[-k*w_1, -k*w_2, -k*w_3]])
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType, ModuleType
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.spec.agent_declarations import (
    check_agent_functions,
    parse_agent_declarations,
)
from formsync_design.spec.agent_view import QUANTITIES, AgentDeclarations, AgentView, sgn
from formsync_design.spec.dag import free_symbols as dag_free_symbols

__all__ = [
    "AgentDesign",
    "agent_design_from_module",
    "agent_design_from_functions",
    "agent_expressions",
    "uses_switching",
    "sampling_variant",
    "rule_variant",
    "SAMPLING_RULES",
]


@dataclass(frozen=True)
class AgentDesign:
    """An agent design (a value, keyed by its content like :class:`~formsync_design.spec.loader.Spec`).

    Attributes
    ----------
    name, title, path, source, key : str
    decl : AgentDeclarations
    functions : mapping
        ``controller`` and the optional ``states``, ``event``, ``next_interval``, ``monitors``.
    module : dict
        The design file's namespace (other functions a design-specific stage uses, e.g. its
        derivation), not part of the value's identity.

    Examples
    --------
    >>> d = agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}, name="damper")
    >>> isinstance(d, AgentDesign), d.form, d.has("states")
    (True, 'agent', False)
    """

    name: str
    title: str
    path: str
    key: str
    source: str
    decl: AgentDeclarations
    functions: Mapping[str, Callable[[AgentView], Any]]
    module: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    #: the design's Lagrangian view (a :class:`~formsync_design.spec.loader.Spec`) when its file
    #: also provides ``lagrangian_controller(view)`` and ``lyapunov(view)``, else ``None``
    lagrangian: Any = field(default=None, compare=False, repr=False)

    form = "agent"

    @property
    def controller(self) -> Callable[[AgentView], Any]:
        return self.functions["controller"]

    @property
    def representation(self) -> str:
        return self.decl.representation

    @property
    def gains(self) -> tuple[str, ...]:
        """The box dimensions (controller gains, then multipliers)."""
        return self.decl.family_gains

    def has(self, function: str) -> bool:
        return function in self.functions

    @staticmethod
    def from_functions(controller: Callable[[AgentView], Any], **declarations: Any) -> AgentDesign:
        """:func:`agent_design_from_functions` (the notebook way, like ``Spec.from_functions``).

        >>> AgentDesign.from_functions(lambda v: -v.k * v.w, gains={"k": {}}).decl.gains[0].name
        'k'
        """
        return agent_design_from_functions(controller, **declarations)


def _call(fn: str, f: Callable[[AgentView], Any], v: AgentView, where: str) -> Any:
    try:
        return f(v)
    except DerivationError as e:
        raise DerivationError(f"{where}: {fn}(view): {e}") from None
    except AttributeError as e:
        if getattr(e, "obj", None) is v and getattr(e, "name", None):
            raise DerivationError(f"{where}: {fn}(view): expected an attribute of the view "
                                  f"({v.attributes()}), received view.{e.name}") from None
        raise DerivationError(f"{where}: {fn}(view): the function raised "
                              f"{type(e).__name__}: {e}") from None
    except Exception as e:  # a user's function: report, don't crash
        msg = " ".join(str(e).split())
        raise DerivationError(f"{where}: {fn}(view): the function raised "
                              f"{type(e).__name__}: {msg}") from None


def _check_symbols(fn: str, expr: Any, v: AgentView, where: str, allowed_extra: set[Any]) -> None:
    cls = v.symbols_by_class()
    always = cls["gains"] | cls["inertia"] | cls["weights"] | cls["states"] | allowed_extra
    measured = set(v.decl.measured)
    allowed = set(always)
    for q in QUANTITIES:
        if q in measured:
            allowed |= cls[q]
    free = dag_free_symbols(expr)
    bad = free - allowed
    if not bad:
        return
    if bad & cls["kept"]:
        raise DerivationError(f"{where}: {fn}(view): expected the kept values v.kept only in "
                              "event(view) and next_interval(view), received a use in "
                              f"{fn.split('(')[0]}")
    provided = set().union(*cls.values())
    unknown = sorted(str(s) for s in bad - provided)
    if unknown:
        raise DerivationError(f"{where}: {fn}(view): expected only the view's symbols "
                              f"({v.attributes()}), received unknown symbols {unknown}")
    used = sorted({q for q in QUANTITIES if cls[q] & bad})
    raise DerivationError(f"{where}: {fn}(view): expected only the MEASURED quantities "
                          f"{list(v.decl.measured)}, received a law that uses {used} "
                          f"({', '.join(sorted(str(s) for s in bad)[:4])})")


def _vector(fn: str, out: Any, size: int, where: str) -> sp.Matrix:
    try:
        M = sp.Matrix(out)
    except Exception:  # noqa: BLE001 - report the type received
        raise DerivationError(f"{where}: {fn}(view): expected an explicit {size}x1 SymPy Matrix, "
                              f"received a {type(out).__name__}") from None
    if M.shape != (size, 1) or any(isinstance(e, sp.MatrixExpr) for e in M):
        raise DerivationError(f"{where}: {fn}(view): expected an explicit {size}x1 SymPy Matrix, "
                              f"received shape {tuple(M.shape)}")
    return M


def _scalar(fn: str, out: Any, where: str) -> sp.Expr:
    try:
        e = sp.sympify(out)
    except (sp.SympifyError, TypeError, ValueError):
        raise DerivationError(f"{where}: {fn}(view): expected a scalar expression, received a "
                              f"{type(out).__name__}") from None
    if isinstance(e, sp.MatrixBase) and e.shape == (1, 1):
        e = e[0, 0]
    if not isinstance(e, sp.Expr):
        raise DerivationError(f"{where}: {fn}(view): expected a scalar expression, received a "
                              f"{type(out).__name__}")
    return e


def uses_switching(design: AgentDesign) -> bool:
    """Whether the law (torque or controller states, one in-neighbour) calls ``sgn``, the
    switching function a simulation realises by its ``switch`` option.

    >>> uses_switching(agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}))
    False
    >>> uses_switching(agent_design_from_functions(lambda v: -v.k * v.sgn(v.w), gains={"k": {}}))
    True
    """
    ex = agent_expressions(design, 1)
    return bool(ex["u"].has(sgn) or any(e.has(sgn) for e in ex.get("states", {}).values()))


def agent_expressions(design: AgentDesign, m: int, where: str | None = None) -> dict[str, Any]:
    """Call every function of ``design`` on the view of a spacecraft with ``m`` in-neighbours.

    Returns ``{"view": v, "u": 3x1, "states": {name: kx1}, "event": g, "next_interval": tau,
    "monitors": {name: expr}}`` (absent keys: the design has no such function); validated
    like at load (one-line :class:`DerivationError` naming the file and the function).

    >>> d = agent_design_from_functions(lambda v: -v.k * v.w, name="damper", gains={"k": {}})
    >>> agent_expressions(d, 0)["u"].T
    Matrix([[-k*w_1, -k*w_2, -k*w_3]])
    """
    where = where or design.path
    decl = design.decl
    if decl.plant != "attitude":
        raise DerivationError(
            f"{where}: PLANT: expected a design on the attitude plant (torques on each "
            f"spacecraft's attitude) for this stage, received {design.name} on the "
            f"{decl.plant} plant (run it with formsync verify on its case, e.g. "
            f"formsync verify {design.name})")
    v = AgentView(decl, m)
    out: dict[str, Any] = {"view": v}
    out["u"] = _vector("controller", _call("controller", design.controller, v, where), 3, where)
    _check_symbols("controller", out["u"], v, where, set())
    if decl.states:
        raw = _call("states", design.functions["states"], v, where)
        if not isinstance(raw, Mapping) or set(raw) != {n for n, _ in decl.states}:
            got = sorted(raw) if isinstance(raw, Mapping) else type(raw).__name__
            raise DerivationError(f"{where}: states(view): expected a dict with the keys "
                                  f"{[n for n, _ in decl.states]}, received {got}")
        out["states"] = {n: _vector(f"states()[{n!r}]", raw[n], k, where) for n, k in decl.states}
        for n, e in out["states"].items():
            _check_symbols(f"states()[{n!r}]", e, v, where, set())
    held = v.symbols_by_class()["held"]
    kept = v.symbols_by_class()["kept"]
    if decl.hold:
        raw = _call("hold", design.functions["hold"], v, where)
        if not isinstance(raw, Mapping) or set(raw) != {n for n, _ in decl.hold}:
            got = sorted(raw) if isinstance(raw, Mapping) else type(raw).__name__
            raise DerivationError(f"{where}: hold(view): expected a dict with the keys "
                                  f"{[n for n, _ in decl.hold]}, received {got}")
        out["hold"] = {n: _vector(f"hold()[{n!r}]", raw[n], k, where) for n, k in decl.hold}
        for n, e in out["hold"].items():
            _check_symbols(f"hold()[{n!r}]", e, v, where, set())
    for fn, extra in (("controller", out["u"]), *(
            (f"states()[{n!r}]", e) for n, e in out.get("states", {}).items()), *(
            (f"hold()[{n!r}]", e) for n, e in out.get("hold", {}).items())):
        if kept & dag_free_symbols(sp.Matrix(extra)):
            raise DerivationError(f"{where}: {fn}: expected the kept values v.kept only in "
                                  "event(view) and next_interval(view), received a use in "
                                  f"{fn.split('(')[0]}")
    if "event" in design.functions:
        out["event"] = _scalar("event", _call("event", design.functions["event"], v, where), where)
        _check_symbols("event", out["event"], v, where, held | kept)
    if "next_interval" in design.functions:
        out["next_interval"] = _scalar(
            "next_interval", _call("next_interval", design.functions["next_interval"], v, where),
            where)
        _check_symbols("next_interval", out["next_interval"], v, where, kept)
    if "monitors" in design.functions:
        raw = _call("monitors", design.functions["monitors"], v, where)
        if not isinstance(raw, Mapping) or not all(isinstance(k, str) for k in raw):
            raise DerivationError(f"{where}: monitors(view): expected a dict name -> scalar, "
                                  f"received {type(raw).__name__}")
        out["monitors"] = {k: _scalar(f"monitors()[{k!r}]", e, where) for k, e in raw.items()}
        for k, e in out["monitors"].items():
            # a monitor observes the run: it may read any quantity of the view
            cls = v.symbols_by_class()
            allowed = set().union(*cls.values()) - cls["kept"]
            bad = sorted(str(s) for s in dag_free_symbols(e) - allowed)
            if bad:
                raise DerivationError(f"{where}: monitors()[{k!r}]: expected only the view's "
                                      f"symbols, received unknown symbols {bad}")
    return out


def _validate(design: AgentDesign, where: str, text: bool = False) -> str:
    # ``text`` (the expressions' srepr, a key of designs built from functions) walks the
    # expression *tree*: only computed when asked for
    if design.decl.plant == "relative-orbit":
        from formsync_design.spec.tracking import validate_tracking

        orbit = validate_tracking(design.functions, where, design.decl)
        return orbit.canonical() if text else ""
    parts = []
    for m in (0, 1, 2):
        ex = agent_expressions(design, m, where)
        if not text:
            continue
        parts.append(sp.srepr(ex["u"]))
        for k in ("states", "event", "next_interval", "monitors", "hold"):
            if k in ex:
                parts.append(sp.srepr(ex[k]))
    return "\n".join(parts)


def agent_design_from_module(mod: ModuleType, where: str, key: str, stem: str) -> AgentDesign:
    """The :class:`AgentDesign` of an executed design module (validated; see module docstring)."""
    return _design_from_attrs(mod.__dict__, where, key, stem)[0]


def _design_from_attrs(attrs: Mapping[str, Any], where: str, key: str,
                       stem: str) -> tuple[AgentDesign, str]:
    """The validated design of a namespace and the text of its expressions."""
    decl = parse_agent_declarations(attrs, where)
    fns = check_agent_functions(attrs, decl, where)
    d = AgentDesign(name=str(attrs.get("NAME", stem)), title=str(attrs.get("TITLE", stem)),
                    path=where, key=key, source=where, decl=decl,
                    functions=MappingProxyType(fns), module=MappingProxyType(dict(attrs)))
    return d, _validate(d, where)


def agent_design_from_functions(controller: Callable[[AgentView], Any], *, name: str = "custom",
                                title: str | None = None, **declarations: Any) -> AgentDesign:
    """An agent design from Python callables (declarations by keyword: ``representation``,
    ``gains``, ``graphs``, ``sampling``, ``states``, ``leader``, ``measured`` and the
    functions ``states_fn``, ``event``, ``next_interval``, ``monitors``, ``conditions``).

    The key digests the declarations and the SymPy expressions the functions return.

    >>> d = agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}, name="a")
    >>> d.key == agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}}, name="a").key
    True
    """
    where = "<python>"
    attrs: dict[str, Any] = {"controller": controller}
    for k in ("representation", "gains", "graphs", "sampling", "states", "leader", "measured",
              "hold"):
        if k in declarations:
            attrs[k.upper()] = declarations.pop(k)
    if "states_fn" in declarations:
        attrs["states"] = declarations.pop("states_fn")
    if "hold_fn" in declarations:
        attrs["hold"] = declarations.pop("hold_fn")
    for fn in ("event", "next_interval", "monitors", "conditions"):
        if fn in declarations:
            attrs[fn] = declarations.pop(fn)
    if declarations:
        raise DerivationError(f"{where}: expected declarations among representation, gains, "
                              "graphs, sampling, states, leader, measured, hold, states_fn, "
                              "hold_fn, event, next_interval, monitors, conditions; received "
                              f"{sorted(declarations)}")
    decl = parse_agent_declarations(attrs, where)
    fns = check_agent_functions(attrs, decl, where)
    extra = MappingProxyType({k: v for k, v in attrs.items() if k == "conditions"})
    d = AgentDesign(name=name, title=title or name, path=where, key="", source=where, decl=decl,
                    functions=MappingProxyType(fns), module=extra)
    text = _validate(d, where, text=True)
    tokens = [text]
    if "conditions" in extra:
        import inspect

        try:
            tokens.append(inspect.getsource(extra["conditions"]))
        except (OSError, TypeError):
            tokens.append(f"conditions@{id(extra['conditions'])}")
    body = "\n".join(tokens)
    h = hashlib.sha256(f"agent:{name}\n{decl.to_dict()!r}\n{body}".encode()).hexdigest()
    return AgentDesign(name=d.name, title=d.title, path=where, key=h, source=where, decl=decl,
                       functions=d.functions, module=extra)


def sampling_variant(design: AgentDesign, sampling: str, *, name: str | None = None,
                     **functions: Any) -> AgentDesign:
    """The design ``design`` (from a file) under another sampling rule, with the same
    declarations, controller and module namespace.

    ``functions``: the new rule's functions by their contract names (``event``,
    ``next_interval``, ``hold``; ``None`` removes one) and ``HOLD`` (a dict) when the rule
    keeps values.  The key digests the original key, the rule and the new expressions.
    Used to run a self-triggered design's law under event-triggered or periodic sampling
    on the same formation.

    >>> import formsync_design.resources as res
    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("selftrigger_mrp")
    >>> p = sampling_variant(d, "periodic", next_interval=None)
    >>> p.decl.sampling, p.name, p.key != d.key, p.has("next_interval")
    ('periodic', 'selftrigger_mrp-periodic', True, False)
    """
    attrs = dict(design.module)
    if not attrs:
        raise DerivationError(f"expected a design loaded from a file for a sampling variant, "
                              f"received {design.name!r} built from functions")
    attrs["SAMPLING"] = sampling
    for fn in ("event", "next_interval", "hold"):
        attrs.pop(fn, None)
    for fn, f in functions.items():
        if fn == "HOLD":
            attrs["HOLD"] = f
        elif fn not in ("event", "next_interval", "hold"):
            raise DerivationError(f"{design.path}: expected variant functions among event, "
                                  f"next_interval, hold, HOLD; received {fn!r}")
        elif f is not None:
            attrs[fn] = f
    if "hold" not in attrs:
        attrs.pop("HOLD", None)
    vname = name or f"{design.name}-{sampling}"
    attrs["NAME"] = vname
    where = f"{design.path} ({sampling} variant)"
    d, body = _design_from_attrs(attrs, where, "", vname)
    key = hashlib.sha256(f"{design.key}\nvariant:{sampling}\n{body}".encode()).hexdigest()
    return AgentDesign(name=d.name, title=f"{design.title} ({sampling} sampling)", path=design.path,
                       key=key, source=design.source, decl=d.decl, functions=d.functions,
                       module=d.module)


#: The sampling rules a variant can take (:func:`rule_variant`).
SAMPLING_RULES = ("continuous", "periodic", "event", "self-triggered")


def rule_variant(design: AgentDesign, rule: str) -> AgentDesign:
    """``design`` under the sampling rule ``rule``, its functions from the design file:
    the design itself for its own rule; otherwise :func:`sampling_variant` with the design's
    ``hold`` and ``HOLD`` kept (a rule that keeps values keeps them in every variant) and the
    new rule's function: ``event`` for ``"event"`` (the design's ``event``, else its
    ``event_rule``: an event rule offered beside another sampling rule), ``next_interval``
    for ``"self-triggered"`` (the design's); ``"periodic"`` and ``"continuous"`` need none.
    A rule the file offers no function for is refused (:class:`~formsync_design.errors.
    DerivationError`).

    >>> from formsync_design.spec.loader import load_design
    >>> d = load_design("selftrigger_mrp")
    >>> e = rule_variant(d, "event")
    >>> e.decl.sampling, e.has("event"), dict(e.decl.hold) == dict(d.decl.hold)
    ('event', True, True)
    >>> rule_variant(d, "self-triggered") is d
    True
    """
    if rule not in SAMPLING_RULES:
        raise DerivationError(f"expected a sampling rule among {list(SAMPLING_RULES)}, "
                              f"received {rule!r}")
    if rule == design.decl.sampling:
        return design
    mod = design.module
    fns: dict[str, Any] = {}
    if callable(mod.get("hold")) and rule != "continuous":
        fns["hold"] = mod["hold"]
        fns["HOLD"] = dict(design.decl.hold)
    if rule == "event":
        fn = mod.get("event") if callable(mod.get("event")) else mod.get("event_rule")
        if not callable(fn):
            raise DerivationError(f"{design.path}: expected event(v) or event_rule(v) for the "
                                  f"event-triggered variant of {design.name}, received none")
        fns["event"] = fn
    elif rule == "self-triggered":
        if not callable(mod.get("next_interval")):
            raise DerivationError(f"{design.path}: expected next_interval(v) for the "
                                  f"self-triggered variant of {design.name}, received none")
        fns["next_interval"] = mod["next_interval"]
    return sampling_variant(design, rule, **fns)
