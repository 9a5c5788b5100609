"""Independent truth for the formation certificate: the finite-difference Jacobian of the
compiled simulation kernel's right-hand side at consensus (the simulator's own closed loop,
CasADi, with ``sgn`` realised as the simulator realises it), in the coordinates
``(q_vec_i, w_i, z_i)`` with ``q0_i = sqrt(1 - |q_vec_i|^2)``.  Eigenvalues are invariant
under the change of chart, so its spectrum must equal the certificate's linearisation's."""

from __future__ import annotations

import numpy as np

from formsync_design.sim.agent_kernel import agent_parameters, get_agent_kernel
from formsync_design.sim.agents import AgentFormation, AgentOptions
from formsync_design.sim.formation import Gains


def fd_jacobian(design, graph, inertias, gains, *, switch="sat", phi=0.01, h=1e-6):
    """Central differences of the kernel RHS at consensus (identity, at rest, z = 0)."""
    n = graph.n
    nz = design.decl.state_size
    att = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    f = AgentFormation(graph, np.asarray(inertias, float), att, np.zeros((n, 3)), Gains(**gains))
    opt = AgentOptions(tf=1.0, output_step=0.5, step=0.05, switch=switch, phi=phi)
    kern = get_agent_kernel(design, f.neighbours(), switch, 10, 2, ("0", "0", "0"))
    p = agent_parameters(design, f, opt, kern.layout)
    lead = 4 if design.decl.leader else 0
    nx = 6 * n + nz * n

    def full(xi):
        qv = xi[: 3 * n].reshape(n, 3)
        q0 = np.sqrt(1.0 - (qv**2).sum(axis=1))
        x = np.concatenate([np.column_stack([qv, q0]).ravel(), xi[3 * n:]])
        if lead:
            x = np.concatenate([x, [0.0, 0.0, 0.0, 1.0]])
        return x

    def rhs(xi):
        xd = np.asarray(kern.rhs(full(xi), 0.0, p)).ravel()
        qd = xd[: 4 * n].reshape(n, 4)[:, :3].ravel()
        return np.concatenate([qd, xd[4 * n: 4 * n + 3 * n + nz * n]])

    Jm = np.zeros((nx, nx))
    for k in range(nx):
        e = np.zeros(nx)
        e[k] = h
        Jm[:, k] = (rhs(e) - rhs(-e)) / (2 * h)
    return Jm
