"""Four certificates of a gain box of any design, one comparison.

For a design whose closed loop the engine derives (default: Liang et al. 2016, whose box
is ``(K_o, K_q, beta)``; the PD baseline's is ``(k_p, k_d)``), :func:`certify` decides a
gain box of the design's controller gains with one of

``paper``
    the paper's per-spacecraft sufficient test (each ``Theta_i > 0`` and
    ``Pi > 0``), by :func:`formsync_design.certify.engine.certify_box` on
    :func:`formsync_design.derive.conditions.derive_conditions` (today's test).
``exact``
    the specification's *own* Lyapunov function ``V = sum_i V_i`` on the whole graph:
    ``V > 0`` on the disagreement subspace and ``V' < 0`` along the nominal
    loop, decided per Laplacian mode (:mod:`.modes`): ``P_k > 0`` and
    ``A_k^T P_k + P_k A_k < 0`` for every eigenvalue ``lambda_k > 0``.  Both
    matrices are multi-affine in the gains (checked symbolically), so for fixed
    ``x`` the quadratic form is multi-affine and its extremes over the box are
    at the vertices: checking the vertices is exact.  A multiplier of the candidate
    (the PD baseline's ``eps``) is used as given, or else chosen from a geometric grid
    over its declared range (:func:`.modecheck.multiplier_candidates`, containing the
    ``paper`` certificate's grid); a value that fails refutes that candidate only
    (``undecided``), unless the loop itself is unstable at a vertex.
``searched`` (:mod:`.searched`)
    a searched quadratic ``V`` with the switching structure: per mode
    ``P_k = [[p_k(g), rho_s lambda], [rho_s lambda, rho_qd]]`` (the gradient in
    ``q_i'`` is the controller's switching argument, so ``-K_v arg^T sgn(arg)``
    stays dissipative), with ``p_k`` multi-affine in the gains (one
    coefficient per vertex monomial).  The class contains the paper's ``V``, so
    ``exact`` certified implies ``searched`` certified.  Vertex LMIs solved with
    cvxpy + Clarabel give a *hint*; the coefficients are rounded to rationals
    and every vertex LMI is re-checked exactly over the eigenvalue enclosure.
    When a diagonal entry of ``A_k^T P_k + P_k A_k`` that the free entry does
    not reach is ``>= 0`` at some vertex, ``Z = e_i e_i^T`` is an exact dual
    certificate: ``<F, Z> >= 0`` for every member of the class, so **no**
    function of the class exists for that gain point (a refutation of the class,
    not of a candidate).  For Liang's design the entry is
    ``2 (beta lambda_max - K_o)``; per-spacecraft scalings ``D`` of the
    gradient do not help either (``vec^T (beta (D L + L D) - 2 K_o D) vec
    = 2 (beta lambda_max - K_o) vec^T D vec`` for the top eigenvector), so the
    remaining gap to ``spectral`` needs a non-quadratic function or a
    boundary-layer ultimate-bound argument that does not rely on the switching
    term being dissipative.  A design without a switching term (``c_sigma = 0``) has no
    structure to keep: its class is every quadratic ``V`` per mode (free ``p`` and ``r``),
    the natural specialisation.
``spectral``
    the true stability region of the nominal linear loop: every
    ``det(s I - A_k)`` (derived) Hurwitz, by the Routh-Hurwitz conditions
    (coefficients and Hurwitz minors positive) with exact interval bounds over
    the box and the eigenvalue enclosure.  The outer bound.

Every verdict is exact rational arithmetic over rigorous eigenvalue enclosures
(:mod:`.spectrum`); a solver's output never decides.
"""

from __future__ import annotations

import time
from typing import Any

from formsync_design.analysis.modecheck import (
    box_poly_range,
    check_pd_coeffs,
    entry_coeffs,
    hurwitz_conditions,
    lam_dict,
    multi_affine,
    multiplier_candidates,
    split_box,
    vertex_dict,
)
from formsync_design.analysis.modes import ModeModel, mode_model
from formsync_design.analysis.results import Certificate, CertificateResult, Verdict
from formsync_design.analysis.searched import (
    certify_searched,
)
from formsync_design.analysis.spectrum import LaplacianSpectrum, laplacian_spectrum
from formsync_design.errors import InputError
from formsync_design.gains import GainBox
from formsync_design.graphs import make_graph

__all__ = [ "certify", "exact_candidates", "certify_exact_with"]


# ---------------------------------------------------------------------------
# (b) exact: the specification's V on the whole graph
# ---------------------------------------------------------------------------
def certify_exact_with(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox,
                       mult: dict) -> tuple[Verdict, str, Any, dict]:
    """The exact certificate with the multipliers ``mult`` (``{symbol: GainRange}``, a range
    is a box dimension of the check)."""
    p = mm.p_paper
    f = mm.vdot(p)
    syms = (*mm.gains, *mult)
    names = (*mm.names, *(s.name for s in mult))
    full = GainBox((*box.ranges, *mult.values())) if mult else box
    if not multi_affine([p, f], syms):
        return (Verdict.UNDECIDED, "the Lyapunov matrices are not multi-affine in the gains; "
                "vertex checks would not be exact", None, {})
    checks = 0
    undecided = None
    for v in full.vertices():
        sub = dict(zip(syms, v))
        polys = [(name, [entry_coeffs(mat[i, j], sub) for i, j in ((0, 0), (0, 1), (1, 1))])
                 for name, mat in (("V > 0", p), ("V' < 0", -f))]
        for c in spec_.clusters:
            for name, ent in polys:
                st, which, rng = check_pd_coeffs(ent[0], ent[1], ent[2], c)
                checks += 1
                if st < 0:
                    w = {"gains": vertex_dict(names, v), "lambda": lam_dict(c), "condition": name,
                         "quantity": which, "upper_bound": rng[1]}
                    return (Verdict.REFUTED, f"the specification's V fails {name} at a vertex for the mode "
                            f"lambda in [{float(c.lo):g}, {float(c.hi):g}]", w, {"checks": checks})
                if st == 0 and undecided is None:
                    undecided = (v, c, name)
    if undecided is not None:
        v, c, name = undecided
        return (Verdict.UNDECIDED, f"{name} could not be decided over the eigenvalue enclosure "
                f"[{float(c.lo):g}, {float(c.hi):g}]", None, {"checks": checks})
    ev: dict[str, Any] = {"checks": checks}
    if mult:
        ev["multipliers"] = {s.name: (r.lo if r.is_point else [r.lo, r.hi]) for s, r in mult.items()}
    return (Verdict.CERTIFIED, "the specification's V > 0 and V' < 0 on the disagreement subspace at every "
            "vertex and mode (multi-affine in the gains: exact for the box)", None, ev)


def exact_candidates(mm: ModeModel, given: GainBox | None) -> list[dict]:
    """The multiplier values the exact certificate tries, in order (``[{}]`` without multipliers)."""
    return multiplier_candidates(mm, given)


def _certify_exact(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox,
                   given: GainBox | None) -> tuple[Verdict, str, Any, dict]:
    cands = exact_candidates(mm, given)
    searched = [s.name for s in mm.multipliers if given is None or s.name not in given.names]
    if not searched:
        st, reason, w, ev = certify_exact_with(mm, spec_, box, cands[0])
        if st is Verdict.REFUTED and mm.multipliers:
            reason += (f" (with the given multiplier {', '.join(s.name for s in mm.multipliers)}: "
                       "refutes that candidate only)")
        return st, reason, w, ev
    last: tuple[Verdict, str, Any, dict] | None = None
    checks = 0
    for cand in cands:
        st, reason, w, ev = certify_exact_with(mm, spec_, box, cand)
        checks += int(ev.get("checks", 0))
        if st is Verdict.CERTIFIED:
            chosen = ", ".join(f"{s.name} = {float(r.lo):g}" for s, r in cand.items() if s.name in searched)
            return (st, f"{reason}; multiplier {chosen} (grid value, {len(cands)} on the grid)", None,
                    {**ev, "checks": checks})
        last = (st, reason, w, ev)
    assert last is not None
    from formsync_design.analysis.searched import unstable_vertex

    bad = unstable_vertex(mm, spec_, box)
    if bad is not None:
        return (Verdict.REFUTED, "the nominal loop is not asymptotically stable at a vertex: no Lyapunov "
                "function exists there, whatever the multiplier", bad, {"checks": checks})
    rng = "; ".join(f"{s.name} in {r}" for s, r in zip(mm.multipliers, mm.multiplier_ranges)
                    if s.name in searched)
    return (Verdict.UNDECIDED, f"no multiplier value tried certifies the box ({rng}, {len(cands)} grid "
            f"values; last: {last[1]}); a failing value refutes that candidate only", None,
            {"checks": checks})


# ---------------------------------------------------------------------------
# (d) spectral: Routh-Hurwitz per mode
# ---------------------------------------------------------------------------
def _certify_spectral(mm: ModeModel, spec_: LaplacianSpectrum, box: GainBox) -> tuple[Verdict, str, Any, dict]:
    conds = hurwitz_conditions(mm.charpoly)
    undecided = None
    for c in spec_.clusters:
        for e in conds:
            lo, _ = box_poly_range(e, mm, box, c)
            if lo > 0:
                continue
            for v in box.vertices():
                pt = GainBox.parse(dict(zip(mm.names, v)), mm.names)
                _, hi = box_poly_range(e, mm, pt, c)
                if hi <= 0:
                    w = {"gains": vertex_dict(mm.names, v), "lambda": lam_dict(c), "condition": f"{e} > 0",
                         "upper_bound": hi}
                    return (Verdict.REFUTED, "a Routh-Hurwitz condition of the nominal loop fails at a "
                            "vertex: the linear loop is not asymptotically stable there", w, {})
            undecided = undecided or (c, e)
    if undecided is not None:
        c, e = undecided
        return (Verdict.UNDECIDED, f"the Routh-Hurwitz condition {e} > 0 is not decided on the whole "
                "box by interval bounds (subdivide)", None, {})
    return (Verdict.CERTIFIED, "every mode's characteristic polynomial is Hurwitz on the whole box "
            "(exact interval bounds)", None, {"conditions": [str(e) for e in conds]})


# ---------------------------------------------------------------------------
# (a) paper + dispatcher
# ---------------------------------------------------------------------------
def _certify_paper(graph: Any, box: GainBox, given: GainBox | None, spec: Any, margin: Any,
                   use_sdp: bool = True) -> tuple[Verdict, str, Any, dict]:
    from formsync_design.certify.engine import certify_box
    from formsync_design.certify.multipliers import certify_with_multipliers
    from formsync_design.derive.closed_loop import resolve_spec
    from formsync_design.derive.conditions import derive_conditions

    sp_ = resolve_spec(spec)
    conds = derive_conditions(graph, sp_)
    full = {r.name: r for r in (*box.ranges, *(given.ranges if given is not None else ()))}
    mult = {n: rng for n in sp_.decl.multipliers
            if n not in full and (rng := sp_.decl.gain(n).range) is not None}
    if mult:
        r = certify_with_multipliers(conds, full, mult, margin=margin, use_sdp=use_sdp)
    else:
        r = certify_box(conds, GainBox.parse(full, tuple(conds.gains)), margin=margin, use_sdp=use_sdp)
    status = {"certified": Verdict.CERTIFIED, "refuted": Verdict.REFUTED,
              "undecided": Verdict.UNDECIDED}.get(str(r.status), Verdict.ERROR)
    w = None
    if status is Verdict.REFUTED and r.witness is not None:
        w = r.witness.to_dict()
    why = f": {r.reason}" if r.reason else f" ({r.status} on the whole box)"
    return status, f"the paper's per-spacecraft test{why}", w, {"argument": r.argument}


def certify(graph: Any, box: Any, certificate: str | Certificate = Certificate.PAPER, *,
            spec: Any = None, margin: Any = 0, spectrum: LaplacianSpectrum | None = None,
            use_sdp: bool = True, seed_with_paper: bool = True) -> CertificateResult:
    """Decide a gain box of the design's controller gains with one of the four certificates.

    Parameters
    ----------
    graph : Graph or graph spec (``"ring:8"``)
    box : GainBox or anything :meth:`GainBox.parse` accepts, over the design's controller
        gains (liang2016: ``K_o, K_q, beta``; pd_consensus: ``k_p, k_d``), optionally with a
        multiplier of its candidate (``paper``/``exact`` only: then used as given)
    certificate : ``paper`` | ``exact`` | ``searched`` | ``spectral``
    spec : specification (default: the paper's)
    margin : number
        Only for ``paper`` (the engine's margin).
    spectrum : LaplacianSpectrum, optional
        Reuse an enclosure (region maps call this many times per graph).
    use_sdp : bool
        ``paper``: take the engine's hints from the SDP (default) or LAPACK
        (same exact re-check; region maps use LAPACK for speed).
    seed_with_paper : bool
        ``searched``: try the specification's own ``V`` (when it is a member of the
        class) before solving the LMIs.

    Returns
    -------
    CertificateResult

    Examples
    --------
    >>> box = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
    >>> [certify("star:8", box, c).status.value for c in ("paper", "exact", "searched", "spectral")]
    ['refuted', 'refuted', 'refuted', 'certified']
    >>> certify("ring:8", box, "exact").status.value
    'certified'
    >>> pd = {"k_p": (0.5, 2), "k_d": (1, 3)}
    >>> [certify("star:8", pd, c, spec="pd_consensus").status.value for c in ("exact", "searched", "spectral")]
    ['certified', 'certified', 'certified']
    """
    t0 = time.perf_counter()
    try:
        cert = Certificate(str(certificate))
    except ValueError:
        raise InputError(f"expected a certificate in {[c.value for c in Certificate]}, "
                         f"received {certificate!r}") from None
    g = make_graph(graph)
    mm = mode_model(spec)
    b, given = split_box(mm, box)
    if given is not None and cert in (Certificate.SEARCHED, Certificate.SPECTRAL):
        raise InputError(f"expected no multiplier ({', '.join(given.names)}) with the {cert} certificate "
                         "(a multiplier is a parameter of the specification's candidate: paper and exact "
                         f"only), received {given}")
    sp_ = spectrum if spectrum is not None else laplacian_spectrum(g)
    if cert is Certificate.PAPER:
        status, reason, w, ev = _certify_paper(g, b, given, spec, margin, use_sdp)
    elif cert is Certificate.EXACT:
        status, reason, w, ev = _certify_exact(mm, sp_, b, given)
    elif cert is Certificate.SEARCHED:
        member = _certify_exact(mm, sp_, b, None) if (seed_with_paper and mm.aligned) else None
        status, reason, w, ev = certify_searched(mm, sp_, b, member)
    else:
        status, reason, w, ev = _certify_spectral(mm, sp_, b)
    shown = GainBox((*b.ranges, *given.ranges)) if given is not None else b
    return CertificateResult(cert, status, g.name, g.n, shown, reason, w, ev, sp_.method,
                             time.perf_counter() - t0)
