"""The derivation report: content, determinism, and the committed copy."""

from __future__ import annotations

from pathlib import Path

import pytest

from formsync_design.derive.report import write_derivation_report

ROOT = Path(__file__).resolve().parents[1]


def test_report_is_byte_identical_on_rerun(tmp_path):
    a = write_derivation_report("ring:4", tmp_path / "a", command="x")
    b = write_derivation_report("ring:4", tmp_path / "b", command="x")
    assert a.markdown.read_bytes() == b.markdown.read_bytes()
    assert a.latex.read_bytes() == b.latex.read_bytes()
    text = a.markdown.read_text()
    for needle in ("## 7. Paper versus derivation", "**differs**", "Cross-check", "K_{vi}"):
        assert needle in text
    assert a.brute_force_checked


@pytest.mark.slow
def test_committed_report_is_current(tmp_path):
    committed = ROOT / "reports" / "liang2016-derivation-ring8.md"
    r = write_derivation_report("ring:8", tmp_path, command="formsync derive")
    assert committed.read_text() == r.markdown.read_text()
