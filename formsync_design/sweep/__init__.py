"""Stage 8 — topology sweeps: campaigns over graph sets x gain boxes on Dask."""

from formsync_design.sweep.campaign import Campaign, SweepOutcome, load_campaign, run_sweep

__all__ = ["Campaign", "SweepOutcome", "load_campaign", "run_sweep"]
