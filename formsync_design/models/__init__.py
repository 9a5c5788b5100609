"""Stage 2 — plant models: the symbolic attitude model, disturbance torques, inertia checks."""

from formsync_design.models.attitude import AttitudeModel, derive_attitude_model
from formsync_design.models.disturbances import DISTURBANCES, DisturbanceModel, Orbit
from formsync_design.models.inertia import check_inertia, check_inertias

__all__ = [
    "AttitudeModel",
    "derive_attitude_model",
    "DisturbanceModel",
    "Orbit",
    "DISTURBANCES",
    "check_inertia",
    "check_inertias",
]
