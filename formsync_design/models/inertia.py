"""The one inertia validator: a 3x3 symmetric positive-definite matrix (kg m^2).

Every stage that accepts an inertia from the user (a formation, a case file,
``formsync certify --inertia``, a derivation at given inertias) checks it with
:func:`check_inertia` (one matrix) or :func:`check_inertias` (one per
spacecraft), so the messages and tolerances are the same everywhere.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formsync_design.errors import InputError

__all__ = ["check_inertia", "check_inertias", "SYMMETRY_RTOL"]

#: Relative tolerance of the symmetry check (of the largest entry's magnitude).
SYMMETRY_RTOL = 1e-12


def _where(k: int | None, src: str | None) -> str:
    out = f" for spacecraft {k}" if k is not None else ""
    return out + (f" in {src}" if src else "")


def check_inertia(J: Any, k: int | None = None, src: str | None = None) -> np.ndarray:
    """A validated inertia matrix as a float array of shape (3, 3).

    Parameters
    ----------
    J : array_like
        The matrix (kg m^2).
    k : int, optional
        1-based spacecraft number, named in messages.
    src : str, optional
        Where it came from (a file, an option), named in messages.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    InputError
        Not numeric, not 3x3, NaN/inf, not symmetric (to ``SYMMETRY_RTOL``
        of the largest entry) or not positive definite; one line, numbers
        written with ``:g``.

    Examples
    --------
    >>> check_inertia([[2, 0, 0], [0, 3, 0], [0, 0, 4]]).diagonal().tolist()
    [2.0, 3.0, 4.0]
    >>> check_inertia(np.diag([1.0, -1.0, 1.0]), k=2)
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected a positive definite inertia for spacecraft 2, received eigenvalues [-1, 1, 1]
    """
    where = _where(k, src)
    try:
        A = np.array(J, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected a numeric 3x3 inertia{where}, received {type(J).__name__}") from None
    if A.shape != (3, 3):
        raise InputError(f"expected a 3x3 inertia{where}, received shape {A.shape}")
    if not np.all(np.isfinite(A)):
        raise InputError(f"expected finite inertia entries{where}, received NaN/inf")
    scale = max(1.0, float(np.abs(A).max()))
    if not np.allclose(A, A.T, rtol=0, atol=SYMMETRY_RTOL * scale):
        asym = float(np.abs(A - A.T).max())
        raise InputError(
            f"expected a symmetric inertia{where}, received one with |J - J^T| = {asym:g}"
        )
    ev = np.linalg.eigvalsh(A)
    if ev[0] <= 0:
        shown = ", ".join(f"{e:g}" for e in ev)
        raise InputError(f"expected a positive definite inertia{where}, received eigenvalues [{shown}]")
    return A


def check_inertias(J: Any, n: int, src: str | None = None) -> np.ndarray:
    """``n`` validated inertias as a float array of shape (n, 3, 3).

    Examples
    --------
    >>> check_inertias([np.eye(3)] * 2, 2).shape
    (2, 3, 3)
    >>> check_inertias([np.eye(3)], 2)
    Traceback (most recent call last):
    ...
    formsync_design.errors.InputError: expected 2 inertias of shape 3x3 (one per spacecraft), received shape (1, 3, 3)
    """
    try:
        A = np.array(J, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {n} numeric 3x3 inertias{_where(None, src)}, received "
                         f"{type(J).__name__}") from None
    if A.shape != (n, 3, 3):
        raise InputError(
            f"expected {n} inertias of shape 3x3 (one per spacecraft){_where(None, src)}, "
            f"received shape {A.shape}"
        )
    # one vectorised pass (a Monte-Carlo campaign validates thousands of formations); the
    # per-matrix check runs only to name the first offending spacecraft in its own words
    if A.size and np.all(np.isfinite(A)):
        scale = np.maximum(1.0, np.abs(A).max(axis=(1, 2)))
        asym = np.abs(A - np.swapaxes(A, 1, 2)).max(axis=(1, 2))
        if np.all(asym <= SYMMETRY_RTOL * scale) and np.all(np.linalg.eigvalsh(A)[:, 0] > 0):
            return A
    for i in range(n):
        A[i] = check_inertia(A[i], i + 1, src)
    return A
