"""The whole-horizon driver of :mod:`formsync_design.sim.native_c` written in Python over
CasADi's virtual machine: the fallback when no C compiler is available (or compilation
is off), and a second implementation the tests hold the compiled driver to.

Same algorithms, same semantics and the same outputs (:class:`~formsync_design.sim.
native.RunOutput`): RK4 with ``M`` sub-steps per output interval or DOPRI5 (Hairer:
FSAL, PI step control, initial step, dense output), zero-order hold per sample
interval, ``q0 -> floor`` located on the interpolant by the Illinois method, switching
and torque-limit crossings counted at step ends with the first and the last located
(DOPRI5: every step ends at the next crossing, so no step straddles a kink),
the metrics on the grid in O(N) (:func:`~formsync_design.sim.metrics.linear_metrics`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from formsync_design.sim.metrics import linear_metrics
from formsync_design.sim.native_c import CFG, INFO

__all__ = ["run_vm", "DOPRI5"]

#: Dormand-Prince 5(4) tableau (``a`` rows, ``c``, error weights ``e``, dense ``d``).
DOPRI5: dict[str, Any] = {
    "a": [[], [1 / 5], [3 / 40, 9 / 40], [44 / 45, -56 / 15, 32 / 9],
          [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
          [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
          [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]],
    "c": [0.0, 0.2, 0.3, 0.8, 8 / 9, 1.0, 1.0],
    "e": [71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40],
    "d": [-12715105075 / 11282082432, 0.0, 87487479700 / 32700410799,
          -10690763975 / 1880347072, 701980252875 / 199316789632,
          -1453857185 / 822651844, 69997945 / 29380423],
}


class _Interp:
    """Cubic Hermite (RK4) or DOPRI5 dense output on one step ``[t, t + h]``."""

    def __init__(self, t: float, h: float, ya: np.ndarray, fa: np.ndarray, yb: np.ndarray,
                 fb: np.ndarray | None, rc: np.ndarray | None = None) -> None:
        self.t, self.h, self.ya, self.fa, self.yb, self.fb, self.rc = t, h, ya, fa, yb, fb, rc

    def __call__(self, th: float) -> np.ndarray:
        if self.rc is None:
            assert self.fb is not None
            t2, t3 = th * th, th * th * th
            return ((2 * t3 - 3 * t2 + 1) * self.ya + (t3 - 2 * t2 + th) * self.h * self.fa
                    + (-2 * t3 + 3 * t2) * self.yb + (t3 - t2) * self.h * self.fb)
        r, th1 = self.rc, 1 - th
        return r[0] + th * (r[1] + th1 * (r[2] + th * (r[3] + th1 * r[4])))


def _illinois(g: Callable[[float], float], ga: float, gb: float, h: float, tol: float) -> float:
    """First point at or past the sign change of ``g`` on ``[0, 1]`` (``g(0) = ga``)."""
    a, b, side = 0.0, 1.0, 0
    for _ in range(200):
        if (b - a) * h <= tol:
            break
        x = (a * gb - b * ga) / (gb - ga)
        if not (a < x < b):
            x = 0.5 * (a + b)
        e = 0.5 * tol / h  # a point closer than tol/2 to an end moves to tol/2 inside
        if b - a > 2 * e:
            if x - a < e:
                x = a + e
            elif b - x < e:
                x = b - e
        gx = g(x)
        if (gx > 0) == (ga > 0):
            a, ga = x, gx
            if side == -1:
                gb *= 0.5
            side = -1
        else:
            b, gb = x, gx
            if side == 1:
                ga *= 0.5
            side = 1
    return b


class _Run:
    def __init__(self, kern: Any, n: int, p: np.ndarray, cfg: np.ndarray, K: int) -> None:
        self.kern, self.n, self.nx, self.p, self.K = kern, n, 7 * n, p, K
        self.c = dict(zip(CFG, (float(v) for v in cfg), strict=True))
        self.info = dict.fromkeys(INFO, 0.0)
        self.info.update(tevent=math.nan, tfail=math.nan, q0fail=math.nan)
        self.ev = {"switch_count": 0.0, "switch_first": math.nan, "switch_last": math.nan,
                   "limit_count": 0.0, "limit_first": math.nan, "limit_last": math.nan}
        self.last: list[Any] = [None, None]
        self.pend: tuple[int, int, bool] | None = None  # kink stop: (channel, component, sign past it)
        self.X: list[np.ndarray] = []
        self.U: list[np.ndarray] = []
        lay_umax = kern.layout["umax"]
        self.umax = np.asarray(p[lay_umax], dtype=float)
        self.phi = float(p[kern.layout["phi"]][0])
        self.limited = bool(np.isfinite(self.umax).any())
        self.swkind = int(self.c["swkind"])
        self.iq = np.arange(n) * 4 + 3

    # evaluations ---------------------------------------------------------------------
    def f(self, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(xdot, u, tau, uraw)``: the closed loop, the limited torque, the switching
        argument and the torque before the limit."""
        self.info["nfev"] += 1
        out = self.kern.evaluate(x, t, self.p)
        return tuple(np.asarray(o).ravel() for o in out)  # type: ignore[return-value]

    def ctrl(self, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(u, tau, uraw)``: the controller alone."""
        self.info["nctrl"] += 1
        out = self.kern.evaluate(x, t, self.p)
        return tuple(np.asarray(o).ravel() for o in out[1:])  # type: ignore[return-value]

    def plant(self, t: float, x: np.ndarray, uh: np.ndarray) -> np.ndarray:
        self.info["nfev"] += 1
        return np.asarray(self.kern.plant(x, uh, t, self.p)).ravel()

    # grid, events, failures ------------------------------------------------------------
    def grid(self, x: np.ndarray, u: np.ndarray) -> None:
        self.X.append(np.array(x, dtype=float))
        self.U.append(np.array(u, dtype=float))

    def evf(self, ch: int, tau: np.ndarray, ur: np.ndarray) -> np.ndarray:
        """Event functions: the boundary layer ``|tau| - phi`` (``tau`` for sgn) and the
        torque before the limit against the limit ``|uraw| - umax``."""
        if ch == 0:
            return tau if self.swkind == 2 else np.abs(tau) - self.phi
        return np.abs(ur) - self.umax

    def locate(self, itp: _Interp, ch: int, j: int, ga: float, gb: float) -> float:
        def g(th: float) -> float:
            _, tau, ur = self.ctrl(itp.t + th * itp.h, itp(th))
            return float(self.evf(ch, tau, ur)[j])

        return itp.t + _illinois(g, ga, gb, itp.h, self.c["evtol"]) * itp.h

    def events_step(self, itp: _Interp, ua: np.ndarray, ta: np.ndarray, ub: np.ndarray,
                    tb: np.ndarray) -> None:
        for ch, name in ((0, "switch"), (1, "limit")):
            if (ch == 0 and self.swkind == 0) or (ch == 1 and not self.limited):
                continue
            with np.errstate(all="ignore"):
                ga, gb = self.evf(ch, ta, ua), self.evf(ch, tb, ub)
                cross = np.flatnonzero((ga > 0) != (gb > 0))
                if cross.size == 0:
                    continue
                th = ga[cross] / (ga[cross] - gb[cross])
            self.ev[f"{name}_count"] += cross.size
            jf, jl = int(cross[int(np.argmin(th))]), int(cross[int(np.argmax(th))])
            if math.isnan(self.ev[f"{name}_first"]):
                self.ev[f"{name}_first"] = self.locate(itp, ch, jf, float(ga[jf]), float(gb[jf]))
            self.last[ch] = (itp, jl, float(ga[jl]), float(gb[jl]))

    def kinks(self, itp: _Interp, ua: np.ndarray, ta: np.ndarray, ub: np.ndarray,
              tb: np.ndarray) -> tuple[float, int, int, float] | None:
        """The earliest crossing of any channel in the step, located; counts every crossing
        (the component a previous step ended at takes its past-the-crossing sign)."""
        best: tuple[float, int, int, float, float] | None = None
        for ch, name in ((0, "switch"), (1, "limit")):
            if (ch == 0 and self.swkind == 0) or (ch == 1 and not self.limited):
                continue
            with np.errstate(all="ignore"):
                ga, gb = self.evf(ch, ta, ua), self.evf(ch, tb, ub)
            sa, sb = ga > 0, gb > 0
            if self.pend is not None and self.pend[0] == ch:
                jp = self.pend[1]
                sa[jp] = self.pend[2]
                if sa[jp] != (ga[jp] > 0):
                    ga[jp] = 1e-300 if sa[jp] else -1e-300
            cross = np.flatnonzero(sa != sb)
            self.ev[f"{name}_count"] += cross.size
            for jc in cross:
                j = int(jc)
                th = ga[j] / (ga[j] - gb[j])
                if best is None or th < best[0]:
                    best = (float(th), ch, int(j), float(ga[j]), float(gb[j]))
        if best is None:
            return None
        _, chb, jb, ga_, gb_ = best
        return self.locate(itp, chb, jb, ga_, gb_), chb, jb, ga_

    def finish_events(self) -> None:
        for ch, name in ((0, "switch"), (1, "limit")):
            if self.last[ch] is not None:
                itp, j, ga, gb = self.last[ch]
                self.ev[f"{name}_last"] = self.locate(itp, ch, j, ga, gb)

    def q0_event(self, itp: _Interp, xa: np.ndarray, xb: np.ndarray) -> tuple[int, float]:
        best, bt, floor = -1, 0.0, self.c["floor"]
        for i in range(self.n):
            a, b = xa[self.iq[i]], xb[self.iq[i]]
            if math.isfinite(b) and b <= floor:
                c = int(self.iq[i])

                def g(s: float, c: int = c) -> float:
                    return float(itp(s)[c] - floor)

                th = _illinois(g, a - floor, b - floor, itp.h, self.c["evtol"]) if a > floor else 0.0
                tc = itp.t + th * itp.h
                if best < 0 or tc < bt:
                    best, bt = i, tc
        return best, bt

    def hit(self, x: np.ndarray) -> bool:
        b = x[self.iq]
        return bool((np.isfinite(b) & (b <= self.c["floor"])).any())

    def drift(self, x: np.ndarray) -> float:
        with np.errstate(all="ignore"):
            d = np.abs(np.linalg.norm(x[: 4 * self.n].reshape(self.n, 4), axis=1) - 1)
        return float(d.max()) if np.all(np.isfinite(d)) else math.nan

    def fail(self, x: np.ndarray, t: float, reason: int) -> None:
        imin = int(np.argmin(x[self.iq]))
        self.info.update(status=3.0 if reason == 4 else 2.0, reason=0.0 if reason == 4 else float(reason),
                         tfail=t, q0fail=float(x[self.iq[imin]]), sc=float(imin + 1),
                         kdone=float(len(self.X) - 1))

    def event(self, sc: int, tev: float, itp: _Interp, minq: np.ndarray) -> None:
        self.info.update(status=1.0, tevent=tev, sc=float(sc + 1), kdone=float(len(self.X) - 1))
        np.minimum(minq, itp((tev - itp.t) / itp.h)[self.iq], out=minq)  # up to the event
        minq[sc] = min(minq[sc], self.c["floor"])


def _rk4(R: _Run, x: np.ndarray, t: float, minq: np.ndarray) -> None:
    zoh, M = R.c["zoh"] != 0, int(R.c["substeps"])
    h = R.c["interval"] / M
    evs = not zoh and (R.swkind or R.limited)
    if not zoh:
        k1, ul0, tau0, u0 = R.f(t, x)
    for _k in range(R.K):
        if zoh:
            uh = R.ctrl(t, x)[0]
            R.grid(x, uh)
        else:
            R.grid(x, ul0)
        for _j in range(M):
            with np.errstate(all="ignore"):
                if zoh:
                    k1 = R.plant(t, x, uh)
                    k2 = R.plant(t + h / 2, x + h / 2 * k1, uh)
                    k3 = R.plant(t + h / 2, x + h / 2 * k2, uh)
                    k4 = R.plant(t + h, x + h * k3, uh)
                else:
                    k2 = R.f(t + h / 2, x + h / 2 * k1)[0]
                    k3 = R.f(t + h / 2, x + h / 2 * k2)[0]
                    k4 = R.f(t + h, x + h * k3)[0]
                xn = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            R.info["steps"] += 1
            hit = R.hit(xn)
            fb = None
            if not zoh:
                with np.errstate(all="ignore"):
                    fb, ul1, tau1, u1 = R.f(t + h, xn)
            elif hit:
                fb = R.plant(t + h, xn, uh)
            itp = _Interp(t, h, x, k1, xn, fb)
            if hit:
                sc, tev = R.q0_event(itp, x, xn)
                R.event(sc, tev, itp, minq)
                return
            if not np.all(np.isfinite(xn)):
                R.fail(x, t, 1)
                return
            if not (R.drift(xn) <= R.c["normtol"]):
                R.fail(x, t, 4)
                return
            if evs:
                R.events_step(itp, u0, tau0, u1, tau1)
            np.minimum(minq, xn[R.iq], out=minq)
            x = xn
            if not zoh:
                k1, ul0, u0, tau0 = fb, ul1, u1, tau1  # type: ignore[assignment]
            t = t + h
    if zoh:
        R.grid(x, R.ctrl(t, x)[0])
    else:
        R.grid(x, ul0)
    R.info["kdone"] = float(R.K)


def _held(R: _Run, uh: np.ndarray, t: float, x: np.ndarray) -> np.ndarray:
    return R.plant(t, x, uh)


def _closed(R: _Run, t: float, x: np.ndarray) -> np.ndarray:
    return R.f(t, x)[0]


def _hinit(R: _Run, ev: Callable[[float, np.ndarray], np.ndarray], t: float, x: np.ndarray,
           f0: np.ndarray, rtol: float, atol: float, hmax: float) -> float:
    sk = atol + rtol * np.abs(x)
    dnf, dny = float(np.sum((f0 / sk) ** 2)), float(np.sum((x / sk) ** 2))
    h = 1e-6 if (dnf <= 1e-10 or dny <= 1e-10) else math.sqrt(dny / dnf) * 0.01
    h = min(h, hmax)
    f1 = ev(t + h, x + h * f0)
    der2 = math.sqrt(float(np.sum(((f1 - f0) / sk) ** 2))) / h
    der12 = max(der2, math.sqrt(dnf))
    h1 = max(1e-6, h * 1e-3) if der12 <= 1e-15 else (0.01 / der12) ** 0.2
    return min(100 * h, h1, hmax)


def _dopri(R: _Run, x: np.ndarray, t0: float, minq: np.ndarray) -> None:
    c = R.c
    zoh, iv, K = c["zoh"] != 0, c["interval"], R.K
    rtol, atol, hmax, tol = c["rtol"], c["atol"], c["hmax"], c["evtol"]
    A, C, Ew, D = DOPRI5["a"], DOPRI5["c"], DOPRI5["e"], DOPRI5["d"]
    safe, beta, expo1, facc1, facc2 = 0.9, 0.04, 0.2 - 0.04 * 0.75, 5.0, 0.1
    facold, h, t, kg = 1e-4, c["h0"], t0, 1
    kinkstop = not zoh and c["kinkstop"] != 0 and bool(R.swkind or R.limited)
    forced, fch, fj, fsign, hnat = False, -1, 0, False, 0.0
    uh = np.zeros(3 * R.n)
    u0 = ul0 = tau0 = uh
    for seg in range(K if zoh else 1):
        tend = t0 + (seg + 1) * iv if zoh else t0 + K * iv
        ev: Callable[[float, np.ndarray], np.ndarray]
        if zoh:
            t = t0 + seg * iv
            uh = R.ctrl(t, x)[0]
            R.grid(x, uh)
            ev = functools.partial(_held, R, uh)
            k1 = ev(t, x)
        else:
            ev = functools.partial(_closed, R)
            k1, ul0, tau0, u0 = R.f(t, x)
            R.grid(x, ul0)
        if not h > 0:
            h = _hinit(R, ev, t, x, k1, rtol, atol, hmax)
        rejected_last = False
        while t < tend:
            hmin = 16 * 2.220446049250313e-16 * abs(tend)
            if R.info["steps"] + R.info["rejected"] >= c["maxsteps"]:
                R.fail(x, t, 3)
                return
            h = min(h, hmax)
            last = False
            if not forced:
                hnat = h
            if t + (1.0 if forced else 1.01) * h >= tend:
                h, last = tend - t, True
            ks = [k1]
            with np.errstate(all="ignore"):
                for s in range(1, 6):
                    ys = x + h * sum(A[s][j] * ks[j] for j in range(s))
                    ks.append(ev(t + C[s] * h if s < 5 else (tend if last else t + h), ys))
                tn = tend if last else t + h
                y1 = x + h * sum(A[6][j] * ks[j] for j in range(6) if A[6][j] != 0.0)
                if zoh:
                    k7 = ev(tn, y1)
                else:
                    k7, ul1, tau1, u1 = R.f(tn, y1)
                ks.append(k7)
                sk = atol + rtol * np.maximum(np.abs(x), np.abs(y1))
                e = h * sum(Ew[j] * ks[j] for j in range(7) if Ew[j] != 0.0) / sk
                err = math.sqrt(float(np.sum(e * e)) / R.nx)
            if not err <= 1.0:
                R.info["rejected"] += 1
                fac11 = err**expo1 if math.isfinite(err) else 1e300
                h = h / min(facc1, fac11 / safe)
                rejected_last, forced = True, False
                if not h >= hmin:
                    R.fail(x, t, 2 if np.all(np.isfinite(y1)) else 1)
                    return
                continue
            R.info["steps"] += 1
            d = y1 - x
            bs = h * k1 - d
            rc = np.array([x, d, bs, d - h * k7 - bs, h * sum(D[j] * ks[j] for j in range(7) if D[j] != 0.0)])
            itp = _Interp(t, tn - t, x, k1, y1, k7, rc)
            if R.hit(y1):
                sc, tev = R.q0_event(itp, x, y1)
                if not zoh:
                    while kg <= K and t0 + kg * iv < tev:
                        tg = t0 + kg * iv
                        yg = itp((tg - t) / itp.h)
                        R.grid(yg, R.ctrl(tg, yg)[0])
                        kg += 1
                R.event(sc, tev, itp, minq)
                return
            if not (R.drift(y1) <= c["normtol"]):
                R.fail(x, t, 4)
                return
            if kinkstop:
                # never step across a kink (boundary layer, torque limit): end the step at
                # the earliest crossing instead and start the next one there
                counts = (R.ev["switch_count"], R.ev["limit_count"])
                found = R.kinks(itp, u0, tau0, u1, tau1)
                if found is not None and t + tol < found[0] < tn - tol:
                    R.ev["switch_count"], R.ev["limit_count"] = counts
                    R.info["steps"] -= 1
                    R.info["kinks"] += 1
                    h, forced = found[0] - t, True
                    fch, fj, fsign = found[1], found[2], not (found[3] > 0)
                    continue
                names = ("switch", "limit")
                if found is not None:
                    nm = names[found[1]]
                    if math.isnan(R.ev[f"{nm}_first"]):
                        R.ev[f"{nm}_first"] = found[0]
                    R.ev[f"{nm}_last"] = found[0]
                if forced and not (found is not None and found[1] == fch and found[2] == fj):
                    nm = names[fch]
                    R.ev[f"{nm}_count"] += 1
                    if math.isnan(R.ev[f"{nm}_first"]):
                        R.ev[f"{nm}_first"] = tn
                    R.ev[f"{nm}_last"] = tn
                    R.pend = (fch, fj, fsign)
                else:
                    R.pend = None
            if not zoh:
                while kg <= K and t0 + kg * iv <= tn:
                    tg = t0 + kg * iv
                    if kg == K or tg == tn:
                        R.grid(y1, ul1)
                    else:
                        yg = itp((tg - t) / itp.h)
                        R.grid(yg, R.ctrl(tg, yg)[0])
                    kg += 1
                if not kinkstop and (R.swkind or R.limited):
                    R.events_step(itp, u0, tau0, u1, tau1)
                u0, ul0, tau0 = u1, ul1, tau1
            np.minimum(minq, y1[R.iq], out=minq)
            fac11 = err**expo1
            fac = min(facc1, max(facc2, fac11 / facold**beta / safe))
            facold = max(err, 1e-4)
            hnew = (tn - t) / fac
            if rejected_last and hnew > tn - t:
                hnew = tn - t
            if (last or forced) and hnew >= tn - t and hnat > hnew:
                hnew = hnat
            x, k1, t, h = y1, k7, tn, hnew
            rejected_last = forced = False
    if zoh:
        R.grid(x, R.ctrl(t, x)[0])
    R.info["kdone"] = float(K)


def run_vm(kern: Any, n: int, p: np.ndarray, cfg: np.ndarray, x0: np.ndarray, t0: float,
           K: int) -> Any:
    """:meth:`NativeKernel.run <formsync_design.sim.native.NativeKernel.run>` in Python on
    ``kern`` (a :class:`~formsync_design.sim.kernels.Kernel`: ``evaluate``, ``plant``)."""
    from formsync_design.sim.native import RunOutput

    R = _Run(kern, n, np.asarray(p, dtype=float), np.asarray(cfg, dtype=float), K)
    x = np.array(x0, dtype=float)
    minq = x[R.iq].copy()
    if R.c["method"] == 0:
        _rk4(R, x, float(t0), minq)
    else:
        _dopri(R, x, float(t0), minq)
    R.finish_events()
    X = np.array(R.X).reshape(-1, 7 * n)
    U = np.array(R.U).reshape(-1, 3 * n)
    om, qm = linear_metrics(X, n)
    with np.errstate(all="ignore"):
        ne = np.abs(np.linalg.norm(X[:, : 4 * n].reshape(len(X), n, 4), axis=2) - 1)
    R.info["normerr"] = float(ne.max()) if ne.size else 0.0
    return RunOutput(X, U, np.column_stack([om, qm]), minq, dict(R.info), dict(R.ev))
