"""formsync-design: derive, certify and simulate decentralized attitude
synchronization controllers for spacecraft formations.

The curated public surface (``import formsync_design as fs``), in the order
data flows through the stages:

* graphs: :func:`make_graph`, :class:`Graph`; :func:`load_graph` (also directed, weighted,
  with a leader: :class:`Digraph`) and :func:`check_theorem_graph` (a design's graph class);
* the design (controller law, Lyapunov candidate, declared gains, representation,
  graph class): :func:`load_design` / :func:`load_spec` (a shipped design's name such
  as ``"pd_consensus"``, or a file), :class:`Design` (= :class:`Spec`; or
  ``Spec.from_functions`` in a notebook), :class:`Declarations`; agent designs
  (``FORM = "agent"``: a per-spacecraft law in quaternion, MRP or SO(3) quantities on a
  directed weighted graph, with a leader, controller states, trigger rules):
  :class:`AgentDesign`;
* derivation: :func:`derive_closed_loop`, :func:`derive_conditions`,
  :func:`paper_conditions`, :func:`closed_form_conditions`,
  :func:`required_kv`, :func:`lyapunov_findings`,
  :func:`write_derivation_report`; for agent designs :func:`agent_closed_loop` and
  :func:`agent_conditions`;
* certification: :class:`GainBox` (the one gain-box type), :func:`certify_box`,
  :func:`certify_with_multipliers` (designs whose candidate has multipliers),
  :func:`region_map`, :func:`plot_slices`, :func:`design_gains`; certified L2 gains of an
  agent design's linearisation (:func:`linearize_agents`): :func:`certify_gamma`,
  :func:`certify_l2_box`, :func:`design_l2_gains`;
  :func:`certify_agent_graphs` (an agent design's box on graph families; a graph outside
  its theorem refused as a finding); the formation-level certificate of any agent design
  on the graph given, :func:`certify_formation` (-> :class:`FormationCertificate`, with its
  :class:`Scope`) on its exact linearisation at consensus (:func:`linearize_formation`),
  and :func:`check_theorem` (a design's declared graph class tested on graph families);
  :func:`to_statespace` exports that linearisation as a ``control.StateSpace``
  (python-control, the ``control`` extra);
* simulation: :func:`simulate`, the one entry point (a :class:`Formation` with
  :class:`SimOptions`: the Lagrangian view on the compiled whole-horizon driver; an
  :class:`AgentFormation` with :class:`AgentOptions`, :class:`Reference`, gyro models
  :class:`RateSensors`: the design's agent form, continuous or sampled; a
  :class:`FlyaroundScenario`: a design on the relative-orbit plant), one result type
  :class:`SimResult` for every run (a fly-around's relative orbit and thrusters in its
  :class:`OrbitRecord`); :class:`Gains`, :func:`simulate_sampled` (a Lagrangian
  design's per-spacecraft sample-and-hold and trigger rules), :func:`metric_figure`,
  :func:`torque_figures`, :func:`monte_carlo` (one :class:`MonteCarloResult`),
  :func:`measured_l2_gain`; the paths themselves are exported too
  (:func:`simulate_agents`, :func:`simulate_flyaround`);
* verification of a published case: :func:`verify_case` (a case file or a shipped case's
  name, -> :class:`EngineVerification`); :func:`load_case` and :func:`load_agent_case`
  (the simulation case layouts a case file's base case is read with); the verification
  engine (formations, scenarios, Monte-Carlo, metrics and claims declared in the case
  file): :func:`load_engine_case`, :func:`run_engine` (-> :class:`EngineVerification`), :func:`register_metric` (the metric registry, -> a
  :class:`MetricValue`); sampled designs: :func:`sampling_variant`, :func:`rule_variant`
  (a design under another sampling rule: an engine scenario's ``sampling``),
  :func:`interevent_bound` (the certified inter-event lower bound of a self-trigger rule);
* the relative-orbit plant (the fly-around of Zhang et al. 2014): :func:`load_flyaround_case`,
  :class:`FlyaroundScenario`, :class:`FlyaroundOptions`, :func:`simulate_flyaround`
  (-> :class:`SimResult` with an :class:`OrbitRecord`), :func:`flyaround_figures`,
  :func:`derive_tracking_attitude`, :func:`attitude_certificate` (verified by the engine:
  ``formsync verify zhang2014_flyaround``);
* campaigns: :func:`load_campaign`, :func:`run_sweep`;
* numbers: :func:`parse_number` (the exact-number parser) and
  :func:`json_number` (the JSON number convention);
* errors: :class:`FormsyncError` and its subclasses (bad input derives from
  :class:`ValueError`, other failures from :class:`RuntimeError`).

>>> import formsync_design as fs
>>> g = fs.make_graph("ring:8")
>>> conds = fs.derive_conditions(g)
>>> str(fs.certify_box(conds, {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}).status)
'certified'
>>> "simulate" in dir(fs) and "simulate" in fs.__all__
True

Heavy stages (SymPy, cvxpy, CasADi, Dask, matplotlib) are imported on first
use of one of their names (PEP 562), so ``import formsync_design`` and
``formsync --help`` stay fast.  Figures are returned, never shown, and no
function of the package selects a matplotlib backend.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from formsync_design.errors import (
    ClusterError,
    CompilerError,
    DerivationError,
    FormsyncError,
    GraphError,
    InputError,
    PackagingError,
    SimulationError,
    SolverError,
    WriteError,
)
from formsync_design.lazy import lazy_attributes

__version__ = "0.1.0"

# public name -> where it is defined (imported lazily, PEP 562).  A stage's
# subpackage is named where it re-exports the name, so modules may move inside
# a stage without changing the surface.
_LAZY: dict[str, str | tuple[str, str]] = {
    # graphs
    "Graph": "formsync_design.graphs",
    "make_graph": "formsync_design.graphs",
    "Digraph": "formsync_design.graphs",
    "load_graph": "formsync_design.graphs",
    "check_theorem_graph": "formsync_design.graphs",
    # models and specification
    "AttitudeModel": "formsync_design.models",
    "derive_attitude_model": "formsync_design.models",
    "Spec": "formsync_design.spec",
    "load_spec": "formsync_design.spec",
    "Design": "formsync_design.spec",
    "load_design": "formsync_design.spec",
    "Declarations": "formsync_design.spec",
    "AgentDesign": "formsync_design.spec",
    # derivation
    "ClosedLoop": "formsync_design.derive",
    "MatrixFamily": "formsync_design.derive",
    "LyapunovConditions": "formsync_design.derive",
    "derive_closed_loop": "formsync_design.derive",
    "derive_conditions": "formsync_design.derive",
    "paper_conditions": "formsync_design.derive",
    "closed_form_conditions": "formsync_design.derive",
    "required_kv": "formsync_design.derive",
    "lyapunov_findings": "formsync_design.derive.compare",
    "write_derivation_report": "formsync_design.derive.report",
    "agent_closed_loop": "formsync_design.derive",
    "agent_conditions": "formsync_design.derive",
    "linearize_agents": "formsync_design.derive.linearize",
    "linearize_formation": "formsync_design.derive.formation",
    # gains and numbers
    "GainBox": "formsync_design.gains",
    "GainRange": "formsync_design.gains",
    "parse_gain_range": "formsync_design.gains",
    "parse_number": "formsync_design.gains",
    "json_number": "formsync_design.gains",
    # certification
    "CertificationResult": "formsync_design.certify",
    "certify_box": "formsync_design.certify",
    "certify_with_multipliers": "formsync_design.certify",
    "certify_agent_graphs": "formsync_design.certify.agentgraphs",
    "certify_formation": "formsync_design.certify.formation",
    "FormationCertificate": "formsync_design.certify.formation",
    "Scope": "formsync_design.certify.scope",
    "check_theorem": "formsync_design.verify.theoremcheck",
    "to_statespace": "formsync_design.interop",
    "RegionMap": "formsync_design.certify",
    "region_map": "formsync_design.certify",
    "plot_slices": "formsync_design.certify.plots",
    "DesignResult": "formsync_design.certify",
    "design_gains": "formsync_design.certify",
    "certify_gamma": "formsync_design.analysis.l2gain",
    "certify_l2_box": "formsync_design.analysis.l2gain",
    "design_l2_gains": "formsync_design.analysis.l2design",
    # simulation
    "Formation": "formsync_design.sim",
    "Gains": "formsync_design.sim",
    "SimOptions": "formsync_design.sim",
    "SimResult": "formsync_design.sim",
    "simulate": "formsync_design.sim",
    "simulate_sampled": "formsync_design.sim",
    "AgentFormation": "formsync_design.sim",
    "AgentOptions": "formsync_design.sim",
    "Reference": "formsync_design.sim",
    "simulate_agents": "formsync_design.sim",
    "RateSensors": "formsync_design.sim.sensors",
    "measured_l2_gain": "formsync_design.sim.l2measure",
    "metric_figure": "formsync_design.sim.figures",
    "torque_figures": "formsync_design.sim.figures",
    "MonteCarloSettings": "formsync_design.sim",
    "MonteCarloResult": "formsync_design.sim",
    "MonteCarloRun": "formsync_design.sim",
    "monte_carlo": ("formsync_design.sim", "run_montecarlo"),
    # verification of a published case
    "Case": "formsync_design.verify",
    "load_case": "formsync_design.verify",
    "verify_case": "formsync_design.verify.dispatch",
    "load_agent_case": "formsync_design.verify",
    "load_engine_case": "formsync_design.verify.enginecase",
    "run_engine": "formsync_design.verify.engine",
    "EngineVerification": "formsync_design.verify.engine",
    "register_metric": "formsync_design.verify.metrics",
    "MetricValue": "formsync_design.verify.metrics",
    "interevent_bound": "formsync_design.analysis.triggering",
    "sampling_variant": "formsync_design.spec.agent",
    "rule_variant": "formsync_design.spec.agent",
    # the relative-orbit plant: the fly-around case
    "load_flyaround_case": "formsync_design.verify.tracking_case",
    "FlyaroundScenario": "formsync_design.sim.tracking_scenario",
    "FlyaroundOptions": "formsync_design.sim.tracking_scenario",
    "OrbitRecord": "formsync_design.sim.orbit_record",
    "simulate_flyaround": "formsync_design.sim.tracking",
    "flyaround_figures": "formsync_design.sim.tracking_figures",
    "derive_tracking_attitude": "formsync_design.derive.tracking",
    "attitude_certificate": "formsync_design.analysis.tracking",
    # agent designs: the paths the command line takes (the generic functions route there)
    "certify_agent": "formsync_design.certify.agent",
    "region_agent": "formsync_design.certify.agent",
    "design_agent": "formsync_design.certify.agent",
    "AgentGainDesign": "formsync_design.certify.agent",
    "run_agent_montecarlo": "formsync_design.sim.agent_montecarlo",
    "agent_derivation": "formsync_design.derive.agent_report",
    "write_agent_derivation_report": "formsync_design.derive.agent_report",
    # campaigns
    "load_campaign": "formsync_design.sweep",
    "run_sweep": "formsync_design.sweep",
}

__all__ = [
    "__version__",
    "FormsyncError",
    "InputError",
    "GraphError",
    "DerivationError",
    "SolverError",
    "SimulationError",
    "CompilerError",
    "ClusterError",
    "PackagingError",
    "WriteError",
    *_LAZY,
]

if TYPE_CHECKING:  # the lazy names for type checkers and IDEs
    from formsync_design.graphs import Graph as Graph, make_graph as make_graph


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals(), public_only=True)
