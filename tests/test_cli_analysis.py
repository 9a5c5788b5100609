"""``formsync certify/region/design`` with --certificate and requirement options (issue 15).

Independent truth: numpy eigenvalues of the full stacked nominal loop
``q'' = -K_o q' - K_q L q`` (``[[0, I], [-K_q L, -K_o I]]``, disagreement
modes only), and the closed-form processing-delay margin of
``s^2 + K_o s + K_q lambda e^{-s tau}`` (``w^4 + K_o^2 w^2 = (K_q lambda)^2``,
``tau = atan2(K_o, w) / w``).
"""

from __future__ import annotations

import itertools
import json
import math
from fractions import Fraction

import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.graphs import make_graph

PT = ["--ko", "1.6", "--kq", "0.4", "--beta", "0.3"]


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def _true_rate(graph: str, ko: float, kq: float) -> float:
    """-max Re over the disagreement modes, from the full 2N x 2N matrix (not per mode)."""
    lap = make_graph(graph).laplacian.astype(float)
    n = lap.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-kq * lap, -ko * np.eye(n)]])
    ev = np.linalg.eigvals(a)
    # remove the consensus mode's two eigenvalues 0 and -K_o (lambda = 0)
    ev = sorted(ev, key=lambda z: abs(z))[1:]
    k = int(np.argmin([abs(z + ko) for z in ev]))
    ev = ev[:k] + ev[k + 1:]
    return float(-max(z.real for z in ev))


def _closed_form_delay_margin(graph: str, ko: float, kq: float) -> float:
    lam = np.linalg.eigvalsh(make_graph(graph).laplacian.astype(float))[1:]
    best = math.inf
    for lk in lam:
        c = kq * lk
        w2 = (-ko**2 + math.sqrt(ko**4 + 4 * c * c)) / 2
        w = math.sqrt(w2)
        best = min(best, math.atan2(ko, w) / w)
    return best


def test_default_is_the_paper_path_and_explicit_paper_is_identical(capsys) -> None:
    a = _run(capsys, "certify", "--graph", "ring:8", *PT)
    b = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "paper")
    def strip(out: str) -> list[str]:  # the solver line carries a wall time
        return [ln for ln in out.splitlines() if not ln.startswith("  solver:")]

    assert a[0] == b[0] == 0 and strip(a[1]) == strip(b[1])
    assert "derived conditions" in a[1] and "certified margin" in a[1]


@pytest.mark.parametrize("graph", ["ring:8", "star:8", "complete:8"])
def test_spectral_verdict_matches_full_eigenvalues(capsys, graph: str) -> None:
    for ko, kq in [(1.6, 0.4), (0.5, 3.0)]:
        rc, out, _ = _run(capsys, "certify", "--graph", graph, "--ko", str(ko), "--kq", str(kq),
                          "--beta", "0.3", "--certificate", "spectral", "--format", "json")
        d = json.loads(out)
        stable = _true_rate(graph, ko, kq) > 0
        assert (rc == 0) == stable == (d["status"] == "certified")


def test_certificates_on_star_paper_gains(capsys) -> None:
    # the nominal loop converges (spectral certifies), the paper's V does not (exact refutes)
    assert _true_rate("star:8", 1.6, 0.4) > 0
    codes = {c: _run(capsys, "certify", "--graph", "star:8", *PT, "--certificate", c)[0]
             for c in ("paper", "exact", "searched", "spectral")}
    assert codes == {"paper": 1, "exact": 1, "searched": 1, "spectral": 0}
    rc, out, _ = _run(capsys, "certify", "--graph", "star:8", *PT, "--certificate", "searched")
    assert out.startswith("REFUTED: star:8 (N=8), searched certificate") and "witness" in out


def test_decay_is_never_faster_than_the_true_rate(capsys) -> None:
    true = _true_rate("ring:8", 1.6, 0.4)
    rc, out, _ = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "searched",
                      "--decay", "0.01", "--format", "json")
    d = json.loads(out)
    alpha = float(Fraction(str(d["requirements"][0]["value"])))
    assert rc == 0 and d["status"] == "certified" and 0.01 <= alpha <= true
    # asking for more than the true rate: refuted exactly, never certified
    rc, out, _ = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
                      "--decay", f"{true * 1.05:.6f}")
    assert rc == 1 and out.startswith("REFUTED") and "decays slower than alpha" in out
    # just below the true rate: not refuted (the true rate meets it), at most undecided
    rc, out, _ = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
                      "--decay", f"{true * 0.95:.6f}")
    assert not out.startswith("REFUTED")


def test_settle_time_bound(capsys) -> None:
    rc, out, _ = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
                      "--settle", "1000", "--x0-radius", "0.5", "--accuracy", "0.01", "--format", "json")
    d = json.loads(out)
    (chk,) = d["requirements"]
    t = float(Fraction(str(chk["value"])))
    assert rc == 0 and chk["status"] == "certified" and t <= 1000
    # the promised time cannot beat the slowest mode: |x| decays at most like exp(-rate t)
    assert t >= math.log(0.5 / 0.01) / _true_rate("ring:8", 1.6, 0.4) * 0.999
    rc, out, _ = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
                      "--settle", f"{t * 0.5:g}")
    assert rc == 1 and "settle: undecided" in out


def test_delay_margin_matches_closed_form(capsys) -> None:
    tau_c = _closed_form_delay_margin("ring:8", 1.6, 0.4)
    ok = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
              "--delay", f"{tau_c * 0.98:.6f}", "--format", "json")
    d = json.loads(ok[1])
    assert ok[0] == 0 and d["requirements"][0]["value"] == pytest.approx(tau_c, rel=1e-6)
    bad = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
               "--delay", f"{tau_c * 1.02:.6f}")
    assert bad[0] == 1 and "delay: refuted" in bad[1]
    # transmission delay on a regular graph: delay-independent here (Atay)
    tr = _run(capsys, "certify", "--graph", "ring:8", *PT, "--certificate", "exact",
              "--delay", "100", "--delay-model", "transmission")
    assert tr[0] == 0


def test_graphs_set_certified_converges_under_random_drops(capsys) -> None:
    from formsync_design.analysis import graphs_minus_links, simulate_switching

    rc, out, _ = _run(capsys, "certify", "--graph", "ring:6", *PT, "--certificate", "exact",
                      "--graphs-set", "minus:1")
    assert rc == 0 and "graph_set: certified" in out
    gs = [make_graph("ring:6"), *graphs_minus_links("ring:6", 1)]
    _, x, _ = simulate_switching(gs, (1.6, 0.4, 0.3), tf=80.0, mean_dwell=0.5, seed=7)
    assert np.linalg.norm(x[-1]) < 1e-2 * np.linalg.norm(x[0])
    rc, out, _ = _run(capsys, "certify", "--graph", "ring:6", *PT, "--certificate", "exact",
                      "--graphs-set", "ring:6,circulant:6:1,2")
    assert rc == 0


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--certificate", "exact", "--margin", "0.1"], "--margin only"),
        (["--certificate", "exact", "--conditions", "paper"], "--conditions derived"),
        (["--ko", "1:2", "--delay", "0.1"], "gain point"),
        (["--graphs-set", "minus:x"], "minus:K"),
        (["--graphs-set", "ring:5"], "N=8"),
        (["--decay", "-1"], "positive --decay"),
        (["--settle", "0"], "positive --settle"),
        (["--decay", "0.1", "--ud", "0.5"], "K_v check"),
    ],
)
def test_bad_input_one_line(capsys, extra: list[str], needle: str) -> None:
    args = {"--graph": "ring:8", "--ko": "1.6", "--kq": "0.4", "--beta": "0.3"}
    rest = []
    for k, v in zip(extra[::2], extra[1::2]):
        if k in args:
            args[k] = v
        else:
            rest += [k, v]
    rc, _, err = _run(capsys, "certify", *[t for kv in args.items() for t in kv], *rest)
    assert rc == 2 and err.count("\n") == 1 and needle in err and "expected" in err


def test_help_explains_each_certificate(capsys) -> None:
    rc, out, _ = _run(capsys, "certify", "--help")
    assert rc == 0
    for c in ("paper ", "exact ", "searched ", "spectral "):
        assert f"\n  {c}" in out


def test_region_cells_agree_with_true_rates(capsys, tmp_path) -> None:
    rc, out, _ = _run(capsys, "region", "--graph", "star:8", "--ko", "0.5:4", "--kq", "0.1:2",
                      "--beta", "0.3:0.3", "--certificate", "spectral", "--decay", "0.1",
                      "--resolution", "3", "--out", str(tmp_path), "--no-progress")
    assert rc == 0 and "star:8 (spectral certificate, decay)" in out
    data = json.loads((tmp_path / "region.json").read_text())
    (m,) = data["maps"]
    assert m["cells"] == 9
    seen = set()
    for cell in m["boxes"]:
        b = {k: (float(Fraction(str(cell["box"][k][0]))), float(Fraction(str(cell["box"][k][1]))))
             for k in ("K_o", "K_q")}
        rates = [_true_rate("star:8", ko, kq) for ko, kq in itertools.product(b["K_o"], b["K_q"])]
        seen.add(cell["status"])
        if cell["status"] == "certified":
            assert min(rates) >= 0.1
        elif cell["status"] == "refuted":
            assert min(rates) < 0.1
    assert "certified" in seen and "refuted" in seen


def test_constrained_design_meets_its_delay(capsys) -> None:
    rc, out, _ = _run(capsys, "design", "--graph", "ring:6", "--ko", "1:3", "--kq", "0.2:1",
                      "--beta", "0.1:0.3", "--min-delay", "0.5", "--grid", "2", "--format", "json")
    d = json.loads(out)
    assert rc == 0 and d["status"] == "certified"
    ko, kq = (float(Fraction(str(d["gains"][k]))) for k in ("K_o", "K_q"))
    assert _closed_form_delay_margin("ring:6", ko, kq) >= 0.5
    assert float(Fraction(str(d["alpha"]))) <= _true_rate("ring:6", ko, kq)


def test_torque_limit_matches_simulated_peaks(capsys, tmp_path) -> None:
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.formation import Formation, Gains, SimOptions
    from formsync_design.sim.simulator import simulate

    jf = tmp_path / "J.txt"
    jf.write_text("50 0 0\n0 55 0\n0 0 60\n")
    base = ["certify", "--graph", "ring:6", *PT, "--inertia", str(jf), "--att0", "0.1", "--rate0", "0.01"]
    rc, out, _ = _run(capsys, *base, "--torque-limit", "1e6", "--format", "json")
    d = json.loads(out)
    bound = float(Fraction(str(d["requirements"][0]["value"])))
    assert rc == 0 and d["requirements"][0]["status"] == "certified"
    # simulated peaks from the corners of the initial set stay below the certified bound
    rng = np.random.default_rng(5)
    q = rng.normal(size=(6, 3))
    q *= 0.1 / np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(size=(6, 3))
    w *= 0.01 / np.linalg.norm(w, axis=1, keepdims=True)
    f = Formation(make_graph("ring:6"), np.array([np.diag([50.0, 55.0, 60.0])] * 6),
                  np.column_stack([q, np.sqrt(1 - (q**2).sum(1))]), w, Gains(1.6, 0.4, 0.3, (0.0,) * 6),
                  no_disturbance(6))
    r = simulate(f, SimOptions(tf=40.0, compile=False))
    peak = float(np.linalg.norm(r.u.reshape(len(r.t), 6, 3), axis=2).max())
    assert peak <= bound
    # below the certified bound: not certified (the bound is conservative: undecided)
    rc, out, _ = _run(capsys, *base, "--torque-limit", f"{bound / 2:g}")
    assert rc == 1 and "torque: undecided" in out
    rc, _, err = _run(capsys, "certify", "--graph", "ring:6", *PT, "--torque-limit", "10")
    assert rc == 2 and "inertias" in err


def test_design_with_torque_limit(capsys, tmp_path) -> None:
    from formsync_design.analysis.torque import peak_torque_bound

    jf = tmp_path / "J.txt"
    jf.write_text("50 0 0\n0 55 0\n0 0 60\n")
    rc, out, _ = _run(capsys, "design", "--graph", "ring:6", "--ko", "1:3", "--kq", "0.2:1", "--beta",
                      "0.1:0.3", "--torque-limit", "150", "--inertia", str(jf), "--att0", "0.05",
                      "--grid", "2", "--format", "json")
    d = json.loads(out)
    assert rc == 0
    gains = tuple(Fraction(str(d["gains"][k])) for k in ("K_o", "K_q", "beta"))
    assert peak_torque_bound("ring:6", gains, np.diag([50.0, 55.0, 60.0]), 0.05, 0.01).peak <= 150


def test_region_delay_cells_hold_at_random_interior_points(capsys, tmp_path) -> None:
    """`formsync region --delay`: every gain of a certified cell has a closed-form processing
    margin (all Laplacian modes, eigvalsh) above tau, every gain of a refuted cell below it -
    checked at seeded random points inside each cell, not at the corners the decision used."""
    tau = 0.8
    rc, out, _ = _run(capsys, "region", "--graph", "star:6", "--ko", "0.5:3", "--kq", "0.1:1.5",
                      "--beta", "0.3", "--certificate", "spectral", "--delay", str(tau),
                      "--resolution", "5", "--out", str(tmp_path), "--no-progress")
    assert rc == 0 and "certified" in out
    data = json.loads((tmp_path / "region.json").read_text())
    cells = data["maps"][0]["boxes"]
    seen = {c["status"] for c in cells}
    assert {"certified", "refuted"} <= seen
    rng = np.random.default_rng(15)
    for c in cells:
        (ko_lo, ko_hi), (kq_lo, kq_hi) = ([float(Fraction(str(x))) for x in c["box"][k]]
                                          for k in ("K_o", "K_q"))
        for _ in range(6):
            ko, kq = rng.uniform(ko_lo, ko_hi), rng.uniform(kq_lo, kq_hi)
            tm = _closed_form_delay_margin("star:6", ko, kq)
            if c["requirements"].get("delay") == "certified":
                assert tm > tau
            elif c["requirements"].get("delay") == "refuted":
                assert tm < tau


def test_region_transmission_delay_cells_are_delay_independent(capsys, tmp_path) -> None:
    """Transmission delay on a regular graph: cells certified for --delay are delay-independent;
    at seeded random interior points the quasi-polynomial crossing analysis finds no crossing
    frequency (infinite margin) and a long-delay simulation converges."""
    from formsync_design.analysis.delay import delay_margin, simulate_delayed_loop

    rc, _, _ = _run(capsys, "region", "--graph", "ring:6", "--ko", "0.5:3", "--kq", "0.1:1.5",
                    "--beta", "0.3", "--certificate", "spectral", "--delay", "3",
                    "--delay-model", "transmission", "--resolution", "4", "--out", str(tmp_path),
                    "--no-progress")
    assert rc == 0
    cells = json.loads((tmp_path / "region.json").read_text())["maps"][0]["boxes"]
    cert = [c for c in cells if c["requirements"].get("delay") == "certified"]
    assert cert and len(cert) < len(cells)
    rng = np.random.default_rng(16)
    for c in cert:
        (ko_lo, ko_hi), (kq_lo, kq_hi) = ([float(Fraction(str(x))) for x in c["box"][k]]
                                          for k in ("K_o", "K_q"))
        ko, kq = rng.uniform(ko_lo, ko_hi), rng.uniform(kq_lo, kq_hi)
        assert delay_margin("ring:6", (ko, kq, 0.3), "transmission").margin == math.inf
    c = cert[0]
    ko, kq = (float(Fraction(str(c["box"][k][0]))) for k in ("K_o", "K_q"))
    t, d = simulate_delayed_loop("ring:6", (ko, kq, 0.3), 3.0, "transmission", tf=150, h=0.01, seed=3)
    assert d[-1] < 0.1 * d[0]


def test_certify_transmission_delay_on_irregular_graph(capsys) -> None:
    """star:8 (irregular) with transmission delay: the Lyapunov-Krasovskii lower bound certifies a
    short delay; a long one is undecided (a sufficient bound refutes nothing), never refuted."""
    rc, out, _ = _run(capsys, "certify", "--graph", "star:8", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3",
                      "--certificate", "spectral", "--delay", "0.5", "--delay-model", "transmission")
    assert rc == 0 and "delay: certified" in out and "Lyapunov-Krasovskii" in out
    rc, out, _ = _run(capsys, "certify", "--graph", "star:8", "--ko", "1.6", "--kq", "0.4", "--beta", "0.3",
                      "--certificate", "spectral", "--delay", "50", "--delay-model", "transmission")
    assert "delay: undecided" in out and "refuted" not in out


def test_pd_design_certificates_on_the_command_line(capsys) -> None:
    """`formsync certify --design pd_consensus`: spectral certified for positive gains (hand:
    s^2 + k_d s + k_p lambda), the delay margin is the closed form with (K_o, K_q) -> (k_d, k_p),
    and the decay rate is never above the true rate of the dense loop."""
    pd = ["--design", "pd_consensus", "--graph", "star:8", "--gain", "k_p=0.4", "--gain", "k_d=1.6"]
    rc, out, _ = _run(capsys, "certify", *pd, "--certificate", "spectral", "--format", "json")
    assert rc == 0 and json.loads(out)["certificate"]["status"] == "certified"
    rc, out, _ = _run(capsys, "certify", *pd, "--certificate", "searched", "--decay", "0.1", "--delay", "0.5",
                      "--format", "json")
    d = json.loads(out)
    checks = {c["name"]: c for c in d["requirements"]}
    assert rc == 0 and checks["delay"]["status"] == "certified"
    assert float(Fraction(str(checks["delay"]["value"]))) == pytest.approx(
        _closed_form_delay_margin("star:8", 1.6, 0.4), rel=1e-7)
    assert float(Fraction(str(checks["decay"]["value"]))) <= _true_rate("star:8", 1.6, 0.4) * (1 + 1e-9)
    # a given multiplier is used as given; with the spectral certificate it is refused (one line)
    rc, _, err = _run(capsys, "certify", *pd, "--gain", "eps=0.1", "--certificate", "spectral")
    assert rc == 2 and err.count("\n") == 1 and "multiplier" in err


def test_region_torque_cells_hold_in_simulation(capsys, tmp_path) -> None:
    """`formsync region --torque-limit` on the PD design: a certified cell's promise holds for
    seeded random gains inside it and initial states of the set (CasADi simulation of the
    design's compiled controller); a refuted cell's witness needs more than the limit at t = 0."""
    from formsync_design.analysis.torque import initial_torque_witness
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.formation import Formation, Gains, SimOptions
    from formsync_design.sim.simulator import simulate

    jf = tmp_path / "J.txt"
    jf.write_text("50 0 0\n0 55 0\n0 0 60\n")
    limit = 30.0
    rc, out, _ = _run(capsys, "region", "--design", "pd_consensus", "--graph", "ring:5", "--gain", "k_p=0.1:1.5",
                      "--gain", "k_d=0.5:2.5", "--certificate", "spectral", "--torque-limit", str(limit),
                      "--inertia", str(jf), "--att0", "0.05", "--rate0", "0.01", "--resolution", "3",
                      "--out", str(tmp_path), "--no-progress")
    assert rc == 0
    cells = json.loads((tmp_path / "region.json").read_text())["maps"][0]["boxes"]
    seen = {c["requirements"]["torque"] for c in cells}
    assert {"certified", "refuted"} <= seen, seen
    rng = np.random.default_rng(25)
    J = np.diag([50.0, 55.0, 60.0])
    for c in cells:
        box = {k: tuple(Fraction(str(x)) for x in c["box"][k]) for k in ("k_p", "k_d")}
        if c["requirements"]["torque"] == "refuted":
            assert initial_torque_witness("ring:5", box, J, 0.05, spec="pd_consensus")["torque_N_m"] > limit
        if c["requirements"]["torque"] != "certified":
            continue
        gains = {k: float(lo + (hi - lo) * rng.random()) for k, (lo, hi) in box.items()}
        q = rng.normal(size=(5, 3))
        q *= 0.05 / np.linalg.norm(q, axis=1, keepdims=True)
        w = rng.normal(size=(5, 3))
        w *= 0.01 / np.linalg.norm(w, axis=1, keepdims=True)
        f = Formation(make_graph("ring:5"), np.array([J] * 5), np.column_stack([q, np.sqrt(1 - (q**2).sum(1))]),
                      w, Gains(gains), no_disturbance(5))
        r = simulate(f, SimOptions(tf=30.0, compile=False), spec="pd_consensus")
        assert float(np.linalg.norm(r.u.reshape(len(r.t), 5, 3), axis=2).max()) <= limit


def test_pd_constrained_design_box_meets_the_torque_limit(capsys, tmp_path) -> None:
    """`formsync design --design pd_consensus --torque-limit`: a real box (not the point), and
    the torque bound reported for it holds at random gains inside it (the bound at a point)."""
    from formsync_design.analysis.torque import peak_torque_bound

    jf = tmp_path / "J.txt"
    jf.write_text("50 0 0\n0 55 0\n0 0 60\n")
    rc, out, _ = _run(capsys, "design", "--design", "pd_consensus", "--graph", "ring:6", "--gain", "k_p=0.1:1",
                      "--gain", "k_d=0.5:3", "--torque-limit", "40", "--inertia", str(jf), "--att0", "0.05",
                      "--grid", "2", "--format", "json")
    d = json.loads(out)
    assert rc == 0 and d["status"] == "certified"
    box = {k: [Fraction(str(x)) for x in v] for k, v in d["box"].items()}
    assert all(hi > lo for lo, hi in box.values())
    bound = float(Fraction(str(d["box_torque_bound_N_m"])))
    assert bound <= 40
    rng = np.random.default_rng(3)
    for _ in range(3):
        pt = tuple(float(lo + (hi - lo) * Fraction(rng.random())) for lo, hi in box.values())
        assert peak_torque_bound("ring:6", pt, np.diag([50.0, 55.0, 60.0]), 0.05, 0.01,
                                 spec="pd_consensus").peak <= bound
