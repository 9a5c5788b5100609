"""Rigorous Lyapunov and inertia checks of a real matrix known to within an entrywise bound.

For a matrix ``A`` with ``|A - A~| <= dA`` entrywise (``A~`` a float matrix, ``dA`` a float
bound) and an exactly representable symmetric ``P``:

* :func:`lyapunov_lower_bound` returns ``ell`` with ``lambda_min(s (A^T P + P A)) >= ell``
  proven, ``s = -1`` (a Lyapunov certificate: with ``P > 0`` and ``ell > 0``, ``A`` is
  Hurwitz) or ``s = +1`` (the inertia theorem of Ostrowski and Schneider: when
  ``A^T P + P A > 0``, ``A`` has as many eigenvalues with positive real part as ``P`` has
  positive eigenvalues, none on the imaginary axis);
* :func:`pd_lower_bound` the same for ``P`` itself.

The bound: ``X~ = fl(P A~)``; ``|P A - X~| <= |P| dA + gamma_n |P| |A~|``; the sum
``X~ + X~^T`` adds one rounding; ``lambda_min`` of the float sum is bounded below by a
shifted Cholesky factorisation with Rump's error bound
(:func:`~formsync_design.certify.exact.rigorous_lower_bound`), and the norm of the
symmetric error matrix by its largest row sum; every float bound is inflated by
``1 + gamma_(n + 4)`` twice.

>>> import numpy as np
>>> A = np.array([[-1.0, 2.0], [0.0, -3.0]])
>>> P = solve_lyapunov_float(A)
>>> bool(lyapunov_lower_bound(A, np.zeros((2, 2)), P) > 0), bool(pd_lower_bound(P) > 0)
(True, True)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from formsync_design.certify.exact import gamma_bound, rigorous_lower_bound

__all__ = ["solve_lyapunov_float", "lyapunov_lower_bound", "pd_lower_bound", "decide_point"]

_TOL = 1e-9


def solve_lyapunov_float(A: np.ndarray, shift: float = 0.0, sign: int = -1) -> np.ndarray:
    """``P`` (symmetrised float) solving ``(A - shift I)^T P + P (A - shift I) = sign I``."""
    from scipy.linalg import solve_continuous_lyapunov

    n = A.shape[0]
    As = A - shift * np.eye(n)
    P = solve_continuous_lyapunov(As.T, sign * np.eye(n))
    return (P + P.T) / 2


def _min_eig_bound(M: np.ndarray) -> float:
    lam = float(np.linalg.eigvalsh(M)[0])
    if not np.isfinite(lam) or lam <= 0:
        return -np.inf
    ell = rigorous_lower_bound([M], np.array([[1.0]]), np.array([0.9 * lam]))[0]
    return float(ell)


def pd_lower_bound(P: np.ndarray) -> float:
    """A proven lower bound of ``lambda_min(P)`` (``-inf`` when none positive is found)."""
    return _min_eig_bound(np.asarray(P, dtype=float))


def lyapunov_lower_bound(A: np.ndarray, dA: np.ndarray, P: np.ndarray, sign: int = -1,
                         shift: float = 0.0) -> float:
    """A proven lower bound of ``lambda_min(sign ((A - shift I)^T P + P (A - shift I)))`` for
    every ``A`` within ``dA`` of the float matrix given (module docstring); ``shift`` is
    exact (a float), its rounding into the diagonal is accounted for."""
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    As = A - shift * np.eye(n)
    dAs = np.asarray(dA, dtype=float) + np.abs(As) * gamma_bound(1) * np.eye(n) * (shift != 0)
    X = P @ As
    S = X + X.T
    M = float(sign) * S
    absP = np.abs(P)
    infl = (1.0 + gamma_bound(n + 4)) ** 2
    Ex = (absP @ dAs + gamma_bound(n) * (absP @ np.abs(As))) * infl
    E = (Ex + Ex.T + gamma_bound(1) * np.abs(S)) * infl
    enorm = float(E.sum(axis=1).max()) * infl
    ell = _min_eig_bound(M)   # exactly symmetric: fl(x + y) = fl(y + x)
    return ell - enorm


def decide_point(A: np.ndarray, dA: np.ndarray, P: np.ndarray | None = None) -> dict[str, Any]:
    """Decide whether the exact matrix within ``dA`` of ``A`` is Hurwitz (module docstring).

    Returns ``{"status", "abscissa", "P", "ell", "decay"}`` or, refuted, ``{"sigma",
    "ell", "k"}``; undecided when neither check passes.
    """
    from formsync_design.certify.results import Status

    lam = np.linalg.eigvals(A) if A.size else np.zeros(0)
    alpha = float(lam.real.max()) if lam.size else -np.inf
    if alpha < -_TOL:
        cand = [P] if P is not None else []
        try:
            cand.append(solve_lyapunov_float(A))
        except (np.linalg.LinAlgError, ValueError):
            pass
        for Pc in cand:
            if Pc is None or not np.all(np.isfinite(Pc)):
                continue
            ell = lyapunov_lower_bound(A, dA, Pc)
            pl = pd_lower_bound(Pc)
            if ell > 0 and pl > 0:
                pmax = float(np.abs(Pc).sum(axis=1).max()) * (1 + 1e-12)
                return {"status": Status.CERTIFIED, "abscissa": alpha, "P": Pc, "ell": ell,
                        "decay": ell / (2 * pmax)}
        return {"status": Status.UNDECIDED, "abscissa": alpha,
                "reason": "stable in floating point but the Lyapunov re-check did not pass"}
    if alpha > _TOL:
        # the shift: in (0, alpha), as far as possible from every eigenvalue's real part
        # (the Lyapunov equation of the shifted matrix is then well conditioned)
        re = np.unique(np.concatenate([[0.0, alpha], lam.real[(lam.real > 0) & (lam.real < alpha)]]))
        k = int(np.argmax(np.diff(re)))
        sigma = float((re[k] + re[k + 1]) / 2)
        Pr: np.ndarray | None
        try:
            Pr = solve_lyapunov_float(A, shift=sigma, sign=1)
        except (np.linalg.LinAlgError, ValueError):
            Pr = None
        if Pr is not None and np.all(np.isfinite(Pr)):
            ell = lyapunov_lower_bound(A, dA, Pr, sign=1, shift=sigma)
            diag = np.diag(Pr)
            k = int(np.argmax(diag))
            if ell > 0 and diag[k] > 0:
                top = complex(lam[int(np.argmax(lam.real))])
                return {"status": Status.REFUTED, "abscissa": alpha, "sigma": sigma, "ell": ell,
                        "k": k, "top": top}
        return {"status": Status.UNDECIDED, "abscissa": alpha,
                "reason": "unstable in floating point but the inertia re-check did not pass"}
    return {"status": Status.UNDECIDED, "abscissa": alpha,
            "reason": f"a marginal mode (largest real part {alpha:.3g}): neither proven stable "
                      "nor unstable"}
