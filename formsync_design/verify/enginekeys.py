"""Engine case tables and keys beside the formations, scenarios, metrics and claims
(:mod:`formsync_design.verify.enginecase`): the ``[montecarlo]`` table
(:func:`parse_montecarlo`, its draw rules in :mod:`formsync_design.verify.enginedraws`) and
the keys for comparing designs.

``[[formations]] initial = [{euler_deg | q | quaternion, rate}, ...]`` and ``tf``
    the formation starts from its own state (one row per spacecraft, read by the agent case
    parser beside the case's inertias; only on a formation of the case's size) and runs over
    its own horizon, replacing the scenario's
    (:meth:`~formsync_design.verify.enginecase.EngineCase.case_for`);
``[[scenarios]] torque_matching = {scenario, formation, hold = [gain, ...], rtol}``
    every gain of the scenario's design but those held is multiplied by the one factor that
    makes its peak torque on that formation equal the named scenario's there (the search of
    :func:`~formsync_design.analysis.equal_torque.equal_peak_scale` to ``rtol``, done once per
    verification: :meth:`~formsync_design.verify.engine.EngineResults.gain_scale`); every run,
    draw, certificate and metric of the scenario then uses the scaled gains.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from formsync_design.errors import InputError
from formsync_design.ranges import check_range
from formsync_design.sim.montecarlo_data import MAX_RUNS, MonteCarloSettings
from formsync_design.verify.agentcase import AgentCase, parse_agent_case
from formsync_design.verify.enginedraws import DRAW_RULES

__all__ = ["MonteCarloSpec", "parse_montecarlo", "formation_initial", "torque_matching",
           "check_torque_matching"]

_MC_KEYS = {"runs", "seed", "max_angle", "max_rate", "box", "tf", "draws", "rate_sigma"}

@dataclass(frozen=True)
class MonteCarloSpec:
    """``settings`` (runs, seed, spreads), ``box`` (gain -> ``"lo:hi"``, ``{}``: the
    scenario's gains), ``tf`` (the draws' horizon, ``None``: the scenario's), ``draws``
    (:data:`~formsync_design.verify.enginedraws.DRAW_RULES`) and ``rate_sigma`` (rad/s,
    ``about-reference``)."""

    settings: MonteCarloSettings
    box: dict[str, str]
    tf: float | None = None
    draws: str = "box"
    rate_sigma: float = 0.01


def _int(v: Any, where: str, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise InputError(f"expected {where} an integer in [{lo}, {hi}], received {v!r:.40}")
    return v


def _check_keys(t: dict) -> None:
    extra = sorted(set(t) - _MC_KEYS)
    if extra:
        raise InputError(f"expected keys {sorted(_MC_KEYS)} in [montecarlo], received unknown "
                         f"{extra}")


def _number(v: Any, where: str, quantity: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"expected {where} as a number, received {v!r:.40}")
    check_range(v, quantity, where)
    return float(v)


def parse_montecarlo(data: dict, base: AgentCase) -> MonteCarloSpec | None:
    from formsync_design.gains import parse_gain_range

    t = data.get("montecarlo")
    if t is None:
        return None
    if not isinstance(t, dict):
        raise InputError(f"expected a [montecarlo] table, received {t!r:.60}")
    _check_keys(t)
    settings = MonteCarloSettings(
        runs=_int(t.get("runs", 20), "montecarlo.runs", 1, MAX_RUNS),
        seed=_int(t.get("seed", 0), "montecarlo.seed", 0, 2**63 - 1),
        max_angle_deg=_number(t.get("max_angle", 90.0), "montecarlo.max_angle", "angle"),
        max_rate=_number(t.get("max_rate", 0.01), "montecarlo.max_rate", "rate")
    ).resolved_for("agent")
    draws = t.get("draws", "box")
    if draws not in DRAW_RULES:
        raise InputError(f"expected montecarlo.draws among {list(DRAW_RULES)}, received "
                         f"{draws!r:.40}")
    if draws == "box" and "rate_sigma" in t:
        raise InputError("expected montecarlo.rate_sigma only with draws = \"about-reference\", "
                         "received it with the box draws")
    if draws == "about-reference" and ("max_rate" in t or "box" in t):
        raise InputError("expected rate_sigma and the scenario's gains with draws = "
                         "\"about-reference\", received max_rate or box")
    if draws == "euler-uniform" and ("rate_sigma" in t or "box" in t):
        raise InputError("expected max_angle, max_rate and the scenario's gains with draws = "
                         "\"euler-uniform\", received rate_sigma or box")
    tf = None if "tf" not in t else _number(t["tf"], "montecarlo.tf", "horizon")
    sigma = _number(t.get("rate_sigma", 0.01), "montecarlo.rate_sigma", "rate")
    box = t.get("box", {})
    if not isinstance(box, dict):
        raise InputError(f"expected montecarlo.box = {{gain = \"lo:hi\"}}, received {box!r:.60}")
    ctrl = list(base.design.decl.controller_gains)
    unknown = sorted(set(box) - set(ctrl))
    if unknown:
        raise InputError(f"expected montecarlo.box gains among {ctrl}, received unknown {unknown}")
    out = {}
    for k, v in box.items():
        if isinstance(v, bool) or not isinstance(v, (str, int, float)):
            raise InputError(f"expected montecarlo.box.{k} as \"lo:hi\" or a number, received {v!r:.40}")
        parse_gain_range(str(v), f"montecarlo.box.{k}")
        out[k] = str(v)
    return MonteCarloSpec(settings, out, tf, str(draws), sigma)


def formation_initial(row: dict, where: str, agent: dict, n: int, path: str) -> tuple[Any, Any] | None:
    """A formation's ``initial`` rows read by the agent case parser (each beside the case's
    spacecraft ``i``'s inertia; only on a formation of the case's size)."""
    init = row.get("initial")
    if init is None:
        return None
    if not isinstance(init, list) or len(init) != n or not all(isinstance(r, dict) for r in init):
        raise InputError(f"expected {where}.initial = [{{euler_deg | q | quaternion, rate}}, ...] "
                         f"with {n} spacecraft, received {init!r:.60}")
    sc = agent.get("spacecraft", [])
    if n != len(sc):
        raise InputError(f"expected {where}.initial on a formation of the case's {len(sc)} "
                         f"spacecraft, received it on one of {n}")
    for k, r in enumerate(init, 1):
        extra = sorted(set(r) - {"euler_deg", "q", "quaternion", "rate"})
        if extra:
            raise InputError(f"expected {where}.initial[{k}] keys among euler_deg, q, quaternion, "
                             f"rate, received unknown {extra}")
    doc = copy.deepcopy(agent)
    doc["spacecraft"] = [{"inertia": sc[i].get("inertia"), **copy.deepcopy(r)}
                         for i, r in enumerate(init)]
    c = parse_agent_case(doc, path)
    return c.attitudes, c.rates


def torque_matching(row: dict, where: str, case: AgentCase, over: dict[str, Any]
                     ) -> dict[str, Any] | None:
    """A scenario's ``torque_matching`` table, checked (module docstring); its formation is
    checked against the formations by :func:`parse_engine_case`."""
    t = row.get("torque_matching")
    if t is None:
        return None
    keys = {"scenario", "formation", "hold", "rtol"}
    if not isinstance(t, dict) or not {"scenario", "formation"} <= set(t) or set(t) - keys:
        raise InputError(f"expected {where}.torque_matching = {{scenario, formation, hold, rtol}}, "
                         f"received {t!r:.60}")
    hold = t.get("hold", [])
    gains = list(case.design.decl.controller_gains)
    if not isinstance(hold, list) or not all(isinstance(h, str) and h in gains for h in hold):
        raise InputError(f"expected {where}.torque_matching.hold as gains among {gains}, "
                         f"received {hold!r:.60}")
    rtol = _number(t.get("rtol", 1e-3), f"{where}.torque_matching.rtol", "tolerance")
    if not 0 < rtol < 1:
        raise InputError(f"expected {where}.torque_matching.rtol in (0, 1), received {rtol:g}")
    for k in ("scenario", "formation"):
        if not isinstance(t[k], str):
            raise InputError(f"expected {where}.torque_matching.{k} as a name, received "
                             f"{t[k]!r:.40}")
    out = {"scenario": t["scenario"], "formation": t["formation"], "hold": list(hold),
           "rtol": rtol}
    over["torque_matching"] = out
    return out


def check_torque_matching(scenarios: Sequence[Any], formations: Sequence[str]) -> None:
    """Every ``torque_matching`` names another scenario (one without ``torque_matching``) and
    a formation of the case."""
    names = [s.name for s in scenarios]
    for k, s in enumerate(scenarios, 1):
        t = s.torque_matching
        if t is None:
            continue
        if t["scenario"] not in names or t["scenario"] == s.name or next(
                x for x in scenarios if x.name == t["scenario"]).torque_matching:
            raise InputError(f"expected scenarios[{k}].torque_matching.scenario naming another "
                             f"scenario among {names} that has no torque_matching itself, "
                             f"received {t['scenario']!r:.60}")
        if t["formation"] not in formations:
            raise InputError(f"expected scenarios[{k}].torque_matching.formation among "
                             f"{list(formations)}, received {t['formation']!r:.60}")
