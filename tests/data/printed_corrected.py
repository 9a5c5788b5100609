"""TEST VARIANT of ``derivations/liang2016_printed.py`` with three printed objects corrected.

Used by tests/test_compare.py to show that the verdicts are computed: here the
cross-product matrix is the skew-symmetric one, the alternative reading of B is
the derived (Euler-consistent) B, and M is the derived K_o I - beta L; the
comparison must then say "holds"/"agrees" for them.  Everything else is the paper's.

Original docstring: Expressions exactly as printed in Liang et al. (2016), transcribed for comparison.

These are *paper data*, not used for any certification of the derived
conditions: the toolbox evaluates them only to show where the printed
expressions and the derivation agree or disagree (``--conditions paper``,
the derivation report).  Reading conventions for ambiguous typography are
stated on each function.
"""

import sympy as sp


def printed_skew(q):
    """Corrected cross-product matrix: bottom row [-(q)_2, (q)_1, 0]."""
    return sp.Matrix([[0, -q[2], q[1]], [q[2], 0, -q[0]], [-q[1], q[0], 0]])


def printed_B(Q, J, qd, skew):
    """Printed B = -(Q^T (J Q q')^x Q + Q^T Jdot Q), read with Jdot = 0 (rigid body)."""
    return -(Q.T * skew(J * Q * qd) * Q)


def printed_B_alt(Q, Qdot, J, qd, skew):
    """Corrected B = Q^T J Qdot - Q^T (J Q q')^x Q (the derived factorization)."""
    return Q.T * J * Qdot - Q.T * skew(J * Q * qd) * Q


def printed_kv(ubar, J):
    """Printed rule K_vi = ubar * alpha_max(J_i^{-1}) (largest eigenvalue of J^-1)."""
    import numpy as np

    return float(ubar) * float(np.linalg.eigvalsh(np.linalg.inv(np.asarray(J, float)))[-1])


def printed_theta(m, K_o, K_q, beta):
    """Printed Theta_i per axis: [[1/2, (1/2) Omega_i^T], [(1/2) Omega_i, K]],
    Omega_i = (beta ... beta)^T read as m stacked beta*I_3 blocks,
    K = (1/4) diag((K_q + beta K_o) I_3 ...)."""
    T = sp.zeros(m + 1, m + 1)
    T[0, 0] = sp.Rational(1, 2)
    for k in range(1, m + 1):
        T[0, k] = T[k, 0] = beta / 2
        T[k, k] = (K_q + beta * K_o) / 4
    return T


def printed_M(adj, K_o, K_q, beta):
    """Corrected M = K_o I - beta L: diagonal K_o - beta m_i, off-diagonal beta delta_ij."""
    n = len(adj)
    deg = [sum(int(x) for x in row) for row in adj]
    return [
        [(K_o - beta * deg[i]) if i == j else int(adj[i][j]) * beta for j in range(n)]
        for i in range(n)
    ]


def printed_N(n, K_o, K_q, beta):
    """Printed N = diag(beta K_q I_3 ...) (per axis: beta K_q I_n)."""
    return [[beta * K_q if i == j else 0 for j in range(n)] for i in range(n)]


def printed_vdot_i(qd, s, edges, qdn, tau, d, K_o, K_q, K_v, beta):
    """Printed V_i' after substituting the dynamics (with the printed K_p read as K_q):
    (K_q + beta K_o)/2 sum_j e_ij^T (q_i' - q_j') + beta sum_j (q_i' - q_j')^T q_i'
    - (K_q + beta K_o) q_i'^T s_i - K_o q_i'^T q_i' - beta K_q s_i^T s_i
    - (K_vi - A^-1 Q^T u_d)^T |tau_i|   (the last term read componentwise)."""
    out = (K_q + beta * K_o) / 2 * sum((e.dot(qd - qj) for e, qj in zip(edges, qdn)), 0)
    out += beta * sum(((qd - qj).dot(qd) for qj in qdn), 0)
    out += -(K_q + beta * K_o) * qd.dot(s) - K_o * qd.dot(qd) - beta * K_q * s.dot(s)
    out += -sum(((K_v - d[k]) * sp.Abs(tau[k]) for k in range(3)), 0)
    return out


#: State at which printed and derived expressions are compared numerically:
#: spacecraft 1 of the paper's Table 1 (vector part q, body rate omega) and J_1.
EXAMPLE_STATE = {
    "q": ("1/10", "2/5", "-3/10"),
    "omega": ("85/100", "-43/100", "77/100"),
    "J": (("50", "0", "4"), ("0", "55", "0"), ("4", "0", "60")),
}

#: Gains published in section 3.
PAPER_GAINS = {"K_o": "1.6", "K_q": "0.4", "beta": "0.3", "K_v": "0.01"}
