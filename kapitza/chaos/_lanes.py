"""The largest Lyapunov exponent on *lanes*: many trajectories per thread, vectorised.

:func:`grid_largest_lanes` computes what :func:`kapitza.chaos._kernels.grid_largest`
computes — a trajectory and one tangent vector per grid point, integrated together by
DOP853 under one error control, the vector renormalised after every accepted step, its
log growth summed per interval — for :data:`~lagrange_core._first_order_lanes.LANES`
points per thread at once, with every array's last axis the lane and every loop over
lanes free of calls (the pattern of :mod:`lagrange_core._first_order_lanes`, whose stage
sums and error norm it shares).  The system's right-hand side comes from its generated
lanes kernels (:mod:`lagrange_core._rhs_lanes`), one call per stage for all lanes:

* ``JVP`` (``tangent="jacobian"``): ``rhs_jvp_lanes`` gives f and J v in one pass —
  forward-mode derivatives of the generated formulas, exact, sharing sin and cos with f;
* ``DIFFERENCE`` (``tangent="difference"``): ``rhs_lanes`` at y and at y + ε v,
  J v ≈ (f(y + ε v) − f(y))/ε with ε = √eps·max(1, ‖y‖)/‖v‖, as the scalar kernel.

Same algorithm, step control (steps landing on the interval ends, at most T/2), statuses
and counts as :func:`kapitza.chaos._kernels.advance` for one tangent vector; the log of
the norms is taken once per interval (their running product, folded into the log
whenever it leaves [1e-150, 1e150]) instead of once per step — a relative difference of
a few ulps per step in the product, far below the exponent's statistical error.
Rounding differs from the scalar kernel as :mod:`lagrange_core._first_order_lanes` says
(sin/cos within 2 ulp, fused multiply-adds, a one-coordinate system's q̈ simplified), so
chaotic trajectories part after a while and agree in their exponents within the stated
errors; regular ones agree to the integration's tolerance
(tests/test_first_order_lanes.py).

Long runs pause: a point that has taken a call's step budget saves its state
(:func:`save_width`) and the next call resumes it, the same steps as an unbroken run, so
``lyapunov_grid`` sizes its calls to ~0.25 s (``lagrange_core.batch._run_paused``, as
``simulate_grid``) and stops on Ctrl-C within about a second whatever the periods.
"""
import math
import sys

import numba
import numpy as np
from numba import njit

from lagrange_core._first_order_lanes import (
    LANES,
    error_sums,
    first_step,
    sparse_tables,
    stage_sum,
    step_factor,
)
from lagrange_core._integrator_kernels import FAST_MATH
from lagrange_core._kernel_calls import RHS_JVP_LANES
from lagrange_core._lane_calls import rhs_jvp_on_lanes, rhs_on_lanes
from lagrange_core._thread_blocks import run_spans

#: tangent modes
DIFFERENCE, JVP = 0, 1
# statuses and counts as kapitza.chaos._kernels
# (and INTERRUPTED: paused after the call's step budget, its state saved to resume)
_FINISHED, _UNDERFLOW, _NON_FINITE, _SINGULAR, _MAX_STEPS, INTERRUPTED = 0, 2, 3, 4, 5, 7
#: SAVEI[·, _SAVED] = 1: the row holds a paused point's state
_SAVED = 0
_STEPS, _REJECTED, _EVALS = 0, 1, 2
_EPS = 2.220446049250313e-16
_SQRT_EPS = 1.4901161193847656e-08
#: the running product of a lane's norms is folded into its log outside [1/BIG, BIG]
_BIG = 1e150


def call_points():
    """Points a lanes call takes (``first`` of ``lagrange_core.batch._run_paused``): two
    lane groups of 2 × threads × LANES, so each block of a call has twice as many points
    as lanes and a lane whose point pauses or ends takes the next instead of idling until
    the block's slowest point has used its step budget (fewer points would leave lanes
    empty).  On a 40 × 40 map × 2000 periods one group took 1.1–1.2× the time of two,
    four about the same (noisy: measured at load 2.4–2.8 on 2 cores)."""
    return 2 * 2 * numba.get_num_threads() * LANES


def save_width(n):
    """Floats of a paused point's saved state (``SAVE`` rows): y, v, f(y) and J v (2n
    each), t, its compensation, h, the running product of norms, the next interval's
    index and the rejected flag."""
    return 8 * n + 6


def grid_largest_lanes(ka, mode, idx, Y0, P, T, T0, stops, v0, rtol, atol, max_steps, A, B, C,
                       E3, E5, LOGS, YF, TF, COUNTS, STATUS, budget, stop, slot, SAVE,
                       SAVEI):
    """Every point ``idx[m]`` on lanes, with the arguments and results of
    :func:`kapitza.chaos._kernels.grid_largest` (``mode`` JVP or DIFFERENCE instead of
    ``exact``); ``ka`` must hold the slots ``rhs`` and ``rhs_lanes``, and in JVP mode
    ``rhs_jvp_lanes`` (:func:`lagrange_core._rhs_lanes.load_rhs_lanes` with ``jvp=True``).

    A point pauses after ``budget`` accepted steps in this call — status 7 (as
    ``lagrange_core``'s GRID_INTERRUPTED), its integrator state in ``SAVE[slot[m]]``
    (:func:`save_width` floats), ``SAVEI[slot[m], 0]`` = 1, its counts, LOGS of the
    intervals it finished, YF and TF so far written — and a later call given that row
    resumes it exactly where it stopped (the same steps as an unbroken run), so that
    ``lagrange_core.batch._run_paused`` can size the calls for Ctrl-C as it does for
    ``simulate_grid``; once ``stop[0]`` is set (Ctrl-C,
    ``lagrange_core.progress.KERNEL_STOP``) every running point pauses at its next step
    and no other point starts.  The points are cut into two blocks per thread, whose lanes take
    the block's next point when theirs ends."""
    if mode == JVP and ka[RHS_JVP_LANES] == 0:      # a call through address 0 would crash
        raise ValueError("grid_largest_lanes: JVP mode needs the rhs_jvp_lanes kernel; load it "
                         "with load_rhs_lanes(kernels, jvp=True).")
    block = max(8, -(-idx.shape[0] // (2 * numba.get_num_threads())))
    _grid(ka, mode, idx, block, Y0, P, T, T0, stops, v0, rtol, atol, max_steps, A, B, C, E3,
          E5, LOGS, YF, TF, COUNTS, STATUS, budget, stop, slot, SAVE, SAVEI)


def _grid(ka, mode, idx, block, Y0, P, T, T0, stops, v0, rtol, atol, max_steps, A, B, C, E3,
          E5, LOGS, YF, TF, COUNTS, STATUS, budget, stop, slot, SAVE, SAVEI):
    """The blocks of :func:`grid_largest_lanes` on the threads of
    :func:`lagrange_core._thread_blocks.run_spans`."""
    run_spans(lambda lo, hi: _block(ka, mode, idx, lo, hi, Y0, P, T, T0, stops, v0, rtol, atol,
                                    max_steps, A, B, C, E3, E5, LOGS, YF, TF, COUNTS, STATUS,
                                    budget, stop, slot, SAVE, SAVEI), idx.shape[0], block,
              stoppable=True)


@njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def _tangent(ka, mode, ts, ys, Vs, Pl, f, jv, yd, fd, sc, work, L):
    """f = f(ts, ys) and jv = J Vs for every lane (``mode``; ``yd``, ``fd`` (d, L) and ``sc``
    (3, L) are scratch); returns the failed lanes' count, their status in work[0]."""
    if mode == JVP:
        return rhs_jvp_on_lanes(ka, ts, ys, Vs, Pl, f, jv, work, L)
    bad = rhs_on_lanes(ka, ts, ys, Pl, f, work, L)
    d = ys.shape[0]
    for l in range(L):
        sc[0, l] = 0.0
        sc[1, l] = 0.0
    for i in range(d):
        for l in range(L):
            sc[0, l] += ys[i, l] * ys[i, l]
            sc[1, l] += Vs[i, l] * Vs[i, l]
    for l in range(L):
        vn = sc[1, l]
        sc[2, l] = _SQRT_EPS * max(1.0, math.sqrt(sc[0, l])) / math.sqrt(vn) if vn > 0.0 else 1.0
        sc[0, l] = work[0, l] if bad > 0 else 0.0
    for i in range(d):
        for l in range(L):
            yd[i, l] = ys[i, l] + sc[2, l] * Vs[i, l]
    bad2 = rhs_on_lanes(ka, ts, yd, Pl, fd, work, L)
    if bad > 0:
        for l in range(L):
            work[0, l] = max(work[0, l], sc[0, l])
    for i in range(d):
        for l in range(L):
            jv[i, l] = (fd[i, l] - f[i, l]) / sc[2, l]
    return bad + bad2


@njit(cache=True, error_model="numpy")
def _load(ka, mode, l, i, sv, svi, Y0, P, T, T0, v0, rtol, atol, y, V, K, KV, Pl, t, tc, h,
          Tl, T0l, jl, prod, rejected, base, COUNTS, one, W, f0, sa, sb):
    """Start point i in lane l — or resume it from its saved row ``sv``/``svi`` (paused by an
    earlier call: ``svi[0]`` = 1; layout of :func:`save_width`) — its state, parameters,
    tangent vector, f and J v at the start (K[0], KV[0], by the lanes kernels on one lane:
    ``one`` holds their arrays) and its first step.  Returns 0, or the point's status when
    it cannot start (singular, or values that are not finite)."""
    d = y.shape[0]
    p = P[i]
    for k in range(p.shape[0]):
        Pl[k, l] = p[k]
    Tl[l] = T[i]
    T0l[l] = T0[i]
    base[l] = COUNTS[i, _STEPS]
    if svi[_SAVED] == 1:
        for j in range(d):
            y[j, l] = sv[j]
            V[j, l] = sv[d + j]
            K[0, j, l] = sv[2 * d + j]
            KV[0, j, l] = sv[3 * d + j]
        o = 4 * d
        t[l] = sv[o]
        tc[l] = sv[o + 1]
        h[l] = sv[o + 2]
        prod[l] = sv[o + 3]
        jl[l] = int(sv[o + 4])
        rejected[l] = sv[o + 5] != 0.0
        svi[_SAVED] = 0
        return 0
    ts, ys, Vs, Pv, f, jv, yd, fd, sc, work = one
    ts[0] = T0[i]
    for j in range(d):
        ys[j, 0] = Y0[i, j]
        Vs[j, 0] = v0[j]
    for k in range(p.shape[0]):
        Pv[k, 0] = p[k]
    # (np.int64: a bare 1 is typed Literal[int](1), and _tangent with the lanes calls under
    # it compiled a second time for this one call, 2.8 s on an empty cache)
    if _tangent(ka, mode, ts, ys, Vs, Pv, f, jv, yd, fd, sc, work, np.int64(1)) > 0:
        return _SINGULAR
    COUNTS[i, _EVALS] += 1 if mode == JVP else 2
    for j in range(d):
        if not (math.isfinite(f[j, 0]) and math.isfinite(jv[j, 0])):
            return _NON_FINITE
    for j in range(d):
        y[j, l] = Y0[i, j]
        V[j, l] = v0[j]
        K[0, j, l] = f[j, 0]
        KV[0, j, l] = jv[j, 0]
        f0[j] = f[j, 0]
    t[l] = T0[i]
    tc[l] = 0.0
    jl[l] = 0
    prod[l] = 1.0
    rejected[l] = False
    h[l] = min(first_step(ka, T0[i], Y0[i], f0, p, rtol, atol, W, sa, sb), 0.5 * T[i])
    COUNTS[i, _EVALS] += 2
    return _NON_FINITE if h[l] < 0.0 else 0


@njit(cache=True, nogil=True, error_model="numpy", fastmath=FAST_MATH)
def _block(ka, mode, idx, lo_b, hi_b, Y0, P, T, T0, stops, v0, rtol, atol, max_steps, A, B, C,
           E3, E5, LOGS, YF, TF, COUNTS, STATUS, budget, stop, slot, SAVE, SAVEI):
    """The points idx[lo_b:hi_b] on one thread's lanes."""
    d = Y0.shape[1]
    n = d // 2
    npar = max(P.shape[1], 1)
    nj = stops.shape[0]
    L = min(LANES, hi_b - lo_b)
    sidx, scoef, spairs = sparse_tables(A, B, E5, E3)
    evals = 12 if mode == JVP else 24
    pt = np.full(L, -1, dtype=np.int64)
    pk = np.zeros(L, dtype=np.int64)
    y = np.zeros((d, L))
    ys = np.zeros((d, L))
    ynew = np.zeros((d, L))
    V = np.zeros((d, L))
    Vs = np.zeros((d, L))
    Vnew = np.zeros((d, L))
    K = np.zeros((13, d, L))
    KV = np.zeros((13, d, L))
    yd = np.zeros((d, L))
    fd = np.zeros((d, L))
    sc = np.zeros((3, L))
    Pl = np.ones((npar, L))
    work = np.zeros((1 + 2 * n * (n + 1), L))
    t = np.zeros(L)
    tc = np.zeros(L)
    h = np.zeros(L)
    hs = np.zeros(L)
    ts = np.zeros(L)
    tar = np.zeros(L)
    tnew = np.zeros(L)
    tcn = np.zeros(L)
    Tl = np.ones(L)
    T0l = np.zeros(L)
    prod = np.ones(L)
    nrm = np.zeros(L)
    e5 = np.zeros(L)
    e3 = np.zeros(L)
    est = np.zeros(L)
    jl = np.zeros(L, dtype=np.int64)
    clip = np.zeros(L, dtype=np.bool_)
    fin = np.zeros(L, dtype=np.bool_)
    sing = np.zeros(L, dtype=np.bool_)
    good = np.zeros(L, dtype=np.bool_)
    special = np.zeros(L, dtype=np.bool_)
    rejected = np.zeros(L, dtype=np.bool_)
    live = np.zeros(L, dtype=np.bool_)
    base = np.zeros(L, dtype=np.int64)
    nst = np.zeros(L, dtype=np.int64)
    nrej = np.zeros(L, dtype=np.int64)
    nev = np.zeros(L, dtype=np.int64)
    one = (np.zeros(1), np.zeros((d, 1)), np.zeros((d, 1)), np.ones((npar, 1)),
           np.zeros((d, 1)), np.zeros((d, 1)), np.zeros((d, 1)), np.zeros((d, 1)),
           np.zeros((3, 1)), np.zeros((1 + 2 * n * (n + 1), 1)))
    W = np.zeros((n, n + 1))
    f0 = np.empty(d)
    sa = np.empty(d)
    sb = np.empty(d)
    nxt = lo_b
    active = 0
    for l in range(L):
        while nxt < hi_b and pt[l] < 0:
            i = idx[nxt]
            sl = slot[nxt]
            st = _load(ka, mode, l, i, SAVE[sl], SAVEI[sl], Y0, P, T, T0, v0, rtol, atol, y,
                       V, K, KV, Pl, t, tc, h, Tl, T0l, jl, prod, rejected, base, COUNTS, one,
                       W, f0, sa, sb)
            if st != 0:
                STATUS[i] = st
                TF[i] = T0[i]
                # element by element: an array copied into a slice makes numba compile its
                # shape-mismatch message (f-strings), ~2 s in each process that compiles it
                for k in range(Y0.shape[1]):
                    YF[i, k] = Y0[i, k]
            else:
                pt[l] = i
                pk[l] = nxt
                live[l] = True
                active += 1
            nxt += 1
    while active > 0:
        if stop[0] != 0 and budget > 0:     # Ctrl-C: every running point pauses at its
            budget = 0                      # next step, and no other point starts
            nxt = hi_b
        for l in range(L):          # the step: landing on the interval's end
            tt = t[l]
            tg = T0l[l] + stops[min(jl[l], nj - 1)] * Tl[l]
            tar[l] = tg
            cl = tt + h[l] >= tg
            hh = tg - tt if cl else h[l]
            clip[l] = cl
            hs[l] = hh if live[l] else 0.0
            sing[l] = False
        for s in range(1, 13):
            yo = ynew if s == 12 else ys
            Vo = Vnew if s == 12 else Vs
            stage_sum(sidx[s], scoef[s], spairs[s], K, y, hs, yo, L)
            stage_sum(sidx[s], scoef[s], spairs[s], KV, V, hs, Vo, L)
            cs = 1.0 if s == 12 else C[s]
            for l in range(L):
                ts[l] = t[l] + cs * hs[l]
            if _tangent(ka, mode, ts, yo, Vo, Pl, K[s], KV[s], yd, fd, sc, work, L) > 0:
                for l in range(L):
                    sing[l] |= work[0, l] != 0.0
        for l in range(L):
            e5[l] = 0.0
            e3[l] = 0.0
            fin[l] = True
        error_sums(sidx[0], scoef, K, y, ynew, hs, rtol, atol, e5, e3, est, fin, L)
        error_sums(sidx[0], scoef, KV, V, Vnew, hs, rtol, atol, e5, e3, est, fin, L)
        for l in range(L):
            nrm[l] = 0.0
        for i in range(d):
            for l in range(L):
                nrm[l] += Vnew[i, l] * Vnew[i, l]
        # accept or reject, every lane at once; the controller of advance
        for l in range(L):
            z = (e5[l] == 0.0) & (e3[l] == 0.0)
            err = 0.0 if z else e5[l] / math.sqrt((e5[l] + 0.01 * e3[l]) * (2 * d))
            fe = math.isfinite(err)
            fin[l] = fin[l] & fe
            lv = live[l]
            ok = lv & (not sing[l]) & fin[l] & (err < 1.0)
            rej = lv & (not sing[l]) & (not ok)
            good[l] = ok
            hh = hs[l]
            fac = step_factor(err)
            hr = hh * max(0.2, fac) if fe else 0.2 * hh
            fa = min(10.0, fac)
            fa = min(1.0, fa) if rejected[l] else fa
            ha = min(max(h[l], hh * fa) if clip[l] else hh * fa, 0.5 * Tl[l])
            h[l] = ha if ok else (hr if rej else h[l])
            rejected[l] = False if ok else (True if rej else rejected[l])
            yk = hh - tc[l]
            tk = t[l] + yk
            tnew[l] = tar[l] if clip[l] else tk
            tcn[l] = 0.0 if clip[l] else (tk - t[l]) - yk
            nrej[l] += 1 if rej else 0
            nst[l] += 1 if ok else 0
            nev[l] += evals if lv else 0
            r = math.sqrt(nrm[l])
            nrm[l] = r
            pr = prod[l] * r
            prod[l] = pr if ok else prod[l]
            hmin = 16.0 * _EPS * max(abs(t[l]), abs(tar[l]))
            bad_norm = ~((r > 0.0) & (r < math.inf))
            far = ~((pr > 1.0 / _BIG) & (pr < _BIG))
            special[l] = lv & (sing[l] | (rej & (hr < hmin))
                               | (ok & (clip[l] | bad_norm | far
                                        | (base[l] + nst[l] >= max_steps)
                                        | (nst[l] >= budget))))
        for i in range(d):
            for l in range(L):
                u = good[l]
                r = nrm[l]
                y[i, l] = ynew[i, l] if u else y[i, l]
                K[0, i, l] = K[12, i, l] if u else K[0, i, l]
                V[i, l] = Vnew[i, l] / r if u else V[i, l]
                KV[0, i, l] = KV[12, i, l] / r if u else KV[0, i, l]
        for l in range(L):
            u = good[l]
            t[l] = tnew[l] if u else t[l]
            tc[l] = tcn[l] if u else tc[l]
        # the rest, lane by lane: interval ends, failures, ends (and the next point)
        for l in range(L):
            if not special[l]:
                continue
            i = pt[l]
            st = -1
            if sing[l]:
                st = _SINGULAR
            elif not good[l]:
                st = _UNDERFLOW if fin[l] else _NON_FINITE
            elif not (nrm[l] > 0.0 and math.isfinite(nrm[l])):
                st = _NON_FINITE
            else:
                if not (1.0 / _BIG < prod[l] < _BIG) and jl[l] < nj:
                    LOGS[i, jl[l]] += math.log(prod[l])
                    prod[l] = 1.0
                while jl[l] < nj and t[l] >= T0l[l] + stops[jl[l]] * Tl[l]:
                    LOGS[i, jl[l]] += math.log(prod[l])
                    prod[l] = 1.0
                    jl[l] += 1
                if jl[l] >= nj:
                    st = _FINISHED
                elif base[l] + nst[l] >= max_steps:
                    st = _MAX_STEPS
                elif nst[l] >= budget:      # pause: the state saved, resumed next call
                    st = INTERRUPTED
                    sv = SAVE[slot[pk[l]]]
                    for j in range(d):
                        sv[j] = y[j, l]
                        sv[d + j] = V[j, l]
                        sv[2 * d + j] = K[0, j, l]
                        sv[3 * d + j] = KV[0, j, l]
                    o = 4 * d
                    sv[o] = t[l]
                    sv[o + 1] = tc[l]
                    sv[o + 2] = h[l]
                    sv[o + 3] = prod[l]
                    sv[o + 4] = float(jl[l])
                    sv[o + 5] = 1.0 if rejected[l] else 0.0
                    SAVEI[slot[pk[l]], _SAVED] = 1
            if st < 0:
                continue
            # a paused point keeps its running product in SAVE (the log taken when
            # its interval ends, as in an unbroken run)
            if st != INTERRUPTED and jl[l] < nj and prod[l] != 1.0:
                LOGS[i, jl[l]] += math.log(prod[l])
            STATUS[i] = st
            TF[i] = t[l]
            COUNTS[i, _STEPS] += nst[l]
            COUNTS[i, _REJECTED] += nrej[l]
            COUNTS[i, _EVALS] += nev[l]
            for j in range(d):
                YF[i, j] = y[j, l]
            pt[l] = -1
            live[l] = False
            active -= 1
            nst[l] = 0
            nrej[l] = 0
            nev[l] = 0
            while nxt < hi_b and pt[l] < 0:
                i2 = idx[nxt]
                sl = slot[nxt]
                st2 = _load(ka, mode, l, i2, SAVE[sl], SAVEI[sl], Y0, P, T, T0, v0, rtol,
                            atol, y, V, K, KV, Pl, t, tc, h, Tl, T0l, jl, prod, rejected, base,
                            COUNTS, one, W, f0, sa, sb)
                if st2 != 0:
                    STATUS[i2] = st2
                    TF[i2] = T0[i2]
                    for k in range(Y0.shape[1]):
                        YF[i2, k] = Y0[i2, k]
                else:
                    pt[l] = i2
                    pk[l] = nxt
                    live[l] = True
                    active += 1
                nxt += 1
            if pt[l] < 0:           # idle: a finite state that no longer moves
                for j in range(d):
                    if not (math.isfinite(y[j, l]) and math.isfinite(V[j, l])):
                        y[j, l] = 0.0
                        V[j, l] = 0.0
                    for m in range(13):
                        K[m, j, l] = 0.0
                        KV[m, j, l] = 0.0


# numba's cache does not notice changes to the kernels these call
from lagrange_core import (  # noqa: E402
    _first_order_lanes,
    _integrator_kernels,
    _kernel_calls,
    _lane_calls,
)
from lagrange_core.module_store import guard_numba_cache  # noqa: E402

guard_numba_cache(sys.modules[__name__], _first_order_lanes, _integrator_kernels, _kernel_calls,
                  _lane_calls)


# a first call on the main thread compiles where Ctrl-C need not wait for it
from lagrange_core._first_calls import guard as _guard_first_calls  # noqa: E402

_guard_first_calls(__name__)
