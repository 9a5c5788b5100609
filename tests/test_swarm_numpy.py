"""The plain-scipy baseline of the swarm benchmarks (``benchmarks/swarm_numpy.py``,
``benchmarks/swarm_baseline.py``) against independent truth: the numpy right-hand side against
the toolbox's own CasADi kernel of ``bai2008_passivity`` (``kern.rhs``, not compiled) at seeded
random states on ring:5 and on a weighted digraph with unequal in-degrees, and the reference
integrator on a torque-free rigid body, whose body-frame ``|J w|``, kinetic energy and
inertial angular momentum are constant (analytic truth)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.swarm_baseline import ladder_rtols, reference_solution, scipy_ladder
from benchmarks.swarm_numpy import case_data, graph_arcs, initial_state, make_rhs
from formsync_design.graphs.digraph_io import digraph_from_edges, make_digraph
from formsync_design.sim.agent_kernel import agent_parameters, get_agent_kernel
from formsync_design.sim.agents import AgentFormation, AgentOptions
from formsync_design.sim.formation import Gains
from formsync_design.spec.loader import load_design

K_DIAG = np.array([20.0, 23.0, 17.0])   # unequal axes: the diagonal gain's order is checked
K_P = 10.0


@pytest.fixture(scope="module")
def design():
    return load_design("bai2008_passivity")


def kernel_rhs(design, graph, J, x0):
    """The toolbox kernel's ``xdot`` function of ``graph`` (its arcs and weights) and the
    formation's arc arrays ``(arcs_i, arcs_j, a)`` in the kernel's order."""
    n = graph.n
    att = x0[: 4 * n].reshape(n, 4)
    rates = x0[4 * n:].reshape(n, 3)
    f = AgentFormation(graph, J, att, rates, Gains(K=tuple(K_DIAG), k_p=K_P))
    nb = f.neighbours()
    kern = get_agent_kernel(design, nb, "sgn", 1, 1, compile=False)
    p = agent_parameters(design, f, AgentOptions(), kern.layout)
    ai = np.array([i for i, js in enumerate(nb) for _ in js])
    aj = np.array([j for js in nb for j in js])
    return (lambda x: np.asarray(kern.rhs(x, 0.0, p)).ravel()), (ai, aj, f.weights())


def random_states(n, seed, count):
    """Seeded states far from synchronisation: unit quaternions of any attitude (either sign
    of ``q0``) and rates up to 1 rad/s."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = rng.normal(size=(n, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        w = rng.uniform(-1, 1, size=(n, 3))
        yield np.concatenate([q.ravel(), w.ravel()])


def check_against_kernel(design, graph, seed):
    n = graph.n
    x0, J = initial_state(n, seed)
    kr, (ai, aj, a) = kernel_rhs(design, graph, J, x0)
    f = make_rhs(J, ai, aj, a, K_DIAG, K_P)
    for x in [x0, *random_states(n, seed + 1, 4)]:
        want = kr(x)
        got = f(0.0, x)
        scale = np.max(np.abs(want))
        assert scale > 1e-3
        # 1e-12 relative to the largest component of xdot (entries can cancel to ~0)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * scale)
    return ai, aj, a


def test_ring5_matches_kernel(design):
    ai, aj, a = check_against_kernel(design, make_digraph("ring:5"), seed=5)
    # the kernel's arcs of ring:5 are graph_arcs' ring (same order, unit weights)
    gi, gj, ga = graph_arcs(5, "ring")
    assert ai.tolist() == gi.tolist() and aj.tolist() == gj.tolist() and a.tolist() == ga.tolist()


def test_weighted_digraph_matches_kernel(design):
    # 1-based (i receives from j, weight); in-degrees 3, 1, 2, 1, 3; not balanced
    g = digraph_from_edges([(1, 2, "0.5"), (1, 3, "1.5"), (1, 5, "0.25"), (2, 1, "2"),
                            (3, 2, "0.75"), (3, 4, "1"), (4, 3, "1.25"), (5, 4, "0.6"),
                            (5, 1, "0.3"), (5, 3, "1.1")], n=5, name="weighted5")
    assert not g.is_undirected
    assert sorted({len(g.receives_from(i)) for i in range(5)}) == [1, 2, 3]
    _, _, a = check_against_kernel(design, g, seed=11)
    assert len(set(a.tolist())) == 10


def test_numpy_rhs_arc_order_and_duplicates():
    """The neighbour sum does not depend on the arcs' order; a repeated arc adds its weight."""
    n = 6
    x0, J = initial_state(n, 3)
    ai, aj, a = graph_arcs(n, "ring")
    f = make_rhs(J, ai, aj, a, K_DIAG, K_P)
    perm = np.random.default_rng(0).permutation(ai.size)
    g = make_rhs(J, ai[perm], aj[perm], a[perm], K_DIAG, K_P)
    np.testing.assert_allclose(g(0.0, x0), f(0.0, x0), rtol=1e-13, atol=1e-15)
    h = make_rhs(J, np.concatenate([ai, ai]), np.concatenate([aj, aj]), 0.5 * np.ones(2 * ai.size),
                 K_DIAG, K_P)
    np.testing.assert_allclose(h(0.0, x0), f(0.0, x0), rtol=1e-13, atol=1e-15)


def test_initial_state():
    x0, J = initial_state(9, 4)
    x1, _ = initial_state(9, 4)
    assert np.array_equal(x0, x1)
    qb = x0[:36].reshape(9, 4)
    np.testing.assert_allclose(np.linalg.norm(qb, axis=1), 1.0, atol=1e-15)
    assert np.all(2 * np.degrees(np.arccos(qb[:, 3])) <= 30.0 + 1e-9) and np.all(qb[:, 3] > 0)
    assert np.all(np.abs(x0[36:]) <= 0.05)
    J4, _, _ = case_data()
    assert np.array_equal(J[5], J4[1]) and np.array_equal(J[8], J4[0])


def rot(qb):
    """Body-to-inertial rotation matrix of a unit quaternion ``(q1, q2, q3, q0)``."""
    v, q0 = qb[:3], qb[3]
    S = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return (q0 * q0 - v @ v) * np.eye(3) + 2 * np.outer(v, v) + 2 * q0 * S


def test_reference_conserves_torque_free_invariants():
    """A free asymmetric body tumbling near its intermediate axis (no coupling, no damping):
    ``|J w|``, ``w^T J w / 2`` and the inertial momentum ``R(q) J w`` are constant."""
    Jd = np.diag([50.0, 55.0, 60.0])
    f = make_rhs(Jd[None], [], [], [], 0.0, 0.0)
    w0 = np.array([0.05, 0.6, -0.03])
    x0 = np.concatenate([[0.1, -0.2, 0.3, np.sqrt(1 - 0.14)], w0])
    t_eval = np.linspace(0.0, 60.0, 301)
    sol = reference_solution(f, x0, 60.0, t_eval)
    Y = sol.y.T
    W = Y[:, 4:]
    H = W @ Jd                                   # J w (J diagonal)
    E = 0.5 * np.einsum("ti,ti->t", W, H)
    Hn = np.linalg.norm(H, axis=1)
    Hi = np.array([rot(y[:4] / np.linalg.norm(y[:4])) @ h for y, h in zip(Y, H)])
    assert np.ptp(W[:, 1]) > 0.1                 # it does tumble: the rates change
    assert np.max(np.abs(Hn / Hn[0] - 1)) <= 1e-10
    assert np.max(np.abs(E / E[0] - 1)) <= 1e-10
    assert np.max(np.abs(Hi - Hi[0])) <= 1e-10 * Hn[0]
    assert np.max(np.abs(np.linalg.norm(Y[:, :4], axis=1) - 1)) <= 1e-10


def test_ladder_reaches_target():
    x0, J = initial_state(4, 1)
    _, K, kp = case_data()
    f = make_rhs(J, *graph_arcs(4, "ring"), K, kp)
    ref = reference_solution(f, x0, 10.0)
    rtol, err, wall, nfev = scipy_ladder(f, x0, 10.0, None, 1e-8, ref, repeats=1)
    assert err <= 1e-8 and wall > 0 and nfev > 0
    assert rtol in ladder_rtols() and rtol < 1e-4
