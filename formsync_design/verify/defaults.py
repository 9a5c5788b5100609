"""What a command uses when it is given only ``--design NAME``: the design's shipped case.

Every ``formsync`` subcommand runs on a shipped design with no other option.  The gains,
the graph, the convergence criterion and the horizon then come from the design's **shipped
case**: the case file under ``verification/`` whose ``[case] design`` names the design (the
case named like the design first), else the case that lists the design as a **comparison
design** (a ``[[scenarios]]`` row with ``design`` and ``gains``, the first one without
``torque_matching``), with the comparison's gains and simulation settings.  A gain no case
gives takes the design's declared default range.
Every default is said in one line (:class:`Defaults`), printed by the command on stderr.

A graph of another size than the case's **resizes** the case: spacecraft ``i`` takes the
inertia, initial attitude, rate (and controller states, switching gain) of the case's
spacecraft ``i % n`` (:func:`cycle_case`; :meth:`AgentCase.cycled
<formsync_design.verify.agentcase.AgentCase.cycled>` for agent cases).

A command that does not apply to a design (a formation stage of a single-spacecraft tracking
design) is a negative finding with its reason (:class:`NotApplicable`, exit status 1), never
a usage error.

>>> from formsync_design.spec.loader import load_design
>>> src = case_source(load_design("liang2016"))  # its engine case names it: its own case
>>> src.label, src.role
('verification/liang2016.toml', 'design')
>>> from formsync_design.spec.loader import load_spec
>>> case_source(load_spec("pd_consensus")).label    # its Lagrangian view: its own case
'verification/pd_consensus.toml'
>>> case_source(load_design("pd_consensus")).label  # its agent form: the same engine case
'verification/pd_consensus.toml'
>>> case_source(load_design("ma_quat_smc")).role    # a comparison design: ma_so3's scenario
'comparison'
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError

__all__ = [
    "CaseSource",
    "Defaults",
    "NotApplicable",
    "case_source",
    "cycle_case",
    "is_tracking",
    "lagrangian_case_for",
    "agent_case_source_doc",
    "resize_note",
]


class NotApplicable(Exception):
    """A command that does not apply to a design: the CLI prints the reason in one line and
    exits 1 (a finding about the design, not a usage error)."""


@dataclass(frozen=True)
class CaseSource:
    """A design's shipped case.

    Attributes
    ----------
    path : Path - the case file
    role : str - ``"design"`` (its ``[case] design`` names the design) or ``"comparison"``
    gains : dict - the comparison's gains (``role == "comparison"``), else empty
    simulation : dict - the comparison's simulation settings (``tf``, ``step``, ``switch``,
        ``phi``), else empty
    """

    path: Path
    role: str
    gains: dict[str, Any] = field(default_factory=dict)
    simulation: dict[str, Any] = field(default_factory=dict)

    @property
    def label(self) -> str:
        """The case as the repository names it (``verification/NAME.toml``)."""
        return f"verification/{self.path.name}"

    def describe(self) -> str:
        """Where the case comes from, in words."""
        if self.role == "comparison":
            return f"{self.label} (where it is the comparison design)"
        return self.label


@dataclass
class Defaults:
    """The defaults a command took, one line each (printed on stderr by the command)."""

    lines: list[str] = field(default_factory=list)

    def add(self, line: str) -> None:
        self.lines.append(line)

    def emit(self, command: str) -> None:
        """Write the lines on stderr, prefixed by the command."""
        import sys

        for line in self.lines:
            sys.stderr.write(f"formsync {command}: {line}\n")
        sys.stderr.flush()


def is_tracking(design: Any) -> bool:
    """Whether ``design`` is a single spacecraft tracking its reference on the relative-orbit
    plant (``PLANT = "relative-orbit"``).

    >>> from formsync_design.spec.loader import load_design
    >>> is_tracking(load_design("zhang2014_flyaround")), is_tracking(load_design("ma_so3"))
    (True, False)
    """
    return getattr(getattr(design, "decl", None), "plant", "attitude") == "relative-orbit"


def _case_ref(doc: dict) -> str | None:
    meta = doc.get("case", {})
    ref = meta.get("design", meta.get("spec")) if isinstance(meta, dict) else None
    return ref if isinstance(ref, str) else None


def case_source(design: Any) -> CaseSource | None:
    """The shipped case of ``design`` (module docstring), ``None`` when no case names it.

    A case whose ``[case] design`` names the design wins (the case named like the design
    first; a case naming no design is the paper's, liang2016's); else the first case listing
    it as a comparison design (a scenario's ``design``).
    """
    from formsync_design.resources import case_file, case_names
    from formsync_design.tomlio import load_toml

    name = str(getattr(design, "name", design))
    names = sorted(case_names(), key=lambda n: (n != name, n))
    docs = [(case_file(n), load_toml(case_file(n), "case TOML file")) for n in names]
    for path, doc in docs:
        ref = _case_ref(doc)
        if ref is None and path.stem == name == "liang2016":
            return CaseSource(path, "design")
        if ref is not None and (ref == name or Path(ref).stem == name):
            return CaseSource(path, "design")
    for path, doc in docs:
        rows = doc.get("scenarios", [])
        for row in (rows if isinstance(rows, list) else ()):
            if isinstance(row, dict) and row.get("design") == name and "torque_matching" not in row:
                sim = {("phi" if k == "boundary_layer" else k): v
                       for k, v in dict(row.get("simulation", {})).items()
                       if k in ("tf", "step", "switch", "boundary_layer")}
                return CaseSource(path, "comparison", dict(row.get("gains", {})), sim)
    return None


def agent_case_source_doc(design: Any, src: CaseSource) -> dict:
    """The case document of a comparison design: the comparison case's spacecraft, graph,
    orbit and disturbance with the comparison's gains and simulation settings (a gain the
    comparison does not give: the lower end of the design's declared range); the leader
    (reference, pinning) is dropped for a design without one."""
    from formsync_design.tomlio import load_toml
    from formsync_design.verify.agentcase import ENGINE_TABLES

    doc = dict(load_toml(src.path, "case TOML file"))
    for table in ENGINE_TABLES:  # "claims" and an engine case's tables
        doc.pop(table, None)
    meta = dict(doc.get("case", {}))
    meta["design"] = design.name
    meta["kind"] = "agents"
    meta["name"] = f"{design.name}-on-{meta.get('name', src.path.stem)}"
    doc["case"] = meta
    gains: dict[str, Any] = {}
    for n in design.decl.controller_gains:
        if n in src.gains:
            gains[n] = src.gains[n]
        else:
            r = design.decl.gain(n).range
            if r is None:
                raise InputError(f"expected --gain {n}=X for design {design.name} ({src.label} "
                                 "gives no value and the design declares no range), received none")
            gains[n] = float(r.lo)
    doc["gains"] = gains
    if not design.decl.leader:
        doc.pop("reference", None)
        g = doc.get("graph")
        if isinstance(g, dict):
            doc["graph"] = {k: v for k, v in g.items() if k != "pinning"}
    sim = {k: v for k, v in dict(doc.get("simulation", {})).items()
           if k not in ("step", "output_step")}
    sim.update({("boundary_layer" if k == "phi" else k): v for k, v in src.simulation.items()})
    out_step = doc.get("simulation", {}).get("output_step")
    if out_step is not None:
        sim["output_step"] = out_step
    if "step" in src.simulation:
        sim["step"] = src.simulation["step"]
    elif "step" in doc.get("simulation", {}):
        sim["step"] = doc["simulation"]["step"]
    doc["simulation"] = sim
    return doc


def lagrangian_case_for(spec: Any, case_arg: Any, defaults: Defaults | None = None) -> Any:
    """The :class:`~formsync_design.verify.case.Case` of a Lagrangian run: ``--case``, else
    the design's shipped case, else the paper's (said in ``defaults``)."""
    from formsync_design.verify.case import load_case

    if case_arg is not None:
        return load_case(case_arg)
    src = case_source(spec)
    if src is not None and src.role == "design":
        case = load_case(src.path)
        if defaults is not None:
            defaults.add(f"case from {src.label} (the shipped case of design {spec.name})")
        return case
    case = load_case()
    if defaults is not None:
        defaults.add(f"case from verification/{Path(case.path).name} (design {spec.name} has no "
                     "shipped case: the paper's spacecraft, disturbance and graph)")
    return case


def cycle_case(case: Any, n: int) -> Any:
    """The Lagrangian ``case`` resized to ``n`` spacecraft: spacecraft ``i`` takes the
    inertia, initial attitude, rate and switching gain of the case's spacecraft ``i % N``
    (the graph is given to :meth:`~formsync_design.verify.case.Case.formation`).

    >>> from formsync_design.verify.case import load_case
    >>> c = cycle_case(load_case(), 3)
    >>> c.n, c.graph("ring:3").n, bool((c.inertias[2] == load_case().inertias[2]).all())
    (3, 3, True)
    >>> cycle_case(load_case(), 10).gains.K_v == load_case().gains.K_v + load_case().gains.K_v[:2]
    True
    """
    from formsync_design.sim import Gains

    if n < 1:
        raise InputError(f"expected a graph of at least one spacecraft, received {n}")
    idx = [i % case.n for i in range(n)]
    kv = case.gains.K_v
    gains = Gains(dict(case.gains.as_dict()), tuple(kv[i] for i in idx)) if kv else case.gains
    return replace(case, inertias=case.inertias[idx], attitudes=case.attitudes[idx],
                   rates=case.rates[idx], gains=gains, graph_spec=f"ring:{n}" if n >= 3 else
                   f"path:{n}")


def resize_note(case_name: str, n_case: int, graph_name: str, n: int) -> str:
    """The line saying how a case was resized to a graph of another size.

    >>> print(resize_note("pd_consensus", 4, "ring:6", 6))  # doctest: +NORMALIZE_WHITESPACE
    graph ring:6 has 6 spacecraft, the case pd_consensus 4: resized, spacecraft i takes the
    data of the case's spacecraft i % 4 (inertia, attitude, rate)
    """
    return (f"graph {graph_name} has {n} spacecraft, the case {case_name} {n_case}: resized, "
            f"spacecraft i takes the data of the case's spacecraft i % {n_case} (inertia, "
            "attitude, rate)")
