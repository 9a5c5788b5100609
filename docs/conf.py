"""Sphinx configuration of the formsync-design documentation.

Build (from the repository root, after ``.venv/bin/pip install -e '.[docs]'``)::

    .venv/bin/sphinx-build -W --keep-going -b html docs docs/_build/html
    .venv/bin/sphinx-build -W --keep-going -b doctest docs docs/_build/doctest

The committed reports (``reports/``) are copied into ``docs/reports/`` (generated, ignored by
git) when the build starts, so that their relative links (figures, the derivation report a
verification report names) resolve inside the documentation exactly as in the repository;
the reports themselves are never edited.  Nothing is executed during the build except the
imports autodoc and sphinx-argparse need.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import formsync_design

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# cli_reference: the formsync parser with its terminal texts made literal (docs/cli.md)
sys.path.insert(0, str(DOCS / "_ext"))

project = "formsync-design"
author = "formsync-design developers"
copyright = "formsync-design developers, BSD-3-Clause"
release = formsync_design.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinxarg.ext",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# docs/reports/ is a copy made by _copy_reports below (its CSV/JSON/TeX files are data);
# docs/generated/ holds the stubs autosummary writes
exclude_patterns = ["_build", "**/.ipynb_checkpoints"]
templates_path = ["_templates"]  # autosummary: one page per class, its documented methods

# -- MyST: Markdown pages, the README/ARCHITECTURE sections they include, the reports
myst_enable_extensions = ["dollarmath", "colon_fence"]
# slug anchors for headings, so that links like ARCHITECTURE.md#the-design-plug-in-contract
# (in the README sections the guide includes) resolve
myst_heading_anchors = 3

# -- autodoc / autosummary / numpydoc: the API reference of formsync_design.__all__
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
# the class pages list their attributes in the docstring's Attributes section (numpydoc);
# an autosummary table of members would document every dataclass field twice
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# -- doctest: only the {doctest} blocks of these pages; the docstrings' examples are run by
# the test suite (pytest --doctest-modules, configured in pyproject.toml)
doctest_test_doctest_blocks = ""
# the pages' examples name files relative to the repository root, as the commands do
doctest_global_setup = f"import os as _os\n_CWD = _os.getcwd()\n_os.chdir({str(ROOT)!r})"
doctest_global_cleanup = "_os.chdir(_CWD)"

# -- HTML
html_theme = "furo"
html_title = f"formsync-design {release}"
html_static_path: list[str] = []


def _copy_reports(app, config) -> None:  # noqa: ARG001 (Sphinx's hook signature)
    """Copy ``reports/`` into the documentation source as ``docs/reports/`` (a fresh copy)."""
    dst = DOCS / "reports"
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(ROOT / "reports", dst)


def setup(app):
    app.connect("config-inited", _copy_reports)
    return {"parallel_read_safe": True}
