"""C source of the whole-horizon driver, compiled together with the CasADi-generated
per-spacecraft closed loop (:mod:`formsync_design.sim.native` assembles and loads it).

The CasADi code provides four functions built from the derivation by
:func:`formsync_design.sim.kernels.agent_functions`: ``fsk_trig(t, freq, orbit)``
(the time-only disturbance terms, once per evaluation), ``fsk_agent(qb, w, s, trig,
gains, K_v, phi, umax, J, Jinv, harm, gg) -> (dqb, dw, u, tau)`` (one spacecraft's closed
loop), ``fsk_ctrl`` (same inputs) ``-> (u, tau)`` (its controller alone, for the torque on
the output grid and the event functions) and ``fsk_plant(qb, w, u, trig, J, Jinv, harm,
gg) -> (dqb, dw)`` (its plant under a held torque).  This file only loops: ``s = L q`` through the Laplacian's nonzeros (so a
run costs O(N + edges) per evaluation, and one compiled object serves every formation
size and graph), the integrators, the events and the metrics.

Integrators: classical RK4 with ``M`` sub-steps per output interval (the arithmetic of
:class:`~formsync_design.sim.kernels.Kernel`'s ``chunk``), and Dormand-Prince 5(4)
(Hairer's DOPRI5: FSAL, PI step-size control, Hairer's initial step, the 4th-order dense
output used for the output grid and the events).  Under zero-order hold every sample
interval is its own segment (the held torque is a discontinuity).

Events: a spacecraft's ``q0`` reaching ``floor`` is detected at every (sub-)step end and
located by the Illinois method on the step's interpolant (cubic Hermite for RK4, the
dense output for DOPRI5) to ``evtol`` seconds; the run stops there (grid points before
the event are kept).  Switching events (a component of the switching argument ``tau``
crossing the boundary layer ``|tau| = phi``, or ``tau = 0`` for ``sgn``) and torque-limit
events (``|u_raw| = umax``) are counted at (sub-)step ends; the first and the last
crossing are located to ``evtol`` on the interpolant (a few controller evaluations).
Non-finite states, step-size underflow and quaternion norm drift stop a run with a
failure status the caller interprets.

Outputs are decimated inside: the state, torque and metrics ``(Omega_m, Q_m)`` on the
output grid (:c:func:`fsd_run`), or only a per-run summary reduced here
(:c:func:`fsd_batch`, threads over runs).
"""

from __future__ import annotations

__all__ = ["DRIVER_SOURCE", "CFG", "INFO", "LAYOUT", "SUMMARY", "EVENTS"]

#: Offsets of the parameter blocks (``kernels.param_layout`` order) passed to the driver.
LAYOUT = ("gains", "K_v", "phi", "umax", "J", "Jinv", "L", "freq", "harm", "gg", "orbit")

#: Configuration vector entries.
CFG = ("method", "interval", "substeps", "rtol", "atol", "hmax", "floor", "normtol", "zoh",
       "evtol", "qtol", "wtol", "maxsteps", "h0", "swkind", "kinkstop")

#: Per-run information entries.
INFO = ("status", "kdone", "tevent", "sc", "tfail", "q0fail", "steps", "rejected", "nfev",
        "normerr", "reason", "nctrl", "kinks", "pad2", "pad3", "pad4")

#: Per-run summary of a batch (what a Monte-Carlo run keeps).
SUMMARY = ("status", "tevent", "sc", "conv_time", "final_om", "final_qm", "min_q0",
           "peak_u", "normerr", "steps", "rejected", "nfev", "kdone", "tfail", "q0fail",
           "reason")

#: Per-channel event record: count, first time, last time (channels: switching, torque limit).
EVENTS = ("switch_count", "switch_first", "switch_last", "limit_count", "limit_first", "limit_last")

DRIVER_SOURCE = r"""
/* ===================== formsync whole-horizon driver ===================== */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>

enum { LY_GAINS, LY_KV, LY_PHI, LY_UMAX, LY_J, LY_JINV, LY_L, LY_FREQ, LY_HARM, LY_GG,
       LY_ORBIT, LY_SIZE };
enum { CF_METHOD, CF_INTERVAL, CF_SUBSTEPS, CF_RTOL, CF_ATOL, CF_HMAX, CF_FLOOR, CF_NORMTOL,
       CF_ZOH, CF_EVTOL, CF_QTOL, CF_WTOL, CF_MAXSTEPS, CF_H0, CF_SWKIND, CF_KINKSTOP, CF_SIZE };
enum { IN_STATUS, IN_KDONE, IN_TEVENT, IN_SC, IN_TFAIL, IN_Q0FAIL, IN_STEPS, IN_REJECTED,
       IN_NFEV, IN_NORMERR, IN_REASON, IN_NCTRL, IN_KINKS, IN_SIZE = 16 };
enum { SM_STATUS, SM_TEVENT, SM_SC, SM_CONV, SM_OM, SM_QM, SM_MINQ0, SM_PEAKU, SM_NORMERR,
       SM_STEPS, SM_REJECTED, SM_NFEV, SM_KDONE, SM_TFAIL, SM_Q0FAIL, SM_REASON, SM_SIZE };
enum { EV_SWC, EV_SWF, EV_SWL, EV_LIMC, EV_LIMF, EV_LIML, EV_SIZE };
/* status: 0 horizon reached, 1 q0 reached the floor (located), 2 failure, 3 norm drift */
/* reason of a failure: 1 non-finite state, 2 step-size underflow, 3 too many steps */

typedef struct {
  int n, nx;
  const double *p;
  long off[LY_SIZE];
  int *rp, *ci;
  double *cv, *s;
  double trig[FSD_NTRIG];
  const casadi_real *arg[FSD_SZ_ARG];
  casadi_real *res[FSD_SZ_RES];
  casadi_int iw[FSD_SZ_IW + 1];
  casadi_real w[FSD_SZ_W + 1];
  long nfev, nctrl;
} fsd_model;

static void fsd_free(fsd_model *m) {
  free(m->rp); free(m->ci); free(m->cv); free(m->s);
  m->rp = 0; m->ci = 0; m->cv = 0; m->s = 0;
}

static int fsd_init(fsd_model *m, int n, const double *p, const long *off) {
  int i, j, k, nnz = 0;
  const double *L = p + off[LY_L];  /* column-major: L_ij at i + n j */
  memset(m, 0, sizeof(*m));
  m->n = n; m->nx = 7 * n; m->p = p;
  for (i = 0; i < LY_SIZE; ++i) m->off[i] = off[i];
  for (k = 0; k < n * n; ++k) if (L[k] != 0.0) ++nnz;
  m->rp = (int*)malloc(sizeof(int) * (n + 1));
  m->ci = (int*)malloc(sizeof(int) * (nnz + 1));
  m->cv = (double*)malloc(sizeof(double) * (nnz + 1));
  m->s = (double*)malloc(sizeof(double) * 3 * n);
  if (!m->rp || !m->ci || !m->cv || !m->s) { fsd_free(m); return -1; }
  k = 0;
  for (i = 0; i < n; ++i) {
    m->rp[i] = k;
    for (j = 0; j < n; ++j) {
      double v = L[i + (long)n * j];
      if (v != 0.0) { m->ci[k] = j; m->cv[k] = v; ++k; }
    }
  }
  m->rp[n] = k;
  return 0;
}

static void fsd_trig(fsd_model *m, double t) {
  double tt = t;
  m->arg[0] = &tt; m->arg[1] = m->p + m->off[LY_FREQ]; m->arg[2] = m->p + m->off[LY_ORBIT];
  m->res[0] = m->trig;
  fsk_trig(m->arg, m->res, m->iw, m->w, 0);
}

static void fsd_lap(fsd_model *m, const double *x) {
  int i, k;
  for (i = 0; i < m->n; ++i) {
    double a = 0, b = 0, c = 0;
    for (k = m->rp[i]; k < m->rp[i + 1]; ++k) {
      const double *qj = x + 4 * m->ci[k];
      double v = m->cv[k];
      a += v * qj[0]; b += v * qj[1]; c += v * qj[2];
    }
    m->s[3 * i] = a; m->s[3 * i + 1] = b; m->s[3 * i + 2] = c;
  }
}

/* closed loop at (t, x): xd (may be NULL), limited torque u, switching argument tau and the
   torque before the limit ur (each may be NULL) */
static void fsd_f(fsd_model *m, double t, const double *x, double *xd, double *u, double *tau,
                  double *ur) {
  int i, n = m->n;
  const double *p = m->p;
  fsd_trig(m, t);
  fsd_lap(m, x);
  for (i = 0; i < n; ++i) {
    m->arg[0] = x + 4 * i; m->arg[1] = x + 4 * n + 3 * i; m->arg[2] = m->s + 3 * i;
    m->arg[3] = m->trig; m->arg[4] = p + m->off[LY_GAINS]; m->arg[5] = p + m->off[LY_KV] + i;
    m->arg[6] = p + m->off[LY_PHI]; m->arg[7] = p + m->off[LY_UMAX] + 3 * i;
    m->arg[8] = p + m->off[LY_J] + 9 * i; m->arg[9] = p + m->off[LY_JINV] + 9 * i;
    m->arg[10] = p + m->off[LY_HARM] + 18 * i; m->arg[11] = p + m->off[LY_GG];
    if (xd) {
      m->res[0] = xd + 4 * i; m->res[1] = xd + 4 * n + 3 * i;
      m->res[2] = u ? u + 3 * i : 0; m->res[3] = tau ? tau + 3 * i : 0;
      m->res[4] = ur ? ur + 3 * i : 0;
      fsk_agent(m->arg, m->res, m->iw, m->w, 0);
    } else {  /* the controller alone */
      m->res[0] = u ? u + 3 * i : 0; m->res[1] = tau ? tau + 3 * i : 0;
      m->res[2] = ur ? ur + 3 * i : 0;
      fsk_ctrl(m->arg, m->res, m->iw, m->w, 0);
    }
  }
  if (xd) m->nfev++; else m->nctrl++;
}

/* plant under the held torque uh */
static void fsd_plant(fsd_model *m, double t, const double *x, const double *uh, double *xd) {
  int i, n = m->n;
  const double *p = m->p;
  fsd_trig(m, t);
  for (i = 0; i < n; ++i) {
    m->arg[0] = x + 4 * i; m->arg[1] = x + 4 * n + 3 * i; m->arg[2] = uh + 3 * i;
    m->arg[3] = m->trig; m->arg[4] = p + m->off[LY_J] + 9 * i;
    m->arg[5] = p + m->off[LY_JINV] + 9 * i; m->arg[6] = p + m->off[LY_HARM] + 18 * i;
    m->arg[7] = p + m->off[LY_GG];
    m->res[0] = xd + 4 * i; m->res[1] = xd + 4 * n + 3 * i;
    fsk_plant(m->arg, m->res, m->iw, m->w, 0);
  }
  m->nfev++;
}

/* the paper's metrics in O(N): Omega_m^2 = 2 sum_i |w_i - wbar|^2 / (N - 1) and, with
   p_i = r* (x) qb_i (r the normalised mean quaternion, an orthogonal map keeping every
   q_i . q_j), sum_{i<j} |q_ij|^2 = ((tr P)^2 - |P|_F^2) / 2, P = sum_i p_i p_i^T */
static void fsd_metrics(int n, const double *x, double *om, double *qm) {
  int i;
  double r[4] = {0, 0, 0, 0}, wb[3] = {0, 0, 0}, nr, sw = 0;
  double V00 = 0, V01 = 0, V02 = 0, V11 = 0, V12 = 0, V22 = 0, c0 = 0, c1 = 0, c2 = 0, B = 0;
  double A, quad, pairs;
  if (n < 2) { *om = 0; *qm = 0; return; }
  for (i = 0; i < n; ++i) {
    const double *q = x + 4 * i, *w = x + 4 * n + 3 * i;
    r[0] += q[0]; r[1] += q[1]; r[2] += q[2]; r[3] += q[3];
    wb[0] += w[0]; wb[1] += w[1]; wb[2] += w[2];
  }
  nr = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
  if (nr > 0) { r[0] /= nr; r[1] /= nr; r[2] /= nr; r[3] /= nr; } else { r[3] = 1; }
  wb[0] /= n; wb[1] /= n; wb[2] /= n;
  for (i = 0; i < n; ++i) {
    const double *q = x + 4 * i, *w = x + 4 * n + 3 * i;
    double d0 = w[0] - wb[0], d1 = w[1] - wb[1], d2 = w[2] - wb[2];
    /* vector part r0 q - q0 r - r x q, scalar part r0 q0 + r . q */
    double v0 = r[3] * q[0] - q[3] * r[0] - (r[1] * q[2] - r[2] * q[1]);
    double v1 = r[3] * q[1] - q[3] * r[1] - (r[2] * q[0] - r[0] * q[2]);
    double v2 = r[3] * q[2] - q[3] * r[2] - (r[0] * q[1] - r[1] * q[0]);
    double s = r[3] * q[3] + r[0] * q[0] + r[1] * q[1] + r[2] * q[2];
    sw += d0 * d0 + d1 * d1 + d2 * d2;
    V00 += v0 * v0; V01 += v0 * v1; V02 += v0 * v2; V11 += v1 * v1; V12 += v1 * v2; V22 += v2 * v2;
    c0 += s * v0; c1 += s * v1; c2 += s * v2; B += s * s;
  }
  A = V00 + V11 + V22;
  /* (tr P)^2 - |P|_F^2 = (A^2 - |V|_F^2) + 2 (A B - |c|^2), both parts >= 0 */
  quad = 2 * ((V00 * V11 - V01 * V01) + (V00 * V22 - V02 * V02) + (V11 * V22 - V12 * V12))
         + 2 * (A * B - (c0 * c0 + c1 * c1 + c2 * c2));
  pairs = (double)n * (n - 1);
  *om = sqrt(2 * sw / (n - 1));
  *qm = sqrt(quad > 0 ? quad / pairs : 0.0);
}

static double fsd_normerr(int n, const double *x) {
  int i; double e = 0;
  for (i = 0; i < n; ++i) {
    const double *q = x + 4 * i;
    double d = fabs(sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) - 1.0);
    if (!(d <= e)) e = d;  /* NaN propagates */
  }
  return e;
}

static int fsd_finite(int nx, const double *x) {
  int i;
  for (i = 0; i < nx; ++i) if (!isfinite(x[i])) return 0;
  return 1;
}

/* ---- output sink: the full grid (fsd_run) or a reduced summary (fsd_batch) ---- */
typedef struct {
  double *X, *U, *MET;   /* full grid (any may be NULL) */
  long k;                /* last grid index written */
  long lastbad;          /* last grid index violating the tolerances (-1: none) */
  double om, qm, peaku, normerr, qtol, wtol;
} fsd_sink;

static void fsd_grid(fsd_model *m, fsd_sink *o, long k, const double *x, const double *u) {
  int i, n = m->n;
  double om, qm, ne;
  fsd_metrics(n, x, &om, &qm);
  ne = fsd_normerr(n, x);
  if (o->X) memcpy(o->X + k * m->nx, x, sizeof(double) * m->nx);
  if (o->U) memcpy(o->U + k * 3 * n, u, sizeof(double) * 3 * n);
  if (o->MET) { o->MET[2 * k] = om; o->MET[2 * k + 1] = qm; }
  if (!(qm <= o->qtol && om <= o->wtol)) o->lastbad = k;
  for (i = 0; i < 3 * n; ++i) { double a = fabs(u[i]); if (!(a <= o->peaku)) o->peaku = a; }
  if (!(ne <= o->normerr)) o->normerr = ne;
  o->om = om; o->qm = qm; o->k = k;
}

/* ---- interpolants of one step ---- */
typedef struct {
  int kind;            /* 0: cubic Hermite (RK4), 1: DOPRI5 dense output */
  int nx;
  double t, h;
  const double *ya, *fa, *yb, *fb;  /* Hermite */
  const double *rc;                 /* dense: 5 nx coefficients */
} fsd_interp;

static double fsd_icomp(const fsd_interp *I, int c, double th) {
  if (I->kind == 0) {
    double t2 = th * th, t3 = t2 * th;
    return (2 * t3 - 3 * t2 + 1) * I->ya[c] + (t3 - 2 * t2 + th) * I->h * I->fa[c]
           + (-2 * t3 + 3 * t2) * I->yb[c] + (t3 - t2) * I->h * I->fb[c];
  } else {
    const double *r = I->rc; int nx = I->nx; double th1 = 1 - th;
    return r[c] + th * (r[nx + c] + th1 * (r[2 * nx + c] + th * (r[3 * nx + c] + th1 * r[4 * nx + c])));
  }
}

static void fsd_ivec(const fsd_interp *I, double th, double *y) {
  int c;
  for (c = 0; c < I->nx; ++c) y[c] = fsd_icomp(I, c, th);
}

/* the next Illinois point in (a, b): the secant point, moved to tol/2 inside the bracket
   when it falls closer than that to an end (so a converging side closes the bracket) */
static double fsd_next(double a, double b, double ga, double gb, double h, double tol) {
  double x = (a * gb - b * ga) / (gb - ga), e = 0.5 * tol / h;
  if (!(x > a && x < b)) x = 0.5 * (a + b);
  if (b - a > 2 * e) {
    if (x - a < e) x = a + e;
    else if (b - x < e) x = b - e;
  }
  return x;
}

/* Illinois on g(th) = component c of the interpolant - level, g(0) > 0 >= g(1) */
static double fsd_root_comp(const fsd_interp *I, int c, double level, double tol) {
  double a = 0, b = 1, ga = fsd_icomp(I, c, 0) - level, gb = fsd_icomp(I, c, 1) - level;
  int side = 0, it;
  if (!(ga > 0)) return 0;
  if (!(gb <= 0)) return 1;
  for (it = 0; it < 200 && (b - a) * I->h > tol; ++it) {
    double x = fsd_next(a, b, ga, gb, I->h, tol), gx;
    gx = fsd_icomp(I, c, x) - level;
    if (gx > 0) { a = x; ga = gx; if (side == -1) gb *= 0.5; side = -1; }
    else { b = x; gb = gx; if (side == 1) ga *= 0.5; side = 1; }
  }
  return b;  /* the first point at or past the crossing */
}

/* ---- switching / torque-limit event channels ---- */
typedef struct {
  double *tau0, *u0, *tau1, *u1;   /* values at the step ends (3n each; u: before the limit) */
  double *ytmp, *utmp, *ttmp;
  double ev[EV_SIZE];
  int swkind;                        /* 0 none, 1 boundary layer |tau| = phi, 2 sign tau */
  /* the step holding the latest crossing of each channel, located once at the end */
  double *lbuf[2];                   /* 5 nx each: the interpolant's data */
  fsd_interp lI[2];
  int lj[2];
  double lga[2], lgb[2];
  /* DOPRI5 stopping at kinks: the crossing a step was shortened to end at */
  int pch, pj, psign;  /* channel (-1 none), component, sign of g past the crossing */
} fsd_events;

/* event function of channel ch (0 switching, 1 limit), component j */
static double fsd_evf(fsd_model *m, int ch, int j, const double *tau, const double *u, int swkind) {
  if (ch == 0) {
    double phi = m->p[m->off[LY_PHI]];
    return swkind == 2 ? tau[j] : fabs(tau[j]) - phi;
  } else {
    /* the torque before the limit against the limit (smooth on both sides) */
    double um = m->p[m->off[LY_UMAX] + j];
    return fabs(u[j]) - um;
  }
}

/* locate the crossing of (ch, j) in the step of I by evaluating the controller on the
   interpolant (Illinois on the sign change; ga, gb: the values at the step ends) */
static double fsd_locate_ev(fsd_model *m, const fsd_interp *I, fsd_events *E, int ch, int j,
                            double ga, double gb, double tol) {
  double a = 0, b = 1;
  int side = 0, it;
  for (it = 0; it < 100 && (b - a) * I->h > tol; ++it) {
    double x = fsd_next(a, b, ga, gb, I->h, tol), gx;
    fsd_ivec(I, x, E->ytmp);
    fsd_f(m, I->t + x * I->h, E->ytmp, 0, 0, E->ttmp, E->utmp);
    gx = fsd_evf(m, ch, j, E->ttmp, E->utmp, E->swkind);
    if ((gx > 0) == (ga > 0)) { a = x; ga = gx; if (side == -1) gb *= 0.5; side = -1; }
    else { b = x; gb = gx; if (side == 1) ga *= 0.5; side = 1; }
  }
  return I->t + b * I->h;
}

static void fsd_keep_interp(fsd_events *E, int ch, const fsd_interp *I) {
  int nx = I->nx;
  double *b = E->lbuf[ch];
  E->lI[ch] = *I;
  if (I->kind == 0) {
    memcpy(b, I->ya, sizeof(double) * nx); memcpy(b + nx, I->fa, sizeof(double) * nx);
    memcpy(b + 2 * nx, I->yb, sizeof(double) * nx); memcpy(b + 3 * nx, I->fb, sizeof(double) * nx);
    E->lI[ch].ya = b; E->lI[ch].fa = b + nx; E->lI[ch].yb = b + 2 * nx; E->lI[ch].fb = b + 3 * nx;
  } else {
    memcpy(b, I->rc, sizeof(double) * 5 * nx);
    E->lI[ch].rc = b;
  }
}

/* count the sign changes of every channel between the step ends (at most one per
   component and step is seen); locate the run's first crossing at once, keep the step of
   the latest one */
static void fsd_events_step(fsd_model *m, const fsd_interp *I, fsd_events *E, double tol,
                            int limited) {
  int ch, j, n3 = 3 * m->n;
  for (ch = 0; ch < 2; ++ch) {
    int jfirst = -1, jlast = -1;
    double ga_f = 0, gb_f = 0, ga_l = 0, gb_l = 0, th_f = 2, th_l = -1;
    if (ch == 0 && E->swkind == 0) continue;
    if (ch == 1 && !limited) continue;
    for (j = 0; j < n3; ++j) {
      double ga = fsd_evf(m, ch, j, E->tau0, E->u0, E->swkind);
      double gb = fsd_evf(m, ch, j, E->tau1, E->u1, E->swkind);
      if ((ga > 0) != (gb > 0)) {
        double th = ga / (ga - gb);  /* linear guess, to order the crossings of the step */
        E->ev[3 * ch] += 1;
        if (th < th_f) { th_f = th; jfirst = j; ga_f = ga; gb_f = gb; }
        if (th > th_l) { th_l = th; jlast = j; ga_l = ga; gb_l = gb; }
      }
    }
    if (jfirst < 0) continue;
    if (isnan(E->ev[3 * ch + 1])) E->ev[3 * ch + 1] = fsd_locate_ev(m, I, E, ch, jfirst, ga_f, gb_f, tol);
    fsd_keep_interp(E, ch, I);
    E->lj[ch] = jlast; E->lga[ch] = ga_l; E->lgb[ch] = gb_l;
  }
}

/* DOPRI5 with kink stops: the earliest crossing of any channel in the step, located
   (the component a previous step ended at takes its past-the-crossing sign at the start);
   counts every crossing of the step. Returns 1 and (ts, ch, j) when one exists. */
static int fsd_kinks(fsd_model *m, const fsd_interp *I, fsd_events *E, double tol, int limited,
                     double *ts, int *chs, int *js, double *gas) {
  int ch, j, n3 = 3 * m->n, best = 0;
  double thb = 2, gab = 0, gbb = 0;
  for (ch = 0; ch < 2; ++ch) {
    if (ch == 0 && E->swkind == 0) continue;
    if (ch == 1 && !limited) continue;
    for (j = 0; j < n3; ++j) {
      double ga = fsd_evf(m, ch, j, E->tau0, E->u0, E->swkind);
      double gb = fsd_evf(m, ch, j, E->tau1, E->u1, E->swkind);
      int sa = ga > 0, sb = gb > 0;
      if (ch == E->pch && j == E->pj) {
        sa = E->psign;
        if (sa != (ga > 0)) ga = sa ? 1e-300 : -1e-300;  /* at the kink: take the new side */
      }
      if (sa != sb) {
        double th = ga / (ga - gb);
        E->ev[3 * ch] += 1;
        if (th < thb) { thb = th; best = 1; *chs = ch; *js = j; gab = ga; gbb = gb; }
      }
    }
  }
  if (!best) return 0;
  *ts = fsd_locate_ev(m, I, E, *chs, *js, gab, gbb, tol);
  *gas = gab;
  return 1;
}

static void fsd_events_finish(fsd_model *m, fsd_events *E, double tol) {
  int ch;
  for (ch = 0; ch < 2; ++ch)
    if (E->lj[ch] >= 0)
      E->ev[3 * ch + 2] = fsd_locate_ev(m, &E->lI[ch], E, ch, E->lj[ch], E->lga[ch], E->lgb[ch], tol);
}

/* ---- q0 floor: earliest crossing in the step (spacecraft returned, -1 none) ---- */
static int fsd_q0_event(const fsd_model *m, const fsd_interp *I, const double *ya, const double *yb,
                        double floor, double tol, double *tev) {
  int i, best = -1;
  double bt = 0;
  for (i = 0; i < m->n; ++i) {
    double a = ya[4 * i + 3], b = yb[4 * i + 3];
    if (isfinite(b) && b <= floor) {
      double th = a > floor ? fsd_root_comp(I, 4 * i + 3, floor, tol) : 0.0;
      double tc = I->t + th * I->h;
      if (best < 0 || tc < bt) { best = i; bt = tc; }
    }
  }
  *tev = bt;
  return best;
}

static void fsd_minq(int n, const double *x, double *MINQ) {
  int i;
  for (i = 0; i < n; ++i) { double q0 = x[4 * i + 3]; if (q0 < MINQ[i]) MINQ[i] = q0; }
}

static void fsd_fail(const fsd_model *m, const double *x, double t, int reason, double *info) {
  int i, imin = 0;
  for (i = 1; i < m->n; ++i) if (x[4 * i + 3] < x[4 * imin + 3]) imin = i;
  info[IN_STATUS] = reason == 4 ? 3 : 2;
  info[IN_REASON] = reason == 4 ? 0 : reason;
  info[IN_TFAIL] = t;
  info[IN_Q0FAIL] = x[4 * imin + 3];
  info[IN_SC] = imin + 1;
}

/* ======================= RK4, M sub-steps per interval ======================= */
static void fsd_rk4(fsd_model *m, const double *cfg, const double *x0, double t0, long K,
                    fsd_sink *o, double *MINQ, double *info, fsd_events *E, double *buf,
                    int limited) {
  int n = m->n, nx = m->nx, zoh = cfg[CF_ZOH] != 0, c, evs = !zoh && (E->swkind || limited);
  long M = (long)cfg[CF_SUBSTEPS], k, j;
  double h = cfg[CF_INTERVAL] / M, floor = cfg[CF_FLOOR], ntol = cfg[CF_NORMTOL];
  double tol = cfg[CF_EVTOL], t = t0, *sw;
  double *x = buf, *xn = buf + nx, *k1 = buf + 2 * nx, *k2 = buf + 3 * nx, *k3 = buf + 4 * nx,
         *k4 = buf + 5 * nx, *ys = buf + 6 * nx, *fb = buf + 7 * nx, *uh = buf + 8 * nx,
         *ul0 = buf + 8 * nx + 3 * n, *ul1 = buf + 8 * nx + 6 * n;
  memcpy(x, x0, sizeof(double) * nx);
  /* continuous control: the first stage at (t, x), which also gives the torque there, is
     evaluated at the end of the previous sub-step and carried over */
  if (!zoh) fsd_f(m, t, x, k1, ul0, E->tau0, E->u0);
  for (k = 0; k < K; ++k) {
    if (zoh) { fsd_f(m, t, x, 0, uh, 0, 0); fsd_grid(m, o, k, x, uh); }
    else fsd_grid(m, o, k, x, ul0);
    for (j = 0; j < M; ++j) {
      fsd_interp I;
      int hit = 0;
      if (zoh) fsd_plant(m, t, x, uh, k1);
      for (c = 0; c < nx; ++c) ys[c] = x[c] + h / 2 * k1[c];
      if (zoh) fsd_plant(m, t + h / 2, ys, uh, k2); else fsd_f(m, t + h / 2, ys, k2, 0, 0, 0);
      for (c = 0; c < nx; ++c) ys[c] = x[c] + h / 2 * k2[c];
      if (zoh) fsd_plant(m, t + h / 2, ys, uh, k3); else fsd_f(m, t + h / 2, ys, k3, 0, 0, 0);
      for (c = 0; c < nx; ++c) ys[c] = x[c] + h * k3[c];
      if (zoh) fsd_plant(m, t + h, ys, uh, k4); else fsd_f(m, t + h, ys, k4, 0, 0, 0);
      for (c = 0; c < nx; ++c) xn[c] = x[c] + h / 6 * (k1[c] + 2 * k2[c] + 2 * k3[c] + k4[c]);
      info[IN_STEPS] += 1;
      for (c = 0; c < n; ++c) { double b = xn[4 * c + 3]; if (isfinite(b) && b <= floor) hit = 1; }
      /* the derivative at the sub-step end: the next first stage (continuous control) */
      if (!zoh) fsd_f(m, t + h, xn, fb, ul1, E->tau1, E->u1);
      else if (hit) fsd_plant(m, t + h, xn, uh, fb);
      I.kind = 0; I.nx = nx; I.t = t; I.h = h; I.ya = x; I.fa = k1; I.yb = xn; I.fb = fb; I.rc = 0;
      if (hit) {
        double tev;
        int sc = fsd_q0_event(m, &I, x, xn, floor, tol, &tev);
        info[IN_STATUS] = 1; info[IN_TEVENT] = tev; info[IN_SC] = sc + 1; info[IN_KDONE] = k;
        fsd_ivec(&I, (tev - t) / h, ys);  /* the smallest q0 up to the event */
        fsd_minq(n, ys, MINQ);
        if (floor < MINQ[sc]) MINQ[sc] = floor;
        return;
      }
      if (!fsd_finite(nx, xn)) { fsd_fail(m, x, t, 1, info); info[IN_KDONE] = k; return; }
      if (!(fsd_normerr(n, xn) <= ntol)) { fsd_fail(m, x, t, 4, info); info[IN_KDONE] = k; return; }
      if (evs) fsd_events_step(m, &I, E, tol, limited);
      fsd_minq(n, xn, MINQ);
      memcpy(x, xn, sizeof(double) * nx);
      if (!zoh) {
        sw = k1; k1 = fb; fb = sw;
        sw = ul0; ul0 = ul1; ul1 = sw;
        sw = E->u0; E->u0 = E->u1; E->u1 = sw;
        sw = E->tau0; E->tau0 = E->tau1; E->tau1 = sw;
      }
      t = t + h;
    }
  }
  if (zoh) { fsd_f(m, t, x, 0, uh, 0, 0); fsd_grid(m, o, K, x, uh); }  /* the value the hold applies next */
  else fsd_grid(m, o, K, x, ul0);  /* the torque at tf */
  info[IN_KDONE] = K;
}

/* ======================= DOPRI5 (Hairer), dense output ======================= */
static const double
  DA21 = 1.0 / 5,
  DA31 = 3.0 / 40, DA32 = 9.0 / 40,
  DA41 = 44.0 / 45, DA42 = -56.0 / 15, DA43 = 32.0 / 9,
  DA51 = 19372.0 / 6561, DA52 = -25360.0 / 2187, DA53 = 64448.0 / 6561, DA54 = -212.0 / 729,
  DA61 = 9017.0 / 3168, DA62 = -355.0 / 33, DA63 = 46732.0 / 5247, DA64 = 49.0 / 176,
  DA65 = -5103.0 / 18656,
  DA71 = 35.0 / 384, DA73 = 500.0 / 1113, DA74 = 125.0 / 192, DA75 = -2187.0 / 6784,
  DA76 = 11.0 / 84,
  DC2 = 0.2, DC3 = 0.3, DC4 = 0.8, DC5 = 8.0 / 9,
  DE1 = 71.0 / 57600, DE3 = -71.0 / 16695, DE4 = 71.0 / 1920, DE5 = -17253.0 / 339200,
  DE6 = 22.0 / 525, DE7 = -1.0 / 40,
  DD1 = -12715105075.0 / 11282082432, DD3 = 87487479700.0 / 32700410799,
  DD4 = -10690763975.0 / 1880347072, DD5 = 701980252875.0 / 199316789632,
  DD6 = -1453857185.0 / 822651844, DD7 = 69997945.0 / 29380423;

static void fsd_eval(fsd_model *m, int zoh, double t, const double *x, const double *uh,
                     double *xd, double *u, double *tau, double *ur) {
  if (zoh) fsd_plant(m, t, x, uh, xd); else fsd_f(m, t, x, xd, u, tau, ur);
}

/* Hairer's initial step (hinit of DOPRI5) */
static double fsd_hinit(fsd_model *m, int zoh, double t, const double *x, const double *f0,
                        const double *uh, double rtol, double atol, double hmax, double *y1, double *f1) {
  int c, nx = m->nx;
  double dnf = 0, dny = 0, h, der2 = 0, der12, h1;
  for (c = 0; c < nx; ++c) {
    double sk = atol + rtol * fabs(x[c]);
    dnf += (f0[c] / sk) * (f0[c] / sk); dny += (x[c] / sk) * (x[c] / sk);
  }
  h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
  if (h > hmax) h = hmax;
  for (c = 0; c < nx; ++c) y1[c] = x[c] + h * f0[c];
  fsd_eval(m, zoh, t + h, y1, uh, f1, 0, 0, 0);
  for (c = 0; c < nx; ++c) {
    double sk = atol + rtol * fabs(x[c]), d = (f1[c] - f0[c]) / sk;
    der2 += d * d;
  }
  der2 = sqrt(der2) / h;
  der12 = der2 > sqrt(dnf) ? der2 : sqrt(dnf);
  h1 = der12 <= 1e-15 ? (1e-6 > h * 1e-3 ? 1e-6 : h * 1e-3) : pow(0.01 / der12, 0.2);
  h = 100 * h < h1 ? 100 * h : h1;
  return h < hmax ? h : hmax;
}

static void fsd_dopri(fsd_model *m, const double *cfg, const double *x0, double t0, long K,
                      fsd_sink *o, double *MINQ, double *info, fsd_events *E, double *buf,
                      int limited) {
  int n = m->n, nx = m->nx, zoh = cfg[CF_ZOH] != 0, c, rejected_last = 0;
  double iv = cfg[CF_INTERVAL], rtol = cfg[CF_RTOL], atol = cfg[CF_ATOL], hmax = cfg[CF_HMAX];
  double floor = cfg[CF_FLOOR], ntol = cfg[CF_NORMTOL], tol = cfg[CF_EVTOL];
  double maxsteps = cfg[CF_MAXSTEPS], facold = 1e-4, h, t = t0;
  const double safe = 0.9, beta = 0.04, expo1 = 0.2 - 0.04 * 0.75, facc1 = 5.0, facc2 = 0.1;
  double *x = buf, *y1 = buf + nx, *k1 = buf + 2 * nx, *k2 = buf + 3 * nx, *k3 = buf + 4 * nx,
         *k4 = buf + 5 * nx, *k5 = buf + 6 * nx, *k6 = buf + 7 * nx, *k7 = buf + 8 * nx,
         *ys = buf + 9 * nx, *rc = buf + 10 * nx, *yg = buf + 15 * nx, *uh = buf + 16 * nx,
         *ug = buf + 16 * nx + 3 * n, *ul0 = buf + 16 * nx + 6 * n, *ul1 = buf + 16 * nx + 9 * n;
  long kg = 1, seg;
  int kinkstop = !zoh && cfg[CF_KINKSTOP] != 0 && (E->swkind || limited), forced = 0, fch = -1, fj = 0, fsign = 0;
  double hnat = 0;
  memcpy(x, x0, sizeof(double) * nx);
  h = cfg[CF_H0];
  for (seg = 0; seg < (zoh ? K : 1); ++seg) {
    /* a segment: the whole horizon (continuous control) or one hold interval (ZOH) */
    double tend = zoh ? t0 + (seg + 1) * iv : t0 + K * iv;
    if (zoh) {
      t = t0 + seg * iv;
      fsd_f(m, t, x, 0, uh, 0, 0);
      fsd_grid(m, o, seg, x, uh);
      fsd_plant(m, t, x, uh, k1);
    } else {
      fsd_f(m, t, x, k1, ul0, E->tau0, E->u0);
      fsd_grid(m, o, 0, x, ul0);
    }
    if (!(h > 0)) h = fsd_hinit(m, zoh, t, x, k1, uh, rtol, atol, hmax, ys, k2);
    rejected_last = 0;
    while (t < tend) {
      double err = 0, tn, hmin = 16 * 2.220446049250313e-16 * fabs(tend), fac11, fac;
      int last = 0;
      fsd_interp I;
      if (info[IN_STEPS] + info[IN_REJECTED] >= maxsteps) { fsd_fail(m, x, t, 3, info); info[IN_KDONE] = o->k; return; }
      if (h > hmax) h = hmax;
      if (!forced) hnat = h;
      if (t + (forced ? 1.0 : 1.01) * h >= tend) { h = tend - t; last = 1; }
      for (c = 0; c < nx; ++c) ys[c] = x[c] + h * DA21 * k1[c];
      fsd_eval(m, zoh, t + DC2 * h, ys, uh, k2, 0, 0, 0);
      for (c = 0; c < nx; ++c) ys[c] = x[c] + h * (DA31 * k1[c] + DA32 * k2[c]);
      fsd_eval(m, zoh, t + DC3 * h, ys, uh, k3, 0, 0, 0);
      for (c = 0; c < nx; ++c) ys[c] = x[c] + h * (DA41 * k1[c] + DA42 * k2[c] + DA43 * k3[c]);
      fsd_eval(m, zoh, t + DC4 * h, ys, uh, k4, 0, 0, 0);
      for (c = 0; c < nx; ++c)
        ys[c] = x[c] + h * (DA51 * k1[c] + DA52 * k2[c] + DA53 * k3[c] + DA54 * k4[c]);
      fsd_eval(m, zoh, t + DC5 * h, ys, uh, k5, 0, 0, 0);
      for (c = 0; c < nx; ++c)
        ys[c] = x[c] + h * (DA61 * k1[c] + DA62 * k2[c] + DA63 * k3[c] + DA64 * k4[c] + DA65 * k5[c]);
      tn = last ? tend : t + h;
      fsd_eval(m, zoh, tn, ys, uh, k6, 0, 0, 0);
      for (c = 0; c < nx; ++c)
        y1[c] = x[c] + h * (DA71 * k1[c] + DA73 * k3[c] + DA74 * k4[c] + DA75 * k5[c] + DA76 * k6[c]);
      fsd_eval(m, zoh, tn, y1, uh, k7, ul1, E->tau1, E->u1);
      for (c = 0; c < nx; ++c) {
        double sk = atol + rtol * (fabs(x[c]) > fabs(y1[c]) ? fabs(x[c]) : fabs(y1[c]));
        double e = h * (DE1 * k1[c] + DE3 * k3[c] + DE4 * k4[c] + DE5 * k5[c] + DE6 * k6[c] + DE7 * k7[c]) / sk;
        err += e * e;
      }
      err = sqrt(err / nx);
      if (!(err <= 1.0)) {  /* rejected (a NaN error too) */
        info[IN_REJECTED] += 1;
        fac11 = isfinite(err) ? pow(err, expo1) : 1e300;
        h = h / (facc1 < fac11 / safe ? facc1 : fac11 / safe);
        rejected_last = 1;
        forced = 0;
        if (!(h >= hmin)) { fsd_fail(m, x, t, fsd_finite(nx, y1) ? 2 : 1, info); info[IN_KDONE] = o->k; return; }
        continue;
      }
      /* accepted */
      info[IN_STEPS] += 1;
      for (c = 0; c < nx; ++c) {
        double d = y1[c] - x[c], bs = h * k1[c] - d;
        rc[c] = x[c]; rc[nx + c] = d; rc[2 * nx + c] = bs; rc[3 * nx + c] = d - h * k7[c] - bs;
        rc[4 * nx + c] = h * (DD1 * k1[c] + DD3 * k3[c] + DD4 * k4[c] + DD5 * k5[c] + DD6 * k6[c] + DD7 * k7[c]);
      }
      I.kind = 1; I.nx = nx; I.t = t; I.h = tn - t; I.ya = x; I.fa = k1; I.yb = y1; I.fb = k7; I.rc = rc;
      {
        double tev = 0;
        int hit = 0, sc;
        for (c = 0; c < n; ++c) { double b = y1[4 * c + 3]; if (isfinite(b) && b <= floor) hit = 1; }
        if (hit) {
          sc = fsd_q0_event(m, &I, x, y1, floor, tol, &tev);
          if (!zoh)
            for (; kg <= K && t0 + kg * iv < tev; ++kg) {
              double tg = t0 + kg * iv;
              fsd_ivec(&I, (tg - t) / I.h, yg);
              fsd_f(m, tg, yg, 0, ug, 0, 0);
              fsd_grid(m, o, kg, yg, ug);
            }
          info[IN_STATUS] = 1; info[IN_TEVENT] = tev; info[IN_SC] = sc + 1; info[IN_KDONE] = o->k;
          fsd_ivec(&I, (tev - t) / I.h, yg);  /* the smallest q0 up to the event */
          fsd_minq(n, yg, MINQ);
          if (floor < MINQ[sc]) MINQ[sc] = floor;
          return;
        }
      }
      if (!(fsd_normerr(n, y1) <= ntol)) { fsd_fail(m, x, t, 4, info); info[IN_KDONE] = o->k; return; }
      if (kinkstop) {
        /* never step across a kink of the closed loop (boundary layer, torque limit): end
           the step at the earliest crossing instead and start the next one there */
        double ts = 0, ga = 0, c0 = E->ev[0], c1 = E->ev[3];
        int ch = -1, j = 0, found = fsd_kinks(m, &I, E, tol, limited, &ts, &ch, &j, &ga);
        if (found && ts < tn - tol && ts > t + tol) {
          E->ev[0] = c0; E->ev[3] = c1;  /* counted again by the shortened step */
          info[IN_STEPS] -= 1;
          info[IN_KINKS] += 1;
          h = ts - t; forced = 1; fch = ch; fj = j; fsign = !(ga > 0);
          continue;
        }
        if (found) {
          if (isnan(E->ev[3 * ch + 1])) E->ev[3 * ch + 1] = ts;
          E->ev[3 * ch + 2] = ts;
        }
        if (forced && !(found && ch == fch && j == fj)) {
          /* the step ends at the crossing it was shortened to: count it there, and give
             the component its past-the-crossing sign at the next step's start */
          E->ev[3 * fch] += 1;
          if (isnan(E->ev[3 * fch + 1])) E->ev[3 * fch + 1] = tn;
          E->ev[3 * fch + 2] = tn;
          E->pch = fch; E->pj = fj; E->psign = fsign;
        } else {
          E->pch = -1;
        }
      }
      if (!zoh) {
        for (; kg <= K && t0 + kg * iv <= tn; ++kg) {
          double tg = t0 + kg * iv;
          if (kg == K || tg == tn) { fsd_grid(m, o, kg, y1, ul1); continue; }
          fsd_ivec(&I, (tg - t) / I.h, yg);
          fsd_f(m, tg, yg, 0, ug, 0, 0);
          fsd_grid(m, o, kg, yg, ug);
        }
        if (!kinkstop && (E->swkind || limited)) fsd_events_step(m, &I, E, tol, limited);
        memcpy(E->u0, E->u1, sizeof(double) * 3 * n);
        memcpy(ul0, ul1, sizeof(double) * 3 * n);
        memcpy(E->tau0, E->tau1, sizeof(double) * 3 * n);
      }
      fsd_minq(n, y1, MINQ);
      /* step-size control (Hairer's PI controller, beta = 0.04) */
      fac11 = pow(err, expo1);
      fac = fac11 / pow(facold, beta);
      fac = fac / safe;
      if (fac > facc1) fac = facc1;
      if (fac < facc2) fac = facc2;
      facold = err > 1e-4 ? err : 1e-4;
      {
        double hnew = (tn - t) / fac;
        if (rejected_last && hnew > tn - t) hnew = tn - t;
        /* a step shortened to land on a segment end passes on the unshortened estimate
           unless its own error asks for less (the next hold interval starts with it) */
        if ((last || forced) && hnew >= tn - t && hnat > hnew) hnew = hnat;
        forced = 0;
        memcpy(x, y1, sizeof(double) * nx);
        memcpy(k1, k7, sizeof(double) * nx);
        t = tn;
        h = hnew;
      }
      rejected_last = 0;
    }
  }
  if (zoh) { fsd_f(m, t, x, 0, uh, 0, 0); fsd_grid(m, o, K, x, uh); }
  info[IN_KDONE] = K;
}

static int fsd_run_core(int n, const double *p, const long *off, const double *cfg,
                        const double *x0, double t0, long K, fsd_sink *o, double *MINQ,
                        double *info, double *events) {
  fsd_model m;
  fsd_events E;
  double *buf, *ebuf;
  int nx = 7 * n, i, limited = 0;
  if (fsd_init(&m, n, p, off) != 0) return -1;
  buf = (double*)malloc(sizeof(double) * (17 * nx + 12 * n + 8));
  ebuf = (double*)malloc(sizeof(double) * (4 * 3 * n + nx + 6 * n + 10 * nx + 8));
  if (!buf || !ebuf) { free(buf); free(ebuf); fsd_free(&m); return -1; }
  E.tau0 = ebuf; E.u0 = ebuf + 3 * n; E.tau1 = ebuf + 6 * n; E.u1 = ebuf + 9 * n;
  E.ytmp = ebuf + 12 * n; E.utmp = E.ytmp + nx; E.ttmp = E.utmp + 3 * n;
  E.lbuf[0] = E.ttmp + 3 * n; E.lbuf[1] = E.lbuf[0] + 5 * nx; E.lj[0] = -1; E.lj[1] = -1;
  E.pch = -1; E.pj = 0; E.psign = 0;
  E.swkind = (int)cfg[CF_SWKIND];
  E.ev[EV_SWC] = 0; E.ev[EV_SWF] = NAN; E.ev[EV_SWL] = NAN;
  E.ev[EV_LIMC] = 0; E.ev[EV_LIMF] = NAN; E.ev[EV_LIML] = NAN;
  for (i = 0; i < IN_SIZE; ++i) info[i] = 0;
  info[IN_TEVENT] = NAN; info[IN_TFAIL] = NAN; info[IN_Q0FAIL] = NAN;
  for (i = 0; i < n; ++i) MINQ[i] = x0[4 * i + 3];
  o->k = -1; o->lastbad = -1; o->om = NAN; o->qm = NAN; o->peaku = 0; o->normerr = 0;
  for (i = 0; i < 3 * n; ++i) if (isfinite(p[off[LY_UMAX] + i])) limited = 1;
  if (cfg[CF_METHOD] == 0) fsd_rk4(&m, cfg, x0, t0, K, o, MINQ, info, &E, buf, limited);
  else fsd_dopri(&m, cfg, x0, t0, K, o, MINQ, info, &E, buf, limited);
  fsd_events_finish(&m, &E, cfg[CF_EVTOL]);
  info[IN_NFEV] = (double)m.nfev;
  info[IN_NCTRL] = (double)m.nctrl;
  info[IN_NORMERR] = o->normerr;
  if (events) for (i = 0; i < EV_SIZE; ++i) events[i] = E.ev[i];
  free(buf); free(ebuf); fsd_free(&m);
  return 0;
}

/* One run, the whole horizon: X (K+1, 7N), U (K+1, 3N), MET (K+1, 2) on the output grid
   (rows 0..info[kdone] are written), MINQ (N) the smallest q0 of every spacecraft over
   all steps, info (IN_SIZE), events (EV_SIZE). Returns 0, or -1 when out of memory. */
int fsd_run(int n, const double *p, const long *off, const double *cfg, const double *x0,
            double t0, long K, double *X, double *U, double *MET, double *MINQ, double *info,
            double *events) {
  fsd_sink o;
  o.X = X; o.U = U; o.MET = MET; o.qtol = cfg[CF_QTOL]; o.wtol = cfg[CF_WTOL];
  return fsd_run_core(n, p, off, cfg, x0, t0, K, &o, MINQ, info, events);
}

/* ---- batches: runs spread over threads, each reduced to a summary here ---- */
typedef struct {
  int B, n; long np, K; const double *P, *cfg, *X0; const long *off; double *S;
  int next, err; pthread_mutex_t mu;
} fsd_job;

static void fsd_one(fsd_job *jb, int b, double *MINQ) {
  fsd_sink o;
  double info[IN_SIZE], *s = jb->S + (long)b * SM_SIZE, mq = INFINITY;
  int i, nx = 7 * jb->n;
  o.X = 0; o.U = 0; o.MET = 0; o.qtol = jb->cfg[CF_QTOL]; o.wtol = jb->cfg[CF_WTOL];
  if (fsd_run_core(jb->n, jb->P + (long)b * jb->np, jb->off, jb->cfg, jb->X0 + (long)b * nx, 0.0,
                   jb->K, &o, MINQ, info, 0) != 0) { jb->err = 1; return; }
  for (i = 0; i < jb->n; ++i) if (MINQ[i] < mq) mq = MINQ[i];
  s[SM_STATUS] = info[IN_STATUS]; s[SM_TEVENT] = info[IN_TEVENT]; s[SM_SC] = info[IN_SC];
  s[SM_CONV] = (info[IN_STATUS] == 0 && o.lastbad < jb->K) ? (double)(o.lastbad + 1) * jb->cfg[CF_INTERVAL] : NAN;
  s[SM_OM] = o.om; s[SM_QM] = o.qm; s[SM_MINQ0] = mq; s[SM_PEAKU] = o.peaku;
  s[SM_NORMERR] = o.normerr; s[SM_STEPS] = info[IN_STEPS]; s[SM_REJECTED] = info[IN_REJECTED];
  s[SM_NFEV] = info[IN_NFEV]; s[SM_KDONE] = info[IN_KDONE]; s[SM_TFAIL] = info[IN_TFAIL];
  s[SM_Q0FAIL] = info[IN_Q0FAIL]; s[SM_REASON] = info[IN_REASON];
}

static void *fsd_worker(void *arg) {
  fsd_job *jb = (fsd_job*)arg;
  double *MINQ = (double*)malloc(sizeof(double) * (jb->n + 1));
  if (!MINQ) { jb->err = 1; return 0; }
  for (;;) {
    int b;
    pthread_mutex_lock(&jb->mu);
    b = jb->next++;
    pthread_mutex_unlock(&jb->mu);
    if (b >= jb->B) break;
    fsd_one(jb, b, MINQ);
  }
  free(MINQ);
  return 0;
}

/* B runs (parameters P (B, np), initial states X0 (B, 7N)) on `threads` threads; the
   summary of run b in S[b * SM_SIZE ...]. Returns 0, or -1 (out of memory / threads). */
int fsd_batch(int B, int n, long np, const double *P, const long *off, const double *cfg,
              const double *X0, long K, double *S, int threads) {
  fsd_job jb;
  pthread_t th[64];
  int i, started = 0;
  jb.B = B; jb.n = n; jb.np = np; jb.K = K; jb.P = P; jb.cfg = cfg; jb.X0 = X0; jb.off = off;
  jb.S = S; jb.next = 0; jb.err = 0;
  pthread_mutex_init(&jb.mu, 0);
  if (threads < 1) threads = 1;
  if (threads > 64) threads = 64;
  for (i = 1; i < threads; ++i) if (pthread_create(&th[started], 0, fsd_worker, &jb) == 0) ++started;
  fsd_worker(&jb);
  for (i = 0; i < started; ++i) pthread_join(th[i], 0);
  pthread_mutex_destroy(&jb.mu);
  return jb.err ? -1 : 0;
}

int fsd_sizes(long *out) {
  out[0] = CF_SIZE; out[1] = IN_SIZE; out[2] = SM_SIZE; out[3] = EV_SIZE; out[4] = LY_SIZE;
  return 0;
}
"""
