"""Plain numpy right-hand side of the ``bai2008_passivity`` formation, for ``scipy.integrate``.

The honest baseline of the swarm benchmarks: what a researcher fluent in numpy would write for
the closed loop of ``derivations/bai2008_passivity.py`` (no CasADi, no code generation, no
Python loop over spacecraft or arcs).  It is *not* the toolbox's kernel and shares no code
with it; ``tests/test_swarm_numpy.py`` checks the two agree to rounding.

Closed loop (spacecraft ``i``, in-neighbours ``j`` with weights ``a_ij``; quaternions
``(q1, q2, q3, q0)``, vector part first; ``R(q)`` body to inertial):

* law: ``e_ij = q0_i q_j - q0_j q_i - q_i x q_j`` (vector part of ``q_i^* (x) q_j``),
  ``u_i = -K w_i + k_p sum_j a_ij e_ij`` (``K`` diagonal, three values);
* plant: ``q_i' = (q0_i w_i + q_i x w_i) / 2``, ``q0_i' = -q_i . w_i / 2``,
  ``J_i w_i' = -w_i x (J_i w_i) + u_i`` (no disturbance, no torque limit).

State order (the toolbox's): ``x = [q1_1, q2_1, q3_1, q0_1, ..., q0_N, w1_1, ..., w3_N]``, all
quaternions first (``4N``), then all rates (``3N``).

How it is vectorised: ``e_ij`` is bilinear in ``(q_i, q0_i)`` and ``(q_j, q0_j)``, so the
neighbour sum factors through the weighted adjacency ``A`` (a ``scipy.sparse`` CSR matrix built
once from the arc index arrays): with ``S = A [q | q0]`` (one sparse product of an ``(N, 4)``
array), ``sum_j a_ij e_ij = q0_i S_i[:3] - S_i[3] q_i - q_i x S_i[:3]``.  ``J^{-1}`` is
inverted once, the products ``J w`` and ``J^{-1} (...)`` are one ``einsum`` each over the
``(N, 3, 3)`` stack; cross products are written out per component (``np.cross`` has a large
fixed cost per call).

Differences from the toolbox's kernel (``formsync_design/sim/agent_kernel.py``), none of them
visible on unit quaternions: the kernel's law sees each quaternion normalised (``q / |q|``),
this one the quaternion as integrated (the plant keeps ``|q|`` constant, so along a solution
the two differ by the integrator's drift of ``|q|`` only); the neighbour sum is summed in a
different order (rounding).

Also here: :func:`graph_arcs` (arc index arrays of a few graphs), :func:`case_data` (the
inertias and gains of ``verification/bai2008_passivity.toml``) and :func:`initial_state` (a
seeded random initial state near synchronisation).
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.sparse as sps

__all__ = ["CASE_FILE", "make_rhs", "graph_arcs", "case_data", "initial_state"]

#: The verification case whose spacecraft inertias and gains the benchmarks use.
CASE_FILE = Path(__file__).resolve().parent.parent / "verification" / "bai2008_passivity.toml"


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise ``a x b`` of two ``(N, 3)`` arrays (written out: ``np.cross`` costs about
    30 us a call at any N on numpy 2.x, more than the rest of a small formation's ``f``).

    >>> _cross(np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    array([[0., 0., 1.]])
    """
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    out = np.empty(a.shape)
    out[:, 0] = a1 * b2 - a2 * b1
    out[:, 1] = a2 * b0 - a0 * b2
    out[:, 2] = a0 * b1 - a1 * b0
    return out


def make_rhs(J: np.ndarray, arcs_i: np.ndarray, arcs_j: np.ndarray, a: np.ndarray,
             K: np.ndarray, k_p: float) -> Callable[[float, np.ndarray], np.ndarray]:
    """``f(t, x)`` of the closed loop (module docstring) for ``scipy.integrate.solve_ivp``.

    ``J``: ``(N, 3, 3)`` inertias; ``arcs_i``, ``arcs_j``, ``a``: arc ``k`` means spacecraft
    ``arcs_i[k]`` receives from ``arcs_j[k]`` (0-based) with weight ``a[k]`` (repeated arcs
    add up); ``K``: the diagonal damping gain (three values, or one for every axis);
    ``k_p``: the link gain.

    >>> J = np.array([np.diag([1.0, 2.0, 3.0])] * 2)
    >>> f = make_rhs(J, [0, 1], [1, 0], [1.0, 1.0], [0.0, 0.0, 0.0], 2.0)
    >>> x = np.array([0, 0, 0, 1.0, 0, 0, np.sin(0.1), np.cos(0.1), 0, 0, 0, 0, 0, 0])
    >>> np.round(f(0.0, x)[8:], 4)  # torques +-k_p sin(0.1) about axis 3, divided by J_33
    array([ 0.    ,  0.    ,  0.0666,  0.    ,  0.    , -0.0666])
    """
    J = np.asarray(J, dtype=float)
    n = J.shape[0]
    if J.shape != (n, 3, 3):
        raise ValueError(f"expected inertias of shape (N, 3, 3), received {J.shape}")
    Jinv = np.linalg.inv(J)
    ai = np.asarray(arcs_i, dtype=np.intp)
    aj = np.asarray(arcs_j, dtype=np.intp)
    w_arcs = np.broadcast_to(np.asarray(a, dtype=float), ai.shape)
    A = sps.csr_matrix((w_arcs, (ai, aj)), shape=(n, n))  # duplicates summed
    Kd = np.broadcast_to(np.asarray(K, dtype=float), (3,)).copy()
    kp = float(k_p)

    def f(t: float, x: np.ndarray) -> np.ndarray:
        qb = x[: 4 * n].reshape(n, 4)
        w = x[4 * n:].reshape(n, 3)
        q, q0 = qb[:, :3], qb[:, 3:]
        S = A @ qb                                  # (N, 4): sum_j a_ij [q_j | q0_j]
        s = S[:, :3]
        u = kp * (q0 * s - S[:, 3:] * q - _cross(q, s)) - Kd * w
        Jw = np.einsum("nij,nj->ni", J, w)
        out = np.empty(7 * n)
        qd = out[: 4 * n].reshape(n, 4)
        qd[:, :3] = 0.5 * (q0 * w + _cross(q, w))
        qd[:, 3] = -0.5 * np.einsum("ni,ni->n", q, w)
        out[4 * n:] = np.einsum("nij,nj->ni", Jinv, u - _cross(w, Jw)).ravel()
        return out

    return f


def graph_arcs(n: int, kind: str = "ring") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(arcs_i, arcs_j, a)`` of a graph on ``n`` spacecraft (0-based, ``i`` receives from
    ``j``, weight 1), sorted by receiver then sender (the toolbox's arc order).

    ``ring``: the undirected ring (``i`` receives from ``i - 1`` and ``i + 1`` mod ``n``,
    ``n >= 3``); ``path``: the undirected path; ``cycle``: the directed cycle (``i``
    receives from ``i - 1`` mod ``n``).

    >>> [v.tolist() for v in graph_arcs(4)]
    [[0, 0, 1, 1, 2, 2, 3, 3], [1, 3, 0, 2, 1, 3, 0, 2], [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]]
    """
    idx = np.arange(n)
    if kind == "ring":
        if n < 3:
            raise ValueError(f"expected a ring of at least 3 spacecraft, received {n}")
        ai = np.repeat(idx, 2)
        aj = np.sort(np.stack([(idx - 1) % n, (idx + 1) % n], axis=1), axis=1).ravel()
    elif kind == "path":
        if n < 2:
            raise ValueError(f"expected a path of at least 2 spacecraft, received {n}")
        ai = np.concatenate([idx[1:], idx[:-1]])
        aj = np.concatenate([idx[:-1], idx[1:]])
        order = np.lexsort((aj, ai))
        ai, aj = ai[order], aj[order]
    elif kind == "cycle":
        if n < 2:
            raise ValueError(f"expected a cycle of at least 2 spacecraft, received {n}")
        ai, aj = idx, (idx - 1) % n
    else:
        raise ValueError(f"expected a graph kind in ['ring', 'path', 'cycle'], received {kind!r}")
    return ai, aj, np.ones(ai.size)


def case_data(path: Path = CASE_FILE) -> tuple[np.ndarray, np.ndarray, float]:
    """``(inertias (4, 3, 3), K (3,), k_p)`` of the case file's ``[[spacecraft]]`` and
    ``[gains]`` (``verification/bai2008_passivity.toml``: ``K`` one value for every axis).

    >>> J, K, kp = case_data()
    >>> J.shape, K.tolist(), kp
    ((4, 3, 3), [20.0, 20.0, 20.0], 10.0)
    """
    with open(path, "rb") as fh:
        case = tomllib.load(fh)
    J = np.array([sc["inertia"] for sc in case["spacecraft"]], dtype=float)
    K = np.broadcast_to(np.asarray(case["gains"]["K"], dtype=float), (3,)).copy()
    return J, K, float(case["gains"]["k_p"])


def initial_state(n: int, seed: int, max_angle_deg: float = 30.0,
                  max_rate: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """``(x0, J)``: a seeded random initial state (toolbox order) and the inertias.

    Each attitude is a rotation about a uniformly random axis by an angle uniform in
    ``[0, max_angle_deg]`` from the identity (``q0 = cos(angle / 2) > 0``, unit to rounding);
    rates uniform in ``[-max_rate, max_rate]`` rad/s per component; inertias the case file's
    four spacecraft cycled (spacecraft ``i`` gets number ``i mod 4``).

    >>> x0, J = initial_state(6, 0)
    >>> x0.shape, J.shape, bool(np.all(x0[3:24:4] > np.cos(np.radians(15))))
    ((42,), (6, 3, 3), True)
    """
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    ang = np.radians(max_angle_deg) * rng.uniform(size=n)
    qb = np.column_stack([np.sin(ang / 2)[:, None] * axis, np.cos(ang / 2)])
    w = rng.uniform(-max_rate, max_rate, size=(n, 3))
    J4, _, _ = case_data()
    J = J4[np.arange(n) % 4]
    return np.concatenate([qb.ravel(), w.ravel()]), J
