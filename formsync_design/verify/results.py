"""Result objects of a verification (frozen dataclasses with ``to_dict()``).

>>> row = SensitivityRow("torque_limit", None, "converged", "ok", 57.7, 1e-6, 1e-7, 1e-5, 1.9, 0, None)
>>> row.to_dict()["value"], row.singular
('unlimited', False)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from formsync_design.gains import json_number
from formsync_design.notebook import NotebookViews
from formsync_design.verify.claims import ClaimResult, Measurement, Verdict

__all__ = ["TopologyRun", "SensitivityRow", "VerificationResult", "to_json_value"]

#: The one word for "no torque limit" in reports and JSON.
UNLIMITED = "unlimited"


def to_json_value(x: Any) -> Any:
    """``x`` with every number written by :func:`~formsync_design.gains.json_number`.

    >>> to_json_value({"a": [float("inf"), 1.5, None]})
    {'a': ['inf', 1.5, None]}
    """
    if isinstance(x, dict):
        return {str(k): to_json_value(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_json_value(v) for v in x]
    if hasattr(x, "to_dict"):
        return x.to_dict()
    return json_number(x)


@dataclass(frozen=True)
class TopologyRun:
    """Certification and simulation of the case on one candidate topology.

    ``horizon`` is the simulated horizon of the run the claims are judged on
    (longer than the case's ``tf`` when the verification lengthened it to reach
    the steady state).
    """

    graph: str
    lambda_max: float
    max_degree: int
    derived_status: str
    derived_margin: float | None
    paper_status: str
    paper_margin: float | None
    theta_certified: bool
    pi_certified: bool
    sim: dict
    sat_sim: dict
    quantities: dict[str, Measurement]
    horizon: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "graph": self.graph, "lambda_max_L": json_number(self.lambda_max),
            "max_degree": self.max_degree,
            "certification": {"derived": str(self.derived_status),
                              "derived_margin": json_number(self.derived_margin),
                              "paper": str(self.paper_status),
                              "paper_margin": json_number(self.paper_margin)},
            "horizon": json_number(self.horizon),
            "simulation": to_json_value(self.sim),
            "saturation_run": to_json_value(self.sat_sim),
            "quantities": {k: m.to_dict() for k, m in self.quantities.items()},
        }


@dataclass(frozen=True)
class SensitivityRow:
    """One run of the sensitivity study (``value`` None = unlimited torque)."""

    parameter: str
    value: float | None
    status: str
    message: str
    convergence_time: float | None
    tail_q_m: float | None
    tail_omega_m: float | None
    final_abs_rate: float | None
    chatter_end_time: float | None
    chatter_reversals_tail: int | None
    saturation_end_time: float | None

    @property
    def singular(self) -> bool:
        return self.status == "singular"

    def to_dict(self) -> dict[str, Any]:
        d = {k: to_json_value(v) for k, v in self.__dict__.items()}
        if self.value is None:
            d["value"] = UNLIMITED
        return d


@dataclass(frozen=True)
class VerificationResult(NotebookViews):
    """Everything :func:`~formsync_design.verify.verification.verify_case` found.

    ``case_path`` and ``spec_source`` are display paths (repository-relative or
    a bare file name, never machine-specific); ``report_name`` is the case
    file's stem, the base name of the report.
    """

    case_name: str
    case_path: str
    case_digest: str
    report_name: str
    spec_name: str
    spec_source: str
    topologies: tuple[TopologyRun, ...]
    claims: tuple[ClaimResult, ...]
    sensitivity: tuple[SensitivityRow, ...]
    kv_required: tuple[float, ...]
    kv_used: tuple[float, ...]
    ubar: tuple[float, ...]
    assumptions: tuple[str, ...]
    topology_note: str
    derivation_report: str
    derivation_verdicts: tuple[tuple[str, str, str], ...]
    saturation_torque_limit: float
    tf: float
    max_tf: float
    default_sim: Any = field(default=None, repr=False, compare=False)


    @property
    def all_hold(self) -> bool:
        """Every claim holds on every topology (undecided is not a pass)."""
        return all(c.verdict is Verdict.HOLDS for c in self.claims)

    def to_dict(self) -> dict[str, Any]:
        return {
            "case": self.case_name, "case_file": self.case_path, "case_sha256": self.case_digest,
            "spec": {"name": self.spec_name, "source": self.spec_source},
            "horizon": {"tf": json_number(self.tf), "max_tf": json_number(self.max_tf)},
            "topologies": [t.to_dict() for t in self.topologies],
            "claims": [c.to_dict() for c in self.claims],
            "sensitivity": [r.to_dict() for r in self.sensitivity],
            "kv_required": to_json_value(self.kv_required), "kv_used": to_json_value(self.kv_used),
            "ubar": to_json_value(self.ubar),
            "assumptions": list(self.assumptions),
            "derivation_verdicts": [{"key": k, "verdict": v, "meaning": m}
                                    for k, v, m in self.derivation_verdicts],
            "all_claims_hold": self.all_hold,
        }
