"""The ``formsync`` parser as the command reference shows it (``docs/cli.md``).

sphinx-argparse parses every help text as reStructuredText, while the texts of
:func:`formsync_design.cli.main.build_parser` are written for a terminal: ``|x(t)|``, ``q_i``,
``*`` and indented examples.  :func:`reference_parser` returns the same parser with those
texts made literal: descriptions and epilogs as preformatted blocks (as ``--help`` prints
them), help strings with reStructuredText's markup characters escaped.  Nothing else changes.
"""

from __future__ import annotations

import argparse
import re
import textwrap

from formsync_design.cli.main import build_parser

__all__ = ["reference_parser"]

_MARKUP = re.compile(r"([\\|*`_<>\[\]])")


def _escaped(text: str | None) -> str | None:
    return None if text is None else _MARKUP.sub(r"\\\1", text)


def _literal(text: str | None) -> str | None:
    """A preformatted block; lines longer than a terminal's wrapped as a terminal shows them."""
    if not text:
        return text
    lines: list[str] = []
    for line in text.splitlines():
        indent = " " * (len(line) - len(line.lstrip()))
        lines += textwrap.wrap(line, width=88, subsequent_indent=indent, break_long_words=False,
                               break_on_hyphens=False) or [""]
    return "::\n\n" + "\n".join("    " + line for line in lines)


def _make_literal(parser: argparse.ArgumentParser) -> None:
    parser.description = _literal(parser.description)
    parser.epilog = _literal(parser.epilog)
    for group in parser._action_groups:
        group.description = _escaped(group.description)
    for action in parser._actions:
        if action.help is not None and action.help != argparse.SUPPRESS:
            action.help = _escaped(action.help)
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                choice.help = _escaped(choice.help)
            for sub in dict.fromkeys(action.choices.values()):
                _make_literal(sub)


def reference_parser() -> argparse.ArgumentParser:
    """``build_parser()`` with its texts made literal for reStructuredText."""
    parser = build_parser()
    _make_literal(parser)
    return parser
