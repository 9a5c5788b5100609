"""Tests of formsync_design.sweep / ``formsync sweep``.

Independent truths: the number of connected graphs on n nodes (OEIS A001349:
1, 1, 2, 6, 21, 112, 853), the Laplacian spectrum from networkx/numpy, and the
closed-form conditions of the derivation (K_o > beta lambda_max(L) for Pi;
K_q + beta K_o > 2 m beta^2 for Theta_i) evaluated here in exact rationals.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from fractions import Fraction
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.errors import FormsyncError, InputError
from formsync_design.sweep import (
    COLUMNS,
    build_tasks,
    campaign_from_dict,
    expand_graph_set,
    expand_graphs,
    run_sweep,
    run_task,
)
from formsync_design.sweep.store import read_results

ROOT = Path(__file__).resolve().parents[1]
# connected graphs on n nodes, OEIS A001349
CONNECTED = {2: 1, 3: 2, 4: 6, 5: 21, 6: 112}


def small_campaign(graphs=("ring:3..5", "star:4", "path:4"), **extra):
    doc = {
        "campaign": {"name": "t", "graphs": list(graphs)},
        "region": {"resolution": 2},
        "design": {"betas": 2},
    }
    doc.update(extra)
    return campaign_from_dict(doc)


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())} if folder.exists() else {}


# ---------------------------------------------------------------------------
# graph sets
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_atlas_counts_match_oeis(n):
    gs, skipped = expand_graph_set(f"atlas:{n}")
    assert len(gs) == CONNECTED[n] and skipped == []
    assert all(g.graph.n == n for g in gs)
    # pairwise non-isomorphic
    nxg = [g.graph.to_networkx() for g in gs]
    for i in range(len(nxg)):
        for j in range(i + 1, len(nxg)):
            assert not nx.is_isomorphic(nxg[i], nxg[j])


def test_atlas_range_syntaxes_agree():
    a = [g.id for g in expand_graph_set("atlas:2..5")[0]]
    b = [g.id for g in expand_graph_set("atlas:N<=5")[0]]
    assert a == b and len(a) == sum(CONNECTED[n] for n in range(2, 6))


def test_family_ranges_and_dedup():
    gs, _ = expand_graphs(["ring:4..6", "ring:6..7", "star:3"])
    assert [g.id for g in gs] == ["ring:4", "ring:5", "ring:6", "ring:7", "star:3"]
    for g in gs[:4]:
        assert g.graph.degrees == (2,) * g.graph.n


def test_random_sets_skip_and_list_disconnected():
    gs, skipped = expand_graph_set("random:7:0.3:0..19")
    assert len(gs) + len(skipped) == 20
    assert skipped and all(s.endswith("(disconnected)") for s in skipped)
    for g in gs:  # each draw is the make_graph graph of its own seed
        assert nx.is_connected(g.graph.to_networkx())
    ids = {g.id for g in gs} | {s.split()[0] for s in skipped}
    assert ids == {f"random:7:0.3:{s}" for s in range(20)}


def test_folder_of_edge_lists(tmp_path):
    (tmp_path / "b.txt").write_text("1 2\n2 3\n3 1\n")
    (tmp_path / "a.edges").write_text("# path\n1 2\n2 3\n3 4\n")
    (tmp_path / "notes.md").write_text("ignored: not an edge-list suffix\n")
    gs, _ = expand_graph_set(f"dir:{tmp_path}")
    assert [g.id for g in gs] == ["file:a.edges", "file:b.txt"]
    assert gs[0].graph.edges == ((0, 1), (1, 2), (2, 3))
    gs2, _ = expand_graph_set(str(tmp_path))
    assert [g.id for g in gs2] == [g.id for g in gs]


@pytest.mark.parametrize(
    "spec, words",
    [
        ("hypercube:3", "families"),
        ("ring:6..4", "A <= B"),
        ("atlas:8", "2..7"),
        ("random:6:0.01:0..2", "non-empty"),
        ("ring:x", "range"),
    ],
)
def test_bad_graph_sets(spec, words):
    with pytest.raises(InputError, match=words.replace(".", r"\.")):
        expand_graph_set(spec)


def test_empty_folder_is_an_empty_set(tmp_path):
    with pytest.raises(InputError, match="non-empty"):
        expand_graph_set(f"dir:{tmp_path}")


# ---------------------------------------------------------------------------
# rows against independent truth
# ---------------------------------------------------------------------------
def _closed_form_ok(graph: nx.Graph, ko, kq, beta) -> bool:
    lap = nx.laplacian_matrix(graph).toarray().astype(float)
    lmax = np.linalg.eigvalsh(lap)[-1]
    lmax_q = Fraction(round(lmax))  # integer for the graphs used here (checked below)
    assert abs(lmax - float(lmax_q)) < 1e-9
    m = max(d for _, d in graph.degree())
    return ko > beta * lmax_q and kq + beta * ko > 2 * m * beta**2


def test_rows_match_closed_forms_and_spectrum():
    ko, kq, beta = Fraction("1.6"), Fraction("0.4"), Fraction("0.3")
    c = small_campaign(graphs=("ring:8", "star:8", "complete:6", "path:2"))
    gs, _ = expand_graphs(c.graphs)
    rows = [run_task(t) for t in build_tasks(c, gs)]
    for g, r in zip(gs, rows):
        h = g.graph.to_networkx()
        ev = np.sort(nx.laplacian_spectrum(h))
        assert float(r["lambda_2"]) == pytest.approx(ev[1], abs=1e-8)
        assert float(r["lambda_max"]) == pytest.approx(ev[-1], abs=1e-8)
        assert int(r["degree_max"]) == max(d for _, d in h.degree())
        expect = "certified" if _closed_form_ok(h, ko, kq, beta) else "refuted"
        assert r["ref_status"] == expect, g.id
        fr = [float(r[k]) for k in ("frac_certified", "frac_refuted", "frac_undecided")]
        assert sum(fr) == pytest.approx(1.0) and all(0 <= f <= 1 for f in fr)
        if r["design_status"] == "designed":  # the recommended point satisfies the closed forms
            rec = [Fraction(r[f"rec_{k}"]) for k in ("K_o", "K_q", "beta")]
            assert _closed_form_ok(h, *rec)
    assert [r["ref_status"] for r in rows] == ["certified", "refuted", "refuted", "certified"]


# ---------------------------------------------------------------------------
# results folder, resume, mismatches
# ---------------------------------------------------------------------------
def test_serial_run_writes_sorted_complete_table(tmp_path):
    c = small_campaign()
    out = run_sweep(c, tmp_path / "r", n_workers=0)
    rows = read_results(tmp_path / "r" / "results.csv")
    assert out.tasks == len(rows) == 5 and out.computed == 5
    assert [r["graph"] for r in rows] == ["ring:3", "ring:4", "ring:5", "star:4", "path:4"]
    assert not (tmp_path / "r" / "journal.jsonl").exists()
    man = json.loads((tmp_path / "r" / "manifest.json").read_text())
    assert man["sha256"] == out.sha256 and man["columns"] == list(COLUMNS)
    names = {p.name for p in (tmp_path / "r").iterdir()}
    assert {"summary.md", "fraction-vs-lambda-max.png", "fraction-vs-max-degree.png"} <= names


class Boom(RuntimeError):
    pass


def test_interrupted_run_resumes_to_identical_rows(tmp_path):
    c = small_campaign()
    ref = tmp_path / "ref"
    run_sweep(c, ref, n_workers=0)
    calls: list[str] = []

    def dies_on_third(task):
        if len(calls) == 2:
            raise Boom("simulated kill")
        calls.append(task["task"])
        return run_task(task)

    out = tmp_path / "r"
    with pytest.raises(FormsyncError, match="simulated kill"):
        run_sweep(c, out, n_workers=0, task_fn=dies_on_third)
    assert not (out / "results.csv").exists()  # never a partial table
    lines = (out / "journal.jsonl").read_text().splitlines()
    assert len(lines) == 2
    # without --resume the folder is refused and left alone
    before = snapshot(out)
    with pytest.raises(InputError, match="--resume"):
        run_sweep(c, out, n_workers=0)
    assert snapshot(out) == before
    redone: list[str] = []

    def counting(task):
        redone.append(task["task"])
        return run_task(task)

    res = run_sweep(c, out, n_workers=0, resume=True, task_fn=counting)
    assert res.reused == 2 and res.computed == 3
    assert not set(redone) & set(calls)  # finished tasks are not redone
    assert (out / "results.csv").read_bytes() == (ref / "results.csv").read_bytes()
    for name in ("fraction-vs-lambda-max.png", "fraction-vs-max-degree.png", "summary.md",
                 "manifest.json"):
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name


def test_torn_journal_line_is_discarded_on_resume(tmp_path):
    c = small_campaign()
    ref = tmp_path / "ref"
    run_sweep(c, ref, n_workers=0)
    out = tmp_path / "r"

    def stop_after_one(task, _n=[0]):  # noqa: B006 - a call counter
        if _n[0] == 1:
            raise Boom("simulated kill")
        _n[0] += 1
        return run_task(task)

    with pytest.raises(FormsyncError, match="simulated kill"):
        run_sweep(c, out, n_workers=0, task_fn=stop_after_one)
    j = out / "journal.jsonl"
    full = j.read_bytes()
    j.write_bytes(full + full[: len(full) // 2])  # a row cut mid-write (no newline)
    run_sweep(c, out, n_workers=0, resume=True)
    rows = read_results(out / "results.csv")
    assert len(rows) == len({r["task"] for r in rows}) == 5
    assert (out / "results.csv").read_bytes() == (ref / "results.csv").read_bytes()


def test_resume_of_a_complete_folder_recomputes_nothing(tmp_path):
    c = small_campaign(graphs=("ring:3",))
    run_sweep(c, tmp_path / "r", n_workers=0)
    before = snapshot(tmp_path / "r")

    def never(task):
        raise AssertionError("no task should run")

    res = run_sweep(c, tmp_path / "r", n_workers=0, resume=True, task_fn=never)
    assert res.computed == 0 and snapshot(tmp_path / "r") == before


def test_folder_of_another_campaign_is_refused(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["sweep", "--graphs", "ring:3", "--resolution", "2", "--design-betas", "2",
                 "--workers", "0", "--out", str(out), "--no-progress"]) == 0
    before = snapshot(out)
    capsys.readouterr()
    for extra in ([], ["--resume"], ["--overwrite"]):
        rc = main(["sweep", "--graphs", "ring:4", "--resolution", "2", "--design-betas", "2",
                   "--workers", "0", "--out", str(out), *extra])
        err = capsys.readouterr().err
        assert rc == 2 and "different campaign" in err and err.count("\n") == 1
        assert snapshot(out) == before


def test_foreign_folder_without_manifest_is_refused(tmp_path, capsys):
    out = tmp_path / "r"
    out.mkdir()
    (out / "precious.txt").write_text("keep me")
    rc = main(["sweep", "--graphs", "ring:3", "--workers", "0", "--out", str(out)])
    assert rc == 2 and "no manifest.json" in capsys.readouterr().err
    assert snapshot(out) == {"precious.txt": b"keep me"}


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--graphs", "hypercube:3"], "families"),
        (["--graphs", "random:6:0.01:0..2"], "non-empty"),
        (["--graphs", "ring:3", "--campaign", "x.toml"], "either --campaign"),
        ([], "--graphs"),
        (["--graphs", "ring:3", "--ko", "5:1"], "LO <= HI"),
        (["--graphs", "ring:3", "--resume", "--overwrite"], "at most one"),
        (["--graphs", "ring:3", "--mc-runs", "2", "--mc-case", "nope.toml"], "no such file"),
        (["--graphs", "ring:3", "--mc-seed", "2"], "--mc-runs"),
    ],
)
def test_cli_bad_input_exit_2_one_line(tmp_path, capsys, argv, words):
    out = tmp_path / "r"
    rc = main(["sweep", *argv, "--workers", "0", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and words in err and err.count("\n") == 1, err
    assert not out.exists()


def test_unreachable_scheduler_fails_fast_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "r"
    rc = main(["sweep", "--graphs", "ring:3", "--scheduler", "tcp://127.0.0.1:9", "--timeout", "1",
               "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 3 and "could not reach the Dask scheduler" in err and err.count("\n") == 1
    assert not out.exists()


def test_campaign_file_strictness(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text('[campaign]\nname = "x"\ngraphs = ["ring:3"]\ncolour = "red"\n')
    rc = main(["sweep", "--campaign", str(p), "--workers", "0", "--out", str(tmp_path / "o")])
    assert rc == 2 and not (tmp_path / "o").exists()


def test_example_campaign_definition_loads():
    from formsync_design.sweep import load_campaign

    c = load_campaign(ROOT / "verification" / "sweep_atlas6.toml")
    gs, skipped = expand_graphs(c.graphs)
    assert len(gs) == sum(CONNECTED.values()) and not skipped
    assert [float(v) for v in c.reference] == [1.6, 0.4, 0.3]
    pd = load_campaign(ROOT / "verification" / "sweep_pd_atlas5.toml")
    assert pd.schema.box == ("k_p", "k_d") and pd.schema.multipliers == ("eps",)
    assert [float(v) for v in pd.reference] == [0.4, 1.6] and pd.compare == "reports/sweep-atlas6"
    assert pd.montecarlo is not None and pd.montecarlo.switching is None


# ---------------------------------------------------------------------------
# Dask
# ---------------------------------------------------------------------------
def test_local_dask_cluster_equals_serial(tmp_path):
    c = small_campaign(graphs=("ring:3", "star:4"))
    run_sweep(c, tmp_path / "serial", n_workers=0)
    res = run_sweep(c, tmp_path / "dask", n_workers=2, timeout=30)
    assert res.executor.startswith("dask LocalCluster")
    for name in ("results.csv", "manifest.json", "summary.md", "fraction-vs-lambda-max.png"):
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes()


def test_existing_scheduler_and_failing_task_keeps_finished_rows(tmp_path):
    from distributed import LocalCluster

    c = small_campaign(graphs=("ring:3", "star:4"))
    run_sweep(c, tmp_path / "serial", n_workers=0)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0") as cluster:
        out = tmp_path / "r"
        with pytest.raises(FormsyncError, match="star:4"):
            run_sweep(c, out, scheduler=cluster.scheduler_address, timeout=30,
                      task_fn=_fails_on_star)
        assert not (out / "results.csv").exists()
        j = out / "journal.jsonl"  # absent if the failure came before any other task finished
        kept = j.read_text().splitlines() if j.exists() else []
        assert all(json.loads(x)["graph"] != "star:4" for x in kept)
        run_sweep(c, out, scheduler=cluster.scheduler_address, timeout=30, resume=True)
    assert (out / "results.csv").read_bytes() == (tmp_path / "serial" / "results.csv").read_bytes()


def _fails_on_star(task):  # module level: picklable by reference for the workers
    if task["graph"] == "star:4":
        time.sleep(0.5)  # usually lets the other task finish first (either order is valid)
        raise Boom("injected failure")
    return run_task(task)


@pytest.mark.slow
def test_killed_process_resumes_to_rows_of_uninterrupted_run(tmp_path):
    """A real SIGKILL of ``formsync sweep`` mid-campaign, then ``--resume``."""
    argv = ["sweep", "--graphs", "atlas:2..5", "--resolution", "4", "--design-betas", "3",
            "--workers", "0", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path / "ref")]) == 0
    out = tmp_path / "r"
    exe = [sys.executable, "-c", "import sys; from formsync_design.cli.main import main; "
           "sys.exit(main(sys.argv[1:]))"]
    proc = subprocess.Popen([*exe, *argv, "--out", str(out)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    j = out / "journal.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if j.exists() and j.read_bytes().count(b"\n") >= 5:
            break
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (out / "results.csv").exists()
    assert main([*argv, "--out", str(out), "--resume"]) == 0
    assert (out / "results.csv").read_bytes() == (tmp_path / "ref" / "results.csv").read_bytes()


@pytest.mark.slow
def test_montecarlo_columns(tmp_path):
    c = small_campaign(graphs=("ring:3", "star:4"),
                       montecarlo={"runs": 3, "tf": 60.0, "gains": "recommended"})
    gs, _ = expand_graphs(c.graphs)
    for t in build_tasks(c, gs):
        r = run_task(t)
        assert r["mc_status"] == "ran" and r["mc_runs"] == "3"
        parts = sum(int(r[k]) for k in ("mc_converged", "mc_not_converged", "mc_singular",
                                         "mc_diverged", "mc_inaccurate"))
        assert parts == 3
        assert (r["mc_conv_time_median"] == "") == (r["mc_converged"] == "0")
        assert len([s for s in r["mc_failed_seeds"].split(";") if s]) == 3 - int(r["mc_converged"])


def test_progress_reports_every_task_and_json_output(tmp_path, capsys):
    seen = []
    c = small_campaign(graphs=("ring:3", "path:3"))
    run_sweep(c, tmp_path / "a", n_workers=0, progress=lambda k, n: seen.append((k, n)))
    assert seen == [(1, 2), (2, 2)]
    rc = main(["sweep", "--graphs", "ring:3", "--graphs", "path:3", "--resolution", "2",
               "--design-betas", "2", "--workers", "0", "--out", str(tmp_path / "b"),
               "--format", "json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["tasks"] == 2 and doc["computed"] == 2 and doc["executor"] == "serial"
    # the summary records the command that regenerates the folder
    md = (tmp_path / "b" / "summary.md").read_text()
    assert "formsync sweep --graphs ring:3 --graphs path:3 --resolution 2 --design-betas 2" in md


def test_montecarlo_case_content_is_part_of_the_campaign(tmp_path):
    from formsync_design.sweep import campaign_hash
    from formsync_design.verify.case import default_case_path

    case = tmp_path / "case.toml"
    text = default_case_path().read_text()
    case.write_text(text)
    c = small_campaign(graphs=("ring:3",), montecarlo={"runs": 2, "case": str(case)})
    gs, _ = expand_graphs(c.graphs)
    h1 = campaign_hash(c, gs)
    case.write_text(text.replace("K_v = 0.01", "K_v = 0.02"))
    assert campaign_hash(c, gs) != h1
    case.unlink()
    with pytest.raises(InputError, match="no such file"):
        campaign_hash(c, gs)


def test_two_boxes_give_one_row_per_graph_and_box(tmp_path):
    boxes = [
        {"name": "wide", "K_o": [0.05, 5], "K_q": [0.05, 5], "beta": [0.01, 1]},
        {"name": "tight", "K_o": [1.5, 1.7], "K_q": [0.35, 0.45], "beta": [0.25, 0.35]},
    ]
    c = small_campaign(graphs=("ring:4", "complete:6"), box=boxes)
    run_sweep(c, tmp_path / "r", n_workers=0)
    rows = read_results(tmp_path / "r" / "results.csv")
    assert [r["task"] for r in rows] == ["ring:4@wide", "ring:4@tight", "complete:6@wide",
                                         "complete:6@tight"]
    tight = {r["graph"]: r for r in rows if r["box"] == "tight"}
    # ring:4 (lambda_max 4, degree 2): the whole tight box satisfies the closed forms at its
    # vertices (K_o > beta lambda_max; K_q + beta K_o > 2 m beta^2), so it is all certified
    assert float(tight["ring:4"]["frac_certified"]) == 1.0
    # complete:6 (lambda_max 6): K_o = 1.5 < 0.35 * 6 fails Pi at a vertex: not all certified
    assert float(tight["complete:6"]["frac_certified"]) < 1.0
    with pytest.raises(InputError, match="distinct box names"):
        small_campaign(box=[boxes[0], boxes[0]])
