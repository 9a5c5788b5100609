"""``python -m formsync_design ...``: the same command line as ``formsync ...``.

The ``formsync`` script (``[project.scripts]``) and this module run the same
:func:`formsync_design.cli.main`, so a notebook's or CI's interpreter runs the
tool without the script on its ``PATH``.
"""

from __future__ import annotations

from formsync_design.cli.main import main

__all__: list[str] = []

if __name__ == "__main__":
    raise SystemExit(main())
