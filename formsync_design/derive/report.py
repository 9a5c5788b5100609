"""The derivation report (Markdown with GitHub-renderable LaTeX) and a LaTeX fragment.

Output is deterministic: no dates, no machine paths, fixed number
formatting, seeded examples, so that rerunning regenerates the same bytes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sympy as sp

from formsync_design.derive.closed_form import closed_form_conditions, pi_pencils
from formsync_design.derive.closed_loop import SpecLike, derive_closed_loop, resolve_spec
from formsync_design.derive.compare import all_findings
from formsync_design.derive.conditions import brute_force_vdot, derive_conditions
from formsync_design.derive.findings import Finding
from formsync_design.derive.templates import derive_local_template
from formsync_design.graphs.build import Graph, make_graph
from formsync_design.models.attitude import derive_attitude_model
from formsync_design.outdir import write_text
from formsync_design.spec.declarations import CLASSIC
from formsync_design.spec.lagrangian_view import ControllerView, LyapunovView
from formsync_design.spec.loader import Spec, gain_symbols

__all__ = ["DerivationReport", "write_derivation_report", "report_basename", "DEFAULT_GRAPH",
           "derivation_command"]

#: The paper's Fig. 2 topology was lost in extraction; the report's default.
DEFAULT_GRAPH = "ring:8"

_BRUTE_FORCE_MAX_N = 8


@dataclass(frozen=True)
class DerivationReport:
    """Paths written by :func:`write_derivation_report` and the verdicts."""

    markdown: Path
    latex: Path
    findings: tuple[Finding, ...]
    brute_force_checked: bool


def report_basename(spec: Spec, graph: Graph) -> str:
    """``<spec>-derivation-<graph slug>`` (e.g. ``liang2016-derivation-ring8``)."""
    slug = "".join(ch for ch in graph.name if ch.isalnum() or ch in "-_")
    if Path(graph.name).exists():
        slug = Path(graph.name).stem
    return f"{spec.name}-derivation-{slug}"


def _pretty_map(spec: Spec) -> dict:
    v = ControllerView(spec.decl)
    M = sp.MatrixSymbol
    out: dict = {
        v.A: M(r"\mathbf{A}_i", 3, 3), v.B: M(r"\mathbf{B}_i", 3, 3), v.Q: M(r"\mathbf{Q}_i", 3, 3),
        v.qd: M(r"\dot{\mathbf{q}}_i", 3, 1), v.s: M(r"\mathbf{s}_i", 3, 1),
        v.sigma: M(r"\boldsymbol{\sigma}_i", 3, 1), M("u_d", 3, 1): M(r"\mathbf{u}_{di}", 3, 1),
    }
    sw = spec.decl.switching
    if sw is not None:
        out[v.gains[sw]] = sp.Symbol(f"{sw}_{{i}}" if sw != "K_v" else "K_{vi}")
    for g in spec.decl.gains:
        if str(g.kind) == "diag" and g.name in v.gains:
            out[v.gains[g.name]] = M(rf"\mathbf{{{g.name}}}", 3, 3)
    return out


def _declarations_section(spec: Spec) -> list[str]:
    """The design's declared gains, graph class and sampling (non-classic designs)."""
    d = spec.decl
    L = ["## Design declarations", "",
         f"Representation `{d.representation}`; sampling `{d.sampling}`; the theorem covers graphs "
         f"that are {', '.join(d.graphs)}.", "",
         "| gain | role | kind | default range | meaning |", "| --- | --- | --- | --- | --- |"]
    for g in d.gains:
        L.append(f"| `{g.name}` | {g.role} | {g.kind} | {g.range if g.range is not None else '-'} "
                 f"| {_cell(g.description) or '-'} |")
    L.append("")
    if d.multipliers:
        L.append("Multipliers are parameters of the Lyapunov candidate only: `formsync certify` "
                 "certifies a gain box when one multiplier value makes every family positive "
                 "definite on the whole box, and searches a grid of values when none is given.")
        L.append("")
    return L


def _lx(expr: Any) -> str:
    return sp.latex(expr).replace("+ -", "- ").replace("-  ", "- ")


def _cell(text: str) -> str:
    """Make text safe inside a Markdown table cell (no bare pipes)."""
    return text.replace("\\|", "\\Vert ").replace("|", "\\vert ").replace("\n", " ")


def _lambda_latex(name: str) -> str:
    """``lambda_max(L)`` -> ``\\lambda_{\\max}(\\mathbf{L})``."""
    which = "max" if "max" in name else "min"
    g = name[name.index("(") + 1 : name.index(")")]
    return f"\\lambda_{{\\{which}}}(\\mathbf{{{g}}})"


def _fmt_value(v: Any) -> str:
    return json.dumps(v, default=str)


def _theta_latex(m: int, spec: Spec) -> str:
    t = derive_local_template(m, spec)
    return _lx(t.theta)


def write_derivation_report(
    graph: Any = DEFAULT_GRAPH, out_dir: str | Path = "reports", spec: SpecLike = None,
    command: str | None = None,
) -> DerivationReport:
    """Derive everything for ``graph`` and write the Markdown report and LaTeX fragment.

    Parameters
    ----------
    graph : graph spec or Graph
    out_dir : path
        Created if missing.
    spec : Spec, AgentDesign, name, path or None
        Default: the paper's specification.  An agent design (``FORM = "agent"``) writes its
        own derivation report (:mod:`formsync_design.derive.agent_report`) and returns that
        report's path.
    command : str, optional
        The command line to print as "regenerate with" (default: ``formsync derive`` with
        the design as given: a shipped name, or a design file's path, which resolves).

    Returns
    -------
    DerivationReport

    Examples
    --------
    >>> import tempfile
    >>> r = write_derivation_report("path:3", tempfile.mkdtemp())
    >>> r.markdown.name
    'liang2016-derivation-path3.md'
    """
    from formsync_design.spec.loader import agent_design_of

    agent = agent_design_of(spec)
    if agent is not None:  # an agent design: its own derivation report (the report's path)
        from formsync_design.derive.agent_report import (
            agent_derivation,
            write_agent_derivation_report,
        )
        from formsync_design.graphs.theorem import load_graph

        ag = load_graph(graph)
        return write_agent_derivation_report(  # type: ignore[return-value]
            agent_derivation(agent, ag), out_dir,
            command=command or f"{derivation_command(spec, agent.name, ag)} --out {out_dir}")
    spec_arg = spec
    spec = resolve_spec(spec)
    g = make_graph(graph)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    base = report_basename(spec, g)
    model = derive_attitude_model()
    cl = derive_closed_loop(spec)
    conds = derive_conditions(g, spec)
    cfs = closed_form_conditions(conds)
    is_paper = spec.name == "liang2016"
    findings = all_findings(g, spec) if is_paper else ()
    brute_ok = False
    if g.n <= _BRUTE_FORCE_MAX_N:
        b, a = brute_force_vdot(g, spec)
        brute_ok = sp.expand(b - a) == 0
    pm = _pretty_map(spec)
    cmd = command or (f"formsync derive --graph {g.name} --out {out_dir}" if spec_arg is None
                      else f"{derivation_command(spec_arg, spec.name, g)} --out {out_dir}")

    L: list[str] = []
    w = L.append
    w(f"# Derivation report: {spec.title}")
    w("")
    w(f"Regenerate with `{cmd}`. Specification: `derivations/{Path(spec.path).name}`. "
      f"Graph: `{g.name}` ({g.n} spacecraft, edges "
      + ", ".join(f"{i}-{j}" for i, j in g.edge_list_1based()) + ").")
    if is_paper and g.name == DEFAULT_GRAPH:
        w("")
        w("> The paper's 8-spacecraft topology (its Fig. 2) was lost in extraction; this report "
          f"assumes `{DEFAULT_GRAPH}`. Every result below is derived for the graph named here; "
          "run the command with another `--graph` for another topology.")
    w("")
    if spec.decl != CLASSIC:
        L.extend(_declarations_section(spec))
    w("Everything below is computed by SymPy from the model equations and the specification; "
      "nothing is typed in. Each scalar block acts on the three axes identically "
      "(checked), i.e. a matrix $F$ shown per axis stands for $F\\otimes\\mathbf{I}_3$.")
    w("")
    w("## 1. Attitude model (paper eqs. 1-3)")
    w("")
    w("Kinematics and dynamics: $\\dot{\\mathbf{q}} = \\mathbf{E}\\boldsymbol{\\omega}$, "
      "$\\mathbf{E} = \\tfrac12(q_0\\mathbf{I}_3 + \\mathbf{q}^\\times)$, "
      "$\\dot q_0 = -\\tfrac12\\mathbf{q}^T\\boldsymbol{\\omega}$, "
      "$\\mathbf{J}\\dot{\\boldsymbol{\\omega}} = -\\boldsymbol{\\omega}^\\times\\mathbf{J}"
      "\\boldsymbol{\\omega} + \\mathbf{u} + \\mathbf{u}_d$. With "
      "$\\boldsymbol{\\omega} = \\mathbf{Q}\\dot{\\mathbf{q}}$, $\\mathbf{Q} = \\mathbf{E}^{-1}$ "
      "(symbolic inverse reduced on $q_0^2 + \\mathbf{q}^T\\mathbf{q} = 1$):")
    w("")
    w("$$")
    w(f"\\mathbf{{Q}} = {_lx(model.Q)}, \\qquad \\dot q_0 = {_lx(model.q0_rate)}")
    w("$$")
    w("")
    w("Premultiplying Euler's equation by $\\mathbf{Q}^T$ gives the Lagrangian form "
      "$\\mathbf{A}\\ddot{\\mathbf{q}} + \\mathbf{B}\\dot{\\mathbf{q}} = \\mathbf{Q}^T\\mathbf{u} + "
      "\\mathbf{Q}^T\\mathbf{u}_d$ with")
    w("")
    w("$$")
    w("\\mathbf{A} = \\mathbf{Q}^T\\mathbf{J}\\mathbf{Q}, \\qquad \\mathbf{B} = "
      "\\mathbf{Q}^T\\mathbf{J}\\dot{\\mathbf{Q}} - \\mathbf{Q}^T(\\mathbf{J}\\mathbf{Q}"
      "\\dot{\\mathbf{q}})^\\times\\mathbf{Q}")
    w("$$")
    w("")
    w("$\\mathbf{B}\\dot{\\mathbf{q}}$ equals $\\mathbf{Q}^T(\\mathbf{J}\\dot{\\mathbf{Q}}\\dot{\\mathbf{q}} "
      "+ \\boldsymbol{\\omega}^\\times\\mathbf{J}\\boldsymbol{\\omega})$ identically (checked "
      "symbolically). $\\mathbf{B}$ itself is not unique; this factorization is the one with "
      "$\\dot{\\mathbf{A}} - 2\\mathbf{B}$ skew-symmetric. The model is also checked in the test "
      "suite against Euler's equation at random states and against the Euler-Lagrange equations "
      "of $T = \\tfrac12\\dot{\\mathbf{q}}^T\\mathbf{A}\\dot{\\mathbf{q}}$.")
    w("")
    w("## 2. Controller and closed loop")
    w("")
    w("Controller (specification):")
    w("")
    w("$$")
    w(f"\\mathbf{{u}}_i = {_lx(cl.control.xreplace(pm))}, \\qquad "
      f"\\boldsymbol{{\\sigma}}_i = \\mathrm{{sgn}}\\left({_lx(cl.switch_argument.xreplace(pm))}\\right)"
      if cl.switch_argument is not None else
      f"\\mathbf{{u}}_i = {_lx(cl.control.xreplace(pm))}")
    w("$$")
    w("")
    w("with $\\mathbf{s}_i = \\sum_{j\\in G_i}(\\mathbf{q}_i - \\mathbf{q}_j)$. Substituting into the "
      "model with $\\mathbf{A}$, $\\mathbf{B}$, $\\mathbf{Q}$ kept as opaque invertible matrices:")
    w("")
    w("$$")
    w(f"\\ddot{{\\mathbf{{q}}}}_i = {_lx(cl.acceleration.xreplace(pm))}")
    w("$$")
    w("")
    w("The model cancels exactly: the closed loop is linear in $(\\dot{\\mathbf{q}}, \\mathbf{s})$ up "
      "to the switching term and the disturbance $\\mathbf{d}_i = \\mathbf{A}_i^{-1}\\mathbf{Q}_i^T"
      "\\mathbf{u}_{di} = \\mathbf{E}_i\\mathbf{J}_i^{-1}\\mathbf{u}_{di}$.")
    w("")
    w("## 3. Lyapunov function and $\\boldsymbol{\\Theta}_i$")
    w("")
    lv = LyapunovView(2, spec.decl)
    w("The candidate's term for a spacecraft with two neighbours ($\\mathbf{e}_k = \\mathbf{q}_i - "
      "\\mathbf{q}_{j_k}$):")
    w("")
    w("$$")
    vi = sp.sympify(spec.lyapunov(lv))
    w(f"V_i = {_lx(vi)}")
    w("$$")
    w("")
    w("$V_i = \\boldsymbol{\\chi}_i^T(\\boldsymbol{\\Theta}_i\\otimes\\mathbf{I}_3)\\boldsymbol{\\chi}_i$, "
      "$\\boldsymbol{\\chi}_i = (\\dot{\\mathbf{q}}_i, \\mathbf{q}_i - \\mathbf{q}_j, j \\in G_i)$; "
      "for the neighbour counts $m$ of this graph:")
    w("")
    for m in sorted(set(g.degrees)):
        who = [i + 1 for i in range(g.n) if g.degrees[i] == m]
        w(f"- $m = {m}$ (spacecraft {', '.join(map(str, who))}):")
        w("")
        w("$$")
        w(f"\\boldsymbol{{\\Theta}}^{{({m})}} = {_theta_latex(m, spec)}")
        w("$$")
        w("")
    w("## 4. Derivative of $V$ along the closed loop")
    w("")
    assert conds.rho is not None  # always set on derived conditions
    rq, rs = conds.rho
    rho_expr = rq * sp.Symbol(r"\dot{\mathbf{q}}_i") + rs * sp.Symbol(r"\mathbf{s}_i")
    w("Per-spacecraft templates (one per neighbour count) are assembled by graph with the "
      "undirected-graph identity $\\sum_i\\sum_{j\\in G_i} c\\,(\\mathbf{q}_i - \\mathbf{q}_j)^T"
      "\\dot{\\mathbf{q}}_j = -c\\sum_j \\dot{\\mathbf{q}}_j^T\\mathbf{s}_j$ into")
    w("")
    w("$$")
    w("\\dot V = -\\boldsymbol{\\zeta}^T(\\boldsymbol{\\Pi}\\otimes\\mathbf{I}_3)\\boldsymbol{\\zeta}"
      + (f" + \\sum_i \\boldsymbol{{\\rho}}_i^T\\left({_lx(cl.c_sigma.xreplace(pm))}\\boldsymbol{{\\sigma}}_i + "
         f"\\mathbf{{d}}_i\\right)" if cl.c_sigma != 0 else
         " + \\sum_i \\boldsymbol{\\rho}_i^T\\mathbf{d}_i")
      + f", \\qquad \\boldsymbol{{\\rho}}_i = {_lx(rho_expr)}")
    w("$$")
    w("")
    w("with $\\boldsymbol{\\zeta} = (\\dot{\\mathbf{q}}_1, \\dots, \\dot{\\mathbf{q}}_n, \\mathbf{s}_1, "
      "\\dots, \\mathbf{s}_n)$ (paper eq. 9; $x, y, z$ within each). "
      + ("The switching argument of the controller **equals** $\\boldsymbol{\\rho}_i$, so "
         "$\\boldsymbol{\\rho}_i^T(\\mathbf{d}_i - K_{vi}\\,\\mathrm{sgn}\\,\\boldsymbol{\\rho}_i) \\le "
         "-(K_{vi} - \\lVert\\mathbf{d}_i\\rVert_\\infty)\\lVert\\boldsymbol{\\rho}_i\\rVert_1$."
         if conds.switching_matches else
         "The controller has no switching term." if cl.switch_argument is None else
         "The switching argument of the controller does **not** equal $\\boldsymbol{\\rho}_i$: "
         "the switching term does not dominate the disturbance in $\\dot V$."))
    w("")
    pen = pi_pencils(conds)
    if pen:
        a_m, g_m, gname_m, _, _ = pen["M"]
        a_n, g_n, gname_n, _, _ = pen["N"]
        sym = {"L": "\\mathbf{L}", "Adj": "\\mathbf{\\mathcal{A}}"}
        w("$$")
        w(f"\\boldsymbol{{\\Pi}} = \\begin{{pmatrix}}\\mathbf{{M}} & 0\\\\ 0 & \\mathbf{{N}}\\end{{pmatrix}},"
          f"\\quad \\mathbf{{M}} = {_lx(a_m)}\\,\\mathbf{{I}}_n {'+' if not str(g_m).startswith('-') else ''}"
          f" {_lx(g_m)}\\,{sym[gname_m]}, \\quad \\mathbf{{N}} = {_lx(a_n)}\\,\\mathbf{{I}}_n"
          + (f" + {_lx(g_n)}\\,{sym[gname_n]}" if g_n != 0 else ""))
        w("$$")
        w("")
        w("($\\mathbf{L}$: graph Laplacian.) ")
    if g.n <= 10:
        P = conds.pi.to_sympy(gain_symbols(spec))
        w(f"Per axis, for `{g.name}`:")
        w("")
        w("$$")
        w(f"\\mathbf{{M}} = {_lx(P[:g.n, :g.n])}")
        w("$$")
        w("")
    if g.n <= _BRUTE_FORCE_MAX_N:
        w("**Cross-check.** A brute-force expansion of $V = \\sum_i V_i$ in all "
          f"{6 * g.n} attitude and rate components, differentiated along the closed loop, "
          + ("agrees identically with the assembled form above." if brute_ok else
             "does **not** agree with the assembled form (a defect: please report it)."))
        w("")
    if spec.decl.switching is not None:
        w("## 5. Disturbance rejection: the $K_{vi}$ condition")
        w("")
        w("$\\mathbf{A}^{-1}\\mathbf{Q}^T = \\mathbf{Q}^{-1}\\mathbf{J}^{-1} = \\mathbf{E}\\mathbf{J}^{-1}$; "
          "$2\\mathbf{E}$ has singular values $\\{1, 1, q_0\\}$ and rotates a vector by at most "
          "$90^\\circ$ when $q_0 \\ge 0$, so $\\sup_{\\bar q}\\lVert\\mathbf{E}\\mathbf{y}\\rVert_\\infty = "
          "\\tfrac12\\lVert\\mathbf{y}\\rVert_2$; the convex $\\lVert\\mathbf{J}^{-1}\\mathbf{u}_d\\rVert_2$ "
          "is largest at a vertex of $\\lvert u_{d,k}\\rvert \\le \\bar u_d$. Hence "
          "$\\varepsilon_i = K_{vi} - \\lVert\\mathbf{d}_i\\rVert_\\infty \\ge 0$ for every attitude and "
          "admissible disturbance if and only if")
        w("")
        w("$$")
        w("K_{vi} \\;\\ge\\; \\frac{\\bar u_d}{2}\\max_{\\mathbf{v}\\in\\{-1,1\\}^3}\\lVert\\mathbf{J}_i^{-1}"
          "\\mathbf{v}\\rVert_2 .")
        w("$$")
        w("")
    else:
        w("## 5. Disturbance rejection")
        w("")
        w("The design has no switching term: the disturbance enters $\\dot V$ as "
          "$\\sum_i \\boldsymbol{\\rho}_i^T\\mathbf{d}_i$ and is not dominated, so a disturbed "
          "formation is only ultimately bounded (the nominal loop converges).")
        w("")
    w("## 6. Closed-form conditions")
    w("")
    w("$\\boldsymbol{\\Theta}_i \\succ 0$ and $\\boldsymbol{\\Pi} \\succ 0$ hold if and only if every "
      "expression below is positive:")
    w("")
    w("| matrix | condition $> 0$ | graph constants | how |")
    w("| --- | --- | --- | --- |")
    for c in cfs:
        consts = ", ".join(f"${_lambda_latex(k)} = {v:.6g}$" for k, v in c.constants.items())
        names = {sp.Symbol(k): _lambda_latex(k) for k in c.constants}
        expr_tex = sp.latex(c.expression, symbol_names=names).replace("+ -", "- ")
        w(f"| {c.family} | ${_cell(expr_tex)}$ | {consts or '-'} | {_cell(c.how)} |")
    w("")
    gl = ("$(K_o, K_q, \\beta)$" if spec.gains == ("K_o", "K_q", "beta") else
          "$(" + ", ".join(sp.latex(x) for x in gain_symbols(spec)) + ")$")
    if all(f.is_multiaffine for f in conds.families):
        w("All entries of $\\boldsymbol{\\Theta}_i$ and $\\boldsymbol{\\Pi}$ are multi-affine in "
          f"{gl}, which is what lets `formsync certify` decide whole gain boxes from "
          "their vertices.")
    else:
        w("Some entries of $\\boldsymbol{\\Theta}_i$ and $\\boldsymbol{\\Pi}$ are not multi-affine in "
          f"{gl}: `formsync certify` decides such families by interval subdivision of the box.")
    w("")
    if findings:
        w("## 7. Paper versus derivation")
        w("")
        w("Each verdict is decided in this run by the computation named beside it "
          "(its value is listed below the table); a verdict key is followed by the question "
          "it answers.")
        w("")
        w("| # | verdict key: question | item | paper (printed) | derived | verdict | decided by | "
          "evidence |")
        w("| --- | --- | --- | --- | --- | --- | --- | --- |")
        for k, f in enumerate(findings, start=1):
            w(f"| {k} | `{f.key}`: {_cell(f.meaning)} | {_cell(f.item)} | {_cell(f.paper)} | "
              f"{_cell(f.derived)} | **{f.verdict}** | {_cell(f.computation.summary())} | "
              f"{_cell(f.evidence)} |")
        w("")
        w("### Computed values, counterexamples and evidence values")
        w("")
        w("Model items are evaluated at spacecraft 1 of the paper's Table 1 "
          "($\\mathbf{q} = (0.1, 0.4, -0.3)$, $q_0 = +\\sqrt{1 - \\mathbf{q}^T\\mathbf{q}}$, "
          "$\\boldsymbol{\\omega} = (0.85, -0.43, 0.77)$ rad/s, $\\mathbf{J}_1$), "
          "$\\dot{\\mathbf{q}} = \\mathbf{E}\\boldsymbol{\\omega}$.")
        w("")
        for k, f in enumerate(findings, start=1):
            w(f"{k}. **{f.key}** ({f.verdict}):")
            w(f"   - computed ({f.computation.kind}): `{_fmt_value(f.computation.to_dict()['value'])}`")
            for name, val in f.counterexample.items():
                w(f"   - {name}: `{_fmt_value(val)}`")
        w("")
    md = out / f"{base}.md"
    write_text(md, "\n".join(L) + "\n")

    # LaTeX fragment
    T: list[str] = [
        f"% {spec.title}; graph {g.name}. Generated by formsync-design ({cmd}).",
        "\\begin{align}",
        f"  \\mathbf{{Q}} &= {_lx(model.Q)} \\\\",
        "  \\mathbf{A} &= \\mathbf{Q}^T\\mathbf{J}\\mathbf{Q}, \\quad \\mathbf{B} = "
        "\\mathbf{Q}^T\\mathbf{J}\\dot{\\mathbf{Q}} - \\mathbf{Q}^T(\\mathbf{J}\\mathbf{Q}"
        "\\dot{\\mathbf{q}})^\\times\\mathbf{Q} \\\\",
        f"  \\mathbf{{u}}_i &= {_lx(cl.control.xreplace(pm))} \\\\",
        f"  \\ddot{{\\mathbf{{q}}}}_i &= {_lx(cl.acceleration.xreplace(pm))} \\\\",
    ]
    for m in sorted(set(g.degrees)):
        T.append(f"  \\boldsymbol{{\\Theta}}^{{({m})}} &= {_theta_latex(m, spec)} \\\\")
    if pen:
        T.append(f"  \\mathbf{{M}} &= {_lx(pen['M'][0])}\\,\\mathbf{{I}}_n + "
                 f"({_lx(pen['M'][1])})\\,\\mathbf{{{'L' if pen['M'][2] == 'L' else 'A'}}}, \\quad "
                 f"\\mathbf{{N}} = {_lx(pen['N'][0])}\\,\\mathbf{{I}}_n \\\\")
    if spec.decl.switching is not None:
        T.append("  K_{vi} &\\ge \\frac{\\bar u_d}{2}\\max_{\\mathbf{v}\\in\\{-1,1\\}^3}"
                 "\\lVert\\mathbf{J}_i^{-1}\\mathbf{v}\\rVert_2")
    elif T[-1].endswith(" \\\\"):
        T[-1] = T[-1][: -len(" \\\\")]
    T.append("\\end{align}")
    tex = out / f"{base}.tex"
    write_text(tex, "\n".join(T) + "\n")
    return DerivationReport(markdown=md, latex=tex, findings=findings, brute_force_checked=brute_ok)


def derivation_command(spec_arg: Any, name: str, graph: Any) -> str:
    """The command that regenerates a derivation report: ``--design NAME`` for a shipped
    design, ``--design PATH`` (as given) for a design file.

    >>> derivation_command("pd_consensus", "pd_consensus", "ring:4")
    'formsync derive --design pd_consensus --graph ring:4'
    >>> derivation_command(Path("my/ma.py"), "ma", "ring:5")
    'formsync derive --design my/ma.py --graph ring:5'
    """
    import shlex

    from formsync_design.resources import design_file, design_names

    if isinstance(spec_arg, (str, Path)) and str(spec_arg) not in design_names():
        ref = str(spec_arg)
    else:
        path = getattr(spec_arg, "path", None)
        shipped = name in design_names() and (
            not path or Path(str(path)).resolve() == design_file(name).resolve())
        ref = name if shipped or not path else str(path)
    gname = getattr(graph, "name", graph)
    return shlex.join(["formsync", "derive", "--design", ref, "--graph", str(gname)])
