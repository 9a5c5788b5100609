"""Every bad input tried, with the exit status and message it must give (issue 34, item 8).

One parametrised table assembled from ``tests/bad_inputs/<area>.py``; the harness is
``tests/badinput.py``.
"""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import tests.bad_inputs as areas
from tests.badinput import BadInput, run_bad_input


def _rows() -> list[BadInput]:
    rows: list[BadInput] = []
    for m in sorted(pkgutil.iter_modules(areas.__path__), key=lambda m: m.name):
        rows += importlib.import_module(f"tests.bad_inputs.{m.name}").ROWS
    return rows


ROWS = _rows()


def test_the_table_ids_are_unique() -> None:
    ids = [r.id for r in ROWS]
    assert len(ids) == len(set(ids)), sorted(i for i in ids if ids.count(i) > 1)


@pytest.mark.parametrize("row", ROWS, ids=[r.id for r in ROWS])
def test_bad_input(row: BadInput, tmp_path, capsys) -> None:
    run_bad_input(row, tmp_path, capsys)
