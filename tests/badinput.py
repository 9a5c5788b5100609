"""The bad-input table's harness: one row per bad input a user (or an audit) tried.

A :class:`BadInput` row names the files it writes into a fresh folder, the ``formsync``
arguments it runs there (in-process, ``main(argv)``, with that folder as the current
directory), the exit status it must end with, substrings its stderr must contain and
must not contain, and *sentinel* files that must not exist afterwards (a payload that
would create one did not run).  ``{d}`` in an argument or a file's text is the folder.

The rows live in ``tests/bad_inputs/<area>.py`` (``ROWS = [...]``); ``tests/test_bad_inputs.py``
collects every area into one parametrised table.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["BadInput", "run_bad_input", "PAYLOAD"]

#: A Python payload that proves it ran: it creates the file ``PWNED`` beside itself.
PAYLOAD = (
    "import pathlib\n"
    "pathlib.Path(__file__).with_name('PWNED').write_text('ran')\n"
)


@dataclass(frozen=True)
class BadInput:
    """One bad input and what the command must do with it.

    Attributes
    ----------
    id : str
        A short unique name (the test's id).
    argv : tuple of str
        The arguments of ``formsync`` (``{d}`` is replaced by the row's folder).
    exit : int
        The expected exit status (0 success, 1 negative finding, 2 bad input, 3 failure).
    stderr : tuple of str
        Substrings the standard error must contain (case-sensitive).
    files : mapping of str to str or bytes
        Files to write (relative to the folder; sub-folders are created), ``{d}`` replaced.
    not_in_stderr : tuple of str
        Substrings that must not appear (e.g. the content of a file that must not be echoed).
    sentinels : tuple of str
        Files (relative to the folder) that must not exist after the run.
    symlinks : mapping of str to str
        Symbolic links to create (relative to the folder) and their targets (``{d}`` replaced;
        the target need not exist).
    one_line : bool
        Whether the error must be exactly one line of stderr when ``exit == 2`` (the
        convention; information lines such as "gains from ..." may precede it).
    source : str
        Where the row comes from (the issue or audit that found it).
    """

    id: str
    argv: tuple[str, ...]
    exit: int
    stderr: tuple[str, ...] = ()
    files: Mapping[str, str | bytes] = field(default_factory=dict)
    not_in_stderr: tuple[str, ...] = ()
    sentinels: tuple[str, ...] = ("PWNED",)
    symlinks: Mapping[str, str] = field(default_factory=dict)
    one_line: bool = True
    source: str = ""


def _fill(text: str, d: Path) -> str:
    return text.replace("{d}", str(d))


def run_bad_input(row: BadInput, folder: Path, capsys) -> tuple[int, str, str]:
    """Write the row's files into ``folder``, run ``formsync`` there and check the row.

    Returns ``(status, stdout, stderr)`` for further checks.
    """
    from formsync_design.cli import main

    for rel, content in row.files.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(_fill(content, folder))
    for rel, target in row.symlinks.items():
        (folder / rel).symlink_to(_fill(target, folder))
    argv = [_fill(a, folder) for a in row.argv]
    old = Path.cwd()
    os.chdir(folder)
    try:
        capsys.readouterr()
        try:
            status = main(argv)
        except SystemExit as e:  # argparse's usage errors
            status = e.code if isinstance(e.code, int) else 2
        out, err = capsys.readouterr()
    finally:
        os.chdir(old)
    assert status == row.exit, (
        f"{row.id}: expected exit {row.exit}, received {status}; stderr: {err.strip()[:500]}")
    assert "Traceback" not in err, f"{row.id}: a traceback on stderr: {err[:2000]}"
    for s in row.stderr:
        assert _fill(s, folder) in err, f"{row.id}: expected {s!r} in stderr, received {err!r}"
    for s in row.not_in_stderr:
        assert _fill(s, folder) not in err, f"{row.id}: {s!r} must not be in stderr: {err!r}"
    if row.exit == 2 and row.one_line:
        lines = [ln for ln in err.splitlines() if "error" in ln]
        assert len(lines) == 1, f"{row.id}: expected one error line on stderr, received {err!r}"
    for s in row.sentinels:
        assert not (folder / s).exists(), f"{row.id}: {s} exists: code from a data file ran"
    return status, out, err
