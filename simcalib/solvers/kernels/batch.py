"""The fused DQ kernel used by ``simcalib.solve`` (B = 1) and ``solve_batch`` (on threads).

Per problem: validate and convert the motions (``gram._quats_soa``), choose the sign of
each motion pair (:func:`_align`), accumulate the weighted Gram blocks, assemble (S, W, M)
once (``gram._assemble``), run the method (``dqcore._solve_core``), write X and the data
cost. One compiled entry, ``_one(b0, b1, ...)``, serves single solves (problems 0..1) and
batches (chunks of problems on a few Python threads; the kernel releases the GIL), so
``solve`` equals ``solve_batch`` bit for bit.

Sign alignment (one rule for every DQ method). A motion's dual quaternions are defined up
to sign; the pair (q_C, q_H) must be taken with the signs that make ``q_C q = q q_H``.
Start: the scalar parts of q_C and q_H get the same sign (exact away from 180 deg). A
motion is *ambiguous* when a scalar part is below 0.25 (rotation within ~30 deg of 180):
there, noise can flip the scalar rule. Refinement: solve dqopt, flip every ambiguous pair
with ``(q_C q) . (q q_H) < 0``, repeat (at most 4 rounds). When the refined solution still
fits an ambiguous motion badly (|(q_C q) . (q q_H)| < 0.9), two more starts are tried: the
ambiguous motions' relative signs propagated from one reference motion through the scalar
parts of motion products (``w(q_Ci q_Cj) = s_i s_j w(q_Hi q_Hj)``, reliable when the axes
are not perpendicular), with both global signs; each is refined and the alignment with the
lowest dqopt cost is kept.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np
from simcalib.geometry import quat_multiply
from simcalib.solvers.kernels import jit
from simcalib.solvers.kernels.jit import njit, twin_of

from simcalib.solvers.kernels.dqcore import DQOPT, I_COST, I_STATUS, N_INFO, N_WORK, \
    ST_NONFINITE, _solve_core
from simcalib.solvers.kernels.gram import _T, _assemble, _grams_from_outer, \
    _outer_from_soa, _quats_soa
from simcalib.solvers.kernels.quaternion import RIGID_TOL, _qmul, _transform_from_dq

__all__ = ["run_batch", "AMBIGUOUS_W"]

#: scalar part below which a motion's sign is ambiguous (rotation within ~30 deg of 180)
AMBIGUOUS_W = 0.25
#: |(q_C q).(q q_H)| below which an ambiguous motion counts as badly fitted
_FIT_DOT = 0.9


@njit(cache=True, error_model="numpy")
def _cost_soa(Q, wts, weighted, n, q, qd, a2):
    """Cost (8) motion by motion from the SoA quaternions Q (16, N) (accurate near 0): the
    motions' terms in one loop without a running sum (LLVM vectorises it), then their sum
    in motion order (the same additions as one loop, ~4x less time)."""
    per = np.empty(n)
    _cost_terms(Q, wts, weighted, n, q, qd, a2, per)
    tot = 0.0
    for i in range(n):
        tot += per[i]
    return tot


@njit(cache=True, error_model="numpy", inline="always")
def _cost_terms(Q, wts, weighted, n, q, qd, a2, per):
    """per[i] = motion i's (weighted) term of the cost (8)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    dx, dy, dz, dw = qd[0], qd[1], qd[2], qd[3]
    for i in range(n):
        p = _qmul(Q[0, i], Q[1, i], Q[2, i], Q[3, i], x, y, z, w)
        r = _qmul(x, y, z, w, Q[4, i], Q[5, i], Q[6, i], Q[7, i])
        p1 = _qmul(Q[8, i], Q[9, i], Q[10, i], Q[11, i], x, y, z, w)
        p2 = _qmul(x, y, z, w, Q[12, i], Q[13, i], Q[14, i], Q[15, i])
        p3 = _qmul(Q[0, i], Q[1, i], Q[2, i], Q[3, i], dx, dy, dz, dw)
        p4 = _qmul(dx, dy, dz, dw, Q[4, i], Q[5, i], Q[6, i], Q[7, i])
        ti = 0.0
        for k in range(4):
            ti += (p[k] - r[k]) ** 2 + a2 * (p1[k] - p2[k] + p3[k] - p4[k]) ** 2
        per[i] = wts[i] * ti if weighted else ti


@twin_of(_cost_soa, when=lambda Q, wts, weighted, n, q, qd, a2: n >= 4)   # crossover
def _cost_soa_twin(Q, wts, weighted, n, q, qd, a2):
    """:func:`_cost_soa` over all motions at once (numpy)."""
    c, h, cd, hd = (Q[r:r + 4, :n].T for r in (0, 4, 8, 12))
    r1 = quat_multiply(c, q) - quat_multiply(q, h)
    r2 = quat_multiply(cd, q) - quat_multiply(q, hd) + quat_multiply(c, qd) \
        - quat_multiply(qd, h)
    per = np.sum(r1 * r1, axis=1) + a2 * np.sum(r2 * r2, axis=1)
    return float(np.sum(per * wts[:n]) if weighted else np.sum(per))


@njit(cache=True, error_model="numpy", inline="always")
def _solve_gram(opt, T, Q, wts, weighted, n, a2, Z0, q, qd, info, P, nrm, AtA, BtB, BtA, S, W,
                M, wk):
    """dqopt (method code ``opt``, passed as a runtime value so that ``_solve_core`` is
    compiled once) without prior on the current alignment of Q; Gram blocks left in AtA,
    BtB, BtA."""
    _outer_from_soa(Q, wts, weighted, n, P, nrm)
    _grams_from_outer(T, P, nrm, AtA, BtB, BtA)
    _assemble(AtA, BtB, BtA, a2, Z0, Z0, Z0, S, W, M)
    _solve_core(opt, S, W, M, q, qd, info, wk)


@njit(cache=True, error_model="numpy", inline="always")
def _flip(Q, par, i):
    par[i] = -par[i]
    for k in range(4):
        Q[4 + k, i] = -Q[4 + k, i]
        Q[12 + k, i] = -Q[12 + k, i]


@njit(cache=True, error_model="numpy")
def _save_state(best, q, qd, info, AtA, BtB, BtA):
    for k in range(4):
        best[k] = q[k]
        best[4 + k] = qd[k]
    for k in range(N_INFO):
        best[8 + k] = info[k]
    for i in range(4):
        for j in range(4):
            best[8 + N_INFO + 4 * i + j] = AtA[i, j]
            best[24 + N_INFO + 4 * i + j] = BtB[i, j]
            best[40 + N_INFO + 4 * i + j] = BtA[i, j]


@njit(cache=True, error_model="numpy", inline="always")
def _fit_dots(Q, n, q, dots):
    """dots[i] = (q_Ci q) . (q q_Hi) for every motion (one branch-free loop: vectorised)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    for i in range(n):
        a = _qmul(Q[0, i], Q[1, i], Q[2, i], Q[3, i], x, y, z, w)
        b = _qmul(x, y, z, w, Q[4, i], Q[5, i], Q[6, i], Q[7, i])
        dots[i] = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


@twin_of(_fit_dots, when=lambda Q, n, q, dots: n >= 4)   # measured crossover
def _fit_dots_twin(Q, n, q, dots):
    """:func:`_fit_dots` over all motions at once (numpy)."""
    a = quat_multiply(Q[0:4, :n].T, q)
    b = quat_multiply(q, Q[4:8, :n].T)
    dots[:n] = np.sum(a * b, axis=1)


@njit(cache=True, error_model="numpy", inline="always")
def _refine(opt, T, Q, par, wts, weighted, n, amb, namb, a2, Z0, q, qd, info, P, nrm, AtA, BtB,
            BtA, S, W, M, dots, wk):
    """Flip ambiguous pairs that the dqopt rotation fits with the other sign; re-solve until
    stable (<= 4 flip rounds). Returns the smallest |fit dot| over ambiguous motions.
    (One call site of the solver: the compiled code holds one copy of it.)"""
    fresh = False   # dots hold the fit of the current q
    for rnd in range(5):
        _solve_gram(opt, T, Q, wts, weighted, n, a2, Z0, q, qd, info, P, nrm, AtA, BtB, BtA, S,
                    W, M, wk)
        fresh = False
        if rnd == 4 or namb == 0:
            break
        _fit_dots(Q, n, q, dots)
        fresh = True
        nflip = 0
        for i in range(n):
            if amb[i] > 0.0 and dots[i] < 0.0:
                _flip(Q, par, i)
                nflip += 1
        if nflip == 0:
            break
    worst = 1.0
    if namb == 0:
        return worst
    if not fresh:
        _fit_dots(Q, n, q, dots)
    for i in range(n):
        if amb[i] > 0.0:
            d = abs(dots[i])
            if d < worst:
                worst = d
    return worst


@njit(cache=True, error_model="numpy")
def _propagate_signs(Q, n, amb, sgn):
    """Relative signs (+-1 in sgn) of the ambiguous motions from the scalar parts of motion
    products, starting at the first ambiguous motion; unreachable motions keep +1 and
    reachable ones are marked by |sgn| = 2 (reference) or 3 (propagated)."""
    ref = -1
    for i in range(n):
        sgn[i] = 1.0
        if amb[i] > 0.0 and ref < 0:
            ref = i
    if ref < 0:
        return
    sgn[ref] = 2.0
    for sweep in range(n):
        progress = False
        for i in range(n):
            if amb[i] == 0.0 or abs(sgn[i]) > 1.5:
                continue
            best = -1
            bw = AMBIGUOUS_W
            wh_best = 0.0
            for j in range(n):
                if abs(sgn[j]) < 1.5:
                    continue
                # scalar part of q_Ci q_Cj and q_Hi q_Hj
                wc = Q[3, i] * Q[3, j] - Q[0, i] * Q[0, j] - Q[1, i] * Q[1, j] - Q[2, i] * Q[2, j]
                if abs(wc) > bw:
                    bw = abs(wc)
                    best = j
                    wh = Q[7, i] * Q[7, j] - Q[4, i] * Q[4, j] - Q[5, i] * Q[5, j] - Q[6, i] * Q[6, j]
                    wh_best = wh * wc
            if best >= 0:
                s = 1.0 if sgn[best] > 0 else -1.0
                sgn[i] = 3.0 * (s if wh_best > 0.0 else -s)
                progress = True
        if not progress:
            break


@njit(cache=True, error_model="numpy", inline="always")
def _align(opt, T, Q, wts, weighted, n, a2, q, qd, info, AtA, BtB, BtA, work):
    """Choose the motion pair signs (module doc); q, qd, info hold the dqopt solution (no
    prior) and AtA, BtB, BtA the Gram blocks of the final alignment. Returns the number of
    pairs whose sign differs from the scalar-part rule. ``work``: the arrays of
    :func:`_work_arrays` (overwritten)."""
    P, nrm, S, W, M, Z0, amb, dots, par = work[:9]
    sgn, best_par, best, wk = work[14], work[15], work[16], work[17]
    for i in range(n):
        amb[i] = 0.0   # 1.0: ambiguous motion
        par[i] = 1.0   # -1: pair flipped relative to the scalar-part rule
    namb = _mark_ambiguous(Q, n, amb)
    best_cost = np.inf
    n_starts = 1
    start = 0
    while start < n_starts:   # one call site of _refine (see _refine)
        if start > 0:
            _start_signs(Q, par, sgn, n, start == 2)
        worst = _refine(opt, T, Q, par, wts, weighted, n, amb, namb, a2, Z0, q, qd, info, P,
                        nrm, AtA, BtB, BtA, S, W, M, dots, wk)
        if start == 0 and namb > 0 and worst < _FIT_DOT:
            n_starts = 3
            best_par[:n] = par[:n]             # start 0 is the best so far
            best_cost = info[I_COST]
            _save_state(best, q, qd, info, AtA, BtB, BtA)
            # the propagation works on the scalar-part signs: undo start 0's flips
            for i in range(n):
                if par[i] < 0.0:
                    _flip(Q, par, i)
            _propagate_signs(Q, n, amb, sgn)
        elif start > 0 and info[I_COST] < best_cost:
            best_cost = info[I_COST]
            best_par[:n] = par[:n]
            _save_state(best, q, qd, info, AtA, BtB, BtA)
        start += 1
    if n_starts > 1:   # restore the best start
        for i in range(n):
            if par[i] != best_par[i]:
                _flip(Q, par, i)
        _restore_state(best, q, qd, info, AtA, BtB, BtA)
    total = 0
    for i in range(n):
        if par[i] < 0.0:
            total += 1
    return total


@njit(cache=True, error_model="numpy", inline="always")
def _mark_ambiguous(Q, n, amb):
    """amb[i] = 1 for the motions whose sign is ambiguous (a scalar part <= AMBIGUOUS_W);
    returns their number."""
    namb = 0
    for i in range(n):
        if abs(Q[3, i]) <= AMBIGUOUS_W or abs(Q[7, i]) <= AMBIGUOUS_W:
            amb[i] = 1.0
            namb += 1
    return namb


@njit(cache=True, error_model="numpy", inline="always")
def _start_signs(Q, par, sgn, n, negate):
    """Starts 1, 2 of the alignment: the relative signs propagated from a reference motion
    (sgn, :func:`_propagate_signs`), the reachable ones negated for start 2."""
    for i in range(n):
        s = sgn[i] if abs(sgn[i]) < 1.5 else (1.0 if sgn[i] > 0 else -1.0)
        if negate and abs(sgn[i]) > 1.5:
            s = -s
        if s != par[i]:
            _flip(Q, par, i)


@njit(cache=True, error_model="numpy")
def _restore_state(best, q, qd, info, AtA, BtB, BtA):
    """The inverse of :func:`_save_state`."""
    for k in range(4):
        q[k] = best[k]
        qd[k] = best[4 + k]
    for k in range(N_INFO):
        info[k] = best[8 + k]
    for i in range(4):
        for j in range(4):
            AtA[i, j] = best[8 + N_INFO + 4 * i + j]
            BtB[i, j] = best[24 + N_INFO + 4 * i + j]
            BtA[i, j] = best[40 + N_INFO + 4 * i + j]


@njit(cache=True, error_model="numpy", inline="always")
def _work_arrays(n):
    """The per-problem work arrays, made once per :func:`_one` call (each problem
    overwrites them; a problem allocates nothing): P, nrm, S, W, M, Z0 (zeros, read only),
    amb, dots, par (N each), AtA, BtB, BtA, q, qd, sgn, best_par (N each), best (the saved
    state of the best alignment start), the scratch of ``dqcore._solve_core``."""
    return (np.empty((6, 4, 4)), np.empty(2), np.empty((4, 4)), np.empty((4, 4)),
            np.empty((4, 4)), np.zeros((4, 4)), np.empty(n), np.empty(n), np.empty(n),
            np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty(4), np.empty(4),
            np.empty(n), np.empty(n), np.empty(8 + N_INFO + 48), np.empty((N_WORK, 4, 4)))


@njit(cache=True, error_model="numpy", inline="always")
def _solve_problem(method, opt, T, Cb, Hb, Qin, use_q, align, alpha, wts, weighted, tol,
                   has_prior, S_add, W_add, M_add, X, info, Q, work):
    """One problem: fill Q (16, N) (from C, H, or Qin when use_q), align (unless the motions
    come aligned), solve, write X and info. Returns (index of the first non-rigid motion or -1, sign flips, data cost)."""
    n = Q.shape[1]
    if use_q:
        Q[:, :] = Qin
    else:
        bad = _quats_soa(Cb, Hb, tol, Q)
        if bad >= 0:
            return bad, 0, np.inf
    P, nrm, S, W, M = work[0], work[1], work[2], work[3], work[4]
    AtA, BtB, BtA, q, qd = work[9], work[10], work[11], work[12], work[13]
    a2 = alpha * alpha
    if align:
        nflip = _align(opt, T, Q, wts, weighted, n, a2, q, qd, info, AtA, BtB, BtA, work)
    else:
        nflip = 0
        _outer_from_soa(Q, wts, weighted, n, P, nrm)
        _grams_from_outer(T, P, nrm, AtA, BtB, BtA)
    if method != opt or has_prior or not align:
        _assemble(AtA, BtB, BtA, a2, S_add, W_add, M_add, S, W, M)
        _solve_core(method, S, W, M, q, qd, info, work[17])
    if info[I_STATUS] == ST_NONFINITE:
        for i in range(4):
            for j in range(4):
                X[i, j] = np.nan
        return -1, nflip, np.inf
    _transform_from_dq(q, qd, X)
    # data cost (8): Gram form; recomputed motion by motion when small relative to the
    # scale (the Gram form loses digits there: noise-free or low-noise data)
    cst = 0.0
    scale = 0.0
    for i in range(4):
        scale += AtA[i, i] + a2 * BtB[i, i]
        for j in range(4):
            cst += q[i] * AtA[i, j] * q[j] + a2 * (q[i] * BtB[i, j] * q[j]
                                                   + 2.0 * q[i] * BtA[i, j] * qd[j]
                                                   + qd[i] * AtA[i, j] * qd[j])
    if cst < 1e-5 * scale:
        cst = _cost_soa(Q, wts, weighted, n, q, qd, a2)
    return -1, nflip, cst


@njit(cache=True, error_model="numpy", nogil=True)
def _one(b0, b1, method, opt, T, C, H, Qin, use_q, align, alphas, wts, weighted, tol,
         has_prior, S_add, W_add, M_add, X, cost, info, bad, nflip, Qout, keep_q):
    """Problems b0 <= b < b1 of a batch, on the calling thread, without the GIL: single
    solves run (0, 1), :func:`run_batch` runs chunks of a batch on a few Python threads.
    The only compiled entry of the solve path (no separate parallel kernel: its compile
    re-optimised the whole solver once more, ~1/3 of the cold start)."""
    n = Qin.shape[2] if use_q else C.shape[1]
    Q = np.empty((16, n))
    work = _work_arrays(n)
    for b in range(b0, b1):
        r = _solve_problem(method, opt, T, C[b] if not use_q else C[0],
                           H[b] if not use_q else H[0], Qin[b] if use_q else Qin[0], use_q,
                           align, alphas[b], wts[b] if weighted else wts[0], weighted, tol,
                           has_prior, S_add, W_add, M_add, X[b], info[b], Q, work)
        bad[b] = r[0]
        nflip[b] = r[1]
        cost[b] = r[2]
        if keep_q:
            Qout[b, :, :] = Q


_ZERO4 = np.zeros((4, 4))
_DUMMY4 = np.zeros((1, 1, 4, 4))
_DUMMYQ = np.zeros((1, 16, 1))
#: batches up to this size run on the calling thread
_MIN_THREADED = 64
#: problems a thread takes at a time: the threads (the calling one included) take chunks
#: from a shared counter until none is left, so a core that the machine slows down takes
#: fewer (a call costs ~3 us; 32 problems ~0.6 ms)
_CHUNK = 32
#: the last chunks shrink down to this many problems (:func:`_chunk_starts`)
_MIN_CHUNK = 4
_POOL = None   # (workers, pid, ThreadPoolExecutor), made at the first batch that uses threads


def _threads() -> int:
    """Threads for a batch: numba's thread count (``NUMBA_NUM_THREADS``, or
    ``numba.set_num_threads``; experiment and sweep workers set it to 1); 1 for
    interpreted kernels (they hold the GIL)."""
    if jit.interpreting():
        return 1
    import numba
    return int(numba.get_num_threads())


def _pool(workers: int):
    """The thread pool of ``workers`` helper threads (made again after a fork: a child
    inherits the pool object but not its threads)."""
    global _POOL
    import os
    if _POOL is None or _POOL[:2] != (workers, os.getpid()):
        from concurrent.futures import ThreadPoolExecutor
        if _POOL is not None and _POOL[1] == os.getpid():
            _POOL[2].shutdown(wait=False)
        _POOL = (workers, os.getpid(),
                 ThreadPoolExecutor(workers, thread_name_prefix="simcalib-batch"))
    return _POOL[2]


def _run_chunks(nb: int, args: tuple) -> None:
    """Run problems 0..nb-1 of ``args`` on the calling thread or, for larger batches, on
    ``_threads()`` threads (the calling one and pool helpers; ``_one`` releases the GIL)
    taking the chunks of :func:`_chunk_starts` from one counter."""
    nthreads = min(_threads(), -(-nb // _CHUNK))
    if nb <= _MIN_THREADED or nthreads <= 1:
        _one(0, nb, *args)
        return
    starts = _chunk_starts(nb, nthreads)
    last = len(starts) - 1
    counter = itertools.count()   # next() is atomic under the GIL

    def work():
        while True:
            k = next(counter)
            if k >= last:
                return
            _one(starts[k], starts[k + 1], *args)

    futures = [_pool(nthreads - 1).submit(work) for _ in range(nthreads - 1)]
    work()
    for f in futures:
        f.result()


@functools.lru_cache(maxsize=64)
def _chunk_starts(nb: int, nthreads: int) -> tuple:
    """The chunks' first problems (and ``nb``): ``_CHUNK`` problems while many remain,
    then fewer as the rest shrinks (a quarter of its share per thread, at least
    ``_MIN_CHUNK``), so that the threads finish together: the thread that takes the last
    chunk keeps the others waiting for at most a few problems, not for a whole chunk
    (~0.3 ms on average at B = 1000; more when the machine deschedules that thread).
    Cached: a batch of a size seen before reuses its chunks (the Python loop cost ~50 us
    per call at B = 1000)."""
    starts = [0]
    b = 0
    while b < nb:
        b = min(nb, b + min(_CHUNK, max(_MIN_CHUNK, (nb - b) // (4 * nthreads))))
        starts.append(b)
    return tuple(starts)


def _kernel_array(a) -> np.ndarray:
    """``a`` as the kernel's one signature takes it: C-contiguous, float64 and writable (a
    read-only view, e.g. ``np.broadcast_to`` of one problem's motions, is another numba
    type: its own specialisation, loaded from the cache on its first use in a process,
    ~0.2 s that the loader thread did not load)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    return a if a.flags.writeable else a.copy()


def run_batch(method_code: int, alphas, *, C=None, H=None, Q=None, weights=None,
              prior_adds=None, keep_q: bool = False, align: bool = True) -> dict:
    """Run the fused kernel on ``(B, N, 4, 4)`` ``C``, ``H`` (validated in the kernel; as
    :func:`_kernel_array`) or on already converted motions ``Q (B, 16, N)``. ``alphas (B,)``,
    ``weights (B, N)`` or None, ``prior_adds`` = (S_add, W_add, M_add) or None; ``align``
    False when Q holds already aligned motions (skips the sign alignment).

    Returns a dict of arrays: X (B, 4, 4), cost (B,), info (B, N_INFO), bad (B,) (first
    non-rigid motion or -1), nflip (B,), and Q (B, 16, N) when ``keep_q``."""
    alphas = _kernel_array(alphas)
    nb = alphas.shape[0]
    use_q = Q is not None
    if use_q:
        Qin = _kernel_array(Q)
        C = H = _DUMMY4
        n = Qin.shape[2]
    else:
        Qin = _DUMMYQ
        C, H = _kernel_array(C), _kernel_array(H)
        n = C.shape[1]
    weighted = weights is not None
    wts = _kernel_array(weights) if weighted else np.ones((1, n))
    S_add, W_add, M_add = (_ZERO4, _ZERO4, _ZERO4) if prior_adds is None else (
        _kernel_array(a) for a in prior_adds)
    X = np.full((nb, 4, 4), np.nan)
    cost = np.full(nb, np.inf)
    info = np.zeros((nb, N_INFO))
    bad = np.full(nb, -1, dtype=np.int64)
    nflip = np.zeros(nb, dtype=np.int64)
    Qout = np.empty((nb, 16, n)) if keep_q else _DUMMYQ
    args = (int(method_code), DQOPT, _T, C, H, Qin, use_q, bool(align), alphas, wts, weighted,
            RIGID_TOL, prior_adds is not None, S_add, W_add, M_add, X, cost, info, bad, nflip,
            Qout, keep_q)
    _run_chunks(nb, args)
    out = {"X": X, "cost": cost, "info": info, "bad": bad, "nflip": nflip}
    if keep_q:
        out["Q"] = Qout
    return out


def warm_up(parallel: bool = False) -> float:
    """Compile (or load from the cache) the solve kernel (``parallel`` is accepted for
    compatibility: batches use the same kernel on threads); returns the seconds it took (0
    when ready). ``simcalib.solve``/``solve_batch`` call it before their timed region, so
    ``runtime_s`` never includes compilation."""
    import time
    if _READY[1] or jit.interpreting():   # interpreted kernels compile nothing
        return 0.0
    t0 = time.perf_counter()
    C = np.ascontiguousarray(np.broadcast_to(np.eye(4), (1, 2, 4, 4)))
    run_batch(DQOPT, np.ones(1), C=C, H=C.copy())
    _READY[1] = True
    return time.perf_counter() - t0


_READY = {1: False}


def random_motions_for_warm_up():
    """Eight exact motions of a fixed X (deterministic, no rng): enough for one solve, its
    certificate and its diagnostics to compile every kernel a run uses."""
    from simcalib.geometry import invert_transform, matrix_from_rotvec
    X = np.eye(4)
    X[:3, :3] = matrix_from_rotvec(np.array([0.1, -0.2, 0.3]))
    X[:3, 3] = (0.1, 0.2, -0.05)
    k = np.arange(1, 9, dtype=np.float64)
    rotvecs = np.stack([np.sin(k), np.cos(1.3 * k), np.sin(0.7 * k + 1)], axis=1) * 0.5
    C = np.tile(np.eye(4), (8, 1, 1))
    C[:, :3, :3] = matrix_from_rotvec(rotvecs)
    C[:, :3, 3] = np.stack([np.cos(k), np.sin(2 * k), 0.3 * k / 8], axis=1)
    H = invert_transform(X) @ C @ X
    return C, H


def load_every_kernel() -> None:
    """Load (or compile, once per machine) every compiled entry the solver API calls, with
    the argument types it calls them with: the solve kernel :func:`_one` (single solves,
    batches, solves of given motions with weights and a prior: one signature) and the
    certificate's kernel. (``tests/test_solvers_kernels_jit.py`` checks that a solve, its
    diagnostics and a batch afterwards compile nothing more.)"""
    from simcalib.solvers.kernels.dqcore import certificate_values
    C, H = random_motions_for_warm_up()
    out = run_batch(DQOPT, np.ones(1), C=C[None], H=H[None], keep_q=True)
    run_batch(DQOPT, np.ones(1), Q=out["Q"], weights=np.ones((1, C.shape[0])),
              prior_adds=(np.eye(4), np.zeros((4, 4)), np.eye(4)), align=False)
    certificate_values(np.eye(4), np.zeros((4, 4)), np.eye(4))
    if not jit.interpreting():
        _READY[1] = True
