"""The lv2012 output-feedback design: derivation, certified L2 gain, gyro models, verification.

Independent truths: central finite differences of the compiled nonlinear kernel (the closed
loop and the storage's derivative), a dense frequency sweep of the linearisation (the
H-infinity norm), simulated forced responses (measured L2 gains from rest, a sinusoid's
steady gain), the classic Lagrangian simulator (controller (4)), the filter's closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from formsync_design.analysis.l2design import budget_bound, design_l2_gains
from formsync_design.analysis.l2freq import frequency_witness, hinf_norm
from formsync_design.analysis.l2gain import certify_gamma, certify_l2_box, harmonic_steady_bound
from formsync_design.derive.linearize import linearize_agents
from formsync_design.errors import InputError
from formsync_design.graphs.digraph_io import make_digraph
from formsync_design.sim.agent_kernel import agent_law, get_agent_kernel
from formsync_design.sim.agents import AgentFormation, AgentOptions, Reference, simulate_agents
from formsync_design.sim.formation import Gains
from formsync_design.sim.l2measure import measured_l2_gain, random_disturbance
from formsync_design.sim.sensors import RateSensors
from formsync_design.spec.loader import load_design

GAINS = {"k_p": 1.2, "k_d": 6.0, "a_f": 0.8}


@pytest.fixture(autouse=True)
def _vm(monkeypatch):
    monkeypatch.setenv("FORMSYNC_NO_COMPILE", "1")


@pytest.fixture(scope="module")
def design():
    return load_design("lv2012")


def _inertias(rng, n, scale=4.0):
    out = []
    for _ in range(n):
        M = rng.normal(size=(3, 3))
        out.append(np.diag(scale + rng.random(3)) + 0.1 * (M + M.T))
    return np.round(np.array(out), 2)


@pytest.fixture(scope="module")
def small(design):
    rng = np.random.default_rng(12)
    J = _inertias(rng, 3)
    g = make_digraph("path:3", pinning=[1, 0, 1])
    return g, J, linearize_agents(design, g, J)


def _state(rng, n, nz, spread=0.3):
    q = []
    for _ in range(n):
        v = rng.normal(size=3)
        v *= spread * rng.random() / np.linalg.norm(v)
        q.append([*v, math.sqrt(1 - v @ v)])
    return np.array(q), 0.05 * rng.normal(size=(n, 3)), 0.1 * rng.normal(size=(n, nz))


def test_linearisation_against_finite_differences_of_the_compiled_loop(design, small):
    g, J, lin = small
    n = g.n
    kern = get_agent_kernel(design, tuple(g.receives_from(i) for i in range(n)), "sgn", 1, 1,
                            compile=False)
    from formsync_design.sim.agent_kernel import agent_parameters

    f = AgentFormation(g, J, np.tile([0, 0, 0, 1.0], (n, 1)), np.zeros((n, 3)), Gains(GAINS),
                       None, Reference())
    p = agent_parameters(design, f, AgentOptions(), kern.layout)

    def rhs(q, w, z):
        x = np.concatenate([np.concatenate([qi, [math.sqrt(1 - qi @ qi)]]) for qi in q]
                           + [w.ravel(), z.ravel(), [0, 0, 0, 1.0]])
        xd = np.asarray(kern.rhs(x, 0.0, p)).ravel()
        qd = np.concatenate([xd[4 * i: 4 * i + 3] for i in range(n)])
        return np.concatenate([qd, xd[4 * n: 7 * n], xd[7 * n: 10 * n]])

    z0 = np.zeros((n, 3))
    A_fd = np.zeros((lin.nx, lin.nx))
    h = 1e-6
    for j in range(lin.nx):
        parts = [np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))]
        parts[j // (3 * n)].flat[j % (3 * n)] = h
        plus = rhs(parts[0], parts[1], z0 + parts[2])
        minus = rhs(-parts[0], -parts[1], z0 - parts[2])
        A_fd[:, j] = (plus - minus) / (2 * h)
    A, _, _ = lin.standard(GAINS)
    assert np.abs(A - A_fd).max() < 1e-7 * max(1.0, np.abs(A).max())


def test_storage_derivative_along_the_compiled_loop(design, small):
    """V' = -k_d sum |y_i|^2 (d = 0) at random states, by a finite difference of V along the
    kernel's right-hand side: the symbolic identity checked by an independent route."""
    g, J, _ = small
    n = g.n
    kern = get_agent_kernel(design, tuple(g.receives_from(i) for i in range(n)), "sgn", 1, 1,
                            compile=False)
    from formsync_design.sim.agent_kernel import agent_parameters

    f = AgentFormation(g, J, np.tile([0, 0, 0, 1.0], (n, 1)), np.zeros((n, 3)), Gains(GAINS),
                       None, Reference())
    p = agent_parameters(design, f, AgentOptions(), kern.layout)
    kp, kd, af = GAINS["k_p"], GAINS["k_d"], GAINS["a_f"]
    b = [float(x) for x in g.pinning]

    def V(x):
        Q = x[: 4 * n].reshape(n, 4)
        W = x[4 * n: 7 * n].reshape(n, 3)
        Z = x[7 * n: 10 * n].reshape(n, 3)
        out = sum(0.5 * W[i] @ J[i] @ W[i] + 2 * kp * b[i] * (1 - Q[i, 3])
                  + kd * af / 2 * np.sum((Q[i, :3] - Z[i]) ** 2) for i in range(n))
        for i, j, a in g.arcs:  # each undirected edge twice: half weight
            eta = Q[j, 3] * Q[i, 3] + Q[j, :3] @ Q[i, :3]
            out += kp * float(a) * (1 - eta)
        return out

    rng = np.random.default_rng(3)
    for _ in range(5):
        Q, W, Z = _state(rng, n, 3, 0.9)
        x = np.concatenate([Q.ravel(), W.ravel(), Z.ravel(), [0, 0, 0, 1.0]])
        xd = np.asarray(kern.rhs(x, 0.0, p)).ravel()
        h = 1e-6
        vdot = (V(x + h * xd) - V(x - h * xd)) / (2 * h)
        y = af * (Q[:, :3] - Z)
        assert vdot == pytest.approx(-kd * np.sum(y**2), rel=1e-6, abs=1e-10)


def test_the_filter_realises_its_transfer_function(design):
    text, ok = design.module["filter_transfer"](design)
    assert ok and text == "a_f*s/(a_f + s)"
    # the compiled law's filter derivative is a_f (e - x) (e = vec(q_r^* q)): the closed form
    # x(t) = e (1 - e^{-a_f t}) for a constant e from x(0) = 0, integrated by the kernel
    law = agent_law(design, 0).law
    rng = np.random.default_rng(1)
    Q, _, Z = _state(rng, 1, 3)
    out = law(own=[*Q[0], 0, 0, 0, *Z[0]], J=np.eye(3), t=0, b=1, ref=[0, 0, 0, 1] + [0] * 6,
              gains=[1.0, 2.0, 0.7], phi=0.01)
    assert np.allclose(np.asarray(out["zdot"]).ravel(), 0.7 * (Q[0, :3] - Z[0]), atol=1e-15)


def test_no_rate_anywhere_and_gyro_models_leave_the_design_unchanged(design, small):
    assert "rate" not in design.decl.measured
    g, J, _ = small
    rng = np.random.default_rng(4)
    Q, W, _ = _state(rng, 3, 3, 0.6)
    f = AgentFormation(g, J, Q, W, Gains(GAINS), None, Reference())
    opt = AgentOptions(tf=20, output_step=0.5, step=0.05)
    runs = [simulate_agents(design, f, opt, sensors=s) for s in
            (RateSensors.of(3), RateSensors.of(3, bias=1e-3, noise_std=1e-2, seed=1),
             RateSensors.of(3, failed={2: 0.0}))]
    assert all(np.array_equal(r.quaternions, runs[0].quaternions) for r in runs)


def test_controller4_agent_form_matches_the_classic_simulator_and_feels_its_gyro():
    import formsync_design as fs
    from formsync_design.models.disturbances import no_disturbance
    from formsync_design.sim.formation import Formation, SimOptions

    rng = np.random.default_rng(5)
    gr = fs.make_graph("ring:3")
    J = _inertias(rng, 3, 50.0)
    Q, W, _ = _state(rng, 3, 3, 0.6)
    d = load_design("liang2016")  # the agent form of the one design
    af = AgentFormation(gr, J, Q, W, Gains({"K_o": 1.6, "K_q": 0.4, "beta": 0.3, "K_v": 0.01}))
    opt = AgentOptions(tf=5, output_step=0.1, step=0.01, switch="tanh", phi=0.05)
    ra = simulate_agents(d, af, opt)
    rc = fs.simulate(Formation(gr, J, Q, W, Gains(1.6, 0.4, 0.3, (0.01,) * 3), no_disturbance(3)),
                     SimOptions(tf=5, output_step=0.1, step=0.01, switch="tanh", phi=0.05))
    xa = np.concatenate([ra.quaternions.reshape(len(ra.t), -1), ra.rates.reshape(len(ra.t), -1)],
                        axis=1)
    assert np.abs(xa - rc.x).max() < 1e-8
    rb = simulate_agents(d, af, opt, sensors=RateSensors.of(3, bias=1e-3, seed=2))
    assert np.abs(rb.quaternions - ra.quaternions).max() > 1e-6  # (4) reads the biased gyro


def test_certified_gamma_bounds_the_norm_and_every_measured_gain(design):
    """gamma >= the H-inf norm of a dense sweep, and >= the measured L2 gain of the nonlinear
    loop from rest on random disturbances (seeded); the peak sinusoid comes close."""
    rng = np.random.default_rng(7)
    g = make_digraph("path:2", pinning=[1, 1])
    J = _inertias(rng, 2, 2.0)
    lin = linearize_agents(design, g, J)
    cert = certify_gamma(lin, GAINS)
    assert cert.certified
    A, B, C = lin.standard(GAINS)
    sweep = max(np.linalg.svd(C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B),
                              compute_uv=False)[0] for w in np.linspace(0, 5, 5001))
    # the level is the norm rounded up to 4 significant digits
    assert sweep <= float(cert.gamma) <= sweep * 1.0015 + 10 ** (math.floor(math.log10(sweep)) - 3)
    n, h, tf = 2, 0.05, 150.0
    steps = int(tf / h)
    f = AgentFormation(g, J, np.tile([0, 0, 0, 1.0], (n, 1)), np.zeros((n, 3)), Gains(GAINS),
                       None, Reference())
    opt = AgentOptions(tf=tf, output_step=h, step=h)
    gains = []
    for k in range(12):
        u = random_disturbance(rng, ("white", "multisine", "steps")[k % 3], steps, n, h,
                               rms=1e-3, w_max=2 * max(cert.peak_frequency, 0.1))
        gains.append(measured_l2_gain(simulate_agents(design, f, opt, torque_input=u), u, h))
    assert max(gains) <= float(cert.gamma)
    w = cert.peak_frequency
    M = C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B)
    v = np.linalg.svd(M)[2][0].conj()
    t = np.arange(steps) * h
    u = 1e-3 * np.real(np.exp(1j * w * t)[:, None] * v[None, :]).reshape(steps, n, 3)
    peak = measured_l2_gain(simulate_agents(design, f, opt, torque_input=u), u, h)
    assert 0.8 * float(cert.gamma) <= peak <= float(cert.gamma)


def test_riccati_and_sdp_certify_the_same_level(small):
    _, _, lin = small
    a = certify_gamma(lin, GAINS)
    b = certify_gamma(lin, GAINS, method="sdp")
    assert a.certified and b.certified
    assert abs(float(a.gamma) - float(b.gamma)) <= 2e-3 * float(a.gamma)


def test_refuted_box_comes_with_an_exact_witness(small):
    _, _, lin = small
    box = {"k_p": (1.1, 1.3), "k_d": 6.0, "a_f": 0.8}
    A, B, C = lin.standard({"k_p": 1.1, "k_d": 6.0, "a_f": 0.8})
    h, _ = hinf_norm(A, B, C)
    r = certify_l2_box(lin, box, round(0.9 * h, 3))
    assert str(r.status) == "refuted" and r.witness is not None and r.witness.holds()
    w = r.witness
    pt = {k: float(v) for k, v in w.point.items()}
    A, B, C = lin.standard(pt)
    u = np.array([complex(float(a), float(b)) for a, b in w.u])
    X = np.linalg.solve(1j * float(w.omega) * np.eye(A.shape[0]) - A, B @ u)
    assert np.linalg.norm(C @ X) / np.linalg.norm(u) == pytest.approx(w.gain, rel=1e-6)
    assert w.gain > float(w.gamma)
    assert frequency_witness(lin, pt, 2 * h) is None          # nothing to refute above the norm
    assert certify_l2_box(lin, {"k_p": (1.1, 1.12), "k_d": 6.0, "a_f": 0.8}, 1.5 * h).certified


def test_gain_design_respects_the_torque_budget_and_the_bound_holds(design, small):
    g, J, lin = small
    r = design_l2_gains(design, lin, 3, grid=3)
    assert r.certificate.certified and r.torque_bound <= 3
    law = agent_law(design, 1).law
    rng = np.random.default_rng(9)
    kp, kd, af = 0.7, 3.0, 0.9
    bound = float(budget_bound(design, lin, {"k_p": kp, "k_d": kd, "a_f": af}))
    worst = 0.0
    for _ in range(300):
        Q, _, _ = _state(rng, 2, 3, 1.0)
        x = rng.normal(size=3)
        x /= max(1.0, float(np.linalg.norm(x)))
        out = law(own=[*Q[0], 0, 0, 0, *x], J=np.eye(3), t=0, nbrs=[*Q[1], 0, 0, 0, 0, 0, 0],
                  a=[1], b=1, ref=[0, 0, 0, 1] + [0] * 6, gains=[kp, kd, af], phi=0.01)
        worst = max(worst, float(np.linalg.norm(np.asarray(out["u"]))))
    assert worst <= bound  # b + degree = 2 for this spacecraft, the largest in path:3 + pinning
    assert worst >= 0.5 * (2 * kp)


def test_harmonic_steady_bound_against_a_simulated_steady_state(design, small):
    from formsync_design.models.disturbances import harmonic_disturbance

    g, J, lin = small
    cert = certify_gamma(lin, GAINS)
    model = harmonic_disturbance(3, [2e-3, 1e-3, 0], [0.3, 0.5, 0.1], [1e-3, 0, 5e-4])
    zb = harmonic_steady_bound(cert.gamma, model.harmonic)
    f = AgentFormation(g, J, np.tile([0, 0, 0, 1.0], (3, 1)), np.zeros((3, 3)), Gains(GAINS),
                       model, Reference())
    r = simulate_agents(design, f, AgentOptions(tf=300, output_step=0.5, step=0.05))
    z = np.linalg.norm(r.quaternions[-200:, :, :3].reshape(200, -1), axis=1)
    assert 0.2 * zb < z.max() <= zb


def test_sensor_and_input_validation(design, small):
    g, J, _ = small
    f = AgentFormation(g, J, np.tile([0, 0, 0, 1.0], (3, 1)), np.zeros((3, 3)), Gains(GAINS),
                       None, Reference())
    with pytest.raises(InputError, match="torque input of shape"):
        simulate_agents(design, f, AgentOptions(tf=1, output_step=0.5, step=0.05),
                        torque_input=np.zeros((3, 3, 3)))
    with pytest.raises(InputError, match="rk4"):
        simulate_agents(design, f, AgentOptions(tf=1, output_step=0.5, integrator="cvodes"),
                        sensors=RateSensors.of(3))
    with pytest.raises(InputError, match="failed spacecraft"):
        RateSensors.of(3, failed={4: 0.0})
    s = RateSensors.of(3, bias=1e-3, noise_std=2e-3, seed=3)
    off = s.offsets(20000, 0.01)
    assert np.allclose(off.mean(axis=0), s.bias, atol=1e-4)
    assert np.allclose((off - s.bias).std(axis=0), 2e-3, rtol=0.05)


def test_the_case_is_an_engine_case_with_the_filter_metric():
    from formsync_design.resources import case_file
    from formsync_design.tomlio import load_toml
    from formsync_design.verify.enginecase import load_engine_case

    path = case_file("lv2012")
    assert load_toml(path, "case")["case"]["kind"] == "engine"
    case = load_engine_case(path)
    assert {m.spec.name for m in case.metrics} >= {"lead_filter_transfer", "certified_l2_gain",
                                                    "measured_l2_gain_max", "large_angle_scope"}
