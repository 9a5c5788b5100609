"""The derivation report of an agent design on a graph (``formsync derive --design NAME``).

Every statement in it is computed in the run: the quantities the law uses (the free symbols
of the controller, its states and its trigger rule, by quantity class, which proves a
``MEASURED`` declaration), the closed loop of a spacecraft of each in-degree of the graph
(:func:`~formsync_design.derive.agent.agent_closed_loop`), the graph's properties against
the design's theorem, and the certificate families of the design's ``conditions(c)`` hook
with their multi-affinity.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sympy as sp

from formsync_design.derive.agent import AgentConditions, agent_closed_loop, agent_conditions
from formsync_design.outdir import write_text
from formsync_design.spec.agent import AgentDesign, agent_expressions
from formsync_design.spec.agent_view import QUANTITIES

__all__ = ["AgentDerivation", "agent_derivation", "write_agent_derivation_report",
           "quantities_used"]

#: Expressions longer than this (characters of their LaTeX) are summarised by their size.
LATEX_LIMIT = 2500


def quantities_used(design: AgentDesign, m: int = 1) -> dict[str, list[str]]:
    """Per function (controller, states, event, next_interval), the quantity classes of
    :data:`~formsync_design.spec.agent_view.QUANTITIES` whose symbols it contains.

    >>> from formsync_design.spec.agent import agent_design_from_functions
    >>> d = agent_design_from_functions(lambda v: -v.k * v.w, gains={"k": {}})
    >>> quantities_used(d)
    {'controller': ['rate']}
    """
    ex = agent_expressions(design, m)
    cls = ex["view"].symbols_by_class()
    out: dict[str, list[str]] = {}
    exprs: dict[str, Any] = {"controller": ex["u"]}
    if "states" in ex:
        exprs["states"] = sp.Matrix.vstack(*ex["states"].values())
    for k in ("event", "next_interval"):
        if k in ex:
            exprs[k] = ex[k]
    for name, e in exprs.items():
        free = set(sp.Matrix([e]).free_symbols) if not isinstance(e, sp.MatrixBase) \
            else set(e.free_symbols)
        out[name] = [q for q in QUANTITIES if cls[q] & free]
    return out


@dataclass(frozen=True)
class AgentDerivation:
    """What the report shows (all computed; see module docstring)."""

    design: AgentDesign
    graph: Any
    degrees: tuple[int, ...]
    uses: dict[str, list[str]]
    controller_latex: dict[int, str]
    controller_ops: dict[int, int]
    states_latex: dict[str, str]
    properties: dict[str, bool]
    theorem_missing: tuple[str, ...]
    conditions: AgentConditions | None
    conditions_note: str = ""
    monitors: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        c = self.conditions
        return {
            "design": self.design.name, "title": self.design.title, "source": self.design.source,
            "key": self.design.key, "declarations": self.design.decl.to_dict(),
            "graph": self.graph.name, "n": self.graph.n, "in_degrees": list(self.degrees),
            "graph_properties": self.properties, "theorem_missing": list(self.theorem_missing),
            "quantities_used": self.uses,
            "controller_operations": {str(k): v for k, v in self.controller_ops.items()},
            "monitors": list(self.monitors),
            "conditions": None if c is None else [
                {"name": f.name, "size": f.size, "multiaffine": f.is_multiaffine,
                 "rows": list(f.row_labels)} for f in c.families],
            "conditions_note": self.conditions_note,
        }


def agent_derivation(design: AgentDesign, graph: Any) -> AgentDerivation:
    """Derive everything the report shows for ``design`` on ``graph``.

    >>> from formsync_design.spec.loader import load_design
    >>> dv = agent_derivation(load_design("lv2012"), "path:3")
    >>> dv.design.name, dv.graph.n
    ('lv2012', 3)
    """
    from formsync_design.errors import DerivationError
    from formsync_design.graphs.theorem import as_digraph

    g = as_digraph(graph)
    degrees = tuple(sorted({len(g.receives_from(i)) for i in range(g.n)}))
    uses = quantities_used(design, max(degrees[-1], 1) if degrees else 1)
    latex: dict[int, str] = {}
    ops: dict[int, int] = {}
    for m in degrees:
        cl = agent_closed_loop(design, m)
        ops[m] = int(sp.count_ops(cl.u))
        text = sp.latex(cl.u.T)
        latex[m] = text if len(text) <= LATEX_LIMIT else ""
    ex = agent_expressions(design, degrees[0] if degrees else 0)
    states = {n: sp.latex(e.T) for n, e in ex.get("states", {}).items()}
    props = g.properties()
    missing = tuple(p for p in design.decl.graphs if not g.has(p))
    conds, note = None, ""
    if callable(design.module.get("conditions")):
        try:
            conds = agent_conditions(design, g)
        except DerivationError as e:
            note = str(e)
    else:
        note = "the design declares no certificate (no conditions(c) hook)"
    return AgentDerivation(design=design, graph=g, degrees=degrees, uses=uses,
                           controller_latex=latex, controller_ops=ops, states_latex=states,
                           properties=props, theorem_missing=missing, conditions=conds,
                           conditions_note=note, monitors=tuple(ex.get("monitors", {})))


def _family_latex(f: Any) -> str:
    gens = sp.symbols(" ".join(f.gains), positive=True) if len(f.gains) > 1 else (
        sp.Symbol(f.gains[0], positive=True),)
    M = sp.zeros(f.size, f.size)
    for t in f.terms:
        mono = sp.Integer(1)
        for s, e in zip(gens, t.exponents):
            mono *= s**e
        M += sp.Matrix(t.dense()) * sp.Rational(t.coefficient.numerator,
                                                t.coefficient.denominator) * mono
    return sp.latex(M)


def write_agent_derivation_report(d: AgentDerivation, out: str | Path, command: str = "") -> Path:
    """Write ``<out>/<design>-derivation-<graph>.md``; return its path.

    >>> import tempfile
    >>> from formsync_design.spec.loader import load_design
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = write_agent_derivation_report(agent_derivation(load_design("lv2012"), "path:3"), tmp)
    ...     p.name, p.read_text().startswith("# Derivation")
    ('lv2012-derivation-path-3.md', True)
    """
    des = d.design
    safe = "".join(c if c.isalnum() or c in "-_" else "-" for c in d.graph.name)
    path = Path(out) / f"{des.name}-derivation-{safe}.md"
    L: list[str] = [f"# Derivation: {des.title} (`{des.name}`) on `{d.graph.name}`", ""]
    if command:
        L += [f"Regenerate: `{command}`", ""]
    decl = des.decl
    L += ["## Declarations", "", "| part | value |", "| --- | --- |",
          f"| representation | `{decl.representation}` |",
          f"| gains | {', '.join(f'`{g.name}` ({g.role}, {g.kind})' for g in decl.gains)} |",
          f"| graph class | {', '.join(decl.graphs)} |", f"| sampling | {decl.sampling} |",
          f"| controller states | {', '.join(f'{n} ({k})' for n, k in decl.states) or 'none'} |",
          f"| leader | {'yes' if decl.leader else 'no'} |",
          f"| declared MEASURED | {', '.join(decl.measured)} |", ""]
    L += ["## Quantities the law uses (computed from its free symbols)", ""]
    for fn, q in d.uses.items():
        L.append(f"- `{fn}`: {', '.join(q) if q else 'none of the state quantities'}")
    undeclared = sorted({q for qs in d.uses.values() for q in qs} - set(decl.measured))
    L += ["", "Every quantity used is declared." if not undeclared
          else f"Used but not declared: {undeclared}.", ""]
    L += ["## Closed loop", "",
          "Per spacecraft: the representation's kinematics, and "
          "$\\dot\\omega_i = J_i^{-1}(u_i - \\omega_i \\times J_i \\omega_i + d_i)$ with the design's "
          "torque $u_i$ below (in-degree $m$: the number of neighbours it receives from).", ""]
    for m in d.degrees:
        tex = d.controller_latex[m]
        L.append(f"- $m = {m}$ ({d.controller_ops[m]} operations): "
                 + (f"$u^T = {tex}$" if tex else "the expression is longer than the report "
                    f"shows ({LATEX_LIMIT} LaTeX characters); see the design file"))
    for n, tex in d.states_latex.items():
        L.append(f"- controller state `{n}`: $\\dot {n}^T = {tex}$")
    if d.monitors:
        L.append(f"- monitors recorded along simulations: {', '.join(d.monitors)}")
    L += ["", "## Graph", "", f"{d.graph.n} spacecraft, in-degrees {list(d.degrees)}.", "",
          "| property | holds |", "| --- | --- |"]
    L += [f"| {k} | {'yes' if v else 'no'} |" for k, v in d.properties.items()]
    L += ["", ("The graph has every property the design's theorem needs."
               if not d.theorem_missing else
               f"The graph lacks {list(d.theorem_missing)}: outside the design's theorem."), ""]
    L += ["## Certificate", ""]
    if d.conditions is None:
        L += [d.conditions_note, ""]
    else:
        L += ["Each family must be positive definite on the whole gain box (decided by `formsync "
              "certify --design ...` with an exact re-check).", ""]
        for f in d.conditions.families:
            L.append(f"- `{f.name}` ({f.size}x{f.size}, "
                     f"{'multi-affine' if f.is_multiaffine else 'not multi-affine'} in "
                     f"{', '.join(f.gains)}): ${_family_latex(f)}$")
        L.append("")
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, "\n".join(L) + "\n")
    return path
