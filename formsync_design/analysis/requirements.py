"""A certificate plus design requirements on one gain box (issue 15, CLI restrictions).

:func:`certify_requirements` first decides the box with one of the four
certificates (:func:`.certificates.certify`), then each requirement:

``decay`` alpha
    certified when :func:`.performance.certified_decay_rate` proves
    ``V' <= -2 alpha' V`` on the whole box with ``alpha' >= alpha`` (the
    paper's ``V`` for ``paper``/``exact``, the searched class for
    ``searched``/``spectral``); **refuted** when, at some vertex of the box,
    the shifted characteristic polynomial ``p_k(s - alpha)`` of some Laplacian
    mode violates a Routh-Hurwitz condition on the whole eigenvalue enclosure
    (exact rational bounds): a mode then decays slower than ``alpha``, so no
    Lyapunov function of any class certifies ``alpha``.  Otherwise undecided.
``settle`` T (with ``x0_radius`` r and ``accuracy`` eps)
    certified when the certified rate gives ``ln(sqrt(kappa) r / eps) / alpha <= T``
    (:func:`.performance.settling_time`; ``kappa``, the condition number of ``V``,
    is computed in floating point at the box's vertices); otherwise undecided.
``delay`` tau (``delay_model`` processing | transmission)
    per gain point only: certified when the exact per-mode delay margin
    (:func:`.delay.delay_margin`) exceeds ``tau``, refuted when it does not (a
    root crosses into the right half plane at the margin).
``torque_limit`` U (with ``inertias``, ``att_radius`` r0, ``rate_radius`` w0)
    a gain point or a whole box: certified when the certified peak-torque bound
    (:func:`.torque.peak_torque_bound`, valid for every gain of the box) from every
    ``|q_i(0)| <= r0``, ``|omega_i(0)| <= w0`` is ``<= U`` for every spacecraft; refuted
    when an initial state of the set at a gain of the box already needs more than ``U``
    at ``t = 0`` (:func:`.torque.torque_limit_check`); otherwise undecided.
``graph_set``
    certified when one quadratic Lyapunov function is common to every graph of
    the set and every gain of the box (:func:`.switching.certify_switching`,
    exact re-check): stable under arbitrary switching among the graphs.  Otherwise,
    at a gain point with ``min_dwell`` T: certified when the certified dwell time
    (:func:`.dwell.certify_dwell_time`, per-graph Lyapunov functions) is ``<= T``
    (stable for every switching that stays at least T seconds on each graph);
    otherwise undecided.

The overall verdict is the certificate's unless it is ``certified``; then the
worst requirement's (error > refuted > undecided > certified).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

import sympy as sp

from formsync_design.analysis.certificates import certify
from formsync_design.analysis.delay import DelayModel, delay_margin
from formsync_design.analysis.modecheck import gain_subs, hurwitz_conditions, split_box
from formsync_design.analysis.modes import mode_model, poly_coeffs_in_lambda
from formsync_design.analysis.performance import certified_decay_rate
from formsync_design.analysis.results import Certificate, CertificateResult, Verdict, jsonify
from formsync_design.analysis.spectrum import LaplacianSpectrum, laplacian_spectrum, poly_range
from formsync_design.analysis.switching import certify_switching, graphs_minus_links
from formsync_design.errors import InputError
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph

__all__ = ["Requirements", "RequirementCheck", "RequirementResult", "certify_requirements",
           "parse_graph_set", "decay_refutation"]

_SEVERITY = {Verdict.CERTIFIED: 0, Verdict.UNDECIDED: 1, Verdict.REFUTED: 2, Verdict.ERROR: 3}


@dataclass(frozen=True)
class Requirements:
    """What the gains must achieve besides stability (``None``: not required)."""

    decay: Fraction | None = None
    settle: float | None = None
    x0_radius: float = 0.5
    accuracy: float = 0.01
    delay: float | None = None
    delay_model: DelayModel = DelayModel.PROCESSING
    graph_set: tuple[Any, ...] | None = None
    graph_set_label: str = ""
    min_dwell: float | None = None
    torque_limit: float | None = None
    inertias: Any = None
    att_radius: Fraction = Fraction(1, 10)
    rate_radius: Fraction = Fraction(1, 100)

    def any(self) -> bool:
        """Whether any requirement is set.

        >>> Requirements().any(), Requirements(decay=Fraction(1, 10)).any()
        (False, True)
        """
        return any(x is not None for x in (self.decay, self.settle, self.delay, self.graph_set,
                                           self.torque_limit))


@dataclass(frozen=True)
class RequirementCheck:
    """One requirement's verdict: what was required, what was certified, why."""

    name: str
    status: Verdict
    required: Any
    value: Any
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return jsonify({"name": self.name, "status": str(self.status), "required": self.required,
                        "value": self.value, "reason": self.reason})


@dataclass(frozen=True)
class RequirementResult:
    """The certificate's verdict on the box and each requirement's."""

    status: Verdict
    base: CertificateResult
    checks: tuple[RequirementCheck, ...] = field(default_factory=tuple)

    @property
    def certified(self) -> bool:
        return self.status is Verdict.CERTIFIED

    def to_dict(self) -> dict[str, Any]:
        return {"status": str(self.status), "certificate": self.base.to_dict(),
                "requirements": [c.to_dict() for c in self.checks]}


def parse_graph_set(text: str, graph: Any) -> tuple[tuple[Any, ...], str]:
    """``minus:K`` (the graph and every connected graph without K of its links) or
    a comma-separated list of graph specs (``circulant:N:a,b`` kept whole).

    >>> gs, label = parse_graph_set("minus:1", "ring:4")
    >>> len(gs), label
    (5, 'ring:4 and its 4 connected subgraphs without 1 link(s)')
    >>> [g.name for g in parse_graph_set("ring:6,circulant:6:1,2", "ring:6")[0]]
    ['ring:6', 'circulant:6:1,2']
    """
    g = make_graph(graph)
    text = text.strip()
    if text.startswith("minus:"):
        k_txt = text.split(":", 1)[1]
        if not (k_txt.isascii() and k_txt.isdigit()) or int(k_txt) < 1:
            raise InputError(f"expected --graphs-set minus:K with an integer K >= 1, received {text!r}")
        subs = graphs_minus_links(g, int(k_txt))
        return (g, *subs), f"{g.name} and its {len(subs)} connected subgraphs without {k_txt} link(s)"
    parts: list[str] = []
    for tok in text.split(","):
        tok = tok.strip()
        if parts and ":" not in tok and not Path(tok).is_file():
            parts[-1] += "," + tok  # circulant offsets
        elif tok:
            parts.append(tok)
    if not parts:
        raise InputError(f"expected --graphs-set minus:K or G1,G2,..., received {text!r}")
    gs = tuple(make_graph(p) for p in parts)
    bad = [x.name for x in gs if x.n != g.n]
    if bad:
        raise InputError(f"expected graphs with N={g.n} (the --graph's) in --graphs-set, received {bad}")
    return gs, ", ".join(x.name for x in gs)


def decay_refutation(graph: Any, box: Any, alpha: Any, *, spec: Any = None,
                     spectrum: LaplacianSpectrum | None = None) -> dict[str, Any] | None:
    """A gain vertex and Laplacian mode whose true decay rate is below ``alpha``, proven exactly.

    Along mode ``k`` the nominal loop's characteristic polynomial is ``p_k(s)``;
    every root has real part ``< -alpha`` iff ``p_k(s - alpha)`` is Hurwitz.  A
    Routh-Hurwitz condition of ``p_k(s - alpha)`` that is ``< 0`` on the whole
    eigenvalue enclosure (exact polynomial range) proves a root with real part
    ``> -alpha``.  Returns ``None`` when no vertex refutes.

    >>> w = decay_refutation("ring:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}, 1)
    >>> w["condition"] is not None, decay_refutation("ring:8", {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}, 0.01)
    (True, None)
    """
    g = make_graph(graph)
    mm = mode_model(spec)
    b, _ = split_box(mm, box)
    sp_ = spectrum if spectrum is not None else laplacian_spectrum(g)
    a = Fraction(alpha)
    s = sp.Symbol("s")
    deg = len(mm.charpoly) - 1
    poly = sum((c * (s - sp.Rational(a.numerator, a.denominator)) ** (deg - i)
                for i, c in enumerate(mm.charpoly)), sp.Integer(0))
    shifted = tuple(sp.Poly(sp.expand(poly), s).all_coeffs())
    conds = hurwitz_conditions(shifted)
    for v in b.vertices():
        sub = gain_subs(mm, v)
        for c in sp_.clusters:
            for e in conds:
                coeffs = poly_coeffs_in_lambda(e, sub)
                lo, hi = poly_range(coeffs, c.lo, c.hi)
                if hi < 0:
                    return {"point": dict(zip(mm.names, v)), "lambda": (c.lo, c.hi),
                            "condition": str(e), "upper_bound": hi}
    return None


def _worst(statuses: list[Verdict]) -> Verdict:
    return max(statuses, key=lambda x: _SEVERITY[x]) if statuses else Verdict.CERTIFIED


def certify_requirements(graph: Any, box: Any, certificate: str | Certificate, req: Requirements, *,
                         spec: Any = None, margin: Any = 0, spectrum: LaplacianSpectrum | None = None,
                         use_sdp: bool = True) -> RequirementResult:
    """Decide a gain box with a certificate and every requirement in ``req``.

    Examples
    --------
    >>> pt = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    >>> r = certify_requirements("ring:8", pt, "exact", Requirements(decay=Fraction(1, 100), delay=0.5))
    >>> r.status.value, [c.status.value for c in r.checks]
    ('certified', ['certified', 'certified'])
    >>> certify_requirements("ring:8", pt, "exact", Requirements(delay=2.0)).status.value
    'refuted'
    """
    g = make_graph(graph)
    mm = mode_model(spec)
    b, given = split_box(mm, box)
    cert = Certificate(str(certificate))
    if req.delay is not None and not all(r.is_point for r in b.ranges):
        raise InputError("expected a gain point (X, not LO:HI) with --delay: the delay margin is "
                         f"certified per gain point, received {b}")
    if req.torque_limit is not None:
        if req.inertias is None:
            raise InputError("expected inertias (--inertia or --case) with --torque-limit, received none")
    sp_ = spectrum if spectrum is not None else laplacian_spectrum(g)
    full = GainBox((*b.ranges, *given.ranges)) if given is not None else b
    base = certify(g, full, cert, spec=spec, margin=margin, spectrum=sp_, use_sdp=use_sdp)
    if not base.certified:
        return RequirementResult(base.status, base, ())
    checks: list[RequirementCheck] = []
    if req.decay is not None or req.settle is not None:
        checks.extend(_decay_checks(g, full, cert, req, spec, sp_))
    if req.delay is not None:
        checks.append(_delay_check(g, b, req, spec))
    if req.torque_limit is not None:
        checks.append(_torque_check(g, b, req, spec))
    if req.graph_set is not None:
        checks.append(_graph_set_check(b, req, spec))
    return RequirementResult(_worst([c.status for c in checks]), base, tuple(checks))


def _decay_checks(g: Any, b: GainBox, cert: Certificate, req: Requirements, spec: Any,
                  sp_: LaplacianSpectrum) -> list[RequirementCheck]:
    cls = "exact" if cert in (Certificate.PAPER, Certificate.EXACT) else "searched"
    d = certified_decay_rate(g, b, cls, spec=spec)
    out = []
    if req.decay is not None:
        if d.status is Verdict.CERTIFIED and d.alpha >= req.decay:
            out.append(RequirementCheck("decay", Verdict.CERTIFIED, req.decay, d.alpha,
                                        f"V' <= -2 alpha V on the whole box ({cls} class, exact re-check)"))
        else:
            w = decay_refutation(g, b, req.decay, spec=spec, spectrum=sp_)
            if w is not None:
                pt = ", ".join(f"{k}={float(v):g}" for k, v in w["point"].items())
                out.append(RequirementCheck(
                    "decay", Verdict.REFUTED, req.decay, d.alpha,
                    f"at {pt} a Laplacian mode (lambda in [{float(w['lambda'][0]):g}, "
                    f"{float(w['lambda'][1]):g}]) decays slower than alpha: Routh-Hurwitz condition "
                    f"{w['condition']} of p(s - alpha) is <= {float(w['upper_bound']):g} < 0 (exact)"))
            else:
                out.append(RequirementCheck(
                    "decay", Verdict.UNDECIDED, req.decay, d.alpha,
                    f"the certified rate ({cls} class) is {float(d.alpha):g} < {float(req.decay):g} "
                    "and no mode is proven slower (a narrower box or the searched class may certify it)"))
    if req.settle is not None:
        t = d.settling_time(req.x0_radius, req.accuracy) if d.status is Verdict.CERTIFIED else math.inf
        ok = t <= req.settle
        out.append(RequirementCheck(
            "settle", Verdict.CERTIFIED if ok else Verdict.UNDECIDED, req.settle, t,
            f"|x(t)| <= {req.accuracy:g} for t >= {t:.4g} s from every |x(0)| <= {req.x0_radius:g} "
            f"(alpha = {float(d.alpha):.4g}, kappa = {d.kappa:.4g})"
            + ("" if ok else f"; not within {req.settle:g} s")))
    return out


def _delay_check(g: Any, b: GainBox, req: Requirements, spec: Any) -> RequirementCheck:
    assert req.delay is not None
    dm = delay_margin(g, tuple(r.lo for r in b.ranges), req.delay_model, spec=spec)
    ok = dm.margin > req.delay
    lam = "" if dm.critical_lambda is None else f", critical lambda = {dm.critical_lambda:g}"
    exact = dm.method == "quasi-polynomial"  # else a sufficient Lyapunov-Krasovskii lower bound
    how = f"exact per Laplacian mode{lam}" if exact else "Lyapunov-Krasovskii lower bound"
    return RequirementCheck(
        "delay", Verdict.CERTIFIED if ok else (Verdict.REFUTED if exact else Verdict.UNDECIDED),
        req.delay, dm.margin, f"{dm.model.value} delay margin {dm.margin:.6g} s ({how}) "
        + ("exceeds" if ok else "does not exceed") + f" tau = {req.delay:g} s")


def _torque_check(g: Any, b: GainBox, req: Requirements, spec: Any) -> RequirementCheck:
    from formsync_design.analysis.torque import torque_limit_check

    assert req.torque_limit is not None
    tc = torque_limit_check(g, b, req.torque_limit, req.inertias, req.att_radius, req.rate_radius, spec=spec)
    value = tc.bound.peak if tc.status is not Verdict.REFUTED or tc.witness is None else tc.witness["torque_N_m"]
    return RequirementCheck("torque", tc.status, req.torque_limit, value, tc.reason)


def _graph_set_check(b: GainBox, req: Requirements, spec: Any) -> RequirementCheck:
    assert req.graph_set is not None
    label = req.graph_set_label or ", ".join(x.name for x in req.graph_set)
    r = certify_switching(req.graph_set, b, spec=spec)
    if r.status is Verdict.CERTIFIED:
        return RequirementCheck("graph_set", Verdict.CERTIFIED, label, [[r.a, r.b], [r.b, 1]], r.reason)
    if req.min_dwell is None or not all(x.is_point for x in b.ranges):
        st = Verdict.ERROR if r.status is Verdict.ERROR else Verdict.UNDECIDED
        hint = "" if req.min_dwell is not None else "; give --min-dwell T for a dwell-time certificate"
        return RequirementCheck("graph_set", st, label, None, r.reason + hint)
    from formsync_design.analysis.dwell import certify_dwell_time

    d = certify_dwell_time(req.graph_set, tuple(x.lo for x in b.ranges), spec=spec)
    ok = d.status is Verdict.CERTIFIED and d.dwell <= req.min_dwell
    st = Verdict.CERTIFIED if ok else (Verdict.REFUTED if d.status is Verdict.REFUTED else Verdict.UNDECIDED)
    return RequirementCheck("graph_set", st, f"{label}, dwell >= {req.min_dwell:g} s", d.dwell,
                            f"no common quadratic V ({r.reason}); {d.reason}")
