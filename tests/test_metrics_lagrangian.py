"""The metrics of a design's Lagrangian view and the relative measures
(formsync_design/verify/metrics_lagrangian.py), against independent computations."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

from formsync_design.errors import InputError
from formsync_design.verify.enginecase import load_engine_case
from formsync_design.verify.metrics_lagrangian import (
    chatter_end_time,
    relative_convergence_time,
    relative_measures,
)

_SC = """
[[spacecraft]]
inertia = [[50, 0, 4], [0, 55, 0], [4, 0, 60]]
rate = [0.05, -0.03, 0.02]
q = [0.1, 0.2, -0.1]

[[spacecraft]]
inertia = [[52, 1, 0.5], [1, 54, 3], [0.5, 3, 62]]
rate = [0.02, -0.01, 0.03]
q = [0.1, 0.1, 0.1]

[[spacecraft]]
inertia = [[53, 0.4, 0], [0.4, 54, 0.8], [0, 0.8, 58]]
rate = [-0.02, 0.02, -0.01]
q = [-0.1, 0.1, -0.1]

[[spacecraft]]
inertia = [[55, 0.8, 2], [0.8, 59, 1], [2, 1, 61]]
rate = [0.04, 0.03, -0.05]
q = [-0.1, 0.1, -0.1]
"""


def _case(tmp_path, metrics: str, design: str = "liang2016", gains: str = "") -> object:
    gains = gains or "K_q = 0.4\nK_o = 1.6\nbeta = 0.3\nK_v = 0.01"
    text = f"""
[case]
kind = "engine"
design = "{design}"
graph = "ring:4"
[gains]
{gains}
[orbit]
altitude_km = 400.0
[disturbance]
model = "paper"
[simulation]
tf = 30.0
output_step = 0.1
integrator = "cvodes"
rtol = 1e-8
atol = 1e-12
switch = "sat"
boundary_layer = 0.01
[[formations]]
name = "ring4"
[[formations]]
name = "star8"
graph = "star:8"
{metrics}
[[claims]]
id = "c"
text = "c"
predicate = "kv >= 1"
""" + _SC
    p = tmp_path / "c.toml"
    p.write_text(text)
    return p


def test_relative_measures_match_the_pairwise_definition():
    rng = np.random.default_rng(7)
    T, n = 3, 4
    q = rng.normal(size=(T, n, 4))
    q /= np.linalg.norm(q, axis=2, keepdims=True)
    w = rng.normal(size=(T, n, 3))
    om, qm = relative_measures(SimpleNamespace(quaternions=q, rates=w))
    for k in range(T):
        sq = sw = 0.0
        for i, j in itertools.permutations(range(n), 2):
            qi, q0i, qj, q0j = q[k, i, :3], q[k, i, 3], q[k, j, :3], q[k, j, 3]
            sq += float(np.sum((q0j * qi - q0i * qj - np.cross(qj, qi)) ** 2))
            sw += float(np.sum((w[k, i] - w[k, j]) ** 2))
        assert om[k] == pytest.approx(np.sqrt(sw / (n * (n - 1))), rel=1e-12)
        assert qm[k] == pytest.approx(np.sqrt(sq / (n * (n - 1))), rel=1e-9)


def test_relative_convergence_time_and_chattering():
    t = np.arange(0.0, 5.0, 0.5)
    qm = np.array([1, 1, 0, 0, 1, 0, 0, 0, 0, 0.0])
    assert relative_convergence_time(t, np.zeros_like(t), qm, 0.5, 1.0) == 2.5
    assert relative_convergence_time(t, np.zeros_like(t), qm[::-1], 0.5, 1.0) is None
    tt = np.arange(0, 10, 0.1)
    assert chatter_end_time(tt, np.exp(-tt)[:, None]) is None
    # a torque that reverses at every sample up to 6 s, then decays: chattering ends by 6 s
    t20 = np.arange(0.0, 20.0, 0.1)
    chat = np.where(t20 < 6, (-1.0) ** np.arange(t20.size), 0.01 * np.exp(-t20))
    end = chatter_end_time(t20, chat[:, None])
    assert end is not None and 5.5 <= end < 6.0


def test_lagrangian_certificates_and_switching_gain(tmp_path):
    from formsync_design.derive.closed_form import required_kv
    from formsync_design.verify.engine import run_engine

    rows = "".join(f'\n[[metrics]]\nid = "{i}"\nmetric = "{m}"\nformation = "{f}"\n{a}\n' for i, m, f, a in [
        ("th_ring", "lagrangian_certificate", "ring4", 'family = "Theta"'),
        ("pi_ring", "lagrangian_certificate", "ring4", 'family = "Pi"'),
        ("th_star", "lagrangian_certificate", "star8", 'family = "Theta"'),
        ("margin", "lagrangian_margin", "ring4", ""),
        ("kv", "switching_gain_ratio", "ring4", ""),
        ("kv2", "required_switching_gain", "ring4", "spacecraft = 2"),
        ("u2", "disturbance_bound", "ring4", "spacecraft = 2"),
    ])
    ver = run_engine(load_engine_case(_case(tmp_path, rows)))
    v = {row.id: val for row, val in ver.metrics}
    # as the classic verifier found (reports/liang2016-verification.md before the engine):
    # Theta_i holds at degree 2 and fails at the star's centre (degree 7)
    assert v["th_ring"].value == "certified" and v["th_star"].value == "refuted"
    assert v["pi_ring"].value in ("certified", "refuted")
    assert v["margin"].value is None or v["margin"].value > 0
    J2 = np.array([[52, 1, 0.5], [1, 54, 3], [0.5, 3, 62]], float)
    kv_star = max(np.linalg.norm(np.linalg.solve(J2, np.array(s, float)))
                  for s in itertools.product((-1, 1), repeat=3)) * v["u2"].value / 2
    assert v["kv2"].value == pytest.approx(kv_star, rel=1e-12)
    assert v["kv2"].value == pytest.approx(required_kv(J2, v["u2"].value), rel=1e-12)
    assert v["kv"].value > 1 and "holds" in v["kv"].detail


def test_lagrangian_metrics_refuse_a_design_without_a_view(tmp_path):
    rows = "\n[[metrics]]\nid = \"kv\"\nmetric = \"lagrangian_certificate\"\n"
    p = _case(tmp_path, rows, design="ma_so3",
              gains="K1 = 1.15\nK2 = 0.15\nP1 = 0.03\nP2 = 0.03\neps = 0.01")
    with pytest.raises(InputError, match="Lagrangian view"):
        load_engine_case(p)


def test_report_derivation_writes_the_committed_derivation_report(tmp_path):
    """[report] derivation of the pd_consensus case writes the derivation report the classic
    verifier wrote (reports/pd_consensus-derivation-ring4.*: equal but for --out)."""
    from pathlib import Path

    from formsync_design.resources import case_file
    from formsync_design.verify.engine_derivation import write_case_derivation

    case = load_engine_case(case_file("pd_consensus"))
    assert case.report_derivation == "ring4"
    rep = write_case_derivation(case, tmp_path)
    root = Path(__file__).resolve().parents[1] / "reports"
    for p in (rep.markdown, rep.latex):
        got = p.read_text().replace(f" --out {tmp_path}", "")
        assert got == (root / p.name).read_text(), p.name


def test_report_keys_are_checked(tmp_path):
    base = _case(tmp_path, "")
    text = base.read_text()
    for extra, words in (('[report]\nderivation = "nope"\n', "report.derivation among"),
                         ('[report]\nfigures = [["ring4", "x"]]\n', "report.figures")):
        base.write_text(text + extra + '\n[[metrics]]\nid = "kv"\nmetric = "switching_gain_ratio"\n')
        with pytest.raises(InputError, match=words):
            load_engine_case(base)
    base.write_text(text + '[report]\nfigures = [["ring4", "nominal"]]\n'
                    '\n[[metrics]]\nid = "kv"\nmetric = "switching_gain_ratio"\n')
    assert load_engine_case(base).report_figures == (("ring4", "nominal"),)
