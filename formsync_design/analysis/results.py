"""Result types of :mod:`formsync_design.analysis` (frozen, with ``to_dict``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from formsync_design.gains import GainBox, json_number

__all__ = ["Certificate", "Verdict", "CertificateResult", "jsonify"]


class Certificate(StrEnum):
    """The four certificates of a gain box, from most to least conservative.

    ``paper``: the paper's per-spacecraft test (each Theta_i > 0 and Pi > 0);
    ``exact``: the paper's own Lyapunov function on the whole graph, per
    Laplacian mode; ``searched``: the best quadratic Lyapunov function with the
    switching structure (vertex LMIs); ``spectral``: the true stability region
    of the nominal linear loop (Routh-Hurwitz per mode).
    """

    PAPER = "paper"
    EXACT = "exact"
    SEARCHED = "searched"
    SPECTRAL = "spectral"


class Verdict(StrEnum):
    """Outcome of a certificate on a box."""

    CERTIFIED = "certified"
    REFUTED = "refuted"
    UNDECIDED = "undecided"
    ERROR = "error"


def jsonify(x: Any) -> Any:
    """Recursively apply :func:`~formsync_design.gains.json_number` (dicts, lists, tuples).

    >>> from fractions import Fraction
    >>> jsonify({"a": (Fraction(1, 3), 2.0)})
    {'a': ['1/3', 2.0]}
    """
    if isinstance(x, dict):
        return {str(k): jsonify(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonify(v) for v in x]
    return json_number(x)


@dataclass(frozen=True)
class CertificateResult:
    """One certificate's verdict on one gain box, with its evidence.

    Attributes
    ----------
    certificate : Certificate
    status : Verdict
    graph : str
    n : int
    box : GainBox
    reason : str
        One sentence: the argument that decided (or why nothing did).
    witness : dict or None
        For ``refuted``: the gain point, the Laplacian eigenvalue enclosure and
        the failing condition (with the exact value or bound).
    evidence : dict
        Certificate-specific numbers (searched coefficients, dual certificate,
        recheck counts, solver statuses).
    spectrum_method : str
        How the Laplacian eigenvalues were enclosed.
    elapsed : float
        Seconds.
    """

    certificate: Certificate
    status: Verdict
    graph: str
    n: int
    box: GainBox
    reason: str
    witness: dict[str, Any] | None = None
    evidence: dict[str, Any] = field(default_factory=dict)
    spectrum_method: str = ""
    elapsed: float = 0.0

    @property
    def certified(self) -> bool:
        return self.status is Verdict.CERTIFIED

    def to_dict(self) -> dict[str, Any]:
        return {
            "certificate": str(self.certificate),
            "status": str(self.status),
            "graph": self.graph,
            "n": self.n,
            "box": self.box.to_dict(),
            "reason": self.reason,
            "witness": None if self.witness is None else jsonify(self.witness),
            "evidence": jsonify(self.evidence),
            "spectrum_method": self.spectrum_method,
            "elapsed_s": json_number(self.elapsed),
        }
