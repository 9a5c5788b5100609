"""Dwell-time certificate over a graph set (issue 15, item 4).

Independent truth: scipy's Lyapunov solver, and exact matrix-exponential propagation of
the full ``2N`` nominal loop (original coordinates, full Laplacians) switching at the
certified dwell time.
"""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
from scipy.linalg import expm, solve_continuous_lyapunov

from formsync_design.analysis.dwell import certify_dwell_time, lyapunov_exact, reduced_matrix
from formsync_design.analysis.switching import certify_switching
from formsync_design.cli.main import main
from formsync_design.graphs import make_graph

SET = ["star:6", "path:6"]
PT = (0.3, 1.0, 0.3)


def test_exact_lyapunov_solutions() -> None:
    for g in SET:
        a = reduced_matrix(g, Fraction(-3, 10), Fraction(-1))
        p = lyapunov_exact(a)
        n = len(a)
        for i in range(n):
            for j in range(n):
                v = sum(a[k][i] * p[k][j] + p[i][k] * a[k][j] for k in range(n))
                assert v == (-1 if i == j else 0)
        af = np.array([[float(x) for x in r] for r in a])
        ref = solve_continuous_lyapunov(af.T, -np.eye(n))
        assert np.allclose(np.array([[float(x) for x in r] for r in p]), ref, rtol=1e-9, atol=1e-12)


def test_no_common_function_but_a_dwell_time() -> None:
    assert certify_switching(SET, dict(zip(("K_o", "K_q", "beta"), PT))).status.value != "certified"
    d = certify_dwell_time(SET, PT)
    assert d.status.value == "certified" and d.mu > 1 and 0 < d.dwell < math.inf
    assert certify_dwell_time(["star:6"], PT).dwell == 0.0


def test_switching_at_the_dwell_time_converges_within_the_bound() -> None:
    d = certify_dwell_time(SET, PT)
    ko, kq = PT[0], PT[1]
    gs = [make_graph(g) for g in SET]
    n = gs[0].n
    mats = [np.block([[np.zeros((n, n)), np.eye(n)], [-kq * g.laplacian.astype(float), -ko * np.eye(n)]])
            for g in gs]
    ps = [np.array([[float(x) for x in r] for r in lyapunov_exact(reduced_matrix(g, Fraction(-3, 10),
                                                                                    Fraction(-1)))])
          for g in SET]
    tmat = np.hstack([np.eye(n - 1), -np.ones((n - 1, 1))])
    big_t = np.block([[tmat, np.zeros_like(tmat)], [np.zeros_like(tmat), tmat]])

    def v(j: int, x: np.ndarray) -> float:
        z = big_t @ x
        return float(z @ ps[j] @ z)

    dwell = d.dwell * 1.01
    rng = np.random.default_rng(8)
    x = rng.normal(size=2 * n)
    v0 = v(0, x)
    steps = 20
    for cycle in range(10):
        j = cycle % 2
        step = expm(mats[j] * (dwell / steps))
        for s in range(1, steps + 1):
            x = step @ x
            t = cycle * dwell + s * dwell / steps
            bound = float(d.mu) ** cycle * math.exp(-2 * float(d.decay) * t) * v0
            assert v(j, x) <= bound * (1 + 1e-9)
    assert v(1, x) < v0 * float(d.mu) ** 9 * math.exp(-2 * float(d.decay) * 10 * dwell) * (1 + 1e-9) < v0


def test_cli_min_dwell(capsys) -> None:
    base = ["certify", "--graph", "star:6", "--ko", "0.3", "--kq", "1", "--beta", "0.3",
            "--certificate", "spectral", "--graphs-set", ",".join(SET)]
    assert main(base) == 1
    out = capsys.readouterr().out
    assert "graph_set: undecided" in out and "--min-dwell" in out
    d = certify_dwell_time(SET, PT)
    assert main([*base, "--min-dwell", f"{d.dwell * 1.01:.6g}", "--format", "json"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["requirements"][0]["status"] == "certified"
    assert main([*base, "--min-dwell", f"{d.dwell * 0.5:.6g}"]) == 1
    capsys.readouterr()
    assert main(["certify", "--graph", "star:6", "--ko", "0.3", "--kq", "1", "--beta", "0.3",
                 "--min-dwell", "3"]) == 2
