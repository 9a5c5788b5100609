"""Exception hierarchy of formsync-design.

Every exception derives from :class:`FormsyncError` and from the matching
built-in, so callers may catch either:

* bad input (the user's to fix; ``formsync`` exit status 2) derives from
  :class:`ValueError`: :class:`InputError`, :class:`GraphError`,
  :class:`DerivationError` (a specification without the required structure);
* a failure that is not the user's input (exit status 3) derives from
  :class:`RuntimeError`: :class:`SolverError`, :class:`SimulationError`,
  :class:`CompilerError`, :class:`ClusterError`, :class:`PackagingError`.

Messages name what was expected and what was received (bad input) or what
failed and what to try (failures).  A negative *finding* (not certified, a
claim fails) is a result, never an exception.
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
    "CompilerError",
    "ClusterError",
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


class CompilerError(FormsyncError, RuntimeError):
    """Compiling a simulation kernel failed (C compiler missing or broken)."""


class ClusterError(FormsyncError, RuntimeError):
    """A Dask cluster could not be reached or lost its workers."""
