"""The sixth design (``derivations/bai2008_passivity.py``, Bai, Arcak, Wen 2008) against
independent truth: a numpy implementation of the law (quaternion products written here, and
the axis-angle of ``R_i^T R_j`` from rotation matrices), the invariance under a common
rotation (no inertial information), the storage function computed from a simulated run's
states by numpy, the linearisation against a numpy finite-difference Jacobian of a numpy
closed loop and against the analytic modes ``j s^2 + K s + k_p lambda / 2`` of the graph
Laplacian, and the passivity certificate's derived identity (a wrong law is refused)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from formsync_design.certify.formation import certify_formation
from formsync_design.certify.results import Status
from formsync_design.derive.agent import agent_conditions
from formsync_design.derive.formation import linearize_formation
from formsync_design.errors import DerivationError
from formsync_design.gains import GainBox
from formsync_design.graphs.digraph_io import digraph_from_edges
from formsync_design.sim.agents import AgentOptions, simulate_agents
from formsync_design.spec.agent import agent_design_from_functions, agent_expressions
from formsync_design.spec.loader import load_design
from formsync_design.verify.agentcase import load_agent_case, shipped_agent_case
from tests.fd_formation import fd_jacobian  # noqa: I001

NAME = "bai2008_passivity"
K_DIAG = np.array([20.0, 23.0, 17.0])   # a diagonal gain with unequal axes
K_P = 10.0


# ------------------------------------------------------------------ independent numpy truth


def qmul(p: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Hamilton product of ``[x, y, z, w]`` quaternions (written out component by component)."""
    x1, y1, z1, w1 = p
    x2, y2, z2, w2 = r
    return np.array([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                     w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])


def conj(q: np.ndarray) -> np.ndarray:
    return np.array([-q[0], -q[1], -q[2], q[3]])


def rot(q: np.ndarray) -> np.ndarray:
    """Body-to-inertial rotation matrix of ``[x, y, z, w]`` (Rodrigues: angle and axis)."""
    ang = 2 * np.arctan2(np.linalg.norm(q[:3]), q[3])
    if ang == 0:
        return np.eye(3)
    n = q[:3] / np.linalg.norm(q[:3])
    N = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + np.sin(ang) * N + (1 - np.cos(ang)) * N @ N


def law(qi, wi, nbrs, K=K_DIAG, kp=K_P):
    """``u_i = -K w_i + k_p sum_j a_ij vec(q_i^* (x) q_j)`` (``nbrs``: ``[(a_ij, q_j), ...]``)."""
    u = -K * wi
    for a, qj in nbrs:
        u = u + kp * a * qmul(conj(qi), qj)[:3]
    return u


def unit(rng, n=None):
    q = rng.normal(size=(4,) if n is None else (n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def closed_loop(x, J, adj, K=K_DIAG, kp=K_P):
    """``(q_i', w_i')`` of the whole formation (``x``: quaternions (N, 4), rates (N, 3))."""
    Q, W = x
    n = len(Q)
    Qd, Wd = np.zeros_like(Q), np.zeros_like(W)
    for i in range(n):
        u = law(Q[i], W[i], [(adj[i, j], Q[j]) for j in range(n) if adj[i, j]], K, kp)
        Qd[i] = 0.5 * qmul(Q[i], np.append(W[i], 0.0))
        Wd[i] = np.linalg.solve(J[i], u - np.cross(W[i], J[i] @ W[i]))
    return Qd, Wd


def spectrum(M_or_eigs, *, eigs=False):
    """Eigenvalues sorted by rounded real, then imaginary part (ties of equal modes stable)."""
    e = np.asarray(M_or_eigs) if eigs else np.linalg.eigvals(M_or_eigs)
    return e[np.lexsort((np.round(e.imag, 6), np.round(e.real, 6)))]


def storage(Q, W, J, adj, K=K_DIAG, kp=K_P):
    """``V = sum_i w^T J w / 2 + sum_links 2 k_p a_ij (1 - c_ij)`` (each link once)."""
    n = len(Q)
    V = sum(0.5 * W[i] @ J[i] @ W[i] for i in range(n))
    for i in range(n):
        for j in range(i + 1, n):
            if adj[i, j]:
                V += 2 * kp * adj[i, j] * (1 - qmul(conj(Q[i]), Q[j])[3])
    return V


# ------------------------------------------------------------------------- the design's law


@pytest.fixture(scope="module")
def design():
    return load_design(NAME)


def symbolic_law(design, m):
    ex = agent_expressions(design, m)
    v = ex["view"]
    f = sp.lambdify([*v.q, v.q0, *v.w, *v.K.diagonal(), v.k_p,
                     *[s for n in v.nbrs for s in (*n.q, n.q0, n.a)]], ex["u"], "numpy")

    def u(qi, wi, nbrs, K=K_DIAG, kp=K_P):
        args = [*qi, *wi, *K, kp, *[s for a, qj in nbrs for s in (*qj, a)]]
        return np.asarray(f(*args), float).ravel()
    return u


def test_the_controller_is_the_numpy_law_at_random_states(design):
    rng = np.random.default_rng(2008)
    for m in (1, 2, 3):
        u = symbolic_law(design, m)
        for _ in range(20):
            qi, wi = unit(rng), rng.normal(size=3)
            nbrs = [(rng.uniform(0.2, 2.0), unit(rng)) for _ in range(m)]
            np.testing.assert_allclose(u(qi, wi, nbrs), law(qi, wi, nbrs), rtol=1e-12, atol=1e-12)


def test_the_link_term_is_the_axis_of_the_relative_rotation_times_sin_half_angle():
    """``vec(q_i^* q_j)`` from quaternions equals ``sign(c) sin(theta/2) n`` with ``theta, n``
    the angle and axis of the rotation matrix ``R_i^T R_j`` (a second representation)."""
    rng = np.random.default_rng(3170)
    for _ in range(30):
        qi, qj = unit(rng), unit(rng)
        Rr = rot(qi).T @ rot(qj)
        theta = np.arccos(np.clip((np.trace(Rr) - 1) / 2, -1, 1))
        axis = np.array([Rr[2, 1] - Rr[1, 2], Rr[0, 2] - Rr[2, 0], Rr[1, 0] - Rr[0, 1]])
        axis /= 2 * np.sin(theta)
        rel = qmul(conj(qi), qj)
        np.testing.assert_allclose(rel[:3], np.sign(rel[3]) * np.sin(theta / 2) * axis,
                                   atol=1e-10)


def test_the_law_uses_relative_attitudes_only(design):
    """A common rotation of every attitude (``q_k -> p q_k``, a change of inertial frame)
    leaves every torque unchanged; rotating one spacecraft only does not."""
    rng = np.random.default_rng(44)
    u = symbolic_law(design, 3)
    moved = 0.0
    for _ in range(20):
        p = unit(rng)
        qi, wi = unit(rng), rng.normal(size=3)
        nbrs = [(1.0, unit(rng)) for _ in range(3)]
        base = u(qi, wi, nbrs)
        rotated = u(qmul(p, qi), wi, [(a, qmul(p, qj)) for a, qj in nbrs])
        np.testing.assert_allclose(rotated, base, atol=1e-12)
        moved = max(moved, float(np.abs(u(qmul(p, qi), wi, nbrs) - base).max()))
    assert moved > 1.0


# ------------------------------------------------------------- the storage along a run


def test_the_storage_function_is_non_increasing_along_a_simulated_run(design):
    case = load_agent_case(shipped_agent_case(design))
    g = case.graph()
    adj = np.array(g.adjacency, float)
    K = np.full(3, float(case.gains.K)) if np.ndim(case.gains.K) == 0 else np.asarray(
        case.gains.K, float)
    kp = float(case.gains.k_p)
    r = simulate_agents(design, case.formation(),
                        AgentOptions(tf=40.0, output_step=0.05, step=0.005))
    J = case.inertias
    V = np.array([storage(r.quaternions[k], r.rates[k], J, adj, K, kp) for k in range(len(r.t))])
    assert V[0] > 10.0 and V[-1] < 0.05 * V[0]
    assert np.all(np.diff(V) <= 1e-9 * V[0])
    # V(0) - V(t) = int_0^t sum_i w_i^T K w_i (the passivity identity), trapezoid on the grid
    P = np.einsum("tnk,k,tnk->t", r.rates, K, r.rates)
    dissipated = np.concatenate([[0.0], np.cumsum((P[1:] + P[:-1]) / 2 * np.diff(r.t))])
    np.testing.assert_allclose(V[0] - V, dissipated, atol=2e-3 * V[0])
    # the design's own monitor shares sum to the same V
    np.testing.assert_allclose(r.monitors["storage"].sum(axis=1), V, rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------ the linearisation


def ring(n):
    return digraph_from_edges([e for i in range(n) for e in ((i + 1, (i + 1) % n + 1, 1),
                                                             ((i + 1) % n + 1, i + 1, 1))],
                              n=n, name=f"ring{n}")


def numpy_fd(J, adj, K, kp, h=1e-7):
    """Central differences of :func:`closed_loop` at synchronisation in ``(q_vec, w)``."""
    n = len(J)

    def f(xi):
        qv = xi[: 3 * n].reshape(n, 3)
        Q = np.column_stack([qv, np.sqrt(1 - (qv**2).sum(axis=1))])
        Qd, Wd = closed_loop((Q, xi[3 * n:].reshape(n, 3)), J, adj, K, kp)
        return np.concatenate([Qd[:, :3].ravel(), Wd.ravel()])
    A = np.zeros((6 * n, 6 * n))
    for k in range(6 * n):
        e = np.zeros(6 * n)
        e[k] = h
        A[:, k] = (f(e) - f(-e)) / (2 * h)
    return A


def test_the_linearisation_has_the_spectrum_of_numpy_finite_differences(design):
    case = load_agent_case(shipped_agent_case(design))
    g = case.graph()
    J = case.inertias
    gains = {"K": 20, "k_p": 10}
    lin = linearize_formation(design, g, J, fixed={k: Fraction(v) for k, v in gains.items()})
    A = lin.loop.standard({})[0]
    B = numpy_fd(J, np.array(g.adjacency, float), np.full(3, 20.0), 10.0)
    np.testing.assert_allclose(spectrum(A), spectrum(B), atol=1e-5)
    # and entry by entry against the compiled kernel's finite differences (same chart)
    np.testing.assert_allclose(A, fd_jacobian(design, g, J, gains, h=1e-7), atol=1e-5)


def test_the_linear_modes_are_the_damped_laplacian_oscillators(design):
    """Equal inertias ``j I``: every eigenvalue solves ``j s^2 + K s + k_p lambda / 2 = 0``
    for a Laplacian eigenvalue ``lambda`` of ring:5 (``lambda = 0`` gives ``s = 0`` and
    ``s = -K / j``), three times (one per axis)."""
    n, j, K, kp = 5, 40.0, 12.0, 9.0
    J = np.tile(j * np.eye(3), (n, 1, 1))
    lin = linearize_formation(design, ring(n), J, fixed={"K": Fraction(12), "k_p": Fraction(9)})
    got = spectrum(lin.loop.standard({})[0])
    lam = 2 - 2 * np.cos(2 * np.pi * np.arange(n) / n)
    want = spectrum(np.repeat(np.concatenate([np.roots([j, K, kp * x / 2]) for x in lam]), 3),
                    eigs=True)
    np.testing.assert_allclose(got, want, atol=1e-7)


@pytest.mark.parametrize("n", [4, 8])
def test_directed_cycles_follow_the_complex_mode_test(design, n):
    """Outside the theorem's class: on the directed cycle C_n (``lambda = 1 - e^{2 pi i k/n}``)
    the mode ``j s^2 + K s + k_p lambda / 2`` is stable iff ``(Im c)^2 < a^2 Re c`` with
    ``a = K / j``, ``c = k_p lambda / (2 j)`` (Routh-Hurwitz for complex coefficients); at
    ``K = 20, k_p = 10, j = 55`` C4 passes and C8 fails, and the certificate agrees."""
    j, K, kp = 55.0, 20.0, 10.0
    lam = 1 - np.exp(2j * np.pi * np.arange(1, n) / n)
    c, a = kp * lam / (2 * j), K / j
    stable = bool(np.all(c.imag**2 < a**2 * c.real))
    assert stable == (n == 4)
    g = digraph_from_edges([(i + 1, i % n + 2 if i < n - 1 else 1, 1) for i in range(n)], n=n,
                           name=f"C{n}")
    r = certify_formation(design, g, np.tile(j * np.eye(3), (n, 1, 1)),
                          GainBox.parse({"K": "20", "k_p": "10"}))
    assert r.status == (Status.CERTIFIED if stable else Status.REFUTED)


# ------------------------------------------------------------- the passivity certificate


def test_the_storage_certificate_is_derived_and_refuses_a_non_passive_law(design):
    conds = agent_conditions(design, "star:5")        # in-degrees 1 and 4
    assert [f.name for f in conds.families] == ["dissipation: -V' = w^T K w at d = 0",
                                                "storage: link-potential weight k_p"]
    mod = design.module
    wrong = agent_design_from_functions(
        lambda v: -v.K * v.w - v.k_p * sum((n.a * mod["relative"](v, n)[0] for n in v.nbrs),
                                           sp.zeros(3, 1)),
        name="bai_wrong_sign", gains=dict(mod["GAINS"]), measured=mod["MEASURED"],
        conditions=mod["conditions"])
    with pytest.raises(DerivationError, match="V' is not"):
        agent_conditions(wrong, "path:3")


def test_on_a_digraph_the_storage_argument_is_refuted_for_every_gain(design):
    """Outside the class: the derived digraph family has the indefinite block ``[[0, -k_p/2],
    [-k_p/2, 0]]`` in ``(w_j, e_ij)``, refuted on the whole gain range with one exact
    witness; the formation's own verdict on C4 (certified) is a separate question."""
    from formsync_design.certify.agent import certify_agent

    c4 = [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1, 0, 0, 0]]
    conds = agent_conditions(design, c4)
    (fam,) = conds.families
    assert fam.name.startswith("digraph storage, in-degree 1")
    box = GainBox.parse({"K": "1:50", "k_p": "1:50"})
    assert certify_agent(design, conds, box).status == Status.REFUTED
    r = certify_formation(design, digraph_from_edges([(1, 2, 1), (2, 3, 1), (3, 4, 1), (4, 1, 1)],
                                                     n=4, name="C4"),
                          np.tile(55.0 * np.eye(3), (4, 1, 1)), GainBox.parse({"K": "20",
                                                                                "k_p": "10"}))
    assert r.status == Status.CERTIFIED


# ------------------------------------------------- cycles: a non-synchronised equilibrium


def test_on_a_ring_the_twisted_state_is_an_equilibrium_that_a_run_leaves(design):
    """On ring:6 the quaternions ``q_k = (sin(2 pi k/6) z, cos(2 pi k/6))`` (one winding of
    S^3) at rest are an equilibrium that is not synchronised: each spacecraft's two link terms
    cancel exactly (the set where ``D psi = 0`` is larger than ``psi = 0`` on a cyclic graph).
    A run started 0.01 away leaves it and synchronises (it is not an attractor: on S^3 the
    winding loop can shrink off its great circle)."""
    from formsync_design.graphs.digraph_io import make_digraph
    from formsync_design.sim.agents import AgentFormation
    from formsync_design.sim.formation import Gains

    n = 6
    half = 2 * np.pi * np.arange(n) / n
    Q = np.column_stack([np.zeros(n), np.zeros(n), np.sin(half), np.cos(half)])
    u = symbolic_law(design, 2)
    for i in range(n):
        nbrs = [(1.0, Q[(i - 1) % n]), (1.0, Q[(i + 1) % n])]
        np.testing.assert_allclose(u(Q[i], np.zeros(3), nbrs), 0.0, atol=1e-12)
        assert np.linalg.norm(qmul(conj(Q[i]), Q[(i + 1) % n])[:3]) > 0.8   # 120 deg apart
    rng = np.random.default_rng(6)
    P = Q + 0.01 * rng.normal(size=Q.shape)
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    J = np.tile(np.diag([50.0, 55.0, 60.0]), (n, 1, 1))
    r = simulate_agents(design, AgentFormation(make_digraph("ring:6"), J, P, np.zeros((n, 3)),
                                               Gains(K=20.0, k_p=10.0)),
                        AgentOptions(tf=600, output_step=1.0, step=0.02, angle_tol=0.01,
                                     rate_tol=1e-4))
    assert r.attitude_error[0] > 100 and r.attitude_error[-1] < 0.01
    assert str(r.status) == "converged"
