"""Exception hierarchy of formsync-design.

Every exception raised for bad input derives from :class:`FormsyncError` and
from the matching built-in, so callers may catch either.  Messages name what
was expected and what was received.
"""

from __future__ import annotations

__all__ = [
    "FormsyncError",
    "GraphError",
    "InputError",
    "DerivationError",
    "SolverError",
    "SimulationError",
    "PackagingError",
]


class FormsyncError(Exception):
    """Base class of every error raised by formsync-design."""


class InputError(FormsyncError, ValueError):
    """A user-supplied value is malformed or out of range."""


class GraphError(InputError):
    """A communication graph is malformed or unsuitable for the controller."""


class DerivationError(FormsyncError, ValueError):
    """A controller law or Lyapunov candidate does not have the required structure."""


class SolverError(FormsyncError, RuntimeError):
    """A numerical solver failed in a way that is not a finding about the input."""


class SimulationError(FormsyncError, RuntimeError):
    """A simulation produced NaN/inf or could not proceed."""


class PackagingError(FormsyncError, RuntimeError):
    """The installation lacks a file it should ship (not the user's input)."""
