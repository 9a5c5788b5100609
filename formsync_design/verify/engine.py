"""The verification engine: an ``engine`` case in, every verdict computed, one report out.

``formsync verify CASE`` (:mod:`formsync_design.verify.request`)
reads the case (:mod:`formsync_design.verify.enginecase`), computes each ``[[metrics]]``
row with the registered metric (:mod:`formsync_design.verify.metrics`), judges each
``[[claims]]`` predicate (:mod:`formsync_design.verify.predicates`) and writes the report
(:mod:`formsync_design.verify.engine_report`).  The design file and the metric registry are
the only extension points: nothing here is specific to a paper.

What is computed, once per verification (:class:`EngineResults`, cached):

* **runs**: one simulation per (formation, scenario) a metric reads
  (:func:`~formsync_design.sim.agents.simulate_agents`: the scenario's options, its
  convergence criterion ``angle_tol``/``rate_tol``; a sampled design through
  :func:`~formsync_design.sim.agent_sampled.simulate_agents_sampled`, its record kept: the
  trigger evaluations and the values kept at each broadcast), with the scenario's design
  (its ``sampling`` variant) and period (``period_matching``: from the matched scenario's run
  of the same formation and draw) and gains (``torque_matching``: scaled by the factor that
  gives the matched scenario's peak torque, :meth:`EngineResults.gain_scale`); and per
  Monte-Carlo draw for a ``montecarlo = "max"|"min"``
  row (the draws of :mod:`formsync_design.verify.enginedraws`, the same for every scenario of
  a formation, the ``[montecarlo] tf`` horizon);
* **the design's families** over the ``[families]`` box, per formation
  (:func:`~formsync_design.certify.agent.certify_families`);
* **certificates**: the formation-level certificate
  (:func:`~formsync_design.certify.formation.certify_formation`) of the scenario's gains (a
  point box) on the formation's graph and inertias, the switching function realised as the
  scenario's ``switch`` with its boundary layer; computed for every formation (unless it
  says ``certify = false``) under every scenario (the report's table) and shared between
  scenarios with the same inputs (graph, inertias, gains, switching realisation).  A
  diagonal gain with unequal entries has no point box: no certificate (undecided, said why);
* **Monte-Carlo**: the seeded batch of :func:`~formsync_design.sim.agent_montecarlo.run_agent_montecarlo`
  per (formation, scenario) a metric reads, the draws of ``[montecarlo]``.

A claim's verdict is ``holds``, ``fails`` or ``undecided`` (a metric it needs is unknown, or
the values do not decide it); its *evidence* is the evidence of the metrics that decided it,
and its *basis* is ``proof`` only when every one of them is a certificate, else ``evidence``
(simulation is evidence, never proof).  A certificate declared by the own metric of a design
file that is not shipped is that file's word, not the engine's proof: the basis then reads
``declared by design file PATH (sha256 HEX)`` (:mod:`formsync_design.spec.trust`).

A rate damper ``u = -k J w`` damps the rates (simulation: evidence) but has no attitude
feedback, so its consensus is marginal: the certificate is undecided, and so is the claim:

>>> import pathlib, tempfile
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "damper.py").write_text(
...     'FORM = "agent"\\nGAINS = {"k": {}}\\ndef controller(v):\\n    return -v.k * v.J * v.w\\n')
>>> sc = '[[spacecraft]]\\ninertia = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\\nrate = [0.1, 0, 0]\\nq = [0, 0, 0]\\n'
>>> _ = (d / "c.toml").write_text('''
... [case]
... kind = "engine"
... design = "damper.py"
... graph = "path:2"
... [gains]
... k = 1.0
... [simulation]
... tf = 5.0
... output_step = 0.5
... step = 0.05
... [[metrics]]
... id = "w"
... metric = "final_rate"
... [[metrics]]
... id = "cert"
... metric = "formation_certificate"
... [[claims]]
... id = "damped"
... text = "the rates decay below 0.001 rad/s in 5 s"
... predicate = "w < 1e-3"
... [[claims]]
... id = "stable"
... text = "consensus is locally exponentially stable"
... predicate = 'cert == "certified"'
... ''' + sc + sc)
>>> ver = run_engine(load_engine_case(d / "c.toml", trust=[d / "damper.py"]))  # a file: trusted
>>> [(c.claim.id, c.verdict, c.basis) for c in ver.claims]
[('damped', 'holds', 'evidence'), ('stable', 'undecided', 'evidence')]
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import numpy as np

from formsync_design.notebook import NotebookViews
from formsync_design.verify.enginecase import (
    ClaimRow,
    EngineCase,
    MetricRow,
    load_engine_case,
)
from formsync_design.verify.enginesensors import scenario_inputs
from formsync_design.verify.metrics import MetricContext, MetricValue, format_number, point_gains
from formsync_design.verify.predicates import evaluate
from formsync_design.verify.request import VerifyRequest

__all__ = ["EngineResults", "ClaimVerdict", "EngineVerification", "run_engine",
           "verify_engine_case", "certificate_inputs", "aggregate", "judge", "measure"]


def certificate_inputs(case: Any) -> tuple[dict[str, Fraction] | None, str, str, str]:
    """``(point, switch, phi, why)`` of the certificate of an agent case's gains: the exact
    point (:func:`~formsync_design.verify.metrics.point_gains`; ``None`` when a diagonal
    gain has unequal entries, ``why`` says so), the switching realisation and boundary layer
    of its options."""
    point, why = point_gains(case)
    o = case.options
    return point, str(o.switch), repr(float(o.phi)), why


class EngineResults:
    """The runs, certificates and Monte-Carlo batches of one verification, each computed once
    (implements :class:`~formsync_design.verify.metrics.Results`)."""

    def __init__(self, case: EngineCase, progress: Callable[[str], None] = lambda s: None) -> None:
        self.case = case
        self.progress = progress
        self.runs: dict[tuple[str, str], Any] = {}
        self.draw_runs: dict[tuple[str, str, int], Any] = {}
        self.records: dict[tuple[str, str, int | None], Any] = {}
        self.periods: dict[tuple[str, str, int | None], float] = {}
        self.mc: dict[tuple[str, str], Any] = {}
        self._certs: dict[tuple[Any, ...], Any] = {}
        self._families: dict[str, Any] = {}
        self._draws: dict[tuple[str, str], list[Any]] = {}
        self._memo: dict[tuple[Any, ...], Any] = {}
        self._scales: dict[str, tuple[Any, Any]] = {}
        self.cert_keys: dict[tuple[str, str], tuple[Any, ...]] = {}

    def case_for(self, formation: str, scenario: str) -> Any:
        """The scenario's case on the formation (:meth:`EngineCase.case_for
        <formsync_design.verify.enginecase.EngineCase.case_for>`), with the scaled gains of
        a ``torque_matching`` scenario."""
        c = self.case.case_for(formation, scenario)
        if self.case.scenario(scenario).torque_matching is None:
            return c
        scale = self.gain_scale(scenario)
        assert scale is not None
        return replace(c, gains=scale[1])

    def gain_scale(self, scenario: str) -> tuple[Any, Any] | None:
        """``(search, gains)`` of a ``torque_matching`` scenario: the
        :class:`~formsync_design.analysis.equal_torque.EqualPeak` search (from the factor
        target / literal peak, steps of 1.1) of the one factor on its gains (all but those
        held) that makes its peak torque on the matching formation equal the matched
        scenario's there, and the scaled gains; computed once (``None`` for a scenario
        without torque_matching)."""
        from formsync_design.analysis.equal_torque import equal_peak_scale, scaled_gains

        t = self.case.scenario(scenario).torque_matching
        if t is None:
            return None
        if scenario not in self._scales:
            f = str(t["formation"])
            target = float(np.max(self.run(f, str(t["scenario"])).peak_torque))
            c = self.case.case_for(f, scenario)
            d = self.case.scenario(scenario).run_design
            opt = self.options(f, scenario)
            g = self.case.formation(f).graph

            def peak(k: float) -> float:
                self.progress(f"torque matching {scenario}: gain factor {k:.6g}")
                f0 = c.formation(g, gains=scaled_gains(c.gains, k, t["hold"]))
                return float(np.max(self._simulate(d, f0, opt, {}).peak_torque))

            lit = float(np.max(self._simulate(d, c.formation(g), opt, {}).peak_torque))
            ep = equal_peak_scale(peak, target, rtol=float(t["rtol"]), start=target / lit,
                                  step=1.1)
            self._scales[scenario] = (ep, scaled_gains(c.gains, ep.scale, t["hold"]))
        return self._scales[scenario]

    @staticmethod
    def _simulate(d: Any, f: Any, opt: Any, rec: dict[str, Any],
                  inputs: dict[str, Any] | None = None) -> Any:
        from formsync_design.sim.agents import simulate_agents, simulate_agents_sampled

        if d.decl.sampling != "continuous":
            return simulate_agents_sampled(d, f, opt, record=rec)
        return simulate_agents(d, f, opt, **(inputs or {}))  # a gyro model: verify/enginesensors

    def options(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        """The simulation options of a run: the scenario's, the Monte-Carlo horizon for a
        draw, and the matched period of a ``period_matching`` scenario."""
        from dataclasses import replace

        opt = self.case.case_for(formation, scenario).options
        mc = self.case.montecarlo
        if draw is not None and mc is not None and mc.tf is not None:
            opt = replace(opt, tf=mc.tf)
        match = self.case.scenario(scenario).period_matching
        if match is not None:
            key = (formation, scenario, draw)
            if key not in self.periods:
                tx = self.run(formation, match, draw).transmissions
                k = max(1, int(round(float(np.mean(tx)))))
                self.periods[key] = opt.tf / k
            opt = replace(opt, period=self.periods[key])
        return opt

    def draws(self, formation: str, scenario: str) -> list[Any]:
        """The Monte-Carlo draws of a formation under a scenario
        (:mod:`formsync_design.verify.enginedraws`)."""
        from formsync_design.sim.agent_montecarlo import agent_run_formation
        from formsync_design.verify.enginedraws import euler_draws, reference_draws

        key = (formation, scenario)
        if key not in self._draws:
            mc = self.case.montecarlo
            assert mc is not None  # the case refuses Monte-Carlo rows without [montecarlo]
            c = self.case_for(formation, scenario)
            base = c.formation(self.case.formation(formation).graph)
            st = mc.settings
            runs, max_angle_deg, max_rate = st.numbers()
            if mc.draws == "about-reference":
                self._draws[key] = reference_draws(base, c.reference, runs, st.seed,
                                                   max_angle_deg, mc.rate_sigma)
            elif mc.draws == "euler-uniform":
                self._draws[key] = euler_draws(base, runs, st.seed, max_angle_deg, max_rate)
            else:
                box = self._mc_box(c)
                self._draws[key] = [agent_run_formation(c.design, base, box, st, sd)
                                    for sd in st.run_seeds()]
        return self._draws[key]

    def run(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        key = (formation, scenario, draw)
        store: dict[Any, Any] = self.runs if draw is None else self.draw_runs
        skey = key[:2] if draw is None else key
        if skey not in store:
            sc = self.case.scenario(scenario)
            opt = self.options(formation, scenario, draw)
            f = self.initial(formation, scenario, draw)
            d = sc.run_design
            self.progress(f"simulate {formation} / {scenario}"
                          + ("" if draw is None else f" / draw {draw + 1}"))
            rec: dict[str, Any] = {}
            store[skey] = self._simulate(d, f, opt, rec, scenario_inputs(sc.overrides, f.n))
            self.records[key] = rec
        return store[skey]

    def initial(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        """The formation a run starts from: the case's (resized), or the draw's."""
        if draw is not None:
            return self.draws(formation, scenario)[draw]
        c = self.case_for(formation, scenario)
        return c.formation(self.case.formation(formation).graph)

    def record(self, formation: str, scenario: str, draw: int | None = None) -> Any:
        self.run(formation, scenario, draw)
        return self.records[(formation, scenario, draw)]

    def families(self, formation: str) -> Any:
        """The design's own families (``conditions(c)``) on the formation's graph decided
        over the case's ``[families]`` box
        (:func:`~formsync_design.certify.agent.certify_families`)."""
        from formsync_design.certify.agent import certify_families

        if formation not in self._families:
            self.progress(f"certify the design's families on {formation}")
            self._families[formation] = certify_families(
                self.case.base.design, self.case.formation(formation).graph,
                self.case.families_box or {})
        return self._families[formation]

    def memo(self, key: tuple[Any, ...], compute: Callable[[], Any]) -> Any:
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]

    def certificate(self, formation: str, scenario: str) -> Any:
        from formsync_design.certify.formation import certify_formation
        from formsync_design.gains import GainBox

        c = self.case_for(formation, scenario)
        point, switch, phi, why = certificate_inputs(c)
        if point is None:
            return why
        g = self.case.formation(formation).graph
        ckey = (formation, c.design.key, tuple(sorted(point.items())), switch, phi,
                c.inertias.tobytes())
        self.cert_keys[(formation, scenario)] = ckey
        if ckey not in self._certs:
            self.progress(f"certify {formation} / {scenario}")
            box = GainBox.parse({k: (v, v) for k, v in point.items()})
            self._certs[ckey] = certify_formation(c.design, g, c.inertias, box, switch=switch,
                                                  phi=phi)
        return self._certs[ckey]

    def _mc_box(self, c: Any) -> Any:
        from formsync_design.gains import GainBox

        mc = self.case.montecarlo
        assert mc is not None
        point, _, _, why = certificate_inputs(c)
        ranges: dict[str, Any] = dict(mc.box)
        for k in c.design.decl.controller_gains:
            if k not in ranges:
                if point is None:
                    from formsync_design.errors import InputError

                    raise InputError(f"expected montecarlo.box.{k} ({why}), received none")
                ranges[k] = (point[k], point[k])
        return GainBox.parse(ranges, list(c.design.decl.controller_gains))

    def montecarlo(self, formation: str, scenario: str) -> Any:
        from dataclasses import replace

        from formsync_design.sim.agent_montecarlo import run_agent_montecarlo

        key = (formation, scenario)
        if key not in self.mc:
            mc = self.case.montecarlo
            assert mc is not None  # the case refuses montecarlo metrics without [montecarlo]
            c = self.case_for(formation, scenario)
            box = self._mc_box(c)
            self.progress(f"Monte-Carlo {formation} / {scenario} ({mc.settings.runs} runs)")
            f = c.formation(self.case.formation(formation).graph)
            opt = c.options if mc.tf is None else replace(c.options, tf=mc.tf)
            self.mc[key] = run_agent_montecarlo(c.design, f, box, mc.settings, opt,
                                                certify=False)
        return self.mc[key]


@dataclass(frozen=True)
class ClaimVerdict:
    """A judged claim: the row, ``verdict``, ``deciding`` metric ids, their ``evidence``
    kinds, the ``basis`` (``proof``/``evidence``), the ``values`` it read (id -> text) and
    its ``scope``: the formation / scenario pairs of the deciding metrics."""

    claim: ClaimRow
    verdict: str
    deciding: tuple[str, ...]
    evidence: tuple[str, ...]
    basis: str
    values: tuple[tuple[str, str], ...]
    scope: tuple[str, ...] = ()


@dataclass(frozen=True)
class EngineVerification(NotebookViews):
    """The verification of an engine case: the ``metrics`` (row, value), the ``claims``
    (:class:`ClaimVerdict`), the certificate of every formation x scenario, and the
    cached ``results`` (runs and batches, for the figures)."""

    case: EngineCase
    metrics: tuple[tuple[MetricRow, MetricValue], ...]
    claims: tuple[ClaimVerdict, ...]
    certificates: tuple[tuple[str, str, Any], ...]
    results: EngineResults = field(repr=False, compare=False)

    @property
    def all_hold(self) -> bool:
        return all(c.verdict == "holds" for c in self.claims)


def judge(claim: ClaimRow, values: dict[str, MetricValue],
          rows: dict[str, MetricRow] | None = None) -> ClaimVerdict:
    """The verdict of ``claim`` from the metric values (module docstring); ``rows``: the
    metric rows by id (for the verdict's scope)."""
    out = evaluate(claim.node, {k: v.interval() for k, v in values.items()})
    ev = tuple(sorted({str(values[m].evidence) for m in out.deciding}))
    basis = "proof" if ev == ("certificate",) and out.verdict != "undecided" else "evidence"
    if basis == "proof" and rows is not None:
        declared = _declared_by(rows[m] for m in out.deciding)
        if declared:  # a design file's own metric declared the certificate: its word, not ours
            basis = "declared by design file " + ", ".join(declared)
    read = tuple((m, values[m].text()) for m in sorted(claim.node.names()))
    scope: tuple[str, ...] = ()
    if rows is not None:
        scope = tuple(sorted({f"{rows[m].formation} / {rows[m].scenario}" for m in out.deciding}))
    return ClaimVerdict(claim, out.verdict, out.deciding, ev, basis, read, scope)


def _declared_by(rows: Any) -> list[str]:
    """The non-shipped design files (``PATH (sha256 HEX)``) whose own metrics are among
    ``rows``."""
    from formsync_design.spec.trust import code_file_of

    out: list[str] = []
    for r in rows:
        code = code_file_of(r.spec.fn)
        if code is not None and code.text() not in out:
            out.append(code.text())
    return out


def aggregate(values: list[MetricValue], stat: str, skip_unknown: bool, unit: str
              ) -> MetricValue:
    """The ``max``, ``min`` or ``mean`` of a number metric over the Monte-Carlo draws
    (evidence ``montecarlo``): unknown when a draw has no value (unless ``skip_unknown``:
    those draws are left out); a lower bound when the extreme (for the mean: any value) may
    be one of the lower bounds.

    >>> vs = [MetricValue(2.0, "s", "simulation"), MetricValue(3.0, "s", "simulation", bound="lower")]
    >>> aggregate(vs, "max", False, "s").text(), aggregate(vs, "min", False, "s").text()
    ('>= 3', '2')
    >>> aggregate(vs, "mean", False, "s").text(), aggregate(vs[:1] * 2, "mean", False, "s").text()
    ('>= 2.5', '2')
    >>> aggregate([MetricValue(None, "s", "simulation", "diverged")] + vs, "min", False, "s").value is None
    True
    """
    n = len(values)
    known = [(k, v) for k, v in enumerate(values) if v.value is not None]
    missing = [k + 1 for k, v in enumerate(values) if v.value is None]
    if not known or (missing and not skip_unknown):
        why = values[missing[0] - 1].detail if missing else "no draws"
        return MetricValue(None, unit, "montecarlo", f"{len(missing)} of {n} draws without a "
                           f"value (draw {missing[0] if missing else '-'}: {why})")
    lo = [float(v.value) for _, v in known]  # type: ignore[arg-type]
    lower = [v.bound == "lower" for _, v in known]
    if stat == "mean":
        val = float(np.mean(lo))
        left = f"; {len(missing)} draws without a value left out" if missing else ""
        return MetricValue(val, unit, "montecarlo",
                           f"mean over {len(known)} of {n} draws; range {format_number(min(lo))} "
                           f"to {format_number(max(lo))}{left}",
                           "lower" if any(lower) else "exact")
    if stat == "max":
        k = int(np.argmax(lo))
        bound = "lower" if any(lower) else "exact"
        val = max(lo)
    else:
        k = int(np.argmin(lo))
        exact = [x for x, lb in zip(lo, lower) if not lb]
        val = min(lo)
        bound = "exact" if exact and min(exact) <= val else "lower"
    left = f"; {len(missing)} draws without a value left out ({', '.join(map(str, missing[:5]))})" \
        if missing else ""
    return MetricValue(val, unit, "montecarlo",
                       f"{stat} over {len(known)} of {n} draws (draw {known[k][0] + 1}); range "
                       f"{format_number(min(lo))} to {format_number(max(lo))}{left}", bound)


def _checked(m: MetricRow, v: Any) -> MetricValue:
    """A metric's result, refused (one line) unless it is a MetricValue of the declared kind."""
    from formsync_design.errors import InputError

    want = str if m.spec.value == "text" else float
    if not isinstance(v, MetricValue) or not (v.value is None or isinstance(v.value, want)):
        got = type(v.value if isinstance(v, MetricValue) else v).__name__
        raise InputError(f"expected metric {m.spec.name} to return a MetricValue with a "
                         f"{m.spec.value} value or None, received {got}")
    return v


class _EngineWork:
    """A verification's results as a design file's metric sees them: the engine's own work
    (a run, a certificate, a batch) does not count towards the design code's time limit
    (:func:`formsync_design.spec.contain.paused`)."""

    _ENGINE = frozenset({"run", "record", "options", "initial", "families", "certificate",
                         "montecarlo"})

    def __init__(self, results: Any) -> None:
        self._results = results

    def __getattr__(self, name: str) -> Any:
        from formsync_design.spec.contain import paused

        attr = getattr(self._results, name)
        if name not in self._ENGINE or not callable(attr):
            return attr

        def engine_work(*a: Any, **k: Any) -> Any:
            with paused():
                return attr(*a, **k)

        return engine_work


def measure(m: MetricRow, ctx: MetricContext, check: bool = True) -> MetricValue:
    """A metric's value (``check``: refused unless a :class:`MetricValue` of the declared
    kind); a metric registered by a design file that is not shipped runs under
    :func:`~formsync_design.spec.contain.contained` and its value says which file (and hash)
    declared it (its evidence is that file's word, not the engine's: :func:`judge`)."""
    from formsync_design.spec.contain import contained
    from formsync_design.spec.trust import code_file_of

    code = code_file_of(m.spec.fn)
    if code is None:
        v = m.spec.fn(ctx)
        return _checked(m, v) if check else v
    with contained(code.path, f"metric {m.spec.name}"):
        v = m.spec.fn(replace(ctx, results=_EngineWork(ctx.results)))
        v = _checked(m, v) if check else v
    if not isinstance(v, MetricValue):
        return v
    return replace(v, detail=f"declared by design file {code.text()}"
                   + (f"; {v.detail}" if v.detail else ""))


def run_engine(case: EngineCase, progress: Callable[[str], None] = lambda s: None
               ) -> EngineVerification:
    """Compute every metric, certificate and verdict of ``case`` (module docstring); the case
    of another form is run by its form (:mod:`formsync_design.verify.engineform`)."""
    form = getattr(case, "form", None)
    if form is not None:
        return form.run(case, progress)
    res = EngineResults(case, progress)
    certs = []
    for f in case.formations:
        for s in case.scenarios:
            certs.append((f.name, s.name, res.certificate(f.name, s.name) if f.certify
                          else "not computed (the formation has certify = false)"))
    values: dict[str, MetricValue] = {}
    rows = []
    for m in case.metrics:
        ctx = MetricContext(res.case_for(m.formation, m.scenario), m.formation, m.scenario,
                            m.spec, res, m.args, graph=case.formation(m.formation).graph)
        if m.aggregate is None:
            v = measure(m, ctx)
        else:
            assert case.montecarlo is not None
            per = [measure(m, replace(ctx, draw=k))
                   for k in range(case.montecarlo.settings.numbers()[0])]
            v = aggregate(per, m.aggregate, m.skip_unknown, m.spec.unit)
        values[m.id] = v
        rows.append((m, v))
    by_id = {m.id: m for m in case.metrics}
    claims = tuple(judge(c, values, by_id) for c in case.claims)
    return EngineVerification(case, tuple(rows), claims, tuple(certs), res)


def verify_engine_case(req: VerifyRequest) -> int:
    """``formsync verify`` of an ``engine`` case (exit status: :mod:`formsync_design.verify.request`)."""
    import json

    from formsync_design.verify.engine_report import engine_json, write_engine_report

    case = load_engine_case(req.path, design=req.design)
    ver = run_engine(case, req.progress)
    req.progress("write report")
    if case.report_derivation is not None:
        from formsync_design.verify.engine_derivation import write_case_derivation

        write_case_derivation(case, req.out)
    md, figs = write_engine_report(ver, req.out, req.path.stem, req.command())
    if req.format == "json":
        sys.stdout.write(json.dumps(engine_json(ver, req.command()), indent=2) + "\n")
    else:
        sys.stdout.write(f"wrote {md} ({len(figs)} figures)\n")
        for c in ver.claims:
            sys.stdout.write(f"  {c.verdict:10s} [{c.basis}] {c.claim.id}: {c.claim.text}\n")
    if req.strict and not ver.all_hold:
        return 1
    return 0
