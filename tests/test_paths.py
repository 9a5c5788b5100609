"""No committed text file names a folder that only one machine has (issue 25).

Commands printed for users ("Regenerate: ...", usage lines) use the README's
``.venv/bin/...`` and paths relative to the repository; sources are cited by a
name, not by where one machine keeps them.  Independent truth: the list of
committed files is ``git ls-files`` (skipped outside a git checkout), and each
is read as bytes.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: An absolute path into a home folder, a virtual environment, an interpreter, a checkout or a
#: shared folder of one machine.  ``/work/``, ``/home/`` and ``/Users/`` are always one machine's;
#: ``/root/``, ``/tmp/`` and ``/opt/`` only when the path goes on into a venv, an interpreter, a
#: site-packages or a checkout (``--out /tmp/rep`` in an example, or ``/root/x`` as the file name
#: of a PermissionError in a test, are the user's choice and fine).
_MACHINE_PATH = re.compile(
    r"(?<![\w.~-])(?:/work/|/home/|/Users/"
    r"|/(?:root|tmp|opt)/[^\s'\"`]*?(?:venv|/bin/python|site-packages|/\.git\b|/repo\b|/src/))"
)

#: Legitimate mentions, each explicitly: (committed file, text of the line that may contain it).
#: This file names the patterns it looks for.
_ALLOWED: set[tuple[str, str]] = {
    ("tests/test_paths.py", ""),
}


def _committed_files() -> list[str]:
    git = shutil.which("git")
    if git is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: the committed files are unknown")
    out = subprocess.run([git, "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    return [p for p in out.stdout.decode().split("\0") if p]


def _allowed(path: str, line: str) -> bool:
    return any(path == p and (not text or text in line) for p, text in _ALLOWED)


def machine_paths(text: str) -> list[str]:
    """The machine-specific absolute paths in ``text``.

    >>> machine_paths("run `/work/venv/bin/python x.py` or .venv/bin/python x.py")
    ['/work/']
    >>> machine_paths("formsync derive --out /tmp/rep; PermissionError('/root/x')")
    []
    >>> machine_paths("/tmp/build/.venv/bin/formsync and /Users/me/x")
    ['/tmp/build/.venv', '/Users/']
    """
    return [m.group(0) for m in _MACHINE_PATH.finditer(text)]


def test_the_pattern_finds_what_it_must_and_spares_user_examples() -> None:
    assert machine_paths("Regenerate: `/work/venv/bin/python verification/region_report.py`")
    assert machine_paths("the patent text ``/work/shared/seeds/001.txt``")
    assert machine_paths("/home/alice/formsync/.venv/bin/python")
    assert machine_paths("/root/.venv/bin/formsync")
    assert machine_paths("/tmp/x/venv/bin/python")
    assert not machine_paths("formsync verify my_case.toml --out /tmp/verification")
    assert not machine_paths("Regenerate: `.venv/bin/python verification/region_report.py`")
    assert not machine_paths('PermissionError(13, "Permission denied", "/root/x")')


def test_no_committed_file_names_an_absolute_path_of_one_machine() -> None:
    found = []
    for rel in _committed_files():
        p = ROOT / rel
        if not p.is_file():
            continue
        data = p.read_bytes()
        if b"\0" in data:
            continue  # binary (PNG, NPZ): no printed command in it
        text = data.decode("utf-8", errors="replace")
        for lineno, line in enumerate(text.splitlines(), start=1):
            if _allowed(rel, line):
                continue
            for hit in machine_paths(line):
                found.append(f"{rel}:{lineno}: {hit}")
    assert not found, "absolute paths of one machine in committed files:\n" + "\n".join(found)
