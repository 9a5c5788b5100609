"""The sympy -> CasADi bridge against sympy's own evaluation and an independent numpy controller."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from formsync_design.errors import DerivationError, InputError
from formsync_design.models.attitude import derive_attitude_model
from formsync_design.sim.bridge import (
    build_controller,
    matrix_expr_to_casadi,
    model_function,
    switch_function,
    sympy_to_casadi,
)

from .numpy_reference import skew, switch as np_switch


def _random_state(rng: np.random.Generator):
    q = rng.uniform(-0.5, 0.5, 3)
    q0 = float(np.sqrt(1 - q @ q))
    qd = rng.normal(size=3)
    M = rng.normal(size=(3, 3))
    J = M @ M.T + 40 * np.eye(3)
    return q, q0, qd, J


def test_model_function_matches_sympy_evaluation():
    m = derive_attitude_model()
    f = model_function()
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, q0, qd, J = _random_state(rng)
        subs = {m.q[k]: q[k] for k in range(3)}
        subs.update({m.qd[k]: qd[k] for k in range(3)})
        subs[m.q0] = q0
        subs.update({m.J[i, k]: J[i, k] for i in range(3) for k in range(3)})
        out = f(q=q, q0=q0, qd=qd, J=J)
        for name in ("E", "Q", "A", "B"):
            ref = np.array(getattr(m, name).evalf(subs=subs), dtype=float)
            np.testing.assert_allclose(out[name].full(), ref, rtol=1e-12, atol=1e-12)


def test_model_E_is_inverse_of_Q_on_sphere_only():
    f = model_function()
    q = np.array([0.2, -0.1, 0.3])
    q0 = float(np.sqrt(1 - q @ q))
    out = f(q=q, q0=q0, qd=np.zeros(3), J=np.eye(3))
    np.testing.assert_allclose(out["E"].full() @ out["Q"].full(), np.eye(3), atol=1e-14)
    off = f(q=q, q0=1.1 * q0, qd=np.zeros(3), J=np.eye(3))
    assert np.abs(off["E"].full() @ off["Q"].full() - np.eye(3)).max() > 1e-3


def _np_controller(q, q0, qd, J, s, K_o, K_q, beta, K_v, kind, phi):
    """Independent closed-form controller (4) (numpy, not through the bridge)."""
    Q = 2 * (q0 * np.eye(3) - skew(q) + np.outer(q, q) / q0)
    q0d = -q @ qd / q0
    Qd = 2 * (q0d * np.eye(3) - skew(qd) + (np.outer(qd, q) + np.outer(q, qd)) / q0 - np.outer(q, q) * q0d / q0**2)
    A = Q.T @ J @ Q
    B = Q.T @ J @ Qd - Q.T @ skew(J @ Q @ qd) @ Q
    tau = qd + beta * s
    return np.linalg.solve(Q.T, (B - K_o * A) @ qd - K_q * A @ s - K_v * A @ np_switch(kind, tau, phi))


@pytest.mark.parametrize("kind", ["sgn", "sat", "tanh"])
@pytest.mark.parametrize("inverse", ["E", "solve"])
def test_controller_matches_independent_numpy(kind, inverse):
    f = build_controller(switch=kind, inverse=inverse).function
    rng = np.random.default_rng(2)
    for _ in range(4):
        q, q0, qd, J = _random_state(rng)
        s = rng.normal(scale=0.1, size=3)
        gains = dict(K_o=1.6, K_q=0.4, beta=0.3, K_v=0.02, phi=0.05)
        u = f(q=q, q0=q0, qd=qd, J=J, s=s, **gains)["u"].full().ravel()
        ref = _np_controller(q, q0, qd, J, s, gains["K_o"], gains["K_q"], gains["beta"], gains["K_v"],
                             kind, gains["phi"])
        np.testing.assert_allclose(u, ref, rtol=1e-10, atol=1e-10)


def test_controller_inverse_E_differs_off_sphere():
    fe = build_controller(inverse="E").function
    fs = build_controller(inverse="solve").function
    q = np.array([0.3, 0.1, -0.2])
    q0 = float(np.sqrt(1 - q @ q)) * 1.01  # off the unit sphere
    args = dict(q=q, q0=q0, qd=np.array([0.1, -0.2, 0.3]), J=np.diag([50.0, 55, 60]), s=np.array([0.05, 0, 0]),
                K_o=1.6, K_q=0.4, beta=0.3, K_v=0.01, phi=0.01)
    ue = fe(**args)["u"].full()
    us = fs(**args)["u"].full()
    assert np.abs(ue - us).max() > 1e-6  # documented: exact only on the unit sphere


def test_closed_loop_identity_through_bridge():
    """With u from (4) and u_d = 0, A q'' + B q' = Q^T u gives q'' = -K_o q' - K_q s - K_v sigma."""
    mf = model_function()
    cf = build_controller(switch="tanh").function
    rng = np.random.default_rng(3)
    q, q0, qd, J = _random_state(rng)
    s = rng.normal(scale=0.1, size=3)
    out = cf(q=q, q0=q0, qd=qd, J=J, s=s, K_o=1.6, K_q=0.4, beta=0.3, K_v=0.02, phi=0.05)
    m = mf(q=q, q0=q0, qd=qd, J=J)
    A, B, Q = (m[k].full() for k in ("A", "B", "Q"))
    qdd = np.linalg.solve(A, Q.T @ out["u"].full().ravel() - B @ qd)
    sigma = out["sigma"].full().ravel()
    np.testing.assert_allclose(qdd, -1.6 * qd - 0.4 * s - 0.02 * sigma, rtol=1e-9, atol=1e-11)


def test_switch_functions():
    t = ca.SX.sym("t")
    vals = np.array([-1.0, -0.005, 0.0, 0.002, 3.0])
    for kind in ("sgn", "sat", "tanh"):
        fn = ca.Function("f", [t], [switch_function(kind, t, 0.01)])
        got = np.array([float(fn(v)) for v in vals])
        np.testing.assert_allclose(got, np_switch(kind, vals, 0.01), atol=1e-15)
    with pytest.raises(InputError):
        switch_function("relay", t, 0.1)
    with pytest.raises(InputError):
        build_controller(switch="bang")


def test_sympy_to_casadi_numbers_and_functions():
    x, y = sp.symbols("x y")
    X, Y = ca.SX.sym("x"), ca.SX.sym("y")
    e = sp.sin(x) * sp.sqrt(y) + x**-2 - sp.Rational(3, 4) * sp.tanh(y) + sp.Abs(x - y)
    f = ca.Function("f", [X, Y], [sympy_to_casadi(e, {x: X, y: Y})])
    ref = float(e.subs({x: 0.7, y: 2.5}))
    assert abs(float(f(0.7, 2.5)) - ref) < 1e-14


def test_unbound_and_unsupported_raise():
    x, y = sp.symbols("x y")
    with pytest.raises(DerivationError, match="binding for symbol y"):
        sympy_to_casadi(x + y, {x: 1.0})
    with pytest.raises(DerivationError, match="explicit scalar"):
        sympy_to_casadi(sp.gamma(x), {x: 1.0})
    M = sp.MatrixSymbol("M", 3, 3)
    with pytest.raises(DerivationError, match="binding for matrix M"):
        matrix_expr_to_casadi(M * M.T, {}, {})
    with pytest.raises(DerivationError, match="matrix expression"):
        matrix_expr_to_casadi(sp.HadamardProduct(M, M), {"M": ca.SX.sym("m", 3, 3)}, {})
    with pytest.raises(DerivationError, match="shape"):
        matrix_expr_to_casadi(M, {"M": ca.SX.sym("m", 2, 2)}, {})


def test_matrix_expr_inverse_mapping_and_fallback():
    Qs = sp.MatrixSymbol("Q", 2, 2)
    v = sp.MatrixSymbol("v", 2, 1)
    Qx = ca.SX.sym("Q", 2, 2)
    vx = ca.SX.sym("v", 2)
    Ex = ca.SX.sym("E", 2, 2)
    mapped = matrix_expr_to_casadi(Qs.I.T * v, {"Q": Qx, "v": vx}, {}, {"Q": Ex})
    fallback = matrix_expr_to_casadi(Qs.I.T * v, {"Q": Qx, "v": vx}, {})
    Qn = np.array([[2.0, 1.0], [0.5, 3.0]])
    vn = np.array([1.0, -2.0])
    fm = ca.Function("fm", [Ex, vx], [mapped])
    ff = ca.Function("ff", [Qx, vx], [fallback])
    np.testing.assert_allclose(fm(np.linalg.inv(Qn), vn).full().ravel(), np.linalg.solve(Qn.T, vn), atol=1e-14)
    np.testing.assert_allclose(ff(Qn, vn).full().ravel(), np.linalg.solve(Qn.T, vn), atol=1e-14)


def test_controller_follows_the_specification_and_its_key():
    """The variant's -2 K_q A s term makes its torque at K_q equal the paper's at 2 K_q;
    both translations are cached under their own content keys."""
    from pathlib import Path

    from formsync_design.spec.loader import load_spec

    variant = load_spec(Path(__file__).parent / "data" / "controller_variant_spec.py")
    cv = build_controller(variant, switch="tanh")
    cp = build_controller(None, switch="tanh")
    assert cv.spec_key == variant.key and cp.spec_key == load_spec(None).key != cv.spec_key
    rng = np.random.default_rng(31)
    for _ in range(5):
        q, q0, qd, J = _random_state(rng)
        s = rng.normal(size=3)
        args = dict(q=q, q0=q0, qd=qd, J=J, s=s, K_o=1.6, beta=0.3, K_v=0.02, phi=0.05)
        uv = cv.function(K_q=0.4, **args)["u"].full().ravel()
        up2 = cp.function(K_q=0.8, **args)["u"].full().ravel()
        up1 = cp.function(K_q=0.4, **args)["u"].full().ravel()
        np.testing.assert_allclose(uv, up2, rtol=1e-12, atol=1e-12)
        assert np.abs(uv - up1).max() > 1e-3
    assert build_controller(variant, switch="tanh").function is cv.function  # cache hit
