"""Protocols at the seams between the stages: what a stage needs of its input.

The core functions take "anything with ..." rather than one concrete class, so
a notebook user (or a future design plug-in) can pass their own objects.
These :class:`typing.Protocol` classes name those requirements for the type
checker (and, being ``runtime_checkable``, for ``isinstance``), so that
signatures such as ``certify_box(conditions: ConditionsLike, box: BoxInput)``
say what they use instead of ``Any``.

Attributes are declared as read-only properties, so the toolbox's frozen
dataclasses satisfy them.

======================  ============================================  =======================
protocol                what it needs                                 implemented by
======================  ============================================  =======================
:class:`GraphLike`      ``n``, ``edges``, ``name``, ``laplacian``     ``graphs.Graph``
:class:`SpecLike`       ``name``, ``controller``, ``lyapunov``        ``spec.Spec``
:class:`ConditionFamily` a gain-polynomial symmetric matrix            ``derive.MatrixFamily``
:class:`ConditionsLike` ``graph``, ``gains``, ``families``            ``derive.LyapunovConditions``
:class:`GainBoxLike`    ``names``, ``vertices()``                     ``gains.GainBox``
:class:`FormationLike`  graph, inertias, attitudes, rates, gains, ...  ``sim.Formation``
======================  ============================================  =======================

>>> from formsync_design import make_graph, derive_conditions, GainBox
>>> g = make_graph("ring:4")
>>> isinstance(g, GraphLike)
True
>>> conds = derive_conditions(g)
>>> isinstance(conds, ConditionsLike), all(isinstance(f, ConditionFamily) for f in conds.families)
(True, True)
>>> isinstance(GainBox.parse({"K_o": 1.6, "K_q": 0.4, "beta": 0.3}), GainBoxLike)
True
>>> isinstance(object(), GraphLike)
False
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias, runtime_checkable

import numpy as np

__all__ = [
    "GraphLike",
    "SpecLike",
    "ConditionFamily",
    "ConditionsLike",
    "GainBoxLike",
    "BoxInput",
    "FormationLike",
    "NumberInput",
    "GraphInput",
    "SpecInput",
]


@runtime_checkable
class GraphLike(Protocol):
    """An undirected communication graph on ``n`` spacecraft (0-based ``edges``).

    >>> isinstance(__import__("formsync_design").make_graph("path:3"), GraphLike)
    True
    """

    @property
    def n(self) -> int: ...

    @property
    def edges(self) -> tuple[tuple[int, int], ...]: ...

    @property
    def name(self) -> str: ...

    @property
    def laplacian(self) -> np.ndarray: ...


@runtime_checkable
class SpecLike(Protocol):
    """A design specification: a controller law and a Lyapunov candidate.

    ``controller(view)`` and ``lyapunov(view)`` receive the symbolic views of
    :mod:`formsync_design.spec.loader`; caches are keyed by the specification's
    content digest (``Spec.key``).

    >>> from formsync_design import load_spec
    >>> isinstance(load_spec(None), SpecLike)
    True
    """

    @property
    def name(self) -> str: ...

    @property
    def controller(self) -> Callable[..., Any]: ...

    @property
    def lyapunov(self) -> Callable[..., Any]: ...


@runtime_checkable
class ConditionFamily(Protocol):
    """A symmetric matrix ``F(p)`` polynomial in the gains ``p`` (one Lyapunov condition).

    >>> from formsync_design import make_graph, derive_conditions
    >>> fam = derive_conditions(make_graph("ring:4")).pi
    >>> isinstance(fam, ConditionFamily), fam.is_multiaffine
    (True, True)
    """

    @property
    def name(self) -> str: ...

    @property
    def gains(self) -> tuple[str, ...]: ...

    @property
    def size(self) -> int: ...

    @property
    def block_size(self) -> int: ...

    @property
    def is_multiaffine(self) -> bool: ...

    def evaluate(self, point: Sequence[float] | Mapping[str, float]) -> np.ndarray: ...

    def evaluate_exact(self, point: Sequence[Any] | Mapping[str, Any]) -> list[list[Any]]: ...


@runtime_checkable
class ConditionsLike(Protocol):
    """The Lyapunov conditions of a design on a graph: families that must be ``≻ 0``.

    >>> from formsync_design import make_graph, paper_conditions
    >>> isinstance(paper_conditions(make_graph("ring:4")), ConditionsLike)
    True
    """

    @property
    def graph(self) -> GraphLike: ...

    @property
    def gains(self) -> tuple[str, ...]: ...

    @property
    def families(self) -> Sequence[ConditionFamily]: ...


@runtime_checkable
class GainBoxLike(Protocol):
    """A box of gains: named closed intervals with exact vertices.

    >>> from formsync_design import GainBox
    >>> isinstance(GainBox.parse({"K_o": "1:2", "K_q": 1, "beta": 0.1}), GainBoxLike)
    True
    """

    @property
    def names(self) -> tuple[str, ...]: ...

    def vertices(self) -> list[tuple[Any, ...]]: ...


#: What the certification functions accept as a box: a :class:`GainBoxLike`
#: or a mapping ``{gain: number | "lo:hi" | (lo, hi)}`` parsed by ``GainBox.parse``.
BoxInput: TypeAlias = "GainBoxLike | Mapping[str, Any]"


#: A number the exact parser ``gains.parse_number`` accepts (a float is taken as
#: the decimal it prints as, a string may be ``"p/q"``).
NumberInput: TypeAlias = "int | float | Fraction | str"

#: A graph or a graph specification ``make_graph`` accepts (``"ring:8"``, a file).
GraphInput: TypeAlias = "GraphLike | str | Path"

#: A specification or what ``load_spec`` resolves (a file, or None for the paper's).
SpecInput: TypeAlias = "SpecLike | str | Path | None"


@runtime_checkable
class FormationLike(Protocol):
    """A formation to simulate: graph, inertias (N×3×3), attitudes (N×4), rates (N×3), gains.

    >>> import numpy as np
    >>> from formsync_design import Formation, Gains, make_graph
    >>> from formsync_design.models.disturbances import no_disturbance
    >>> att = np.array([[0.0, 0.0, 0.0, 1.0]] * 2)
    >>> f = Formation(make_graph("path:2"), np.array([np.eye(3)] * 2), att, np.zeros((2, 3)),
    ...               Gains(1.6, 0.4, 0.3, (0.0, 0.0)), no_disturbance(2))
    >>> isinstance(f, FormationLike)
    True
    """

    @property
    def graph(self) -> GraphLike: ...

    @property
    def inertias(self) -> np.ndarray: ...

    @property
    def attitudes(self) -> np.ndarray: ...

    @property
    def rates(self) -> np.ndarray: ...

    @property
    def gains(self) -> Any: ...

    @property
    def disturbance(self) -> Any: ...


if TYPE_CHECKING:  # the type checker verifies that the toolbox's classes conform
    from formsync_design.derive.families import MatrixFamily
    from formsync_design.derive.lyapunov import LyapunovConditions
    from formsync_design.gains import GainBox
    from formsync_design.graphs import Graph
    from formsync_design.sim.formation import Formation
    from formsync_design.spec.loader import Spec

    def _graph(x: Graph) -> GraphLike:
        return x

    def _spec(x: Spec) -> SpecLike:
        return x

    def _family(x: MatrixFamily) -> ConditionFamily:
        return x

    def _conditions(x: LyapunovConditions) -> ConditionsLike:
        return x

    def _box(x: GainBox) -> GainBoxLike:
        return x

    def _formation(x: Formation) -> FormationLike:
        return x
