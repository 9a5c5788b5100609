"""The formation-level certificate against independent truth: finite differences of the
compiled simulation kernel, the second (quaternion, leader) linearisation, analytic matrices,
and the CLI verdicts with their scope."""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest

from formsync_design.certify.formation import certify_formation
from formsync_design.certify.lyapunov import decide_point
from formsync_design.certify.results import Status
from formsync_design.cli.main import main
from formsync_design.derive.formation import linearize_formation
from formsync_design.derive.linearize import linearize_agents
from formsync_design.gains import GainBox
from formsync_design.graphs.digraph_io import digraph_from_edges
from formsync_design.spec.loader import load_design
from formsync_design.verify.agentcase import load_agent_case, shipped_agent_case
from tests.fd_formation import fd_jacobian  # noqa: I001

PAPER = {"K1": "1.15", "K2": "0.15", "P1": "0.03", "P2": "0.03", "eps": "0.01"}


def cycle(n: int):
    return digraph_from_edges([(i + 1, (i - 1) % n + 1, 1) for i in range(n)], n=n, name=f"C{n}")


def so3_case():
    return load_agent_case(shipped_agent_case(load_design("ma_so3")))


def disagreement_abscissa(A: np.ndarray, n: int, p: int) -> float:
    """Largest real part of the disagreement dynamics, by projecting out the common
    directions numerically (independent of the exact quotient)."""
    lam, V = np.linalg.eig(A)
    out = -np.inf
    for k in range(lam.size):
        v = V[:, k]
        blocks = [v[[3 * i + c if c < 3 else 3 * n + 3 * i + c - 3 for c in range(6)]]
                  for i in range(n)]
        spread = max(np.linalg.norm(b - blocks[0]) for b in blocks)
        if spread > 1e-6 * np.linalg.norm(v):
            out = max(out, lam[k].real)
    return out


@pytest.mark.parametrize("name,n,gains", [
    ("ma_so3", 5, {"K1": 0.7, "K2": 0.3, "P1": 0.05, "P2": 0.02, "eps": 0.04}),
    pytest.param("ma_mrp_ft", 4, {"K1": 0.5, "K2": 0.05, "P1": 0.01, "P2": 0.01, "eps": 0.01},
                 marks=pytest.mark.slow),
    pytest.param("ma_quat_smc", 6, {"K1": 1.15, "K2": 0.15, "P2": 0.03}, marks=pytest.mark.slow),
])
def test_linearisation_equals_finite_differences_of_the_simulated_loop(name, n, gains):
    """Entry by entry, in the chart of the representation (the fractional powers make the
    finite difference converge like sqrt(h): h = 1e-10 leaves about 1e-4)."""
    d = load_design(name)
    g = cycle(n)
    J = so3_case().cycled(n).inertias
    lin = linearize_formation(d, g, J, switch="sat", phi="1/100",
                              fixed={k: Fraction(str(v)) for k, v in gains.items()})
    A = lin.loop.standard({})[0]
    F = fd_jacobian(d, g, J, gains, h=1e-10)
    c = {"so3": 2.0, "mrp": 0.5, "quaternion": 1.0}[d.representation]
    S = np.eye(A.shape[0])
    S[: 3 * n, : 3 * n] *= c      # the chart coordinates are c * (quaternion vector part)
    np.testing.assert_allclose(A, S @ F @ np.linalg.inv(S), atol=2e-3)
    assert abs(disagreement_abscissa(A, n, 6) - disagreement_abscissa(F, n, 6)) < 2e-3


def test_generic_linearisation_equals_the_quaternion_leader_linearisation():
    """lv2012 (a leader, a filter state): the generic DAG linearisation and the symbolic
    Jacobian of derive/linearize.py are two implementations of one matrix."""
    d = load_design("lv2012")
    case = load_agent_case(shipped_agent_case(d))
    g = case.graph()
    a = linearize_agents(d, g, case.inertias)
    b = linearize_formation(d, g, case.inertias).loop
    assert a.gains == b.gains and a.T == b.T
    assert {e: dict(c) for e, c in a.F.terms.items()} == {e: dict(c) for e, c in b.F.terms.items()}
    assert np.array_equal(a.G, b.G)


def test_decide_point_on_analytic_matrices():
    stable = np.array([[-1.0, 5.0], [0.0, -2.0]])
    unstable = np.array([[0.25, 1.0], [-1.0, 0.25]])      # eigenvalues 1/4 +- i
    marginal = np.array([[0.0, 1.0], [-1.0, 0.0]])
    d = decide_point(stable, np.zeros((2, 2)))
    assert d["status"] == Status.CERTIFIED and 0 < d["decay"] <= 1.0
    d = decide_point(unstable, np.zeros((2, 2)))
    assert d["status"] == Status.REFUTED and 0 < d["sigma"] < 0.25
    assert decide_point(marginal, np.zeros((2, 2)))["status"] == Status.UNDECIDED
    # an uncertainty that covers an unstable matrix cannot be certified
    d = decide_point(np.array([[-1e-3, 0.0], [0.0, -1.0]]), np.full((2, 2), 2e-3))
    assert d["status"] != Status.CERTIFIED


def test_ma_so3_on_directed_cycles_paper_gains():
    """C7 is locally exponentially stable (slowly), C8 is not: the eigenvalue of the witness
    is one of the finite-difference Jacobian's, with real part above the proven sigma."""
    d = load_design("ma_so3")
    box = GainBox.parse(PAPER)
    r7 = certify_formation(d, cycle(7), so3_case().cycled(7).inertias, box)
    assert r7.status == Status.CERTIFIED and 0 < r7.decay < 0.06
    r8 = certify_formation(d, cycle(8), so3_case().cycled(8).inertias, box)
    assert r8.status == Status.REFUTED
    w = r8.witness
    F = fd_jacobian(d, cycle(8), so3_case().cycled(8).inertias,
                    {k: float(Fraction(v)) for k, v in PAPER.items()}, h=1e-10)
    lam = np.linalg.eigvals(F)
    assert np.min(np.abs(lam - w.eigenvalue)) < 1e-3 and w.eigenvalue.real > w.sigma > 0


def test_a_box_is_refuted_at_a_vertex_and_certified_when_every_point_is():
    d = load_design("ma_so3")
    J = so3_case().cycled(6).inertias
    good = GainBox.parse({**PAPER, "K1": "1:1.3", "K2": "0.15:0.3"})
    assert certify_formation(d, cycle(6), J, good).status == Status.CERTIFIED
    bad = GainBox.parse({**PAPER, "K1": "0.5:1.15"})        # K1 = 0.5 is unstable on C6
    r = certify_formation(d, cycle(6), J, bad)
    assert r.status == Status.REFUTED and r.witness.point["K1"] == Fraction(1, 2)


def test_a_leader_design_is_decided_on_the_full_state():
    d = load_design("lv2012")
    case = load_agent_case(shipped_agent_case(d))
    box = GainBox.parse(case.gains.as_dict())
    r = certify_formation(d, case.graph(), case.inertias, box)
    assert r.status == Status.CERTIFIED and "reference" in r.scope.target
    assert r.evidence["consensus_dim"] == 0


def test_ideal_sign_is_named_as_not_covered():
    d = load_design("ma_mrp_ft")
    r = certify_formation(d, cycle(4), so3_case().cycled(4).inertias,
                          GainBox.parse({"K1": "0.5", "K2": "0.05", "P1": "0.01", "P2": "0.01",
                                         "eps": "0.01"}), switch="sgn")
    assert r.status == Status.UNDECIDED and "not differentiable" in r.scope.covers


def _edges(tmp_path, n):
    p = tmp_path / f"c{n}.txt"
    p.write_text("".join(f"{i + 1} {(i - 1) % n + 1} 1\n" for i in range(n)))
    return str(p)


def test_cli_certify_verdicts_carry_the_formation_scope(tmp_path, capsys):
    gains = [x for k, v in PAPER.items() for x in ("--gain", f"{k}={v}")]
    rc = main(["certify", "--design", "ma_so3", "--graph", _edges(tmp_path, 8), *gains,
               "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and doc["status"] == "refuted"
    f = doc["formation"]
    assert f["scope"]["system"] == "formation" and f["scope"]["n"] == 8
    assert f["scope"]["property"] == "local-exponential" and f["witness"]["real_part_above"] > 0
    assert doc["design_conditions"]["scope"]["system"] == "design-conditions"
    rc = main(["certify", "--design", "ma_so3", "--graph", _edges(tmp_path, 5), *gains])
    out = capsys.readouterr().out
    assert rc == 0 and "formation on" in out and "(N = 5)" in out


def test_cli_certify_of_designs_without_conditions(tmp_path, capsys):
    for name, gains in (("ma_quat_smc", ["K1=1.15", "K2=0.15", "P2=0.03"]),
                        ("ma_mrp_ft", ["K1=1.15", "K2=0.15", "P1=0.03", "P2=0.03", "eps=0.01"])):
        rc = main(["certify", "--design", name, "--graph", _edges(tmp_path, 5),
                   *[x for g in gains for x in ("--gain", g)], "--format", "json"])
        doc = json.loads(capsys.readouterr().out)
        assert rc in (0, 1) and doc["formation"]["scope"]["system"] == "formation"
        assert "design_conditions" not in doc


@pytest.mark.slow
def test_a_directed_cycle_of_100_spacecraft_decides():
    d = load_design("ma_so3")
    r = certify_formation(d, cycle(100), so3_case().cycled(100).inertias, GainBox.parse(PAPER))
    assert r.status == Status.REFUTED and r.evidence["quotient_dim"] == 594


def test_an_undecided_formation_gets_a_seeded_falsification_search(capsys):
    """ma_mrp_ft with the ideal sgn: |s|^(1/2) sgn(s) is not differentiable at consensus, so
    no proof decides; the falsification runs are evidence, replayed by their seeds."""
    args = ["certify", "--design", "ma_mrp_ft", "--graph", "ring:4", "--switch", "sgn",
            *[x for g in ("K1=0.5", "K2=0.05", "P1=0.01", "P2=0.01", "eps=0.01")
              for x in ("--gain", g)], "--format", "json"]
    assert main(args) == 1
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == "undecided" and "not differentiable" in doc["formation"]["scope"]["covers"]
    fal = doc["falsification"]
    assert fal["basis"] == "evidence" and [r["seed"] for r in fal["runs"]] == [1, 2, 3, 4]
    assert main(args) == 1
    again = json.loads(capsys.readouterr().out)["falsification"]
    assert again == fal
