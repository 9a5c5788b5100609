"""The ``sensors`` and ``leader`` overrides of an engine scenario: what its runs read.

A ``[[scenarios]]`` row may say ``sensors = {bias = 1e-4, noise = 3e-4, seed = 2012, failed =
[1], failed_at = 0.0}``: its runs hand the law the output of
:class:`~formsync_design.sim.sensors.RateSensors` instead of the true rate (the plant always
integrates the true rate), through the compiled kernel's ``measured`` variant.  ``bias``
(rad/s per axis, signs drawn from ``seed``), ``noise`` (rad/s per sample at the RK4 step),
``failed`` (spacecraft numbers whose gyro reads zero from ``failed_at`` s on); every key is
optional and ``sensors = {}`` is a perfect gyro read through the same variant (a design that
never reads the rate then runs bit for bit as under any other gyro).  It needs the ``rk4``
integrator and a continuous design (:func:`~formsync_design.sim.agents.simulate_agents`).

``leader = false`` drops the base case's ``[reference]`` table from the scenario (the runs
have no leader): for a comparison ``design`` that declares none; the formation's pinning
gains are then not read by its law.

>>> from formsync_design.resources import case_file
>>> from formsync_design.verify.agentcase import load_agent_case
>>> c = load_agent_case(case_file("lv2012_small"))
>>> spec = parse_sensors({"bias": 1e-4, "failed": [2]}, "scenarios[1].sensors", c)
>>> spec["failed"], rate_sensors(spec, 3).fail_time.tolist()
([2], [inf, 0.0, inf])
"""

from __future__ import annotations

from typing import Any

from formsync_design.errors import InputError
from formsync_design.ranges import check_range

__all__ = ["SENSOR_KEYS", "parse_sensors", "scenario_sensors", "scenario_leader", "rate_sensors", "scenario_inputs"]

#: The keys of a scenario's ``sensors`` table.
SENSOR_KEYS = ("bias", "noise", "seed", "failed", "failed_at")


def _num(t: dict, key: str, where: str, quantity: str) -> float:
    v = t.get(key, 0.0)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v < 0:
        raise InputError(f"expected {where}.{key} as a number >= 0, received {v!r:.40}")
    check_range(v, quantity, f"{where}.{key}")
    return float(v)


def parse_sensors(table: Any, where: str, case: Any) -> dict[str, Any]:
    """The validated ``sensors`` table of a scenario (module docstring) of the scenario's
    :class:`~formsync_design.verify.agentcase.AgentCase`, refused unless it integrates with
    ``rk4`` a continuous design."""
    n, integrator = case.n, str(case.options.integrator)
    sampling = str(case.design.decl.sampling)
    if not isinstance(table, dict):
        raise InputError(f"expected {where} as a table {{{', '.join(SENSOR_KEYS)}}}, received "
                         f"{table!r:.60}")
    extra = sorted(set(table) - set(SENSOR_KEYS))
    if extra:
        raise InputError(f"expected keys among {list(SENSOR_KEYS)} in {where}, received "
                         f"unknown {extra}")
    if integrator != "rk4" or sampling != "continuous":
        raise InputError(f"expected the rk4 integrator and a continuous design for {where}, "
                         f"received {integrator} and {sampling}")
    seed = table.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise InputError(f"expected {where}.seed an integer in [0, 2^63), received {seed!r:.40}")
    failed = table.get("failed", [])
    if not isinstance(failed, list) or not all(
            isinstance(k, int) and not isinstance(k, bool) and 1 <= k <= n for k in failed) \
            or len(set(failed)) != len(failed):
        raise InputError(f"expected {where}.failed a list of distinct spacecraft numbers in "
                         f"1..{n}, received {failed!r:.60}")
    return {"bias": _num(table, "bias", where, "rate"), "noise": _num(table, "noise", where, "rate"),
            "seed": seed, "failed": list(failed),
            "failed_at": _num(table, "failed_at", where, "horizon")}


def scenario_sensors(row: dict[str, Any], where: str, case: Any) -> dict[str, Any]:
    """``{"sensors": parsed}`` of a ``[[scenarios]]`` row with a ``sensors`` table, else
    ``{}`` (merged into the scenario's overrides)."""
    if "sensors" not in row:
        return {}
    return {"sensors": parse_sensors(row["sensors"], f"{where}.sensors", case)}


def scenario_leader(row: dict[str, Any], where: str, merged: dict[str, Any],
                    over: dict[str, Any]) -> None:
    """Apply a row's ``leader = false`` to its ``merged`` tables (module docstring): the
    base case's ``[reference]`` is dropped (the design itself is not replaced)."""
    if "leader" not in row:
        return
    v = row["leader"]
    if v is not False:
        raise InputError(f"expected {where}.leader = false (the runs have no leader), received "
                         f"{v!r:.40}")
    merged.pop("reference", None)
    over["leader"] = False


def rate_sensors(spec: dict[str, Any], n: int) -> Any:
    """The :class:`~formsync_design.sim.sensors.RateSensors` of a parsed ``sensors`` table."""
    from formsync_design.sim.sensors import RateSensors

    return RateSensors.of(n, bias=spec["bias"], noise_std=spec["noise"],
                          failed={k: spec["failed_at"] for k in spec["failed"]},
                          seed=spec["seed"])


def scenario_inputs(overrides: dict[str, Any], n: int) -> dict[str, Any]:
    """The keyword arguments of a scenario's runs: ``sensors`` when it declares them."""
    spec = overrides.get("sensors")
    return {} if spec is None else {"sensors": rate_sensors(spec, n)}
