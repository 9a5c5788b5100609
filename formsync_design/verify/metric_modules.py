"""Import every module of built-in metrics, so that reading an engine case finds them all
registered (:mod:`formsync_design.verify.metrics`; a paper's own metrics live in its design
file and register when the case loads its design).

>>> from formsync_design.verify.metrics import METRICS
>>> {"family_certificate", "certified_l2_gain", "rate_free_law", "large_angle_scope"} <= set(METRICS)
True
"""

from __future__ import annotations

from formsync_design.verify import (  # noqa: F401 (each registers its metrics)
    metrics_attitude,
    metrics_compare,
    metrics_design,
    metrics_l2,
    metrics_lagrangian,
    metrics_sampled,
    metrics_scope,
    metrics_sensors,
    metrics_tracking,
)

__all__: list[str] = []
