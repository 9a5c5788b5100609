"""Certificates that answer design questions (issue 15), for any design whose closed loop the
engine derives (in its own controller gains: liang2016's ``K_o, K_q, beta``, pd_consensus's
``k_p, k_d``; pass ``spec=``).

* :func:`certify` - one of four certificates (``paper``, ``exact``, ``searched``,
  ``spectral``) on a gain box (:mod:`.certificates`);
* :func:`compare_regions` - the four side by side on a grid of cells (:mod:`.compare`);
* :func:`certified_decay_rate`, :func:`settling_time` - performance (:mod:`.performance`);
* :func:`delay_margin`, :func:`simulate_delayed_loop` - communication delay (:mod:`.delay`);
* :func:`certify_switching`, :func:`graphs_minus_links` - link failures (:mod:`.switching`);
* :func:`design_with_constraints` - gains maximising the certified decay rate (:mod:`.design`);
* :func:`certify_requirements` - a certificate plus decay/settle/delay/torque/graph-set
  requirements on a box (:mod:`.requirements`, used by the CLI);
* :func:`peak_torque_bound`, :func:`torque_limit_check` - certified peak torque from an initial
  set, at a gain point or over a whole gain box (:mod:`.torque`);
* :func:`certify_dwell_time` - dwell time over a graph set without a common ``V`` (:mod:`.dwell`);
* :func:`certify_inertia_uncertainty`, :func:`simulate_mismatch` - inertia mismatch (:mod:`.inertia`);
* :func:`laplacian_spectrum` - rigorous eigenvalue enclosures (:mod:`.spectrum`);
* :func:`mode_model` - the per-Laplacian-mode reduction, derived (:mod:`.modes`).
"""

from formsync_design.analysis.certificates import certify
from formsync_design.analysis.compare import (
    ORDER,
    RegionComparison,
    compare_regions,
    plot_comparison,
)
from formsync_design.analysis.delay import (
    DelayMargin,
    DelayModel,
    delay_margin,
    simulate_delayed_loop,
)
from formsync_design.analysis.design import ConstrainedDesign, design_with_constraints
from formsync_design.analysis.dwell import DwellTime, certify_dwell_time
from formsync_design.analysis.inertia import (
    InertiaBox,
    InertiaCertificate,
    certify_inertia_uncertainty,
    simulate_mismatch,
)
from formsync_design.analysis.modes import ModeModel, mode_model
from formsync_design.analysis.performance import (
    DecayResult,
    certified_decay_rate,
    settling_time,
    spectral_decay_rate,
)
from formsync_design.analysis.requirements import (
    RequirementResult,
    Requirements,
    certify_requirements,
)
from formsync_design.analysis.results import Certificate, CertificateResult, Verdict
from formsync_design.analysis.spectrum import LaplacianSpectrum, laplacian_spectrum
from formsync_design.analysis.switching import (
    SwitchingResult,
    certify_switching,
    graphs_minus_links,
    simulate_switching,
)
from formsync_design.analysis.torque import (
    TorqueBound,
    TorqueCheck,
    peak_torque_bound,
    torque_limit_check,
)

__all__ = [
    "Certificate",
    "CertificateResult",
    "Verdict",
    "certify",
    "ORDER",
    "RegionComparison",
    "compare_regions",
    "plot_comparison",
    "DecayResult",
    "certified_decay_rate",
    "spectral_decay_rate",
    "settling_time",
    "DelayModel",
    "DelayMargin",
    "delay_margin",
    "simulate_delayed_loop",
    "ModeModel",
    "mode_model",
    "LaplacianSpectrum",
    "laplacian_spectrum",
    "SwitchingResult",
    "certify_switching",
    "graphs_minus_links",
    "simulate_switching",
    "ConstrainedDesign",
    "design_with_constraints",
    "Requirements",
    "RequirementResult",
    "certify_requirements",
    "TorqueBound",
    "TorqueCheck",
    "peak_torque_bound",
    "torque_limit_check",
    "DwellTime",
    "certify_dwell_time",
    "InertiaBox",
    "InertiaCertificate",
    "certify_inertia_uncertainty",
    "simulate_mismatch",
]
