"""What a design declares besides its controller and Lyapunov candidate.

A design file (``derivations/NAME.py``) may set these module attributes; each
is validated when the design is loaded (a bad one is a one-line
:class:`~formsync_design.errors.DerivationError` naming the file, the part and
what was expected):

``REPRESENTATION`` (default ``"quaternion"``)
    The attitude representation from the model library the controller is
    written in: ``"quaternion"`` (the Lagrangian form in the quaternion vector
    part, derived by :mod:`formsync_design.models.attitude`), ``"mrp"``
    (:mod:`~formsync_design.models.mrp`, shadow-set switching), ``"so3"``
    (:mod:`~formsync_design.models.so3`).  The derivation and certification
    stages support the representations in :data:`DERIVABLE`; a design in
    another representation loads but ``derive``/``certify`` refuse it with a
    message naming the representation.

``GAINS`` (default: the classic gains of Liang et al., :data:`CLASSIC_GAINS`)
    A mapping ``name -> declaration`` (a dict with optional keys ``role``,
    ``kind``, ``range``, ``description``), or a sequence of names.  ``role``:

    - ``"controller"`` (default): a controller gain, a dimension of every gain box;
    - ``"multiplier"``: a parameter of the Lyapunov candidate only (not of the
      controller); the certificate may choose it: a box certified for *some*
      value of the multiplier is certified (see ``certify_design``);
    - ``"switching"``: the gain of the switching term, per spacecraft, sized by
      the disturbance bound (``K_vi``), not a box dimension.

    ``kind``: ``"scalar"`` (default) or ``"diag"`` (a diagonal 3x3 gain; the
    controller sees a 3x3 matrix symbol, the Lyapunov candidate sees the
    per-axis entry).  ``range``: the default range ``"LO:HI"`` or ``(lo, hi)``
    (``> 0``), used when a command is not given the gain.

``GRAPHS`` (default ``("undirected", "weakly-connected")``)
    The graph properties the design's theorem needs (names of
    :class:`~formsync_design.graphs.digraph.GraphProperty`).

``SAMPLING`` (default ``"continuous"``)
    ``"continuous"``, ``"periodic"``, ``"event"`` or ``"self-triggered"``:
    how each spacecraft samples (see :mod:`formsync_design.sim.hybrid`).

``PLANT``, ``ACTUATORS``, ``LEADER``, ``STATES``, ``MEASURED``, ...
    What the design controls and how, declared by an agent design (``FORM = "agent"``,
    :mod:`formsync_design.spec.agent`): the rigid-body attitude of each spacecraft driven by
    body torques (the default), or the relative orbit and attitude of a spacecraft about its
    reference driven by thrusters (``PLANT = "relative-orbit"``,
    :mod:`formsync_design.spec.tracking`).  A design on the relative-orbit plant may declare
    gains of role ``"weight"`` (design weights from which a gain is computed, e.g. LQR
    weights).  ``KIND`` (the former name of that choice) is refused with the new spelling.
"""

from __future__ import annotations

import enum
import keyword
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError, InputError
from formsync_design.gains import GainRange, parse_gain_range

__all__ = [
    "GainRole",
    "GainKind",
    "GainDecl",
    "Declarations",
    "REPRESENTATIONS",
    "DERIVABLE",
    "SAMPLING_RULES",
    "GRAPH_PROPERTIES",
    "CLASSIC_GAINS",
    "CLASSIC",
    "RESERVED_NAMES",
    "parse_declarations",
]


class GainRole(enum.StrEnum):
    """What a declared gain is for (module docstring)."""

    CONTROLLER = "controller"
    MULTIPLIER = "multiplier"
    SWITCHING = "switching"
    WEIGHT = "weight"  # a design weight of the relative-orbit plant (e.g. an LQR weight)


class GainKind(enum.StrEnum):
    """Scalar gain or diagonal 3x3 gain."""

    SCALAR = "scalar"
    DIAG = "diag"


#: Representations of the model library, with the module that provides them.
REPRESENTATIONS: dict[str, str] = {
    "quaternion": "formsync_design.models.attitude",
    "mrp": "formsync_design.models.mrp",
    "so3": "formsync_design.models.so3",
}

#: Representations the derivation/certification stages support.
DERIVABLE: tuple[str, ...] = ("quaternion",)

#: Sampling rules a design may declare.
SAMPLING_RULES: tuple[str, ...] = ("continuous", "periodic", "event", "self-triggered")

#: Graph property names a design may require (values of ``GraphProperty``).
GRAPH_PROPERTIES: tuple[str, ...] = (
    "weakly-connected",
    "spanning-tree",
    "strongly-connected",
    "balanced",
    "undirected",
    "leader-reachable",
)

#: Names a gain may not take: the quantities the views provide.
RESERVED_NAMES: frozenset[str] = frozenset(
    {"A", "B", "Q", "qd", "s", "sw", "sigma", "m", "edges", "gains", "switch_arguments",
     "gain", "u_d"}
)


@dataclass(frozen=True)
class GainDecl:
    """One declared gain.

    Examples
    --------
    >>> g = GainDecl("k_p", GainRole.CONTROLLER, GainKind.SCALAR, GainRange("k_p", 1, 2))
    >>> g.symbol, g.to_dict()["range"]
    (k_p, {'lo': 1, 'hi': 2})
    """

    name: str
    role: GainRole = GainRole.CONTROLLER
    kind: GainKind = GainKind.SCALAR
    range: GainRange | None = None
    description: str = ""

    @property
    def symbol(self) -> sp.Symbol:
        """The positive scalar symbol (for a diagonal gain: its per-axis entry)."""
        return sp.Symbol(self.name, positive=True)

    @property
    def matrix(self) -> sp.MatrixSymbol:
        """The 3x3 matrix symbol of a diagonal gain (as the controller sees it)."""
        return sp.MatrixSymbol(self.name, 3, 3)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "role": str(self.role),
            "kind": str(self.kind),
            "range": self.range.to_dict() if self.range is not None else None,
            "description": self.description,
        }


@dataclass(frozen=True)
class Declarations:
    """A design's representation, gains, graph class and sampling rule.

    Examples
    --------
    >>> CLASSIC.family_gains, CLASSIC.switching
    (('K_o', 'K_q', 'beta'), 'K_v')
    >>> d = Declarations(gains=(GainDecl("k_p"), GainDecl("eps", GainRole.MULTIPLIER)))
    >>> d.controller_gains, d.multipliers, d.graphs
    (('k_p',), ('eps',), ('undirected', 'weakly-connected'))
    """

    representation: str = "quaternion"
    gains: tuple[GainDecl, ...] = ()
    graphs: tuple[str, ...] = ("undirected", "weakly-connected")
    sampling: str = "continuous"

    @property
    def family_gains(self) -> tuple[str, ...]:
        """Names of the box dimensions: controller gains, then multipliers (declaration order)."""
        ctrl = [g.name for g in self.gains if g.role == GainRole.CONTROLLER]
        mult = [g.name for g in self.gains if g.role == GainRole.MULTIPLIER]
        return tuple(ctrl + mult)

    @property
    def controller_gains(self) -> tuple[str, ...]:
        return tuple(g.name for g in self.gains if g.role == GainRole.CONTROLLER)

    @property
    def multipliers(self) -> tuple[str, ...]:
        return tuple(g.name for g in self.gains if g.role == GainRole.MULTIPLIER)

    @property
    def switching(self) -> str | None:
        """The switching gain's name, or ``None``."""
        for g in self.gains:
            if g.role == GainRole.SWITCHING:
                return g.name
        return None

    def gain(self, name: str) -> GainDecl:
        for g in self.gains:
            if g.name == name:
                return g
        raise InputError(
            f"expected a gain of the design ({', '.join(g.name for g in self.gains)}), "
            f"received {name!r}"
        )

    def family_symbols(self) -> tuple[sp.Symbol, ...]:
        """Symbols of :attr:`family_gains`, in order."""
        return tuple(self.gain(n).symbol for n in self.family_gains)

    def default_ranges(self) -> dict[str, GainRange | None]:
        return {g.name: g.range for g in self.gains}

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "representation": self.representation,
            "gains": [g.to_dict() for g in self.gains],
            "graphs": list(self.graphs),
            "sampling": self.sampling,
        }
        return out


#: The gains of Liang et al. (2016): the default when a design declares none.
CLASSIC_GAINS: tuple[GainDecl, ...] = (
    GainDecl("K_o", GainRole.CONTROLLER, GainKind.SCALAR, None, "rate-damping gain"),
    GainDecl("K_q", GainRole.CONTROLLER, GainKind.SCALAR, None, "coupling gain"),
    GainDecl("beta", GainRole.CONTROLLER, GainKind.SCALAR, None, "sliding-variable weight"),
    GainDecl("K_v", GainRole.SWITCHING, GainKind.SCALAR, None, "switching gain K_vi"),
)

#: The declarations of a design that declares nothing.
CLASSIC = Declarations(gains=CLASSIC_GAINS)


def _fail(where: str, part: str, expected: str, got: Any) -> DerivationError:
    return DerivationError(f"{where}: {part}: expected {expected}, received {got}")


def _show(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _parse_gain(name: Any, spec: Any, where: str) -> GainDecl:
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise _fail(where, "GAINS", "gain names that are Python identifiers", _show(name))
    if name in RESERVED_NAMES or name.startswith("_"):
        raise _fail(where, f"GAINS[{name!r}]",
                    "a name that is not a quantity of the views "
                    f"({', '.join(sorted(RESERVED_NAMES))}) and does not start with '_'", name)
    if spec is None:
        spec = {}
    if not isinstance(spec, Mapping):
        raise _fail(where, f"GAINS[{name!r}]",
                    "a dict with keys role, kind, range, description", type(spec).__name__)
    unknown = sorted(set(map(str, spec)) - {"role", "kind", "range", "description"})
    if unknown:
        raise _fail(where, f"GAINS[{name!r}]", "keys among role, kind, range, description",
                    f"unknown keys {unknown}")
    try:
        role = GainRole(spec.get("role", "controller"))
    except ValueError:
        raise _fail(where, f"GAINS[{name!r}].role", f"one of {[str(r) for r in GainRole]}",
                    _show(spec.get("role"))) from None
    try:
        kind = GainKind(spec.get("kind", "scalar"))
    except ValueError:
        raise _fail(where, f"GAINS[{name!r}].kind", f"one of {[str(k) for k in GainKind]}",
                    _show(spec.get("kind"))) from None
    rng = None
    if spec.get("range") is not None:
        try:
            rng = parse_gain_range(spec["range"], name)
        except InputError as e:
            raise DerivationError(f"{where}: GAINS[{name!r}].range: {e}") from None
    desc = spec.get("description", "")
    if not isinstance(desc, str):
        raise _fail(where, f"GAINS[{name!r}].description", "a string", type(desc).__name__)
    if role == GainRole.MULTIPLIER and rng is None:
        raise _fail(where, f"GAINS[{name!r}].range",
                    "a range for a multiplier (the values a certificate may choose from)", "none")
    if role == GainRole.SWITCHING and kind != GainKind.SCALAR:
        raise _fail(where, f"GAINS[{name!r}]", "a scalar switching gain", "kind 'diag'")
    return GainDecl(name, role, kind, rng, desc)


def parse_declarations(attrs: Mapping[str, Any], where: str, *,
                       weights: bool = False) -> Declarations:
    """Validate a design's declarations (module attributes) into :class:`Declarations`.

    Parameters
    ----------
    attrs : mapping
        The module's namespace (``REPRESENTATION``, ``GAINS``, ``GRAPHS``, ``SAMPLING``).
    where : str
        The file named in error messages.
    weights : bool
        Whether gains of role ``"weight"`` may be declared (a design on the relative-orbit
        plant, :mod:`formsync_design.spec.agent`).

    Examples
    --------
    >>> d = parse_declarations({"GAINS": {"k_p": {"range": "0.1:2"}, "k_d": {},
    ...                                   "eps": {"role": "multiplier", "range": "0.01:1"}}},
    ...                        "demo.py")
    >>> d.family_gains, d.multipliers, d.switching
    (('k_p', 'k_d', 'eps'), ('eps',), None)
    >>> parse_declarations({"GAINS": ["k", "k"]}, "demo.py")
    Traceback (most recent call last):
    ...
    formsync_design.errors.DerivationError: demo.py: GAINS: expected each gain declared once, received 'k' twice
    >>> parse_declarations({"REPRESENTATION": "euler"}, "demo.py")
    Traceback (most recent call last):
    ...
    formsync_design.errors.DerivationError: demo.py: REPRESENTATION: expected one of ['quaternion', 'mrp', 'so3'], received 'euler'
    """
    if "KIND" in attrs:
        raise _fail(where, "KIND", "no KIND (every design is one contract: a spacecraft tracking "
                    "a reference in relative orbit and attitude declares FORM = 'agent' with "
                    "PLANT = 'relative-orbit')", _show(attrs["KIND"]))
    rep = attrs.get("REPRESENTATION", "quaternion")
    if not isinstance(rep, str) or rep not in REPRESENTATIONS:
        raise _fail(where, "REPRESENTATION", f"one of {list(REPRESENTATIONS)}", _show(rep))
    if "GAINS" not in attrs:
        gains = CLASSIC_GAINS
    else:
        raw = attrs["GAINS"]
        if isinstance(raw, Mapping):
            items = list(raw.items())
        elif isinstance(raw, Sequence) and not isinstance(raw, (str, bytes)):
            items = [(n, None) for n in raw]
        else:
            raise _fail(where, "GAINS", "a dict of gain declarations or a list of names",
                        type(raw).__name__)
        seen: list[str] = []
        for n, _ in items:
            if not isinstance(n, str):
                raise _fail(where, "GAINS", "gain names that are Python identifiers", _show(n))
            if n in seen:
                raise _fail(where, "GAINS", "each gain declared once", f"{n!r} twice")
            seen.append(n)
        gains = tuple(_parse_gain(n, s, where) for n, s in items)
        if not any(g.role == GainRole.CONTROLLER for g in gains):
            raise _fail(where, "GAINS", "at least one controller gain", "none")
        if not weights and any(g.role == GainRole.WEIGHT for g in gains):
            raise _fail(where, "GAINS", "weights (role 'weight') only on the relative-orbit "
                        "plant (PLANT = 'relative-orbit')",
                        [g.name for g in gains if g.role == GainRole.WEIGHT])
        if sum(g.role == GainRole.SWITCHING for g in gains) > 1:
            raise _fail(where, "GAINS", "at most one switching gain",
                        [g.name for g in gains if g.role == GainRole.SWITCHING])
    graphs = attrs.get("GRAPHS", ("undirected", "weakly-connected"))
    if isinstance(graphs, str) or not isinstance(graphs, Sequence):
        raise _fail(where, "GRAPHS", "a list of graph property names", _show(graphs))
    for p in graphs:
        if not isinstance(p, str) or p not in GRAPH_PROPERTIES:
            raise _fail(where, "GRAPHS", f"graph properties among {list(GRAPH_PROPERTIES)}",
                        _show(p))
    sampling = attrs.get("SAMPLING", "continuous")
    if not isinstance(sampling, str) or sampling not in SAMPLING_RULES:
        raise _fail(where, "SAMPLING", f"one of {list(SAMPLING_RULES)}", _show(sampling))
    if weights and "GAINS" not in attrs:
        raise _fail(where, "GAINS", "the gains of a design on the relative-orbit plant declared",
                    "none")
    return Declarations(representation=str(rep), gains=gains,
                        graphs=tuple(str(p) for p in graphs), sampling=str(sampling))

