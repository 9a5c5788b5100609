"""Lazy public names of a package (PEP 562): one ``__getattr__`` / ``__dir__`` pair for every
package ``__init__`` that imports its public names on first use, so that ``import
formsync_design`` (and ``formsync --version``) load nothing heavy.

>>> ns = {"__all__": ["sqrt"]}
>>> getattr_, dir_ = lazy_attributes("demo", {"sqrt": "math", "tau2": ("math", "tau")}, ns)
>>> getattr_("sqrt")(4.0), "sqrt" in ns        # imported on first use, then kept
(2.0, True)
>>> round(getattr_("tau2"), 3)                  # an alias: (module, attribute)
6.283
>>> getattr_("nope")
Traceback (most recent call last):
...
AttributeError: module 'demo' has no attribute 'nope'
>>> dir_()                                     # the namespace and __all__
['__all__', 'sqrt', 'tau2']
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import import_module
from typing import Any

__all__ = ["lazy_attributes"]


def lazy_attributes(package: str, table: Mapping[str, str | tuple[str, str]],
                    namespace: dict[str, Any], *, public_only: bool = False
                    ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    Parameters
    ----------
    package : str
        The package's name (for the ``AttributeError``).
    table : mapping
        Public name -> the module defining it, or ``(module, attribute)`` for an alias.
    namespace : dict
        The package's ``globals()``: a name imported once is stored there, so the next
        access is an ordinary attribute.
    public_only : bool
        ``__dir__`` lists ``__all__`` only (else the namespace and ``__all__``).
    """

    def __getattr__(name: str) -> Any:
        target = table.get(name)
        if target is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, attr = target if isinstance(target, tuple) else (target, name)
        value = getattr(import_module(module), attr)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        public = set(namespace.get("__all__", ()))
        return sorted(public if public_only else set(namespace) | public)

    return __getattr__, __dir__
