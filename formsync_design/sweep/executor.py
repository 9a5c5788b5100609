"""Executors of a sweep: serial, a local Dask cluster, or an existing scheduler.

Failures are classified for the exit status of ``formsync``:

* a malformed scheduler address is the user's input (:class:`InputError`, exit 2);
* a scheduler that cannot be reached, a cluster without workers, a local
  cluster that does not start, a worker that dies (``KilledWorker``) or a lost
  connection are failures of the environment (:class:`ClusterError`, exit 3),
  with what failed and what to try;
* a task that raises keeps the class of its error when it is one of ours
  (an :class:`InputError` stays bad input) and is otherwise a
  :class:`FormsyncError` (exit 3); finished rows are kept either way.

Ctrl-C: the worker processes of a local cluster are started with SIGINT
ignored and blocked (they inherit both), so a terminal's Ctrl-C, which reaches
the whole process group, interrupts only this process; a Ctrl-C during the
cluster's start is held and raised once it is up (never lost).  It then
cancels the futures and closes the cluster with SIGINT ignored and Dask's
logging silenced, and re-raises :class:`KeyboardInterrupt` (``formsync`` prints
one line and exits 130).  Rows finished before the interrupt are already in the
journal.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import re
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from formsync_design.errors import ClusterError, FormsyncError, InputError

__all__ = ["execute", "check_scheduler_address"]

_ADDRESS = re.compile(r"(tcp|tls|inproc|ucx|ws|wss)://[^\s/:]+(:\d{1,5})?/?|[A-Za-z0-9_.-]+:\d{1,5}",
                      re.ASCII)
_DASK_LOGGERS = ("distributed", "distributed.nanny", "distributed.worker", "distributed.scheduler",
                 "distributed.client", "distributed.core", "distributed.comm",
                 "distributed.deploy", "distributed.process", "tornado", "asyncio")


def check_scheduler_address(address: str) -> str:
    """Validate a Dask scheduler address (``tcp://host:port`` or ``host:port``).

    >>> check_scheduler_address("tcp://10.0.0.5:8786")
    'tcp://10.0.0.5:8786'
    >>> check_scheduler_address("tcp//oops")
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a scheduler address like tcp://HOST:PORT, received 'tcp//oops'
    """
    a = str(address).strip()
    if not _ADDRESS.fullmatch(a):
        raise InputError(f"expected a scheduler address like tcp://HOST:PORT, received {address!r}")
    m = re.search(r":(\d+)/?$", a, re.ASCII)
    if m and not 0 < int(m.group(1)) < 65536:
        raise InputError(f"expected a port in 1..65535 in the scheduler address, received {address!r}")
    return a


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored in this block (main thread only; a no-op elsewhere)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _hold_sigint() -> Callable[[], None]:
    """Hold SIGINT while a local cluster starts; return the function that lets it through.

    The worker processes must not see a terminal's Ctrl-C (it reaches the whole process
    group): SIGINT is blocked in this thread, so every thread started meanwhile (Dask's
    event loop, which spawns the workers) and every worker inherits it blocked.  This
    process must not lose one, nor be interrupted half-way through the start: until the
    returned function runs, a SIGINT (which any native thread may receive) is only
    recorded; that function unblocks it, restores the handler and raises
    :class:`KeyboardInterrupt` if one arrived.  A no-op outside the main thread.
    """
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    seen: list[int] = []
    old = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    done: list[bool] = []

    def release() -> None:
        if done:
            return
        done.append(True)
        if signal.SIGINT not in mask:  # a SIGINT pending on this thread is recorded now
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        signal.signal(signal.SIGINT, old)
        if seen:
            raise KeyboardInterrupt

    return release


@contextlib.contextmanager
def _quiet_dask() -> Iterator[None]:
    """Dask's own shutdown chatter (nanny/worker warnings) silenced in this block."""
    saved = [(lg, lg.level) for lg in (logging.getLogger(n) for n in _DASK_LOGGERS)]
    for lg, _ in saved:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, lvl in saved:
            lg.setLevel(lvl)


@contextlib.contextmanager
def _client(scheduler: str | None, n_workers: int, timeout: float) -> Iterator[Any]:
    from distributed import Client, LocalCluster

    if scheduler:
        addr = check_scheduler_address(scheduler)
        try:
            with _quiet_dask():
                client = Client(addr, timeout=f"{timeout}s")
        except Exception as e:  # noqa: BLE001 - any connection failure is the same finding
            raise ClusterError(
                f"could not reach the Dask scheduler at {addr!r} within {timeout:g} s "
                f"({type(e).__name__}); check that it runs and the address and port are right, "
                "or raise --timeout, or run with a local cluster (omit --scheduler)"
            ) from None
        try:
            try:
                client.wait_for_workers(1, timeout=timeout)
            except Exception:  # noqa: BLE001
                raise ClusterError(
                    f"the Dask scheduler at {addr!r} has no workers after {timeout:g} s; start "
                    "workers (dask worker ADDRESS) or raise --timeout"
                ) from None
            yield client
        finally:
            with _sigint_ignored(), _quiet_dask(), contextlib.suppress(Exception):
                client.close(timeout=5)
        return
    held = _hold_sigint()
    from formsync_design.progress import mark_ready

    mark_ready("sweep: local cluster starting")  # FORMSYNC_READY_FILE (a test's Ctrl-C waits for it)
    try:
        cluster = LocalCluster(
            n_workers=n_workers, threads_per_worker=1, processes=True, host="127.0.0.1",
            dashboard_address=None, silence_logs=logging.CRITICAL,
            # the scheduler's HTTP server (health routes) on a free port: its default, 8787,
            # is taken by any other cluster running, and Dask then warns on stderr
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
        )
    except Exception as e:  # noqa: BLE001 - not a finding about the campaign
        held()
        raise ClusterError(
            f"could not start a local Dask cluster of {n_workers} worker processes "
            f"({type(e).__name__}: {e}); try fewer --workers or --workers 0 (serial)"
        ) from None
    grace = 5.0
    try:
        try:
            held()  # a Ctrl-C that arrived while the cluster started is raised here
            client = Client(cluster, timeout=f"{max(timeout, 30)}s")
        except KeyboardInterrupt:
            grace = _kill_workers(cluster)
            raise
        try:
            yield client
        except KeyboardInterrupt:  # their rows are lost anyway: stop the workers now
            grace = _kill_workers(cluster)
            raise
        finally:
            with _sigint_ignored(), _quiet_dask(), contextlib.suppress(Exception):
                client.close(timeout=grace)
    finally:
        with _sigint_ignored(), _quiet_dask(), contextlib.suppress(Exception):
            cluster.close(timeout=grace)


def _kill_workers(cluster: Any) -> float:
    """SIGKILL the worker processes of a local cluster (after Ctrl-C: a task in flight is
    lost either way, and a graceful close waits for it); return the grace in seconds left
    for closing the cluster."""
    with contextlib.suppress(Exception):
        for nanny in list(cluster.workers.values()):
            pid = nanny.pid
            if pid:
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)
    return 1.0


def _task_failure(name: str, exc: BaseException) -> FormsyncError:
    """The error reported for a task that raised (or whose worker died)."""
    kind = type(exc).__name__
    if kind == "KilledWorker":
        return ClusterError(
            f"a Dask worker died while computing task {name!r} (out of memory or killed); "
            "finished rows are kept: rerun with --resume, with fewer --workers or more memory"
        )
    if kind in ("CommClosedError", "StreamClosedError", "FutureCancelledError", "CancelledError"):
        return ClusterError(
            f"lost the connection to the Dask cluster while computing task {name!r} ({kind}); "
            "finished rows are kept: rerun with --resume"
        )
    msg = (f"task {name!r} failed: {kind}: {' '.join(str(exc).split())} "
           "(finished rows kept: rerun with --resume)")
    if isinstance(exc, InputError):
        return InputError(msg)
    if isinstance(exc, FormsyncError):
        try:
            return type(exc)(msg)
        except Exception:  # noqa: BLE001 - an error class with another signature
            return FormsyncError(msg)
    return FormsyncError(msg)


def execute(
    tasks: Sequence[dict[str, Any]],
    on_row: Callable[[dict[str, str]], None],
    *,
    scheduler: str | None,
    n_workers: int,
    timeout: float,
    task_fn: Callable[[dict[str, Any]], dict[str, str]],
    on_start: Callable[[], None] | None = None,
) -> None:
    """Run ``task_fn`` on every task, calling ``on_row`` (in this process) as rows arrive.

    Serial when ``n_workers == 0`` and no ``scheduler``; otherwise on Dask.
    ``on_start`` is called once the executor is ready, before the first task runs
    (the sweep creates its journal there).
    Raises :class:`ClusterError` for a cluster failure, the task's error class
    (module docstring) for a failed task, :class:`KeyboardInterrupt` on Ctrl-C
    after the cluster is closed.

    >>> rows = []
    >>> execute([{"task": "a"}], rows.append, scheduler=None, n_workers=0, timeout=1,
    ...         task_fn=lambda t: {"task": t["task"] + "!"})
    >>> rows
    [{'task': 'a!'}]
    """
    if not tasks:
        return
    if n_workers == 0 and not scheduler:
        if on_start is not None:
            on_start()
        for t in tasks:
            try:
                row = task_fn(t)
            except (KeyboardInterrupt, SystemExit):
                raise
            except Exception as e:  # noqa: BLE001 - reported with the task, finished rows kept
                raise _task_failure(t["task"], e) from e
            on_row(row)
        return
    from distributed import as_completed

    with _client(scheduler, n_workers, timeout) as client:
        if on_start is not None:
            on_start()
        salt = hashlib.sha256(os.urandom(16)).hexdigest()[:12]
        futs = client.map(task_fn, list(tasks), key=[f"sweep-{salt}-{k}" for k in range(len(tasks))],
                          pure=False)
        names = {f.key: t["task"] for f, t in zip(futs, tasks)}
        try:
            for fut in as_completed(futs):
                if fut.status == "error":
                    raise _task_failure(names[fut.key], fut.exception())
                if fut.status == "cancelled":
                    raise _task_failure(names[fut.key], ClusterError("cancelled"))
                on_row(fut.result())
        except OSError as e:  # a lost connection surfaces as CommClosedError (an OSError)
            raise _task_failure("?", e) from None
        finally:
            with _sigint_ignored(), _quiet_dask(), contextlib.suppress(Exception):
                client.cancel(futs)
