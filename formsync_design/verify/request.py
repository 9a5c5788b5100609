"""What ``formsync verify`` was asked: :class:`VerifyRequest`.

``formsync verify CASE`` checks the case argument and ``--out`` (nothing is computed or
written before), then hands the request to the engine
(:func:`formsync_design.verify.engine.verify_engine_case`), which reads the case file
(:mod:`formsync_design.verify.enginecase`; bad input: :class:`~formsync_design.errors.InputError`,
exit 2), computes every verdict, writes ``<out>/<case file stem>-verification.md`` (and its
figures under ``<out>/figures/<case file stem>-verification/``), prints a summary (or the
JSON document with ``request.format == "json"``) and returns the exit status: 0, or 1 with
``request.strict`` unless every claim holds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

__all__ = ["VerifyRequest"]


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
