"""The stage packages import their public names on first use (PEP 562, issue 25 item 7):
every name of their ``__all__`` resolves, and importing the packages (or the command
line's entry point) loads none of the heavy libraries."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

PACKAGES = ("formsync_design.sim", "formsync_design.verify")


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_resolves(package: str) -> None:
    mod = importlib.import_module(package)
    for name in mod.__all__:
        obj = getattr(mod, name)
        assert obj is not None
        assert getattr(obj, "__name__", name) == name or not callable(obj), name
    assert set(mod.__all__) <= set(dir(mod))
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        mod.nonsense  # noqa: B018


def test_importing_the_packages_loads_no_heavy_library() -> None:
    code = ("import sys, formsync_design, formsync_design.sim, formsync_design.verify, "
            "formsync_design.cli.main; print(sorted(m for m in ('sympy', 'cvxpy', 'scipy', "
            "'casadi', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
