"""Stage 8 — topology sweeps: campaigns over graph sets x gain boxes on Dask.

The stage is split by job: :mod:`.graphsets` (graph-set grammar),
:mod:`.campaign` (definition, loading, fingerprint), :mod:`.designs` (what a
campaign takes from its design: gain names, default box and reference),
:mod:`.schema` (``results.csv`` columns, named after the design's gains), :mod:`.tasks` (one row per graph x box),
:mod:`.store` (journal and results folder), :mod:`.executor` (serial / Dask),
:mod:`.runner` (:func:`run_sweep`) and :mod:`.summary` (figures, Markdown).
"""

from formsync_design.sweep.campaign import (
    Campaign,
    campaign_from_dict,
    campaign_hash,
    load_campaign,
)
from formsync_design.sweep.graphsets import expand_graph_set, expand_graphs
from formsync_design.sweep.runner import SweepOutcome, run_sweep
from formsync_design.sweep.schema import COLUMNS, SweepSchema
from formsync_design.sweep.summary import plot_convergence, plot_fraction, write_summary
from formsync_design.sweep.tasks import build_tasks, run_task

__all__ = [
    "Campaign",
    "SweepOutcome",
    "SweepSchema",
    "COLUMNS",
    "campaign_from_dict",
    "campaign_hash",
    "load_campaign",
    "expand_graph_set",
    "expand_graphs",
    "build_tasks",
    "run_task",
    "run_sweep",
    "write_summary",
    "plot_fraction",
    "plot_convergence",
]
