"""The one report writer of the verification engine (:mod:`formsync_design.verify.engine`).

:func:`write_engine_report` writes ``<out>/<case stem>-verification.md`` and the figures of
every simulated run under ``<out>/figures/<case stem>-verification/`` (the agent figures
of :mod:`formsync_design.sim.agent_figures`, named ``<formation>-<scenario>-<figure>.png``),
through :mod:`formsync_design.outdir` (atomic writes).  The report holds: the command that
regenerates it, the design and the case (with its sha256), the assumptions, the convergence
criterion of every scenario, the formations x scenarios certificate table with the scope
of every certificate verdict, the scope of the simulation and Monte-Carlo evidence (with
``[report] runs = true``, every simulated run and Monte-Carlo draw), the metrics table, the claims table (verdict, evidence, basis, predicate, the values read), the
written semantics and the metrics' documentation.  :func:`engine_json` is the same as one
JSON document.  Numbers have a fixed format (:func:`~formsync_design.verify.metrics.format_number`),
no time or machine enters, and the Monte-Carlo draws are seeded: a rerun is byte-identical.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from formsync_design.gains import json_number
from formsync_design.outdir import write_text
from formsync_design.verify.metrics import format_number

__all__ = ["engine_markdown", "engine_json", "engine_figures", "write_engine_report",
           "report_design_code"]

_SEMANTICS = [
    "A claim's predicate is read by the engine's own parser "
    "(`formsync_design/verify/predicates.py`; never evaluated as code).  A number metric is "
    "an interval of what the quantity can be: a measured value is exact; a certified decay "
    "rate and a convergence time not reached by the horizon are lower bounds (`>= x`); a "
    "metric without a value (a certificate undecided, a run that diverged or stopped) is "
    "unknown.  A comparison **holds** when it holds for every value of its intervals, "
    "**fails** when it fails for every value, and is **undecided** otherwise or when a metric "
    "it reads is unknown; `and`/`or`/`not` are three-valued (a failing conjunct decides "
    "`and`, a holding disjunct decides `or`).",
    "The evidence of a verdict is the evidence of the metrics that decided it: `certificate` "
    "(an exact or rigorously rounded re-check), `numerical` (floating-point eigenvalues), "
    "`simulation` (one run), `montecarlo` (a seeded batch).  Its basis is **proof** only when "
    "every deciding metric is a certificate; otherwise it is **evidence**: simulation is "
    "evidence, never proof.",
]


def _cell(text: Any) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _g(x: Any) -> str:
    return "-" if x is None else format_number(float(x))


def _run_scope(case: Any, f: str, s: str) -> str:
    c = case.case_for(f, s)
    o = c.options
    g = case.formation(f).graph
    from formsync_design.spec.agent import uses_switching

    d = case.scenario(s).run_design
    rule = d.decl.sampling
    integ = f"{rule} sampling, exact hybrid integrator (DOP853)" if rule != "continuous" else (
        f"{o.integrator}, step {o.step:g} s" if o.integrator == "rk4" else "CVODES")
    switch = (f"switch {o.switch}" + (f", boundary layer {o.phi:g}" if o.switch != "sgn" else "")
              if uses_switching(d) else "no switching function")
    return (f"formation on {g.name} (N = {g.n}) under scenario {s}: one simulated run of the "
            f"nonlinear closed loop over {o.tf:g} s ({integ}, {switch}"
            f", disturbance {c.disturbance.get('model', 'paper')}) [evidence]")


def _mc_scope(case: Any, f: str, s: str) -> str:
    mc = case.montecarlo
    st = mc.settings
    box = ", ".join(f"{k} = {v}" for k, v in sorted(mc.box.items())) or "the scenario's gains"
    g = case.formation(f).graph
    tf = "" if mc.tf is None else f", horizon {mc.tf:g} s"
    if mc.draws == "about-reference":
        return (f"formation on {g.name} (N = {g.n}) under scenario {s}: {st.runs} seeded draws "
                f"(seed {st.seed}{tf}), attitudes rotated from the leader's initial attitude by "
                f"up to {st.max_angle_deg:g} deg about uniform axes, rates N(0, "
                f"{mc.rate_sigma:g}^2) rad/s per axis, disturbance phases drawn, the scenario's "
                "gains [evidence]")
    if mc.draws == "euler-uniform":
        return (f"formation on {g.name} (N = {g.n}) under scenario {s}: {st.runs} seeded draws "
                f"(seed {st.seed}{tf}), every 3-2-1 Euler angle uniform in +-{st.max_angle_deg:g} "
                f"deg, every rate component uniform in +-{st.max_rate:g} rad/s, the scenario's "
                "gains [evidence]")
    return (f"formation on {g.name} (N = {g.n}) under scenario {s}: {st.runs} seeded runs "
            f"(seed {st.seed}{tf}), attitudes up to {st.max_angle_deg:g} deg from the identity, "
            f"rates up to {st.max_rate:g} rad/s, gains {box} [evidence]")


def _scenario_rows(case: Any) -> list[str]:
    L = ["| scenario | description | overrides | tf (s) | angle_tol (deg) | rate_tol (rad/s) |",
         "| --- | --- | --- | --- | --- | --- |"]
    for s in case.scenarios:
        o = s.case.options
        over = "; ".join(f"{t}: " + (", ".join(f"{k} = {v}" for k, v in sorted(d.items()))
                                      if isinstance(d, dict) else str(d))
                         for t, d in sorted(s.overrides.items())) or "none"
        L.append(f"| {s.name} | {_cell(s.description) or '-'} | {_cell(over)} | {o.tf:g} | "
                 f"{o.angle_tol:g} | {o.rate_tol:g} |")
    return L


def _certificate_section(ver: Any) -> list[str]:
    L = ["## Formations and their certificates", "",
         "The formation-level certificate (`formsync_design/certify/formation.py`) of each "
         "scenario's gains on each formation's graph (inertias of the case, cycled when the "
         "size differs).  Scenarios that certify the same system (graph, inertias, gains and "
         "switching realisation) share one row: the certificate is computed once.", "",
         "| formation | graph | N | scenarios | certificate | certified decay rate (1/s) | "
         "largest real part (1/s, floats) | method |",
         "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    groups: dict[tuple[str, Any], tuple[list[str], Any]] = {}
    for f, s, c in ver.certificates:
        key = (f, c if isinstance(c, str) else id(c))
        groups.setdefault(key, ([], c))[0].append(s)
    scopes: list[str] = []
    for (f, _), (names, c) in groups.items():
        g = ver.case.formation(f).graph
        sc = ", ".join(names)
        if isinstance(c, str):
            status = "undecided" if ver.case.formation(f).certify else "not computed"
            L.append(f"| {f} | {_cell(g.name)} | {g.n} | {sc} | {status} | - | - | "
                     f"{_cell(c)} |")
            continue
        ab = c.evidence.get("spectral_abscissa")
        L.append(f"| {f} | {_cell(g.name)} | {g.n} | {sc} | **{c.status}** | {_g(c.decay)} | "
                 f"{_g(ab)} | {_cell(c.evidence.get('method', '')) or '-'} |")
        line = f"- {f} / {sc}: {_cell(c.scope.text())}"
        if c.reason:
            line += f"; reason: {_cell(c.reason)}"
        if c.witness is not None:
            line += f"; witness: {_cell(c.witness.text())}"
        scopes.append(line)
    L += ["", "Scope of every certificate verdict (`formsync_design/certify/scope.py`):", ""]
    L += scopes or ["- none computed"]
    return L + [""]


def _evidence_scopes(ver: Any) -> list[str]:
    runs = sorted({(m.formation, m.scenario) for m, _ in ver.metrics
                   if m.evidence == "simulation"}
                  | {(m.formation, str(m.args["versus"])) for m, _ in ver.metrics
                     if m.evidence == "simulation" and "versus" in m.args})
    mcs = sorted({(m.formation, m.scenario) for m, _ in ver.metrics
                  if m.evidence == "montecarlo"}
                 | {(m.formation, str(m.args["versus"])) for m, _ in ver.metrics
                    if m.evidence == "montecarlo" and "versus" in m.args})
    L = ["## Scope of the simulation evidence", ""]
    L += [f"- {f} / {s}: {_run_scope(ver.case, f, s)}" for f, s in runs]
    L += [f"- {f} / {s} (Monte-Carlo): {_mc_scope(ver.case, f, s)}" for f, s in mcs]
    if not runs and not mcs:
        L.append("- no simulation")
    return L + [""]


def _run_row(res: Any, f: str, s: str, draw: int | None) -> str:
    r = res.run(f, s, draw)
    d = res.case.scenario(s).run_design
    rule = d.decl.sampling
    opt = res.options(f, s, draw)
    per = _g(opt.period) if rule == "periodic" else "-"
    tx = ev = ie = "-"
    if r.transmissions is not None:
        t = np.asarray(r.transmissions)
        tx = f"{int(t.sum())} ({int(t.min())}-{int(t.max())})"
        e = res.record(f, s, draw).get("trigger_evaluations")
        ev = "-" if e is None else str(int(np.sum(e)))
        mn = np.asarray(r.min_interevent, float)
        mean = np.asarray(r.mean_interevent, float)
        if np.any(np.isfinite(mn)):
            ie = f"{_g(np.nanmin(mn))} / {_g(np.nanmean(mean))}"
    ref = "-" if r.reference_error is None else _g(r.reference_error[-1])
    head = f"| {f} | {s} |" if draw is None else f"| {f} | {s} | {draw + 1} |"
    return (f"{head} {rule} | {per} | {r.status} | {tx} | {ev} | {ie} | "
            f"{_g(r.attitude_error[-1])} | {ref} | {_g(float(np.sum(r.effort)))} | "
            f"{_g(float(np.max(r.peak_torque)))} |")


_RUN_COLS = ("sampling | period (s) | status | transmissions (per spacecraft) | trigger "
             "evaluations | min / mean inter-event (s) | final pairwise angle (deg) | final "
             "angle to the reference (deg) | control effort (N^2 m^2 s) | peak torque (N m) |")


def _runs_section(ver: Any) -> list[str]:
    """Every simulated run (formations x scenarios, then the Monte-Carlo draws), as run
    (with ``[report] runs = true``)."""
    res = ver.results
    order = {(f.name, s.name): k for k, (f, s) in enumerate(
        (f, s) for f in ver.case.formations for s in ver.case.scenarios)}
    runs = sorted(res.runs, key=lambda k: order[k])
    if not ver.case.report_runs or (not runs and not res.draw_runs):
        return []
    L = ["## Runs", "",
         "Every run a metric read, as simulated (a sampled design: the exact hybrid integrator, "
         "trigger instants located by root finding; a periodic run's period is the scenario's or "
         "the one its period_matching derived; trigger evaluations: one per broadcast for a "
         "self-trigger, the integrator's crossing detection and root finding for an event "
         "trigger, none for periodic sampling).", ""]
    if runs:
        L += ["| formation | scenario | " + _RUN_COLS, "| --- " * 13 + "|"]
        L += [_run_row(res, f, s, None) for f, s in runs]
        L.append("")
    if res.draw_runs:
        mc = ver.case.montecarlo
        L += [f"Monte-Carlo draws ({mc.draws}, seed {mc.settings.seed}"
              + (f", horizon {mc.tf:g} s" if mc.tf is not None else "") + "): the same draws "
              "for every scenario of a formation.", "",
              "| formation | scenario | draw | " + _RUN_COLS, "| --- " * 14 + "|"]
        keys = sorted(res.draw_runs, key=lambda k: (order[k[:2]] // len(ver.case.scenarios),
                                                     k[2], order[k[:2]]))
        L += [_run_row(res, f, s, k) for f, s, k in keys]
        L.append("")
    return L


def engine_markdown(ver: Any, fig_dir: str, figures: list[str], command: str,
                    case_display: str) -> str:
    """The report's text (module docstring)."""
    from formsync_design.verify.output import display_path, report_marker

    case = ver.case
    b = case.base
    title = b.title or b.name
    L = [report_marker(case_display), "", f"# {title}: verification", "",
         f"Generated by `{command}`: every verdict below is computed in that run (rerun it to "
         "regenerate this report byte for byte).", "",
         f"- design: `{b.design.name}` ({display_path(b.design.path)})"
         if getattr(b.design, "path", None) else f"- design: `{b.design.name}`",
         f"- case: `{case_display}` (sha256 `{case.digest}`)"]
    L += [f"- design code that is not shipped, run on the user's trust: `{c.path}` (sha256 "
          f"`{c.sha256}`)" for c in report_design_code(ver)]
    if b.source:
        L.append(f"- source: {_cell(b.source)}")
    L += ["", "## Assumptions", ""]
    L += [f"- {_cell(a)}" for a in b.assumptions] or ["- none stated"]
    form = getattr(case, "form", None)  # another form's sections (verify/engineform.py)
    if form is not None:
        L += [""] + form.scenario_section(case) + [""] + form.certificate_section(ver)
        L += form.evidence_section(ver) + form.runs_section(ver)
    else:
        L += ["", "## Scenarios and the convergence criterion", "",
              "Converged: from some time to the end of the run, the largest pairwise attitude "
              "angle (and, with a leader, the largest angle to the reference) stays within "
              "angle_tol and the rate error within rate_tol.", ""]
        L += _scenario_rows(case)
        L += [""] + _certificate_section(ver) + _evidence_scopes(ver) + _runs_section(ver)
    L += ["## Metrics", "",
          "| id | metric | formation | scenario | arguments | value | unit | evidence | detail |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for m, v in ver.metrics:
        args = ", ".join([f"{k} = {a}" for k, a in sorted(m.args.items())]
                         + ([f"montecarlo = {m.aggregate}"] if m.aggregate else [])
                         + (["skip_unknown"] if m.skip_unknown else [])) or "-"
        L.append(f"| {m.id} | {m.spec.name} | {m.formation} | {m.scenario} | {_cell(args)} | "
                 f"{_cell(v.text())} | {v.unit} | {v.evidence} | {_cell(v.detail) or '-'} |")
    L += ["", "## Claims", "",
          "| id | claim | source | predicate | values read | verdict | evidence | basis |",
          "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for c in ver.claims:
        vals = ", ".join(f"{k} = {t}" for k, t in c.values)
        L.append(f"| {c.claim.id} | {_cell(c.claim.text)} | {_cell(c.claim.source) or '-'} | "
                 f"`{_cell(c.claim.predicate)}` | {_cell(vals)} | **{c.verdict}** | "
                 f"{', '.join(c.evidence) or '-'} (decided by {', '.join(c.deciding) or '-'}"
                 f"{'; on ' + ', '.join(c.scope) if c.scope else ''}) | {c.basis} |")
    n = {v: sum(c.verdict == v for c in ver.claims) for v in ("holds", "fails", "undecided")}
    L += ["", f"{n['holds']} hold, {n['fails']} fail, {n['undecided']} undecided.", "",
          "## Semantics", ""]
    L += [f"- {s}" for s in _SEMANTICS]
    L += ["", "## Metrics used", "", "| metric | unit | evidence | what it measures |",
          "| --- | --- | --- | --- |"]
    for name in sorted({m.spec.name for m, _ in ver.metrics}):
        spec = next(m.spec for m, _ in ver.metrics if m.spec.name == name)
        L.append(f"| {name} | {spec.unit} | {spec.evidence} | {_cell(spec.doc)} |")
    L.append("")
    if figures:
        L += ["## Figures", ""]
        L += [f"![{f}]({fig_dir}/{f}.png)" for f in figures]
        L.append("")
    return "\n".join(L)


def engine_figures(ver: Any) -> dict[str, Any]:
    """The agent figures of every simulated run (those of ``[report] figures`` when the
    case lists them), by file stem (another form's: its own)."""
    from formsync_design.sim.agent_figures import agent_figures

    form = getattr(ver.case, "form", None)
    if form is not None:
        return form.figures(ver)

    out = {}
    only = getattr(ver.case, "report_figures", None)
    for (f, s), r in sorted(ver.results.runs.items()):
        if only is not None and (f, s) not in only:
            continue
        tol = ver.case.scenario(s).case.options.angle_tol
        for name, fig in agent_figures(r, tol).items():
            out[f"{f}-{s}-{name}"] = fig
    return out


def report_design_code(ver: Any) -> list[Any]:
    """The non-shipped design files of a verification (its design, the scenarios' designs):
    :class:`~formsync_design.spec.trust.TrustedFile` records, named in the report."""
    from formsync_design.spec.trust import design_code_of

    case = ver.case
    designs = [case.base.design, getattr(case.base, "spec", None)]  # a fly-around: .spec
    for s in case.scenarios:
        designs += [getattr(getattr(s, "case", None), "design", None), getattr(s, "run_design", None)]
    return design_code_of(designs)


def engine_json(ver: Any, command: str) -> dict[str, Any]:
    """The verification as one JSON document (numbers by :func:`json_number`)."""
    case = ver.case
    form = getattr(case, "form", None)
    head = {"case": case.base.name, "design": case.base.design.name, "digest": case.digest,
            "command": command, "assumptions": list(case.base.assumptions)}
    code = report_design_code(ver)
    if code:
        head["design_code"] = [c.to_dict() for c in code]
    return head | (_agent_tables(ver) if form is None else form.json_tables(ver)) | {
        "metrics": [{"id": m.id, "metric": m.spec.name, "formation": m.formation,
                     "scenario": m.scenario, "args": dict(m.args),
                     "montecarlo": m.aggregate, **v.to_dict()}
                    for m, v in ver.metrics],
        "claims": [{"id": c.claim.id, "text": c.claim.text, "source": c.claim.source,
                    "predicate": c.claim.predicate, "verdict": c.verdict,
                    "evidence": list(c.evidence), "basis": c.basis,
                    "deciding": list(c.deciding), "values": dict(c.values),
                    "scope": list(c.scope)}
                   for c in ver.claims],
        "all_hold": ver.all_hold,
    }


def _agent_tables(ver: Any) -> dict[str, Any]:
    case = ver.case
    return {
        "formations": [{"name": f.name, "graph": f.graph.name, "n": f.graph.n,
                        "source": f.source} for f in case.formations],
        "scenarios": [{"name": s.name, "overrides": s.overrides,
                       "tf": json_number(s.case.options.tf),
                       "angle_tol": json_number(s.case.options.angle_tol),
                       "rate_tol": json_number(s.case.options.rate_tol)} for s in case.scenarios],
        "certificates": [{"formation": f, "scenario": s, "graph": case.formation(f).graph.name,
                          **({"status": "undecided" if case.formation(f).certify
                              else "not computed", "reason": c} if isinstance(c, str) else
                             {k: v for k, v in c.to_dict().items() if k != "evidence"}
                             | {"method": c.evidence.get("method", ""),
                                "spectral_abscissa": None if c.evidence.get("spectral_abscissa") is None
                                else json_number(float(c.evidence["spectral_abscissa"]))})}
                         for f, s, c in ver.certificates],
    }


def write_engine_report(ver: Any, out: str | Path, stem: str, command: str
                        ) -> tuple[Path, list[Path]]:
    """Write the report and its figures; ``(markdown path, figure paths)``."""
    from formsync_design.sim.figures import save_figure
    from formsync_design.verify.output import display_path, report_paths

    md, figdir = report_paths(out, stem)
    figs = engine_figures(ver)
    paths = []
    if figs:
        figdir.mkdir(parents=True, exist_ok=True)
    for name, fig in figs.items():
        paths.append(save_figure(fig, figdir / f"{name}.png"))
    text = engine_markdown(ver, f"figures/{figdir.name}", list(figs), command,
                           display_path(ver.case.path))
    write_text(md, text)
    return md, paths
