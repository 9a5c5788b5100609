"""The base case of a fly-around engine case (a design on the relative-orbit plant), read and
validated strictly.

An engine case (``[case] kind = "engine"``, :mod:`formsync_design.verify.enginecase`) whose
design is on the relative-orbit plant (``PLANT = "relative-orbit"``) has this base case; its
``[[scenarios]]``, ``[[metrics]]``, ``[[claims]]`` are read by
:mod:`formsync_design.verify.engine_tracking` (a scenario's overrides: :func:`parse_variant`,
:func:`apply_variant`).  Layout (``verification/zhang2014_flyaround.toml`` is the paper's
case)::

    [case]          name, kind = "engine", design (a shipped relative-orbit design or a .py
                    file relative to the case file), title, source, assumptions = [...]
    [target]        a (m), e, i_deg, u_deg (argument of latitude), optional raan_deg
    [chaser]        the same
    [spacecraft]    mass (kg), inertia (3x3, kg m^2), attitude0_deg = [3] (3-2-1, body
                    relative to the desired frame), rate0 = [3] (rad/s, relative)
    [reference]     a, b, c (m), alpha_deg, beta_deg, gamma_deg, phi0_deg, theta0_deg,
                    P1, P2, T (s)
    [thrusters]     layout = "cube-pairs", half_size (m), thrust (N), min_pulse (s),
                    exhaust_velocity (m/s)
    [gains]         the design's gains (a diagonal gain: one number or [x, y, z])
    [simulation]    tf, sample_period, substeps, allocation, carry, reading, steady_from
    [certificate]   K_d_scale, k_p_scale, inertia_scale = [lo, hi], rate_margin

Unknown tables or keys, wrong types, values out of range and gains the design does not
declare raise :class:`~formsync_design.errors.InputError` (exit 2) naming the file.

>>> case = load_flyaround_case()
>>> case.name, case.scenario.mass, case.options.allocation
('zhang2014_flyaround', 2000.0, 'pinv-shift')
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import parse_real
from formsync_design.models.orbit import KeplerElements
from formsync_design.models.relative_reference import FlyaroundParams
from formsync_design.models.thrusters import cube_pairs_layout
from formsync_design.ranges import check_range, quantity_of
from formsync_design.sim.tracking_scenario import ALLOCATIONS, FlyaroundOptions, FlyaroundScenario
from formsync_design.spec.agent import AgentDesign
from formsync_design.spec.declarations import GainKind
from formsync_design.spec.loader import load_design
from formsync_design.textio import read_bytes
from formsync_design.tomlio import load_toml
from formsync_design.verify.case import case_name

__all__ = ["FlyaroundCase", "Variant", "load_flyaround_case", "parse_flyaround_case",
           "parse_variant", "apply_variant", "LAYOUTS", "ENGINE_TABLES"]

#: Thruster layouts a case may name.
LAYOUTS = ("cube-pairs",)

_TABLES: dict[str, set[str] | None] = {
    "case": {"name", "kind", "design", "title", "source", "assumptions"},
    "target": {"a", "e", "i_deg", "u_deg", "raan_deg"},
    "chaser": {"a", "e", "i_deg", "u_deg", "raan_deg"},
    "spacecraft": {"mass", "inertia", "attitude0_deg", "rate0"},
    "reference": {"a", "b", "c", "alpha_deg", "beta_deg", "gamma_deg", "phi0_deg",
                  "theta0_deg", "P1", "P2", "T"},
    "thrusters": {"layout", "half_size", "thrust", "min_pulse", "exhaust_velocity"},
    "gains": None,
    "simulation": {"tf", "sample_period", "substeps", "allocation", "carry", "reading",
                   "steady_from"},
    "certificate": {"K_d_scale", "k_p_scale", "inertia_scale", "rate_margin"},
}
#: The tables of the engine case (read by :mod:`formsync_design.verify.engine_tracking`).
ENGINE_TABLES = ("scenarios", "metrics", "claims", "report")
_VARIANT = ("gains", "thrusters", "simulation", "spacecraft")


@dataclass(frozen=True)
class Variant:
    """A scenario's overrides: the case with some entries replaced (``label``: the
    scenario's name)."""

    label: str
    gains: dict = field(default_factory=dict)
    thrusters: dict = field(default_factory=dict)
    simulation: dict = field(default_factory=dict)
    spacecraft: dict = field(default_factory=dict)


@dataclass(frozen=True)
class FlyaroundCase:
    """A validated fly-around case.

    Attributes
    ----------
    name, title, source, path : str
    design : str
        The design (a shipped name or a resolved file path).
    scenario : FlyaroundScenario
    options : FlyaroundOptions
    steady_from : float
        Start of the steady-state window (s).
    thrusters : dict
        The ``[thrusters]`` table (layout parameters).
    assumptions : tuple of str
    certificate : dict
    digest : str
        sha256 of the case file.
    """

    name: str
    title: str
    source: str
    path: str
    design: str
    scenario: FlyaroundScenario
    options: FlyaroundOptions
    steady_from: float
    thrusters: dict
    assumptions: tuple[str, ...]
    certificate: dict
    digest: str = ""

    @property
    def spec(self) -> AgentDesign:
        return load_design(self.design)


def _table(data: dict, name: str, where: str, required: bool = True) -> dict:
    t = data.get(name)
    if t is None:
        if required:
            raise InputError(f"expected a [{name}] table in {where}, received none")
        return {}
    if not isinstance(t, dict):
        raise InputError(f"expected [{name}] to be a table in {where}, received "
                         f"{type(t).__name__}")
    keys = _TABLES[name]
    if keys is not None:
        unknown = sorted(set(t) - keys)
        if unknown:
            raise InputError(f"expected keys among {sorted(keys)} in [{name}] of {where}, "
                             f"received {unknown}")
    return t


def _num(t: dict, key: str, table: str, where: str, default: Any = None,
         positive: bool = False) -> float:
    if key not in t:
        if default is None:
            raise InputError(f"expected {table}.{key} in {where}, received none")
        return float(default)
    try:
        v = parse_real(t[key], f"{table}.{key}")
        check_range(v, quantity_of(f"{table}.{key}"), f"{table}.{key}")
    except InputError as e:
        raise InputError(f"{where}: {e}") from None
    if positive and v <= 0:
        raise InputError(f"expected {table}.{key} > 0 in {where}, received {v:g}")
    return v


def _vec(t: dict, key: str, table: str, where: str, n: int, default: Any) -> np.ndarray:
    raw = t.get(key, default)
    arr = np.asarray(raw, dtype=object)
    if arr.shape != (n,) and not (n == 9 and arr.shape == (3, 3)):
        raise InputError(f"expected {table}.{key} as {n if n != 9 else '3x3'} numbers in "
                         f"{where}, received shape {arr.shape}")
    q = quantity_of(f"{table}.{key}")
    return np.array([check_range(parse_real(v, f"{table}.{key}"), q, f"{table}.{key}")
                     for v in arr.ravel()], dtype=float)


def _orbit(t: dict, name: str, where: str) -> KeplerElements:
    return KeplerElements.from_degrees(
        a=_num(t, "a", name, where, positive=True), e=_num(t, "e", name, where),
        i=_num(t, "i_deg", name, where), u=_num(t, "u_deg", name, where),
        raan=_num(t, "raan_deg", name, where, default=0.0))


def _gains(spec: AgentDesign, t: dict, where: str) -> dict[str, tuple[float, ...]]:
    names = [g.name for g in spec.decl.gains]
    unknown = sorted(set(t) - set(names))
    if unknown:
        raise InputError(f"expected gains among the design's {names} in [gains] of {where}, "
                         f"received {unknown}")
    out = {}
    for g in spec.decl.gains:
        if g.name not in t:
            raise InputError(f"expected a value for the design's gain {g.name} in [gains] of "
                             f"{where}, received none")
        raw = t[g.name]
        vals = raw if isinstance(raw, list) else [raw]
        width = 3 if g.kind == GainKind.DIAG else 1
        if len(vals) not in ({1, 3} if width == 3 else {1}):
            raise InputError(f"expected gains.{g.name} as {'1 or 3 numbers' if width == 3 else 'a number'} "
                             f"in {where}, received {len(vals)} values")
        nums = tuple(parse_real(v, f"gains.{g.name}") for v in vals)
        if not all(v > 0 for v in nums):
            raise InputError(f"expected gains.{g.name} > 0 in {where}, received {nums}")
        out[g.name] = nums * 3 if width == 3 and len(nums) == 1 else nums
    return out


def _layout(t: dict, where: str) -> Any:
    name = t.get("layout", "cube-pairs")
    if name not in LAYOUTS:
        raise InputError(f"expected thrusters.layout one of {list(LAYOUTS)} in {where}, "
                         f"received {name!r}")
    return cube_pairs_layout(_num(t, "half_size", "thrusters", where, 1.0, positive=True),
                            _num(t, "thrust", "thrusters", where, 25.0, positive=True))


def _options(sim: dict, thr: dict, where: str) -> FlyaroundOptions:
    alloc = sim.get("allocation", "pinv-shift")
    if alloc not in ALLOCATIONS:
        raise InputError(f"expected simulation.allocation one of {list(ALLOCATIONS)} in "
                         f"{where}, received {alloc!r}")
    carry = sim.get("carry", False)
    if not isinstance(carry, bool):
        raise InputError(f"expected simulation.carry true or false in {where}, received "
                         f"{carry!r}")
    sub = sim.get("substeps", 10)
    if not isinstance(sub, int) or isinstance(sub, bool):
        raise InputError(f"expected simulation.substeps an integer in {where}, received {sub!r}")
    try:
        return FlyaroundOptions(
            tf=_num(sim, "tf", "simulation", where, 18000.0, positive=True),
            sample_period=_num(sim, "sample_period", "simulation", where, 0.2, positive=True),
            substeps=sub, allocation=alloc, carry=carry,
            min_pulse=_num(thr, "min_pulse", "thrusters", where, 0.03),
            exhaust_velocity=_num(thr, "exhaust_velocity", "thrusters", where, 2900.0,
                                  positive=True),
            reading=str(sim.get("reading", "corrected")))
    except InputError as e:
        raise InputError(f"{where}: {e}") from None


def parse_variant(row: dict, spec: AgentDesign, where: str, label: str) -> Variant:
    """A scenario row's overrides (``gains``, ``thrusters``, ``simulation``, ``spacecraft =
    {inertia_scale}``), their keys checked (their values: :func:`apply_variant`)."""
    for part in _VARIANT:
        sub = row.get(part, {})
        if not isinstance(sub, dict):
            raise InputError(f"expected {where}.{part} as a table, received {sub!r:.60}")
        allowed = ({g.name for g in spec.decl.gains} if part == "gains"
                   else {"inertia_scale"} if part == "spacecraft" else _TABLES[part])
        assert allowed is not None
        bad = sorted(set(sub) - allowed - ({"steady_from"} if part == "simulation" else set()))
        if bad or (part == "simulation" and "steady_from" in sub):
            raise InputError(f"expected {where}.{part} keys among "
                             f"{sorted(allowed - {'steady_from'})}, received "
                             f"{bad or ['steady_from']}")
    return Variant(label, dict(row.get("gains", {})), dict(row.get("thrusters", {})),
                   dict(row.get("simulation", {})), dict(row.get("spacecraft", {})))


def _certificate(t: dict, where: str) -> dict:
    out: dict[str, Any] = {}
    for key, default in (("K_d_scale", [0.5, 2.0]), ("k_p_scale", [0.5, 2.0]),
                         ("inertia_scale", [0.9, 1.1])):
        v = t.get(key, default)
        if not (isinstance(v, list) and len(v) == 2):
            raise InputError(f"expected certificate.{key} = [lo, hi] in {where}, received {v!r}")
        lo, hi = (parse_real(x, f"certificate.{key}") for x in v)
        if not 0 < lo <= hi:
            raise InputError(f"expected 0 < lo <= hi for certificate.{key} in {where}, "
                             f"received {lo:g}, {hi:g}")
        out[key] = (lo, hi)
    out["rate_margin"] = _num(t, "rate_margin", "certificate", where, 2.0, positive=True)
    if out["rate_margin"] < 1:
        raise InputError(f"expected certificate.rate_margin >= 1 in {where}, received "
                         f"{out['rate_margin']:g}")
    return out


def load_flyaround_case(path: str | Path | None = None, design: Any = None) -> FlyaroundCase:
    """Read and validate the base case of a fly-around case file (default: the shipped
    ``zhang2014_flyaround``; ``design``: overrides ``[case] design``)."""
    from formsync_design.resources import case_file

    p = Path(path) if path is not None else case_file("zhang2014_flyaround")
    return replace(parse_flyaround_case(load_toml(p, "case TOML file"), str(p), design),
                   digest=hashlib.sha256(read_bytes(p, "case TOML file")).hexdigest())


def _design_ref(meta: dict, where: str, design: Any) -> str:
    if design is not None:
        return str(getattr(design, "path", design))
    ref = meta.get("design", "zhang2014_flyaround")
    if not isinstance(ref, str) or not ref:
        raise InputError(f"expected case.design a design name or file in {where}, received "
                         f"{ref!r}")
    from formsync_design.spec.trust import resolve_design_ref

    return str(resolve_design_ref(ref, where, "case.design"))


def parse_flyaround_case(data: dict, where: str = "<memory>", design: Any = None
                         ) -> FlyaroundCase:
    """Validate a parsed fly-around case document's base case (module docstring; the engine
    tables are left to :mod:`formsync_design.verify.engine_tracking`)."""
    unknown = sorted(set(data) - set(_TABLES) - set(ENGINE_TABLES))
    if unknown:
        raise InputError(f"expected tables among {sorted(set(_TABLES) | set(ENGINE_TABLES))} "
                         f"in {where}, received {unknown}")
    meta = _table(data, "case", where)
    if meta.get("kind") != "engine":
        raise InputError(f"expected [case] kind = 'engine' in {where}, received "
                         f"{meta.get('kind')!r}")
    design = _design_ref(meta, where, design)
    spec = load_design(design)
    plant = getattr(spec.decl, "plant", "attitude")
    if plant != "relative-orbit":
        raise InputError(f"expected case.design a design on the relative-orbit plant in {where}, "
                         f"received {spec.name} (on the {plant} plant)")
    sc_t = _table(data, "spacecraft", where)
    ref = _table(data, "reference", where)
    thr = _table(data, "thrusters", where)
    sim = _table(data, "simulation", where, required=False)
    try:
        reference = FlyaroundParams.from_degrees(
            a=_num(ref, "a", "reference", where), b=_num(ref, "b", "reference", where),
            c=_num(ref, "c", "reference", where),
            alpha=_num(ref, "alpha_deg", "reference", where, 0.0),
            beta=_num(ref, "beta_deg", "reference", where, 0.0),
            gamma=_num(ref, "gamma_deg", "reference", where, 0.0),
            phi0=_num(ref, "phi0_deg", "reference", where),
            theta0=_num(ref, "theta0_deg", "reference", where),
            p1=_num(ref, "P1", "reference", where), p2=_num(ref, "P2", "reference", where),
            period=_num(ref, "T", "reference", where))
        scenario = FlyaroundScenario(
            target=_orbit(_table(data, "target", where), "target", where),
            chaser=_orbit(_table(data, "chaser", where), "chaser", where),
            mass=_num(sc_t, "mass", "spacecraft", where, positive=True),
            inertia=_vec(sc_t, "inertia", "spacecraft", where, 9, None).reshape(3, 3),
            reference=reference, layout=_layout(thr, where),
            gains=_gains(spec, _table(data, "gains", where), where),
            attitude0_deg=_vec(sc_t, "attitude0_deg", "spacecraft", where, 3, [0, 0, 0]),
            rate0=_vec(sc_t, "rate0", "spacecraft", where, 3, [0, 0, 0]))
    except InputError as e:
        msg = str(e)
        raise InputError(msg if where in msg else f"{where}: {msg}") from None
    options = _options(sim, thr, where)
    steady = _num(sim, "steady_from", "simulation", where, 1000.0)
    if not 0 <= steady < options.tf:
        raise InputError(f"expected 0 <= simulation.steady_from < tf in {where}, received "
                         f"{steady:g}")
    assumptions = meta.get("assumptions", [])
    if not (isinstance(assumptions, list) and all(isinstance(a, str) for a in assumptions)):
        raise InputError(f"expected case.assumptions a list of strings in {where}")
    return FlyaroundCase(
        name=case_name(meta, where), title=str(meta.get("title", Path(where).stem)),
        source=str(meta.get("source", "")), path=where, design=design, scenario=scenario,
        options=options, steady_from=steady, thrusters=dict(thr),
        assumptions=tuple(assumptions),
        certificate=_certificate(_table(data, "certificate", where, required=False), where))


def apply_variant(case: FlyaroundCase, v: Variant) -> tuple[FlyaroundScenario, FlyaroundOptions]:
    """The scenario and options of the case under a scenario's overrides."""
    where = f"{case.path} (scenario {v.label!r})"
    sc = case.scenario
    if v.gains:
        gains = dict(sc.gains)
        gains.update(_gains(case.spec, {**{k: list(x) for k, x in sc.gains.items()}, **v.gains},
                            where))
        sc = replace(sc, gains=gains)
    if v.thrusters:
        thr = {**case.thrusters, **v.thrusters}
        sc = replace(sc, layout=_layout(thr, where))
    if "inertia_scale" in v.spacecraft:
        s = parse_real(v.spacecraft["inertia_scale"], "inertia_scale")
        if not (math.isfinite(s) and s > 0):
            raise InputError(f"expected inertia_scale > 0 in {where}, received {s:g}")
        sc = replace(sc, inertia=sc.inertia * s, law_inertia=sc.inertia)
    opt = case.options
    sim = {**{k: getattr(opt, k) for k in ("tf", "sample_period", "substeps", "allocation",
                                          "carry", "reading")}, **v.simulation}
    sim.pop("steady_from", None)
    thr = {**case.thrusters, **v.thrusters}
    opt = _options(sim, thr, where)
    return sc, opt
