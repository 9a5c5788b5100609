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

from formsync_design.sim.native_int import INTEGRATORS

__all__ = ["DRIVER_SOURCE", "DRIVER_CORE", "CFG", "INFO", "LAYOUT", "SUMMARY", "EVENTS"]

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

DRIVER_CORE = r"""
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

"""

#: The whole driver (this module's core, then the integrators, runs and batches of
#: :mod:`formsync_design.sim.native_int`).
DRIVER_SOURCE = DRIVER_CORE + INTEGRATORS
