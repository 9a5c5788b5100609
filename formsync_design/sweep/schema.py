"""The ``results.csv`` schema of a sweep and the fixed text of its cells."""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

__all__ = ["FORMAT", "GAINS", "COLUMNS", "COLUMN_DOC", "MC_COLUMNS", "fmt_cell", "rational_text"]

FORMAT = "formsync-sweep/1"
GAINS = ("K_o", "K_q", "beta")

_SCHEMA: list[tuple[str, str]] = [
    ("task", "unique task id '<graph>@<box>'"),
    ("graph_index", "position of the graph in the expanded graph list (manifest.json)"),
    ("box_index", "position of the gain box in the campaign"),
    ("graph", "graph id: family spec (ring:8), atlas:G<index> (networkx atlas), random:N:P:SEED, file:<name>"),
    ("graph_set", "the graph-set spec the graph came from"),
    ("n", "number of spacecraft N"),
    ("edges", "number of links"),
    ("edge_list", "links as 1-based 'i-j' pairs separated by spaces"),
    ("degree_min", "smallest degree m_i"),
    ("degree_max", "largest degree m_i"),
    ("degree_mean", "mean degree"),
    ("lambda_2", "algebraic connectivity of the Laplacian L (LAPACK, for plots)"),
    ("lambda_max", "largest eigenvalue of L (LAPACK, for plots)"),
    ("conditions", "Lyapunov conditions checked: derived (from the controller) or paper (printed)"),
    ("box", "gain-box name"),
    *[(f"box_{g}_{e}", f"{'lower' if e == 'lo' else 'upper'} bound of {g} in the box")
      for g in GAINS for e in ("lo", "hi")],
    *[(f"ref_{g}", f"reference gain {g}") for g in GAINS],
    ("ref_status", "certify_box at the reference gains: certified|refuted|undecided|error"),
    ("ref_margin", "rigorous lower bound of lambda_min over Theta_i and Pi at the reference gains (certified only)"),
    ("ref_refuted_by", "family with the exactly checked refuting witness (refuted only)"),
    ("resolution", "region_map resolution R (finest box = 1/R of each range)"),
    ("frac_certified", "volume fraction of the box proven admissible (region_map)"),
    ("frac_refuted", "volume fraction proven inadmissible"),
    ("frac_undecided", "volume fraction undecided at resolution R"),
    ("design_status", "design_gains: designed|infeasible|undecided|error"),
    *[(f"rec_{g}", f"recommended {g} (designed only)") for g in GAINS],
    ("rec_margin", "rigorous lower bound of lambda_min at the recommended gains"),
    *[(f"cbox_{g}_{e}", f"largest certified box around the recommended gains: {g} {e}")
      for g in GAINS for e in ("lo", "hi")],
    ("cbox_half_width", "relative half width s of that box (g_i [1-s, 1+s] clipped to the ranges)"),
    ("cbox_status", "certify_box status of that box (with the SDP hint)"),
    ("mc_gains", "gains simulated: reference|recommended (empty: no Monte-Carlo)"),
    ("mc_status", "ran | skipped (reason) | empty"),
    ("mc_runs", "number of Monte-Carlo runs"),
    ("mc_converged", "runs converged (Q_m <= q_tol and Omega_m <= omega_tol to the end)"),
    ("mc_not_converged", "runs not converged within tf"),
    ("mc_singular", "runs that reached q0 <= q0_floor"),
    ("mc_diverged", "runs with NaN/inf"),
    ("mc_inaccurate", "runs with quaternion norm drift above norm_tol"),
    ("mc_conv_time_median", "median convergence time over converged runs (s)"),
    ("mc_conv_time_p95", "95th percentile convergence time (s)"),
    ("mc_conv_time_max", "largest convergence time (s)"),
    ("mc_failed_seeds", "run seeds of non-converged runs (replay with formsync montecarlo --replay), ';'-separated, at most 20"),
]
COLUMNS: tuple[str, ...] = tuple(c for c, _ in _SCHEMA)
COLUMN_DOC: dict[str, str] = dict(_SCHEMA)
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

