"""Verify a case of any kind from Python: :func:`verify_case` (``fs.verify_case``).

``formsync verify CASE`` hands a case to the verifier of its ``[case] kind``
(:mod:`formsync_design.verify.kinds`), which computes every verdict and writes the
report.  :func:`verify_case` dispatches on the same kind and returns the computation's
result object, writing nothing:

============================  ==============================================================
``[case] kind``               result
============================  ==============================================================
``formation`` (the default)   :class:`~formsync_design.verify.results.VerificationResult`
``engine``                    :class:`~formsync_design.verify.engine.EngineVerification`
                              (a tracking design's: :class:`~formsync_design.verify.engine_tracking.TrackingVerification`)
============================  ==============================================================

Each result has the case's judged claims as ``claims``.

>>> from formsync_design.verify.kinds import KINDS
>>> sorted(RESULT_KINDS) == sorted(KINDS)
True
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from formsync_design.errors import InputError
from formsync_design.verify.kinds import case_kind

__all__ = ["RESULT_KINDS", "resolve_case", "verify_case"]

#: Case kind -> the name of the result class :func:`verify_case` returns for it.
RESULT_KINDS: dict[str, str] = {
    "formation": "VerificationResult",
    "engine": "EngineVerification",
}


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
        if not p.is_file():
            raise InputError(f"expected an existing case TOML file, received {str(case)!r}")
        return p
    if case not in case_names():
        raise InputError(f"expected a case name in {case_names()} or a .toml file, "
                         f"received {case!r}")
    return case_file(case)


def verify_case(case_path: str | Path | None = None, *, spec: Any = None,
                progress: Callable[[str], None] | None = None) -> Any:
    """Verify a case file of any kind; return that kind's result (module docstring).

    Parameters
    ----------
    case_path : str, path or None
        A case file, a shipped case's name, or None for the paper's case.
    spec : design name, path, Spec or None
        The design to verify in the case (``formsync verify --design``); default the
        case file's own.
    progress : callable(str), optional
        Called with a short message before each step.

    Raises
    ------
    InputError
        An unknown case name, a missing file, a case of an unknown kind, a formation case
        given an agent design, or anything the kind's verifier refuses.

    Examples
    --------
    >>> res = verify_case("lv2012_small")  # doctest: +SKIP
    >>> type(res).__name__, sorted({c.verdict for c in res.claims})  # doctest: +SKIP
    ('EngineVerification', ['holds', 'undecided'])
    """
    from formsync_design.tomlio import load_toml
    from formsync_design.verify.output import display_path

    path = resolve_case(case_path)
    kind = case_kind(load_toml(path, "case TOML file"), display_path(path))
    if kind == "formation":
        from formsync_design.spec.loader import Spec, lagrangian_view, load_design
        from formsync_design.verify.verification import verify_case as verify_formation

        if spec is not None and not isinstance(spec, Spec):
            spec = load_design(spec)
            spec = lagrangian_view(spec) or spec  # a formation case runs the Lagrangian view
        kind_of = ("agent" if getattr(spec, "form", "lagrangian") == "agent"
                   else getattr(getattr(spec, "decl", None), "kind", "formation"))
        if spec is not None and kind_of != "formation":
            raise InputError(f"expected a formation design for the formation case "
                             f"{display_path(path)}, received {spec.name} (a {kind_of} design)")
        return verify_formation(path, spec=spec, progress=progress)
    if kind == "engine":
        from formsync_design.verify.engine import run_engine
        from formsync_design.verify.enginecase import load_engine_case

        return run_engine(load_engine_case(path, design=spec), progress or (lambda s: None))
    raise InputError(f"expected [case] kind one of {sorted(RESULT_KINDS)} in "  # pragma: no cover
                     f"{display_path(path)}, received {kind!r}")
