"""Where the shipped designs and cases live.

The human-facing sources are the top-level folders ``derivations/`` (design
specifications and printed expressions) and ``verification/`` (published
cases and their claims).  The build maps them into the package namespace as
``formsync_design.derivations`` and ``formsync_design.verification``
(``[tool.setuptools.package-dir]`` in ``pyproject.toml``), so a wheel, a
normal install and an editable install all find them through
:mod:`importlib.resources`.

The package itself refers to a few of these files (the paper's design is the
default specification, its printed expressions are compared with the
derivation, its case is the default of ``formsync verify``): an installation
without one of them is broken, and every look-up says so with a
:class:`~formsync_design.errors.PackagingError` (exit status 3), not with a
message that blames the user's input.

>>> design_file("liang2016").name
'liang2016.py'
>>> "liang2016" in case_names()
True
>>> [p.name for p in check_installation()][:2]
['liang2016.py', 'liang2016_printed.py']
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from formsync_design.errors import InputError, PackagingError

__all__ = [
    "DESIGNS_PACKAGE",
    "CASES_PACKAGE",
    "REQUIRED_FILES",
    "design_file",
    "case_file",
    "design_names",
    "case_names",
    "check_installation",
]

DESIGNS_PACKAGE = "formsync_design.derivations"
CASES_PACKAGE = "formsync_design.verification"

#: Data files the package itself refers to, per data package: an installation
#: lacking one is a packaging error, not a user's mistake.
REQUIRED_FILES: dict[str, tuple[str, ...]] = {
    DESIGNS_PACKAGE: ("liang2016.py", "liang2016_printed.py"),
    CASES_PACKAGE: ("liang2016.toml",),
}


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
            f"expected {package} as a folder on disk, received {str(root)!r}; "
            "reinstall formsync-design"
        )
    missing = [name for name in REQUIRED_FILES.get(package, ()) if not (path / name).is_file()]
    if missing:
        raise PackagingError(
            f"expected the shipped file(s) {', '.join(missing)} in {path} ({package}), "
            "received none; this installation is incomplete: reinstall formsync-design "
            "(from a source checkout, check [tool.setuptools] in pyproject.toml)"
        )
    return path


def _file(package: str, name: str, suffix: str, kind: str, names: list[str]) -> Path:
    path = _folder(package) / f"{name}{suffix}"
    if not path.is_file():
        raise InputError(f"expected a {kind} name in {sorted(names)}, received {name!r}")
    return path


def design_names() -> list[str]:
    """Names of the shipped design specifications (``derivations/*.py``).

    Printed-expression files (``NAME_printed.py``) and private modules are
    not designs.

    >>> "liang2016" in design_names(), "liang2016_printed" in design_names()
    (True, False)
    """
    return sorted(
        p.stem
        for p in _folder(DESIGNS_PACKAGE).glob("*.py")
        if not p.stem.startswith("_") and not p.stem.endswith("_printed")
    )


def case_names() -> list[str]:
    """Names of the shipped verification cases (``verification/*.toml``, sweeps excluded).

    >>> "liang2016" in case_names()
    True
    """
    return sorted(
        p.stem for p in _folder(CASES_PACKAGE).glob("*.toml") if not p.stem.startswith("sweep")
    )


def design_file(name: str) -> Path:
    """Path of the shipped design specification ``NAME`` (or ``NAME_printed``).

    >>> design_file("liang2016_printed").name
    'liang2016_printed.py'
    >>> design_file("nope")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a design name in [...], received 'nope'
    """
    return _file(DESIGNS_PACKAGE, name, ".py", "design", design_names())


def case_file(name: str) -> Path:
    """Path of the shipped case file ``NAME.toml``.

    >>> case_file("liang2016").suffix
    '.toml'
    """
    return _file(CASES_PACKAGE, name, ".toml", "case", case_names())


def check_installation() -> list[Path]:
    """Check that every data file the package refers to is installed; return them all.

    Returns the paths of every shipped data file (designs, printed
    expressions, cases, sweep campaigns), required ones first.  Raises
    :class:`~formsync_design.errors.PackagingError` naming the missing file
    when the installation is incomplete.  ``python -m formsync_design.resources``
    runs it (the CI's installed-wheel check).

    >>> paths = check_installation()
    >>> all(p.is_file() for p in paths), paths[0].name
    (True, 'liang2016.py')
    """
    found: list[Path] = []
    for package, required in REQUIRED_FILES.items():
        folder = _folder(package)
        found.extend(folder / name for name in required)
        found.extend(
            sorted(
                p
                for p in folder.iterdir()
                if p.is_file() and p.suffix in (".py", ".toml") and p.name not in required
                and not p.name.startswith("_")
            )
        )
    return found


if __name__ == "__main__":  # pragma: no cover - the CI's installed-wheel check
    import sys

    try:
        for _path in check_installation():
            print(_path)
    except PackagingError as _e:
        sys.stderr.write(f"formsync-design: error: {_e}\n")
        raise SystemExit(3) from None
