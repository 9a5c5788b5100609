"""Case files of agent designs (TOML, read with :func:`formsync_design.tomlio.load_toml`).

One case layout for every agent design (:mod:`formsync_design.spec.agent`): the base case
of an engine case (:mod:`formsync_design.verify.enginecase`, which adds the engine's tables),
read by the agent commands with :func:`load_agent_case`::

    [case]          name, title, source, kind, design = "NAME" | "file.py" (required),
                    assumptions = ["...", ...],
                    graph = "ring:5" | "edges.txt" (relative to the case file) (or [graph])
    [graph]         arcs = [[i, j, a_ij], ...] (1-based: i receives from j; j = 0 pins i to
                    the leader with gain a_ij), n (optional), pinning = [b_1, ..., b_N]
    [gains]         the design's controller gains (a diagonal gain: one number or [x, y, z])
    [reference]     attitude = [q1, q2, q3, q0] (or euler_deg), rate = ["expr in t", ...]
                    (rad/s, body frame; formulas read by formsync_design.safeexpr, never
                    evaluated); required exactly when the design declares LEADER
    [orbit]         altitude_km, mu, earth_radius_km   (for the disturbance models)
    [disturbance]   as in formation cases (model = "paper" | "none" | "constant" | ...)
    [simulation]    tf, output_step, step, integrator, switch, boundary_layer, torque_limit
                    (N m or "unlimited"), angle_tol (deg), rate_tol (rad/s), rtol, atol,
                    period (s, periodic sampling)
    [[spacecraft]]  inertia = 3x3, rate = [3], and one of q = [q1, q2, q3] (q0 > 0),
                    quaternion = [q1, q2, q3, q0] (unit, any sign), euler_deg = [phi, theta,
                    psi] (3-2-1: R = Rz(psi) Ry(theta) Rx(phi), body to inertial);
                    optional states = {name = [...]} (initial controller states)

Bad input is a one-line :class:`~formsync_design.errors.InputError` naming the table and key.

>>> import tempfile, pathlib
>>> p = pathlib.Path(tempfile.mkdtemp()) / "c.toml"
>>> _ = p.write_text('''
... [case]
... design = "damper.py"
... graph = "path:2"
... [gains]
... k = 1.0
... [[spacecraft]]
... inertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
... rate = [0.1, 0, 0]
... euler_deg = [0, 0, 90]
... [[spacecraft]]
... inertia = [[2, 0, 0], [0, 2, 0], [0, 0, 2]]
... rate = [0, 0, 0]
... q = [0, 0, 0]
... ''')
>>> _ = (p.parent / "damper.py").write_text(
...     'FORM = "agent"\\nGAINS = {"k": {}}\\ndef controller(v):\\n    return -v.k * v.w\\n')
>>> c = load_agent_case(p, trust=[p.parent / "damper.py"])  # a design file: your word
>>> c.n, c.graph().name, [round(float(x), 6) for x in c.attitudes[0]]
(2, 'path:2', [0.0, 0.0, 0.707107, 0.707107])
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.models.disturbances import Orbit
from formsync_design.sim.agents import AgentFormation, AgentOptions, Reference
from formsync_design.sim.formation import Gains
from formsync_design.sim.reference_rate import reference_rate_expressions
from formsync_design.textio import read_bytes
from formsync_design.tomlio import load_toml
from formsync_design.verify.case import (
    case_matrix,
    case_name,
    case_number,
    case_numbers,
    case_orbit,
    case_path,
    check_case_tables,
    make_disturbance,
)

__all__ = ["ENGINE_TABLES", "AgentCase", "load_agent_case", "parse_agent_case", "euler321_to_quat",
           "case_design_ref", "case_is_agent", "shipped_agent_case", "formation_case_path",
           "formation_inertias"]

#: The tables an engine case (``[case] kind = "engine"``, :mod:`formsync_design.verify.enginecase`)
#: adds to the agent case layout; :func:`load_agent_case` reads such a file's base case without them.
ENGINE_TABLES = ("formations", "scenarios", "montecarlo", "families", "report", "metrics",
                 "claims")

_TABLES: dict[str, set[str] | None] = {
    "case": {"name", "title", "source", "kind", "design", "assumptions", "graph"},
    "graph": {"arcs", "n", "pinning"},
    "gains": None,
    "reference": {"attitude", "euler_deg", "rate"},
    "orbit": {"altitude_km", "mu", "earth_radius_km"},
    "disturbance": {"model", "signs", "vector", "amplitude", "frequency", "offset"},
    "simulation": {"tf", "output_step", "step", "integrator", "switch", "boundary_layer",
                   "torque_limit", "angle_tol", "rate_tol", "rtol", "atol", "period"},
    "spacecraft": {"inertia", "rate", "q", "quaternion", "euler_deg", "states", "name"},
}


def euler321_to_quat(phi_deg: float, theta_deg: float, psi_deg: float) -> np.ndarray:
    """``(q1, q2, q3, q0)`` of ``R = Rz(psi) Ry(theta) Rx(phi)`` (body to inertial; 3-2-1).

    >>> [round(float(x), 6) for x in euler321_to_quat(0, 0, 90)]
    [0.0, 0.0, 0.707107, 0.707107]
    """
    h = [math.radians(a) / 2 for a in (phi_deg, theta_deg, psi_deg)]
    cr, sr = math.cos(h[0]), math.sin(h[0])
    cp, sp_ = math.cos(h[1]), math.sin(h[1])
    cy, sy = math.cos(h[2]), math.sin(h[2])
    q0 = cr * cp * cy + sr * sp_ * sy
    q1 = sr * cp * cy - cr * sp_ * sy
    q2 = cr * sp_ * cy + sr * cp * sy
    q3 = cr * cp * sy - sr * sp_ * cy
    return np.array([q1, q2, q3, q0])


@dataclass(frozen=True)
class AgentCase:
    """A validated agent case (see module docstring).

    Attributes
    ----------
    name, title, source, path, kind : str
    design : the loaded :class:`~formsync_design.spec.agent.AgentDesign`
    design_ref : str - what ``[case] design`` named
    graph_input : the graph specification (a string, or the ``[graph]`` table)
    inertias (N, 3, 3); attitudes (N, 4); rates (N, 3); states : dict name -> (N, k)
    gains : Gains; reference : Reference or None; orbit : Orbit; disturbance : dict
    options : AgentOptions; assumptions : tuple of str
    digest : sha256 of the file's bytes
    """

    name: str
    title: str
    source: str
    path: str
    kind: str
    design: Any
    design_ref: str
    graph_input: Any
    inertias: np.ndarray
    attitudes: np.ndarray
    rates: np.ndarray
    states: dict[str, np.ndarray]
    gains: Gains
    reference: Reference | None
    orbit: Orbit
    disturbance: dict
    options: AgentOptions
    assumptions: tuple[str, ...] = ()
    digest: str = ""

    @property
    def n(self) -> int:
        return int(self.inertias.shape[0])

    def graph(self, spec: Any = None) -> Any:
        """The case's digraph (or ``spec``: a graph spec, file, Graph or Digraph; size checked)."""
        from formsync_design.graphs.digraph_io import digraph_from_edges, make_digraph

        src = self.graph_input if spec is None else spec
        if isinstance(src, dict):
            arcs = src.get("arcs", [])
            if not isinstance(arcs, list) or not all(isinstance(a, list) for a in arcs):
                raise InputError(f"expected graph.arcs = [[i, j, a_ij], ...] in {self.path}, "
                                 f"received {repr(arcs)[:60]}")
            g = digraph_from_edges([tuple(a) for a in arcs], n=src.get("n", self.n),
                                   pinning=src.get("pinning"), name=f"{self.name}-graph")
        else:
            g = make_digraph(src)
        if g.n != self.n:
            raise InputError(f"expected a graph of {self.n} spacecraft (the case has {self.n}), "
                             f"received {g.name!r} with {g.n}")
        return g

    def pinning_rule(self, n: int) -> tuple[tuple[Any, ...], str] | None:
        """The case's pinning gains for a graph of ``n`` spacecraft and the rule, in words
        (None when the case pins no spacecraft).

        The case's own size keeps its gains; another size keeps the case's rule: every
        spacecraft pinned with one gain ``b``, or spacecraft 1 alone.  Other pinnings give no
        rule for another size (:class:`~formsync_design.errors.InputError`).

        >>> from formsync_design.resources import case_file
        >>> pins, rule = load_agent_case(case_file("lv2012")).pinning_rule(3)
        >>> [str(b) for b in pins], rule
        (['1', '1', '1'], 'every spacecraft pinned with b = 1 (the rule of the case lv2012)')
        """
        pins = tuple(self.graph().pinning)
        if not any(b > 0 for b in pins):
            return None
        if n == self.n:
            return pins, f"the pinning gains of the case {self.name}"
        if len(set(pins)) == 1:
            return (pins[0],) * n, f"every spacecraft pinned with b = {pins[0]} (the rule of the case {self.name})"
        if pins[0] > 0 and not any(pins[1:]):
            return ((pins[0],) + (pins[0] * 0,) * (n - 1),
                    f"spacecraft 1 pinned with b = {pins[0]} (the rule of the case {self.name})")
        raise InputError(
            f"expected a graph with pinning gains for {n} spacecraft, received a graph without: the "
            f"case {self.name} pins its {self.n} spacecraft with {[str(b) for b in pins]}, which "
            "gives no rule for another size; give --graph as an edge-list file with 'i 0 b' lines")

    def cycled(self, n: int) -> AgentCase:
        """The case resized to ``n`` spacecraft: spacecraft ``i`` takes the inertia, initial
        attitude, rate and controller states of the case's spacecraft ``i % self.n`` (as a
        sweep's Lagrangian Monte-Carlo cycles inertias); the graph is then given to
        :meth:`formation` (the case's own graph keeps its size).

        >>> from formsync_design.resources import case_file
        >>> c = load_agent_case(case_file("ma_so3")).cycled(7)
        >>> c.n, bool((c.inertias[5] == c.inertias[0]).all())
        (7, True)
        """
        idx = [i % self.n for i in range(n)]
        return replace(self, inertias=self.inertias[idx], attitudes=self.attitudes[idx],
                       rates=self.rates[idx], states={k: v[idx] for k, v in self.states.items()})

    def formation(self, graph: Any = None, gains: Gains | None = None,
                  disturbance: str | None = None) -> AgentFormation:
        """The :class:`AgentFormation` (optionally another graph, gains or disturbance model)."""
        d = dict(self.disturbance) if disturbance is None else {"model": disturbance}
        return AgentFormation(self.graph(graph), self.inertias, self.attitudes, self.rates,
                              gains if gains is not None else self.gains,
                              make_disturbance(d, self.inertias, self.orbit), self.reference,
                              dict(self.states))


def load_agent_case(path: str | Path, design: Any = None, *, trust: Any = ()) -> AgentCase:
    """Load and validate an agent case file (``design``: overrides ``[case] design``;
    ``trust``: design files the case may name, :mod:`formsync_design.spec.trust`)."""
    from formsync_design.spec.trust import trusting

    with trusting(*trust):
        return _load_agent_case(Path(path), design)


def _load_agent_case(p: Path, design: Any) -> AgentCase:
    data = load_toml(p, "case TOML file")
    meta = data.get("case")
    if isinstance(meta, dict) and meta.get("kind") == "engine":  # its base case (the engine's
        data = {k: v for k, v in data.items() if k not in ENGINE_TABLES}  # tables: enginecase)
    case = parse_agent_case(data, str(p), design=design)
    return replace(case, digest=hashlib.sha256(read_bytes(p, "case TOML file")).hexdigest())


def case_design_ref(path: str | Path) -> str | None:
    """The ``[case] design`` (or its old name ``spec``) of a case file, ``None`` when the file
    does not exist or names none.

    >>> from formsync_design.resources import case_file
    >>> case_design_ref(case_file("ma_so3"))
    'ma_so3'
    """
    p = Path(path)
    if not p.is_file():
        return None
    meta = load_toml(p, "case TOML file").get("case", {})
    ref = meta.get("design", meta.get("spec")) if isinstance(meta, dict) else None
    return ref if isinstance(ref, str) else None


def case_is_agent(path: str | Path) -> bool:
    """Whether the case file's ``[case] design`` names an agent design (``FORM = "agent"``);
    ``False`` for a Lagrangian design, a case of a design with a Lagrangian view (the
    Lagrangian readers run that view) or a missing file; a design that does not load raises
    its one-line error.

    >>> from formsync_design.resources import case_file
    >>> case_is_agent(case_file("ma_so3")), case_is_agent(case_file("liang2016"))
    (True, False)
    >>> case_is_agent(case_file("pd_consensus"))
    False
    """
    ref = case_design_ref(path)
    if ref is None:
        return False
    d = _design_of(ref, str(path))
    if getattr(d, "form", None) != "agent":
        return False
    # a case of a design with a Lagrangian view is the paper's case: the Lagrangian readers keep it
    return getattr(d, "lagrangian", None) is None


def shipped_agent_case(design: Any) -> Path | None:
    """The shipped case file (``verification/NAME.toml``) whose ``[case] design`` names
    ``design`` (by name or file stem), ``None`` when none does.

    >>> from formsync_design.spec.loader import load_design
    >>> shipped_agent_case(load_design("ma_so3")).name
    'ma_so3.toml'
    """
    from formsync_design.resources import case_file, case_names

    for name in case_names():
        ref = case_design_ref(case_file(name))
        if ref == design.name or (ref is not None and Path(ref).stem == design.name):
            return case_file(name)
    return None


def formation_case_path(design: Any) -> Path | None:
    """The shipped case that simulates ``design``: its own (:func:`shipped_agent_case`), else
    a shipped engine case comparing it (a ``[[scenarios]]`` row with ``design``); ``None``
    when none.

    >>> from formsync_design.spec.loader import load_design
    >>> formation_case_path(load_design("ma_quat_smc")).name
    'ma_so3.toml'
    """
    own = shipped_agent_case(design)
    if own is not None:
        return own
    from formsync_design.resources import case_file, case_names

    for name in case_names():
        path = case_file(name)
        rows = load_toml(path, "case TOML file").get("scenarios", [])
        if isinstance(rows, list) and any(
                isinstance(c, dict) and c.get("design") == design.name for c in rows):
            if case_is_agent(path):
                return path
    return None


def formation_inertias(design: Any, n: int) -> tuple[np.ndarray, str]:
    """The inertias of an ``n``-spacecraft formation of ``design`` and where they come from:
    the shipped case that simulates it (:func:`formation_case_path`), else the paper's case
    (``verification/liang2016.toml``), cycled ``i mod`` its size when ``n`` differs.

    >>> from formsync_design.spec.loader import load_design
    >>> J, note = formation_inertias(load_design("ma_so3"), 7)
    >>> J.shape, note
    ((7, 3, 3), 'inertias of verification/ma_so3.toml, cycled to N = 7 (spacecraft i takes J_(i mod 5))')
    """
    path = formation_case_path(design)
    if path is None:
        from formsync_design.verify.case import load_case

        paper = load_case()
        J = np.asarray(paper.inertias, dtype=float)
        note = f"inertias of the {paper.name} case (no shipped case simulates {design.name})"
    else:
        J = np.asarray(load_agent_case(path).inertias, dtype=float)
        note = f"inertias of {path.parent.name}/{path.name}"
    if len(J) != n:
        note += f", cycled to N = {n} (spacecraft i takes J_(i mod {len(J)}))"
    return J[np.arange(n) % len(J)], note


def _design_of(ref: str, path: str) -> Any:
    """The design a case file at ``path`` names: a shipped name, else a trusted file beside
    it (:func:`~formsync_design.spec.trust.resolve_design_ref`)."""
    from formsync_design.spec.loader import load_design
    from formsync_design.spec.trust import resolve_design_ref

    return load_design(resolve_design_ref(ref, path, "case.design"))


def _resolve_design(ref: str, path: str) -> Any:
    from formsync_design.spec.lagrangian_agent import agent_of

    return agent_of(_design_of(ref, path), f" in [case] design of {path}")


def parse_agent_case(data: dict, path: str = "<memory>", design: Any = None) -> AgentCase:
    """Validate a parsed agent case document (module docstring)."""
    check_case_tables(data, _TABLES, path)
    meta = data.get("case", {})
    if design is None:
        ref = meta.get("design")
        if not isinstance(ref, str) or not ref:
            raise InputError(f"expected [case] design = \"NAME\" or a design file in {path}, "
                             f"received {ref!r}")
        d = _resolve_design(ref, path)
    else:
        from formsync_design.spec.lagrangian_agent import agent_of
        from formsync_design.spec.loader import load_design

        d = load_design(design)
        ref = getattr(d, "path", str(design))
        d = agent_of(d, "")
    sc = data.get("spacecraft")
    if not sc or len(sc) < 2:
        raise InputError(f"expected at least two [[spacecraft]] tables in {path}, received "
                         f"{len(sc) if sc else 0}")
    J, A, W = [], [], []
    state_rows: dict[str, list[Any]] = {name: [] for name, _ in d.decl.states}
    for i, s in enumerate(sc, start=1):
        for key in ("inertia", "rate"):
            if key not in s:
                raise InputError(f"expected spacecraft {i} to have '{key}', received keys {sorted(s)}")
        J.append(case_matrix(s["inertia"], f"spacecraft {i} inertia"))
        W.append(case_numbers(s["rate"], f"spacecraft {i} rate", 3))
        A.append(_attitude(s, f"spacecraft {i}"))
        st = s.get("states", {})
        if not isinstance(st, dict) or set(st) - set(state_rows):
            raise InputError(f"expected spacecraft {i} states among {sorted(state_rows)}, "
                             f"received {st!r}")
        for name, k in d.decl.states:
            state_rows[name].append(case_numbers(st[name], f"spacecraft {i} states.{name}", k)
                                    if name in st else [0.0] * k)
    g = data.get("gains", {})
    ctrl = d.decl.controller_gains
    if not isinstance(g, dict) or set(g) != set(ctrl):
        got = sorted(g) if isinstance(g, dict) else repr(g)
        raise InputError(f"expected [gains] with exactly {list(ctrl)} (the gains of design "
                         f"{d.name}) in {path}, received {got}")
    gvals: dict[str, Any] = {}
    for k in ctrl:
        diag = str(d.decl.gain(k).kind) == "diag"
        gvals[k] = (tuple(case_numbers(g[k], f"gains.{k}", 3)) if diag and isinstance(g[k], list)
                    else case_number(g[k], f"gains.{k}"))
    ref_t = data.get("reference")
    if d.decl.leader and ref_t is None:
        raise InputError(f"expected a [reference] table for design {d.name} (it declares a "
                         f"leader) in {path}, received none")
    if ref_t is not None and not d.decl.leader:
        raise InputError(f"expected no [reference] for design {d.name} (no leader) in {path}, "
                         "received one")
    reference = None
    if ref_t is not None:
        att = _attitude(ref_t, "reference", default=[0.0, 0.0, 0.0, 1.0])
        rate = ref_t.get("rate", ["0", "0", "0"])
        if not (isinstance(rate, list) and len(rate) == 3
                and all(isinstance(r, (str, int, float)) and not isinstance(r, bool) for r in rate)):
            raise InputError(f"expected reference.rate = three expressions in t in {path}, "
                             f"received {rate!r:.80}")
        exprs = reference_rate_expressions([str(r) for r in rate], "reference.rate", path)
        reference = Reference(tuple(att), exprs)  # type: ignore[arg-type]
    sim = dict(data.get("simulation", {}))
    kw: dict[str, Any] = {}
    for k, v in sim.items():
        name = "phi" if k == "boundary_layer" else k
        if k in ("switch", "integrator"):
            if not isinstance(v, str):
                raise InputError(f"expected a string for simulation.{k}, received {v!r}")
            kw[name] = v
        elif k == "torque_limit" and v in ("none", "unlimited"):
            kw[name] = None
        else:
            kw[name] = case_number(v, f"simulation.{k}")
    options = AgentOptions(**kw)
    assumptions = meta.get("assumptions", [])
    if not (isinstance(assumptions, list) and all(isinstance(a, str) for a in assumptions)):
        raise InputError("expected case.assumptions to be a list of strings")
    if "graph" in data and "graph" in meta:
        raise InputError(f"expected one of [case] graph or a [graph] table in {path}, received both")
    graph_input: Any = data.get("graph", meta.get("graph", f"ring:{len(sc)}"))
    if isinstance(graph_input, str):
        if not graph_input.strip():
            raise InputError(f"expected [case] graph as a graph spec or a graph file in {path}, "
                             "received ''")
        graph_input = case_path(graph_input.strip(), path, "case.graph")
    elif not isinstance(graph_input, dict):
        raise InputError(f"expected [case] graph as a graph spec or a graph file (or a [graph] "
                         f"table) in {path}, received {repr(graph_input)[:60]}")
    case = AgentCase(
        name=case_name(meta, path), title=str(meta.get("title", "")),
        source=str(meta.get("source", "")), path=path, kind=str(meta.get("kind", "agents")),
        design=d, design_ref=str(ref), graph_input=graph_input, inertias=np.array(J),
        attitudes=np.array(A), rates=np.array(W),
        states={k: np.array(v) for k, v in state_rows.items()}, gains=Gains(gvals),
        reference=reference, orbit=case_orbit(data.get("orbit", {})),
        disturbance=dict(data.get("disturbance", {"model": "none"})), options=options,
        assumptions=tuple(assumptions),
    )
    case.formation()  # full validation (graph size, inertias, reference vs design, gains)
    return case


def _attitude(s: dict, what: str, default: list[float] | None = None) -> list[float]:
    keys = [k for k in ("q", "quaternion", "euler_deg", "attitude") if k in s]
    if not keys and default is not None:
        return default
    if len(keys) != 1:
        raise InputError(f"expected exactly one of q, quaternion, euler_deg for {what}, "
                         f"received {sorted(s)}")
    k = keys[0]
    if k == "q":
        q = np.array(case_numbers(s["q"], f"{what} q", 3))
        r = 1 - float(q @ q)
        if r <= 0:
            raise InputError(f"expected |q| < 1 for {what} (q0 = +sqrt(1 - |q|^2)), received "
                             f"|q| = {math.sqrt(float(q @ q)):.6g}")
        return [*q.tolist(), math.sqrt(r)]
    if k == "euler_deg":
        return euler321_to_quat(*case_numbers(s[k], f"{what} euler_deg", 3)).tolist()
    qb = np.array(case_numbers(s[k], f"{what} {k}", 4))
    if abs(float(np.linalg.norm(qb)) - 1) > 1e-9:
        raise InputError(f"expected a unit quaternion for {what}, received norm "
                         f"{np.linalg.norm(qb):.12g}")
    return qb.tolist()
