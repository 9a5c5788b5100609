"""``formsync``: the command-line interface.

Every subcommand lives in its own module ``formsync_design.cli.<name>`` exposing
``add_parser(subparsers)``; the parser it registers sets ``func`` to a
``run(args) -> int`` callable.
"""

from __future__ import annotations

import argparse
import errno
import gc
import os
import re
import sys
import traceback
from collections.abc import Sequence
from typing import Any

from formsync_design import __version__, outdir
from formsync_design.cli import (
    certify as cmd_certify,
    derive as cmd_derive,
    design as cmd_design,
    montecarlo as cmd_montecarlo,
    region as cmd_region,
    simulate as cmd_simulate,
    sweep as cmd_sweep,
    verify as cmd_verify,
)
from formsync_design.cli.options import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
)
from formsync_design.errors import DerivationError, FormsyncError, InputError

__all__ = ["main", "build_parser"]

_COMMANDS = [cmd_derive, cmd_certify, cmd_region, cmd_design, cmd_simulate, cmd_montecarlo, cmd_sweep, cmd_verify]


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line on stderr, exit 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="formsync",
        description=(
            "Decentralized attitude synchronization of spacecraft formations: derive the "
            "closed loop and Lyapunov conditions of a controller symbolically, certify gain "
            "ranges for a communication graph, and simulate the nonlinear formation.\n\n"
            "Exit status: 0 success/certified, 1 negative finding (not certified, a claim "
            "fails), 2 bad input or usage, 3 a failure that is not your input (solver, "
            "compiler, cluster: the message says what to try), 130 interrupted."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"formsync {__version__}")
    sub = p.add_subparsers(dest="command", metavar="SUBCOMMAND", parser_class=_Parser)
    sub.required = True
    for mod in _COMMANDS:
        mod.add_parser(sub)
    return p


_NUMPY_REPR = re.compile(r"np\.(?:float|int|uint|complex|bool|str)\w*\(([^()]*)\)")


def _fail(command: str, message: str) -> None:
    """One line on stderr; numpy scalar reprs (``np.float64(-1.0)``) shown as their value."""
    prog = f"formsync {command}" if command else "formsync"
    text = _NUMPY_REPR.sub(r"\1", " ".join(str(message).split()))
    sys.stderr.write(f"{prog}: error: {text}\n")


_USER_OS_ERRORS = (FileNotFoundError, PermissionError, IsADirectoryError, NotADirectoryError,
                   FileExistsError)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``formsync`` with ``argv`` (default ``sys.argv[1:]``); return the exit status.

    Exit status: 0 success/certified, 1 negative finding, 2 bad input or usage,
    3 a failure that is not the user's input, 130 interrupted.  Errors are one
    line on stderr; set ``FORMSYNC_TRACEBACK=1`` to see the traceback of a
    failure (exit 3).

    Called as the program (``argv`` None), the objects left at the end are moved
    out of the garbage collector's reach (``gc.freeze``): the interpreter's
    final collections over a session's SymPy and CasADi objects otherwise take
    seconds, and Ctrl-C must end the process within a second.

    >>> main(["--version"])  # doctest: +ELLIPSIS
    formsync ...
    0
    """
    rc = _main(argv)
    if argv is None:  # the process ends next: skip the final collections (docstring)
        gc.freeze()
    return rc


def _main(argv: Sequence[str] | None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help/--version (0) or usage error (2)
        return int(e.code or 0)
    except KeyboardInterrupt:
        _fail("", "interrupted (Ctrl-C)")
        return EXIT_INTERRUPTED
    command = str(args.command)
    out = getattr(args, "out", None)
    if isinstance(out, str) and not out.strip():  # Path("") is the working folder: never implied
        _fail(command, f"expected --out DIR naming a folder, received an empty name {out!r} (give "
                       "--out . for the working folder)")
        return EXIT_USAGE
    found: list[Any] = []
    try:
        with outdir.session():  # every --out a command claimed is released however it ends
            with _design_code_session(args, command) as found:
                return int(args.func(args))
    except BrokenPipeError:  # output piped into e.g. `head`: not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except KeyboardInterrupt:
        _fail(command, "interrupted (Ctrl-C); partial results, if any, are where the command said")
        return EXIT_INTERRUPTED
    except UnicodeDecodeError as e:
        _fail(command, f"expected a UTF-8 text file, received binary or non-UTF-8 data ({e.reason} "
                       f"at byte {e.start})")
        return EXIT_USAGE
    except (InputError, DerivationError, ValueError) as e:
        if not isinstance(e, FormsyncError):  # a ValueError we did not anticipate: ours
            return _internal(command, e)
        _fail(command, str(e))
        return EXIT_USAGE
    except FormsyncError as e:  # runtime failures: SolverError, CompilerError, ClusterError, ...
        _fail(command, f"{type(e).__name__}: {e}")
        _traceback()
        return EXIT_FAILURE
    except _USER_OS_ERRORS as e:
        what = f" {e.filename}" if getattr(e, "filename", None) else ""
        _fail(command, f"cannot use{what}: {e.strerror or e}")
        return EXIT_USAGE
    except OSError as e:  # disk full, I/O error: not the user's input
        if e.errno == errno.ENAMETOOLONG:  # a path given (flag or data file) beyond the OS limit
            name = str(getattr(e, "filename", None) or "")
            shown = f" ({len(name)} characters, {name[:40]!r}...)" if name else ""
            _fail(command, "expected a path within the system's limits (a name of at most 255 "
                           f"bytes), received one too long{shown}")
            return EXIT_USAGE
        _fail(command, f"{type(e).__name__}: {e.strerror or e} (check disk space and permissions)")
        _traceback()
        return EXIT_FAILURE
    except Exception as e:  # a bug of ours: say so in one line, exit 3
        return _internal(command, e)
    except BaseException as e:  # SystemExit, GeneratorExit, ... escaping a command
        return _escape(command, e, found)


def _design_code_session(args: argparse.Namespace, command: str) -> Any:
    """The command's trust (``--trust-design`` files, and a ``--design`` file the user named)
    and its record of the design code it loads, announced on stderr in text output
    (:mod:`formsync_design.spec.trust`)."""
    from pathlib import Path

    from formsync_design.resources import design_names
    from formsync_design.spec.trust import code_session, notice

    trusted = list(getattr(args, "trust_design", None) or [])
    named = getattr(args, "spec", None)
    if isinstance(named, str) and named not in design_names() and Path(named).is_file():
        trusted.append(named)
    text = getattr(args, "format", "text") != "json"
    return code_session(trusted, notice(command) if text else None)


def _escape(command: str, e: BaseException, code: list[Any]) -> int:
    """A non-Exception escape (``SystemExit`` raised by code the command ran): exit 2 naming
    the design code this command loaded (``code``: it is the code that may raise it; the
    design's own loading and first evaluation report it themselves, spec.contain); without
    design code, a ``SystemExit`` passes (a usage error), anything else is ours."""
    if not code:
        if isinstance(e, SystemExit):
            raise e
        return _internal(command, e)
    args = ", ".join(repr(a) for a in e.args)[:40]
    _fail(command, f"expected design code to return, received {type(e).__name__}({args}) "
                   f"while running {', '.join(c.text() for c in code)}")
    return EXIT_USAGE


def _traceback() -> None:
    if os.environ.get("FORMSYNC_TRACEBACK"):
        traceback.print_exc()


def _internal(command: str, e: BaseException) -> int:
    _fail(command, f"internal error {type(e).__name__}: {e} (a bug in formsync-design; rerun "
                   f"with FORMSYNC_TRACEBACK=1 and report it)")
    _traceback()
    return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
