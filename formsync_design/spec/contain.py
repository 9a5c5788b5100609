"""Design code that misbehaves is contained: a time limit, and no escape but an error.

A design file is Python (:mod:`formsync_design.spec.loader`).  Loading it, and the first
evaluation of its laws (the validation calls every function on the symbolic views) and of
the metrics it registers (:mod:`formsync_design.verify.metrics`), run inside
:func:`contained`:

* a **time limit**: ``FORMSYNC_DESIGN_TIMEOUT`` seconds (default :data:`DEFAULT_TIMEOUT`;
  ``0`` means no limit).  Design code still running at the limit is stopped and reported
  as a one-line :class:`~formsync_design.errors.DerivationError` (exit 2) naming the file
  and the limit.  The limit is a ``SIGALRM`` timer, so it applies on the main thread only;
  design code run on another thread (a Dask worker's task thread) has no limit there, but
  every command loads and validates the design on its main thread first, so a design that
  hangs on loading or on its first evaluation is stopped before any worker starts.  The
  engine's own work a metric asks for (a simulation, a certificate: :func:`paused`) does
  not count towards its limit.
* **no escape**: ``SystemExit`` (``sys.exit()``), ``GeneratorExit`` and any other
  exception that is not an :class:`Exception` raised by design code is reported as a
  one-line :class:`~formsync_design.errors.DerivationError` naming the file (exit 2), not
  passed on to end the program.  ``os._exit`` called by design code on the main thread
  inside the block is reported the same way.  ``KeyboardInterrupt`` (Ctrl-C) still
  interrupts (exit 130).

This is containment of code that misbehaves, not a sandbox: design code runs with the
user's rights, which is why a data file cannot make it run without the user's word
(:mod:`formsync_design.spec.trust`).

>>> with contained("demo.py", "loading"):
...     raise SystemExit(0)
Traceback (most recent call last):
...
formsync_design.errors.DerivationError: demo.py: expected the design code to return (loading), received SystemExit(0)
>>> import os
>>> os.environ["FORMSYNC_DESIGN_TIMEOUT"] = "0.2"
>>> with contained("spin.py", "loading"):
...     while True:
...         pass
Traceback (most recent call last):
...
formsync_design.errors.DerivationError: spin.py: expected the design code to finish within 0.2 s (loading; FORMSYNC_DESIGN_TIMEOUT), received code still running at the limit
>>> del os.environ["FORMSYNC_DESIGN_TIMEOUT"]
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import threading
import time
from collections.abc import Iterator
from typing import Any

from formsync_design.errors import DerivationError, InputError

__all__ = ["DEFAULT_TIMEOUT", "TIMEOUT_ENV", "design_timeout", "contained", "paused"]

#: The environment variable that sets the limit in seconds (``0``: no limit).
TIMEOUT_ENV = "FORMSYNC_DESIGN_TIMEOUT"

#: The limit when :data:`TIMEOUT_ENV` is not set, in seconds.
DEFAULT_TIMEOUT = 60.0

#: After the limit, the timer fires again at this interval until the block ends (design code
#: that catches the first stop is stopped again).
_REPEAT = 0.25


class _Overtime(BaseException):
    """Raised into design code at the limit (a BaseException: ``except Exception`` in the
    design does not catch it)."""


class _Exited(BaseException):
    """Raised by ``os._exit`` called from design code inside :func:`contained`."""

    def __init__(self, status: Any) -> None:
        super().__init__(status)
        self.status = status


def design_timeout() -> float:
    """The limit in seconds (:data:`TIMEOUT_ENV`, default :data:`DEFAULT_TIMEOUT`); ``inf``
    when it is ``0``.

    >>> design_timeout()
    60.0
    """
    raw = os.environ.get(TIMEOUT_ENV)
    if raw is None or not raw.strip():
        return DEFAULT_TIMEOUT
    try:
        t = float(raw.strip()) if raw.strip().isascii() else math.nan
    except ValueError:
        t = math.nan
    if not (t >= 0 and math.isfinite(t)):
        raise InputError(f"expected {TIMEOUT_ENV} a number of seconds >= 0 (0: no limit), "
                         f"received {raw[:30]!r}")
    return math.inf if t == 0 else t


class _State:
    depth = 0
    deadline = math.inf  # time.monotonic() of the active limit
    paused_left: float | None = None


_STATE = _State()


def _on_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _arm(seconds: float) -> None:
    signal.setitimer(signal.ITIMER_REAL, max(seconds, 1e-3), _REPEAT)


def _disarm() -> None:
    signal.setitimer(signal.ITIMER_REAL, 0)


def _overtime(signum: int, frame: Any) -> None:
    raise _Overtime()


def _exit_from_design(status: Any = 0) -> None:
    raise _Exited(status)


def _shown(e: BaseException) -> str:
    if isinstance(e, _Exited):
        return f"os._exit({e.status!r})"
    args = ", ".join(repr(a) for a in e.args)[:60]
    return f"{type(e).__name__}({args})"


@contextlib.contextmanager
def contained(where: str, what: str) -> Iterator[None]:
    """Run design code of the file ``where`` (doing ``what``) under the module's rules.

    Nested blocks share the outermost block's limit.  :class:`Exception` raised inside is
    passed on unchanged (the caller reports it in its own words).
    """
    if _STATE.depth > 0 or not _on_main_thread():
        _STATE.depth += 1
        try:
            yield
        finally:
            _STATE.depth -= 1
        return
    limit = design_timeout()
    old_handler = signal.signal(signal.SIGALRM, _overtime) if math.isfinite(limit) else None
    old_exit = os._exit
    os._exit = _exit_from_design  # type: ignore[assignment]
    _STATE.depth, _STATE.deadline = 1, time.monotonic() + limit
    try:
        if math.isfinite(limit):
            _arm(limit)
        yield
    except _Overtime:
        _disarm()
        raise DerivationError(f"{where}: expected the design code to finish within {limit:g} s "
                              f"({what}; {TIMEOUT_ENV}), received code still running at the "
                              "limit") from None
    except (KeyboardInterrupt, Exception):
        raise
    except BaseException as e:  # SystemExit, GeneratorExit, os._exit, ...: never an exit
        raise DerivationError(f"{where}: expected the design code to return ({what}), "
                              f"received {_shown(e)}") from None
    finally:
        if math.isfinite(limit):
            _disarm()
            signal.signal(signal.SIGALRM, old_handler if old_handler is not None else signal.SIG_DFL)
        os._exit = old_exit
        _STATE.depth, _STATE.deadline = 0, math.inf


@contextlib.contextmanager
def paused() -> Iterator[None]:
    """The engine's own work inside a :func:`contained` block (a simulation a metric asks
    for): the limit's clock stops for the block, and a design loaded inside it has its own.

    >>> with paused():
    ...     1 + 1
    2
    """
    if _STATE.depth == 0 or not _on_main_thread():
        yield
        return
    left = _STATE.deadline - time.monotonic()
    finite = math.isfinite(_STATE.deadline)
    if finite:
        _disarm()
    depth, _STATE.depth = _STATE.depth, 0
    try:
        yield
    finally:
        _STATE.depth = depth
        _STATE.deadline = time.monotonic() + left
        if finite:
            _arm(left)
