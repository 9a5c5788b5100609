"""The ``results.csv`` schema of a sweep, named after the design's gains, and the fixed
text of its cells.

The columns of a campaign follow its design (:class:`SweepSchema`): the box, the
reference point and the largest certified box are over the design's *controller
gains* (``box_K_o_lo``... for liang2016, ``box_k_p_lo``... for pd_consensus); the
recommended point over its controller gains and multipliers; a design whose
Lyapunov candidate has multipliers adds the multiplier value its certificates chose
(``ref_cert_eps``, ``rec_cert_eps``: the evidence).  An agent design (``FORM =
"agent"``, :mod:`formsync_design.spec.agent`) adds the column ``theorem`` (whether the
graph has the properties its theorem needs).  The classic schema of liang2016
(:data:`COLUMNS`) is the schema of every committed liang2016 report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

__all__ = ["FORMAT", "GAINS", "SweepSchema", "CLASSIC_SCHEMA", "COLUMNS", "COLUMN_DOC",
           "MC_COLUMNS", "fmt_cell", "rational_text"]

FORMAT = "formsync-sweep/1"
GAINS = ("K_o", "K_q", "beta")


@dataclass(frozen=True)
class SweepSchema:
    """The gain names a campaign's tables and columns are keyed by.

    ``box``: the design's controller gains (the box dimensions and the reference
    point); ``multipliers``: its Lyapunov-candidate multipliers (searched, never
    given); ``switching``: its switching gain (Monte-Carlo only) or ``None``; ``form``:
    ``"lagrangian"`` or ``"agent"`` (the design's ``FORM``).

    Examples
    --------
    >>> s = SweepSchema(("k_p", "k_d"), ("eps",), None)
    >>> s.family, s.swept
    (('k_p', 'k_d', 'eps'), 'eps')
    >>> [c for c in s.columns if "eps" in c]
    ['ref_cert_eps', 'rec_cert_eps']
    >>> CLASSIC_SCHEMA.columns == COLUMNS
    True
    >>> "theorem" in SweepSchema(("k_R", "k_w"), (), None, "agent").columns
    True
    """

    box: tuple[str, ...] = GAINS
    multipliers: tuple[str, ...] = ()
    switching: str | None = "K_v"
    form: str = "lagrangian"

    @classmethod
    def of_design(cls, spec: Any) -> SweepSchema:
        """The schema of a :class:`~formsync_design.spec.loader.Spec` or an agent design.

        >>> from formsync_design.spec.loader import load_design, load_spec
        >>> SweepSchema.of_design(load_spec("pd_consensus"))
        SweepSchema(box=('k_p', 'k_d'), multipliers=('eps',), switching=None, form='lagrangian')
        >>> SweepSchema.of_design(load_design("ma_so3")).box
        ('K1', 'K2', 'P1', 'P2', 'eps')
        """
        d = spec.decl
        return cls(tuple(d.controller_gains), tuple(d.multipliers), d.switching,
                   str(getattr(spec, "form", "lagrangian")))

    @property
    def agent(self) -> bool:
        """Whether the design is an agent design (its certificate is its ``conditions(c)``)."""
        return self.form == "agent"

    @property
    def family(self) -> tuple[str, ...]:
        """The dimensions of the Lyapunov conditions: controller gains, then multipliers."""
        return self.box + self.multipliers

    @property
    def swept(self) -> str:
        """The gain the gain design sweeps (the third family dimension; beta for liang2016)."""
        return self.family[2] if len(self.family) > 2 else self.family[-1]

    def _schema(self) -> list[tuple[str, str]]:
        mult = [(f"ref_cert_{m}", f"multiplier {m} of the Lyapunov candidate that certifies the "
                 "reference gains (the evidence: the grid value with the largest certified margin; "
                 "certified only)") for m in self.multipliers]
        rec_mult = [(f"rec_cert_{m}", f"multiplier {m} of the certificate of the recommended gains, "
                     "held at this value in the largest certified box (designed only)")
                    for m in self.multipliers]
        refuted = ("volume fraction proven inadmissible" if not self.multipliers else
                   "volume fraction proven inadmissible (0 for a design with multipliers: a "
                   "failing multiplier value refutes that Lyapunov candidate only)")
        return [
            ("task", "unique task id '<graph>@<box>'"),
            ("graph_index", "position of the graph in the expanded graph list (manifest.json)"),
            ("box_index", "position of the gain box in the campaign"),
            ("graph", "graph id: family spec (ring:8), atlas:G<index> (networkx atlas), "
             "random:N:P:SEED, file:<name>"),
            ("graph_set", "the graph-set spec the graph came from"),
            ("n", "number of spacecraft N"),
            ("edges", "number of links"),
            ("edge_list", "links as 1-based 'i-j' pairs separated by spaces"),
            ("degree_min", "smallest degree m_i"),
            ("degree_max", "largest degree m_i"),
            ("degree_mean", "mean degree"),
            ("lambda_2", "algebraic connectivity of the Laplacian L (LAPACK, for plots)"),
            ("lambda_max", "largest eigenvalue of L (LAPACK, for plots)"),
            *([("theorem", "inside: the graph has every property the design's theorem needs "
                "(GRAPHS); else 'outside: lacks PROPERTY: reason' (the statuses then decide the "
                "conditions(c) families only: none of the theorem's guarantees applies)"),
               ("formation", "formation-level verdict at the reference gains on this graph "
                "(formsync certify: the exact linearisation at consensus, sgn as sat(x/0.01), "
                "inertias of the design's case cycled to N): certified|refuted|undecided"),
               ("formation_decay", "certified exponential decay rate of the disagreement (1/s; "
                "certified only)"),
               ("formation_unstable_re", "real part of the unstable eigenvalue of the witness "
                "(refuted only; the inertia certificate proves one above half of it or more)")]
              if self.agent else []),
            ("conditions", "Lyapunov conditions checked: derived (from the controller) or paper "
             "(printed)"),
            ("box", "gain-box name"),
            *[(f"box_{g}_{e}", f"{'lower' if e == 'lo' else 'upper'} bound of {g} in the box")
              for g in self.box for e in ("lo", "hi")],
            *[(f"ref_{g}", f"reference gain {g}") for g in self.box],
            ("ref_status", "certify_box at the reference gains: certified|refuted|undecided|error"),
            ("ref_margin", "rigorous lower bound of lambda_min over Theta_i and Pi at the reference "
             "gains (certified only)"),
            ("ref_refuted_by", "family with the exactly checked refuting witness (refuted only)"),
            *mult,
            ("resolution", "region_map resolution R (finest box = 1/R of each range)"),
            ("frac_certified", "volume fraction of the box proven admissible (region_map)"),
            ("frac_refuted", refuted),
            ("frac_undecided", "volume fraction undecided at resolution R"),
            ("design_status", "design_agent (grid of design.betas values per gain, as formsync "
             "design --grid): designed|not-found" if self.agent else
             "design_gains: designed|infeasible|undecided|error"),
            *[(f"rec_{g}", f"recommended {g} (designed only)") for g in self.box],
            *rec_mult,
            ("rec_margin", "rigorous lower bound of lambda_min at the recommended gains"),
            *[(f"cbox_{g}_{e}", f"largest certified box around the recommended gains: {g} {e}")
              for g in self.box for e in ("lo", "hi")],
            ("cbox_half_width", "relative half width s of that box (g_i [1-s, 1+s] clipped to the "
             "ranges)"),
            ("cbox_status", "certify_box status of that box (with the SDP hint)"),
            ("mc_gains", "gains simulated: reference|recommended (empty: no Monte-Carlo)"),
            ("mc_status", "ran | skipped (reason) | empty"),
            ("mc_runs", "number of Monte-Carlo runs"),
            *(self._agent_mc() if self.agent else [
                ("mc_converged", "runs converged (Q_m <= q_tol and Omega_m <= omega_tol to the end)"),
                ("mc_not_converged", "runs not converged within tf"),
                ("mc_singular", "runs that reached q0 <= q0_floor"),
                ("mc_diverged", "runs with NaN/inf"),
                ("mc_inaccurate", "runs with quaternion norm drift above norm_tol"),
            ]),
            ("mc_conv_time_median", "median convergence time over converged runs (s)"),
            ("mc_conv_time_p95", "95th percentile convergence time (s)"),
            ("mc_conv_time_max", "largest convergence time (s)"),
            ("mc_failed_seeds", "run seeds of non-converged runs (replay with formsync montecarlo "
             "--replay), ';'-separated, at most 20"),
        ]

    @staticmethod
    def _agent_mc() -> list[tuple[str, str]]:
        """The run-status columns of an agent design's Monte-Carlo (``AGENT_STATUSES``)."""
        lag = "Lagrangian designs only: empty for an agent design"
        return [
            ("mc_converged", "runs converged (attitude and rate disagreement, and the errors to "
             "the reference, within angle_tol and rate_tol from the convergence time to tf)"),
            ("mc_not_converged", "runs not converged within tf"),
            ("mc_stopped", "runs whose hybrid integrator stopped (Zeno protection or too many "
             "triggers)"),
            ("mc_singular", lag),
            ("mc_diverged", "runs whose state went non-finite (status diverged)"),
            ("mc_inaccurate", lag),
        ]

    @property
    def columns(self) -> tuple[str, ...]:
        """The ``results.csv`` columns, in order."""
        return tuple(c for c, _ in self._schema())

    @property
    def doc(self) -> dict[str, str]:
        """Column -> meaning (the table at the end of ``summary.md``)."""
        return dict(self._schema())

    def to_dict(self) -> dict[str, Any]:
        return {"box": list(self.box), "multipliers": list(self.multipliers),
                "switching": self.switching, **({"form": self.form} if self.agent else {})}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SweepSchema:
        """Inverse of :meth:`to_dict` (task payloads carry the schema as plain data)."""
        return cls(tuple(d["box"]), tuple(d["multipliers"]), d["switching"],
                   d.get("form", "lagrangian"))


CLASSIC_SCHEMA = SweepSchema()
"""The schema of liang2016 (``K_o, K_q, beta``, switching gain ``K_v``)."""
COLUMNS: tuple[str, ...] = CLASSIC_SCHEMA.columns
COLUMN_DOC: dict[str, str] = CLASSIC_SCHEMA.doc
MC_COLUMNS = tuple(c for c in COLUMNS if c.startswith("mc_"))


def fmt_cell(x: Any) -> str:
    """Fixed text of a cell: '' for None, integers as such, floats with 10 significant digits."""
    if x is None:
        return ""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, (float, Fraction)):
        f = float(x)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        s = format(f, ".10g")
        return "0" if s == "-0" else s
    return str(x)


def rational_text(q: Fraction) -> str:
    return str(q.numerator) if q.denominator == 1 else f"{q.numerator}/{q.denominator}"
