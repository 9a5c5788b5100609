"""Plant forms of the verification engine: the one hook by which an engine case whose design
drives another plant than the attitude plant is verified by the same engine, judge and report
writer.

Every design is declared in one contract (:mod:`formsync_design.spec.agent`).  The engine's
own form is the attitude plant's (formations of spacecraft with body torques,
:mod:`formsync_design.verify.enginecase`, :mod:`formsync_design.verify.engine`).  A design on
another plant (``PLANT = "relative-orbit"``: one spacecraft flying about a target with
thrusters) has its form registered in :data:`FORMS`; :func:`~formsync_design.verify.enginecase.parse_engine_case`
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
['relative-orbit']
>>> design_form({"case": {"design": "ma_so3"}}, "x.toml") is None
True
>>> design_form({"case": {"design": "zhang2014_flyaround"}}, "x.toml").name
'relative-orbit'
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any, Protocol

from formsync_design.errors import FormsyncError

__all__ = ["EngineForm", "FORMS", "design_form"]

#: A design's ``PLANT`` -> ``"module:attribute"`` of its engine form.
FORMS: dict[str, str] = {
    "relative-orbit": "formsync_design.verify.engine_tracking:FORM",
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
    a design on the attitude plant, or one that does not load (the agent case parser reports
    it)."""
    from formsync_design.spec.loader import load_design
    from formsync_design.spec.trust import resolve_design_ref

    meta = data.get("case", {})
    try:
        if design is not None:  # the caller's (--design): loaded as named
            ref = load_design(design)
        elif isinstance(meta, dict) and meta.get("design") is not None:
            ref = load_design(resolve_design_ref(meta["design"], path, "case.design"))
        else:
            ref = None
    except FormsyncError:
        return None
    plant = getattr(getattr(ref, "decl", None), "plant", None)
    if plant not in FORMS:
        return None
    module, _, attr = FORMS[plant].partition(":")
    form: EngineForm = getattr(importlib.import_module(module), attr)
    return form
