"""The settings and the result of a Monte-Carlo campaign
(:func:`~formsync_design.sim.montecarlo.run_montecarlo`): what is sampled and how
(:class:`MonteCarloSettings`), each run's status, seed, gains and measurements (:class:`MonteCarloRun`) and the campaign's
summary (:class:`MonteCarloResult`)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

from formsync_design.errors import InputError
from formsync_design.gains import GainBox, json_number
from formsync_design.notebook import NotebookViews
from formsync_design.sim.formation import SimOptions

__all__ = [
    "MAX_RUNS",
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


@dataclass(frozen=True)
class MonteCarloSettings:
    """What is randomised and how (module docstring)."""

    runs: int = 1000
    seed: int = 0
    max_angle_deg: float = 100.0
    max_rate: float = 0.9
    phases: bool = True

    def __post_init__(self) -> None:
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise InputError(f"expected an integer number of runs >= 1, received {self.runs}")
        if self.runs > MAX_RUNS:
            raise InputError(
                f"expected at most {MAX_RUNS} runs per campaign (each sampled formation is kept in "
                f"memory, ~3 kB and ~5 ms of CPU per run for N = 8), received {self.runs}; split "
                "the campaign over several seeds"
            )
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"expected a non-negative integer seed, received {self.seed}")
        if not (0 <= self.max_angle_deg < 180):
            raise InputError(
                f"expected 0 <= max_angle_deg < 180 (q0 > 0 initially), received {self.max_angle_deg:g}"
            )
        if not (math.isfinite(self.max_rate) and self.max_rate >= 0):
            raise InputError(f"expected max_rate >= 0 (rad/s), received {self.max_rate:g}")


class RunStatus(enum.StrEnum):
    """How one Monte-Carlo run ended.

    ``converged`` / ``not-converged`` (horizon reached, ``convergence_time``
    None) as in :class:`~formsync_design.sim.result.SimStatus`; ``singular``:
    some ``q0`` reached ``q0_floor`` (``event_time``); ``diverged``: NaN/inf
    (``event_time``); ``inaccurate``: quaternion norm drift above ``norm_tol``.
    """

    CONVERGED = "converged"
    NOT_CONVERGED = "not-converged"
    SINGULAR = "singular"
    DIVERGED = "diverged"
    INACCURATE = "inaccurate"


RUN_STATUSES = tuple(s.value for s in RunStatus)


@dataclass(frozen=True)
class MonteCarloRun:
    """Outcome of one run (``seed`` replays it).

    ``gains``: the sampled gains by name (the design's controller gains, then its
    switching gain ``K_v`` when it has one; a diagonal gain as its three entries), each
    also an attribute (``run.K_o``).

    >>> r = MonteCarloRun(0, 5, (("k_p", 0.5), ("k_d", (1.0, 1.1, 1.2))), RunStatus.CONVERGED,
    ...                   12.5, 1e-5, 1e-6, 0.7, 3.0, 1e-9)
    >>> r.k_p, list(r.to_dict())[:6]
    (0.5, ['index', 'seed', 'k_p', 'k_d_1', 'k_d_2', 'k_d_3'])
    """

    index: int
    seed: int
    gains: tuple[tuple[str, Any], ...]
    status: RunStatus
    convergence_time: float | None
    final_q_m: float
    final_omega_m: float
    min_q0: float
    peak_torque: float
    norm_error: float
    event_time: float | None = None

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "gains":
            raise AttributeError(name)
        for n, v in self.gains:
            if n == name:
                return v
        raise AttributeError(f"{type(self).__name__} has no attribute or gain {name!r}")

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
        "nan"): ``index``, ``seed``, the gains (:meth:`gain_items`), then the outcome."""
        out = {"index": json_number(self.index), "seed": json_number(self.seed)}
        out.update((n, json_number(v)) for n, v in self.gain_items())
        for k, v in self.__dict__.items():
            if k not in ("index", "seed", "gains"):
                out[k] = str(v) if k == "status" else json_number(v)
        return out


@dataclass(frozen=True)
class MonteCarloResult(NotebookViews):
    """Statistics of a Monte-Carlo campaign (frozen); ``failures`` carry their seeds."""

    runs: tuple[MonteCarloRun, ...]
    box: GainBox
    settings: MonteCarloSettings
    options: SimOptions
    counts: dict
    convergence_time_stats: dict
    wall_seconds: float
    build_seconds: float
    certification: dict
    spec_key: str = ""


    @property
    def failures(self) -> tuple[MonteCarloRun, ...]:
        return tuple(r for r in self.runs if r.status != RunStatus.CONVERGED)

    @property
    def all_converged(self) -> bool:
        return not self.failures

    def summary(self) -> dict[str, Any]:
        return {
            "runs": len(self.runs),
            "counts": self.counts,
            "convergence_time": self.convergence_time_stats,
            "worst_final_q_m": max(r.final_q_m for r in self.runs if math.isfinite(r.final_q_m)) if any(
                math.isfinite(r.final_q_m) for r in self.runs) else None,
            "worst_final_omega_m": max(r.final_omega_m for r in self.runs if math.isfinite(r.final_omega_m)) if any(
                math.isfinite(r.final_omega_m) for r in self.runs) else None,
            "min_q0": _finite_min([r.min_q0 for r in self.runs]),
            "max_peak_torque": _finite_max([r.peak_torque for r in self.runs]),
            "box": self.box.as_floats(),
            "settings": self.settings.__dict__,
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
        """:meth:`summary` with every number by :func:`~formsync_design.gains.json_number`
        (NaN of a diverged run as "nan"; None where nothing finite was observed)."""
        return _jsonable(self.summary())


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
