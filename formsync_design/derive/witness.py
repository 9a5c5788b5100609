"""An exact counterexample to a printed Pi: gains at which the printed matrix is positive
definite while the derived one is not, with a rational witness vector whose quadratic forms
are evaluated in exact arithmetic (:func:`disagreement_witness`; the comparison report of
:mod:`formsync_design.derive.compare` prints it).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from formsync_design.derive.closed_loop import SpecLike
from formsync_design.derive.conditions import derive_conditions, paper_conditions
from formsync_design.derive.printed import PrintedLike
from formsync_design.graphs.build import Graph

__all__ = ["disagreement_witness"]


def disagreement_witness(
    graph: Graph, k_q: Fraction = Fraction(2, 5), beta: Fraction = Fraction(3, 10),
    *, spec: SpecLike = None, printed: PrintedLike = None,
) -> dict | None:
    """Gains at which the printed Pi is PD but the derived one is not, with an
    exact witness vector, scanning ``K_o`` on a rational grid (step 1/200 up
    to 40 spacecraft, 1/5 beyond).

    Returns ``None`` when no such ``K_o`` exists on the grid.

    Examples
    --------
    >>> from formsync_design.graphs.build import make_graph
    >>> w = disagreement_witness(make_graph("ring:4"))
    >>> w["zeta^T Pi_derived zeta"] < 0 < w["zeta^T Pi_printed zeta"]
    True
    """
    der = derive_conditions(graph, spec).pi
    pap = paper_conditions(graph, printed).pi
    best: tuple[float, Fraction] | None = None
    step = 1 if graph.n <= 40 else 40
    for k in range(step, 2001, step):
        ko = Fraction(k, 200)
        pt = (ko, k_q, beta)
        sep = min(np.linalg.eigvalsh(pap.evaluate(pt))[0], -np.linalg.eigvalsh(der.evaluate(pt))[0])
        if sep > 1e-9 and (best is None or sep > best[0]):
            best = (float(sep), ko)
    if best is not None:
        ko = best[1]
        pt = (ko, k_q, beta)
        ed = np.linalg.eigh(der.evaluate(pt))
        ep = np.linalg.eigvalsh(pap.evaluate(pt))
        vec = ed[1][:, 0]
        nz = np.flatnonzero(np.abs(vec) > 1e-12)
        if nz.size and vec[nz[0]] < 0:  # a sign convention, so the witness is reproducible
            vec = -vec
        x = [Fraction(round(v * 1000), 1000) for v in vec]
        Fd = der.evaluate_exact(pt)
        Fp = pap.evaluate_exact(pt)
        qd = _qform(Fd, x)
        qp = _qform(Fp, x)
        if qd < 0 < qp:
            return {
                "K_o": ko, "K_q": k_q, "beta": beta, "zeta_per_axis": x,
                "zeta^T Pi_derived zeta": qd, "zeta^T Pi_printed zeta": qp,
                "lambda_min derived": float(ed[0][0]), "lambda_min printed": float(ep[0]),
            }
    return None


def _qform(F: list[list[Fraction]], x: list[Fraction]) -> Fraction:
    nz = [i for i, v in enumerate(x) if v]
    return sum((F[i][j] * x[i] * x[j] for i in nz for j in nz if F[i][j]), Fraction(0))
