"""Design forms of the verification engine: the one hook by which an engine case whose design
is not an agent design is verified by the same engine, judge and report writer.

The engine's own form is the agent form (``FORM = "agent"``: formations of spacecraft,
:mod:`formsync_design.verify.enginecase`, :mod:`formsync_design.verify.engine`).  A design
of another kind (``KIND = "tracking"``: one spacecraft flying about a target with thrusters)
has its form registered in :data:`FORMS`; :func:`~formsync_design.verify.enginecase.parse_engine_case`
hands its case to the form's :meth:`EngineForm.parse`, :func:`~formsync_design.verify.engine.run_engine`
to its :meth:`EngineForm.run`, and :mod:`formsync_design.verify.engine_report` takes from it
the sections that depend on the form (scenarios, certificates, scope of the evidence, runs,
figures, the JSON tables).  The header, assumptions, metrics, claims, semantics and metric
documentation are the engine's, for every form.  A form's case has ``form`` (the form),
``path``, ``digest``, ``base`` (``name``, ``title``, ``source``, ``assumptions``,
``design``), ``metrics`` (:class:`~formsync_design.verify.enginecase.MetricRow`) and
``claims`` (:class:`~formsync_design.verify.enginecase.ClaimRow`); its verification has
``case``, ``metrics`` ((row, value) pairs), ``claims``
(:class:`~formsync_design.verify.engine.ClaimVerdict`), ``results`` and ``all_hold``.

>>> sorted(FORMS)
['tracking']
>>> design_form({"case": {"design": "ma_so3"}}, "x.toml") is None
True
>>> design_form({"case": {"design": "zhang2014_flyaround"}}, "x.toml").name
'tracking'
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from formsync_design.errors import FormsyncError

__all__ = ["EngineForm", "FORMS", "design_form"]

#: A design's ``KIND`` -> ``"module:attribute"`` of its engine form.
FORMS: dict[str, str] = {
    "tracking": "formsync_design.verify.engine_tracking:FORM",
}


class EngineForm(Protocol):
    """What a form provides the engine (module docstring)."""

    name: str

    def parse(self, data: dict, path: str, design: Any = None) -> Any: ...

    def run(self, case: Any, progress: Callable[[str], None]) -> Any: ...

    def scenario_section(self, case: Any) -> list[str]: ...

    def certificate_section(self, ver: Any) -> list[str]: ...

    def evidence_section(self, ver: Any) -> list[str]: ...

    def runs_section(self, ver: Any) -> list[str]: ...

    def figures(self, ver: Any) -> dict[str, Any]: ...

    def json_tables(self, ver: Any) -> dict[str, Any]: ...


def design_form(data: dict, path: str, design: Any = None) -> EngineForm | None:
    """The form of the case's design (``design``: overrides ``[case] design``), ``None`` for
    an agent design, or one that does not load (the agent case parser reports it)."""
    from formsync_design.resources import design_names
    from formsync_design.spec.loader import load_design

    meta = data.get("case", {})
    ref = design if design is not None else (meta.get("design") if isinstance(meta, dict) else None)
    try:
        if isinstance(ref, str):
            ref = load_design(ref if ref.isidentifier() and ref in design_names()
                              else Path(ref) if Path(ref).is_absolute() else Path(path).parent / ref)
        elif ref is not None:
            ref = load_design(ref)
    except FormsyncError:
        return None
    kind = getattr(getattr(ref, "decl", None), "kind", None)
    if getattr(ref, "form", None) == "agent" or kind not in FORMS:
        return None
    module, _, attr = FORMS[kind].partition(":")
    form: EngineForm = getattr(importlib.import_module(module), attr)
    return form
