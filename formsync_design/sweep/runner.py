"""``run_sweep``: run or resume a campaign into a results folder."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from formsync_design.errors import FormsyncError, InputError
from formsync_design.outdir import locked
from formsync_design.spec.trust import design_code_of
from formsync_design.sweep.campaign import (
    Campaign,
    campaign_hash,
    graph_records,
    resolve_spec,
    spec_key,
)
from formsync_design.sweep.executor import check_scheduler_address, execute
from formsync_design.sweep.graphsets import expand_graphs, graph_set_bound
from formsync_design.sweep.schema import FORMAT
from formsync_design.sweep.store import (
    OWNED,
    Journal,
    atomic_write,
    check_folder,
    csv_bytes,
    read_journal,
    read_results,
    sort_key,
)
from formsync_design.sweep.summary import write_summary
from formsync_design.sweep.tasks import build_tasks, run_task

__all__ = ["SweepOutcome", "run_sweep", "check_campaign_size", "MAX_TASKS", "MAX_SIMULATIONS"]

MAX_TASKS = 100_000
"""Most tasks (graphs x boxes) of one campaign: every row is kept in memory and in
``results.csv`` (about 1 KB each), and each task runs a region map and a design
(seconds to minutes each); split a larger study into several campaigns."""

MAX_WORKERS = 256
"""Most local worker processes (each a Python interpreter of ~200 MB)."""

MAX_SIMULATIONS = 10_000_000
"""Most Monte-Carlo simulations (tasks x runs) of one campaign (about 0.1-1 s each:
beyond this a campaign would run for months)."""


def check_campaign_size(campaign: Campaign, n_graphs: int, *, bound: bool = False) -> None:
    """Refuse a campaign that cannot finish, naming the limit (one-line :class:`InputError`).

    >>> from formsync_design.sweep.campaign import campaign_from_dict
    >>> c = campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}})
    >>> check_campaign_size(c, 10)
    >>> check_campaign_size(c, 200_000)
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected at most 100000 tasks (graphs x boxes) in one campaign, received 200000 (200000 graphs x 1 boxes); split the campaign
    """
    tasks = n_graphs * len(campaign.boxes)
    if tasks > MAX_TASKS:
        raise InputError(
            f"expected at most {MAX_TASKS} tasks (graphs x boxes) in one campaign, received "
            f"{'up to ' if bound else ''}{tasks} ({n_graphs} graphs x {len(campaign.boxes)} boxes); "
            "split the campaign"
        )
    if campaign.montecarlo is not None:
        sims = tasks * campaign.montecarlo.runs
        if sims > MAX_SIMULATIONS:
            raise InputError(
                f"expected at most {MAX_SIMULATIONS} Monte-Carlo simulations in one campaign, "
                f"received {'up to ' if bound else ''}{sims} ({tasks} tasks x "
                f"{campaign.montecarlo.runs} runs); lower "
                "montecarlo.runs or split the campaign"
            )


@dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did (wall time is not written to any file)."""

    out: Path
    sha256: str
    tasks: int
    computed: int
    reused: int
    graphs: int
    skipped: tuple[str, ...]
    files: tuple[Path, ...]
    wall_seconds: float
    executor: str
    design: str = "liang2016"


def run_sweep(
    campaign: Campaign,
    out: str | Path,
    *,
    resume: bool = False,
    overwrite: bool = False,
    scheduler: str | None = None,
    n_workers: int = 2,
    timeout: float = 10.0,
    progress: Callable[[int, int], None] | None = None,
    command: str = "",
    task_fn: Callable[[dict[str, Any]], dict[str, str]] | None = None,
    spec: Any = None,
) -> SweepOutcome:
    """Run (or resume) a campaign into the results folder ``out``.

    Parameters
    ----------
    campaign : Campaign
    out : folder (created; see module docstring for its files)
    resume : keep the finished rows of an interrupted run of the same campaign
    overwrite : recompute a folder of the same campaign from scratch
    scheduler : address of an existing Dask scheduler (``tcp://host:8786``)
    n_workers : local worker processes (default 2); 0 = serial, in this process
    timeout : seconds to wait for the scheduler and its workers
    progress : called with ``(computed, pending)`` after every finished task
        (``pending`` = tasks this call computes; finished tasks of a resumed run excluded)
    command : the command line recorded in ``summary.md``
    task_fn : the task function (default :func:`run_task`; tests inject failures)
    spec : the design (a ``Spec``, a name or a path; default the campaign's design,
        else the paper's); it must have the gains the campaign's tables were checked
        against; its content key is part of the campaign hash, so a folder of another
        design is refused

    Raises
    ------
    InputError
        Bad graph sets, a folder of another campaign, a malformed scheduler
        address, a campaign above :data:`MAX_TASKS` tasks or
        :data:`MAX_SIMULATIONS` Monte-Carlo runs.
    ClusterError
        An unreachable scheduler, a cluster without workers, a worker that died.
    KeyboardInterrupt
        Ctrl-C: the journal keeps every finished row; ``resume=True`` finishes.
    """
    t0 = time.perf_counter()
    if resume and overwrite:
        raise InputError("expected at most one of --resume and --overwrite, received both")
    if isinstance(n_workers, bool) or not isinstance(n_workers, int) or not 0 <= n_workers <= MAX_WORKERS:
        raise InputError(f"expected a number of workers in 0..{MAX_WORKERS}, received {n_workers!r}")
    if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
        raise InputError(f"expected a positive timeout in seconds, received {timeout!r}")
    if scheduler:
        scheduler = check_scheduler_address(scheduler)
    # refuse before building anything, on an upper bound of the graph count; then exactly
    source = campaign.source or None
    check_campaign_size(campaign, sum(graph_set_bound(g, base=Path(campaign.base), source=source)
                                      for g in campaign.graphs), bound=True)
    graphs, skipped = expand_graphs(campaign.graphs, base=Path(campaign.base), source=source)
    check_campaign_size(campaign, len(graphs))
    sp = resolve_spec(campaign, spec)
    sha = campaign_hash(campaign, graphs, sp if spec is not None else None)  # validates the case file
    outp = Path(out)
    check_folder(outp, sha, resume=resume, overwrite=overwrite)  # refused before the lock too
    # one writer per folder: a second sweep (or any writer) into ``out`` is refused (exit 2);
    # the folder is checked again under the lock, so its manifest cannot change under us
    with locked(outp, command or None):
        mode = check_folder(outp, sha, resume=resume, overwrite=overwrite)
        tasks = build_tasks(campaign, graphs, sp if spec is not None else None)
        columns = campaign.schema.columns
        ids = {t["task"] for t in tasks}
        done: dict[str, dict[str, str]] = {}
        jpath = outp / "journal.jsonl"
        if mode == "resume":
            if (outp / "results.csv").is_file():
                for r in read_results(outp / "results.csv", columns):
                    done[r["task"]] = r
            for k, r in read_journal(jpath, repair=True, columns=columns).items():
                if k in done and done[k] != r:
                    raise InputError(f"expected identical rows for task {k!r} in results.csv and the journal")
                done[k] = r
            stray = set(done) - ids
            if stray:
                raise InputError(f"expected only tasks of this campaign, received {sorted(stray)[:3]} in {outp}")
        pending = [t for t in tasks if t["task"] not in done]
        executor = "serial" if (n_workers == 0 and not scheduler) else (
            f"dask scheduler {scheduler}" if scheduler else f"dask LocalCluster ({n_workers} worker processes)"
        )
        manifest = {
            "format": FORMAT,
            "sha256": sha,
            "campaign": campaign.to_dict(),
            "graphs": graph_records(graphs),
            "skipped": skipped,
            "tasks": len(tasks),
            "columns": list(columns),
            "spec": {"name": sp.name, "sha256": spec_key(sp)},
        }
        code = design_code_of([sp])  # design code that is not shipped: named (spec.trust)
        if code:
            manifest["design_code"] = [c.to_dict() for c in code]
        man_bytes = (json.dumps(manifest, indent=1, sort_keys=True, ensure_ascii=True) + "\n").encode()

        started = {"ok": False}
        journal: Journal | None = None
        count = {"n": 0}

        def on_row(row: dict[str, str]) -> None:
            nonlocal journal
            if not started["ok"]:
                _begin()
            assert journal is not None
            if row["task"] in done:
                raise FormsyncError(f"expected each task once, received {row['task']!r} twice")
            journal.append(row)
            done[row["task"]] = row
            count["n"] += 1
            if progress:
                progress(count["n"], len(pending))

        def _begin() -> None:
            nonlocal journal
            outp.mkdir(parents=True, exist_ok=True)
            for name in OWNED + ("manifest.json",):  # temporaries of a killed atomic write
                for tmp in (outp / f".{name}.tmp", *outp.glob(f".{name}.*.tmp")):
                    tmp.unlink(missing_ok=True)
            if mode == "overwrite":
                for name in OWNED:
                    (outp / name).unlink(missing_ok=True)
            if mode != "resume" or not (outp / "manifest.json").is_file():
                atomic_write(outp / "manifest.json", man_bytes)
            journal = Journal(jpath)
            started["ok"] = True

        if pending:
            # connect first: an unreachable scheduler must not leave anything behind; the
            # journal exists from the moment the cluster is up (before the first task ends)
            fn = task_fn or run_task
            if n_workers == 0 and not scheduler:
                _begin()
                try:
                    execute(pending, on_row, scheduler=None, n_workers=0, timeout=timeout, task_fn=fn)
                finally:
                    if journal is not None:
                        journal.close()
            else:
                try:
                    execute(pending, on_row, scheduler=scheduler, n_workers=n_workers, timeout=timeout,
                            task_fn=fn, on_start=lambda: None if started["ok"] else _begin())
                finally:
                    if journal is not None:
                        journal.close()
        if not started["ok"]:
            _begin()
            assert journal is not None
            journal.close()
        rows = sorted((done[t["task"]] for t in tasks), key=sort_key)
        atomic_write(outp / "results.csv", csv_bytes(rows, columns))
        files = [outp / "manifest.json", outp / "results.csv"]
        compared = None
        if campaign.compare:
            from formsync_design.sweep.compare import load_compared

            compared = load_compared(campaign.compare, campaign.base)
        files += write_summary(outp, rows, manifest, command=command, schema=campaign.schema,
                               compared=compared)
        jpath.unlink(missing_ok=True)
        return SweepOutcome(
            out=outp, sha256=sha, tasks=len(tasks), computed=len(pending),
            reused=len(tasks) - len(pending), graphs=len(graphs), skipped=tuple(skipped),
            files=tuple(files), wall_seconds=time.perf_counter() - t0, executor=executor,
            design=sp.name,
        )

