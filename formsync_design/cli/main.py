"""``formsync``: the command-line interface.

Every subcommand lives in its own module ``formsync_design.cli.<name>`` exposing
``add_parser(subparsers)``; the parser it registers sets ``func`` to a
``run(args) -> int`` callable.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from formsync_design.cli import certify as cmd_certify
from formsync_design.cli import derive as cmd_derive
from formsync_design.cli import design as cmd_design
from formsync_design.cli import montecarlo as cmd_montecarlo
from formsync_design.cli import region as cmd_region
from formsync_design.cli import simulate as cmd_simulate
from formsync_design.cli import sweep as cmd_sweep
from formsync_design.cli import verify as cmd_verify
from formsync_design.cli.options import EXIT_USAGE
from formsync_design.errors import FormsyncError

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
            "fails), 2 bad input or usage."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="command", metavar="SUBCOMMAND", parser_class=_Parser)
    sub.required = True
    for mod in _COMMANDS:
        mod.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``formsync`` with ``argv`` (default ``sys.argv[1:]``); return the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help (0) or usage error (2)
        return int(e.code or 0)
    try:
        return int(args.func(args))
    except BrokenPipeError:  # output piped into e.g. `head`: not an error
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except FormsyncError as e:
        sys.stderr.write(f"formsync {args.command}: error: {e}\n")
        return EXIT_USAGE
    except (OSError, UnicodeDecodeError) as e:
        sys.stderr.write(f"formsync {args.command}: error: {e}\n")
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
