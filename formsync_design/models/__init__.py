"""Stage 2 — plant models: the symbolic attitude model and disturbance torques."""

from formsync_design.models.attitude import AttitudeModel, derive_attitude_model
from formsync_design.models.disturbances import DISTURBANCES, DisturbanceModel, Orbit

__all__ = ["AttitudeModel", "derive_attitude_model", "DisturbanceModel", "Orbit", "DISTURBANCES"]
