"""Simulation cases in TOML (read with :func:`formsync_design.tomlio.load_toml`, validated strictly).

A case file holds everything physical about a formation run.  Layout
(``verification/liang2016.toml`` is the paper's case and the reference)::

    [case]          name, title, source, graph (a graph spec, e.g. "ring:8"),
                    assumptions = ["...", ...],
                    design = "pd_consensus" or "my_design.py" (optional: a shipped
                    design's name or a design file relative to the case file; default the
                    paper's liang2016; ``spec`` is the old name of this key)
    [gains]         the design's controller gains (liang2016: K_o, K_q, beta; a diagonal
                    gain: one number or [x, y, z]) and its switching gain (liang2016: K_v,
                    one number or one per spacecraft)
    [orbit]         altitude_km (circular), optional mu, earth_radius_km
    [disturbance]   model = "paper" | "gravity-gradient" | "none" | "constant" | "harmonic"
                    paper: signs = [1, 1, 1]; constant: vector = [ux, uy, uz] (N m);
                    harmonic: amplitude = [...], frequency = [...] (rad/s), offset = [...]
    [simulation]    tf, switch, boundary_layer, torque_limit (N m or "unlimited"), sample_period,
                    integrator, step, output_step, rtol, atol, q_tol, omega_tol, q0_floor
    [[spacecraft]]  one table per spacecraft: inertia = 3x3 (kg m^2), rate = [3] (rad/s),
                    and either q = [q1, q2, q3] (then q0 = +sqrt(1 - |q|^2)) or
                    quaternion = [q1, q2, q3, q0] (unit, q0 > 0)

An engine case file (``[case] kind = "engine"``: :mod:`formsync_design.verify.enginecase`,
e.g. ``verification/liang2016.toml``) is read too: its engine tables (``[[formations]]``,
``[[scenarios]]``, ``[montecarlo]``, ``[families]``, ``[report]``, ``[[metrics]]``,
``[[claims]]``) are the engine's and are not read here, nor are the agent kernel's
``[simulation]`` keys (``integrator``, ``rtol``, ``atol``, ``step``, ``period``,
``angle_tol``, ``rate_tol``): the formation simulator keeps its own integrator and
tolerances (``SimOptions``: compiled DOPRI5 at rtol 1e-8 / atol 1e-12, ``q_tol`` 1e-4,
``omega_tol`` 1e-5).

Unreadable files (missing, binary, non-UTF-8, TOML syntax errors), unknown
tables or keys, wrong types, non-unit quaternions, ``q0 <= 0``,
non-SPD inertias and size mismatches raise :class:`InputError`.
"""

from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.graphs.build import make_graph
from formsync_design.models.disturbances import (
    R_EARTH,
    DisturbanceModel,
    Orbit,
    constant_disturbance,
    gravity_gradient_disturbance,
    harmonic_disturbance,
    no_disturbance,
    paper_disturbance,
)
from formsync_design.ranges import check_range, quantity_of
from formsync_design.sim.formation import Formation, Gains, SimOptions
from formsync_design.spec.loader import load_spec
from formsync_design.textio import check_ascii, confined_path, cut, read_bytes
from formsync_design.tomlio import load_toml

__all__ = ["Case", "load_case", "default_case_path", "parse_case", "make_disturbance",
           "case_number", "case_numbers", "case_matrix", "case_orbit", "check_case_tables",
           "case_path", "case_name"]

_TABLES = {
    "case": {"name", "title", "source", "graph", "assumptions", "spec", "design", "kind"},
    "gains": None,  # the design's declared gains (checked against the design below)
    "orbit": {"altitude_km", "mu", "earth_radius_km"},
    "disturbance": {"model", "signs", "vector", "amplitude", "frequency", "offset"},
    "simulation": {
        "tf", "switch", "boundary_layer", "torque_limit", "sample_period", "integrator",
        "step", "output_step", "rtol", "atol", "q_tol", "omega_tol", "q0_floor",
    },
    "spacecraft": {"inertia", "rate", "q", "quaternion", "name"},
}

_SIM_KEYS = {"boundary_layer": "phi"}

#: The engine's tables and the agent kernel's [simulation] keys of an engine case file.
_ENGINE_TABLES = frozenset({"formations", "scenarios", "montecarlo", "families", "report",
                            "metrics", "claims"})
_AGENT_SIM_KEYS = frozenset({"integrator", "rtol", "atol", "step", "period", "angle_tol",
                             "rate_tol"})


def default_case_path() -> Path:
    """``verification/liang2016.toml`` (shipped as ``formsync_design.verification``)."""
    from formsync_design.resources import case_file

    return case_file("liang2016")


@dataclass(frozen=True)
class Case:
    """A validated case.

    Attributes
    ----------
    name, title, source, path : str
    graph_spec : str
    inertias : (N, 3, 3); attitudes : (N, 4) ``(q1, q2, q3, q0)``; rates : (N, 3)
    gains : Gains; orbit : Orbit
    disturbance : dict - the ``[disturbance]`` table (``model`` etc.)
    options : SimOptions - the ``[simulation]`` table over the defaults
    assumptions : tuple of str
    spec : str or None - the specification file named by ``[case] spec`` (resolved
        against the case file's folder), None for the paper's
    digest : str - sha256 of the case file's bytes ("" for a case built in memory)
    """

    name: str
    title: str
    source: str
    path: str
    graph_spec: str
    inertias: np.ndarray
    attitudes: np.ndarray
    rates: np.ndarray
    gains: Gains
    orbit: Orbit
    disturbance: dict
    options: SimOptions
    assumptions: tuple[str, ...] = ()
    spec: str | None = None
    digest: str = ""

    @property
    def n(self) -> int:
        return int(self.inertias.shape[0])

    def graph(self, spec: Any = None) -> Any:
        """The case's graph, or ``spec`` (a graph spec, a ``Graph`` or a ``Digraph``; checked
        against the case size)."""
        from formsync_design.graphs import Digraph

        g = spec if isinstance(spec, Digraph) else make_graph(
            spec if spec is not None else self.graph_spec)
        if g.n != self.n:
            raise InputError(
                f"expected a graph of {self.n} spacecraft (the case has {self.n}), received "
                f"{g.name!r} with {g.n}"
            )
        return g

    def formation(self, graph: Any = None, disturbance: str | None = None) -> Formation:
        """The :class:`Formation` of this case (optionally another graph / disturbance model).

        >>> c = load_case()
        >>> f = c.formation("path:8", "none")
        >>> f.graph.name, f.disturbance.kind
        ('path:8', 'none')
        """
        g = self.graph(graph)
        d = dict(self.disturbance)
        if disturbance is not None:
            d = {"model": disturbance, **({"signs": d["signs"]} if "signs" in d else {})}
        return Formation(g, self.inertias, self.attitudes, self.rates, self.gains,
                         make_disturbance(d, self.inertias, self.orbit))


def make_disturbance(table: dict, inertias: np.ndarray, orbit: Orbit) -> DisturbanceModel:
    """Build a :class:`DisturbanceModel` from a ``[disturbance]`` table."""
    model = table.get("model", "paper")
    n = len(inertias)
    if model == "paper":
        signs = table.get("signs", [1, 1, 1])
        sx, sy, sz = _numlist(signs, "disturbance.signs", 3)
        return paper_disturbance(inertias, orbit, (sx, sy, sz))
    if model == "gravity-gradient":
        return gravity_gradient_disturbance(n, orbit)
    if model == "none":
        return no_disturbance(n)
    if model == "constant":
        if "vector" not in table:
            raise InputError("expected disturbance.vector = [ux, uy, uz] for model 'constant', received none")
        v = np.asarray(_numlist(table["vector"], "disturbance.vector", 3))
        return constant_disturbance(np.tile(v, (n, 1)))
    if model == "harmonic":
        for k in ("amplitude", "frequency"):
            if k not in table:
                raise InputError(f"expected disturbance.{k} for model 'harmonic', received none")
        a = np.asarray(_numlist(table["amplitude"], "disturbance.amplitude", 3))
        w = np.asarray(_numlist(table["frequency"], "disturbance.frequency", 3))
        c = np.asarray(_numlist(table.get("offset", [0, 0, 0]), "disturbance.offset", 3))
        return harmonic_disturbance(n, a, w, c)
    raise InputError(
        f"expected disturbance.model in paper, gravity-gradient, none, constant, harmonic; received {model!r}"
    )


def _num(v: Any, what: str) -> float:
    """A finite number inside the range of its quantity (:func:`~formsync_design.ranges.quantity_of`
    the key ``what``), checked before it is converted or used."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"expected a finite number for {what}, received {_shown(v)}")
    if isinstance(v, float) and not math.isfinite(v):
        raise InputError(f"expected a finite number for {what}, received {v!r}")
    check_range(v, quantity_of(what), what)
    return float(v)


def _shown(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _numlist(v: Any, what: str, size: int | None = None) -> list[float]:
    if not isinstance(v, list):
        raise InputError(f"expected a list of numbers for {what}, received {v!r}")
    out = [_num(x, what) for x in v]
    if size is not None and len(out) != size:
        raise InputError(f"expected {size} numbers for {what}, received {len(out)}")
    return out


def _matrix(v: Any, what: str) -> np.ndarray:
    if not (isinstance(v, list) and len(v) == 3 and all(isinstance(r, list) and len(r) == 3 for r in v)):
        raise InputError(f"expected a 3x3 matrix (list of 3 lists of 3) for {what}, received {v!r}")
    return np.array([[_num(x, what) for x in r] for r in v])


def case_path(text: str, path: str, key: str = "case.graph") -> str:
    """A graph named in the case file at ``path`` (under ``key``): a graph spec (``ring:8``:
    a word, a ``:``, no ``/``) as written, else a file inside the case file's folder (never
    the current folder; an absolute path or one leaving the folder is refused:
    :func:`~formsync_design.textio.confined_path`).

    >>> case_path("ring:8", "cases/c.toml"), case_path("edges.txt", "cases/c.toml")
    ('ring:8', 'cases/edges.txt')
    >>> case_path("/etc/passwd", "cases/c.toml")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected case.graph as a path inside the folder of cases/c.toml ... (an absolute path)
    """
    if _SPEC_LIKE.fullmatch(text) and not (Path(path).parent / text).is_file():
        return check_ascii(text, f"{key} {cut(text, 40)}")
    return str(confined_path(text, path, key))


#: A case's ``name``: ASCII letters, digits, ``_``, ``.``, ``-``, no separator.
_CASE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}")


def case_name(meta: dict, path: str) -> str:
    """``[case] name`` of the case file at ``path`` (default: the file's stem): ASCII
    ``[A-Za-z0-9][A-Za-z0-9_.-]*``, at most 100 characters, never a path (``"../../x"``).

    >>> case_name({"name": "small3"}, "c.toml"), case_name({}, "cases/my case.toml")
    ('small3', 'my case')
    >>> case_name({"name": "../../../x"}, "c.toml")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected case.name in c.toml as ASCII letters, digits, '_', '.', '-' (a letter or digit first, no '/'), received '../../../x'
    """
    if "name" not in meta:
        return Path(path).stem
    name = meta["name"]
    if not isinstance(name, str) or not _CASE_NAME.fullmatch(name):
        raise InputError(f"expected case.name in {path} as ASCII letters, digits, '_', '.', '-' "
                         f"(a letter or digit first, no '/'), received {cut(name, 40)}")
    return name


#: A graph spec as a case file writes it (``ring:8``, ``cycle:5``): never a path out of a folder.
_SPEC_LIKE = re.compile(r"[A-Za-z]+:[^/\\]*")


#: The case files' value checks, public for the other case readers (one line on bad input).
case_number = _num
case_numbers = _numlist
case_matrix = _matrix


def case_orbit(o: dict) -> Orbit:
    """The ``[orbit]`` table (circular: ``altitude_km``, optional ``mu``, ``earth_radius_km``).

    >>> round(case_orbit({"altitude_km": 500}).altitude)
    500000
    """
    return Orbit(
        altitude=_num(o.get("altitude_km", 400.0), "orbit.altitude_km") * 1e3,
        mu=_num(o.get("mu", Orbit.mu), "orbit.mu"),
        earth_radius=_num(o.get("earth_radius_km", R_EARTH / 1e3), "orbit.earth_radius_km") * 1e3,
    )


def load_case(path: str | Path | None = None, *, trust: Any = ()) -> Case:
    """Load and validate a case file (default: the paper's); a shipped case's name
    (``"pd_consensus"``) is that case.  ``trust``: design files the case may name (paths;
    :mod:`formsync_design.spec.trust`).

    >>> c = load_case()
    >>> c.name, c.n, c.graph_spec, c.options.phi
    ('liang2016', 8, 'ring:8', 0.01)
    >>> load_case("pd_consensus").spec
    'pd_consensus'
    """
    from formsync_design.resources import case_file, case_names

    if isinstance(path, str) and path.isidentifier() and not Path(path).exists() \
            and path in case_names():
        path = case_file(path)
    from formsync_design.spec.trust import trusting

    p = Path(path) if path is not None else default_case_path()
    data = load_toml(p, "case TOML file")
    with trusting(*trust):
        case = parse_case(data, str(p))
    return replace(case, digest=hashlib.sha256(read_bytes(p, "case TOML file")).hexdigest())


def _case_design(meta: dict, path: str) -> str | None:
    """``[case] design`` (or its old name ``spec``): a shipped design's name, or a trusted
    design ``.py`` file beside the case file (:func:`~formsync_design.spec.trust.resolve_design_ref`);
    ``None``: the paper's (liang2016)."""
    from formsync_design.spec.trust import resolve_design_ref

    if "spec" in meta and "design" in meta:
        raise InputError(f"expected one of case.design or case.spec in {path}, received both")
    key = "design" if "design" in meta else "spec"
    spec = meta.get(key)
    if spec is None:
        return None
    return str(resolve_design_ref(spec, path, f"case.{key}"))


def check_case_tables(data: dict, tables: dict[str, set[str] | None], path: str) -> None:
    """Every table of ``data`` is one of ``tables`` with only its keys (``None``: free-form);
    ``[[spacecraft]]`` is an array of tables.  One-line :class:`InputError` otherwise.

    >>> check_case_tables({"case": {"name": "x", "colour": 1}}, {"case": {"name"}}, "c.toml")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected keys ['name'] in [case], received unknown ['colour']
    """
    for k, v in data.items():
        if k not in tables:
            raise InputError(f"expected tables {sorted(tables)} in {path}, received unknown [{k}]")
        allowed = tables[k]
        if allowed is None:
            if not isinstance(v, dict):
                raise InputError(f"expected a table [{k}] in {path}, received {_shown(v)}")
            continue
        rows = v if k == "spacecraft" else [v]
        if k == "spacecraft" and not isinstance(v, list):
            raise InputError(f"expected [[spacecraft]] tables in {path}, received {type(v).__name__}")
        for row in rows:
            if not isinstance(row, dict):
                raise InputError(f"expected a table [{k}] in {path}, received {_shown(row)}")
            extra = set(row) - allowed
            if extra:
                raise InputError(f"expected keys {sorted(allowed)} in [{k}], received unknown {sorted(extra)}")


def parse_case(data: dict, path: str = "<memory>") -> Case:
    """Validate a parsed TOML document (see module docstring)."""
    meta = data.get("case", {})
    kind = meta.get("kind") if isinstance(meta, dict) else None
    if kind == "engine":  # the engine's tables and the agent kernel's keys: module docstring
        data = {k: v for k, v in data.items() if k not in _ENGINE_TABLES}
        sim0 = data.get("simulation", {})
        if isinstance(sim0, dict):
            data["simulation"] = {k: v for k, v in sim0.items() if k not in _AGENT_SIM_KEYS}
    check_case_tables(data, _TABLES, path)
    if kind not in (None, "engine"):
        raise InputError(f"expected [case] kind = \"engine\" (a verification case) or no kind "
                         f"(a simulation case) in {path}, received kind {kind!r}")
    sc = data.get("spacecraft")
    if not sc:
        raise InputError(f"expected at least two [[spacecraft]] tables in {path}, received none")
    J, A, W = [], [], []
    for i, s in enumerate(sc, start=1):
        for key in ("inertia", "rate"):
            if key not in s:
                raise InputError(f"expected spacecraft {i} to have '{key}', received keys {sorted(s)}")
        J.append(_matrix(s["inertia"], f"spacecraft {i} inertia"))
        W.append(_numlist(s["rate"], f"spacecraft {i} rate", 3))
        if ("q" in s) == ("quaternion" in s):
            raise InputError(f"expected exactly one of 'q' or 'quaternion' for spacecraft {i}, received {sorted(s)}")
        if "q" in s:
            q = np.array(_numlist(s["q"], f"spacecraft {i} q", 3))
            r = 1 - float(q @ q)
            if r <= 0:
                raise InputError(
                    f"expected |q| < 1 for spacecraft {i} (q0 = +sqrt(1 - |q|^2) > 0), received |q| = "
                    f"{math.sqrt(float(q @ q)):.6g}"
                )
            A.append([*q, math.sqrt(r)])
        else:
            qb = np.array(_numlist(s["quaternion"], f"spacecraft {i} quaternion", 4))
            if abs(float(np.linalg.norm(qb)) - 1) > 1e-9:
                raise InputError(
                    f"expected a unit quaternion for spacecraft {i}, received norm {np.linalg.norm(qb):.12g}"
                )
            if qb[3] <= 0:
                raise InputError(f"expected q0 > 0 for spacecraft {i}, received q0 = {qb[3]:g}")
            A.append(list(qb))
    spec = _case_design(meta, path)
    design = load_spec(spec)
    g = data.get("gains", {})
    if not isinstance(g, dict):
        raise InputError(f"expected a table [gains] in {path}, received {g!r}")
    ctrl, sw = design.decl.controller_gains, design.decl.switching
    want = [*ctrl, *([sw] if sw is not None else [])]
    unknown_gains = sorted(set(g) - set(want))
    if unknown_gains:
        raise InputError(f"expected keys {sorted(want)} in [gains] (the gains of design "
                         f"{design.name}), received unknown {unknown_gains}")
    for k in want:
        if k not in g:
            raise InputError(f"expected gains.{k} in {path}, received none")
    kvs: tuple[float, ...] = ()
    if sw is not None:
        kv = g[sw]
        kvs = (tuple(_numlist(kv, f"gains.{sw}", len(sc))) if isinstance(kv, list)
               else (_num(kv, f"gains.{sw}"),) * len(sc))
    gvals: dict[str, Any] = {}
    for k in ctrl:
        diag = str(design.decl.gain(k).kind) == "diag"
        gvals[k] = (tuple(_numlist(g[k], f"gains.{k}", 3)) if diag and isinstance(g[k], list)
                    else _num(g[k], f"gains.{k}"))
    gains = Gains(gvals, kvs)
    orbit = case_orbit(data.get("orbit", {}))
    sim = data.get("simulation", {})
    kw: dict[str, Any] = {}
    for k, v in sim.items():
        name = _SIM_KEYS.get(k, k)
        if k in ("switch", "integrator"):
            if not isinstance(v, str):
                raise InputError(f"expected a string for simulation.{k}, received {v!r}")
            kw[name] = v
        elif k in ("torque_limit", "sample_period") and v in ("none", "unlimited"):
            kw[name] = None
        else:
            kw[name] = _num(v, f"simulation.{k}")
    options = replace(SimOptions(), **kw)
    assumptions = meta.get("assumptions", [])
    if not (isinstance(assumptions, list) and all(isinstance(a, str) for a in assumptions)):
        raise InputError("expected case.assumptions to be a list of strings")
    dist = dict(data.get("disturbance", {"model": "paper"}))
    graph = meta.get("graph", f"ring:{len(sc)}")
    if not isinstance(graph, str) or not graph.strip():
        raise InputError(f"expected case.graph as a graph spec or a graph file in {path}, "
                         f"received {_shown(graph)}")
    graph_spec = case_path(graph.strip(), path)
    inertias = np.array(J)
    case = Case(
        name=case_name(meta, path),
        title=str(meta.get("title", "")),
        source=str(meta.get("source", "")),
        path=path,
        graph_spec=graph_spec,
        inertias=inertias,
        attitudes=np.array(A),
        rates=np.array(W),
        gains=gains,
        orbit=orbit,
        disturbance=dist,
        options=options,
        assumptions=tuple(assumptions),
        spec=spec,
    )
    # full validation (SPD inertias, graph size, disturbance table) through Formation
    case.formation()
    return case
