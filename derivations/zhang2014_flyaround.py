"""Zhang, Jin, Kang, Xiao (2014): coupled relative orbit / attitude control for a fast
fly-around with monitoring (one design contract: ``FORM = "agent"`` on the relative-orbit
plant, ``PLANT = "relative-orbit"``, with thrusters).

The chaser flies a 500 m sphere around a GEO target on a plane tilted by alpha_rT and keeps
its sensor axis x_d on the target.  Orbit: LQR state feedback on the CW/HCW model about the
desired relative position l_T (the paper's eq. 15-16, K = -R^-1 B^T P).  Attitude: a
Lyapunov-based MRP tracking law with a positive definite K_d (the paper's eq. 17; the law
itself was lost in the text we work from).  Both share 16 thrusters (pseudo-inverse
allocation, PWM with a 30 ms minimum pulse: the case file and
:mod:`formsync_design.sim.tracking`).

Assumptions (ours; each is also listed in ``verification/zhang2014_flyaround.toml``)
-------------------------------------------------------------------------------------
* Attitude law (reconstruction): the paper cites Xing & Parvez, "Nonlinear attitude state
  tracking control for spacecraft", JGCD 24(3) 2001, for the law and its proof, and names
  only K_d.  We use the MRP tracking law of that family in the form of Schaub & Junkins,
  *Analytical Mechanics of Space Systems* (2003), section 8.4 (feedback on the MRP error
  sigma with a scalar stiffness k_p, on the rate error with K_d, plus the exact
  gyroscopic and feedforward terms)::

      T_c = omega_s x J omega_s + J (a_d - omega x w_d) - k_p sigma - K_d omega

  (``omega_s`` = ``v.w`` the inertial body rate; ``sigma``, ``omega``, ``w_d``, ``a_d`` =
  ``v.track.sigma``, ``v.track.w``, ``v.track.w_ref``, ``v.track.wdot_ref``: the MRP and
  rate of the body relative to the desired frame, the desired frame's rate and its
  derivative in body axes) with the candidate ``V = 1/2 omega^T J omega + 2 k_p ln(1 +
  sigma^T sigma)``, whose derivative along the closed loop is ``-omega^T K_d omega``
  (derived, not assumed: :mod:`formsync_design.derive.tracking`).
* Orbit law: ``u = -K (X - X_d) + ff`` with the CW feedforward ``ff = l_T'' - A_21 l_T -
  A_22 l_T'`` (the reference is not a natural CW motion; without it the LQR alone would
  leave a steady error).  The paper writes ``u = K X`` with ``K = -R^-1 B^T P``; the sign
  convention differs, the law is the same.
* The weights Q, R and the gains k_p, K_d are not printed; the case file chooses them by a
  stated rule (Bryson's rule for Q, R; a 0.25 rad/s critically damped attitude loop for
  k_p, K_d), never by fitting the published results; the report shows how they move them.
"""

import sympy as sp

NAME = "zhang2014_flyaround"
TITLE = "Coupled relative orbit / attitude fly-around control (Zhang et al. 2014)"
FORM = "agent"
PLANT = "relative-orbit"  # the chaser's relative orbit about the target and its attitude
ACTUATORS = "thrusters"  # 16 thrusters (the case's layout), allocation and PWM
REPRESENTATION = "mrp"
LEADER = True  # the reference: the desired frame, sensor axis x_d on the target
GRAPHS = ()  # one spacecraft, no communication graph
SAMPLING = "periodic"
GAINS = {
    "q_r": {"role": "weight", "kind": "diag", "range": "0.01:100",
            "description": "LQR weight on the relative position error (1/m^2)"},
    "q_v": {"role": "weight", "kind": "diag", "range": "1:100000",
            "description": "LQR weight on the relative velocity error (s^2/m^2)"},
    "r_u": {"role": "weight", "range": "10:1000000",
            "description": "LQR weight on the commanded specific force (s^4/m^2)"},
    "k_p": {"range": "10:10000", "description": "MRP attitude stiffness (N m)"},
    "K_d": {"kind": "diag", "range": "100:20000",
            "description": "rate-error gain K_d of the paper (N m s), positive definite"},
}


def controller(v):
    """T_c = omega_s x J omega_s + J (a_d - omega x w_d) - k_p sigma - K_d omega."""
    e = v.track
    return (v.w.cross(v.J * v.w) + v.J * (e.wdot_ref - e.w.cross(e.w_ref))
            - v.k_p * e.sigma - v.K_d * e.w)


def lyapunov(v):
    """V = 1/2 omega^T J omega + 2 k_p ln(1 + sigma^T sigma)."""
    e = v.track
    return (e.w.T * v.J * e.w)[0, 0] / 2 + 2 * v.k_p * sp.log(1 + e.sigma.dot(e.sigma))


def orbit_controller(v):
    """u = -K (X - X_d) + ff (specific force in the relative orbit frame)."""
    return -v.K * v.dX + v.ff


def lqr_weights(v):
    """Q = diag(q_r, q_v), R = r_u I."""
    return sp.diag(v.q_r, v.q_v), v.r_u * sp.eye(3)
