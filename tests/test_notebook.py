"""The tutorial notebook runs, top to bottom, and its figures render inline (issue 9, item 9).

``notebooks/tutorial.py`` is a jupytext text notebook; this test converts it
to a notebook and executes it in a real Jupyter kernel (nbclient + ipykernel),
so the tutorial cannot rot.  The kernel runs *without* ``MPLBACKEND`` (as a
user's notebook does): each figure cell must produce an inline ``image/png``
output, which fails if the library switches the backend away from inline.
"""

from __future__ import annotations

from pathlib import Path

import jupytext
import nbformat
import pytest
from ipykernel.kernelspec import install as install_kernel
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "tutorial.py"
FIGURE_CALLS = ("fs.plot_slices(", "fs.metric_figure(", "plt.subplots(")


def _execute(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> nbformat.NotebookNode:
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's own (inline) backend
    # a kernel running this interpreter (not whatever "python3" kernel a machine has)
    prefix = tmp_path / "jupyter"
    install_kernel(kernel_name="formsync-test", prefix=str(prefix))
    monkeypatch.setenv("JUPYTER_PATH", str(prefix / "share" / "jupyter"))
    nb = jupytext.read(NOTEBOOK)
    work = tmp_path / "work"
    work.mkdir()
    client = NotebookClient(nb, timeout=300, kernel_name="formsync-test",
                            resources={"metadata": {"path": str(work)}})
    client.execute()
    return nb


def test_tutorial_is_a_text_notebook() -> None:
    nb = jupytext.read(NOTEBOOK)
    kinds = {cell.cell_type for cell in nb.cells}
    assert kinds == {"markdown", "code"}
    assert "matplotlib.use" not in NOTEBOOK.read_text(encoding="utf-8")  # never forced
    code = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    for step in ("fs.make_graph", "fs.derive_conditions", "fs.Spec.from_functions",
                 "fs.certify_box", "fs.region_map", "fs.simulate", "fs.verify_case"):
        assert step in code, step


def test_tutorial_runs_with_inline_figures(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    nb = _execute(tmp_path, monkeypatch)
    code_cells = [c for c in nb.cells if c.cell_type == "code"]
    errors = [o for c in code_cells for o in c.outputs if o.output_type == "error"]
    assert not errors, errors
    figure_cells = [c for c in code_cells if any(call in c.source for call in FIGURE_CALLS)]
    assert len(figure_cells) >= 4
    for cell in figure_cells:
        images = [o for o in cell.outputs
                  if o.output_type in ("display_data", "execute_result") and "image/png" in o.data]
        assert images, f"no inline figure from cell:\n{cell.source}"
    text = "".join(o.get("text", "") for c in code_cells for o in c.outputs
                   if o.output_type == "stream")
    assert "ring:8: certified" in text and "star:8: refuted" in text
    # results render themselves (issue 25): the rich HTML of a certificate, a region map, a
    # simulation and a pandas table of the verification's claims
    rich = "".join(o.data.get("text/html", "") for c in code_cells for o in c.outputs
                   if o.output_type == "execute_result")
    for title in ("Certification", "Region map", "Simulation", "Agent simulation"):
        assert f"<caption><b>{title}</b></caption>" in rich, title
    assert "verdict" in rich and "family" in rich  # the to_pandas() tables
    assert "holds" in text
    # the inline specification is a different controller: a different trajectory
    times = [line.split("convergence time:")[1].strip() for line in text.splitlines()
             if "convergence time:" in line]
    assert len(times) == 2 and times[0] != times[1], times
