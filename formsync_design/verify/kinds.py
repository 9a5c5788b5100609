"""Case kinds: which verifier judges a case file.

``formsync verify CASE`` reads the case file's ``[case] kind`` and hands the case to the
verifier registered for that kind.  ``"formation"`` (the default, when the key is absent)
is the classic formation case of :mod:`formsync_design.verify.verification`: spacecraft,
gains of a quaternion design, candidate topologies and a ``[claims]`` table.  A design
whose verification has another shape registers its own kind here (the ``engine`` kind
verifies every agent design, and a tracking design through its form:
:mod:`formsync_design.verify.engineform`), implemented by a module of the library with a function::

    verify_kind(request: VerifyRequest) -> int      # the exit status

which validates the case (bad input: :class:`~formsync_design.errors.InputError`, exit 2),
computes every verdict, writes ``<out>/<case file stem>-verification.md`` (and its
figures under ``<out>/figures/<case file stem>-verification/``), prints a summary (or the
JSON document with ``request.format == "json"``) and returns 0, or 1 with
``request.strict`` unless every claim holds.

>>> "formation" in KINDS
True
>>> case_kind({"case": {"name": "x"}}, "x.toml")
'formation'
>>> case_kind({"case": {"kind": "nonsense"}}, "x.toml")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
formsync_design.errors.InputError: expected [case] kind one of [...] in x.toml, received 'nonsense'
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError

__all__ = ["KINDS", "VerifyRequest", "case_kind", "verifier"]

#: Case kind -> ``"module:function"`` of its verifier.
KINDS: dict[str, str] = {
    "formation": "formsync_design.verify.formation:verify_formation_case",
    "engine": "formsync_design.verify.engine:verify_engine_case",
}


@dataclass(frozen=True)
class VerifyRequest:
    """What ``formsync verify`` was asked, after the case file and ``--out`` were checked.

    Attributes
    ----------
    path : Path
        The case file.
    case_arg : str
        The CASE argument as typed (a shipped case's name or a path), for the command line
        printed in the report.
    out : str
        The output folder (checked: no report of another case is replaced unless
        ``overwrite``).
    design : str or None
        ``--design`` (``None``: the case file's own).
    overwrite, strict : bool
    format : str
        ``"text"`` or ``"json"``.
    progress : callable
        One line of progress (to stderr).
    """

    path: Path
    case_arg: str
    out: str
    design: str | None
    overwrite: bool
    strict: bool
    format: str
    progress: Callable[[str], None]

    def command(self, design_option: str | None = None) -> str:
        """The ``formsync verify`` command line printed in the report: the case as typed
        when it is a shipped case's name, else its display path; ``--design`` (or
        ``design_option``, e.g. ``" --spec FILE"``) and ``--out`` when they were given.

        >>> r = VerifyRequest(Path("verification/x.toml"), "x", "out", None, False, False,
        ...                   "text", print)
        >>> r.command()
        'formsync verify x --out out'
        """
        from formsync_design.verify.output import display_path

        shipped = self.case_arg == self.path.stem and not Path(self.case_arg).exists()
        cmd = "formsync verify " + (self.case_arg if shipped else display_path(self.path))
        if design_option is not None:
            cmd += design_option
        elif self.design is not None:
            cmd += f" --design {self.design}"
        if self.out != "reports":
            cmd += f" --out {self.out}"
        return cmd


def case_kind(data: dict[str, Any], source: str) -> str:
    """The ``[case] kind`` of a parsed case document (default ``"formation"``)."""
    meta = data.get("case", {})
    kind = meta.get("kind", "formation") if isinstance(meta, dict) else "formation"
    if not isinstance(kind, str) or kind not in KINDS:
        raise InputError(f"expected [case] kind one of {sorted(KINDS)} in {source}, "
                         f"received {kind!r}")
    return kind


def verifier(kind: str) -> Callable[[VerifyRequest], int]:
    """The verifier function registered for ``kind``."""
    module, _, func = KINDS[kind].partition(":")
    fn: Callable[[VerifyRequest], int] = getattr(importlib.import_module(module), func)
    return fn
