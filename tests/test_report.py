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


def test_each_verdict_has_its_meaning_and_computation_beside_it(tmp_path):
    r = write_derivation_report("ring:4", tmp_path, command="x")
    rows = [ln for ln in r.markdown.read_text().splitlines() if ln.startswith("| ") and "`" in ln]
    assert len(rows) == len(r.findings) == 12
    for f, row in zip(r.findings, rows):
        cells = row.split(" | ")
        assert cells[1] == f"`{f.key}`: {f.meaning}" and f.meaning.endswith("?")
        assert f"**{f.verdict}**" in row and str(f.computation.kind) in row


def test_report_of_a_variant_spec_shows_its_own_theta(tmp_path):
    data = Path(__file__).parent / "data"
    r = write_derivation_report("ring:4", tmp_path, spec=data / "variant_spec.py", command="x")
    paper = write_derivation_report("ring:4", tmp_path / "p", command="x")
    theta = [ln for ln in r.markdown.read_text().splitlines() if "Theta}^{(2)}" in ln]
    theta_p = [ln for ln in paper.markdown.read_text().splitlines() if "Theta}^{(2)}" in ln]
    assert theta and theta_p and theta != theta_p


@pytest.mark.slow
def test_committed_report_is_current(tmp_path):
    committed = ROOT / "reports" / "liang2016-derivation-ring8.md"
    r = write_derivation_report("ring:8", tmp_path, command="formsync derive")
    assert committed.read_text() == r.markdown.read_text()
