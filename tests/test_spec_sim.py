"""One specification end to end in simulation: the kernel follows the specification, its
caches are keyed by the specification's content, options that cannot be honoured and
compiler failures are errors with the right exit status."""

from __future__ import annotations

import json
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from formsync_design.cli.main import main
from formsync_design.errors import CompilerError, InputError, SimulationError
from formsync_design.graphs.build import make_graph
from formsync_design.models.disturbances import no_disturbance
from formsync_design.sim import ccompile, kernels, native
from formsync_design.sim.formation import MAX_GRID_POINTS, Formation, Gains, SimOptions
from formsync_design.sim.result import SimStatus
from formsync_design.sim.simulator import simulate
from formsync_design.spec.loader import Spec, load_spec

DATA = Path(__file__).parent / "data"
VARIANT = DATA / "controller_variant_spec.py"


def _formation(K_q: float = 0.4, n: int = 3) -> Formation:
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.3, 0.3, size=(n, 3))
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    J = np.array([np.diag([1.0 + i, 2.0, 1.5]) for i in range(n)])
    rates = rng.uniform(-0.05, 0.05, size=(n, 3))
    return Formation(make_graph(f"path:{n}"), J, att, rates, Gains(1.6, K_q, 0.3, (0.01,) * n),
                     no_disturbance(n))


OPT = SimOptions(tf=20.0, step=0.05, output_step=0.5, compile=False)


def test_variant_controller_is_simulated_not_the_papers():
    """The variant uses -2 K_q A s: its trajectory equals the paper's controller with 2 K_q
    (independent truth), differs from the paper's at K_q, and running it leaves the paper's
    result unchanged; the two kernels sit side by side in the memory cache."""
    paper_before = simulate(_formation(), OPT)
    variant = simulate(_formation(), OPT, spec=VARIANT)
    paper_after = simulate(_formation(), OPT)
    truth = simulate(_formation(K_q=0.8), OPT)
    assert np.abs(variant.x - paper_before.x).max() > 1e-3
    np.testing.assert_allclose(variant.x, truth.x, rtol=0, atol=1e-12)
    assert np.array_equal(paper_after.x, paper_before.x)
    assert variant.spec_key == load_spec(VARIANT).key != paper_before.spec_key
    keys = {k[0] for k in kernels.cached_kernels() if k[1] == 3}
    assert {load_spec(None).key, load_spec(VARIANT).key} <= keys


def test_inline_spec_simulates_like_the_file():
    from formsync_design.derivations import liang2016 as paper_mod  # shipped specification

    inline = Spec.from_functions(paper_mod.lagrangian_controller, paper_mod.lyapunov,
                                name="inline")  # the file's Lagrangian view
    a = simulate(_formation(), OPT, spec=inline)
    b = simulate(_formation(), OPT)
    assert inline.key != load_spec(None).key  # another content key ...
    np.testing.assert_array_equal(a.x, b.x)  # ... same controller, same trajectory


@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler")
def test_compiled_kernels_of_two_specs_cached_side_by_side_on_disk(tmp_path, monkeypatch):
    monkeypatch.setenv("FORMSYNC_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("FORMSYNC_NO_COMPILE", raising=False)
    monkeypatch.setattr(kernels, "_KERNELS", {})
    monkeypatch.setattr(native, "_NATIVE", {})
    opt = SimOptions(tf=5.0, step=0.1, output_step=0.5, compile=True)
    f = _formation(n=2)
    a = simulate(f, opt)
    first = sorted(p.name for p in (tmp_path / "kernels").glob("*.so"))
    b = simulate(f, opt, spec=VARIANT)
    both = sorted(p.name for p in (tmp_path / "kernels").glob("*.so"))
    assert a.stats["compiled"] and b.stats["compiled"]
    # one whole-horizon kernel per specification (it serves every formation size)
    assert len(first) == 1 and len(both) == 2 and set(first) < set(both)
    simulate(_formation(n=3), opt)
    assert len(list((tmp_path / "kernels").glob("*.so"))) == 2
    a2 = simulate(f, opt)  # from the caches: still the paper's
    np.testing.assert_array_equal(a2.x, a.x)
    vm = simulate(f, SimOptions(tf=5.0, step=0.1, output_step=0.5, compile=False), spec=VARIANT)
    np.testing.assert_allclose(b.x, vm.x, rtol=0, atol=1e-12)


def test_compiler_failure_is_a_compiler_error_exit_3(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("FORMSYNC_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("FORMSYNC_CC", "false")  # a compiler that always fails
    monkeypatch.delenv("FORMSYNC_NO_COMPILE", raising=False)
    monkeypatch.setattr(kernels, "_KERNELS", {})
    monkeypatch.setattr(native, "_NATIVE", {})
    with pytest.raises(CompilerError, match="FORMSYNC_NO_COMPILE=1"):
        simulate(_formation(n=2), SimOptions(tf=1.0, step=0.1, output_step=0.5))
    rc = main(["simulate", "--tf", "1", "--step", "0.1", "--output-step", "0.5"])
    err = capsys.readouterr().err.strip()
    assert rc == 3 and len(err.splitlines()) == 1 and "FORMSYNC_NO_COMPILE" in err
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")  # the remedy the message names works
    r = simulate(_formation(n=2), SimOptions(tf=1.0, step=0.1, output_step=0.5))
    assert r.stats["compiled"] is False


def test_missing_compiler_falls_back_with_a_warning(tmp_path, monkeypatch):
    monkeypatch.setenv("FORMSYNC_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("FORMSYNC_CC", raising=False)
    monkeypatch.delenv("FORMSYNC_NO_COMPILE", raising=False)
    monkeypatch.setattr(ccompile.shutil, "which", lambda name: None)
    monkeypatch.setattr(kernels, "_KERNELS", {})
    monkeypatch.setattr(native, "_NATIVE", {})
    with pytest.warns(RuntimeWarning, match="no C compiler"):
        r = simulate(_formation(n=2), SimOptions(tf=1.0, step=0.1, output_step=0.5))
    assert r.stats["compiled"] is False
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")  # chosen on purpose: silent
    monkeypatch.setattr(kernels, "_KERNELS", {})
    monkeypatch.setattr(native, "_NATIVE", {})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        simulate(_formation(n=2), SimOptions(tf=1.0, step=0.1, output_step=0.5))


def test_cli_simulate_and_montecarlo_accept_spec(capsys):
    rc = main(["simulate", "--tf", "5", "--no-compile", "--spec", str(VARIANT), "--format", "json"])
    js = json.loads(capsys.readouterr().out)
    assert rc == 1 and js["specification"] == "double-kq" and js["spec_key"] == load_spec(VARIANT).key
    rc = main(["simulate", "--tf", "5", "--no-compile", "--format", "json"])
    paper = json.loads(capsys.readouterr().out)
    assert paper["specification"] == "liang2016" and paper["final_q_m"] != js["final_q_m"]
    rc = main(["montecarlo", "--runs", "2", "--tf", "5", "--no-compile", "--no-certify",
               "--spec", str(VARIANT), "--format", "json"])
    mc = json.loads(capsys.readouterr().out)
    assert rc == 1 and mc["specification"] == "double-kq" and mc["runs"] == 2


# -- options that cannot be honoured ---------------------------------------------------


def test_step_longer_than_output_step_is_refused_not_clamped(capsys):
    with pytest.raises(InputError, match=r"step <= the output step \(0\.1 s\)"):
        SimOptions(step=100.0)
    with pytest.raises(InputError, match="sample period"):
        SimOptions(step=1.0, sample_period=0.5)
    assert SimOptions(step=0.1, output_step=0.1).substeps == 1  # equal is fine
    assert main(["simulate", "--step", "100"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--step" in err and "0.1 s" in err and len(err.splitlines()) == 1


def test_tf_must_be_a_multiple_of_the_output_step(capsys):
    with pytest.raises(InputError, match="whole multiple of the output step"):
        SimOptions(tf=10.05, output_step=0.1)
    assert main(["simulate", "--tf", "10.05"]) == 2
    assert "--tf" in capsys.readouterr().err
    SimOptions(tf=0.3, output_step=0.1)  # 0.3/0.1 in floating point is still 3 intervals


def test_grid_too_large_is_refused_with_the_limit():
    with pytest.raises(InputError, match=re.escape(f"{MAX_GRID_POINTS:g}")):
        SimOptions(tf=1e9, output_step=1.0, step=1.0)


def test_blow_up_away_from_singularity_is_a_simulation_error_exit_3():
    f = _formation(n=2)
    f = Formation(f.graph, f.inertias, f.attitudes, f.rates, Gains(5e3, 0.4, 0.3, (0.0,)), f.disturbance)
    with pytest.raises(SimulationError, match="reduce the step"):
        simulate(f, SimOptions(tf=5.0, step=0.05, compile=False))
    # the adaptive integrator resolves the stiff loop (K_o h far beyond RK4's stability)
    r = simulate(f, SimOptions(tf=0.5, compile=False))
    assert r.stats["integrator"] == "dopri5" and np.all(np.isfinite(r.x))


# -- results ------------------------------------------------------------------------------


def test_result_status_enum_and_json():
    r = simulate(_formation(), OPT)
    assert isinstance(r.status, SimStatus) and r.status == "not-converged"
    assert r.convergence_time is None and not r.stopped_early and r.stop_time == 20.0
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["status"] == "not-converged" and d["convergence_time"] is None
    assert d["options"]["torque_limit"] is None and d["singular_time"] is None


def test_singular_stop_is_explicit():
    q = np.array([[0.5, 0, 0], [0.5, 0, 0]])
    att = np.column_stack([q, np.sqrt(1 - (q**2).sum(1))])
    f = Formation(make_graph("path:2"), np.array([np.eye(3)] * 2), att, np.array([[3.0, 0, 0]] * 2),
                  Gains(1.6, 0.4, 0.3, (0.0,)), no_disturbance(2))
    r = simulate(f, SimOptions(tf=10.0, compile=False))
    assert r.status == SimStatus.SINGULAR and r.stopped_early
    assert r.convergence_time is None and r.singular_spacecraft in (1, 2)
    assert r.stop_time < 10.0 and r.singular_time is not None
    d = r.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["status"] == "singular" and d["convergence_time"] is None


def test_case_file_spec_is_used_and_spec_option_overrides_it(capsys):
    case = str(DATA / "case_with_spec.toml")
    trust = ["--trust-design", str(DATA / "case_spec_fast.py")]  # the design file it names
    assert main(["simulate", "--case", case, "--tf", "2", "--no-compile", "--format", "json",
                 *trust]) == 1
    js = json.loads(capsys.readouterr().out)
    assert js["specification"] == "case_spec_fast"
    assert js["spec_key"] == load_spec(DATA / "case_spec_fast.py").key
    assert main(["simulate", "--case", case, "--tf", "2", "--no-compile", "--format", "json",
                 "--spec", str(VARIANT), *trust]) == 1
    assert json.loads(capsys.readouterr().out)["specification"] == "double-kq"
