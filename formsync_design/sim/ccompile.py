"""The C compiler and the on-disk cache of compiled simulation kernels.

Every compiled object lives in :func:`cache_dir` ``/kernels`` (never inside the
repository), named ``<name>_<digest>.so`` where the digest covers the C source, the
caller's key material (the specification's content key), the flags, the CasADi
version and the host (``-march=native`` makes an object machine-specific).  Objects
are written atomically, so concurrent processes never load half a file.

Compiler: ``$FORMSYNC_CC``, else ``gcc``, else ``cc``; none found is reported by
:func:`c_compiler` returning None (callers fall back to CasADi's virtual machine with
a warning, :func:`warn_no_compiler`); ``FORMSYNC_NO_COMPILE=1`` selects the virtual
machine on purpose (:func:`compile_enabled`).  A compiler that exists but fails raises
:class:`~formsync_design.errors.CompilerError` (exit status 3).

A kernel is built in a private folder ``kernels/.build-<pid>-*`` and moved into the
cache with one ``os.replace`` after an fsync, so the cache holds complete objects only.
A write that fails for want of room while building (the C source, or the compiler's
own output: disk full, the file-size limit) raises
:class:`~formsync_design.errors.WriteError` (exit status 3) naming the kernel and the
errno, not the compiler; the build folder is removed, and build folders left by a
killed process are removed by the next build.  CasADi's code generator does not report a
failed write (it leaves a file cut short): :func:`generated_source` checks that the file
it wrote ends as CasADi ends one, and reports a short one as that write's failure.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import shutil
import signal
import subprocess
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import casadi as ca

from formsync_design.errors import CompilerError, WriteError
from formsync_design.outdir import ROOM_ERRNOS, write_error
from formsync_design.progress import activity

__all__ = [
    "CFLAGS",
    "code_digest",
    "cache_dir",
    "compile_enabled",
    "c_compiler",
    "host_tag",
    "build_shared",
    "generated_source",
    "warn_no_compiler",
]

#: gcc flags of the kernels.  ``-march=native`` (27% faster than plain ``-O2`` here) makes
#: the objects machine-specific, so the cache key includes the host and its CPU.
CFLAGS = ("-O3", "-march=native", "-fPIC", "-shared")


def cache_dir() -> Path:
    """User cache directory of compiled kernels (never inside the repository).

    ``$FORMSYNC_CACHE_DIR``, else ``$XDG_CACHE_HOME/formsync-design``, else
    ``~/.cache/formsync-design``.

    >>> cache_dir().name != ""
    True
    """
    env = os.environ.get("FORMSYNC_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "formsync-design"


def code_digest(paths: tuple[str, ...]) -> str:
    """SHA-256 of the package's code at ``paths`` (modules, or folders whose ``.py`` files
    count; relative to the package) and of the versions of formsync-design, SymPy and CasADi:
    part of a compiled kernel's cache key, so an edited generator never loads an object
    built by the old one.

    >>> len(code_digest(("sim/ccompile.py",)))
    64
    """
    from importlib.metadata import PackageNotFoundError, version

    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for dist in ("formsync-design", "sympy", "casadi"):
        try:
            h.update(f"{dist}={version(dist)}\n".encode())
        except PackageNotFoundError:
            h.update(f"{dist}=?\n".encode())
    for rel in paths:
        p = root / rel
        for f in sorted(p.rglob("*.py")) if p.is_dir() else [p]:
            h.update(f.relative_to(root).as_posix().encode() + b"\0")
            h.update(f.read_bytes())
    return h.hexdigest()


def compile_enabled() -> bool:
    """False when ``FORMSYNC_NO_COMPILE`` is set to a true value (``1``, ``yes``, ``true``).

    >>> isinstance(compile_enabled(), bool)
    True
    """
    return os.environ.get("FORMSYNC_NO_COMPILE", "").strip().lower() not in ("1", "yes", "true", "on")


def host_tag() -> str:
    """Host name, machine and CPU model (part of every cache key).

    >>> "|" in host_tag()
    True
    """
    import platform

    cpu = ""
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next((ln for ln in fh if ln.startswith("model name")), "")
    except OSError:  # pragma: no cover - not Linux
        pass
    return f"{platform.node()}|{platform.machine()}|{cpu.strip()}"


def c_compiler() -> str | None:
    """``$FORMSYNC_CC``, else ``gcc``/``cc`` on the path, else None."""
    return os.environ.get("FORMSYNC_CC") or shutil.which("gcc") or shutil.which("cc")


def warn_no_compiler(stacklevel: int = 3) -> None:
    """The one warning for a missing C compiler (the virtual machine is used instead)."""
    warnings.warn(
        "no C compiler (gcc/cc) found: simulating in the CasADi virtual machine, which is "
        "slower; install gcc, or set FORMSYNC_NO_COMPILE=1 to silence this",
        RuntimeWarning,
        stacklevel=stacklevel,
    )


#: What a compiler prints when it could not write its output for want of room (in the C
#: locale it runs in): the errno texts and the signal of the file-size limit.
_ROOM_TEXTS = {
    errno.ENOSPC: (os.strerror(errno.ENOSPC),),
    errno.EDQUOT: (os.strerror(errno.EDQUOT),),
    errno.EFBIG: (os.strerror(errno.EFBIG), "File size limit exceeded", "signal 25"),
}


def _room_errno(said: str, returncode: int) -> int | None:
    """The errno of a compiler run that failed for want of room, else None.

    >>> _room_errno("ld: final link failed: No space left on device", 1) == errno.ENOSPC
    True
    >>> _room_errno("error: expected ';'", 1) is None
    True
    """
    if returncode == -signal.SIGXFSZ:
        return errno.EFBIG
    return next((code for code, texts in _ROOM_TEXTS.items() if any(t in said for t in texts)), None)


#: The last lines of every C file CasADi's code generator writes.
_CASADI_END = '} /* extern "C" */\n#endif'


def _short_write_errno(path: Path) -> int:
    """Why a file was cut short: the file-size limit (EFBIG), a full disk (ENOSPC), else EIO."""
    import resource

    soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if soft != resource.RLIM_INFINITY and path.stat().st_size >= soft:
        return errno.EFBIG
    fs = os.statvfs(path.parent)
    return errno.ENOSPC if fs.f_bavail * fs.f_frsize < (1 << 20) else errno.EIO


def generated_source(cg: ca.CodeGenerator, filename: str, what: str) -> str:
    """The C source CasADi's code generator ``cg`` writes as ``filename`` (in a private
    temporary folder, read back), checked whole: a file cut short (CasADi does not report a
    failed write) raises the :class:`~formsync_design.errors.WriteError` of that file.

    >>> x = ca.SX.sym("x")
    >>> cg = ca.CodeGenerator("f.c", {"with_header": False})
    >>> cg.add(ca.Function("f", [x], [2 * x]))
    >>> "casadi_real" in generated_source(cg, "f.c", "a test function")
    True
    """
    with tempfile.TemporaryDirectory() as td:
        p = Path(td, filename)
        cg.generate(td + os.sep)
        text = p.read_text() if p.is_file() else ""
        if not text.rstrip().endswith(_CASADI_END):
            code = _short_write_errno(p) if p.is_file() else errno.EIO
            raise write_error(p, OSError(code, os.strerror(code)), f"the C source of {what}")
    return text


def _remove_stale_builds(d: Path) -> None:
    """Remove the build folders ``.build-<pid>-*`` of processes that no longer run."""
    for b in d.glob(".build-*-*"):
        try:
            pid = int(b.name.split("-")[1])
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(b, ignore_errors=True)
        except (ValueError, IndexError, OSError):  # not ours, or alive under another user
            continue


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def build_shared(name: str, src: str | Callable[[], str], key: str, cc: str,
                 flags: tuple[str, ...] = CFLAGS, libs: tuple[str, ...] = ("-lm",)) -> Path:
    """Compile ``src`` to ``cache_dir()/kernels/<name>_<digest>.so`` unless it is cached.

    ``src`` is the C source, or a function returning it.  With the source itself the
    digest covers it and ``key`` (extra material: the specification's content key).
    With a function the digest covers ``key`` alone, which must then identify the
    source completely (the specification's content key, the options and the digest of
    the generator's code, as :func:`~formsync_design.sim.native.get_native` passes), and
    the function is called only when the object is not cached: a warm run skips
    generating the source.  Flags, libraries, the CasADi version and the host are
    always part of the digest.
    Raises :class:`~formsync_design.errors.CompilerError` when the compiler fails or
    the cache folder is not writable, :class:`~formsync_design.errors.WriteError` when
    a write of the build fails for want of room (module docstring).
    """
    tail = [key, " ".join(flags), " ".join(libs), str(getattr(ca, "__version__", "")), host_tag()]
    material = "\n".join(["keyed by the generator", *tail] if callable(src) else [src, *tail])
    digest = hashlib.sha256(material.encode()).hexdigest()[:20]
    d = cache_dir() / "kernels"
    so = d / f"{name}_{digest}.so"
    if so.is_file():
        return so
    if callable(src):
        src = src()
    what = f"the simulation kernel {name} (C source and object) into the cache"
    try:
        d.mkdir(parents=True, exist_ok=True)
        _remove_stale_builds(d)
        with tempfile.TemporaryDirectory(dir=d, prefix=f".build-{os.getpid()}-") as td:
            c = Path(td, f"{name}.c")
            c.write_text(src)
            tmp_so = Path(td, so.name)
            env = {**os.environ, "LC_ALL": "C"}  # messages in English: a full disk is recognised
            with activity(f"compiling the simulation kernel {name} (once per design)"):
                r = subprocess.run([cc, *flags, str(c), "-o", str(tmp_so), *libs],
                                   capture_output=True, text=True, env=env)
            said = " ".join((r.stderr or r.stdout or "").split())
            if r.returncode != 0:
                code = _room_errno(said, r.returncode)
                if code is not None:  # the compiler could not write its output: not its fault
                    raise write_error(so, OSError(code, os.strerror(code)), what)
                raise CompilerError(
                    f"compiling the simulation kernel {name} with {cc} failed (exit "
                    f"{r.returncode}: {said[-300:] or 'no output'}); fix or install gcc, or set "
                    "FORMSYNC_NO_COMPILE=1 to simulate in the CasADi virtual machine"
                )
            _fsync(tmp_so)
            os.replace(tmp_so, so)  # atomic: concurrent processes never see half a file
            with contextlib.suppress(OSError):
                _fsync(d)
    except WriteError:
        raise
    except OSError as e:
        if e.errno in ROOM_ERRNOS:
            raise write_error(so, e, what) from None
        raise CompilerError(
            f"building the simulation kernel {name} in {d} failed ({e.strerror or e}); set "
            "FORMSYNC_CACHE_DIR to a writable folder, or FORMSYNC_NO_COMPILE=1"
        ) from None
    return so
