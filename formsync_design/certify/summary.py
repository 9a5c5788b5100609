"""The :class:`~formsync_design.certify.results.CertificationResult` of a box from its decided
vertices (:func:`summarize`, for :func:`~formsync_design.certify.engine.certify_box`): each
family's status and certified lower bound, the smallest exact witness of a refutation (its
Rayleigh quotient, whether it refutes the whole box), the solver's and re-check's counts."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from fractions import Fraction

import numpy as np

from formsync_design.certify.exact import (
    check_witness,
)
from formsync_design.certify.results import (
    FamilyMargin,
    Status,
    Witness,
)
from formsync_design.certify.structure import Block, Group, Structure
from formsync_design.certify.vertices import (
    VertexResults,
    uniform_refutation,
)

__all__ = ["summarize", "block_certified"]


def block_certified(b: Block, vr: VertexResults, sub: Mapping[int, tuple]) -> bool:
    if b.multiaffine:
        return bool(np.all(vr.status[b.index] == 1))
    return bool(sub.get(b.index, (False,))[0])


def _block_lower(b: Block, vr: VertexResults, sub: Mapping[int, tuple]) -> Fraction:
    if b.multiaffine:
        return Fraction(float(vr.lower[b.index].min()))
    low = sub[b.index][1]
    assert low is not None
    return low


def summarize(
    st: Structure,
    vr: VertexResults,
    verts: list[tuple[Fraction, ...]],
    mg: Fraction,
    gains: tuple[str, ...],
    sub: Mapping[int, tuple] | None = None,
) -> tuple[tuple[FamilyMargin, ...], Witness | None]:
    sub = sub or {}
    fams = []
    witness: Witness | None = None
    for g in st.groups:
        bids = sorted(set(g.blocks))
        hints = [vr.hint[b] for b in bids]
        hmin = min(float(np.nanmin(h)) for h in hints)
        # worst vertex by hint
        worst_b = min(bids, key=lambda b: float(np.nanmin(vr.hint[b])))
        worst_v = int(np.nanargmin(vr.hint[worst_b]))
        cert = all(block_certified(st.blocks[b], vr, sub) for b in bids)
        lower = None
        if cert:
            lower = min(_block_lower(st.blocks[b], vr, sub) for b in bids)
        upper = None
        fam_status = Status.CERTIFIED if cert else Status.UNDECIDED
        for b in bids:
            if vr.witness[b]:
                fam_status = Status.REFUTED
                blk = st.blocks[b]
                # the witness with the smallest Rayleigh quotient
                best = None
                for vi, x in vr.witness[b].items():
                    xx = sum(v * v for v in x)
                    rq = check_witness(blk.terms, verts[vi], x, Fraction(0)) / xx
                    if best is None or rq < best[0]:
                        best = (rq, vi, x)
                assert best is not None
                rq, vi, x = best
                upper = rq if upper is None else min(upper, rq)
                if witness is None:
                    rows = next(r for gi, r in blk.places if gi == g.index)
                    fam = g.family
                    covers = uniform_refutation(blk, x, verts, mg)
                    x = _simplify_witness(blk, x, verts[vi], mg, verts if covers else None)
                    xx = sum(v * v for v in x)
                    rq = check_witness(blk.terms, verts[vi], x, Fraction(0)) / xx
                    upper = min(upper, rq)
                    full = [0] * fam.size
                    for loc, r in enumerate(rows.tolist()):
                        full[r] = x[loc]
                    labels = fam.row_labels or tuple(str(i + 1) for i in range(fam.size))
                    witness = Witness(
                        point=dict(zip(gains, verts[vi])),
                        family=g.names[0],
                        spacecraft=g.spacecraft[0] if g.spacecraft else None,
                        also=tuple(g.spacecraft),
                        x=tuple(full),
                        rows=tuple(labels[r] for r in range(fam.size) if full[r] != 0),
                        value=check_witness(
                            [(t.exponents, t.coefficient, t.matrix) for t in fam.terms],
                            verts[vi], full, mg,
                        ),
                        rayleigh=rq,
                        covers_box=covers,
                    )
        fams.append(
            FamilyMargin(
                name=_group_name(g),
                spacecraft=tuple(g.spacecraft),
                size=g.family.size,
                status=fam_status,
                lower=lower,
                hint=hmin,
                upper=upper,
                worst_vertex=verts[worst_v],
            )
        )
    return tuple(fams), witness


def _simplify_witness(
    blk: Block, x: list[int], pt: tuple[Fraction, ...], mg: Fraction,
    cover: list[tuple[Fraction, ...]] | None,
) -> list[int]:
    """A witness with smaller integers (fewer bits of the same direction) when it
    still checks exactly (and still covers the box when the original did)."""
    big = max(abs(v) for v in x)
    for bits in (4, 8, 12, 16, 24, 32, 48, 64, 96, 128):
        scale = Fraction(2**bits, big)
        y = [int(round(v * scale)) for v in x]
        gcd = 0
        for v in y:
            gcd = math.gcd(gcd, v)
        if gcd == 0:
            continue
        y = [v // gcd for v in y]
        if check_witness(blk.terms, pt, y, mg) > 0:
            continue
        if cover is not None and not uniform_refutation(blk, y, cover, mg):
            continue
        return y
    return x


def _group_name(g: Group) -> str:
    if len(g.names) == 1:
        return g.names[0]
    base = g.names[0].split("_")[0]
    return f"{base}_i (i = {_ranges(g.spacecraft)})" if g.spacecraft else g.names[0]


def _ranges(ids: Sequence[int]) -> str:
    ids = sorted(ids)
    out = []
    start = prev = ids[0]
    for v in [*ids[1:], None]:
        if v is not None and v == prev + 1:
            prev = v
            continue
        out.append(f"{start}" if start == prev else f"{start}-{prev}")
        if v is not None:
            start = prev = v
    return ",".join(out)
