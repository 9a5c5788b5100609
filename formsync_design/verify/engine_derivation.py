"""The derivation report an engine case asks for (``[report] derivation = "FORMATION"``).

A design with a Lagrangian view (:func:`~formsync_design.spec.loader.lagrangian_view`) has a
symbolic derivation (closed loop, ``Theta_i``, ``Pi``, the K_v rule:
:func:`~formsync_design.derive.report.write_derivation_report`); the verification writes it
for the named formation's graph beside its own report, with the ``formsync derive`` command
that regenerates it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["derivation_command_line", "write_case_derivation"]


def derivation_command_line(view: Any, graph_name: str, out: str) -> str:
    """The ``formsync derive`` command of the derivation report: ``--graph`` unless the
    default graph, ``--spec`` unless the default specification, ``--out`` unless ``reports``.

    >>> from formsync_design.spec.loader import load_spec
    >>> derivation_command_line(load_spec("liang2016"), "ring:8", "reports")
    'formsync derive'
    >>> derivation_command_line(load_spec("pd_consensus"), "ring:4", "out")
    'formsync derive --graph ring:4 --spec derivations/pd_consensus.py --out out'
    """
    from formsync_design.derive.report import DEFAULT_GRAPH
    from formsync_design.spec.loader import load_spec
    from formsync_design.verify.output import display_path

    cmd = "formsync derive"
    if graph_name != DEFAULT_GRAPH:
        cmd += f" --graph {graph_name}"
    default = load_spec(None)
    if Path(str(view.path)).resolve() != Path(str(default.path)).resolve():
        cmd += f" --spec {display_path(view.path)}"
    if out != "reports":
        cmd += f" --out {out}"
    return cmd


def write_case_derivation(case: Any, out: str | Path) -> Any:
    """Write the derivation report of ``case``'s Lagrangian view on the graph of its
    ``report_derivation`` formation into ``out``; ``None`` when the case asks for none.

    Returns
    -------
    DerivationReport or None
    """
    from formsync_design.derive.report import write_derivation_report
    from formsync_design.spec.loader import lagrangian_view
    from formsync_design.verify.metrics_lagrangian import lagrangian_graph

    if case.report_derivation is None:
        return None
    view = lagrangian_view(case.base.design)
    g = lagrangian_graph(case.formation(case.report_derivation).graph)
    return write_derivation_report(g, out, spec=view,
                                   command=derivation_command_line(view, g.name, str(out)))
