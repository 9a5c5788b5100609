"""Exception hierarchy of formsync-design.

Every exception derives from :class:`FormsyncError` and from the matching
built-in, so callers may catch either:

* bad input (the user's to fix; ``formsync`` exit status 2) derives from
  :class:`ValueError`: :class:`InputError`, :class:`GraphError`,
  :class:`DerivationError` (a specification without the required structure);
* a failure that is not the user's input (exit status 3) derives from
  :class:`RuntimeError`: :class:`SolverError`, :class:`SimulationError`,
  :class:`CompilerError`, :class:`ClusterError`, :class:`PackagingError`;
* a write that failed for want of room (disk full, file-size limit, quota, I/O
  error; exit status 3) is a :class:`WriteError`, which derives from
  :class:`OSError` and keeps the ``errno`` and the file name.

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
    "WriteError",
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


class WriteError(FormsyncError, OSError):
    """Writing a file failed for want of room: disk full, file-size limit, quota, I/O error.

    ``errno`` and ``filename`` are those of the failed write; the message names the file
    and the errno (see :func:`formsync_design.outdir.write_error`).

    >>> import errno
    >>> e = WriteError(errno.ENOSPC, "writing r.json failed", "r.json")
    >>> e.errno == errno.ENOSPC, e.filename, str(e)
    (True, 'r.json', 'writing r.json failed')
    """

    def __init__(self, code: int, message: str, filename: str | None = None) -> None:
        super().__init__(code, message, filename)
        self.message = message

    def __str__(self) -> str:
        return self.message
