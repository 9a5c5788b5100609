"""Where the shipped designs and cases live.

The human-facing sources are the top-level folders ``derivations/`` (design
specifications and printed expressions) and ``verification/`` (published
cases and their claims).  The build maps them into the package namespace as
``formsync_design.derivations`` and ``formsync_design.verification``
(``[tool.setuptools.package-dir]`` in ``pyproject.toml``), so a wheel, a
normal install and an editable install all find them through
:mod:`importlib.resources`.

>>> design_file("liang2016").name
'liang2016.py'
>>> sorted(case_names())[:1]
['liang2016']
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from formsync_design.errors import InputError, PackagingError

__all__ = ["design_file", "case_file", "design_names", "case_names"]

_DESIGNS = "formsync_design.derivations"
_CASES = "formsync_design.verification"


def _folder(package: str) -> Path:
    try:
        root = resources.files(package)
    except ModuleNotFoundError as e:
        raise PackagingError(
            f"expected the data package {package} in this installation, received none "
            f"({e}); reinstall formsync-design"
        ) from None
    path = Path(str(root))
    if not path.is_dir():
        raise PackagingError(
            f"expected {package} as a folder on disk, received {root!r}; reinstall formsync-design"
        )
    return path


def _file(package: str, name: str, suffix: str, kind: str, names: list[str]) -> Path:
    path = _folder(package) / f"{name}{suffix}"
    if not path.is_file():
        raise InputError(f"expected a {kind} name in {sorted(names)}, received {name!r}")
    return path


def design_names() -> list[str]:
    """Names of the shipped design specifications (``derivations/*.py``)."""
    return sorted(
        p.stem
        for p in _folder(_DESIGNS).glob("*.py")
        if not p.stem.startswith("_") and not p.stem.endswith("_printed")
    )


def case_names() -> list[str]:
    """Names of the shipped verification cases (``verification/*.toml`` with a ``[case]``)."""
    return sorted(p.stem for p in _folder(_CASES).glob("*.toml") if not p.stem.startswith("sweep"))


def design_file(name: str) -> Path:
    """Path of the shipped design specification ``NAME`` (or ``NAME_printed``)."""
    return _file(_DESIGNS, name, ".py", "design", design_names())


def case_file(name: str) -> Path:
    """Path of the shipped case file ``NAME.toml``."""
    return _file(_CASES, name, ".toml", "case", case_names())
