"""The derivation engine against independent truth.

* V' from the assembled (Theta, Pi) form against central finite differences of V
  along the *nonlinear* formation (quaternion kinematics + Euler's equation,
  controller evaluated from the specification with the derived A, B, Q), for
  ring, path, star, complete and random connected graphs and random gains;
* the assembled form against a brute-force symbolic expansion;
* the closed-form conditions against dense eigenvalues;
* the K_vi bound against sampled and optimized attitudes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.optimize import minimize

from formsync_design.derive.closed_form import (
    closed_form_conditions,
    kv_condition_holds,
    required_kv,
)
from formsync_design.derive.closed_loop import derive_closed_loop
from formsync_design.derive.conditions import brute_force_vdot, derive_conditions, paper_conditions
from formsync_design.derive.templates import derive_local_template
from formsync_design.errors import DerivationError
from formsync_design.graphs.build import make_graph
from formsync_design.spec.lagrangian_view import ControllerView, LyapunovView
from formsync_design.spec.loader import load_spec

from .helpers import cross, model_numeric, random_inertia, random_quaternion

DATA = Path(__file__).parent / "data"
ev = model_numeric()


def _controller_fn(spec):
    v = ControllerView()
    u = spec.controller(v)
    return sp.lambdify([v.A, v.B, v.Q, v.qd, v.s, v.sigma, v.K_o, v.K_q, v.K_v, v.beta], u, "numpy")


def _lyapunov_fns(spec, degrees):
    out = {}
    for m in set(degrees):
        lv = LyapunovView(m)
        expr = sp.sympify(spec.lyapunov(lv))
        args = [*lv.qd, *[x for e in lv.edges for x in e], lv.K_o, lv.K_q, lv.beta]
        out[m] = sp.lambdify(args, expr, "numpy")
    return out


class Formation:
    """An independent numeric nonlinear formation: state (q, q0, omega) per spacecraft."""

    def __init__(self, graph, spec, gains, kv, J, ud, phi=0.05):
        self.g = graph
        self.spec = spec
        self.ko, self.kq, self.beta = gains
        self.kv, self.J, self.ud, self.phi = kv, J, ud, phi
        self.ctrl = _controller_fn(spec)
        self.V_fns = _lyapunov_fns(spec, graph.degrees)

    def split(self, x):
        n = self.g.n
        x = x.reshape(n, 7)
        return x[:, :3], x[:, 3], x[:, 4:]

    def s(self, q):
        return np.array([sum(q[i] - q[j] for j in self.g.neighbors(i)) for i in range(self.g.n)])

    def sigma(self, qd, s):
        return np.tanh((qd + self.beta * s) / self.phi)

    def rhs(self, t, x):
        q, q0, w = self.split(x)
        n = self.g.n
        qd = np.array([0.5 * (q0[i] * np.eye(3) + cross(q[i])) @ w[i] for i in range(n)])
        s = self.s(q)
        sig = self.sigma(qd, s)
        out = np.empty((n, 7))
        for i in range(n):
            A, B, Q = (ev(k, q[i], q0[i], qd[i], self.J[i]) for k in ("A", "B", "Q"))
            u = np.asarray(self.ctrl(A, B, Q, qd[i][:, None], s[i][:, None], sig[i][:, None],
                                     self.ko, self.kq, self.kv, self.beta), float).ravel()
            out[i, :3] = qd[i]
            out[i, 3] = -0.5 * q[i] @ w[i]
            out[i, 4:] = np.linalg.solve(self.J[i], -np.cross(w[i], self.J[i] @ w[i]) + u + self.ud[i])
        return out.ravel()

    def V(self, x):
        q, q0, w = self.split(x)
        total = 0.0
        for i in range(self.g.n):
            qd = 0.5 * (q0[i] * np.eye(3) + cross(q[i])) @ w[i]
            edges = [q[i] - q[j] for j in self.g.neighbors(i)]
            total += self.V_fns[self.g.degrees[i]](*qd, *np.ravel(edges), self.ko, self.kq, self.beta)
        return float(total)


def _vdot_formula(f: Formation, conds, x):
    q, q0, w = f.split(x)
    n = f.g.n
    qd = np.array([0.5 * (q0[i] * np.eye(3) + cross(q[i])) @ w[i] for i in range(n)])
    s = f.s(q)
    P = conds.pi.evaluate((f.ko, f.kq, f.beta))
    zeta = np.vstack([qd, s])  # (2n, 3): rows are zeta blocks, columns axes
    quad = -sum(zeta[:, ax] @ P @ zeta[:, ax] for ax in range(3))
    rq, rs = (float(sp.sympify(c).subs(sp.Symbol("beta", positive=True), f.beta)) for c in conds.rho)
    cl = derive_closed_loop(f.spec)
    c_sig = float(cl.c_sigma.subs(sp.Symbol("K_v", positive=True), f.kv))
    sig = f.sigma(qd, s)
    lin = 0.0
    for i in range(n):
        A, Q = ev("A", q[i], q0[i], qd[i], f.J[i]), ev("Q", q[i], q0[i], qd[i], f.J[i])
        d = np.linalg.solve(A, Q.T @ f.ud[i])
        lin += (rq * qd[i] + rs * s[i]) @ (c_sig * sig[i] + d)
    return quad + lin


def _random_formation(graph, spec, seed):
    rng = np.random.default_rng(seed)
    n = graph.n
    gains = tuple(float(x) for x in rng.uniform(0.2, 2.0, size=3))
    J = [random_inertia(rng) for _ in range(n)]
    ud = [0.05 * rng.normal(size=3) for _ in range(n)]
    x0 = []
    for _ in range(n):
        q, q0 = random_quaternion(rng)
        x0.extend([*q, q0, *(0.3 * rng.normal(size=3))])
    f = Formation(graph, spec, gains, float(rng.uniform(0.01, 0.1)), J, ud)
    return f, np.array(x0)


GRAPHS = ["ring:4", "path:4", "star:4", "complete:4", "random:5:0.5:11"]


@pytest.mark.parametrize("graph", GRAPHS)
@pytest.mark.parametrize("spec_file", [None, DATA / "variant_spec.py"])
def test_vdot_matches_finite_differences_along_nonlinear_formation(graph, spec_file):
    spec = load_spec(spec_file)
    g = make_graph(graph)
    conds = derive_conditions(g, spec)
    f, x0 = _random_formation(g, spec, seed=GRAPHS.index(graph) * 101 + (7 if spec_file else 0))
    h = 1e-3
    kw = dict(method="DOP853", rtol=1e-12, atol=1e-13)
    xp = solve_ivp(f.rhs, (0, h), x0, **kw).y[:, -1]
    xm = solve_ivp(f.rhs, (0, -h), x0, **kw).y[:, -1]
    fd = (f.V(xp) - f.V(xm)) / (2 * h)
    formula = _vdot_formula(f, conds, x0)
    assert fd == pytest.approx(formula, rel=1e-5, abs=1e-7)


@pytest.mark.parametrize("graph", ["path:3", "ring:4", "star:4", "complete:4", "random:5:0.6:3"])
@pytest.mark.parametrize("spec_file", [None, DATA / "variant_spec.py"])
def test_assembly_equals_brute_force_expansion(graph, spec_file):
    b, a = brute_force_vdot(graph, load_spec(spec_file))
    assert sp.expand(b - a) == 0
    assert b != 0


def test_closed_loop_of_the_paper_controller_numerically():
    """q'' from Euler's equation under the spec's controller equals the derived closed loop."""
    spec = load_spec()
    ctrl = _controller_fn(spec)
    cl = derive_closed_loop(spec)
    rng = np.random.default_rng(3)
    q, q0 = random_quaternion(rng)
    J = random_inertia(rng)
    w = rng.normal(size=3)
    s, sig, ud = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    ko, kq, kv, beta = 1.3, 0.7, 0.2, 0.4
    E = 0.5 * (q0 * np.eye(3) + cross(q))
    qd = E @ w
    A, B, Q = (ev(k, q, q0, qd, J) for k in ("A", "B", "Q"))
    u = np.asarray(ctrl(A, B, Q, qd[:, None], s[:, None], sig[:, None], ko, kq, kv, beta)).ravel()
    wdot = np.linalg.solve(J, -np.cross(w, J @ w) + u + ud)
    Edot = 0.5 * ((-0.5 * q @ w) * np.eye(3) + cross(qd))
    qdd = Edot @ w + E @ wdot
    sub = {sp.Symbol("K_o", positive=True): ko, sp.Symbol("K_q", positive=True): kq,
           sp.Symbol("K_v", positive=True): kv}
    c = [float(x.subs(sub)) for x in (cl.c_qd, cl.c_s, cl.c_sigma)]
    expected = c[0] * qd + c[1] * s + c[2] * sig + E @ np.linalg.solve(J, ud)
    assert np.allclose(qdd, expected, atol=1e-10)
    # and A^-1 Q^T = E J^-1 numerically (the disturbance map)
    assert np.allclose(np.linalg.solve(A, Q.T), E @ np.linalg.inv(J), atol=1e-12)


def test_theta_is_hessian_of_v_and_matches_printed():
    for g in ["ring:5", "star:5", "random:6:0.5:2"]:
        der, pap = derive_conditions(g), paper_conditions(g)
        for a, b in zip(der.theta, pap.theta):
            assert np.array_equal(a.evaluate((1.1, 0.7, 0.3)), b.evaluate((1.1, 0.7, 0.3)))


def test_printed_m_differs_from_derived_m():
    der, pap = derive_conditions("ring:8"), paper_conditions("ring:8")
    pt = (1.6, 0.4, 0.3)
    assert not np.allclose(der.pi.evaluate(pt), pap.pi.evaluate(pt))


@pytest.mark.parametrize("graph", ["ring:8", "star:8", "complete:6", "circulant:8:1,4",
                                   "path:7", "random:9:0.4:5"])
@pytest.mark.parametrize("which", ["derived", "paper"])
def test_closed_form_conditions_agree_with_eigenvalues(graph, which):
    conds = derive_conditions(graph) if which == "derived" else paper_conditions(graph)
    cfs = closed_form_conditions(conds)
    assert any(c.family.startswith("Pi") for c in cfs)
    assert any(c.family.startswith("Theta") for c in cfs)
    rng = np.random.default_rng(42)
    for _ in range(60):
        pt = tuple(rng.uniform(0.01, 3.0, size=3))
        pd_all = all(np.linalg.eigvalsh(f.evaluate(pt))[0] > 1e-9 for f in conds.families)
        border = min(np.linalg.eigvalsh(f.evaluate(pt))[0] for f in conds.families)
        if abs(border) < 1e-6:
            continue
        assert all(c.holds(pt) for c in cfs) == pd_all


def test_families_are_multiaffine_and_isotropic():
    conds = derive_conditions("random:8:0.5:1")
    assert all(f.is_multiaffine for f in conds.families)
    assert all(f.block_size == 3 for f in conds.families)


def test_large_graph_derives_and_keeps_laplacian_structure():
    conds = derive_conditions("random:300:0.03:4")
    n = conds.graph.n
    P = conds.pi.evaluate_sparse((2.0, 1.0, 0.5))
    rows = np.asarray(P[:n, :n].sum(axis=1)).ravel()
    assert np.allclose(rows, 2.0)  # M = K_o I - beta L and L 1 = 0
    assert len(conds.theta) == n


def test_switching_argument_matches_for_paper_not_for_variant():
    assert derive_conditions("ring:4").switching_matches is True
    assert derive_conditions("ring:4", load_spec(DATA / "variant_spec.py")).switching_matches is False


def test_controller_that_does_not_cancel_is_rejected():
    with pytest.raises(DerivationError, match="cancel"):
        derive_closed_loop(load_spec(DATA / "no_cancel_spec.py"))


def test_cross_axis_candidate_is_rejected():
    with pytest.raises(DerivationError, match="axes"):
        derive_local_template(2, load_spec(DATA / "cross_axis_spec.py"))


def test_required_kv_is_the_supremum_over_attitudes_and_disturbances():
    rng = np.random.default_rng(5)
    J = random_inertia(rng)
    ubar = 0.3
    bound = required_kv(J, ubar)
    best = 0.0
    for _ in range(400):
        q, q0 = random_quaternion(rng)
        E = 0.5 * (q0 * np.eye(3) + cross(q))
        A, Q = ev("A", q, q0, np.zeros(3), J), ev("Q", q, q0, np.zeros(3), J)
        ud = ubar * rng.choice([-1.0, 1.0], size=3) * rng.uniform(0.0, 1.0, size=3) ** 0.1
        d = np.linalg.solve(A, Q.T @ ud)
        assert np.allclose(d, E @ np.linalg.solve(J, ud))
        best = max(best, np.max(np.abs(d)))
    assert best <= bound * (1 + 1e-12)

    # the bound is attained: optimize over attitudes at the worst disturbance vertex
    def neg(x):
        v = x / np.linalg.norm(x)
        q, q0 = v[:3], abs(v[3])
        E = 0.5 * (q0 * np.eye(3) + cross(q))
        return -max(np.max(np.abs(E @ np.linalg.solve(J, ubar * np.array(s))))
                    for s in np.ndindex(2, 2, 2) for s in [2 * np.array(s) - 1])

    res = min((minimize(neg, rng.normal(size=4), method="Nelder-Mead",
                        options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 4000})
               for _ in range(5)), key=lambda r: r.fun)
    assert -res.fun == pytest.approx(bound, rel=1e-5)
    assert kv_condition_holds(bound * 1.0001, J, ubar)
    assert not kv_condition_holds(bound * 0.9999, J, ubar)


def test_family_coefficients_are_exact_python_rationals():
    """Plain-int Fractions (numpy integers would overflow silently in exact checks)."""
    for conds in (derive_conditions("star:6"), paper_conditions("ring:5")):
        for fam in conds.families:
            for t in fam.terms:
                assert type(t.coefficient.numerator) is int
                assert type(t.coefficient.denominator) is int
                hash(t.coefficient)


# --- structured (sparse) assembly, dense graphs, caching by specification content -----------
@pytest.mark.parametrize("graph", ["ring:8", "star:7", "path:5", "complete:7", "random:12:0.4:3",
                                   "circulant:10:1,3"])
@pytest.mark.parametrize("spec_file", [None, "variant_spec.py"])
def test_structured_assembly_equals_entrywise_assembly(graph, spec_file):
    """Two implementations of the Pi assembly agree term by term, exactly."""
    spec = None if spec_file is None else load_spec(DATA / spec_file)
    a = derive_conditions(graph, spec).pi
    b = derive_conditions(graph, spec, structured=False).pi
    assert [t.exponents for t in a.terms] == [t.exponents for t in b.terms]
    for x, y in zip(a.terms, b.terms):
        assert x.coefficient == y.coefficient and np.array_equal(x.dense(), y.dense())


def test_complete_200_has_the_laplacian_structure():
    """A dense graph derives quickly (sparse assembly); checked against the Laplacian
    formula at a dyadic gain point (exact in floating point)."""
    conds = derive_conditions("complete:200")
    n = 200
    ko, kq, b = 1.5, 0.25, 0.125
    P = conds.pi.evaluate_sparse((ko, kq, b)).toarray()
    L = make_graph("complete:200").laplacian
    assert np.array_equal(P[:n, :n], ko * np.eye(n) - b * L)
    assert np.array_equal(P[n:, n:], b * kq * np.eye(n)) and not P[:n, n:].any()
    assert all(t.matrix.nnz <= n * n for t in conds.pi.terms)  # stored sparse
    T = conds.theta[0].evaluate((ko, kq, b))
    assert T.shape == (n, n) and T[0, 0] == 0.5 and T[0, 1] == b / 2


def test_complete_graph_assembly_agrees_with_brute_force():
    b, a = brute_force_vdot("complete:4")
    assert sp.expand(b - a) == 0


def test_caches_follow_the_specification_content_not_its_path(tmp_path):
    """Rewriting a specification file at the same path yields the new derivation."""
    f = tmp_path / "spec.py"
    paper = (Path(load_spec().path)).read_text()
    f.write_text(paper)
    first = derive_conditions("ring:5", load_spec(f))
    f.write_text((DATA / "variant_spec.py").read_text())
    second = derive_conditions("ring:5", load_spec(f))
    pt = (1.1, 0.7, 0.3)
    assert np.array_equal(first.pi.evaluate(pt), derive_conditions("ring:5").pi.evaluate(pt))
    assert not np.array_equal(first.theta[0].evaluate(pt), second.theta[0].evaluate(pt))
    assert np.array_equal(second.theta[0].evaluate(pt),
                          derive_conditions("ring:5", DATA / "variant_spec.py").theta[0].evaluate(pt))


def test_spec_value_and_path_are_accepted_everywhere():
    spec = load_spec(DATA / "variant_spec.py")
    for s in (spec, DATA / "variant_spec.py", str(DATA / "variant_spec.py")):
        assert derive_closed_loop(s).spec_name == "variant"
        assert derive_conditions("ring:4", s).spec_name == "variant"
        assert derive_local_template(2, s).theta[2, 2] != derive_local_template(2).theta[2, 2]


def test_spec_built_in_python_derives_like_its_file():
    from formsync_design.spec.loader import Spec

    variant = load_spec(DATA / "variant_spec.py")
    inline = Spec.from_functions(variant.controller, variant.lyapunov, name="inline")
    pt = (1.1, 0.7, 0.3)
    a = derive_conditions("star:5", inline)
    b = derive_conditions("star:5", variant)
    assert a.spec_name == "inline" and b.spec_name == "variant"
    assert np.array_equal(a.pi.evaluate(pt), b.pi.evaluate(pt))
    assert not np.array_equal(a.pi.evaluate(pt), derive_conditions("star:5").pi.evaluate(pt))
