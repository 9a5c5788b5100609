/* formsync-design: the formation driver of agent designs (formsync_design/sim/agent_native.py).
 *
 * One compiled object serves every design, formation size, graph, horizon and output grid.
 * A design provides CasADi-generated functions (compiled once per design, by its key):
 *
 *   pre(q[4], w[3], z[nz]) -> full[nf]            what a spacecraft broadcasts: its attitude
 *                                                 in the design's representation, rate, states
 *   trig(t, freq[6], orbit[4]) -> trig[ntrig]     time-only disturbance terms (once per call)
 *   lead(qr[4], t) -> ref[na + 6], dqr[4]         the leader (reference) and its kinematics
 *   dist(q[4], J[9], harm[18], trig[ntrig], gg) -> ud[3]
 *                                                 the disturbance torque (called only when
 *                                                 the run has a disturbance, dims[D_DIST])
 *   law_m(own[nf], q[4], w[3], J[9], Jinv[9], a[m], b, ref[na + 6], gains[G], phi,
 *         umax[3], ud[3], t, nbr_1[nf], ..., nbr_m[nf]) -> dq[4], dw[3], dz[nz]
 *                                                 one spacecraft's closed loop with m
 *                                                 in-neighbours (one function per in-degree)
 *   obs_m(the same inputs) -> u[3], monitors[nmon]
 *                                                 its torque (after the limit) and monitors,
 *                                                 evaluated at the output times only
 *
 * This file loops: the graph is data (CSR: row pointers rp[n + 1], in-neighbour columns ci,
 * arc weights a in the same order), as are the inertias, gains, pinning gains, limits and
 * disturbance parameters (the flat parameter vector p with block offsets off[]).
 *
 * State order: q1_1, q2_1, q3_1, q0_1, ..., q0_N, w1_1, ..., w3_N, then the controller
 * states of spacecraft 1..N, then the reference quaternion (a design with a leader).
 *
 * Integrators (cfg[C_METHOD]):
 *   0  classical RK4, M sub-steps of h per output interval, every quaternion normalised after
 *      every sub-step (time accumulated as t + h);
 *   1  Dormand-Prince 5(4) (Hairer's DOPRI5: FSAL, PI step-size control, Hairer's initial
 *      step, the 4th-order dense output for the output grid; the quaternions of an output
 *      are normalised).
 * At every output time the torques (after the limit) and the monitors are evaluated.
 * A non-finite state ends a run (status 1: diverged, kdone = the first output not written);
 * a step-size underflow or too many steps is status 2 (reason 2 or 3).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>

typedef long long fs_int;
typedef int (*fs_fn)(const double **arg, double **res, fs_int *iw, double *w, int mem);

enum { P_GAINS, P_PHI, P_UMAX, P_J, P_JINV, P_A, P_B, P_FREQ, P_HARM, P_GG, P_ORBIT, P_SIZE };
enum { D_N, D_NA, D_NZ, D_NMON, D_LEADER, D_MAXDEG, D_NTRIG, D_SZARG, D_SZRES, D_SZIW, D_SZW,
       D_DIST, D_SIZE };
enum { C_METHOD, C_H, C_M, C_RTOL, C_ATOL, C_HMAX, C_MAXSTEPS, C_H0, C_SIZE };
enum { I_STATUS, I_KDONE, I_STEPS, I_REJECTED, I_NFEV, I_TFAIL, I_REASON, I_NOBS, I_SIZE };

typedef struct {
  int n, na, nz, nf, nmon, leader, maxdeg, ntrig, nx, dist;
  const int *rp, *ci;
  const double *p;
  const long *off;
  fs_fn pre, trig, lead, dist_fn;
  fs_fn const *law, *obs;
  double *full, *zero, *trigv, *ref, *dqr, *jmon, *xdo, *ud;
  const double **arg;
  double **res;
  fs_int *iw;
  double *w;
  long nfev, nobs;
} fs_model;

static void fs_free(fs_model *m) {
  free(m->full); free(m->zero); free(m->trigv); free(m->ref); free(m->dqr);
  free(m->jmon); free(m->xdo); free(m->ud);
  free(m->arg); free(m->res); free(m->iw); free(m->w);
}

static int fs_init(fs_model *m, const long *dims, const long *off, const int *rp, const int *ci,
                   const double *p, void *const *fns) {
  long need = 14 + dims[D_MAXDEG];
  long szarg = dims[D_SZARG] > need ? dims[D_SZARG] : need, szres = dims[D_SZRES] > 8 ? dims[D_SZRES] : 8;
  memset(m, 0, sizeof(*m));
  m->n = (int)dims[D_N]; m->na = (int)dims[D_NA]; m->nz = (int)dims[D_NZ];
  m->nf = m->na + 3 + m->nz; m->nmon = (int)dims[D_NMON]; m->leader = (int)dims[D_LEADER];
  m->maxdeg = (int)dims[D_MAXDEG]; m->ntrig = (int)dims[D_NTRIG];
  m->nx = 7 * m->n + m->nz * m->n + (m->leader ? 4 : 0);
  m->rp = rp; m->ci = ci; m->p = p; m->off = off;
  m->dist = (int)dims[D_DIST];
  m->pre = (fs_fn)fns[0]; m->trig = (fs_fn)fns[1]; m->lead = (fs_fn)fns[2];
  m->dist_fn = (fs_fn)fns[3];
  m->law = (fs_fn const *)(fns + 4);
  m->obs = (fs_fn const *)(fns + 5 + m->maxdeg);
  m->full = (double *)malloc(sizeof(double) * ((size_t)m->nf * m->n + 1));
  m->zero = (double *)calloc((size_t)m->nf + 1, sizeof(double));
  m->trigv = (double *)malloc(sizeof(double) * (m->ntrig + 1));
  m->ref = (double *)calloc((size_t)m->na + 7, sizeof(double));
  m->dqr = (double *)calloc(4, sizeof(double));
  m->jmon = (double *)malloc(sizeof(double) * (m->nmon + 1));
  m->xdo = (double *)malloc(sizeof(double) * (m->nx + 1));
  m->ud = (double *)calloc(3 * (size_t)m->n + 1, sizeof(double));
  m->arg = (const double **)calloc(szarg, sizeof(double *));
  m->res = (double **)calloc(szres, sizeof(double *));
  m->iw = (fs_int *)malloc(sizeof(fs_int) * (dims[D_SZIW] + 1));
  m->w = (double *)malloc(sizeof(double) * (dims[D_SZW] + 1));
  if (!m->full || !m->zero || !m->trigv || !m->ref || !m->dqr || !m->jmon || !m->xdo || !m->ud || !m->arg
      || !m->res || !m->iw || !m->w) { fs_free(m); return -1; }
  return 0;
}

/* the closed loop at (t, x): xd (the state derivative; may be NULL), or with obs set u (3n
   limited torques) and mon (nmon values per spacecraft, spacecraft-major) */
static void fs_rhs(fs_model *m, double t, const double *x, double *xd, double *u, double *mon) {
  int i, k, n = m->n, nf = m->nf, nz = m->nz, obs = xd == 0;
  const double *p = m->p;
  const long *off = m->off;
  double tt = t;
  m->arg[0] = &tt; m->arg[1] = p + off[P_FREQ]; m->arg[2] = p + off[P_ORBIT];
  m->res[0] = m->trigv;
  m->trig(m->arg, m->res, m->iw, m->w, 0);
  if (m->leader) {
    const double *qr = x + 7 * n + nz * n;
    m->arg[0] = qr; m->arg[1] = &tt;
    m->res[0] = m->ref; m->res[1] = m->dqr;
    m->lead(m->arg, m->res, m->iw, m->w, 0);
  }
  for (i = 0; i < n; ++i) {
    m->arg[0] = x + 4 * i; m->arg[1] = x + 4 * n + 3 * i; m->arg[2] = x + 7 * n + nz * i;
    m->res[0] = m->full + (size_t)nf * i;
    m->pre(m->arg, m->res, m->iw, m->w, 0);
    if (m->dist) {
      m->arg[0] = x + 4 * i; m->arg[1] = p + off[P_J] + 9 * i; m->arg[2] = p + off[P_HARM] + 18 * i;
      m->arg[3] = m->trigv; m->arg[4] = p + off[P_GG];
      m->res[0] = m->ud + 3 * i;
      m->dist_fn(m->arg, m->res, m->iw, m->w, 0);
    }
  }
  for (i = 0; i < n; ++i) {
    int deg = m->rp[i + 1] - m->rp[i];
    m->arg[0] = m->full + (size_t)nf * i; m->arg[1] = x + 4 * i; m->arg[2] = x + 4 * n + 3 * i;
    m->arg[3] = p + off[P_J] + 9 * i; m->arg[4] = p + off[P_JINV] + 9 * i;
    m->arg[5] = deg ? p + off[P_A] + m->rp[i] : m->zero; m->arg[6] = p + off[P_B] + i;
    m->arg[7] = m->ref; m->arg[8] = p + off[P_GAINS]; m->arg[9] = p + off[P_PHI];
    m->arg[10] = p + off[P_UMAX] + 3 * i; m->arg[11] = m->ud + 3 * i; m->arg[12] = &tt;
    /* the in-neighbours' broadcasts, in place */
    for (k = 0; k < deg; ++k) m->arg[13 + k] = m->full + (size_t)nf * m->ci[m->rp[i] + k];
    if (!deg) m->arg[13] = m->zero;
    if (obs) {
      m->res[0] = u + 3 * i; m->res[1] = mon + (size_t)m->nmon * i;
      m->obs[deg](m->arg, m->res, m->iw, m->w, 0);
    } else {
      m->res[0] = xd + 4 * i; m->res[1] = xd + 4 * n + 3 * i; m->res[2] = xd + 7 * n + nz * i;
      m->law[deg](m->arg, m->res, m->iw, m->w, 0);
    }
  }
  if (obs) return;
  if (m->leader) memcpy(xd + 7 * n + nz * n, m->dqr, sizeof(double) * 4);
  m->nfev++;
}

static void fs_normalise(const fs_model *m, double *x) {
  int i;
  for (i = 0; i <= m->n; ++i) {
    double *q, r;
    if (i == m->n) {
      if (!m->leader) break;
      q = x + 7 * m->n + m->nz * m->n;
    } else {
      q = x + 4 * i;
    }
    r = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    q[0] /= r; q[1] /= r; q[2] /= r; q[3] /= r;
  }
}

static int fs_finite(int nx, const double *x) {
  int i;
  for (i = 0; i < nx; ++i) if (!isfinite(x[i])) return 0;
  return 1;
}

/* output k: the state, and the torques and monitors evaluated there */
static void fs_output(fs_model *m, long k, double t, const double *x, double *X, double *U,
                      double *MON) {
  int n = m->n;
  memcpy(X + (size_t)k * m->nx, x, sizeof(double) * m->nx);
  fs_rhs(m, t, x, 0, U + (size_t)k * 3 * n, MON + (size_t)k * m->nmon * n);
  m->nobs++;
}

static int fs_rk4(fs_model *m, const double *cfg, const double *x0, long T, const double *tg,
                  double *X, double *U, double *MON, double *info) {
  int nx = m->nx, c, j, M = (int)cfg[C_M];
  long k;
  double h = cfg[C_H], t = tg[0];
  double *buf = (double *)malloc(sizeof(double) * 6 * (size_t)nx);
  double *x, *y, *k1, *k2, *k3, *k4;
  if (!buf) return -1;
  x = buf; y = buf + nx; k1 = buf + 2 * nx; k2 = buf + 3 * nx; k3 = buf + 4 * nx; k4 = buf + 5 * nx;
  memcpy(x, x0, sizeof(double) * nx);
  fs_output(m, 0, tg[0], x, X, U, MON);
  for (k = 1; k <= T; ++k) {
    for (j = 0; j < M; ++j) {
      fs_rhs(m, t, x, k1, 0, 0);
      for (c = 0; c < nx; ++c) y[c] = x[c] + h / 2 * k1[c];
      fs_rhs(m, t + h / 2, y, k2, 0, 0);
      for (c = 0; c < nx; ++c) y[c] = x[c] + h / 2 * k2[c];
      fs_rhs(m, t + h / 2, y, k3, 0, 0);
      for (c = 0; c < nx; ++c) y[c] = x[c] + h * k3[c];
      fs_rhs(m, t + h, y, k4, 0, 0);
      for (c = 0; c < nx; ++c) x[c] = x[c] + h / 6 * (k1[c] + 2 * k2[c] + 2 * k3[c] + k4[c]);
      fs_normalise(m, x);
      t = t + h;
      info[I_STEPS] += 1;
    }
    if (!fs_finite(nx, x)) {
      info[I_STATUS] = 1; info[I_REASON] = 1; info[I_TFAIL] = tg[k]; info[I_KDONE] = (double)k;
      free(buf);
      return 0;
    }
    fs_output(m, k, tg[k], x, X, U, MON);
  }
  info[I_KDONE] = (double)(T + 1);
  free(buf);
  return 0;
}

/* Dormand-Prince 5(4): Hairer, Norsett, Wanner, Solving ODEs I, DOPRI5 */
static const double
  A21 = 0.2, A31 = 3.0 / 40.0, A32 = 9.0 / 40.0, A41 = 44.0 / 45.0, A42 = -56.0 / 15.0,
  A43 = 32.0 / 9.0, A51 = 19372.0 / 6561.0, A52 = -25360.0 / 2187.0, A53 = 64448.0 / 6561.0,
  A54 = -212.0 / 729.0, A61 = 9017.0 / 3168.0, A62 = -355.0 / 33.0, A63 = 46732.0 / 5247.0,
  A64 = 49.0 / 176.0, A65 = -5103.0 / 18656.0, A71 = 35.0 / 384.0, A73 = 500.0 / 1113.0,
  A74 = 125.0 / 192.0, A75 = -2187.0 / 6784.0, A76 = 11.0 / 84.0,
  C2 = 0.2, C3 = 0.3, C4 = 0.8, C5 = 8.0 / 9.0,
  E1 = 71.0 / 57600.0, E3 = -71.0 / 16695.0, E4 = 71.0 / 1920.0, E5 = -17253.0 / 339200.0,
  E6 = 22.0 / 525.0, E7 = -1.0 / 40.0,
  D1 = -12715105075.0 / 11282082432.0, D3 = 87487479700.0 / 32700410799.0,
  D4 = -10690763975.0 / 1880347072.0, D5 = 701980252875.0 / 199316789632.0,
  D6 = -1453857185.0 / 822651844.0, D7 = 69997945.0 / 29380423.0;

static int fs_dopri5(fs_model *m, const double *cfg, const double *x0, long T, const double *tg,
                     double *X, double *U, double *MON, double *info) {
  int nx = m->nx, c, reject = 0, nonfinite = 0;
  long k = 1, steps = 0, maxsteps = (long)cfg[C_MAXSTEPS];
  double rtol = cfg[C_RTOL], atol = cfg[C_ATOL], hmax = cfg[C_HMAX];
  double t = tg[0], tend = tg[T], h, facold = 1e-4, err, sk;
  const double beta = 0.04, expo1 = 0.2 - beta * 0.75, safe = 0.9, facc1 = 5.0, facc2 = 0.1;
  double *buf = (double *)malloc(sizeof(double) * 16 * (size_t)nx);
  double *y, *yn, *yt, *k1, *k2, *k3, *k4, *k5, *k6, *k7, *r, *yo;
  if (!buf) return -1;
  y = buf; yn = buf + nx; yt = buf + 2 * nx; k1 = buf + 3 * nx; k2 = buf + 4 * nx;
  k3 = buf + 5 * nx; k4 = buf + 6 * nx; k5 = buf + 7 * nx; k6 = buf + 8 * nx; k7 = buf + 9 * nx;
  r = buf + 10 * nx; yo = buf + 15 * nx;
  memcpy(y, x0, sizeof(double) * nx);
  fs_output(m, 0, tg[0], y, X, U, MON);
  if (!(hmax > 0)) hmax = tend - t;
  fs_rhs(m, t, y, k1, 0, 0);
  h = cfg[C_H0];
  if (!(h > 0)) {  /* Hairer's initial step */
    double dnf = 0, dny = 0, der2 = 0, der12, h1;
    for (c = 0; c < nx; ++c) {
      sk = atol + rtol * fabs(y[c]);
      dnf += (k1[c] / sk) * (k1[c] / sk); dny += (y[c] / sk) * (y[c] / sk);
    }
    h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
    if (h > hmax) h = hmax;
    for (c = 0; c < nx; ++c) yt[c] = y[c] + h * k1[c];
    fs_rhs(m, t + h, yt, k2, 0, 0);
    for (c = 0; c < nx; ++c) {
      sk = atol + rtol * fabs(y[c]);
      der2 += ((k2[c] - k1[c]) / sk) * ((k2[c] - k1[c]) / sk);
    }
    der2 = sqrt(der2) / h;
    der12 = der2 > sqrt(dnf) ? der2 : sqrt(dnf);
    h1 = der12 <= 1e-15 ? (1e-6 > h * 1e-3 ? 1e-6 : h * 1e-3) : pow(0.01 / der12, 0.2);
    h = 100 * h < h1 ? 100 * h : h1;
    if (h > hmax) h = hmax;
  }
  while (k <= T) {
    int last = 0;
    if (steps >= maxsteps) {
      info[I_STATUS] = 2; info[I_REASON] = 3; info[I_TFAIL] = t; info[I_KDONE] = (double)k;
      free(buf);
      return 0;
    }
    if (h < 1e-14 * (fabs(t) > 1 ? fabs(t) : 1)) {
      info[I_STATUS] = nonfinite ? 1 : 2; info[I_REASON] = nonfinite ? 1 : 2; info[I_TFAIL] = t;
      info[I_KDONE] = (double)k;
      free(buf);
      return 0;
    }
    if (t + 1.01 * h >= tend) { h = tend - t; last = 1; }
    for (c = 0; c < nx; ++c) yt[c] = y[c] + h * A21 * k1[c];
    fs_rhs(m, t + C2 * h, yt, k2, 0, 0);
    for (c = 0; c < nx; ++c) yt[c] = y[c] + h * (A31 * k1[c] + A32 * k2[c]);
    fs_rhs(m, t + C3 * h, yt, k3, 0, 0);
    for (c = 0; c < nx; ++c) yt[c] = y[c] + h * (A41 * k1[c] + A42 * k2[c] + A43 * k3[c]);
    fs_rhs(m, t + C4 * h, yt, k4, 0, 0);
    for (c = 0; c < nx; ++c)
      yt[c] = y[c] + h * (A51 * k1[c] + A52 * k2[c] + A53 * k3[c] + A54 * k4[c]);
    fs_rhs(m, t + C5 * h, yt, k5, 0, 0);
    for (c = 0; c < nx; ++c)
      yt[c] = y[c] + h * (A61 * k1[c] + A62 * k2[c] + A63 * k3[c] + A64 * k4[c] + A65 * k5[c]);
    fs_rhs(m, t + h, yt, k6, 0, 0);
    for (c = 0; c < nx; ++c)
      yn[c] = y[c] + h * (A71 * k1[c] + A73 * k3[c] + A74 * k4[c] + A75 * k5[c] + A76 * k6[c]);
    fs_rhs(m, t + h, yn, k7, 0, 0);
    err = 0;
    for (c = 0; c < nx; ++c) {
      double e = h * (E1 * k1[c] + E3 * k3[c] + E4 * k4[c] + E5 * k5[c] + E6 * k6[c] + E7 * k7[c]);
      double ay = fabs(y[c]), an = fabs(yn[c]);
      sk = atol + rtol * (ay > an ? ay : an);
      err += (e / sk) * (e / sk);
    }
    err = sqrt(err / nx);
    if (!isfinite(err)) {  /* a non-finite stage: shorter steps, or the run diverged */
      nonfinite = 1; reject = 1; h *= 0.1; info[I_REJECTED] += 1; ++steps;
      continue;
    }
    nonfinite = 0;
    {
      double fac11 = pow(err, expo1), fac = fac11 / pow(facold, beta), hnew;
      fac = fac / safe;
      if (fac > facc1) fac = facc1;
      if (fac < facc2) fac = facc2;
      hnew = h / fac;
      ++steps;
      if (err <= 1.0) {
        double tn = last ? tend : t + h;
        facold = err > 1e-4 ? err : 1e-4;
        info[I_STEPS] += 1;
        for (c = 0; c < nx; ++c) {  /* dense output */
          double yd = yn[c] - y[c], bs = h * k1[c] - yd;
          r[c] = y[c]; r[nx + c] = yd; r[2 * nx + c] = bs; r[3 * nx + c] = yd - h * k7[c] - bs;
          r[4 * nx + c] = h * (D1 * k1[c] + D3 * k3[c] + D4 * k4[c] + D5 * k5[c] + D6 * k6[c]
                               + D7 * k7[c]);
        }
        while (k <= T && (tg[k] <= tn || (last && k == T))) {
          double th = (k == T && last) ? 1.0 : (tg[k] - t) / h, th1 = 1 - th;
          for (c = 0; c < nx; ++c)
            yo[c] = r[c] + th * (r[nx + c] + th1 * (r[2 * nx + c] + th * (r[3 * nx + c]
                                                                          + th1 * r[4 * nx + c])));
          fs_normalise(m, yo);
          fs_output(m, k, tg[k], yo, X, U, MON);
          ++k;
        }
        memcpy(y, yn, sizeof(double) * nx);
        memcpy(k1, k7, sizeof(double) * nx);
        t = tn;
        if (fabs(hnew) > hmax) hnew = hmax;
        if (reject && hnew > h) hnew = h;
        reject = 0;
        h = hnew;
      } else {
        double f2 = fac11 / safe;
        hnew = h / (f2 < facc1 ? f2 : facc1);
        reject = 1;
        info[I_REJECTED] += 1;
        h = hnew;
      }
    }
  }
  info[I_KDONE] = (double)(T + 1);
  free(buf);
  return 0;
}

/* One run (module comment).  dims[D_SIZE], off[P_SIZE], cfg[C_SIZE], fns = pre, trig, lead,
   law_0 .. law_maxdeg (NULL for an in-degree the graph does not have); tg: the T + 1 output
   times; X ((T + 1) nx), U ((T + 1) 3n), MON ((T + 1) nmon n) written up to info[I_KDONE].
   Returns 0, or -1 when memory could not be allocated. */
int fsa_run(const long *dims, const long *off, const int *rp, const int *ci, const double *p,
            void *const *fns, const double *cfg, const double *x0, long T, const double *tg,
            double *X, double *U, double *MON, double *info) {
  fs_model m;
  int rc;
  memset(info, 0, sizeof(double) * I_SIZE);
  if (fs_init(&m, dims, off, rp, ci, p, fns) != 0) return -1;
  rc = (int)cfg[C_METHOD] == 1 ? fs_dopri5(&m, cfg, x0, T, tg, X, U, MON, info)
                               : fs_rk4(&m, cfg, x0, T, tg, X, U, MON, info);
  info[I_NFEV] = (double)m.nfev;
  info[I_NOBS] = (double)m.nobs;
  fs_free(&m);
  return rc;
}

/* The closed loop at (t, x) (tests and tools): xd (nx), u (3n), mon (nmon n). */
int fsa_eval(const long *dims, const long *off, const int *rp, const int *ci, const double *p,
             void *const *fns, double t, const double *x, double *xd, double *u, double *mon) {
  fs_model m;
  if (fs_init(&m, dims, off, rp, ci, p, fns) != 0) return -1;
  fs_rhs(&m, t, x, xd, 0, 0);
  fs_rhs(&m, t, x, 0, u, mon);
  fs_free(&m);
  return 0;
}

/* Disagreement per output time (the metrics of formsync_design/sim/disagreement.py, for large
   formations): att[k] the largest principal angle (rad) between two attitudes, 2 atan2(|vec(qa*
   qb)|, |qa . qb|) of the normalised quaternions, and rate[k] the largest |w_i - w_j|.  The
   attitude pass screens the pairs by |qa . qb| (monotone in the angle) and evaluates the exact
   formula's arguments on every pair within 1e-12 of the smallest (a bound far above the dot
   product's rounding): the largest angle is that of the exact formula, to rounding.  Q (T, n, 4),
   W (T, n, 3); qn: 4n work values. */
/* one row of the pair scan: the smallest |a . x_j| and the largest |b - v_j|^2 over j < m
   (finite inputs: the caller detects non-finite ones; reassociated so that it vectorises) */
__attribute__((optimize("O3", "fast-math")))
static void fs_row(long m, double a0, double a1, double a2, double a3, double b0, double b1,
                   double b2, const double *restrict x0, const double *restrict x1,
                   const double *restrict x2, const double *restrict x3,
                   const double *restrict v0, const double *restrict v1,
                   const double *restrict v2, double *cmin, double *dmax) {
  long j;
  double cm = INFINITY, dm = 0;
  for (j = 0; j < m; ++j) {
    double c = fabs(a0 * x0[j] + a1 * x1[j] + a2 * x2[j] + a3 * x3[j]);
    double d0 = b0 - v0[j], d1 = b1 - v1[j], d2 = b2 - v2[j];
    double dd = d0 * d0 + d1 * d1 + d2 * d2;
    cm = c < cm ? c : cm;
    dm = dd > dm ? dd : dm;
  }
  *cmin = cm;
  *dmax = dm;
}

/* The exact values are formed in the operation order of the NumPy functions of
   formsync_design/sim/disagreement.py without fused multiply-adds, so that both give the same
   numbers (tests/test_agent_native.py compares them bitwise). */
__attribute__((optimize("fp-contract=off")))
static void fs_disagree(long k0, long k1, long n, const double *Q, const double *W, double *att,
                        double *rate, double *qn) {
  /* work (9 n values): the normalised quaternions and the rates by component (SoA, so the
     screening loop vectorises), each row's smallest |qa . qb| and largest |wa - wb|^2 */
  double *x0 = qn, *x1 = qn + n, *x2 = qn + 2 * n, *x3 = qn + 3 * n;
  double *v0 = qn + 4 * n, *v1 = qn + 5 * n, *v2 = qn + 6 * n, *rowmin = qn + 7 * n;
  double *rowmax = qn + 8 * n;
  long k, i, j, nseen;
  int qbad, wbad;
  double seen[32][7];
  for (k = k0; k < k1; ++k) {
    const double *q = Q + (size_t)k * n * 4, *w = W + (size_t)k * n * 3;
    double cmin = INFINITY, d2max = 0, amax = 0, dex = 0, nanq = 0, nanw = 0;
    for (i = 0; i < n; ++i) {
      double r = sqrt(q[4 * i] * q[4 * i] + q[4 * i + 1] * q[4 * i + 1] + q[4 * i + 2] * q[4 * i + 2]
                      + q[4 * i + 3] * q[4 * i + 3]);
      x0[i] = q[4 * i] / r; x1[i] = q[4 * i + 1] / r; x2[i] = q[4 * i + 2] / r;
      x3[i] = q[4 * i + 3] / r;
      v0[i] = w[3 * i]; v1[i] = w[3 * i + 1]; v2[i] = w[3 * i + 2];
      /* NaN when a value is not finite (inf - inf), as the NumPy metrics give then */
      nanq += (x0[i] - x0[i]) + (x1[i] - x1[i]) + (x2[i] - x2[i]) + (x3[i] - x3[i]);
      nanw += (v0[i] - v0[i]) + (v1[i] - v1[i]) + (v2[i] - v2[i]);
    }
    qbad = nanq != nanq;
    wbad = nanw != nanw;
    /* screening (reassociated, vectorised): each row's extremes */
    for (i = 0; i < n - 1; ++i) {
      double cm, dm;
      fs_row(n - i - 1, x0[i], x1[i], x2[i], x3[i], v0[i], v1[i], v2[i], x0 + i + 1, x1 + i + 1,
             x2 + i + 1, x3 + i + 1, v0 + i + 1, v1 + i + 1, v2 + i + 1, &cm, &dm);
      rowmin[i] = cm;
      rowmax[i] = dm;
      cmin = cm < cmin ? cm : cmin;
      d2max = dm > d2max ? dm : d2max;
    }
    /* the exact values on every row that can hold an extreme (within 1e-12 of it, far above
       the screening's rounding): the largest 2 atan2(|vec(qa* qb)|, |qa . qb|) over the pairs
       with |qa . qb| within 1e-12 of the smallest, the largest |wa - wb|^2 of those rows */
    nseen = 0;
    for (i = 0; i < n - 1 && !(qbad && wbad); ++i) {
      const double a0 = x0[i], a1 = x1[i], a2 = x2[i], a3 = x3[i];
      const double b0 = v0[i], b1 = v1[i], b2 = v2[i];
      long s_;
      int again = 0;
      if (!(!qbad && rowmin[i] <= cmin + 1e-12) && !(!wbad && rowmax[i] >= d2max * (1 - 1e-12)))
        continue;
      /* a row equal to an earlier candidate row (a repeated spacecraft state) holds only
         pairs that row held */
      for (s_ = 0; s_ < nseen && !again; ++s_)
        again = seen[s_][0] == a0 && seen[s_][1] == a1 && seen[s_][2] == a2
                && seen[s_][3] == a3 && seen[s_][4] == b0 && seen[s_][5] == b1
                && seen[s_][6] == b2;
      if (again) continue;
      if (nseen < 32) {
        seen[nseen][0] = a0; seen[nseen][1] = a1; seen[nseen][2] = a2; seen[nseen][3] = a3;
        seen[nseen][4] = b0; seen[nseen][5] = b1; seen[nseen][6] = b2;
        ++nseen;
      }
      for (j = i + 1; j < n; ++j) {
        double c = fabs(a0 * x0[j] + a1 * x1[j] + a2 * x2[j] + a3 * x3[j]);
        double d0 = b0 - v0[j], d1 = b1 - v1[j], d2 = b2 - v2[j];
        double dd = d0 * d0 + d1 * d1 + d2 * d2;
        if (dd > dex) dex = dd;
        if (!qbad && c <= cmin + 1e-12) {
          double e0 = a3 * x0[j] - x3[j] * a0 + (a1 * x2[j] - a2 * x1[j]);
          double e1 = a3 * x1[j] - x3[j] * a1 + (a2 * x0[j] - a0 * x2[j]);
          double e2 = a3 * x2[j] - x3[j] * a2 + (a0 * x1[j] - a1 * x0[j]);
          double ang = 2.0 * atan2(sqrt(e0 * e0 + e1 * e1 + e2 * e2), c);
          if (ang > amax) amax = ang;
        }
      }
    }
    att[k] = n < 2 ? 0.0 : (qbad ? NAN : amax);
    rate[k] = wbad ? NAN : (n < 2 ? 0.0 : sqrt(dex));
  }
}

typedef struct { long k0, k1, n; const double *Q, *W; double *att, *rate, *qn; } fs_dis_job;

static void *fs_dis_thread(void *arg) {
  fs_dis_job *j = (fs_dis_job *)arg;
  fs_disagree(j->k0, j->k1, j->n, j->Q, j->W, j->att, j->rate, j->qn);
  return 0;
}

/* the samples split over `threads` threads (qn: 9n work values per thread) */
int fsa_disagreement(long T, long n, const double *Q, const double *W, double *att, double *rate,
                     double *qn, int threads) {
  pthread_t tid[64];
  fs_dis_job job[64];
  int h, started = 0;
  if (threads < 1) threads = 1;
  if (threads > 64) threads = 64;
  if (threads > T) threads = (int)(T > 0 ? T : 1);
  for (h = 0; h < threads; ++h) {
    job[h].k0 = T * h / threads; job[h].k1 = T * (h + 1) / threads; job[h].n = n;
    job[h].Q = Q; job[h].W = W; job[h].att = att; job[h].rate = rate; job[h].qn = qn + 9 * n * h;
  }
  for (h = 1; h < threads; ++h) {
    if (pthread_create(&tid[h], 0, fs_dis_thread, &job[h]) != 0) break;
    started = h;
  }
  fs_dis_thread(&job[0]);
  for (h = 1; h <= started; ++h) pthread_join(tid[h], 0);
  for (h = started + 1; h < threads; ++h) fs_dis_thread(&job[h]);  /* not started: run here */
  return 0;
}
