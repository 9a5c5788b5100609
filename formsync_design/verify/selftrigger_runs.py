"""Runs of a self-triggered design and its event-triggered and periodic variants, and what is
measured along them (the case kind ``selftrigger``, :mod:`formsync_design.verify.selftrigger`).

A design of this kind (``derivations/selftrigger_mrp.py`` is the shipped one) is an MRP agent
design with a leader, ``SAMPLING = "self-triggered"``, ``HOLD = {"s": 3, "c": 3}`` (its
sliding variable ``s_i(t_k)`` and the neighbours' part ``c_i(t_k) = sum_j a_ij y_j(t^j_k)``
kept at each broadcast, ``y = r sigma + w``), an ``event_rule(v)`` (the event-triggered check
of the same measurement error) and the gains ``r``, ``m_f``, ``delta``, ``eps``, ``alpha``,
``eta0``.  :func:`scheme_designs` builds the three schemes on one law
(:func:`~formsync_design.spec.agent.sampling_variant`).

Measured on the output grid of every run (:func:`measure`), with ``k`` the spacecraft's last
update: the measurement error ``e_i = s_i(t_k) - sbar_i(t)`` against the threshold
``(1 - 1/m)|s_i(t_k)| + eps + eta0 exp(-alpha t)``; the nonlinear term ``f_i = sbar_i' +
m s_i(t_k)`` against ``delta`` (``sbar_i' = D_i y_i' - b_i y_d'``, the rate derivative from the
plant, disturbance included); the staleness ``xi_i = sum_j a_ij y_j(t) - c_i(t_k)`` (the
neighbours' motion since the broadcasts used); ``Delta_i = f_i - d_i y_d'``; the largest MRP
norm (the operating region) and the accuracy ``|sigma_i - sigma_d|`` and principal angle to
the leader.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from formsync_design.errors import InputError
from formsync_design.models.mrp import mrp_rate_matrix
from formsync_design.sim.agent_kernel import agent_parameters, get_agent_kernel
from formsync_design.sim.agent_sampled import attitude_entries_np, reference_trajectory
from formsync_design.sim.agents import (
    AgentFormation,
    AgentOptions,
    AgentResult,
    simulate_agents_sampled,
)
from formsync_design.spec.agent import AgentDesign, sampling_variant

__all__ = ["SCHEMES", "SchemeRun", "scheme_designs", "run_scheme", "measure", "REQUIRED_GAINS"]

#: The three sampling schemes compared on one law.
SCHEMES = ("self-triggered", "event", "periodic")
#: Gains a design of this case kind must declare.
REQUIRED_GAINS = ("r", "m_f", "delta", "eps", "alpha", "eta0")


def scheme_designs(design: AgentDesign) -> dict[str, AgentDesign]:
    """``{scheme: design}``: the design itself and its event-triggered and periodic variants.

    >>> from formsync_design.spec.loader import load_design
    >>> sorted(scheme_designs(load_design("selftrigger_mrp")))
    ['event', 'periodic', 'self-triggered']
    """
    missing = [g for g in REQUIRED_GAINS if g not in design.decl.controller_gains]
    if (design.decl.sampling != "self-triggered" or design.representation != "mrp"
            or not design.decl.leader or dict(design.decl.hold) != {"s": 3, "c": 3}
            or not callable(design.module.get("event_rule")) or missing):
        raise InputError(f"expected a self-triggered MRP design with a leader, HOLD = "
                         f"{{'s': 3, 'c': 3}}, event_rule(v) and the gains "
                         f"{list(REQUIRED_GAINS)}, received {design.name!r}")
    return {
        "self-triggered": design,
        "event": sampling_variant(design, "event", event=design.module["event_rule"],
                                  hold=design.module["hold"], HOLD=dict(design.decl.hold)),
        "periodic": sampling_variant(design, "periodic", hold=design.module["hold"],
                                     HOLD=dict(design.decl.hold)),
    }


@dataclass(frozen=True)
class SchemeRun:
    """One run: the scheme, its period (periodic), the result and the measured quantities
    (per spacecraft arrays (N,) unless noted; ``*_ratio`` maxima over the grid).

    Attributes
    ----------
    scheme : str; period : float or None; result : AgentResult
    transmissions, evaluations : (N,) ints (broadcasts; trigger-function evaluations)
    min_interevent, mean_interevent : (N,)
    tail_sigma_error : float - max ``|sigma_i - sigma_d|`` over the tail (last ``tail`` of the
        horizon) and the spacecraft; tail_angle_deg : float - max principal angle to the leader
    effort : float - ``sum_i int |u_i|^2 dt``
    f_ratio, e_ratio : float - max ``|f_i|/delta``, max ``|e_i|/threshold``
    sigma_max : float - largest ``|sigma_i|`` and ``|sigma_d|`` seen
    staleness, delta_norm, c_norm : float - tail sup of ``|xi|``, ``|Delta|``, ``|(eps + eta_i)_i|``
        (stacked 2-norms over the formation, per axis triple)
    """

    scheme: str
    period: float | None
    result: AgentResult
    transmissions: np.ndarray
    evaluations: np.ndarray
    min_interevent: np.ndarray
    mean_interevent: np.ndarray
    tail_sigma_error: float
    tail_angle_deg: float
    effort: float
    f_ratio: float
    e_ratio: float
    sigma_max: float
    staleness: float
    delta_norm: float
    c_norm: float

    @property
    def total_transmissions(self) -> int:
        return int(self.transmissions.sum())

    @property
    def interevent_min(self) -> float:
        """Smallest inter-event time of any spacecraft (nan without two broadcasts)."""
        v = self.min_interevent[np.isfinite(self.min_interevent)]
        return float(v.min()) if v.size else math.nan

    def to_dict(self) -> dict[str, Any]:
        from formsync_design.gains import json_number

        def arr(a: Any) -> list[Any]:
            return [json_number(float(x)) for x in np.ravel(a)]

        return {
            "scheme": self.scheme, "period": None if self.period is None
            else json_number(self.period), "status": str(self.result.status),
            "transmissions": [int(k) for k in self.transmissions],
            "evaluations": [int(k) for k in self.evaluations],
            "min_interevent": arr(self.min_interevent), "mean_interevent": arr(self.mean_interevent),
            **{k: json_number(float(getattr(self, k))) for k in (
                "tail_sigma_error", "tail_angle_deg", "effort", "f_ratio", "e_ratio", "sigma_max",
                "staleness", "delta_norm", "c_norm")},
        }


def run_scheme(designs: dict[str, AgentDesign], formation: AgentFormation, options: AgentOptions,
               scheme: str, *, period: float | None = None, tail: float = 0.2) -> SchemeRun:
    """Simulate ``formation`` under one scheme (exact hybrid integration) and measure it.

    >>> import formsync_design as fs
    >>> from formsync_design.resources import case_file
    >>> c = fs.load_agent_case(case_file("selftrigger_mrp"))
    >>> ds = fs.scheme_designs(c.design)
    >>> opt = fs.AgentOptions(tf=2, output_step=0.5)
    >>> run = fs.run_scheme(ds, c.formation(), opt, "self-triggered")
    >>> bool((run.evaluations == run.transmissions).all()), run.interevent_min >= 0.2
    (True, True)
    """
    if scheme not in designs:
        raise InputError(f"expected a scheme in {list(designs)}, received {scheme!r}")
    from dataclasses import replace

    opt = replace(options, period=period) if scheme == "periodic" else options
    rec: dict[str, Any] = {}
    res = simulate_agents_sampled(designs[scheme], formation, opt, record=rec)
    return measure(designs["self-triggered"], formation, opt, res, rec, scheme, period, tail)


def _gain(formation: AgentFormation, name: str) -> float:
    v = formation.gains.as_dict()[name]
    return float(v[0] if isinstance(v, tuple) else v)


def measure(design: AgentDesign, f: AgentFormation, opt: AgentOptions, res: AgentResult,
            rec: dict[str, Any], scheme: str, period: float | None, tail: float) -> SchemeRun:
    """The measured quantities of a finished run (module docstring; ``design``: the
    self-triggered design, whose kernel's plant gives the rate derivatives)."""
    n = f.n
    r, m = _gain(f, "r"), _gain(f, "m_f")
    delta, eps, alpha, eta0 = (_gain(f, k) for k in ("delta", "eps", "alpha", "eta0"))
    g = f.graph
    A = g.adjacency
    b = g.pinning_matrix.diagonal()
    D = A.sum(axis=1) + b
    t = res.t
    T = len(t)
    sig = np.array([[attitude_entries_np("mrp", res.quaternions[k, i]) for i in range(n)]
                    for k in range(T)])
    W = res.rates
    assert f.reference is not None and res.reference is not None
    ref_at = reference_trajectory(f.reference, float(t[-1]))
    sig_d = np.array([attitude_entries_np("mrp", q) for q in res.reference])
    wd = np.array([ref_at(tk)[1] for tk in t])
    wdd = np.array([ref_at(tk)[2] for tk in t])
    y = r * sig + W
    y_d = r * sig_d + wd
    yd_dot = np.array([r * mrp_rate_matrix(sig_d[k]) @ wd[k] + wdd[k] for k in range(T)])
    # rate derivatives from the plant with the held torques (disturbance included)
    kern = get_agent_kernel(design, f.neighbours(), opt.switch, 1, 1, f.reference.rate,
                            compile=False)
    p = agent_parameters(design, f, opt, kern.layout)
    wdot = np.empty_like(W)
    for k in range(T):
        x = np.concatenate([res.quaternions[k].ravel(), W[k].ravel(), [0.0, 0.0, 0.0, 1.0]])
        dx = np.asarray(kern.plant(x, res.torques[k].ravel(), t[k], p)).ravel()
        wdot[k] = dx[4 * n: 7 * n].reshape(n, 3)
    y_dot = np.array([[r * mrp_rate_matrix(sig[k, i]) @ W[k, i] + wdot[k, i] for i in range(n)]
                      for k in range(T)])
    hyb = rec["hybrid"]
    kept = rec["kept"]
    trig = [np.asarray(ts) for ts in hyb.trigger_times]
    s_k = np.empty((T, n, 3))
    c_k = np.empty((T, n, 3))
    for i in range(n):
        idx = np.searchsorted(trig[i], t, side="right") - 1  # the update in force (right-continuous)
        s_k[:, i] = kept[i][idx, :3]
        c_k[:, i] = kept[i][idx, 3:6]
    sbar = D[None, :, None] * y - c_k - b[None, :, None] * y_d[:, None, :]
    e = s_k - sbar
    thr = (1 - 1 / m) * np.linalg.norm(s_k, axis=2) + eps + eta0 * np.exp(-alpha * t)[:, None]
    f_term = D[None, :, None] * y_dot - b[None, :, None] * yd_dot[:, None, :] + m * s_k
    xi = np.einsum("ij,tjk->tik", A, y) - c_k
    din = A.sum(axis=1)
    Delta = f_term - din[None, :, None] * yd_dot[:, None, :]
    tail_mask = t >= t[-1] * (1 - tail) - 1e-9
    ang = res.reference_error if res.reference_error is not None else np.zeros(T)
    sig_err = np.linalg.norm(sig - sig_d[:, None, :], axis=2)

    def sup_norm(X: np.ndarray) -> float:
        return float(np.linalg.norm(X[tail_mask].reshape(int(tail_mask.sum()), -1), axis=1).max())

    evals = np.asarray(rec["trigger_evaluations"], dtype=np.int64)
    return SchemeRun(
        scheme=scheme, period=period, result=res,
        transmissions=np.asarray(hyb.transmissions), evaluations=evals,
        min_interevent=np.asarray(hyb.min_interevent), mean_interevent=np.asarray(hyb.mean_interevent),
        tail_sigma_error=float(sig_err[tail_mask].max()), tail_angle_deg=float(ang[tail_mask].max()),
        effort=float(np.sum(res.effort)),
        f_ratio=float((np.linalg.norm(f_term, axis=2) / delta).max()),
        e_ratio=float((np.linalg.norm(e, axis=2) / thr).max()),
        sigma_max=float(max(np.linalg.norm(sig, axis=2).max(), np.linalg.norm(sig_d, axis=1).max())),
        staleness=sup_norm(xi), delta_norm=sup_norm(Delta),
        c_norm=float(math.sqrt(n) * (eps + eta0 * math.exp(-alpha * t[tail_mask][0]))),
    )
