"""C source of the whole-horizon driver, second part: the integrators (RK4 with ``M``
sub-steps per output interval; DOPRI5 with dense output, Hairer's step control and initial
step, and stops at every kink), one run (``fsd_run``) and batches of runs on threads
(``fsd_batch``).  :mod:`formsync_design.sim.native_c` holds the first part (the model
evaluation, metrics, interpolants and events) and the documentation of the whole.
"""

from __future__ import annotations

__all__ = ["INTEGRATORS"]

INTEGRATORS = r"""
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
