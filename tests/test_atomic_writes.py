"""Every result file is written atomically, through formsync_design.outdir.

A static scan of ``formsync_design/`` (Python's ``ast``, so docstrings and
doctests are not code) lists every call that writes a file directly: ``open`` /
``os.open`` with a writing mode, ``Path.write_text`` / ``write_bytes``,
``savefig``, NumPy's ``save*`` / ``tofile``, ``to_csv``, ``json.dump`` /
``pickle.dump`` into a file, and ``os.replace`` / ``os.rename`` / ``shutil``
copies.  A write is atomic when its target is the temporary of
``with outdir.atomic_path(...) as tmp``; anything else must be in the explicit
allow-list below with its reason, or the test fails.  A stale allow-list entry
fails too.
"""

from __future__ import annotations

import ast
import json
import os
from pathlib import Path

import pytest

from formsync_design import outdir

PKG = Path(__file__).resolve().parents[1] / "formsync_design"

# (file relative to formsync_design/, enclosing function, the call's callee) -> why it is fine.
ALLOWED = {
    ("sim/ccompile.py", "build_shared", "c.write_text"):
        "the C source in a private TemporaryDirectory; the kernel is moved in with os.replace",
    ("sim/ccompile.py", "build_shared", "os.replace"):
        "the kernel cache's own atomic scheme (compile in a temporary folder, rename)",
    ("sweep/store.py", "Journal.__init__", "open"):
        "the append-only journal: one fsync'ed line per row, a torn tail is cut on reading",
    ("sweep/store.py", "read_journal", "open"):
        "truncating the journal's torn tail (a repair of the append-only file)",
    ("sweep/summary.py", "_save", "fig.savefig"):
        "into an in-memory buffer, written with outdir.write_bytes",
    ("cli/main.py", "_main", "os.open"):
        "opens os.devnull",
    ("cli/simulate.py", "run", "r.to_csv"):
        "SimResult.to_csv writes through outdir.atomic_path",
}

_WRITE_METHODS = {"write_text", "write_bytes", "savefig", "to_csv", "tofile"}
_NUMPY_SAVES = {"save", "savez", "savez_compressed", "savetxt"}
_MOVES = {("os", "replace"), ("os", "rename"), ("shutil", "copy"), ("shutil", "copy2"),
          ("shutil", "copyfile"), ("shutil", "move")}
_STREAMS = {"sys.stdout", "sys.stderr"}


def _mode(call: ast.Call, pos: int) -> str | None:
    """The constant mode string of an ``open`` call (``"r"`` when absent, None when not constant)."""
    node = call.args[pos] if len(call.args) > pos else next(
        (k.value for k in call.keywords if k.arg == "mode"), None)
    if node is None:
        return "r"
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def _target(call: ast.Call, receiver: bool) -> ast.expr | None:
    if receiver and isinstance(call.func, ast.Attribute):
        return call.func.value
    return call.args[0] if call.args else None


def _is_write(call: ast.Call) -> tuple[bool, ast.expr | None]:
    """(writes a file?, the node naming the file written) for one call."""
    f = call.func
    if isinstance(f, ast.Name) and f.id == "open":  # open(path, mode)
        mode = _mode(call, 1)
        return mode is None or any(c in mode for c in "wax+"), _target(call, False)
    if isinstance(f, ast.Attribute) and f.attr == "open" and ast.unparse(f.value) != "os":
        module = ast.unparse(f.value) in {"io", "gzip", "bz2", "lzma", "codecs", "builtins"}
        mode = _mode(call, 1 if module else 0)  # module.open(path, mode) or path.open(mode)
        return mode is None or any(c in mode for c in "wax+"), _target(call, not module)
    if isinstance(f, ast.Attribute):
        base = ast.unparse(f.value)
        if base == "os" and f.attr == "open":
            flags = ast.unparse(call.args[1]) if len(call.args) > 1 else ""
            return any(w in flags for w in ("O_WRONLY", "O_RDWR", "O_CREAT", "O_APPEND")), \
                call.args[0] if call.args else None
        if (base, f.attr) in _MOVES:
            return True, call.args[-1] if call.args else None
        if base in {"np", "numpy"} and f.attr in _NUMPY_SAVES:
            return True, _target(call, False)
        if base in {"json", "pickle"} and f.attr == "dump":
            dest = call.args[1] if len(call.args) > 1 else None
            return not (dest is not None and ast.unparse(dest) in _STREAMS), dest
        if f.attr in _WRITE_METHODS:
            if f.attr == "savefig":
                return True, _target(call, False)
            return True, _target(call, True)
    return False, None


class _Scan(ast.NodeVisitor):
    def __init__(self) -> None:
        self.stack: list[str] = []
        self.atomic: set[str] = set()  # names bound by `with atomic_path(...) as NAME`
        self.found: list[tuple[str, str, int]] = []

    def _scope(self, node: ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) -> None:
        self.stack.append(node.name)
        self.generic_visit(node)
        self.stack.pop()

    visit_FunctionDef = visit_AsyncFunctionDef = visit_ClassDef = _scope

    def visit_With(self, node: ast.With) -> None:
        for item in node.items:
            c = item.context_expr
            if isinstance(c, ast.Call) and ast.unparse(c.func).split(".")[-1] == "atomic_path" \
                    and isinstance(item.optional_vars, ast.Name):
                self.atomic.add(item.optional_vars.id)
        self.generic_visit(node)

    def visit_Call(self, node: ast.Call) -> None:
        writes, target = _is_write(node)
        if writes and not (isinstance(target, ast.Name) and target.id in self.atomic):
            self.found.append((".".join(self.stack) or "<module>", ast.unparse(node.func), node.lineno))
        self.generic_visit(node)


def direct_writes(source: str) -> list[tuple[str, str, int]]:
    """(enclosing function, callee, line) of every non-atomic file write in ``source``."""
    s = _Scan()
    s.visit(ast.parse(source))
    return s.found


def _package_writes() -> list[tuple[str, str, str, int]]:
    out = []
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(PKG).as_posix()
        if rel == "outdir.py":  # the one writer of result files
            continue
        out += [(rel, fn, callee, line) for fn, callee, line in direct_writes(p.read_text("utf-8"))]
    return out


def test_no_direct_file_writes_outside_outdir() -> None:
    found = _package_writes()
    bad = [f"{rel}:{line} {fn}: {callee}(...)" for rel, fn, callee, line in found
           if (rel, fn, callee) not in ALLOWED]
    assert not bad, "write these through formsync_design.outdir (atomic):\n" + "\n".join(bad)
    stale = set(ALLOWED) - {(rel, fn, callee) for rel, fn, callee, _ in found}
    assert not stale, f"allow-list entries that match nothing any more: {sorted(stale)}"


@pytest.mark.parametrize("src", [
    "from pathlib import Path\ndef f(p):\n    Path(p).write_text('x')\n",
    "def f(p):\n    with open(p, 'w') as fh:\n        fh.write('x')\n",
    "def f(p, m):\n    open(p, m)\n",
    "def f(p):\n    p.open('a')\n",
    "import numpy as np\ndef f(p, a):\n    np.savez(p, a=a)\n",
    "def f(fig, p):\n    fig.savefig(p, dpi=100)\n",
    "import json\ndef f(d, fh):\n    json.dump(d, fh)\n",
    "import os\ndef f(a, b):\n    os.replace(a, b)\n",
    "import os\ndef f(p):\n    os.open(p, os.O_WRONLY | os.O_CREAT)\n",
    "def f(df, p):\n    df.to_csv(p)\n",
])
def test_scanner_finds_direct_writes(src: str) -> None:
    assert len(direct_writes(src)) == 1


@pytest.mark.parametrize("src", [
    "def f(p):\n    with open(p) as fh:\n        return fh.read()\n",
    "def f(p):\n    with open(p, 'rb') as fh:\n        return fh.read()\n",
    "from formsync_design.outdir import atomic_path\nimport numpy as np\n"
    "def f(p, a):\n    with atomic_path(p) as tmp:\n        np.savetxt(tmp, a)\n",
    "import json, sys\ndef f(d):\n    json.dump(d, sys.stdout)\n",
    "def f():\n    '''>>> open('x', 'w').write('doctest, not code')'''\n",
])
def test_scanner_passes_reads_and_atomic_writes(src: str) -> None:
    assert direct_writes(src) == []


def test_interrupted_report_write_keeps_previous_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A crash at the rename (the last step of a write) leaves the old region files, complete,
    and no temporary beside them."""
    from formsync_design.certify.plots import write_region
    from formsync_design.certify.region import region_map
    from formsync_design.derive.conditions import derive_conditions

    c = derive_conditions("ring:4")
    old = region_map(c, {"K_o": ("0.05", "5"), "K_q": ("0.05", "5"), "beta": ("0.01", "1")},
                     resolution=2)
    new = region_map(c, {"K_o": ("0.5", "3"), "K_q": ("0.5", "3"), "beta": ("0.1", "1")},
                     resolution=2)
    out = tmp_path / "region"
    paths = write_region(out, [old], timing=False)
    before = {p.name: p.read_bytes() for p in paths}
    assert json.loads(before["region.json"])["maps"][0]["ranges"]["K_o"][1] == 5.0

    calls = []

    def crash(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
        calls.append(Path(dst).name)
        raise KeyboardInterrupt  # an interrupt exactly at the rename

    monkeypatch.setattr(outdir.os, "replace", crash)
    with pytest.raises(KeyboardInterrupt):
        write_region(out, [new], timing=False)
    assert calls == ["region.json"]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before

    monkeypatch.undo()  # the same call completes: the new files replace the old ones
    paths = write_region(out, [new], timing=False)
    assert json.loads((out / "region.json").read_text())["maps"][0]["ranges"]["K_o"][1] == 3.0
    assert sorted(p.name for p in out.iterdir()) == sorted(before)
