"""Verify a case from Python: :func:`verify_case` (``fs.verify_case``).

``formsync verify CASE`` runs the verification engine on the case file
(:mod:`formsync_design.verify.engine`), which computes every verdict and writes the
report.  :func:`verify_case` runs the same computation and returns its result, writing
nothing: an :class:`~formsync_design.verify.engine.EngineVerification` (a tracking
design's: :class:`~formsync_design.verify.engine_tracking.TrackingVerification`), its
judged claims as ``claims``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.textio import check_regular

__all__ = ["resolve_case", "verify_case"]


def resolve_case(case: str | Path | None) -> Path:
    """The case file of ``case``: a shipped case's name (``"lv2012_small"``), a path to a
    TOML file, or None for the paper's case (``verification/liang2016.toml``).

    >>> resolve_case("lv2012_small").name
    'lv2012_small.toml'
    >>> resolve_case("nonsense")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a case name in [...] or a .toml file, received 'nonsense'
    """
    from formsync_design.resources import case_file, case_names

    if case is None:
        from formsync_design.verify.case import default_case_path

        return default_case_path()
    p = Path(case)
    if isinstance(case, Path) or p.suffix == ".toml" or p.exists():
        check_regular(p, "existing case TOML file")  # a folder, a FIFO, a loop: each its reason
        return p
    if case not in case_names():
        raise InputError(f"expected a case name in {case_names()} or a .toml file, "
                         f"received {case!r}")
    return case_file(case)


def verify_case(case_path: str | Path | None = None, *, spec: Any = None,
                progress: Callable[[str], None] | None = None, trust: Any = ()) -> Any:
    """Verify a case file; return the engine's result (module docstring).

    Parameters
    ----------
    case_path : str, path or None
        A case file, a shipped case's name, or None for the paper's case.
    spec : design name, path, Spec or None
        The design to verify in the case (``formsync verify --design``); default the
        case file's own.
    progress : callable(str), optional
        Called with a short message before each step.
    trust : paths, optional
        Design files (relative ``.py`` paths beside the case) the case and its scenarios may
        name; they are hashed now and run only with that content
        (:mod:`formsync_design.spec.trust`; shipped designs need none).

    Raises
    ------
    InputError
        An unknown case name, a missing file, or anything the case reader refuses
        (:mod:`formsync_design.verify.enginecase`).

    Examples
    --------
    >>> res = verify_case("lv2012_small")  # doctest: +SKIP
    >>> type(res).__name__, sorted({c.verdict for c in res.claims})  # doctest: +SKIP
    ('EngineVerification', ['holds', 'undecided'])
    """
    from formsync_design.verify.engine import run_engine
    from formsync_design.verify.enginecase import load_engine_case

    path = resolve_case(case_path)
    return run_engine(load_engine_case(path, design=spec, trust=trust),
                      progress or (lambda s: None))
