"""The package ships its data files in every kind of install (issue 9, item 5).

Independent truth: the *source tree* (every module under ``formsync_design/``
and every file under ``derivations/`` and ``verification/``) is compared with
what setuptools actually builds from ``pyproject.toml`` (its ``build_py``
step, which is what a wheel contains), and the built package is imported in
a fresh interpreter, outside the checkout, to find every shipped resource.
A data file that the build drops, or a new subpackage missing from
``[tool.setuptools] packages``, fails here.  The full wheel (build, install
into a fresh venv, run the CLI) is a stage of ``.ci/run`` and the slow test
below.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

import formsync_design
from formsync_design import resources
from formsync_design.errors import PackagingError

ROOT = Path(__file__).resolve().parents[1]
DATA_DIRS = {"derivations": "formsync_design/derivations",
             "verification": "formsync_design/verification"}


def _source_files() -> set[str]:
    """Paths (inside an installed package) that the source tree says must ship."""
    out = {
        p.relative_to(ROOT).as_posix()
        for p in (ROOT / "formsync_design").rglob("*.py")
        if "__pycache__" not in p.parts
    }
    out.add("formsync_design/py.typed")  # PEP 561: the package's annotations are public
    out |= {p.relative_to(ROOT).as_posix()  # the C drivers the package compiles at run time
            for p in (ROOT / "formsync_design").rglob("*.c")}
    for src, dest in DATA_DIRS.items():
        for p in (ROOT / src).rglob("*"):
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc":
                out.add(f"{dest}/{p.relative_to(ROOT / src).as_posix()}")
    return out


def _copy_sources(dest: Path) -> Path:
    """Copy what a source distribution holds (not .venv, build/, reports/) to ``dest``."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, dest / name)
    for name in ("formsync_design", *DATA_DIRS):
        shutil.copytree(ROOT / name, dest / name, ignore=ignore)
    return dest


@pytest.fixture(scope="module")
def built_lib(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The package as setuptools builds it for a wheel (``build_py``), offline."""
    src = _copy_sources(tmp_path_factory.mktemp("src"))
    lib = tmp_path_factory.mktemp("lib")
    proc = subprocess.run(
        [sys.executable, "-c", "from setuptools import setup; setup()", "-q",
         "build_py", "--build-lib", str(lib)],
        cwd=src, capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    return lib


def _run_outside(lib: Path, code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("FORMSYNC_TRACEBACK")}
    env["PYTHONPATH"] = str(lib)  # ahead of the editable install's finder
    env["MPLBACKEND"] = "Agg"
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_build_ships_every_source_and_data_file(built_lib: Path) -> None:
    built = {
        p.relative_to(built_lib).as_posix()
        for p in built_lib.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }
    expected = _source_files()
    assert "formsync_design/derivations/liang2016_printed.py" in expected  # the walk saw the data
    assert "formsync_design/verification/liang2016.toml" in expected
    missing = sorted(expected - built)
    assert not missing, f"the build drops {missing}: fix [tool.setuptools] in pyproject.toml"


def test_every_subpackage_is_listed_in_pyproject() -> None:
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))
                 ["tool"]["setuptools"]["packages"])
    found = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for p in (ROOT / "formsync_design").rglob("__init__.py")
        if "__pycache__" not in p.parts
    }
    found |= {dest.replace("/", ".") for dest in DATA_DIRS.values()}
    missing = sorted(found - listed)
    assert not missing, f"add {missing} to [tool.setuptools] packages in pyproject.toml"
    assert not sorted(listed - found), "pyproject.toml lists packages that do not exist"


def test_required_files_exist_in_the_source_tree() -> None:
    for package, names in resources.REQUIRED_FILES.items():
        src = ROOT / next(s for s, d in DATA_DIRS.items() if d == package.replace(".", "/"))
        for name in names:
            assert (src / name).is_file(), f"{package} requires {name}, absent from {src}"


CHECK = """
import sys
from pathlib import Path
import formsync_design
from formsync_design import resources
from formsync_design.spec.loader import load_design, load_spec
from formsync_design.tomlio import load_toml
from formsync_design.verify.agentcase import load_agent_case
from formsync_design.verify.case import load_case
lib = Path({lib!r})
assert Path(formsync_design.__file__).resolve().is_relative_to(lib.resolve()), formsync_design.__file__
paths = resources.check_installation()
assert all(p.resolve().is_relative_to(lib.resolve()) for p in paths), paths
print("designs", *resources.design_names())
print("cases", *resources.case_names())
print("files", *sorted(p.name for p in paths))
from formsync_design.spec.loader import load_design
from formsync_design.tomlio import load_toml
from formsync_design.verify.agentcase import load_agent_case
for name in resources.design_names():
    spec = load_design(resources.design_file(name))
    assert callable(spec.controller), name
from formsync_design.verify.enginecase import load_engine_case
for name in resources.case_names():
    load_engine_case(resources.case_file(name))
print("default-spec", Path(str(load_spec(None).path)).name)
"""


def test_built_package_finds_every_resource_outside_the_checkout(
    built_lib: Path, tmp_path: Path
) -> None:
    proc = _run_outside(built_lib, CHECK.format(lib=str(built_lib)), tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = {line.split()[0]: line.split()[1:] for line in proc.stdout.splitlines() if line.strip()}
    src_designs = sorted(p.stem for p in (ROOT / "derivations").glob("*.py")
                         if not p.stem.startswith("_") and not p.stem.endswith("_printed"))
    src_cases = sorted(p.stem for p in (ROOT / "verification").glob("*.toml")
                       if not p.stem.startswith("sweep"))
    assert lines["designs"] == src_designs
    assert lines["cases"] == src_cases
    src_files = sorted(p.name for d in DATA_DIRS for p in (ROOT / d).iterdir()
                       if p.is_file() and p.suffix in (".py", ".toml")
                       and not p.name.startswith("_"))
    assert lines["files"] == src_files
    assert lines["default-spec"] == ["liang2016.py"]


@pytest.mark.parametrize("victim", ["verification/liang2016.toml",
                                    "derivations/liang2016_printed.py"])
def test_missing_data_file_is_a_packaging_error(
    built_lib: Path, tmp_path: Path, victim: str
) -> None:
    lib = tmp_path / "lib"
    shutil.copytree(built_lib, lib)
    (lib / "formsync_design" / victim).unlink()
    code = ("import sys; from formsync_design.cli import main; "
            f"sys.exit(main(['verify', 'liang2016', '--out', {str(tmp_path / 'out')!r}]))")
    proc = _run_outside(lib, code, tmp_path)
    assert proc.returncode == 3, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr
    err = [line for line in proc.stderr.splitlines() if "error" in line]
    assert len(err) == 1 and Path(victim).name in err[0] and "reinstall" in err[0], err
    assert not (tmp_path / "out").exists()
    # building the parser reads no data file: --help works on a broken installation
    proc = _run_outside(lib, "import sys; from formsync_design.cli import main; "
                             "sys.exit(main(['--help']))", tmp_path)
    assert proc.returncode == 0 and "Exit status" in proc.stdout, proc.stderr


def test_missing_data_package_raises_packaging_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(resources.REQUIRED_FILES, resources.CASES_PACKAGE,
                        ("liang2016.toml", "no-such-case.toml"))
    with pytest.raises(PackagingError, match="no-such-case.toml"):
        resources.case_names()


def test_this_install_finds_every_source_file() -> None:
    """The running install (editable in development) sees the source tree's data files."""
    for p in (ROOT / "derivations").glob("*.py"):
        if not p.stem.startswith("_"):
            assert resources.design_file(p.stem).read_bytes() == p.read_bytes()
    for p in (ROOT / "verification").glob("*.toml"):
        if not p.stem.startswith("sweep"):
            assert resources.case_file(p.stem).read_bytes() == p.read_bytes()
    assert Path(formsync_design.__file__).parent.name == "formsync_design"


@pytest.mark.slow
def test_wheel_contains_every_file(tmp_path: Path) -> None:
    """Build the real wheel (pip, isolated build) and compare its file list with the source."""
    (tmp_path / "src").mkdir()
    src = _copy_sources(tmp_path / "src")
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "w"),
         str(src)], capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    (wheel,) = (tmp_path / "w").glob("formsync_design-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = sorted(_source_files() - names)
    assert not missing, f"the wheel lacks {missing}"
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    assert "formsync = formsync_design.cli:main" in zipfile.ZipFile(wheel).read(entry).decode()
