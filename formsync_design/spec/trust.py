"""What can run code, and when: the trust model for design files.

A design is Python (:mod:`formsync_design.spec.loader`); case, scenario and campaign files
are data.  The rules:

* **A shipped design's name is the shipped file.**  ``design = "ma_so3"`` (in a data file or
  on the command line) always loads ``derivations/ma_so3.py`` of this installation; no file
  in the current folder or beside the data file shadows it.  Shipped designs are trusted
  by name, and their runs say nothing more.
* **A data file names a design file only beside itself**: a relative ``.py`` path inside the
  data file's own folder (symbolic links resolved; no ``..`` escape, no absolute path, no
  other extension), :func:`resolve_design_ref`.  Anything else is refused (exit 2, one line).
* **Such a file runs only when the user says so**: ``--design FILE`` on the command line (the
  user named it), ``--trust-design FILE`` (repeatable, every command that reads case or
  campaign files), or in Python :func:`trusting` (or the ``trust=`` argument of
  :func:`~formsync_design.verify.enginecase.load_engine_case`,
  :func:`~formsync_design.verify.case.load_case`,
  :func:`~formsync_design.sweep.campaign.load_campaign`).  Trust is by path **and**
  content: the file is hashed (SHA-256) when it is trusted, and the content that runs is
  the content that was hashed (a file changed after that is refused).  Without trust the
  run stops before any design code runs: exit 2, one line naming the file, its sha256 and
  the flag.  A campaign's trusted design reaches the sweep's Dask workers as its path and
  sha256; a worker loads it only with that content.
* **Every run that loads design code that is not shipped says so**: the file and its sha256,
  on stderr (text output), under the key ``design_code`` (``--format json``) and in every
  report written (the verification report, the sweep's manifest and summary, a
  ``summary.json``).  :func:`design_code` lists the files loaded in this session.

Loading such a file, and the first evaluation of its laws and metrics, run under a time
limit and cannot exit the program (:mod:`formsync_design.spec.contain`).

>>> import pathlib, tempfile
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "case.toml").write_text("")
>>> _ = (d / "mine.py").write_text("FORM = 'agent'\\n")
>>> resolve_design_ref("ma_so3", d / "case.toml", "case.design")
'ma_so3'
>>> resolve_design_ref("mine.py", d / "case.toml", "case.design")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected only shipped designs or design files you trust, received case.design = 'mine.py' in .../case.toml: the file .../mine.py (sha256 ...), not a shipped design; run it only if you trust it: --trust-design .../mine.py
>>> with trusting(d / "mine.py"):
...     resolve_design_ref("mine.py", d / "case.toml", "case.design").name
'mine.py'
>>> resolve_design_ref("../mine.py", d / "case.toml", "case.design")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected case.design a shipped design's name (...) or a relative .py path inside the folder of .../case.toml, received '../mine.py' (it leads outside that folder)
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Callable, Iterable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError

__all__ = [
    "TRUST_FLAG",
    "TrustedFile",
    "design_sha256",
    "trusting",
    "resolve_design_ref",
    "pinned_digest",
    "is_shipped_file",
    "note_loaded",
    "design_code",
    "session_design_code",
    "design_code_of",
    "code_file_of",
    "code_session",
    "notice",
]

#: The command-line flag that trusts a design file named by a data file.
TRUST_FLAG = "--trust-design"


@dataclass(frozen=True)
class TrustedFile:
    """A design file and the SHA-256 of the content trusted (or loaded).

    ``path`` is the path as shown (the one given); ``real`` the resolved path (symbolic links
    followed) trust is keyed by.
    """

    path: str
    sha256: str
    real: str = ""

    @classmethod
    def of(cls, path: str | Path) -> TrustedFile:
        """Hash the file ``path`` now (a missing or unreadable file: :class:`InputError`)."""
        from formsync_design.textio import check_regular

        p = Path(path)
        check_regular(p, f"{TRUST_FLAG} design .py file")
        return cls(str(path), design_sha256(p), os.path.realpath(p))

    def to_dict(self) -> dict[str, str]:
        """``{"path", "sha256"}`` (the JSON and manifest form)."""
        return {"path": self.path, "sha256": self.sha256}

    def text(self) -> str:
        """``PATH (sha256 HEX)``, as the reports and stderr show it."""
        return f"{self.path} (sha256 {self.sha256})"


def design_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of the file's bytes.

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "x.py"
    >>> _ = p.write_text("")
    >>> design_sha256(p)[:12]
    'e3b0c44298fc'
    """
    from formsync_design.textio import read_bytes

    return hashlib.sha256(read_bytes(path, "design file")).hexdigest()


_TRUSTED: ContextVar[frozenset[tuple[str, str]]] = ContextVar("formsync_trusted",
                                                              default=frozenset())
#: Resolved path -> sha256 of the data-file designs trusted in this process (or session):
#: loading that path again requires that content.
_PINNED: dict[str, str] = {}
#: Non-shipped design files loaded, by the path the loader compiled them under.
_LOADED: dict[str, TrustedFile] = {}
_SESSIONS: list[tuple[list[TrustedFile], Callable[[TrustedFile], None] | None]] = []


@contextlib.contextmanager
def trusting(*files: str | Path | TrustedFile) -> Iterator[tuple[TrustedFile, ...]]:
    """Trust the design files ``files`` (hashed now) for the block: a data file read inside
    it may name them.  Yields the :class:`TrustedFile` records.

    >>> with trusting() as t:
    ...     t
    ()
    """
    recs = tuple(f if isinstance(f, TrustedFile) else TrustedFile.of(f) for f in files)
    token = _TRUSTED.set(_TRUSTED.get() | {(r.real or os.path.realpath(r.path), r.sha256)
                                           for r in recs})
    try:
        yield recs
    finally:
        _TRUSTED.reset(token)


def is_shipped_file(path: str | Path) -> bool:
    """Whether ``path`` is a shipped design file of this installation.

    >>> from formsync_design.resources import design_file
    >>> is_shipped_file(design_file("ma_so3")), is_shipped_file("ma_so3.py")
    (True, False)
    """
    from formsync_design.resources import design_file, design_names

    p = Path(path)
    if p.stem not in design_names():
        return False
    return os.path.realpath(p) == os.path.realpath(design_file(p.stem))


def resolve_design_ref(ref: Any, data_file: str | Path, what: str) -> str | Path:
    """The design a data file names (``what``: the key, e.g. ``case.design``): a shipped
    design's name (returned as is), or a trusted ``.py`` file inside the data file's folder
    (its path, pinned to the content trusted).  One-line :class:`InputError` otherwise
    (module docstring).
    """
    from formsync_design.resources import design_names

    names = design_names()
    expected = (f"expected {what} a shipped design's name ({', '.join(names)}) or a relative "
                f".py path inside the folder of {data_file}")
    if not isinstance(ref, str) or not ref.strip():
        raise InputError(f"{expected}, received {ref!r:.60}")
    if ref in names:
        return ref
    p = Path(ref)
    if p.is_absolute():
        raise InputError(f"{expected}, received {ref!r:.80} (an absolute path)")
    if p.suffix != ".py":
        why = "not a shipped design" if ref.isidentifier() else "not a .py file"
        raise InputError(f"{expected}, received {ref!r:.80} ({why})")
    folder = Path(data_file).parent
    real_folder = os.path.realpath(folder)
    target = folder / p
    real = os.path.realpath(target)
    if os.path.commonpath([real_folder, real]) != real_folder:
        raise InputError(f"{expected}, received {ref!r:.80} (it leads outside that folder)")
    if not os.path.isfile(real):
        why = "no such file" if not os.path.lexists(target) else "not a regular file"
        raise InputError(f"{expected}, received {ref!r:.80} ({why})")
    sha = design_sha256(real)
    if (real, sha) not in _TRUSTED.get() and _PINNED.get(real) != sha:
        raise InputError(f"expected only shipped designs or design files you trust, received "
                         f"{what} = {ref!r:.80} in {data_file}: the file {target} (sha256 {sha}), "
                         f"not a shipped design; run it only if you trust it: "
                         f"{TRUST_FLAG} {target}")
    _PINNED[real] = sha
    return target


def pinned_digest(path: str | Path) -> str | None:
    """The sha256 a trusted data-file design at ``path`` was trusted with, else ``None``."""
    return _PINNED.get(os.path.realpath(path))


def note_loaded(where: str, sha256: str) -> None:
    """Record that the non-shipped design file ``where`` (content ``sha256``) was loaded: the
    open :func:`code_session` lists it (and announces it once)."""
    rec = TrustedFile(where, sha256, os.path.realpath(where))
    _LOADED[where] = rec
    for found, announce in _SESSIONS:
        if rec not in found:
            found.append(rec)
            if announce is not None:
                announce(rec)


def design_code() -> list[TrustedFile]:
    """The non-shipped design files loaded in the innermost :func:`code_session` (every one
    loaded in this process when none is open)."""
    if _SESSIONS:
        return list(_SESSIONS[-1][0])
    return list(_LOADED.values())


def session_design_code() -> list[TrustedFile]:
    """The non-shipped design files loaded in the innermost open :func:`code_session` (one
    command), ``[]`` when none is open: a command's output names what *it* loaded, never
    what an earlier call in the same process did.

    >>> session_design_code()
    []
    """
    return list(_SESSIONS[-1][0]) if _SESSIONS else []


def code_file_of(fn: Any) -> TrustedFile | None:
    """The non-shipped design file a function (a metric) was defined in, else ``None``."""
    code = getattr(fn, "__code__", None)
    return _LOADED.get(getattr(code, "co_filename", ""))


def design_code_of(designs: Iterable[Any]) -> list[TrustedFile]:
    """The non-shipped design files among loaded designs (their ``path`` and ``key``), in
    order, once each; designs built in Python (``<python>``) and shipped ones are left out.

    >>> from formsync_design.spec.loader import load_design
    >>> design_code_of([load_design("ma_so3"), None])
    []
    """
    out: list[TrustedFile] = []
    for d in designs:
        path, key = getattr(d, "path", None), getattr(d, "key", None)
        if not path or not key or str(path).startswith("<") or is_shipped_file(path):
            continue
        rec = TrustedFile(str(path), str(key), os.path.realpath(path))
        if rec not in out:
            out.append(rec)
    return out


def notice(command: str) -> Callable[[TrustedFile], None]:
    """The stderr announcement of :func:`code_session` for ``formsync COMMAND`` (text output)."""
    import sys

    def say(rec: TrustedFile) -> None:
        sys.stderr.write(f"formsync {command}: loading design code that is not shipped: "
                         f"{rec.text()}\n")
        sys.stderr.flush()

    return say


@contextlib.contextmanager
def code_session(trusted: Iterable[str | Path] = (),
                 announce: Callable[[TrustedFile], None] | None = None
                 ) -> Iterator[list[TrustedFile]]:
    """One command's trust and record: the files ``trusted`` (hashed now), the list of
    non-shipped design files loaded in the block (yielded; ``announce`` called once per
    file).  Trust given inside the block ends with it.
    """
    pins = dict(_PINNED)
    found: list[TrustedFile] = []
    with trusting(*trusted):
        _SESSIONS.append((found, announce))
        try:
            yield found
        finally:
            _SESSIONS.pop()
            _PINNED.clear()
            _PINNED.update(pins)
