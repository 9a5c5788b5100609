"""The value a derivation returns: :class:`LyapunovConditions`, the per-spacecraft ``Theta_i``
and the coupling ``Pi`` of a graph as gain-polynomial matrix families
(:mod:`~formsync_design.derive.families`), built by
:func:`~formsync_design.derive.conditions.derive_conditions` (or as printed,
:func:`~formsync_design.derive.conditions.paper_conditions`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from formsync_design.derive.families import MatrixFamily
from formsync_design.graphs.build import Graph

__all__ = ["LyapunovConditions", "zeta_labels"]


def zeta_labels(n: int) -> tuple[str, ...]:
    """Row labels of ``Pi`` in the paper's eq. (9) order (1-based spacecraft)."""
    return tuple(f"qdot_{i}" for i in range(1, n + 1)) + tuple(f"s_{i}" for i in range(1, n + 1))


@dataclass(frozen=True)
class LyapunovConditions:
    """``Theta_i`` and ``Pi`` of a graph, ready for certification.

    Attributes
    ----------
    graph : Graph
    source : str
        ``"derived"`` (from the derivation) or ``"paper"`` (as printed).
    spec_name : str
    gains : tuple of str
        ``("K_o", "K_q", "beta")``.
    theta : tuple of MatrixFamily
        ``theta[i]`` is ``Theta`` of spacecraft ``i+1`` (per axis, size ``m_i + 1``,
        rows ``(qdot_i, e_i,j ...)``).
    pi : MatrixFamily
        Per-axis ``Pi`` (size ``2n``), rows ``zeta_labels(n)``.
    switching_matches : bool or None
        Whether the switching term's argument equals ``rho_i`` (the
        coefficient of the disturbance in ``V'``); needed for the ``K_vi``
        argument.  ``None`` for printed conditions.
    rho : tuple of (sympy.Expr, sympy.Expr)
        ``rho_i = rho_qd * q_i' + rho_s * s_i`` (coefficients), derived only.
    """

    graph: Graph
    source: str
    spec_name: str
    gains: tuple[str, ...]
    theta: tuple[MatrixFamily, ...]
    pi: MatrixFamily
    switching_matches: bool | None = None
    rho: tuple[Any, Any] | None = None

    @property
    def families(self) -> tuple[MatrixFamily, ...]:
        """``theta + (pi,)``."""
        return (*self.theta, self.pi)

    @property
    def zeta_order(self) -> tuple[str, ...]:
        return zeta_labels(self.graph.n)
