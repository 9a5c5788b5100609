"""Progress of long work: a bar on a terminal's stderr, nothing anywhere else.

Every command that can take more than a few seconds (``verify``, ``region``,
``montecarlo``, ``sweep``, a cold build of a simulation kernel) reports through
this one module.  The bar is drawn by ``tqdm`` on stderr only when stderr is a
terminal and the caller enables it (``--format json`` and ``--no-progress``
disable it), so redirected output, pipes, CI logs and JSON stay clean; set
``FORMSYNC_NO_PROGRESS=1`` to silence it everywhere.

* :class:`Progress` counts ``total`` steps (runs, cells, tasks);
* :func:`activity` shows work of unknown length (a compiler call, a stage of a
  verification) with its elapsed time;
* :func:`progress_enabled` is the one rule of when anything is drawn.

Library functions take a plain ``progress`` callable and never draw; the
command line and the kernel builder create the bars.

* :func:`mark_ready` is a state a watcher can wait for (tests, scripts): when the
  environment variable ``FORMSYNC_READY_FILE`` names a file, the long work of a command
  records there that it is running (the first finished step of every :class:`Progress`,
  a sweep's local cluster as it starts), so a test interrupts a command once its work
  runs, not after a guessed number of seconds.  Unset (the default), nothing is written.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager, redirect_stdout
from typing import IO, Any

__all__ = ["Progress", "activity", "progress_enabled", "mark_ready", "READY_ENV"]

#: The environment variable naming the file :func:`mark_ready` writes (unset: nothing written).
READY_ENV = "FORMSYNC_READY_FILE"
_READY: list[str] = []


def progress_enabled(enabled: bool = True, stream: IO[str] | None = None) -> bool:
    """Whether a progress bar is drawn: ``enabled``, ``stream`` (default stderr) a terminal,
    and ``FORMSYNC_NO_PROGRESS`` unset.

    >>> import io
    >>> progress_enabled(True, io.StringIO()), progress_enabled(False)
    (False, False)
    """
    if not enabled or os.environ.get("FORMSYNC_NO_PROGRESS"):
        return False
    s = sys.stderr if stream is None else stream
    try:
        return bool(s.isatty())
    except (AttributeError, ValueError, OSError):  # closed or not a file
        return False


def mark_ready(what: str) -> None:
    """Record that the long work ``what`` is running, for a watcher (module docstring).

    When ``FORMSYNC_READY_FILE`` names a file, it is rewritten atomically with one line per
    distinct ``what`` marked so far in this process, in order (a watcher reads complete
    lines only); a no-op when the variable is unset or empty.  A failed write is ignored:
    the marker is an observable for tests, never a reason for the command to fail.

    >>> import os, tempfile
    >>> f = os.path.join(tempfile.mkdtemp(), "ready")
    >>> os.environ[READY_ENV] = f
    >>> mark_ready("montecarlo"); mark_ready("montecarlo"); mark_ready("sweep tasks")
    >>> del os.environ[READY_ENV]
    >>> open(f).read().splitlines()[-2:]
    ['montecarlo', 'sweep tasks']
    """
    path = os.environ.get(READY_ENV)
    if not path or what in _READY:
        return
    _READY.append(what)
    from formsync_design.outdir import write_text

    try:
        write_text(path, "".join(f"{w}\n" for w in _READY))
    except OSError:
        pass


class Progress:
    """A progress bar of ``total`` steps on stderr (silent unless :func:`progress_enabled`).

    Parameters
    ----------
    total : int or None
        Number of steps (None: unknown, the bar counts up).
    label : str
        Shown before the bar.
    enabled : bool
        The caller's switch (False for ``--format json`` or ``--no-progress``).
    unit : str
        What a step is (``run``, ``cell``, ``task``).
    tick : bool
        Redraw the bar every half second, so its elapsed time moves while one step takes
        long (a sweep task on 2000 spacecraft); :func:`activity` always ticks.

    Examples
    --------
    Not a terminal (as under pytest): nothing is drawn, the count is kept.

    >>> p = Progress(3, "montecarlo", unit="run")
    >>> p.update(2); p.update(); p.done, p.enabled
    (3, False)
    >>> p.close()
    """

    def __init__(self, total: int | None, label: str, enabled: bool = True, *,
                 unit: str = "it", bar_format: str | None = None, tick: bool = False) -> None:
        self.total = None if total is None else max(int(total), 0)
        self.label = label
        self.done = 0
        self._bar: Any = None
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None
        if progress_enabled(enabled):
            from tqdm import tqdm

            self._bar = tqdm(total=self.total, desc=label, unit=unit, file=sys.stderr,
                             leave=False, dynamic_ncols=True, mininterval=0.2,
                             bar_format=bar_format)
            if tick:
                self._ticker = threading.Thread(target=self._tick, name="formsync-progress",
                                                daemon=True)
                self._ticker.start()

    def _tick(self) -> None:
        while not self._stop.wait(0.5):
            bar = self._bar
            if bar is not None:
                bar.refresh()

    @property
    def enabled(self) -> bool:
        """Whether the bar is drawn."""
        return self._bar is not None

    def update(self, k: int = 1) -> None:
        """Count ``k`` more finished steps (the bar is cleared after the last one); the
        first one marks the work ``label`` as running (:func:`mark_ready`)."""
        if self.done == 0 and k > 0:
            mark_ready(self.label)
        self.done += k
        if self._bar is not None:
            self._bar.update(k)
            if self.total is not None and self.done >= self.total:
                self.close()

    def set_total(self, total: int) -> None:
        """The number of steps, once known (a sweep learns it from its journal)."""
        self.total = int(total)
        if self._bar is not None:
            self._bar.total = self.total
            self._bar.refresh()

    def note(self, text: str) -> None:
        """What is being done now, after the bar."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=True)

    def close(self) -> None:
        """Clear the bar (the command's output follows on a clean line)."""
        self._stop.set()
        if self._ticker is not None and self._ticker is not threading.current_thread():
            self._ticker.join()
            self._ticker = None
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _AboveBar:
    """stdout while a bar is drawn on the same terminal: the bar is cleared for each write
    and drawn again below it."""

    def __init__(self, real: IO[str], progress: Progress) -> None:
        self._real = real
        self._progress = progress

    def write(self, text: str) -> int:
        bar = self._progress._bar
        if bar is None:
            return self._real.write(text)
        with bar.get_lock():
            bar.clear(nolock=True)
            n = self._real.write(text)
            self._real.flush()
            bar.refresh(nolock=True)
        return n

    def __getattr__(self, name: str) -> Any:
        return getattr(self._real, name)


@contextmanager
def activity(label: str, enabled: bool = True) -> Iterator[Progress]:
    """Work of unknown length under ``label``, its elapsed time kept moving on a terminal.

    >>> with activity("compiling the simulation kernel") as a:
    ...     a.note("gcc")
    >>> a.enabled
    False
    """
    p = Progress(None, label, enabled, unit="s", bar_format="{desc}: {elapsed}{postfix}", tick=True)
    try:
        if p.enabled:  # what the work prints meanwhile goes above the bar, not through it
            with redirect_stdout(_AboveBar(sys.stdout, p)):
                yield p
        else:
            yield p
    finally:
        p.close()
