"""Claims of a published design: the ``[claims]`` table, measurements and their judging.

A claim is ``QUANTITY OP VALUE`` (``convergence_time <= 150``), measured on one
simulation run per candidate topology.  A measurement is not always a number,
so each one carries an :class:`Outcome`, and :func:`judge` decides a claim on
it with these rules (the same for every operator ``<=``, ``<``, ``>=``, ``>``,
``==`` unless said otherwise):

*measured*
    The quantity has a value ``x``; the claim holds when ``x OP VALUE`` is true.
*stopped at a singularity*
    The run stopped early (``q0 -> 0``, where controller (4) is undefined).
    Every claim judged on that run **fails**, whatever the operator: a run that
    did not finish is never evidence for a claim.
*never happened*
    An event whose last occurrence is measured (``saturation_end_time``,
    ``chatter_end_time``) did not occur at all.  Its "last time" is earlier than
    any bound, so ``<`` and ``<=`` claims ("saturates only briefly") **hold**
    and ``>``, ``>=`` and ``==`` claims ("saturates until at least ...") **fail**.
*undecided by its computation*
    A certificate (``theta_pd``, ``pi_pd``) that is neither certified nor
    refuted: every claim on it is **undecided**.
*not reached within the horizon* (horizon ``T``)
    A time that lies beyond the simulated horizon: the formation has not
    converged by ``T`` (``convergence_time``), or the event is still going on at
    ``T``.  The true value is known to exceed ``T``, so a claim is decided when
    ``VALUE <= T``: ``<``, ``<=``, ``==`` **fail** and ``>``, ``>=`` **hold**;
    when ``VALUE > T`` it is **undecided** (within the horizon).  A steady-state
    quantity (``tail_q_m``, ``tail_omega_m``, ``final_abs_rate``) is measured
    only on a run that converged before its steady-state tail began; otherwise
    the steady state was not reached and every claim on it is **undecided**
    (within the horizon).  (The verification first lengthens such a run up to
    ``claims.max_tf``; see :mod:`formsync_design.verify.verification`.)

A claim's verdict over the candidate topologies is :attr:`Verdict.HOLDS` or
:attr:`Verdict.FAILS` when every topology agrees, :attr:`Verdict.DEPENDS` when
it holds on some and fails on others, and :attr:`Verdict.UNDECIDED` otherwise
(some topology undecided, none contradicting another).  ``undecided`` is not a
pass: ``formsync verify --strict`` exits 1 unless every claim holds.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import json_number
from formsync_design.ranges import check_range, quantity_of

__all__ = [
    "QUANTITIES",
    "EVENT_QUANTITIES",
    "STEADY_QUANTITIES",
    "Outcome",
    "Verdict",
    "Measurement",
    "ClaimSpec",
    "ClaimResult",
    "ClaimSettings",
    "judge",
    "combine",
    "parse_claims",
    "chatter_end_time",
    "torque_reversals",
    "steady_state_start",
    "measure_run",
]

#: Quantities a claim can be about (name -> description, unit).  ``{limit}`` in a
#: description is the saturation study's torque limit.
QUANTITIES: dict[str, tuple[str, str]] = {
    "convergence_time": ("first time after which Q_m <= q_tol and Omega_m <= omega_tol hold to the "
                         "end of the horizon", "s"),
    "tail_omega_m": ("max Omega_m over the steady-state tail", "rad/s"),
    "tail_q_m": ("max Q_m over the steady-state tail", ""),
    "final_abs_rate": ("max_i |omega_i| at the end (absolute body rates)", "rad/s"),
    "theta_pd": ("1 if every Theta_i > 0 is certified at the published gains, 0 if one is refuted "
                 "(derived conditions)", ""),
    "pi_pd": ("1 if Pi > 0 is certified at the published gains, 0 if refuted (derived conditions)", ""),
    "kv_ratio": ("min_i K_vi / K_vi* (K_vi* from the derivation and the disturbance bound)", ""),
    "saturation_end_time": ("last time any torque component is at the per-axis limit of {limit} "
                            "(a run with that limit)", "s"),
    "chatter_end_time": ("last time the torque chatters (3+ direction reversals of a torque "
                         "component within 1 s)", "s"),
}

#: Quantities that are the last time of an event (may "never happen").
EVENT_QUANTITIES = frozenset({"saturation_end_time", "chatter_end_time"})
#: Quantities of the steady state (need a run that converged before its tail).
STEADY_QUANTITIES = frozenset({"tail_omega_m", "tail_q_m", "final_abs_rate"})

_OPS: dict[str, Callable[[float, float], bool]] = {
    "<=": operator.le, "<": operator.lt, ">=": operator.ge, ">": operator.gt, "==": operator.eq,
}


class Outcome(StrEnum):
    """What a measurement found (module docstring)."""

    MEASURED = "measured"
    NEVER = "never happened"
    NOT_REACHED = "not reached within the horizon"
    SINGULAR = "stopped at a singularity"
    DIVERGED = "diverged (non-finite state)"
    UNDECIDED = "undecided by its computation"


class Verdict(StrEnum):
    """A claim's verdict on one run, or over every candidate topology."""

    HOLDS = "holds"
    FAILS = "fails"
    UNDECIDED = "undecided"
    DEPENDS = "depends on topology"


@dataclass(frozen=True)
class Measurement:
    """One measured quantity of one run.

    Attributes
    ----------
    outcome : Outcome
    value : float or None
        The value when ``outcome`` is ``MEASURED``.
    horizon : float or None
        The simulated horizon (s), for ``NOT_REACHED``.
    note : str
        Why it is not a plain number (the run's message), for the report.
    """

    outcome: Outcome
    value: float | None = None
    horizon: float | None = None
    note: str = ""

    @classmethod
    def of(cls, value: float) -> Measurement:
        """A plain measured value.

        >>> Measurement.of(2.0).value
        2.0
        """
        return cls(Outcome.MEASURED, float(value))

    def to_dict(self) -> dict[str, Any]:
        return {"outcome": str(self.outcome), "value": json_number(self.value),
                "horizon": json_number(self.horizon), "note": self.note}


@dataclass(frozen=True)
class ClaimSpec:
    """One checkable claim (from the case file)."""

    key: str
    text: str
    paper: str
    quantity: str
    op: str
    value: float
    unit: str = ""
    note: str = ""

    @property
    def criterion(self) -> str:
        """``quantity op value [unit]``.

        >>> ClaimSpec("k", "t", "p", "tail_q_m", "<", 1e-4).criterion
        'tail_q_m < 0.0001'
        """
        return f"{self.quantity} {self.op} {self.value:g}" + (f" {self.unit}" if self.unit else "")

    def check(self, m: Measurement) -> Verdict:
        """:func:`judge` this claim on one measurement."""
        return judge(self, m)


def judge(spec: ClaimSpec, m: Measurement) -> Verdict:
    """Decide ``spec`` on one measurement with the rules of the module docstring.

    >>> c = ClaimSpec("sat", "saturates briefly", "p", "saturation_end_time", "<=", 10.0)
    >>> judge(c, Measurement(Outcome.NEVER)), judge(c, Measurement(Outcome.SINGULAR))
    (<Verdict.HOLDS: 'holds'>, <Verdict.FAILS: 'fails'>)
    >>> c = ClaimSpec("conv", "converges", "p", "convergence_time", "<=", 250.0)
    >>> judge(c, Measurement(Outcome.NOT_REACHED, horizon=200.0))
    <Verdict.UNDECIDED: 'undecided'>
    """
    op = _OPS[spec.op]
    if m.outcome in (Outcome.SINGULAR, Outcome.DIVERGED):  # a run that did not finish
        return Verdict.FAILS
    if m.outcome is Outcome.UNDECIDED:
        return Verdict.UNDECIDED
    if m.outcome is Outcome.NEVER:
        return Verdict.HOLDS if spec.op in ("<", "<=") else Verdict.FAILS
    if m.outcome is Outcome.NOT_REACHED:
        if spec.quantity in STEADY_QUANTITIES or m.horizon is None or spec.value > m.horizon:
            return Verdict.UNDECIDED
        return Verdict.HOLDS if spec.op in (">", ">=") else Verdict.FAILS
    if m.value is None or math.isnan(m.value):
        return Verdict.FAILS
    return Verdict.HOLDS if op(m.value, spec.value) else Verdict.FAILS


def combine(verdicts: Mapping[str, Verdict]) -> tuple[Verdict, str]:
    """The verdict over the candidate topologies, and a one-line reason.

    >>> combine({"a": Verdict.HOLDS, "b": Verdict.UNDECIDED})
    (<Verdict.UNDECIDED: 'undecided'>, 'holds on a; undecided on b')
    >>> combine({"a": Verdict.HOLDS, "b": Verdict.HOLDS})[0]
    <Verdict.HOLDS: 'holds'>
    """
    groups: dict[Verdict, list[str]] = {}
    for g, v in verdicts.items():
        groups.setdefault(v, []).append(g)
    if len(groups) == 1:
        (v,) = groups
        return v, "on every candidate topology"
    if Verdict.HOLDS in groups and Verdict.FAILS in groups:
        verdict = Verdict.DEPENDS
    else:
        verdict = Verdict.UNDECIDED
    order = (Verdict.HOLDS, Verdict.FAILS, Verdict.UNDECIDED)
    reason = "; ".join(f"{v} on {', '.join(groups[v])}" for v in order if v in groups)
    return verdict, reason


@dataclass(frozen=True)
class ClaimResult:
    """A claim with its measurement and verdict per topology and the overall verdict."""

    spec: ClaimSpec
    measured: dict[str, Measurement]
    verdicts: dict[str, Verdict]
    verdict: Verdict
    reason: str

    def to_dict(self) -> dict[str, Any]:
        s = self.spec
        return {
            "key": s.key, "text": s.text, "paper": s.paper, "quantity": s.quantity,
            "criterion": s.criterion,
            "measured": {k: m.to_dict() for k, m in self.measured.items()},
            "verdicts": {k: str(v) for k, v in self.verdicts.items()},
            "verdict": str(self.verdict), "reason": self.reason,
        }


@dataclass(frozen=True)
class ClaimSettings:
    """The settings of a ``[claims]`` table (besides the items)."""

    topologies: tuple[str, ...]
    topology_note: str = ""
    saturation_torque_limit: float = 1.0
    tail_fraction: float = 0.2
    max_tf: float | None = None
    phi_sweep: tuple[float, ...] = ()
    torque_limit_sweep: tuple[float | None, ...] = ()


def _float(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (
            isinstance(v, float) and not math.isfinite(v)):
        raise InputError(f"expected a finite number for {what}, received {repr(v)[:60]}")
    check_range(v, quantity_of(what.split(" ")[0]), what)
    return float(v)


def _floats(v: Any, what: str) -> list[float]:
    if not isinstance(v, list):
        raise InputError(f"expected a list of numbers for {what}, received {v!r}")
    return [_float(x, what) for x in v]


def parse_claims(table: dict, path: str = "<case>") -> tuple[ClaimSettings, tuple[ClaimSpec, ...]]:
    """Validate a ``[claims]`` table; return (settings, claims).

    Torque limits in ``torque_limit_sweep`` are numbers (N m) or ``"unlimited"``
    (``0`` is read as unlimited too).

    >>> s, c = parse_claims({"topologies": ["ring:4"], "items": {"x": {"text": "t",
    ...     "paper": "p", "quantity": "tail_q_m", "op": "<=", "value": 1e-4}}})
    >>> c[0].quantity, s.topologies
    ('tail_q_m', ('ring:4',))
    """
    if not table:
        raise InputError(f"expected a [claims] table in {path}, received none")
    known = {"topologies", "topology_note", "saturation_torque_limit", "tail_fraction", "max_tf",
             "phi_sweep", "torque_limit_sweep", "items"}
    unknown = set(table) - known
    if unknown:
        raise InputError(f"expected [claims] keys {sorted(known)}, received unknown {sorted(unknown)}")
    tops = table.get("topologies")
    if not (isinstance(tops, list) and tops and all(isinstance(t, str) for t in tops)):
        raise InputError(f"expected claims.topologies = a non-empty list of graph specs, received {tops!r}")
    limit = _float(table.get("saturation_torque_limit", 1.0), "claims.saturation_torque_limit")
    if limit <= 0:
        raise InputError(f"expected a positive claims.saturation_torque_limit, received {limit:g}")
    frac = _float(table.get("tail_fraction", 0.2), "claims.tail_fraction")
    if not 0 < frac < 1:
        raise InputError(f"expected 0 < claims.tail_fraction < 1, received {frac:g}")
    max_tf = None
    if "max_tf" in table:
        max_tf = _float(table["max_tf"], "claims.max_tf")
        if max_tf <= 0:
            raise InputError(f"expected a positive claims.max_tf (s), received {max_tf:g}")
    phis = _floats(table.get("phi_sweep", []), "claims.phi_sweep")
    if any(x <= 0 for x in phis):
        raise InputError(f"expected positive boundary layers in claims.phi_sweep, received {phis}")
    sweep = table.get("torque_limit_sweep", [])
    if not isinstance(sweep, list):
        raise InputError(f"expected a list for claims.torque_limit_sweep, received {sweep!r}")
    lims: list[float | None] = []
    for x in sweep:
        if x == "unlimited":
            lims.append(None)
            continue
        v = _float(x, "claims.torque_limit_sweep (numbers in N m or \"unlimited\")")
        if v < 0:
            raise InputError(f"expected torque limits >= 0 or \"unlimited\" in claims.torque_limit_sweep, "
                             f"received {v:g}")
        lims.append(v if v > 0 else None)
    settings = ClaimSettings(
        topologies=tuple(tops), topology_note=str(table.get("topology_note", "")),
        saturation_torque_limit=limit, tail_fraction=frac, max_tf=max_tf,
        phi_sweep=tuple(phis), torque_limit_sweep=tuple(lims),
    )
    items = table.get("items")
    if not isinstance(items, dict) or not items:
        raise InputError(f"expected [claims.items.NAME] tables in {path}, received none")
    out = []
    need = {"text", "paper", "quantity", "op", "value"}
    for key, it in items.items():
        if not isinstance(it, dict):
            raise InputError(f"expected a table for claims.items.{key}, received {repr(it)[:60]}")
        missing = need - set(it)
        if missing:
            raise InputError(f"expected keys {sorted(need)} in claims.items.{key}, missing {sorted(missing)}")
        extra = set(it) - need - {"unit", "note"}
        if extra:
            raise InputError(f"expected only {sorted(need | {'unit', 'note'})} in claims.items.{key}, "
                             f"received {sorted(extra)}")
        for k in ("quantity", "op"):
            if not isinstance(it[k], str):
                raise InputError(f"expected a string claims.items.{key}.{k}, received "
                                 f"{repr(it[k])[:60]}")
        if it["quantity"] not in QUANTITIES:
            raise InputError(f"expected claims.items.{key}.quantity in {sorted(QUANTITIES)}, "
                             f"received {it['quantity']!r}")
        if it["op"] not in _OPS:
            raise InputError(f"expected claims.items.{key}.op in {sorted(_OPS)}, received {it['op']!r}")
        v = _float(it["value"], f"claims.items.{key}.value")
        unit = str(it.get("unit", QUANTITIES[it["quantity"]][1]))
        out.append(ClaimSpec(key=key, text=str(it["text"]), paper=str(it["paper"]),
                             quantity=it["quantity"], op=it["op"], value=v,
                             unit="" if unit == "-" else unit, note=str(it.get("note", ""))))
    return settings, tuple(out)


# ---------------------------------------------------------------------------
# measuring a run
# ---------------------------------------------------------------------------
def torque_reversals(u: np.ndarray, rel: float = 1e-3) -> np.ndarray:
    """Boolean (T, C): a direction reversal of a torque component at grid point k.

    A reversal is a sign change of consecutive increments whose sizes both
    exceed ``rel`` times the component's peak magnitude (so numerical noise
    and smooth extrema with tiny increments do not count).

    >>> torque_reversals(np.array([[0.0], [1.0], [0.0], [1.0]]))[:, 0].tolist()
    [False, True, True, False]
    """
    u = np.asarray(u, float)
    du = np.diff(u, axis=0)
    thr = rel * np.maximum(np.max(np.abs(u), axis=0), 1e-300)
    big = np.abs(du) > thr
    flips = (du[1:] * du[:-1] < 0) & big[1:] & big[:-1]
    out = np.zeros_like(u, dtype=bool)
    out[1:-1] = flips
    return out


def chatter_end_time(t: np.ndarray, u: np.ndarray, window: float = 1.0, count: int = 3) -> float | None:
    """Last time at which some torque component reverses direction ``count`` or
    more times within ``window`` seconds (None if it never chatters).

    >>> t = np.arange(0, 10, 0.1)
    >>> u = np.where(t < 3, np.sign(np.sin(40 * t)), np.exp(-t))[:, None]
    >>> 2.0 < chatter_end_time(t, u) < 3.0
    True
    """
    rev = torque_reversals(np.asarray(u, float)).any(axis=1)
    idx = np.flatnonzero(rev)
    if idx.size < count:
        return None
    times = np.asarray(t)[idx]
    last = None
    for k in range(count - 1, idx.size):
        if times[k] - times[k - count + 1] <= window:
            last = float(times[k])
    return last


def steady_state_start(t: np.ndarray, frac: float) -> int:
    """Index of the first sample of the steady-state tail (the last ``frac`` of the samples).

    >>> steady_state_start(np.arange(10.0), 0.2)
    8
    """
    n = len(t)
    return int(math.floor(n * (1 - frac)))


def _event(value: float | None, t: np.ndarray) -> Measurement:
    """The last time of an event: never / still going at the horizon / measured."""
    if value is None:
        return Measurement(Outcome.NEVER)
    tf = float(t[-1])
    dt = float(t[-1] - t[-2]) if len(t) > 1 else 0.0
    if value >= tf - 0.5 * dt:
        return Measurement(Outcome.NOT_REACHED, horizon=tf, note=f"still going on at {tf:g} s")
    return Measurement.of(value)


def measure_run(r: Any, frac: float, *, event: str = "chatter") -> dict[str, Measurement]:
    """The simulation quantities of one run (a :class:`~formsync_design.sim.result.SimResult`
    or anything with its attributes ``status, t, u, omega_m, q_m, convergence_time,
    final_rates, saturation_end_time`` and ``message()``).

    ``event="chatter"`` measures the run's own quantities (convergence, steady
    state, chattering); ``event="saturation"`` measures ``saturation_end_time``
    only (a run with the saturation study's torque limit).

    >>> from types import SimpleNamespace as NS
    >>> r = NS(status="singular", message=lambda: "q0 -> 0")
    >>> measure_run(r, 0.2)["tail_q_m"].outcome
    <Outcome.SINGULAR: 'stopped at a singularity'>
    """
    names = ("saturation_end_time",) if event == "saturation" else (
        "convergence_time", "tail_omega_m", "tail_q_m", "final_abs_rate", "chatter_end_time")
    if r.status in ("singular", "diverged"):
        m = Measurement(Outcome.SINGULAR if r.status == "singular" else Outcome.DIVERGED,
                        note=r.message())
        return dict.fromkeys(names, m)
    t = np.asarray(r.t, float)
    tf = float(t[-1])
    if event == "saturation":
        return {"saturation_end_time": _event(r.saturation_end_time, t)}
    k0 = steady_state_start(t, frac)
    ct = r.convergence_time
    out: dict[str, Measurement] = {}
    if ct is None:
        out["convergence_time"] = Measurement(Outcome.NOT_REACHED, horizon=tf,
                                              note=f"not converged within {tf:g} s")
    else:
        out["convergence_time"] = Measurement.of(ct)
    if ct is None or ct > float(t[k0]):
        m = Measurement(Outcome.NOT_REACHED, horizon=tf,
                        note=f"steady state not reached within {tf:g} s")
        out.update(tail_omega_m=m, tail_q_m=m, final_abs_rate=m)
    else:
        out["tail_omega_m"] = Measurement.of(float(np.max(r.omega_m[k0:])))
        out["tail_q_m"] = Measurement.of(float(np.max(r.q_m[k0:])))
        out["final_abs_rate"] = Measurement.of(float(np.max(np.linalg.norm(r.final_rates, axis=1))))
    out["chatter_end_time"] = _event(chatter_end_time(t, r.u), t)
    return out
