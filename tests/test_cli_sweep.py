"""``formsync sweep`` end to end: Ctrl-C, cluster failures (exit 3), limits, one spec, bad input.

Independent truths: the rows of an uninterrupted serial run (for interrupted
and resumed Dask runs), the closed-form conditions of the derivation with K_o
doubled (Pi > 0 iff 2 K_o > beta lambda_max(L); Theta_i > 0 iff
K_q + 2 beta K_o > 2 m_i beta^2) for a variant specification, evaluated here in
exact rationals with the Laplacian spectrum from networkx.
"""

from __future__ import annotations

import hashlib
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
from formsync_design.errors import ClusterError, FormsyncError, InputError
from formsync_design.sweep import campaign_from_dict, run_sweep, run_task
from formsync_design.sweep.store import read_results

ROOT = Path(__file__).resolve().parents[1]
EXE = [sys.executable, "-c",
       "import sys; from formsync_design.cli.main import main; sys.exit(main(sys.argv[1:]))"]


#: The longest a wait lasts (s): a hang guard for a loaded machine, never what a test measures.
HANG_GUARD = 600.0


def one_line_error(err: str) -> None:
    assert err.count("\n") == 1 and err.endswith("\n"), err
    for bad in ("Traceback", "np.float64", "Errno", "KeyboardInterrupt"):
        assert bad not in err, err


# ---------------------------------------------------------------------------
# Ctrl-C
# ---------------------------------------------------------------------------
def test_ctrl_c_on_a_dask_sweep_stops_and_resumes_to_the_same_rows(tmp_path):
    """SIGINT to the whole process group (what a terminal's Ctrl-C does), Dask workers included.

    The signal is sent once the journal holds two rows (the state: tasks are finishing on the
    workers); every wait is bounded only by a hang guard of minutes, never measured (how fast
    it stops is ``benchmarks/bench_interrupts.py``)."""
    # 142 tasks: long enough that the run cannot finish between the journal check and the signal
    argv = ["sweep", "--graphs", "atlas:2..6", "--resolution", "2", "--design-betas", "2",
            "--no-progress"]
    out = tmp_path / "r"
    proc = subprocess.Popen([*EXE, *argv, "--workers", "2", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    j = out / "journal.jsonl"
    try:
        deadline = time.monotonic() + HANG_GUARD
        while time.monotonic() < deadline and proc.poll() is None:
            if j.exists() and j.read_bytes().count(b"\n") >= 2:
                break
            time.sleep(0.02)
        assert proc.poll() is None, "the sweep finished before it could be interrupted"
        assert j.read_bytes().count(b"\n") >= 2, "hang guard: no two rows in the journal"
        os.killpg(proc.pid, signal.SIGINT)
        _, err_b = proc.communicate(timeout=HANG_GUARD)  # a hang guard, not a measurement
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    err = err_b.decode()
    assert proc.returncode == 130, err
    one_line_error(err)
    assert "--resume" in err and "journal.jsonl" in err
    # the journal is intact: every line a complete row, no results.csv yet
    lines = j.read_bytes().split(b"\n")
    assert lines[-1] == b"" and len(lines) >= 3
    partial = [json.loads(x) for x in lines[:-1]]
    assert not (out / "results.csv").exists()
    # no worker process of ours is left running (exited ones may await reaping by init);
    # the state is waited for, up to the hang guard
    live: list[str] = ["?"]
    deadline = time.monotonic() + HANG_GUARD
    while time.monotonic() < deadline:
        ps = subprocess.run(["ps", "-o", "stat=", "-g", str(proc.pid)], capture_output=True,
                            text=True).stdout.split()
        live = [st for st in ps if not st.startswith("Z")]
        if not live:
            break
        time.sleep(0.1)
    assert not live, live
    # --resume completes it to the rows of an uninterrupted serial run
    assert main([*argv, "--workers", "0", "--out", str(tmp_path / "ref")]) == 0
    assert main([*argv, "--workers", "0", "--out", str(out), "--resume"]) == 0
    ref = read_results(tmp_path / "ref" / "results.csv")
    assert (out / "results.csv").read_bytes() == (tmp_path / "ref" / "results.csv").read_bytes()
    by_task = {r["task"]: r for r in ref}
    assert all(by_task[r["task"]] == r for r in partial)


def test_ctrl_c_in_a_serial_sweep_is_one_line_exit_130(tmp_path, capsys):
    calls = {"n": 0}

    def interrupting(task):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return run_task(task)

    from formsync_design.cli import sweep as cmd_sweep

    original = cmd_sweep.run

    def run(args):
        import formsync_design.sweep as sw

        real = sw.run_sweep

        def patched(*a, **k):
            return real(*a, **k, task_fn=interrupting)

        sw.run_sweep = patched
        try:
            return original(args)
        finally:
            sw.run_sweep = real

    cmd_sweep.run = run
    try:
        out = tmp_path / "r"
        rc = main(["sweep", "--graphs", "ring:3..6", "--resolution", "2", "--design-betas", "2",
                   "--workers", "0", "--out", str(out)])
    finally:
        cmd_sweep.run = original
    err = capsys.readouterr().err
    assert rc == 130
    one_line_error(err)
    assert (out / "journal.jsonl").read_bytes().count(b"\n") == 2


# ---------------------------------------------------------------------------
# failures that are not the user's input: exit 3
# ---------------------------------------------------------------------------
def _dies_on_star(task):  # module level: picklable by reference for the workers
    if task["graph"] == "star:4":
        os._exit(17)  # the worker process dies (as when the kernel kills it)
    return run_task(task)


def small(graphs, **extra):
    doc = {"campaign": {"name": "t", "graphs": list(graphs)}, "region": {"resolution": 2},
           "design": {"betas": 2}}
    doc.update(extra)
    return campaign_from_dict(doc)


def test_a_dying_worker_is_a_cluster_error_and_finished_rows_are_kept(tmp_path):
    import dask
    import distributed  # noqa: F401 - before config.set: its exit would drop distributed's defaults

    c = small(["ring:3", "star:4"])
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        # the one worker may hold both tasks when star:4 kills it (under load ring:3 is still
        # running): the error names a task the dead worker held, and says how to resume
        with pytest.raises(ClusterError, match=r"worker died while computing task "
                           r"'(star:4|ring:3)@standard'.*--resume"):
            run_sweep(c, tmp_path / "r", n_workers=1, timeout=30, task_fn=_dies_on_star)
    assert not (tmp_path / "r" / "results.csv").exists()
    run_sweep(c, tmp_path / "r", n_workers=0, resume=True)
    assert len(read_results(tmp_path / "r" / "results.csv")) == 2


def test_a_local_cluster_beside_another_one_warns_nothing(tmp_path):
    """Dask's default HTTP port (8787) taken, as by any other cluster running on the machine
    (another sweep, a parallel test run): the sweep's cluster takes a free port silently, with
    no "Port 8787 is already in use" warning on stderr (which broke the one-line rule)."""
    import socket
    import warnings

    holder = socket.socket()
    try:
        try:
            holder.bind(("", 8787))  # already taken by someone else: the same situation
            holder.listen()
        except OSError:
            pass
        rows: list[dict[str, str]] = []
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            from formsync_design.sweep.executor import execute

            execute([{"task": "a"}, {"task": "b"}], rows.append, scheduler=None, n_workers=1,
                    timeout=HANG_GUARD, task_fn=_echo)
    finally:
        holder.close()
    assert sorted(r["task"] for r in rows) == ["a!", "b!"]


def _echo(task):
    return {"task": task["task"] + "!"}


def test_unreachable_scheduler_exits_3_malformed_address_exits_2(tmp_path, capsys):
    base = ["sweep", "--graphs", "ring:3", "--timeout", "1", "--out", str(tmp_path / "r")]
    assert main([*base, "--scheduler", "tcp://127.0.0.1:9"]) == 3
    err = capsys.readouterr().err
    one_line_error(err)
    assert "could not reach the Dask scheduler" in err and "--timeout" in err
    for bad in ("tcp//127.0.0.1:8786", "tcp://127.0.0.1:99999", "not an address"):
        assert main([*base, "--scheduler", bad]) == 2
        err = capsys.readouterr().err
        one_line_error(err)
        assert "scheduler address" in err or "port" in err
    assert not (tmp_path / "r").exists()


# ---------------------------------------------------------------------------
# limits
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("argv, words", [
    (["--graphs", "ring:100000000"], "at most 2000 spacecraft"),
    (["--graphs", "ring:4..100000000"], "at most 100000 values"),
    (["--graphs", "random:8:0.5:0..99999", "--graphs", "random:9:0.5:0..99999"],
     "at most 100000 tasks"),
    (["--graphs", "ring:3..20", "--mc-runs", "1000000"], "at most 10000000 Monte-Carlo"),
    (["--graphs", "ring:3", "--workers", "100000"], "workers in 0..256"),
])
def test_sizes_that_cannot_fit_are_refused_up_front(tmp_path, capsys, argv, words):
    workers = [] if "--workers" in argv else ["--workers", "0"]
    rc = main(["sweep", *argv, *workers, "--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert rc == 2 and words in err, err
    one_line_error(err)
    assert not (tmp_path / "r").exists()


# ---------------------------------------------------------------------------
# one specification, end to end
# ---------------------------------------------------------------------------
VARIANT = '''"""The paper's design with the damping gain doubled (K_o -> 2 K_o everywhere)."""
NAME = "doubled-ko"
TITLE = "K_o doubled"


def controller(v):
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - 2 * v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def lyapunov(v):
    c = (v.K_q + 2 * v.beta * v.K_o) / 4
    return (
        c * sum((e.dot(e) for e in v.edges), 0)
        + v.qd.dot(v.qd) / 2
        + v.beta * sum((e.dot(v.qd) for e in v.edges), 0)
    )
'''


def _closed_form(h: nx.Graph, ko: Fraction, kq: Fraction, beta: Fraction) -> bool:
    lmax = float(np.sort(nx.laplacian_spectrum(h))[-1])
    lmax_q = Fraction(round(lmax))
    assert abs(lmax - float(lmax_q)) < 1e-9  # integer spectra for the graphs used
    m = max(d for _, d in h.degree())
    return ko > beta * lmax_q and kq + beta * ko > 2 * m * beta**2


def test_spec_reaches_the_sweep_from_the_flag_and_from_the_campaign_file(tmp_path, capsys):
    spec = tmp_path / "specs" / "doubled.py"
    spec.parent.mkdir()
    spec.write_text(VARIANT)
    graphs = ["ring:8", "star:6", "complete:5", "complete:8"]  # integer Laplacian spectra
    flags = ["sweep", *sum((["--graphs", g] for g in graphs), []), "--resolution", "2",
             "--design-betas", "2", "--workers", "0", "--no-progress"]
    assert main([*flags, "--out", str(tmp_path / "paper")]) == 0
    assert main([*flags, "--spec", str(spec), "--out", str(tmp_path / "flag")]) == 0
    ko, kq, beta = Fraction("1.6"), Fraction("0.4"), Fraction("0.3")
    paper = read_results(tmp_path / "paper" / "results.csv")
    variant = read_results(tmp_path / "flag" / "results.csv")
    for rp, rv in zip(paper, variant):
        h = nx.Graph([tuple(map(int, e.split("-"))) for e in rp["edge_list"].split()])
        assert rp["ref_status"] == ("certified" if _closed_form(h, ko, kq, beta) else "refuted")
        assert rv["ref_status"] == ("certified" if _closed_form(h, 2 * ko, kq, beta) else "refuted")
    assert [r["ref_status"] for r in paper] != [r["ref_status"] for r in variant]
    # the folder of one specification is refused for another (nothing overwritten)
    before = (tmp_path / "paper" / "results.csv").read_bytes()
    capsys.readouterr()
    assert main([*flags, "--spec", str(spec), "--out", str(tmp_path / "paper"), "--overwrite"]) == 2
    assert "different campaign" in capsys.readouterr().err
    assert (tmp_path / "paper" / "results.csv").read_bytes() == before
    # a campaign file's spec is relative to the campaign file (run from another folder)
    camp = tmp_path / "specs" / "c.toml"
    camp.write_text('[campaign]\nname = "v"\ngraphs = ' + json.dumps(graphs)
                    + '\nspec = "doubled.py"\n[region]\nresolution = 2\n[design]\nbetas = 2\n')
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(["sweep", "--campaign", str(camp), "--workers", "0", "--no-progress",
                     "--trust-design", str(spec), "--out", "fromfile"]) == 0
    finally:
        os.chdir(cwd)
    fromfile = read_results(tmp_path / "fromfile" / "results.csv")
    assert [r["ref_status"] for r in fromfile] == [r["ref_status"] for r in variant]
    man = json.loads((tmp_path / "fromfile" / "manifest.json").read_text())
    assert man["spec"]["name"] == "doubled-ko"
    # design code that is not shipped is named, with its hash, in the manifest and the summary
    sha = hashlib.sha256(spec.read_bytes()).hexdigest()
    assert man["design_code"] == [{"path": str(spec), "sha256": sha}]
    assert f"(sha256 `{sha}`)" in (tmp_path / "fromfile" / "summary.md").read_text()
    assert "design_code" not in json.loads((tmp_path / "paper" / "manifest.json").read_text())
    # --spec and a campaign spec together are ambiguous
    capsys.readouterr()
    assert main(["sweep", "--campaign", str(camp), "--spec", str(spec), "--workers", "0",
                 "--out", str(tmp_path / "both")]) == 2
    one_line_error(capsys.readouterr().err)


def test_spec_content_not_path_is_hashed(tmp_path):
    from formsync_design.sweep import campaign_hash, expand_graphs

    spec = tmp_path / "s.py"
    spec.write_text(VARIANT)
    doc = {"campaign": {"name": "t", "graphs": ["ring:4"], "spec": "s.py"}}
    c = campaign_from_dict(doc, spec_dir=tmp_path)
    gs, _ = expand_graphs(c.graphs)
    h1 = campaign_hash(c, gs)
    spec.write_text(VARIANT.replace("2 * v.K_o", "3 * v.K_o"))
    assert campaign_hash(c, gs) != h1
    spec.write_text(VARIANT)
    assert campaign_hash(c, gs) == h1
    assert campaign_hash(campaign_from_dict({"campaign": {"name": "t", "graphs": ["ring:4"]}}),
                         gs) != h1


# ---------------------------------------------------------------------------
# bad input: one line, exit 2
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("name, data", [
    ("c.toml", b"\x00\x01binary\xff"),
    ("c.toml", '[campaign]\nname = "caf\u00e9"\n'.encode("latin-1")),
])
def test_binary_or_non_utf8_campaign_file(tmp_path, capsys, name, data):
    f = tmp_path / name
    f.write_bytes(data)
    rc = main(["sweep", "--campaign", str(f), "--workers", "0", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and str(f) in err, err
    one_line_error(err)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name, data", [
    ("g.txt", b"1 2\n\x00\x00\xff\xfe"),
    ("g.edges", "1 2\n# \u00e9\n".encode("latin-1")),
    ("g.csv", "0,1\n1,0\n# \u00e9\n".encode("latin-1")),
    ("g.csv", b"0,0.5\n0.5,0\n"),
])
def test_bad_graph_files_through_the_cli(tmp_path, capsys, name, data):
    f = tmp_path / name
    f.write_bytes(data)
    rc = main(["sweep", "--graphs", str(f), "--workers", "0", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2, err
    one_line_error(err)
    assert not (tmp_path / "o").exists()


def test_unreadable_out_and_campaign_paths_are_one_line(tmp_path, capsys):
    d = tmp_path / "dir.toml"
    d.mkdir()
    rc = main(["sweep", "--campaign", str(d), "--workers", "0", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2
    one_line_error(err)
    f = tmp_path / "file"
    f.write_text("x")
    rc = main(["sweep", "--graphs", "ring:3", "--workers", "0", "--out", str(f)])
    err = capsys.readouterr().err
    assert rc == 2 and "results folder" in err
    one_line_error(err)
    rc = main(["sweep", "--graphs", "ring:3", "--workers", "0", "--out", str(f / "sub")])
    err = capsys.readouterr().err
    assert rc == 2 and "under the file" in err
    one_line_error(err)
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        rc = main(["sweep", "--graphs", "ring:3", "--workers", "0", "--out", str(ro / "o")])
        err = capsys.readouterr().err
        assert rc == 2 and "not writable" in err
        one_line_error(err)


def test_sweep_library_never_selects_a_backend(tmp_path):
    import re

    import matplotlib

    from formsync_design.sweep import plot_fraction

    src = "\n".join(p.read_text() for p in (ROOT / "formsync_design" / "sweep").glob("*.py"))
    assert not re.search(r"^\s*(import matplotlib\.pyplot|from matplotlib import pyplot|"
                         r"matplotlib\.use\()", src, re.M)
    old = matplotlib.rcParams["backend"]
    matplotlib.rcParams["backend"] = "svg"
    try:
        fig = plot_fraction([{"box": "b", "lambda_max": "4", "frac_certified": "0.5",
                              "ref_status": "certified"}], "lambda_max")
        fig.savefig(tmp_path / "f.png")
        assert matplotlib.rcParams["backend"] == "svg"
    finally:
        matplotlib.rcParams["backend"] = old
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"


def test_campaign_boxes_are_gain_boxes():
    from formsync_design.gains import GainBox

    c = small(["ring:3"], box=[{"name": "b", "K_o": ["1/3", 2], "K_q": 0.4, "beta": [0.1, 0.3]}])
    b = c.boxes[0]
    assert isinstance(b.box, GainBox) and b.box["K_o"].lo == Fraction(1, 3)
    assert b.to_dict() == {"name": "b", "K_o": ["1/3", "2"], "K_q": ["2/5", "2/5"],
                           "beta": ["1/10", "3/10"]}
    with pytest.raises(InputError):
        small(["ring:3"], box=[{"name": "b", "K_o": [2, 1], "K_q": 0.4, "beta": 0.3}])


# ---------------------------------------------------------------------------
# any design: a sweep of the PD baseline (pd_consensus: gains k_p, k_d, multiplier eps)
# ---------------------------------------------------------------------------
# Independent truth: the same questions asked graph by graph through `formsync certify`,
# `formsync region`, `formsync design` and `formsync montecarlo --design pd_consensus`
# (the command-line paths, which build their own boxes, multiplier searches and formations),
# and the multiplier value a certified row reports re-checked by `formsync certify` with that
# value given (no search).
PD_GRAPHS = ("ring:4", "star:5", "complete:4")
PD_BOX = ("k_p=0.1:3", "k_d=0.0001:2")  # k_d near 0 needs eps below the grid: undecided cells
PD_FLAGS = ["sweep", "--design", "pd_consensus", *sum((["--graphs", g] for g in PD_GRAPHS), []),
            *sum((["--gain", b] for b in PD_BOX), []), "--resolution", "4", "--design-betas", "3",
            "--workers", "0", "--no-progress"]


@pytest.fixture(scope="module")
def pd_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("pd") / "r"
    assert main([*PD_FLAGS, "--out", str(out)]) == 0
    return out


def _json(capsys, argv: list[str]) -> tuple[int, dict]:
    capsys.readouterr()
    rc = main([*argv, "--format", "json"])
    return rc, json.loads(capsys.readouterr().out)


def _cell(x) -> str:
    from formsync_design.sweep.schema import fmt_cell

    return fmt_cell(Fraction(x) if isinstance(x, str) else x)


def test_pd_sweep_rows_equal_certify_region_design_graph_by_graph(pd_sweep, capsys, tmp_path):
    rows = read_results(pd_sweep / "results.csv")
    header = (pd_sweep / "results.csv").read_text().splitlines()[0].split(",")
    assert [c for c in header if "k_p" in c or "eps" in c] == [
        "box_k_p_lo", "box_k_p_hi", "ref_k_p", "ref_cert_eps", "rec_k_p", "rec_cert_eps",
        "cbox_k_p_lo", "cbox_k_p_hi"]
    assert not [c for c in header if "K_o" in c or "beta" in c]
    assert [r["graph"] for r in rows] == list(PD_GRAPHS)
    gains = [f"--gain={g}" for g in PD_BOX]
    for r in rows:
        g = r["graph"]
        # the reference point (the design's shipped case: k_p = 0.4, k_d = 1.6), eps searched
        assert (r["ref_k_p"], r["ref_k_d"]) == ("0.4", "1.6")
        rc, cert = _json(capsys, ["certify", "--design", "pd_consensus", "--graph", g,
                                  "--gain", "k_p=0.4", "--gain", "k_d=1.6"])
        assert r["ref_status"] == cert["status"] == "certified" and rc == 0
        assert r["ref_margin"] == _cell(cert["certified_margin"])
        assert r["ref_cert_eps"] == _cell(cert["box"]["eps"][0]) == _cell(cert["box"]["eps"][1])
        # the evidence: that eps value, given (no search), certifies the reference point
        rc, fixed = _json(capsys, ["certify", "--design", "pd_consensus", "--graph", g,
                                   "--gain", "k_p=0.4", "--gain", "k_d=1.6",
                                   "--gain", f"eps={r['ref_cert_eps']}"])
        assert rc == 0 and fixed["status"] == "certified"
        # the region of the box, eps searched per cell
        rc, reg = _json(capsys, ["region", "--design", "pd_consensus", "--graph", g, *gains,
                                 "--resolution", "4", "--out", str(tmp_path / g.replace(":", "_"))])
        fr = reg["maps"][0]["fractions"]
        for k in ("certified", "refuted", "undecided"):
            assert r[f"frac_{k}"] == _cell(fr[k]), (g, k)
        assert r["frac_refuted"] == "0" and 0 < float(r["frac_undecided"]) < 1
        # the recommended gains: k_p, k_d optimized, eps swept (3 values) and held in the box
        rc, des = _json(capsys, ["design", "--design", "pd_consensus", "--graph", g, *gains,
                                 "--betas", "3"])
        assert r["design_status"] == des["status"] == "designed"
        for k in ("k_p", "k_d"):
            assert r[f"rec_{k}"] == _cell(des["gains_exact"][k])
            lo, hi = des["largest_certified_box"][k]
            assert (r[f"cbox_{k}_lo"], r[f"cbox_{k}_hi"]) == (_cell(lo), _cell(hi))
        assert r["rec_cert_eps"] == _cell(des["gains_exact"]["eps"])
        assert des["largest_certified_box"]["eps"] == [float(Fraction(r["rec_cert_eps"]))] * 2
        assert r["rec_margin"] == _cell(des["certified_margin"])
        assert r["cbox_status"] == des["box_certificate"]["status"] == "certified"
    md = (pd_sweep / "summary.md").read_text()
    assert "- design: `pd_consensus`" in md and "reference gains: k_p = 0.4, k_d = 1.6" in md
    assert "| ref_cert_eps |" in md and "3 eps values" in md
    man = json.loads((pd_sweep / "manifest.json").read_text())
    assert man["spec"]["name"] == "pd_consensus" and man["columns"] == header
    assert man["campaign"]["boxes"][0] == {"name": "standard", "k_p": ["1/10", "3"],
                                           "k_d": ["1/10000", "2"]}


def test_pd_campaign_file_journal_and_resume_on_dask(pd_sweep, tmp_path):
    """A PD campaign file (`[campaign] design`), killed after one task, resumed on a local
    Dask cluster: the rows of the uninterrupted serial run from the command-line flags."""
    camp = tmp_path / "pd.toml"
    camp.write_text('[campaign]\nname = "pd"\ndesign = "pd_consensus"\ngraphs = '
                    + json.dumps(list(PD_GRAPHS))
                    + '\n[[box]]\nname = "standard"\nk_p = [0.1, 3]\nk_d = [0.0001, 2]\n'
                    '[region]\nresolution = 4\n[design]\nbetas = 3\n')
    from formsync_design.sweep import load_campaign

    c = load_campaign(camp)
    assert c.schema.box == ("k_p", "k_d") and c.schema.multipliers == ("eps",)
    out = tmp_path / "r"

    def dies_on_second(task, _n=[0]):  # noqa: B006 - a call counter
        if _n[0] == 1:
            raise RuntimeError("simulated kill")
        _n[0] += 1
        return run_task(task)

    with pytest.raises(FormsyncError, match="simulated kill"):
        run_sweep(c, out, n_workers=0, task_fn=dies_on_second)
    lines = (out / "journal.jsonl").read_text().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["task"] == "ring:4@standard"
    assert not (out / "results.csv").exists()
    res = run_sweep(c, out, n_workers=1, resume=True, timeout=60)
    assert res.reused == 1 and res.computed == 2
    assert (out / "results.csv").read_bytes() == (pd_sweep / "results.csv").read_bytes()
    assert not (out / "journal.jsonl").exists()


def test_pd_undecided_reference_is_never_refuted():
    """k_d = 0.0005 needs eps below its declared grid: every value tried fails, which refutes
    those candidates only, so the reference is undecided and no evidence is reported."""
    c = campaign_from_dict({"campaign": {"name": "u", "graphs": ["ring:4"], "design": "pd_consensus"},
                            "reference": {"k_p": 1, "k_d": 0.0005},
                            "box": {"name": "b", "k_p": [0.5, 1], "k_d": [0.0005, 0.001]},
                            "region": {"resolution": 1}, "design": {"betas": 1}})
    from formsync_design.sweep import build_tasks, expand_graphs

    gs, _ = expand_graphs(c.graphs)
    r = run_task(build_tasks(c, gs)[0])
    assert r["ref_status"] == "undecided"
    assert r["ref_cert_eps"] == r["ref_margin"] == r["ref_refuted_by"] == ""
    assert r["frac_refuted"] == "0" and r["frac_certified"] == "0"


@pytest.mark.slow
def test_pd_montecarlo_equals_formsync_montecarlo(tmp_path, capsys):
    argv = ["sweep", "--design", "pd_consensus", "--graphs", "ring:4", "--resolution", "1",
            "--design-betas", "1", "--mc-runs", "3", "--mc-tf", "100", "--mc-case", "pd_consensus",
            "--workers", "0", "--no-progress", "--out", str(tmp_path / "r")]
    assert main(argv) == 0
    (r,) = read_results(tmp_path / "r" / "results.csv")
    rc, mc = _json(capsys, ["montecarlo", "--case", "pd_consensus", "--gain", "k_p=0.4",
                            "--gain", "k_d=1.6", "--runs", "3", "--seed", "0", "--tf", "100",
                            "--step", "0.1", "--output-step", "0.5", "--no-certify",
                            "--threads", "1"])
    assert r["mc_status"] == "ran" and r["mc_runs"] == "3"
    assert r["mc_converged"] == str(mc["counts"]["converged"]) == "3"
    for k in ("median", "p95", "max"):
        assert r[f"mc_conv_time_{k}"] == _cell(mc["convergence_time"][k])


@pytest.mark.parametrize("argv, words", [
    (["--gain", "K_o=1:2"], "design pd_consensus (k_p, k_d) in --gain, received unknown ['K_o']"),
    (["--gain", "eps=0.1:1"], "received eps (a multiplier of the Lyapunov candidate"),
    (["--ko", "1:2"], "in --ko, received unknown ['K_o']"),
    (["--ref", "0.4"], "expected --ref k_p,k_d (2 numbers"),
    (["--ref", "k_p=0.4"], "missing ['k_d']"),
    (["--ref", "k_p=0.4,beta=1"], "in --ref, received unknown ['beta']"),
    (["--conditions", "paper"], "conditions are liang2016's"),
    (["--mc-runs", "2", "--mc-case", "nope"], "no such file"),
])
def test_pd_flags_bad_input_is_one_line_exit_2(tmp_path, capsys, argv, words):
    out = tmp_path / "o"
    rc = main(["sweep", "--design", "pd_consensus", "--graphs", "ring:4", *argv, "--workers", "0",
               "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and words in err, err
    one_line_error(err)
    assert not out.exists()


TWO_GAINS = '''"""PD without a cross term: two box dimensions, nothing for the design stage to sweep."""
GAINS = {"k_p": {"range": "0.1:2"}, "k_d": {"range": "0.5:3"}}


def controller(v):
    return v.Q.I.T * ((v.B - v.k_d * v.A) * v.qd - v.k_p * v.A * v.s)


def lyapunov(v):
    return v.k_p / 4 * sum((e.dot(e) for e in v.edges), 0) + v.qd.dot(v.qd) / 2
'''


@pytest.mark.parametrize("toml, words", [
    ('[[box]]\nname = "b"\nk_p = [0.1, 1]\n', "expected k_d = [lo, hi] in [[box]] 'b'"),
    ('[[box]]\nname = "b"\nk_p = [0.1, 1]\nk_d = [1, 2]\nK_o = [1, 2]\n', "received unknown ['K_o']"),
    ('[[box]]\nname = "b"\nk_p = [0.1, 1]\nk_d = [1, 2]\neps = [0.1, 0.2]\n', "received eps (a multiplier"),
    ('[reference]\nK_o = 1.6\nK_q = 0.4\nbeta = 0.3\n', "in [reference], received unknown"),
    ('[reference]\nk_p = 0.4\n', "expected k_d in [reference]"),
    ('[montecarlo]\nruns = 2\nK_v = 0.01\n', "no montecarlo.K_v for design pd_consensus"),
])
def test_pd_campaign_file_bad_input_is_one_line_exit_2(tmp_path, capsys, toml, words):
    f = tmp_path / "c.toml"
    f.write_text('[campaign]\nname = "c"\ngraphs = ["ring:4"]\ndesign = "pd_consensus"\n' + toml)
    rc = main(["sweep", "--campaign", str(f), "--workers", "0", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and words in err, err
    one_line_error(err)
    assert not (tmp_path / "o").exists()


def test_designs_a_sweep_cannot_run_and_unknown_designs_are_one_line(tmp_path, capsys):
    two = tmp_path / "two.py"
    two.write_text(TWO_GAINS)
    for design, words in ((str(two), "three box dimensions"), ("nope", "expected a design name")):
        rc = main(["sweep", "--design", design, "--graphs", "ring:4", "--workers", "0",
                   "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert rc == 2 and words in err, err
        one_line_error("".join(ln for ln in err.splitlines(True)  # the design-code line aside
                               if "design code that is not shipped" not in ln))
    f = tmp_path / "c.toml"
    f.write_text('[campaign]\nname = "c"\ngraphs = ["ring:4"]\ndesign = "pd_consensus"\n')
    rc = main(["sweep", "--campaign", str(f), "--design", "liang2016", "--workers", "0",
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and "expected one design" in err, err
    one_line_error(err)
    assert not (tmp_path / "o").exists()


def test_liang2016_keeps_its_flags_columns_and_campaign_hash():
    """The old flag names and campaign files: the committed atlas6 manifest's hash."""
    from formsync_design.sweep import campaign_hash, expand_graphs, load_campaign
    from formsync_design.sweep.schema import COLUMNS

    man = json.loads((ROOT / "reports" / "sweep-atlas6" / "manifest.json").read_text())
    c = load_campaign(ROOT / "verification" / "sweep_atlas6.toml")
    gs, _ = expand_graphs(c.graphs)
    assert campaign_hash(c, gs) == man["sha256"] and tuple(man["columns"]) == COLUMNS
    assert c.schema.columns == COLUMNS
    assert campaign_hash(load_campaign(ROOT / "verification" / "sweep_atlas6.toml",
                                       spec="liang2016"), gs) == man["sha256"]


def test_compare_with_another_sweep_matches_graphs_up_to_relabelling(tmp_path, capsys):
    """liang2016's reference gains are refuted on star:6 (exactly checked witness), the PD
    baseline's are certified: the comparison finds star:6 in the other sweep even with its
    centre relabelled, and its content is part of the campaign hash."""
    base = tmp_path / "liang"
    assert main(["sweep", "--graphs", "star:6", "--graphs", "ring:4", "--resolution", "1",
                 "--design-betas", "1", "--workers", "0", "--no-progress", "--out", str(base)]) == 0
    star = tmp_path / "star6.txt"
    star.write_text("".join(f"6 {i}\n" for i in range(1, 6)))  # the centre is spacecraft 6
    camp = tmp_path / "pd.toml"
    # the campaign names its graph file and the compared sweep beside it (a data file's paths
    # stay inside its folder)
    camp.write_text('[campaign]\nname = "pd"\ndesign = "pd_consensus"\ngraphs = ["'
                    + star.name + '", "path:3"]\ncompare = "' + base.name
                    + '"\n[region]\nresolution = 1\n[design]\nbetas = 1\n')
    assert main(["sweep", "--campaign", str(camp), "--workers", "0", "--no-progress",
                 "--out", str(tmp_path / "pd")]) == 0
    md = (tmp_path / "pd" / "summary.md").read_text()
    assert "## Compared with `liang2016`" in md and "1 of 2 graphs of this campaign" in md
    assert "| 6 | 1 | 1 | 0 | 0 | 1 | 0 | 0 |" in md
    assert "Certified for `pd_consensus` only: `file:star6.txt` (= `star:6`, liang2016 refuted" in md
    from formsync_design.sweep import campaign_hash, expand_graphs, load_campaign

    c = load_campaign(camp)
    gs, _ = expand_graphs(c.graphs, base=Path(c.base), source=c.source)
    h = campaign_hash(c, gs)
    res = base / "results.csv"
    res.write_text(res.read_text().replace(",refuted,", ",certified,"))
    assert campaign_hash(c, gs) != h
    capsys.readouterr()
    camp.write_text(camp.read_text().replace(f'compare = "{base.name}"', 'compare = "nowhere"'))
    assert main(["sweep", "--campaign", str(camp), "--workers", "0", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "finished sweep folder" in err
    one_line_error(err)
    assert not (tmp_path / "x").exists()
