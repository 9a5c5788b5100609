"""Command-line interface: ``formsync <subcommand>`` (one thin module per subcommand)."""

from formsync_design.cli.main import build_parser, main

__all__ = ["main", "build_parser"]
