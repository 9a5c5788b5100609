"""The Monte-Carlo part of a sweep campaign: its settings (:class:`MonteCarloSpec`, the
``[montecarlo]`` table after validation) and the case its runs take their spacecraft from
(:func:`case_text`: read once, carried in every task so that remote workers need no file).

>>> MonteCarloSpec().to_dict()["runs"]
20
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.sweep.schema import rational_text
from formsync_design.textio import confined_path, read_text

__all__ = ["MonteCarloSpec", "case_text"]


@dataclass(frozen=True)
class MonteCarloSpec:
    """Monte-Carlo settings of a campaign (see :mod:`.montecarlo`).

    ``gains``: ``"reference"`` or ``"recommended"``; ``case``: case TOML (or a
    shipped case's name) whose inertias (cycled when the graph has more spacecraft
    than the case), orbit, disturbance and - for a design with a switching gain -
    ``K_v`` are used (default: the paper's case).  ``switching``: the design's
    switching gain (its key in ``[montecarlo]``, ``K_v`` for liang2016), ``None``
    for a design without one.

    ``agent``: the Monte-Carlo of an agent design (:mod:`formsync_design.sim.agent_montecarlo`,
    as ``formsync montecarlo --design NAME``): ``case`` is an agent case (default: the
    design's shipped case, :func:`~formsync_design.verify.agentcase.shipped_agent_case`)
    whose per-spacecraft data are cycled over the graph's spacecraft
    (:meth:`~formsync_design.verify.agentcase.AgentCase.cycled`); ``tf``, ``step``,
    ``output_step`` are ``None`` unless given (then the case's ``[simulation]`` options);
    ``phases`` and ``K_v`` do not apply.

    ``base``: the folder a relative ``case`` path resolves against (the campaign file's,
    :func:`~formsync_design.sweep.campaign_fields.campaign_base`; not part of the definition);
    ``source``: the campaign file (then ``case`` stays inside ``base``), ``""`` for the
    command line's ``--mc-case``.
    """

    runs: int = 20
    seed: int = 0
    gains: str = "reference"
    case: str = ""
    K_v: Fraction | None = None
    max_angle_deg: float = 100.0
    max_rate: float = 0.9
    phases: bool = True
    tf: float | None = 200.0
    step: float | None = 0.1
    output_step: float | None = 0.5
    disturbance: str = ""
    switching: str | None = "K_v"
    agent: bool = False
    base: str = field(default=".", compare=False)
    source: str = field(default="", compare=False)

    def to_dict(self) -> dict[str, Any]:
        if self.agent:
            return {"runs": self.runs, "seed": self.seed, "gains": self.gains, "case": self.case,
                    "max_angle_deg": self.max_angle_deg, "max_rate": self.max_rate,
                    "tf": self.tf, "step": self.step, "output_step": self.output_step,
                    "disturbance": self.disturbance, "agent": True}
        sw = ({} if self.switching is None else
              {self.switching: None if self.K_v is None else rational_text(self.K_v)})
        return {
            "runs": self.runs, "seed": self.seed, "gains": self.gains, "case": self.case, **sw,
            "max_angle_deg": self.max_angle_deg, "max_rate": self.max_rate, "phases": self.phases,
            "tf": self.tf, "step": self.step, "output_step": self.output_step,
            "disturbance": self.disturbance,
        }


def case_text(mc: MonteCarloSpec, design: Any = None) -> tuple[str, str]:
    """``(path, TOML text)`` of the Monte-Carlo case (a file, a shipped case's name;
    default: the paper's, for an agent design its shipped agent case), read here so that
    workers of a remote cluster need no access to the file.  A design with a switching gain
    needs its value from the case or from ``[montecarlo]``.  ``design``: the campaign's
    design (required for an agent Monte-Carlo, whose case must be an agent case of it; a
    Lagrangian one must not be an agent case)."""
    from formsync_design.verify.agentcase import case_is_agent
    from formsync_design.verify.case import default_case_path, load_case

    if mc.agent:
        return _agent_case_text(mc, design)
    if not mc.case:
        p = default_case_path()
    else:
        p = _named_case(mc.case, mc.base, mc.source)
    if case_is_agent(p):
        raise InputError(f"expected a Lagrangian case in montecarlo.case, received the agent "
                         f"case {mc.case}")
    case = load_case(p)  # validates (InputError for a missing or malformed case)
    if mc.switching is not None and mc.K_v is None and not case.gains.K_v:
        raise InputError(f"expected montecarlo.{mc.switching} (the case {mc.case or p.name} gives "
                         "no switching gain), received none")
    return str(p), read_text(p, "case TOML file")


def _named_case(case: str, base: str = ".", source: str = "") -> Path:
    """``montecarlo.case``: a shipped case's name (unless such a file exists in ``base``),
    else a path relative to ``base`` (inside it when named by the campaign file ``source``)."""
    from formsync_design.resources import case_file, case_names

    p = Path(case) if Path(case).is_absolute() else Path(base) / case
    if case.isidentifier() and case in case_names() and not p.exists():
        return case_file(case)
    if source:
        return confined_path(case, source, "montecarlo.case", base=base)
    return p


def _agent_case_text(mc: MonteCarloSpec, design: Any) -> tuple[str, str]:
    """:func:`case_text` of an agent design: the case parsed for ``design`` and the
    campaign's ``tf``/``step``/``output_step`` checked against its options."""
    from dataclasses import replace

    from formsync_design.verify.agentcase import case_is_agent, load_agent_case, shipped_agent_case

    if not mc.case:
        shipped = shipped_agent_case(design)
        if shipped is None:
            raise InputError(f"expected montecarlo.case (--mc-case) for the agent design "
                             f"{design.name} (no shipped case names it), received none")
        p = shipped
    else:
        p = _named_case(mc.case, mc.base, mc.source)
    if p.is_file() and not case_is_agent(p):
        raise InputError(f"expected an agent case ([case] design naming an agent design) in "
                         f"montecarlo.case for the agent design {design.name}, received the "
                         f"Lagrangian case {mc.case}")
    case = load_agent_case(p, design=design)  # validates (InputError for a missing file)
    # the campaign's options must be valid for the case (AgentOptions validates; exit 2)
    replace(case.options, **{k: v for k in ("tf", "step", "output_step")
                             if (v := getattr(mc, k)) is not None})
    return str(p), read_text(p, "case TOML file")
