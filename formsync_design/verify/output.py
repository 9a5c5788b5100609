"""Where a verification report goes, how paths are shown, and what may be replaced.

* The report of ``CASE.toml`` is ``<out>/CASE-verification.md`` with figures in
  ``<out>/figures/CASE-verification/``: the name comes from the case file
  actually used (its stem), never from a name written inside it.
* Paths printed in a report are machine-independent (:func:`display_path`):
  ``verification/NAME.toml`` / ``derivations/NAME.py`` for the shipped files,
  relative to the repository for a file inside it, else the bare file name.
* The first line of a report records which case file it verifies
  (:func:`report_marker`).  :func:`check_output` runs before any computation:
  it refuses (one-line :class:`~formsync_design.errors.InputError`, exit 2) an
  ``--out`` that is a file, lies under a file or is not writable, and an
  existing report (or figure folder) of a *different* case unless
  ``overwrite`` is given.  It creates nothing, so a refused run leaves no folder.

>>> display_path(case_file("liang2016"))
'verification/liang2016.toml'
>>> display_path("/somewhere/else/my_case.toml")
'my_case.toml'
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import formsync_design
from formsync_design.errors import InputError, PackagingError
from formsync_design.resources import case_file, design_file

__all__ = [
    "display_path",
    "report_paths",
    "report_marker",
    "read_report_case",
    "check_output",
]

_MARKER = "<!-- formsync verify: case={case} -->"
_MARKER_RE = re.compile(r"^<!-- formsync verify: case=(.*) -->$")
_LEGACY_RE = re.compile(r"Case file: `([^`]+)`")


def _repo_root() -> Path | None:
    """The source checkout the package runs from (an editable install), if any."""
    root = Path(formsync_design.__file__).resolve().parent.parent
    return root if (root / "pyproject.toml").is_file() else None


def _same(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return False


def display_path(path: str | Path) -> str:
    """A path as a report prints it: shipped name, repository-relative, or file name.

    >>> display_path(design_file("liang2016"))
    'derivations/liang2016.py'
    """
    p = Path(path)
    for folder, finder in (("verification", case_file), ("derivations", design_file)):
        try:
            shipped = finder(p.stem)
        except (InputError, PackagingError):  # not a shipped name, or no data package
            continue
        if _same(shipped, p):
            return f"{folder}/{p.name}"
    root = _repo_root()
    if root is not None:
        try:
            return p.resolve().relative_to(root).as_posix()
        except ValueError:
            pass
    return p.name


def report_paths(out_dir: str | Path, report_name: str) -> tuple[Path, Path]:
    """``(<out>/NAME-verification.md, <out>/figures/NAME-verification)``.

    >>> [p.as_posix() for p in report_paths("reports", "liang2016")]
    ['reports/liang2016-verification.md', 'reports/figures/liang2016-verification']
    """
    out = Path(out_dir)
    return out / f"{report_name}-verification.md", out / "figures" / f"{report_name}-verification"


def report_marker(case_display: str) -> str:
    """The first line of a report: which case file it verifies.

    >>> report_marker("verification/liang2016.toml")
    '<!-- formsync verify: case=verification/liang2016.toml -->'
    """
    return _MARKER.format(case=case_display)


def read_report_case(md: Path) -> str | None:
    """The case a report verifies (its marker, or the ``Case file:`` line of an older
    report); None if the file is not a verification report."""
    try:
        text = md.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    first = text.split("\n", 1)[0].strip()
    m = _MARKER_RE.match(first)
    if m:
        return m.group(1)
    m = _LEGACY_RE.search(text[:4000])
    return m.group(1) if m else None


def _check_writable_folder(out: Path) -> None:
    if out.exists():
        if not out.is_dir():
            raise InputError(f"expected --out to be a folder, received {str(out)!r} (a file)")
        if not os.access(out, os.W_OK | os.X_OK):
            raise InputError(f"expected a writable --out folder, received {str(out)!r} (not writable)")
        return
    parent = out.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise InputError(f"expected --out to be a folder path, received {str(out)!r} "
                         f"({str(parent)!r} is a file)")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"expected a writable --out folder, received {str(out)!r} "
                         f"(cannot create it in {str(parent)!r})")


def check_output(out_dir: str | Path, report_name: str, case_display: str,
                 overwrite: bool = False) -> None:
    """Validate the output folder before any computation (module docstring).

    >>> import tempfile
    >>> check_output(tempfile.mkdtemp(), "my_case", "my_case.toml")  # an empty folder is fine
    """
    out = Path(out_dir)
    _check_writable_folder(out)
    if overwrite:
        return
    md, figdir = report_paths(out, report_name)
    for target in (md, figdir):
        if target.exists() and not (target.is_dir() if target == figdir else target.is_file()):
            raise InputError(f"expected {str(target)!r} to be free for the report, received an existing "
                             f"{'file' if target.is_file() else 'folder'}")
    if md.is_file():
        found = read_report_case(md)
        if found != case_display:
            what = f"the case {found!r}" if found else "something that is not a verification report"
            raise InputError(
                f"expected {str(md)!r} to be a report of {case_display!r} or absent, received a report of "
                f"{what}; pass --overwrite to replace it or choose another --out"
            )
    elif figdir.is_dir() and any(figdir.iterdir()):
        raise InputError(
            f"expected no figures of another report in {str(figdir)!r}, received existing files; "
            "pass --overwrite to replace them or choose another --out"
        )
