"""The settings and the result of a Monte-Carlo campaign (``fs.monte_carlo``,
:func:`~formsync_design.sim.montecarlo.run_montecarlo`), one type each for both paths: the
compiled batch of a Lagrangian design (:mod:`formsync_design.sim.montecarlo`) and the runs of
an agent design (:mod:`formsync_design.sim.agent_montecarlo`).

What is sampled and how (:class:`MonteCarloSettings`: a value not given is the default of the
path that runs, :meth:`MonteCarloSettings.resolved_for`), each run's status, seed, gains and
measurements (:class:`MonteCarloRun`: the fields of its path set, the other path's ``None``)
and the campaign's summary (:class:`MonteCarloResult`); each writes, for each path, the keys
that path's reports and ``runs.csv`` hold.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from formsync_design.errors import InputError
from formsync_design.gains import GainBox, json_number
from formsync_design.notebook import NotebookViews

__all__ = [
    "MAX_RUNS",
    "PATHS",
    "MonteCarloSettings",
    "RunStatus",
    "RUN_STATUSES",
    "MonteCarloRun",
    "MonteCarloResult",
]

#: Largest number of runs of one campaign: every sampled formation is kept in memory
#: (about 3 kB each for N = 8) and each run of the paper's case takes ~5 ms of CPU
#: with the compiled kernel, so 100 000 runs are ~300 MB and ~10 CPU-minutes.
MAX_RUNS = 100_000

#: The two Monte-Carlo paths: a Lagrangian design's compiled batch, an agent design's runs.
PATHS = ("lagrangian", "agent")

#: Each path's default ``(runs, max_angle_deg, max_rate, phases)`` (``phases``: Lagrangian only).
_DEFAULTS: dict[str, tuple[int, float, float, bool]] = {
    "lagrangian": (1000, 100.0, 0.9, True),
    "agent": (100, 90.0, 0.01, True),
}


@dataclass(frozen=True)
class MonteCarloSettings:
    """What is randomised and how (the two modules' docstrings): ``runs``, the master
    ``seed``, ``max_angle_deg`` (initial attitudes), ``max_rate`` (rad/s) and ``phases`` (a
    Lagrangian design's disturbance and orbit phases drawn too).

    A value left ``None`` is the default of the path that runs
    (:meth:`resolved_for`): a Lagrangian design 1000 runs, 100 deg, 0.9 rad/s, phases drawn;
    an agent design 100 runs, 90 deg, 0.01 rad/s.  The angle is in ``[0, 180]`` (a rotation
    angle), and below 180 for a Lagrangian design (``q0 > 0`` initially).

    >>> s = MonteCarloSettings(runs=3)
    >>> s.resolved_for("agent").max_rate, s.resolved_for("lagrangian").max_rate
    (0.01, 0.9)
    >>> MonteCarloSettings(runs=10).run_seeds()[:1] == MonteCarloSettings(runs=3).run_seeds()[:1]
    True
    """

    runs: int | None = None
    seed: int = 0
    max_angle_deg: float | None = None
    max_rate: float | None = None
    phases: bool | None = None

    def __post_init__(self) -> None:
        if self.runs is not None:
            if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
                raise InputError(f"expected an integer number of runs >= 1, received {self.runs}")
            if self.runs > MAX_RUNS:
                raise InputError(
                    f"expected at most {MAX_RUNS} runs per campaign (each sampled formation is "
                    f"kept in memory, ~3 kB and ~5 ms of CPU per run for N = 8), received "
                    f"{self.runs}; split the campaign over several seeds"
                )
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"expected a non-negative integer seed, received {self.seed}")
        # a rotation angle: beyond 180 deg is a smaller one
        if self.max_angle_deg is not None and not 0 <= self.max_angle_deg <= 180:
            raise InputError(f"expected max_angle_deg in [0, 180], received {self.max_angle_deg:g}")
        if self.max_rate is not None and not (math.isfinite(self.max_rate) and self.max_rate >= 0):
            raise InputError(f"expected max_rate >= 0 (rad/s), received {self.max_rate:g}")

    def resolved_for(self, path: Literal["lagrangian", "agent"]) -> MonteCarloSettings:
        """These settings with every value not given set to the default of ``path``
        (:data:`PATHS`; the class docstring), checked for it (a Lagrangian design: an angle
        below 180 deg).  Resolving resolved settings changes nothing.

        >>> MonteCarloSettings().resolved_for("lagrangian")
        MonteCarloSettings(runs=1000, seed=0, max_angle_deg=100.0, max_rate=0.9, phases=True)
        >>> MonteCarloSettings(max_angle_deg=30).resolved_for("agent")
        MonteCarloSettings(runs=100, seed=0, max_angle_deg=30, max_rate=0.01, phases=True)
        """
        if path not in _DEFAULTS:
            raise InputError(f"expected a Monte-Carlo path among {list(PATHS)}, received {path!r}")
        runs, angle, rate, phases = _DEFAULTS[path]
        out = replace(
            self,
            runs=runs if self.runs is None else self.runs,
            max_angle_deg=angle if self.max_angle_deg is None else self.max_angle_deg,
            max_rate=rate if self.max_rate is None else self.max_rate,
            phases=phases if self.phases is None else self.phases,
        )
        if path == "lagrangian" and not out.numbers()[1] < 180:
            raise InputError(
                f"expected 0 <= max_angle_deg < 180 (q0 > 0 initially), received {out.max_angle_deg:g}"
            )
        return out

    def numbers(self) -> tuple[int, float, float]:
        """``(runs, max_angle_deg, max_rate)`` of resolved settings (:meth:`resolved_for`)."""
        if self.runs is None or self.max_angle_deg is None or self.max_rate is None:
            raise InputError(f"expected resolved Monte-Carlo settings (resolved_for), received {self}")
        return self.runs, self.max_angle_deg, self.max_rate

    def run_seeds(self) -> list[int]:
        """The per-run seeds of an agent design's runs (the first ``k`` do not depend on
        ``runs``; ``runs`` not given: the agent path's default)."""
        ss = np.random.SeedSequence(self.seed)
        return [int(c.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))
                for c in ss.spawn(self.resolved_for("agent").numbers()[0])]

    def as_dict(self) -> dict[str, Any]:
        """The five settings by name (a Lagrangian campaign's ``settings`` in its summary)."""
        return {"runs": self.runs, "seed": self.seed, "max_angle_deg": self.max_angle_deg,
                "max_rate": self.max_rate, "phases": self.phases}


class RunStatus(enum.StrEnum):
    """How one Monte-Carlo run ended.

    ``converged`` / ``not-converged`` (horizon reached, ``convergence_time``
    None) as in :class:`~formsync_design.sim.result.SimStatus`; ``singular`` (a Lagrangian design):
    some ``q0`` reached ``q0_floor`` (``event_time``); ``diverged``: NaN/inf (``event_time``,
    an agent design's ``diverged_time``); ``inaccurate`` (a Lagrangian design): quaternion
    norm drift above ``norm_tol``; ``stopped`` (an agent design): the hybrid integrator
    stopped (Zeno protection or too many triggers).
    """

    CONVERGED = "converged"
    NOT_CONVERGED = "not-converged"
    SINGULAR = "singular"
    DIVERGED = "diverged"
    INACCURATE = "inaccurate"
    STOPPED = "stopped"


#: The statuses a Lagrangian campaign counts (its summary's ``counts``).
RUN_STATUSES = tuple(s.value for s in RunStatus if s != RunStatus.STOPPED)


@dataclass(frozen=True)
class MonteCarloRun:
    """Outcome of one run (``seed`` replays it) of either path.

    ``gains``: the sampled gains by name in box order (a diagonal gain as its three
    entries; a Lagrangian design's switching gain ``K_v`` last when it has one), each also an
    attribute (``run.K_o``).  Both paths set ``seed``, ``gains``, ``status``,
    ``convergence_time`` (None: not converged) and ``peak_torque``; a Lagrangian run also
    ``index``, ``final_q_m``, ``final_omega_m``, ``min_q0``, ``norm_error`` and ``event_time``;
    an agent run ``final_attitude_error`` (deg), ``final_rate_error``, ``effort``,
    ``transmissions`` and ``min_interevent`` (None without triggering) and ``diverged_time``.
    :meth:`to_dict` writes the keys of the run's path (an agent run: ``final_attitude_error``
    set).

    >>> r = MonteCarloRun(seed=5, gains=(("k_p", 0.5), ("k_d", (1.0, 1.1, 1.2))),
    ...                   status=RunStatus.CONVERGED, convergence_time=12.5, peak_torque=3.0,
    ...                   index=0, final_q_m=1e-5, final_omega_m=1e-6, min_q0=0.7,
    ...                   norm_error=1e-9)
    >>> r.k_p, list(r.to_dict())[:6]
    (0.5, ['index', 'seed', 'k_p', 'k_d_1', 'k_d_2', 'k_d_3'])
    >>> a = MonteCarloRun(seed=5, gains=(("k", 0.5),), status=RunStatus.CONVERGED,
    ...                   convergence_time=2.0, peak_torque=0.1, final_attitude_error=0.01,
    ...                   final_rate_error=1e-4, effort=0.2)
    >>> a.is_agent, list(a.to_dict())[:3]
    (True, ['seed', 'gain_k', 'status'])
    """

    seed: int
    gains: tuple[tuple[str, Any], ...]
    status: RunStatus
    convergence_time: float | None
    peak_torque: float
    # a Lagrangian run
    index: int | None = None
    final_q_m: float | None = None
    final_omega_m: float | None = None
    min_q0: float | None = None
    norm_error: float | None = None
    event_time: float | None = None
    # an agent run
    final_attitude_error: float | None = None
    final_rate_error: float | None = None
    effort: float | None = None
    transmissions: int | None = None
    min_interevent: float | None = None
    diverged_time: float | None = None

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "gains":
            raise AttributeError(name)
        for n, v in self.gains:
            if n == name:
                return v
        raise AttributeError(f"{type(self).__name__} has no attribute or gain {name!r}")

    @property
    def is_agent(self) -> bool:
        """A run of an agent design (its ``final_attitude_error`` set)."""
        return self.final_attitude_error is not None

    def gain_items(self) -> list[tuple[str, float]]:
        """The sampled gains as flat ``(name, value)`` pairs (a diagonal gain ``k`` as
        ``k_1, k_2, k_3``), in box order."""
        out: list[tuple[str, float]] = []
        for n, v in self.gains:
            if isinstance(v, tuple):
                out += [(f"{n}_{i + 1}", float(x)) for i, x in enumerate(v)]
            else:
                out.append((n, float(v)))
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, flat (numbers by :func:`~formsync_design.gains.json_number`; NaN as
        "nan"), the keys of the run's path.  A Lagrangian run: ``index``, ``seed``, the gains
        (:meth:`gain_items`), ``status``, ``convergence_time``, ``final_q_m``,
        ``final_omega_m``, ``min_q0``, ``peak_torque``, ``norm_error``, ``event_time``.  An
        agent run: ``seed``, ``gain_<name>`` (a diagonal gain as ``"[a, b, c]"``),
        ``status``, ``diverged_time``, ``convergence_time``, ``final_attitude_error_deg``,
        ``final_rate_error``, ``peak_torque``, ``effort``, ``transmissions``,
        ``min_interevent``."""
        if self.is_agent:
            return self._agent_dict()
        out = {"index": json_number(self.index), "seed": json_number(self.seed)}
        out.update((n, json_number(v)) for n, v in self.gain_items())
        out["status"] = str(self.status)
        for k in ("convergence_time", "final_q_m", "final_omega_m", "min_q0", "peak_torque",
                  "norm_error", "event_time"):
            out[k] = json_number(getattr(self, k))
        return out

    def _agent_dict(self) -> dict[str, Any]:
        def opt(v: Any) -> Any:
            return None if v is None else json_number(v)

        return {
            "seed": self.seed,
            **{f"gain_{k}": (json_number(v) if not isinstance(v, tuple)
                             else "[" + ", ".join(f"{x:.9g}" for x in v) + "]")
               for k, v in self.gains},
            "status": str(self.status),
            "diverged_time": opt(self.diverged_time),
            "convergence_time": opt(self.convergence_time),
            "final_attitude_error_deg": json_number(self.final_attitude_error),
            "final_rate_error": json_number(self.final_rate_error),
            "peak_torque": json_number(self.peak_torque), "effort": json_number(self.effort),
            "transmissions": self.transmissions,
            "min_interevent": opt(self.min_interevent),
        }


@dataclass(frozen=True)
class MonteCarloResult(NotebookViews):
    """A campaign (frozen) of either path; ``failures`` carry their seeds.

    Both paths: ``runs``, the sampled ``box``, the resolved ``settings``, the run
    ``options`` (``SimOptions`` / ``AgentOptions``), ``counts`` per status,
    ``convergence_time_stats`` (min, median, p95, max of the converged runs; None without
    one) and ``wall_seconds``.  A Lagrangian campaign also ``build_seconds`` (its kernel),
    ``certification`` (the dict of
    :func:`~formsync_design.sim.montecarlo.certify_sampled_box`, ``{"status": "skipped"}``
    when not asked) and ``spec_key``; an agent campaign ``design`` and ``graph`` (names),
    ``certificate`` (the box's certificate status, None when not certified here) and
    ``certificate_reason``.  :meth:`summary` / :meth:`to_dict` write the keys of the path
    (an agent campaign: ``design`` set).
    """

    runs: tuple[MonteCarloRun, ...]
    box: GainBox
    settings: MonteCarloSettings
    options: Any
    counts: dict
    convergence_time_stats: dict
    wall_seconds: float
    build_seconds: float = 0.0
    certification: dict | None = None
    spec_key: str = ""
    design: str | None = None
    graph: str | None = None
    certificate: str | None = None
    certificate_reason: str = ""

    @property
    def is_agent(self) -> bool:
        """A campaign of an agent design (its ``design`` set)."""
        return self.design is not None

    @property
    def failures(self) -> tuple[MonteCarloRun, ...]:
        return tuple(r for r in self.runs if r.status != RunStatus.CONVERGED)

    @property
    def all_converged(self) -> bool:
        return not self.failures

    def summary(self) -> dict[str, Any]:
        """The campaign's summary: for an agent campaign its :meth:`to_dict`; for a Lagrangian
        campaign runs, counts, convergence-time statistics, the worst final ``Q_m`` and
        ``Omega_m``, the smallest ``q0``, the largest torque, box, settings, options, the
        failed runs, the certification and the timings."""
        if self.is_agent:
            return self._agent_dict()
        return {
            "runs": len(self.runs),
            "counts": self.counts,
            "convergence_time": self.convergence_time_stats,
            "worst_final_q_m": _finite_max([_f(r.final_q_m) for r in self.runs]),
            "worst_final_omega_m": _finite_max([_f(r.final_omega_m) for r in self.runs]),
            "min_q0": _finite_min([_f(r.min_q0) for r in self.runs]),
            "max_peak_torque": _finite_max([r.peak_torque for r in self.runs]),
            "box": self.box.as_floats(),
            "settings": self.settings.as_dict(),
            "options": {
                "tf": self.options.tf, "switch": self.options.switch, "phi": self.options.phi,
                "torque_limit": self.options.torque_limit, "sample_period": self.options.sample_period,
                "integrator": self.options.method,
                "step": self.options.rk4_step if self.options.method == "rk4" else None,
                "rtol": self.options.rtol if self.options.method != "rk4" else None,
                "atol": self.options.atol if self.options.method != "rk4" else None,
                "output_step": self.options.interval,
                "q_tol": self.options.q_tol, "omega_tol": self.options.omega_tol,
            },
            "failures": [r.to_dict() for r in self.failures],
            "certification": self.certification,
            "wall_seconds": self.wall_seconds,
            "build_seconds": self.build_seconds,
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: a Lagrangian campaign's :meth:`summary` with every number by
        :func:`~formsync_design.gains.json_number` (NaN of a diverged run as "nan"; None where
        nothing finite was observed); an agent campaign's design, graph, box, runs, seed,
        spreads, counts of converged and diverged runs, failed seeds, convergence-time
        maximum and median, largest torque and certificate."""
        if self.is_agent:
            return self._agent_dict()
        return _jsonable(self.summary())

    def _agent_dict(self) -> dict[str, Any]:
        times = [r.convergence_time for r in self.runs if r.convergence_time is not None]
        return {
            "design": self.design, "graph": self.graph, "box": str(self.box),
            "runs": len(self.runs), "seed": self.settings.seed,
            "max_angle_deg": json_number(self.settings.max_angle_deg),
            "max_rate": json_number(self.settings.max_rate),
            "converged": len(self.runs) - len(self.failures),
            "diverged": sum(r.status == "diverged" for r in self.runs),
            "failed_seeds": [r.seed for r in self.failures],
            "convergence_time_max": json_number(max(times)) if times else None,
            "convergence_time_median": json_number(float(np.median(times))) if times else None,
            "peak_torque_max": json_number(max(r.peak_torque for r in self.runs)),
            "certificate": self.certificate, "certificate_reason": self.certificate_reason,
        }


def _f(v: float | None) -> float:
    return math.nan if v is None else v


def _finite_min(v: list[float]) -> float | None:
    f = [x for x in v if math.isfinite(x)]
    return min(f) if f else None


def _finite_max(v: list[float]) -> float | None:
    f = [x for x in v if math.isfinite(x)]
    return max(f) if f else None


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, enum.Enum):
        return str(x.value)
    return json_number(x)
