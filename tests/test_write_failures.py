"""Writes that fail (issue 34, item 5): a full disk or the file-size limit is exit 3 naming the
write (the file and the errno), never blamed on the compiler, and leaves no partial file: no
half-built kernel in the cache, no temporary beside a result, no torn journal row."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from formsync_design import outdir
from formsync_design.errors import WriteError
from formsync_design.sim import ccompile

_LIMITED = textwrap.dedent("""
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
    limit = int(sys.argv[1])
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    from formsync_design.cli import main
    sys.exit(main(sys.argv[2:]))
""")


def _kernel_entries(cache: Path) -> list[str]:
    k = cache / "kernels"
    return sorted(p.name for p in k.iterdir()) if k.is_dir() else []


@pytest.mark.parametrize("limit, where", [
    (20_000, "the C source of the simulation kernel fsd_kernel "),  # CasADi's generated file
    (200_000, "the simulation kernel fsd_kernel (C source and object) into the cache "),  # gcc's
])
def test_a_kernel_build_under_a_file_size_limit_is_exit_3_naming_the_write(
        tmp_path: Path, limit: int, where: str) -> None:
    """The whole-horizon kernel's generated C source is larger than 20 kB (CasADi's write is cut
    short) and its assembly larger than 200 kB (the compiler's write fails): both are exit 3,
    one line naming the file and EFBIG, never the compiler; the cache holds no entry after."""
    cache = tmp_path / "cache"
    env = {**os.environ, "FORMSYNC_CACHE_DIR": str(cache)}
    env.pop("FORMSYNC_NO_COMPILE", None)
    r = subprocess.run([sys.executable, "-c", _LIMITED, str(limit), "simulate", "--tf", "1",
                        "--step", "0.1", "--output-step", "0.5", "--figures", "none"],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    err = r.stderr.strip()
    assert r.returncode == 3, (where, err)
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "WriteError" in err and "EFBIG" in err and "File too large" in err, err
    assert f"writing {where}" in err, err
    if limit == 200_000:
        assert f"{cache / 'kernels'}/fsd_kernel_" in err and ".so failed" in err, err
    else:
        assert "fsk.c failed" in err, err
    assert f"ulimit -f) is {limit} bytes" in err, err
    assert "CompilerError" not in err and "gcc failed" not in err and "internal compiler" not in err
    assert _kernel_entries(cache) == [], "a half-built kernel was left in the cache"


def test_a_generated_c_source_cut_short_is_a_write_error_not_the_compilers(tmp_path: Path) -> None:
    """CasADi's code generator does not report a failed write: under a file-size limit it left
    the agent kernel's C source cut short and gcc was blamed ("expected expression at end of
    input").  Now the short file is the write's failure, named, EFBIG; the cache holds nothing.
    Under a 40 kB limit the compiled driver's small objects (about 16 kB) are written and the
    C source of ma_so3's law (about 70 kB) is cut short; the cache keeps the complete objects
    only."""
    import re

    cache = tmp_path / "cache"
    env = {**os.environ, "FORMSYNC_CACHE_DIR": str(cache)}
    env.pop("FORMSYNC_NO_COMPILE", None)
    r = subprocess.run([sys.executable, "-c", _LIMITED, "40000", "simulate", "--design", "ma_so3",
                        "--tf", "1", "--figures", "none"],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    err = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 3, r.stderr
    assert re.search(r"WriteError: writing the C source of the agent kernel functions "
                     r"fsa_law_\d", err), err
    assert re.search(r"fsa_law_\d\.c failed: File too large \(EFBIG\)", err), err
    assert "CompilerError" not in r.stderr and "gcc" not in r.stderr
    # the objects written before (complete) stay; nothing of the failed law, no build folder
    left = _kernel_entries(cache)
    assert left and not [e for e in left if e.startswith(("fsa_law", ".build"))], left


def test_generated_source_checks_the_file_casadi_wrote(monkeypatch: pytest.MonkeyPatch) -> None:
    import casadi as ca

    x = ca.SX.sym("x")
    cg = ca.CodeGenerator("f.c", {"with_header": False})
    cg.add(ca.Function("f", [x], [2 * x]))
    whole = ccompile.generated_source(cg, "f.c", "f")
    assert whole.rstrip().endswith('} /* extern "C" */\n#endif')

    class Short:  # writes the file as a full disk leaves it: cut short, no error
        def generate(self, prefix: str) -> None:
            Path(prefix, "f.c").write_text(whole[: len(whole) // 2])

    monkeypatch.setattr(ccompile.os, "statvfs", lambda p: os.statvfs_result((4096,) * 2 + (0,) * 8))
    with pytest.raises(WriteError, match=r"the C source of f .*f\.c failed: .*\(ENOSPC\)"):
        ccompile.generated_source(Short(), "f.c", "f")  # type: ignore[arg-type]


def test_a_compiler_that_reports_a_full_disk_is_a_write_error(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A compiler failing with "No space left on device" is the write's failure (ENOSPC), not a
    CompilerError; any other compiler failure still is one."""
    cc = tmp_path / "cc"
    cc.write_text("#!/bin/sh\necho 'ld: final link failed: No space left on device' >&2\nexit 1\n")
    cc.chmod(0o755)
    monkeypatch.setenv("FORMSYNC_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(WriteError, match=r"fsd_t_\w+\.so failed: No space left on device \(ENOSPC\)") as e:
        ccompile.build_shared("fsd_t", "int x;", "k", str(cc))
    assert e.value.errno == errno.ENOSPC
    assert _kernel_entries(tmp_path / "cache") == []
    bad = tmp_path / "bad"
    bad.write_text("#!/bin/sh\necho 'error: expected ;' >&2\nexit 1\n")
    bad.chmod(0o755)
    with pytest.raises(ccompile.CompilerError, match="expected ;"):
        ccompile.build_shared("fsd_t", "int x;", "k", str(bad))


def test_a_killed_build_leaves_nothing_the_next_build_keeps(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A build folder of a process that no longer runs is removed by the next build; one of a
    running process is left alone."""
    monkeypatch.setenv("FORMSYNC_CACHE_DIR", str(tmp_path))
    k = tmp_path / "kernels"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (k / f".build-{dead}-x").mkdir(parents=True)
    (k / f".build-{dead}-x" / "fsd_t.c").write_text("half")
    (k / f".build-{os.getpid()}-y").mkdir()
    cc = tmp_path / "cc"
    cc.write_text("#!/bin/sh\nwhile [ $# -gt 0 ]; do [ \"$1\" = -o ] && : > \"$2\"; shift; done\n")
    cc.chmod(0o755)
    so = ccompile.build_shared("fsd_t", "int x;", "k", str(cc))
    assert sorted(p.name for p in k.iterdir()) == sorted([f".build-{os.getpid()}-y", so.name])


def _no_room(*a: object, **k: object) -> None:
    raise OSError(errno.ENOSPC, "No space left on device")


class _FullDisk:
    """A file whose every write fails as on a full disk."""

    def __init__(self, path: object, mode: str = "r", *a: object, **k: object) -> None:
        self.fh = open(path, mode, *a, **k)  # noqa: SIM115 - closed in __exit__

    def write(self, data: bytes) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")

    def __getattr__(self, name: str) -> object:
        return getattr(self.fh, name)

    def __enter__(self) -> _FullDisk:
        return self

    def __exit__(self, *exc: object) -> None:
        self.fh.close()


def test_a_result_file_on_a_full_disk_is_exit_3_naming_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """``formsync region`` whose result write fails with ENOSPC: exit 3, one line naming
    region.json and ENOSPC; the folder keeps no temporary and no partial region.json."""
    from formsync_design.cli import main

    out = tmp_path / "r"
    monkeypatch.setattr(outdir, "open", _FullDisk, raising=False)
    rc = main(["region", "--graph", "ring:3", "--resolution", "2", "--no-progress", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 3, err
    assert [ln for ln in err if "error" in ln] == [
        f"formsync region: error: WriteError: writing {out / 'region.json'} failed: No space left "
        "on device (ENOSPC); free some disk space or write elsewhere"], err
    assert not out.exists() or [p.name for p in out.iterdir()] == [], "a partial result was left"


def test_atomic_write_failures_keep_the_old_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """ENOSPC at the write, EFBIG at the fsync: the old file stays, no temporary is left."""
    p = tmp_path / "summary.json"
    p.write_text("old")
    monkeypatch.setattr(outdir, "open", _FullDisk, raising=False)
    with pytest.raises(WriteError, match="ENOSPC") as e:
        outdir.write_text(p, "new")
    assert e.value.filename == str(p) and isinstance(e.value, OSError)
    monkeypatch.undo()

    def too_big(fd: int) -> None:
        raise OSError(errno.EFBIG, "File too large")

    monkeypatch.setattr(outdir.os, "fsync", too_big)
    with pytest.raises(WriteError, match=r"summary\.json failed: File too large \(EFBIG\)"):
        outdir.write_text(p, "new")
    assert [x.name for x in tmp_path.iterdir()] == ["summary.json"] and p.read_text() == "old"


def test_a_journal_row_that_cannot_be_written_is_cut_off(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A journal append failing half-way (a short write, then ENOSPC) leaves the complete rows
    only and raises the WriteError naming the journal."""
    from formsync_design.sweep.store import Journal, read_journal

    p = tmp_path / "journal.jsonl"
    j = Journal(p)
    j.append({"task": "a"})
    real = j.fh.write
    calls = []

    def short_then_full(data: memoryview) -> int:
        calls.append(len(data))
        if len(calls) == 1:
            return real(data[:5])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(j, "fh", type("F", (), {"write": staticmethod(short_then_full),
                                               "fileno": j.fh.fileno})())
    with pytest.raises(WriteError, match=r"the sweep journal .*journal\.jsonl failed: .*ENOSPC"):
        j.append({"task": "b"})
    assert len(calls) == 2
    assert p.read_text() == '{"task": "a"}\n'
    assert read_journal(p, repair=False, columns=["task"]) == {"a": {"task": "a"}}
    assert json.loads(p.read_text()) == {"task": "a"}
