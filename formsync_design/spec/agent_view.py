"""What an agent design's law is written in: the representations, the quantity classes, the
declarations, the symbolic view of a spacecraft and its neighbours (:class:`AgentView`) and the
helper functions of the expressions (:func:`sgn`, :func:`sig`, :func:`hat`, :func:`vee`,
:func:`mrp_G`, :func:`quat_E`, :func:`quat_to_R`).

The designs themselves (loading, validation, the expressions of every function) are in
:mod:`formsync_design.spec.agent`; a design file reaches these helpers through its view
(``v.hat``, ``v.sgn``, ...) or imports them from here.

>>> v = AgentView(AgentDeclarations(representation="mrp"), 1)
>>> sorted(v.symbols_by_class())[:3]
['attitude', 'gains', 'held']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from formsync_design.errors import DerivationError
from formsync_design.spec.declarations import Declarations, GainKind, GainRole

__all__ = [
    "AGENT_REPRESENTATIONS",
    "PLANTS",
    "ACTUATORS",
    "QUANTITIES",
    "AgentDeclarations",
    "AttitudeSymbols",
    "NeighbourView",
    "AgentView",
    "sgn",
    "sgn_of",
    "sig",
    "hat",
    "vee",
    "mrp_G",
    "quat_E",
    "quat_to_R",
]

#: Representations an agent design may be written in.
AGENT_REPRESENTATIONS: tuple[str, ...] = ("quaternion", "mrp", "so3")

#: Plants a design may declare (``PLANT``): each spacecraft's rigid-body attitude, or the
#: relative orbit and attitude of one spacecraft about its reference
#: (:mod:`formsync_design.spec.tracking`).
PLANTS: tuple[str, ...] = ("attitude", "relative-orbit")

#: Actuators a design may declare (``ACTUATORS``): body torques, or thrusters realising the
#: commanded force and torque (the case's layout, allocation and pulse-width modulation).
ACTUATORS: tuple[str, ...] = ("torque", "thrusters")

#: Quantity classes for ``MEASURED``.
QUANTITIES: tuple[str, ...] = (
    "attitude", "rate", "neighbour-attitude", "neighbour-rate", "neighbour-states",
    "reference", "time",
)


class sgn(sp.Function):  # noqa: N801 - reads like the papers' sgn
    """The switching function: ``sign(x)`` (componentwise through :func:`sig`), replaced at
    simulation time by ``sign``, ``sat(x/phi)`` or ``tanh(x/phi)``.

    >>> sgn(sp.Integer(-3)), sgn(sp.Symbol("x")).diff(sp.Symbol("x"))
    (-1, 0)
    """

    nargs = 1

    @classmethod
    def eval(cls, x: Any) -> Any:
        if x.is_Number:
            return sp.sign(x)
        return None

    def fdiff(self, argindex: int = 1) -> Any:
        return sp.Integer(0)


def sgn_of(x: Any) -> Any:
    """:class:`sgn` of a scalar, or componentwise of a matrix (``v.sgn`` in a view).

    >>> sgn_of(sp.Matrix(sp.symbols("a b"))).T
    Matrix([[sgn(a), sgn(b)]])
    """
    if isinstance(x, sp.MatrixBase):
        return x.applyfunc(sgn)
    return sgn(x)


def _vec(x: Any) -> sp.Matrix:
    m = sp.Matrix(x)
    return m.reshape(len(m), 1) if m.shape[1] != 1 else m


def sig(x: Any, p: Any) -> sp.Matrix:
    """``|x_k|^p sgn(x_k)`` componentwise (the finite-time power of sliding-mode designs).

    >>> sig(sp.Matrix([sp.Symbol("a")]), sp.Rational(1, 2))
    Matrix([[sqrt(Abs(a))*sgn(a)]])
    """
    return _vec(x).applyfunc(lambda e: sp.Abs(e) ** sp.sympify(p) * sgn(e))


def hat(w: Any) -> sp.Matrix:
    """The cross-product matrix ``w^`` (``hat(a) b = a x b``).

    >>> hat([1, 2, 3]) * sp.Matrix([4, 5, 6]) == sp.Matrix([1, 2, 3]).cross(sp.Matrix([4, 5, 6]))
    True
    """
    a = _vec(w)
    return sp.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def vee(M: Any) -> sp.Matrix:
    """The inverse of :func:`hat` on skew matrices (``(M[2,1], M[0,2], M[1,0])``).

    >>> vee(hat([1, 2, 3])).T
    Matrix([[1, 2, 3]])
    """
    A = sp.Matrix(M)
    return sp.Matrix([A[2, 1], A[0, 2], A[1, 0]])


def mrp_G(sigma: Any) -> sp.Matrix:
    """``G(sigma)`` of ``sigma' = G(sigma) w`` (:func:`formsync_design.models.mrp.mrp_kinematics_matrix`)."""
    from formsync_design.models.mrp import mrp_kinematics_matrix

    return mrp_kinematics_matrix(_vec(sigma))


def quat_E(q: Any, q0: Any) -> sp.Matrix:
    """``E(q) = (q0 I + q^)/2`` of ``q' = E w`` (the toolbox's quaternion kinematics).

    >>> quat_E([0, 0, 0], 1)
    Matrix([
    [1/2,   0,   0],
    [  0, 1/2,   0],
    [  0,   0, 1/2]])
    """
    return (q0 * sp.eye(3) + hat(q)) / 2


def quat_to_R(q: Any, q0: Any) -> sp.Matrix:
    """``R(q)`` (body to inertial) of a unit quaternion, ``(q0^2 - |q|^2) I + 2 q q^T + 2 q0 q^``."""
    v = _vec(q)
    return (q0**2 - (v.T * v)[0, 0]) * sp.eye(3) + 2 * v * v.T + 2 * q0 * hat(v)


@dataclass(frozen=True)
class AgentDeclarations(Declarations):
    """An agent design's declarations: :class:`Declarations` plus controller states, the
    leader flag, the measured quantities, the plant and the actuators.

    >>> AgentDeclarations(representation="so3").states, AgentDeclarations().measured[:2]
    ((), ('attitude', 'rate'))
    >>> AgentDeclarations().plant, AgentDeclarations().actuators
    ('attitude', 'torque')
    """

    states: tuple[tuple[str, int], ...] = ()
    leader: bool = False
    measured: tuple[str, ...] = QUANTITIES
    hold: tuple[tuple[str, int], ...] = ()
    plant: str = "attitude"
    actuators: str = "torque"

    @property
    def state_size(self) -> int:
        """Controller-state entries per spacecraft."""
        return sum(k for _, k in self.states)

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        out.update(form="agent", states={n: k for n, k in self.states}, leader=self.leader,
                   measured=list(self.measured))
        if self.hold:
            out["hold"] = {n: k for n, k in self.hold}
        if self.plant != "attitude" or self.actuators != "torque":
            out.update(plant=self.plant, actuators=self.actuators)
        return out


def _gain_values(decl: Declarations, roles: tuple[GainRole, ...]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for g in decl.gains:
        if g.role not in roles:
            continue
        if g.kind == GainKind.DIAG:
            out[g.name] = sp.diag(*sp.symbols(f"{g.name}_1:4", positive=True))
        else:
            out[g.name] = g.symbol
    return out


class AttitudeSymbols:
    """One spacecraft's (or the reference's) symbolic state in a representation.

    Attributes: ``q`` (3x1), ``q0`` (quaternion); ``sigma`` (MRP); ``R`` (SO(3)); ``w``
    (body rate); ``z`` (controller states, a dict); ``wdot`` (reference only).

    >>> a = AttitudeSymbols("so3", "n1")
    >>> a.R[0, 1], a.w[2]
    (R_n1_12, w_n1_3)
    """

    def __init__(self, representation: str, tag: str = "", states: tuple[tuple[str, int], ...] = (),
                 reference: bool = False) -> None:
        sfx = f"_{tag}" if tag else ""
        self.representation = representation
        self.tag = tag
        if representation == "quaternion":
            self.q = sp.Matrix(sp.symbols(f"q{sfx}_1:4", real=True))
            self.q0 = sp.Symbol(f"q0{sfx}", real=True)
        elif representation == "mrp":
            self.sigma = sp.Matrix(sp.symbols(f"sigma{sfx}_1:4", real=True))
        elif representation == "so3":
            self.R = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"R{sfx}_{i + 1}{j + 1}", real=True))
        else:
            raise DerivationError(f"expected a representation in {list(AGENT_REPRESENTATIONS)}, "
                                  f"received {representation!r}")
        self.w = sp.Matrix(sp.symbols(f"w{sfx}_1:4", real=True))
        self.z = {n: sp.Matrix(sp.symbols(f"{n}{sfx}_1:{k + 1}", real=True)) for n, k in states}
        if reference:
            self.wdot = sp.Matrix(sp.symbols(f"wdot{sfx}_1:4", real=True))

    def attitude_symbols(self) -> list[sp.Symbol]:
        """The attitude's symbols in a fixed order (the kernel binds them in this order)."""
        if self.representation == "quaternion":
            return [*self.q, self.q0]
        if self.representation == "mrp":
            return list(self.sigma)
        return list(self.R.T)  # column-major, like CasADi

    def symbols(self) -> dict[str, set[Any]]:
        """Symbols by quantity class: ``attitude``, ``rate``, ``states``, ``wdot``."""
        out = {"attitude": set(self.attitude_symbols()), "rate": set(self.w),
               "states": {s for m in self.z.values() for s in m}}
        if hasattr(self, "wdot"):
            out["wdot"] = set(self.wdot)
        return out


class NeighbourView(AttitudeSymbols):
    """An in-neighbour ``j`` of spacecraft ``i``: its state and the weight ``a`` (``a_ij``)."""

    def __init__(self, representation: str, k: int, states: tuple[tuple[str, int], ...]) -> None:
        super().__init__(representation, f"n{k}", states)
        self.a = sp.Symbol(f"a_{k}", positive=True)


class AgentView:
    """What an agent design's functions see for spacecraft ``i`` with ``m`` in-neighbours.

    Own state: the representation's attitude (``q``/``q0``, ``sigma`` or ``R``), ``w``,
    ``J``, ``z``; ``nbrs`` (``m`` :class:`NeighbourView`, each with ``a`` and its state);
    with ``LEADER``: ``b`` and ``ref``; ``held`` (own last broadcast, for ``event``);
    ``t``; one attribute per declared gain; the helpers ``sgn``, ``sig``, ``hat``, ``vee``,
    ``G`` (MRP), ``E`` (quaternion).

    >>> v = AgentView(AgentDeclarations(representation="mrp", leader=True), 2)
    >>> len(v.nbrs), v.sigma[0], v.ref.sigma[0], v.b
    (2, sigma_1, sigma_ref_1, b)
    """

    def __init__(self, decl: AgentDeclarations, m: int, *, multipliers: bool = False) -> None:
        rep = decl.representation
        self.decl = decl
        self.m = m
        self.representation = rep
        self.own = AttitudeSymbols(rep, "", decl.states)
        for name in ("q", "q0", "sigma", "R"):
            if hasattr(self.own, name):
                setattr(self, name, getattr(self.own, name))
        self.w = self.own.w
        self.z = self.own.z
        self.J = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"J_{min(i, j) + 1}{max(i, j) + 1}",
                                                         real=True))
        self.t = sp.Symbol("t", real=True)
        self.nbrs = [NeighbourView(rep, k, decl.states) for k in range(1, m + 1)]
        self.held = AttitudeSymbols(rep, "held")
        self.kept = {n: sp.Matrix(sp.symbols(f"{n}_kept_1:{k + 1}", real=True))
                     for n, k in decl.hold}
        if decl.leader:
            self.b = sp.Symbol("b", nonnegative=True)
            self.ref = AttitudeSymbols(rep, "ref", reference=True)
        roles = (GainRole.CONTROLLER, GainRole.MULTIPLIER) if multipliers else (GainRole.CONTROLLER,)
        self.gains = _gain_values(decl, roles)
        for k, val in self.gains.items():
            setattr(self, k, val)

    # helpers (also importable from this module)
    sgn = staticmethod(sgn_of)
    sig = staticmethod(sig)
    hat = staticmethod(hat)
    vee = staticmethod(vee)
    G = staticmethod(mrp_G)
    E = staticmethod(quat_E)

    def attributes(self) -> str:
        """The names this view provides, for messages."""
        own = {"quaternion": ["q", "q0"], "mrp": ["sigma"], "so3": ["R"]}[self.representation]
        extra = ["b", "ref"] if self.decl.leader else []
        kept = ["kept"] if self.kept else []
        return ", ".join([*own, "w", "J", "z", "t", "nbrs", "held", *kept, *extra, *self.gains,
                          "sgn", "sig", "hat", "vee", "G", "E"])

    def symbols_by_class(self) -> dict[str, set[Any]]:
        """Every symbol the view provides, by :data:`QUANTITIES` class (plus ``gains``,
        ``inertia``, ``weights``, ``held``, ``states``)."""
        own = self.own.symbols()
        out: dict[str, set[Any]] = {
            "attitude": own["attitude"], "rate": own["rate"], "states": own["states"],
            "neighbour-attitude": set(), "neighbour-rate": set(), "neighbour-states": set(),
            "reference": set(), "time": {self.t}, "inertia": set(self.J),
            "weights": {n.a for n in self.nbrs},
            "gains": {s for val in self.gains.values() for s in sp.Matrix([val]).free_symbols},
        }
        for n in self.nbrs:
            s = n.symbols()
            out["neighbour-attitude"] |= s["attitude"]
            out["neighbour-rate"] |= s["rate"]
            out["neighbour-states"] |= s["states"]
        h = self.held.symbols()
        out["held"] = h["attitude"] | h["rate"]
        out["kept"] = {s for m in self.kept.values() for s in m}
        if self.decl.leader:
            r = self.ref.symbols()
            out["reference"] = r["attitude"] | r["rate"] | r["wdot"] | {self.b}
        return out
