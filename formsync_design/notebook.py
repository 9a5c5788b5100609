"""Notebook views of the results users look at: ``to_pandas()`` and rich summaries.

Every result a notebook cell shows (:class:`~formsync_design.sim.result.SimResult`, the
Monte-Carlo results, a
:class:`~formsync_design.certify.subdivision.RegionMap`, a
:class:`~formsync_design.certify.results.CertificationResult`, an
:class:`~formsync_design.verify.engine.EngineVerification`) has

* ``to_pandas()``: a :class:`pandas.DataFrame` of its time series (a simulation: one row per
  output time) or of its table (one row per run, box, family or claim), whose columns hold
  the result's own arrays; pandas is an optional dependency (the ``notebook`` extra), and
  without it ``to_pandas()`` raises :class:`ModuleNotFoundError` saying how to install it;
* ``_repr_html_()`` / ``_repr_markdown_()``: the headline figures (status, margin,
  convergence time, ...), every text HTML-escaped.

The result classes inherit :class:`NotebookViews`, which calls :func:`frame`, :func:`html`
and :func:`markdown` of this module.

The ``to_pandas()`` columns of each type:

* :class:`SimResult` of the Lagrangian simulator: The time series (``t``, ``q_m``, ``omega_m``, torques ``u<axis>_<spacecraft>``)
* :class:`SimResult` of an agent design: The time series (``t``, ``attitude_error_deg``, ``rate_error``, ``reference_error_deg`` with a leader, torques ``u<axis>_<spacecraft>``)
* :class:`SimResult` of a fly-around: The time series (``t``, ``reference_error_deg`` the attitude tracking error, ``rate_error``, ``position_error_m``, torques ``u<axis>_1``)
* :class:`MonteCarloResult`: One row per run (the columns of ``runs.csv``, those of the campaign's path)
* :class:`RegionMap`: One row per box of the subdivision (``<gain>_lo``, ``<gain>_hi``, ``status``, ``family``, ``reason``)
* :class:`CertificationResult`: One row per matrix family (``family``, ``size``, ``status``, bounds of its smallest eigenvalue)
* :class:`EngineVerification` (and a tracking case's :class:`TrackingVerification`): One row per claim (``id``, ``claim``, ``verdict``, ``basis``, ``source``, ``predicate``, ``deciding`` metrics, ``scope``)

>>> from formsync_design.certify import certify_box
>>> from formsync_design.derive import derive_conditions
>>> res = certify_box(derive_conditions("ring:4"), {"K_o": 1.6, "K_q": 0.4, "beta": 0.3})
>>> "certified" in res._repr_html_() and res._repr_markdown_().startswith("**Certification")
True
"""

from __future__ import annotations

import html as _html
import math
from typing import Any

import numpy as np

__all__ = ["NotebookViews", "require_pandas", "frame", "html", "markdown", "headline"]


def require_pandas() -> Any:
    """The :mod:`pandas` module, or a :class:`ModuleNotFoundError` saying how to install it."""
    try:
        import pandas as pd
    except ModuleNotFoundError:
        raise ModuleNotFoundError(
            "expected pandas for to_pandas() (an optional dependency), received none installed; "
            "install it with pip install 'formsync-design[notebook]' (or pip install pandas)"
        ) from None
    return pd


def _num(v: Any, fmt: str = ".4g", unit: str = "") -> str:
    if v is None:
        return "-"
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    if not math.isfinite(x):
        return str(x)
    return format(x, fmt) + (f" {unit}" if unit else "")


def _torque_columns(u: np.ndarray, n: int) -> dict[str, np.ndarray]:
    u = np.asarray(u).reshape(len(u), n, 3)
    return {f"u{c + 1}_{i + 1}": u[:, i, c] for i in range(n) for c in range(3)}


# --- per result type: (title, headline rows, data frame columns) -------------------------

def _sim(r: Any) -> tuple[str, list[tuple[str, str]]]:
    return "Simulation", [
        ("status", str(r.status)), ("spacecraft", str(r.n)),
        ("horizon", _num(r.options.tf, "g", "s")),
        ("convergence time", _num(r.convergence_time, ".4g", "s")),
        ("final Q_m", _num(r.final_q_m, ".3e")),
        ("final Omega_m", _num(r.final_omega_m, ".3e", "rad/s")),
        ("minimum q0", _num(float(np.min(r.min_q0)), ".4f")),
        ("peak torque", _num(float(np.max(r.peak_torque)), ".4g", "N m")),
    ]


def _sim_frame(r: Any) -> dict[str, Any]:
    return {"t": r.t, "q_m": r.q_m, "omega_m": r.omega_m, **_torque_columns(r.u, r.n)}


def _agent(r: Any) -> tuple[str, list[tuple[str, str]]]:
    rows = [("status", str(r.status)), ("design", r.design), ("graph", r.graph),
            ("convergence time", _num(r.convergence_time, ".4g", "s")),
            ("final attitude disagreement", _num(r.attitude_error[-1], ".3e", "deg")),
            ("final rate error", _num(r.rate_error[-1], ".3e", "rad/s"))]
    if r.reference_error is not None:
        rows.append(("final error to the reference", _num(r.reference_error[-1], ".3e", "deg")))
    rows.append(("peak torque", _num(float(np.max(r.peak_torque)), ".4g", "N m")))
    if r.transmissions is not None:
        rows.append(("transmissions", str(int(np.sum(r.transmissions)))))
    if r.message:
        rows.append(("message", r.message))
    return "Agent simulation", rows


def _agent_frame(r: Any) -> dict[str, Any]:
    cols: dict[str, Any] = {"t": r.t, "attitude_error_deg": r.attitude_error,
                            "rate_error": r.rate_error}
    if r.reference_error is not None:
        cols["reference_error_deg"] = r.reference_error
    n = r.torques.shape[1]
    cols.update(_torque_columns(r.torques.reshape(len(r.t), -1), n))
    return cols


def _mc(r: Any) -> tuple[str, list[tuple[str, str]]]:
    if r.is_agent:
        return _agent_mc(r)
    ct = r.convergence_time_stats
    return "Monte-Carlo", [
        ("status", "all converged" if r.all_converged else f"{len(r.failures)} failed"),
        ("runs", str(len(r.runs))),
        ("converged", f"{len(r.runs) - len(r.failures)}/{len(r.runs)}"),
        ("criterion", f"Q_m <= {r.options.q_tol:g}, Omega_m <= {r.options.omega_tol:g} rad/s"),
        ("convergence time (median, max)",
         f"{_num(ct.get('median'), '.4g')}, {_num(ct.get('max'), '.4g')} s"),
        ("certification of the box", str(r.certification.get("status", "-"))),
    ]


def _agent_mc(r: Any) -> tuple[str, list[tuple[str, str]]]:
    d = r.to_dict()
    return "Agent Monte-Carlo", [
        ("status", "all converged" if r.all_converged else f"{len(r.failures)} failed"),
        ("design", r.design), ("graph", r.graph), ("box", str(r.box)),
        ("converged", f"{d['converged']}/{d['runs']}"),
        ("convergence time (median, max)",
         f"{_num(d['convergence_time_median'], '.4g')}, {_num(d['convergence_time_max'], '.4g')} s"),
        ("box certificate", str(r.certificate) if r.certificate is not None else "-"),
    ]


def _runs_frame(r: Any) -> list[dict[str, Any]]:
    return [run.to_dict() for run in r.runs]


def _region(m: Any) -> tuple[str, list[tuple[str, str]]]:
    f = m.fractions
    return "Region map", [
        ("graph", f"{m.graph} ({m.n} spacecraft)"), ("conditions", m.source),
        ("box", ", ".join(f"{g} in [{float(lo):g}, {float(hi):g}]"
                          for g, (lo, hi) in zip(m.gains, m.ranges))),
        ("certified", f"{f['certified']:.1%}"), ("refuted", f"{f['refuted']:.1%}"),
        ("undecided", f"{f['undecided']:.1%}"), ("boxes", str(len(m.boxes))),
    ]


def _region_frame(m: Any) -> list[dict[str, Any]]:
    rows = []
    for b in m.boxes:
        row: dict[str, Any] = {}
        for g, lo, hi in zip(m.gains, b.lo, b.hi):
            row[f"{g}_lo"], row[f"{g}_hi"] = float(lo), float(hi)
        row.update(status=b.cls, family=b.family, reason=b.reason)
        rows.append(row)
    return rows


def _cert(c: Any) -> tuple[str, list[tuple[str, str]]]:
    lb = c.margin_lower_bound
    rows = [("status", str(c.status)), ("graph", f"{c.graph} ({c.n} spacecraft)"),
            ("conditions", c.source), ("box", str(c.box)),
            ("certified margin", _num(lb, ".6g") if lb is not None else "-")]
    if c.witness is not None:
        rows.append(("witness", f"{c.witness.family} at "
                     + ", ".join(f"{k} = {float(v):g}" for k, v in c.witness.point.items())))
    if c.reason:
        rows.append(("reason", c.reason))
    return "Certification", rows


def _cert_frame(c: Any) -> list[dict[str, Any]]:
    return [{"family": f.name, "size": f.size, "status": str(f.status),
             "certified_lower_bound": None if f.lower is None else float(f.lower),
             "upper_bound": None if f.upper is None else float(f.upper)} for f in c.families]


def _verification(v: Any) -> tuple[str, list[tuple[str, str]]]:
    counts: dict[str, int] = {}
    for c in v.claims:
        counts[c.verdict] = counts.get(c.verdict, 0) + 1
    base = v.case.base
    rows = [("status", "every claim holds" if v.all_hold else "not every claim holds"),
            ("case", f"{base.name} ({v.case.path})"), ("design", base.design.name),
            ("claims", ", ".join(f"{k} {n}" for k, n in sorted(counts.items())))]
    formations = getattr(v.case, "formations", ())
    if formations:
        rows.append(("formations", ", ".join(f"{f.name} ({f.graph.name})" for f in formations)))
    return "Verification", rows


def _verification_frame(v: Any) -> list[dict[str, Any]]:
    return [{"id": c.claim.id, "claim": c.claim.text, "verdict": c.verdict, "basis": c.basis,
             "source": c.claim.source, "predicate": c.claim.predicate,
             "deciding": ", ".join(c.deciding), "scope": "; ".join(c.scope)} for c in v.claims]


def _flyaround(r: Any) -> tuple[str, list[tuple[str, str]]]:
    rec = r.orbit
    last = rec.position_error[-1] if r.t.size else None
    rows = [("status", str(r.status)), ("design", r.design),
            ("convergence time", _num(r.convergence_time, ".4g", "s")),
            ("final attitude tracking error",
             _num(r.reference_error[-1] if r.t.size else None, ".3e", "deg")),
            ("final position error", _num(last, ".3e", "m")),
            ("fuel", _num(rec.fuel, ".4g", "kg")), ("delta-V", _num(rec.delta_v, ".4g", "m/s")),
            ("peak torque", _num(float(np.max(r.peak_torque)), ".4g", "N m")),
            ("message", r.message)]
    return "Fly-around simulation", rows


def _flyaround_frame(r: Any) -> dict[str, Any]:
    return {"t": r.t, "reference_error_deg": r.reference_error, "rate_error": r.rate_error,
            "position_error_m": r.orbit.position_error,
            **_torque_columns(r.torques.reshape(len(r.t), -1), 1)}


def _run(r: Any) -> tuple[str, list[tuple[str, str]]]:
    """A :class:`~formsync_design.sim.result.SimResult`: the Lagrangian simulator's headline
    (its ``Q_m``/``Omega_m``), a fly-around's (its orbit record) or an agent design's."""
    if r.omega_m is not None:
        return _sim(r)
    return _flyaround(r) if r.orbit is not None else _agent(r)


def _run_frame(r: Any) -> dict[str, Any]:
    if r.omega_m is not None:
        return _sim_frame(r)
    return _flyaround_frame(r) if r.orbit is not None else _agent_frame(r)


_VIEWS: dict[str, tuple[Any, Any]] = {
    "SimResult": (_run, _run_frame),
    "MonteCarloResult": (_mc, _runs_frame),
    "RegionMap": (_region, _region_frame),
    "CertificationResult": (_cert, _cert_frame),
    "EngineVerification": (_verification, _verification_frame),
    "TrackingVerification": (_verification, _verification_frame),
}


def _view(obj: Any) -> tuple[Any, Any]:
    name = type(obj).__name__
    if name not in _VIEWS:
        raise TypeError(f"expected one of {sorted(_VIEWS)}, received {name}")
    return _VIEWS[name]


def headline(obj: Any) -> tuple[str, list[tuple[str, str]]]:
    """``(title, [(label, value), ...])``: the headline figures of a result."""
    return _view(obj)[0](obj)


class NotebookViews:
    """The notebook methods every result type shares (a mixin without fields): ``to_pandas``
    (:func:`frame`; the columns per type are in the module docstring), ``_repr_html_``
    (:func:`html`) and ``_repr_markdown_`` (:func:`markdown`)."""

    def to_pandas(self) -> Any:
        """The result as a :class:`pandas.DataFrame` (module docstring; pandas: the
        ``notebook`` extra)."""
        return frame(self)

    def _repr_html_(self) -> str:
        return html(self)

    def _repr_markdown_(self) -> str:
        return markdown(self)


def frame(obj: Any) -> Any:
    """The :class:`pandas.DataFrame` of a result (module docstring)."""
    pd = require_pandas()
    data = _view(obj)[1](obj)
    return pd.DataFrame(data) if isinstance(data, dict) else pd.DataFrame.from_records(data)


def html(obj: Any) -> str:
    """The headline figures of a result as an HTML table (every text escaped).

    >>> "&lt;b&gt;" in _table_html("x", [("status", "<b>")])
    True
    """
    title, rows = headline(obj)
    return _table_html(title, rows)


def _table_html(title: str, rows: list[tuple[str, str]]) -> str:
    e = _html.escape
    body = "".join(f"<tr><th style=\"text-align:left\">{e(k)}</th><td style=\"text-align:left\">"
                   f"{e(v)}</td></tr>" for k, v in rows)
    return f"<table><caption><b>{e(title)}</b></caption>{body}</table>"


def markdown(obj: Any) -> str:
    """The headline figures of a result as Markdown (``|`` and newlines escaped)."""
    title, rows = headline(obj)

    def cell(s: str) -> str:
        return " ".join(str(s).split()).replace("|", "\\|")

    lines = [f"**{cell(title)}**", "", "| | |", "| --- | --- |"]
    lines += [f"| {cell(k)} | {cell(v)} |" for k, v in rows]
    return "\n".join(lines) + "\n"
