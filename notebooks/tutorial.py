# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # formsync-design in a notebook
#
# From a communication graph to a verified design, with the public API
# `import formsync_design as fs`:
#
# 1. a **graph** of spacecraft;
# 2. the **derivation**: the controller law and Lyapunov candidate (a
#    *specification*) give, for this graph, matrices `Θ_i(K_o, K_q, β)` and
#    `Π(K_o, K_q, β)` that must be positive definite;
# 3. a **certificate** for a whole box of gains, and a **map** of the region
#    where the conditions hold;
# 4. a **simulation** of the nonlinear formation with certified gains, with
#    figures shown inline;
# 5. the **verification** of a published case's claims.
#
# This file is a text notebook (jupytext "percent" format): open it in
# Jupyter with jupytext installed, or run it as a script. The test suite
# executes it (`tests/test_notebook.py`), so every cell here runs.
# Nothing here selects a matplotlib backend: figures render inline.

# %%
import tempfile
from pathlib import Path

import formsync_design as fs

print(fs.__version__)

# %% [markdown]
# ## 1. A graph
#
# Graph specifications: `ring:N`, `path:N`, `star:N`, `complete:N`,
# `circulant:N:a,b`, `random:N:P:SEED`, or an edge-list/adjacency file.
# The Laplacian's largest eigenvalue enters the coupling condition.

# %%
ring = fs.make_graph("ring:8")
star = fs.make_graph("star:8")
for g in (ring, star):
    print(f"{g.name}: {g.n} spacecraft, {len(g.edges)} edges, "
          f"lambda_max(L) = {g.laplacian_spectral_radius:g}")

# %% [markdown]
# ## 2. The derivation
#
# The specification is a value: `fs.load_spec()` is the paper's (Liang et
# al. 2016, shipped with the package); `fs.load_spec("my_spec.py")` loads your
# own file with `controller(view)` and `lyapunov(view)`.  `derive_conditions`
# derives the closed loop and `V̇`, and returns the families of matrices that
# must be positive definite.

# %%
spec = fs.load_spec()
conds = fs.derive_conditions(ring, spec=spec)
print(spec.name, "-", spec.title)
for family in conds.families[:2]:
    print(f"{family.name}: {family.size}x{family.size}, gains {family.gains}, "
          f"multi-affine: {family.is_multiaffine}")
for condition in fs.closed_form_conditions(conds):
    print(f"{condition.family:12} {condition.expression} > 0   ({condition.how})")

# %% [markdown]
# ### Your own specification, written here
#
# A specification can also be built from two Python functions.  `controller(v)`
# returns the control torque and `lyapunov(v)` the candidate, both in terms of
# the symbolic view `v` (the model matrices `v.A`, `v.B`, `v.Q`, the gains
# `v.K_o`, `v.K_q`, `v.beta`, `v.K_v`, the rates `v.qd`, the relative attitudes
# `v.s` and `v.edges`, the switching function `v.sw`).  Its `key` is a digest
# of its content: every cache (derivations, compiled kernels) is keyed by it.
# Here: the paper's controller with a different Lyapunov candidate (half the
# cross weight and an extra `|s_i|²` term), then a stiffer controller.

# %%
def paper_controller(v):
    """Controller (4) of the paper."""
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - v.K_q * v.A * v.s - v.K_v * v.A * v.sw(tau))


def variant_lyapunov(v):
    """Half the cross weight of Theorem 1's candidate, plus beta^2/8 |s_i|^2."""
    s = v.s
    return ((v.K_q + v.beta * v.K_o) / 4 * sum((e.dot(e) for e in v.edges), 0)
            + v.qd.dot(v.qd) / 2
            + v.beta / 2 * sum((e.dot(v.qd) for e in v.edges), 0)
            + v.beta**2 / 8 * s.dot(s))


variant = fs.Spec.from_functions(paper_controller, variant_lyapunov, name="variant")
print(variant.name, variant.source, variant.key[:16])
variant_conds = fs.derive_conditions(ring, spec=variant)
print("paper's gains, variant candidate:", fs.certify_box(variant_conds, {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}).status)

# %% [markdown]
# ## 3. Certify a gain box, map the admissible region
#
# `certify_box` decides whether the conditions hold for **every** gain in the
# box; the solver only gives a hint, the exact re-check decides.  The paper's
# gains `(K_o, K_q, β) = (1.6, 0.4, 0.3)` are certified on the ring and refuted
# on the star (with a witness).

# %%
paper_gains = {"K_o": 1.6, "K_q": 0.4, "beta": 0.3}
for g in (ring, star):
    result = fs.certify_box(fs.derive_conditions(g, spec=spec), paper_gains)
    print(f"{g.name}: {result.status}")
box = fs.GainBox.parse({"K_o": "1.3:2", "K_q": "0.2:1", "beta": "0.1:0.3"})
print("box", box.names, "->", fs.certify_box(conds, box).status)

# %% [markdown]
# Results show themselves in a notebook: the last expression of a cell renders its
# headline figures (status, certified margin, witness), and `to_pandas()` gives the table
# behind them (here one row per matrix family; pandas is the `notebook` extra).

# %%
certificate = fs.certify_box(conds, box)
certificate

# %%
certificate.to_pandas()

# %% [markdown]
# A region map classifies sub-boxes as certified, refuted or undecided (small
# resolution here to keep the notebook quick); `plot_slices` returns a figure,
# which the notebook shows inline.

# %%
region = fs.region_map(conds, {"K_o": (0.05, 5), "K_q": (0.05, 5), "beta": (0.01, 1)},
                       resolution=6)
print({k: round(v, 3) for k, v in region.fractions.items()})
fs.plot_slices([region])

# %%
region  # the certified, refuted and undecided fractions; region.to_pandas(): one row per box

# %% [markdown]
# ## 4. Simulate the nonlinear formation
#
# The paper's case (8 spacecraft, Table 1 initial conditions, disturbances)
# ships with the package.  `simulate` compiles the right-hand side built from
# the same specification.

# %%
case = fs.load_case()
formation = case.formation("ring:8")
options = fs.SimOptions(tf=100.0)
run = fs.simulate(formation, options)
print(run.status, "convergence time:", run.convergence_time)

# %%
run  # a result shows its headline figures: status, convergence time, final metrics

# %%
series = run.to_pandas()  # one row per output time: t, q_m, omega_m and the torques
series[["t", "q_m", "omega_m"]].tail()

# %%
fs.metric_figure(run, "omega")

# %%
fs.metric_figure(run, "q")

# %% [markdown]
# The same formation under a variant controller (twice the attitude gain),
# written inline: the specification travels with the call, and its compiled
# kernel is cached beside the paper's.

# %%
def stiffer_controller(v):
    """Controller (4) with twice the attitude gain K_q."""
    tau = v.qd + v.beta * v.s
    return v.Q.I.T * ((v.B - v.K_o * v.A) * v.qd - 2 * v.K_q * v.A * v.s
                      - v.K_v * v.A * v.sw(tau))


stiffer = fs.Spec.from_functions(stiffer_controller, variant_lyapunov, name="stiffer")
stiff_run = fs.simulate(formation, options, spec=stiffer)
print(stiff_run.status, "convergence time:", stiff_run.convergence_time)

# %%
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(6, 3))
ax.semilogy(run.t, run.q_m, label="paper's controller (4)")
ax.semilogy(stiff_run.t, stiff_run.q_m, label="2 K_q")
ax.set_xlabel("t (s)")
ax.set_ylabel("Q_m")
ax.legend()
fig

# %% [markdown]
# ## 5. Verify a published case
#
# A case file states a design's parameters, the formations (graphs) and scenarios it is
# verified on, the metrics to measure (named measurements from one registry) and the paper's
# claims as predicates over them; `verify_case` computes every metric (simulations are
# evidence, certificates proof) and judges every claim.  Here a small three-spacecraft case,
# written inline to show the format (the paper's is `verification/liang2016.toml`, run by
# `formsync verify liang2016`; the schema is `docs/engine.md`).

# %%
CASE = """
[case]
kind = "engine"
name = "small3"
title = "three spacecraft from the paper's Table 1"
source = "tutorial"
design = "liang2016"
graph = "ring:3"
assumptions = ["a tutorial case"]

[gains]
K_q = 0.4
K_o = 1.6
beta = 0.3
K_v = 0.01

[orbit]
altitude_km = 400.0

[disturbance]
model = "paper"

[simulation]
tf = 80.0
switch = "sat"
boundary_layer = 0.01
output_step = 0.1

[[spacecraft]]
inertia = [[50, 0, 4], [0, 55, 0], [4, 0, 60]]
rate = [0.085, -0.043, 0.077]
q = [0.1, 0.4, -0.3]

[[spacecraft]]
inertia = [[52, 1, 0.5], [1, 54, 3], [0.5, 3, 62]]
rate = [0.052, -0.026, 0.033]
q = [0.3, 0.2, 0.3]

[[spacecraft]]
inertia = [[53, 0.4, 0], [0.4, 54, 0.8], [0, 0.8, 58]]
rate = [-0.026, 0.022, -0.013]
q = [-0.2, 0.1, -0.1]

[[formations]]
name = "ring3"

[[formations]]
name = "path3"
graph = "path:3"

[[metrics]]
id = "t_ring3"
metric = "relative_convergence_time"
formation = "ring3"
q_tol = 1e-4
omega_tol = 1e-5

[[metrics]]
id = "t_path3"
metric = "relative_convergence_time"
formation = "path3"
q_tol = 1e-4
omega_tol = 1e-5

[[metrics]]
id = "pi_ring3"
metric = "lagrangian_certificate"
formation = "ring3"
family = "Pi"

[[metrics]]
id = "pi_path3"
metric = "lagrangian_certificate"
formation = "path3"
family = "Pi"

[[claims]]
id = "convergence"
text = "converges within 60 s on both connected graphs"
source = "tutorial"
predicate = "t_ring3 <= 60 and t_path3 <= 60"

[[claims]]
id = "pi_pd"
text = "Pi positive definite on both connected graphs"
source = "tutorial"
predicate = 'pi_ring3 == "certified" and pi_path3 == "certified"'
"""
case_path = Path(tempfile.mkdtemp()) / "small3.toml"
case_path.write_text(CASE, encoding="utf-8")
verification = fs.verify_case(case_path)
for claim in verification.claims:
    print(f"{claim.verdict:10} [{claim.basis}] {claim.claim.text}")

# %%
verification.to_pandas()[["claim", "verdict", "basis"]]  # the same as a table: one row per claim

# %% [markdown]
# ## 6. An agent design: a law on SO(3) over a directed weighted graph
#
# The papers' other designs are written per spacecraft in their own representation
# (`FORM = "agent"`): here a geometric PD consensus on rotation matrices, with the weights of a
# directed graph, written inline.  The loader checks the law symbolically (it may use only the
# quantities the view provides); the engine compiles it and simulates the formation.

# %%
import numpy as np
import sympy as sp


def so3_consensus(v):
    e = sp.zeros(3, 1)
    for n in v.nbrs:  # in-neighbours, each with its weight a_ij and rotation matrix R_j
        e += n.a * v.vee(n.R.T * v.R - v.R.T * n.R) / 2
    return v.w.cross(v.J * v.w) - v.J * (v.k_R * e + v.k_w * v.w)


design = fs.AgentDesign.from_functions(so3_consensus, name="so3-consensus", representation="so3",
                                       gains={"k_R": {}, "k_w": {}}, graphs=("spanning-tree",))
digraph = fs.load_graph([[0, 0, 1], [1, 0, 0], [0, "1/2", 0]])  # 1 <- 3, 2 <- 1, 3 <- 2 (a_32 = 1/2)
formation = fs.AgentFormation(digraph, np.array([np.diag([20.0, 25, 30])] * 3),
                              np.array([[0, 0, 0, 1.0], [0.6, 0, 0, 0.8], [0, 0, 0.8, 0.6]]),
                              np.zeros((3, 3)), fs.Gains(k_R=1.0, k_w=1.5))
run = fs.simulate(formation, fs.AgentOptions(tf=40, output_step=0.5, step=0.01), spec=design)
print(run.status, f"converged at {run.convergence_time} s;",
      f"final disagreement {run.attitude_error[-1]:.2e} deg")

# %%
run  # a SimResult: status, convergence time, final disagreement
