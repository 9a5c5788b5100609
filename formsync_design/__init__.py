"""formsync-design: derive, certify and simulate decentralized attitude
synchronization controllers for spacecraft formations."""

from __future__ import annotations

from .errors import DerivationError as DerivationError
from .errors import FormsyncError as FormsyncError
from .errors import GraphError as GraphError
from .errors import InputError as InputError
from .errors import SimulationError as SimulationError
from .errors import SolverError as SolverError
from .families import MatrixFamily as MatrixFamily
from .graphs import Graph as Graph
from .graphs import make_graph as make_graph
from .model import AttitudeModel as AttitudeModel
from .model import derive_attitude_model as derive_attitude_model

__version__ = "0.1.0"
