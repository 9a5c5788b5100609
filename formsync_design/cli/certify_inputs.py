"""The inertia and case files ``formsync certify`` reads (``--inertia FILE``, ``--case FILE``):
3x3 inertias per spacecraft, checked symmetric positive definite, and a case's inertias,
disturbance bounds and switching gains."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from formsync_design.errors import InputError
from formsync_design.textio import ascii_float, cut, read_text

if TYPE_CHECKING:
    import numpy as np

__all__ = ["read_inertias", "read_case"]


def _check_J(J: np.ndarray, k: int, src: str) -> np.ndarray:
    import numpy as np

    if not np.all(np.isfinite(J)):
        raise InputError(f"expected finite inertia entries, received NaN/inf for spacecraft {k} in {src}")
    if not np.allclose(J, J.T, rtol=0, atol=1e-12 * max(1.0, float(np.abs(J).max()))):
        raise InputError(
            f"expected a symmetric inertia for spacecraft {k} in {src}, received {J.tolist()}"
        )
    ev = np.linalg.eigvalsh(J)
    if ev[0] <= 0:
        raise InputError(
            f"expected a positive definite inertia for spacecraft {k} in {src}, received "
            f"eigenvalues {[float(f'{e:.6g}') for e in ev]}"
        )
    return J


def read_inertias(path: str, n: int) -> list[np.ndarray]:
    """Read 3x3 inertias (kg m^2) from a text/CSV file: 3 rows per spacecraft
    (whitespace or comma separated, ``#`` comments).  3 rows = the same inertia
    for every spacecraft; otherwise exactly ``3 n`` rows.

    >>> import tempfile, os
    >>> with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as fh:
    ...     _ = fh.write("50, 0, 0\\n0, 55, 0\\n0, 0, 60\\n")
    >>> [float(J[1, 1]) for J in read_inertias(fh.name, 2)]
    [55.0, 55.0]
    >>> os.unlink(fh.name)
    """
    import numpy as np

    rows = []
    for lineno, raw in enumerate(read_text(path, "inertia file").splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").split()
        if len(parts) != 3:
            raise InputError(f"expected 3 numbers per row, received {len(parts)} fields "
                             f"{cut(line)} at {path}:{lineno}")
        read = [ascii_float(x) for x in parts]  # float() would read a Bengali digit
        bad = next((x for x, v in zip(parts, read) if v is None), None)
        if bad is not None:
            raise InputError(f"expected numbers (digits 0-9), received {cut(bad)} at "
                             f"{path}:{lineno}, column {raw.index(bad) + 1}")
        vals = [float(v) for v in read if v is not None]
        if not all(math.isfinite(v) for v in vals):
            raise InputError(f"expected finite numbers, received {cut(line)} at {path}:{lineno}")
        rows.append(vals)
    if len(rows) == 3:
        J = _check_J(np.array(rows), 1, path)
        return [J] * n
    if len(rows) != 3 * n:
        raise InputError(
            f"expected 3 rows (one inertia for all) or {3 * n} rows (3 per spacecraft, N={n}) "
            f"in {path}, received {len(rows)}"
        )
    return [_check_J(np.array(rows[3 * k : 3 * k + 3]), k + 1, path) for k in range(n)]


def read_case(path: str, n: int) -> dict[str, Any]:
    """Inertias, per-spacecraft disturbance bounds and K_v from a TOML case file
    (format: :mod:`formsync_design.verify.case`, e.g. ``verification/liang2016.toml``)."""
    import numpy as np

    from formsync_design.verify.case import load_case, make_disturbance

    c = load_case(path)
    if c.n != n:
        raise InputError(
            f"expected a case with {n} spacecraft (the graph's N), received {c.n} in {path}"
        )
    d = make_disturbance(c.disturbance, c.inertias, c.orbit)
    return {
        "inertias": [np.asarray(J, dtype=float) for J in c.inertias],
        "ubar": [float(u) for u in d.bound(c.inertias)],
        "kv": list(c.gains.K_v) if len(c.gains.K_v) == n else [c.gains.K_v[0]] * n,
    }
