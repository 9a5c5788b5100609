"""Library code never changes the matplotlib backend (issue 9, item 7).

A notebook user's figures render inline only if nothing the package does
switches the backend.  Independent check: a fresh interpreter selects a
non-Agg backend (``svg``), imports every module of the package (walked with
:mod:`pkgutil`, not listed by hand), draws the figures the library returns,
and the backend is still ``svg``; and no library source calls
``matplotlib.use`` / ``pyplot.switch_backend`` (only the command line, which
owns its process, may choose a non-interactive backend).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import formsync_design

PACKAGE = Path(formsync_design.__file__).resolve().parent
#: Where choosing a backend is allowed: the command line owns its process.
ALLOWED = ("cli",)
CALL = re.compile(r"(?:\bmatplotlib|\bmpl)\s*\.\s*use\s*\(|switch_backend\s*\(")

IMPORT_ALL = r"""
import importlib, pkgutil, sys
import matplotlib
matplotlib.use("svg")
import formsync_design
names = [m.name for m in pkgutil.walk_packages(formsync_design.__path__, "formsync_design.")]
assert len(names) > 20, names
changed = []
for name in names:
    importlib.import_module(name)
    if matplotlib.get_backend().lower() != "svg":
        changed.append((name, matplotlib.get_backend()))
        matplotlib.use("svg")
print("modules", len(names))
print("changed", changed)
"""

def _env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("MPLBACKEND", None)  # the test's own choice must be the one in force
    return env


def test_importing_every_module_keeps_the_backend(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-c", IMPORT_ALL], capture_output=True, text=True,
                          timeout=300, env=_env(), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = dict(line.split(" ", 1) for line in proc.stdout.splitlines())
    assert int(out["modules"]) > 20
    assert out["changed"] == "[]", f"importing these modules changed the backend: {out['changed']}"


def test_drawing_figures_keeps_the_backend(tmp_path: Path) -> None:
    """The figure functions of the public surface return figures and leave the backend alone."""
    code = r"""
import matplotlib
matplotlib.use("svg")
import formsync_design as fs
g = fs.make_graph("ring:4")
conds = fs.derive_conditions(g)
m = fs.region_map(conds, {"K_o": (0.5, 3), "K_q": (0.2, 2), "beta": (0.1, 0.6)}, resolution=4)
assert matplotlib.get_backend() == "svg", ("region_map", matplotlib.get_backend())
figs = [fs.plot_slices([m])]
assert matplotlib.get_backend() == "svg", ("plot_slices", matplotlib.get_backend())
import numpy as np
from formsync_design.models.disturbances import no_disturbance
q = np.array([[0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]])
att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
f = fs.Formation(fs.make_graph("path:2"), np.array([np.eye(3)] * 2), att, np.zeros((2, 3)),
                 fs.Gains(1.6, 0.4, 0.3, (0.0, 0.0)), no_disturbance(2))
r = fs.simulate(f, fs.SimOptions(tf=5.0, compile=False))
figs += [fs.metric_figure(r), *fs.torque_figures(r)]
assert matplotlib.get_backend() == "svg", ("sim figures", matplotlib.get_backend())
print("figures", *sorted({type(fig).__name__ for fig in figs}))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, env=_env(), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "figures Figure" in proc.stdout


def test_no_library_source_selects_a_backend() -> None:
    offenders = []
    files = sorted(PACKAGE.rglob("*.py"))
    assert len(files) > 20
    for path in files:
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] in ALLOWED:
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if CALL.search(code):
                offenders.append(f"{rel}:{number}: {line.strip()}")
    assert not offenders, "library code selects a matplotlib backend:\n" + "\n".join(offenders)


def test_pattern_catches_the_calls() -> None:
    """The source check is not vacuous: it recognises the spellings it forbids."""
    for bad in ('matplotlib.use("Agg")', "mpl.use('Agg', force=True)", "plt.switch_backend('agg')"):
        assert CALL.search(bad), bad
    for fine in ("matplotlib.get_backend()", "fig.use_sticky_edges", "# matplotlib.use is banned"):
        assert not CALL.search(fine.split("#", 1)[0]), fine
