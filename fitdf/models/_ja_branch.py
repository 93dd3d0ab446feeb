"""The realised Jiles-Atherton branch: monotone pieces, describing function, evaluation, tables.

From the nodes ``(H_e, M, dM/dH_e)`` of the steady ascending branch
(:mod:`fitdf.models._ja_integrate`) the parametric cubics are cut into pieces monotone in
``H`` (folds become vertical jumps); on them the numba kernels integrate ``N(A)``, invert
``H(H_e)`` to evaluate the branch at given inputs and sample it for tables.
:class:`SteadyCache` keeps the nodes of recently solved rows (solve and evaluation are
separate kernels, :func:`_steady_rows` and :func:`_eval_rows`) for the ``voltage`` chain,
which evaluates one row's branch several times at new inputs.
"""

from __future__ import annotations

import math
import os
import threading
from collections import OrderedDict

import numba
import numpy as np

from fitdf.models._ja_integrate import _CAP, _cubic, _poly, _steady

_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)
# Gauss-Legendre in v on [0, 1] through t = (1 - cos(pi v)) / 2: removes the square-root
# end behaviour of sqrt(A^2 - H^2) at the tips.
_V = 0.5 * (_GL_X + 1.0)
_T_OF_V = 0.5 * (1.0 - np.cos(np.pi * _V))
_W_OF_V = 0.5 * _GL_W * 0.5 * np.pi * np.sin(np.pi * _V)


@numba.njit(cache=True)
def _segment(rec_e, rec_m, rec_d, j, kap):
    """Cubics in ``t`` of ``M`` and ``H = H_e - alpha M`` on segment ``j``."""
    step = rec_e[j + 1] - rec_e[j]
    m0, m1, m2, m3 = _cubic(rec_m[j], rec_d[j], rec_m[j + 1], rec_d[j + 1], step)
    return m0, m1, m2, m3, rec_e[j] - kap * m0, step - kap * m1, -kap * m2, -kap * m3


@numba.njit(cache=True)
def _monotone_cuts(g1, g2, g3, cuts):
    """``0``, the zeros of ``dH/dt = g1 + 2 g2 t + 3 g3 t^2`` inside (0, 1), ``1``; their count."""
    nc = 1
    cuts[0] = 0.0
    qa, qb, qc = 3.0 * g3, 2.0 * g2, g1
    if qa != 0.0:
        disc = qb * qb - 4.0 * qa * qc
        if disc > 0.0:
            sq = math.sqrt(disc)
            qq = -0.5 * (qb + (sq if qb >= 0.0 else -sq))
            r1 = qq / qa
            r2 = qc / qq if qq != 0.0 else r1
            for r in (min(r1, r2), max(r1, r2)):
                if 0.0 < r < 1.0:
                    cuts[nc] = r
                    nc += 1
    elif qb != 0.0:
        r = -qc / qb
        if 0.0 < r < 1.0:
            cuts[nc] = r
            nc += 1
    cuts[nc] = 1.0
    return nc + 1


@numba.njit(cache=True)
def _pieces(rec_e, rec_m, rec_d, n, kap, A, seg, t0, t1, h0, h1, mj0, mj1):
    """Split the branch into pieces monotone in ``H``, cutting the folds into vertical jumps.

    A rising ``H`` realises the parametric curve only where ``H`` equals its running maximum;
    a dip (avalanche) is replaced by a jump at the maximum, from the fold's ``M`` to ``M``
    where the curve comes back to it. Piece ``i``: segment ``seg[i]`` on ``[t0, t1]``
    (``seg = -1``: a jump at ``h0 = h1`` from ``mj0`` to ``mj1``). Returns the count.
    """
    count = 0
    h_max = -A
    m_at_max = rec_m[0]
    cuts = np.empty(4)
    for j in range(n - 1):
        m0, m1, m2, m3, g0, g1, g2, g3 = _segment(rec_e, rec_m, rec_d, j, kap)
        nc = _monotone_cuts(g1, g2, g3, cuts)
        for p in range(nc - 1):
            ta, tb = cuts[p], cuts[p + 1]
            ha, hb = _poly(g0, g1, g2, g3, ta), _poly(g0, g1, g2, g3, tb)
            if j == n - 2 and p == nc - 2:
                hb = A
            if hb <= ha or hb <= h_max:
                continue
            if ha < h_max - 1e-14 * A:  # back from an avalanche: jump, then the rest
                lo, hi = ta, tb
                for _it in range(200):
                    mid = 0.5 * (lo + hi)
                    if _poly(g0, g1, g2, g3, mid) < h_max:
                        lo = mid
                    else:
                        hi = mid
                    if hi - lo < 1e-15:
                        break
                ta = hi
                seg[count], h0[count], h1[count] = -1, h_max, h_max
                mj0[count], mj1[count] = m_at_max, _poly(m0, m1, m2, m3, ta)
                count += 1
            seg[count], t0[count], t1[count], h0[count], h1[count] = j, ta, tb, max(ha, h_max), hb
            count += 1
            h_max = hb
            m_at_max = _poly(m0, m1, m2, m3, tb)
    return count


@numba.njit(cache=True)
def _branch_df(A, rec_e, rec_m, rec_d, n, kap, seg, t0, t1, h0, h1, mj0, mj1, tv, wv):
    """``N = (2/(pi A^2)) Int y_up'(x) [sqrt(A^2 - x^2) - j x] dx`` over the pieces."""
    count = _pieces(rec_e, rec_m, rec_d, n, kap, A, seg, t0, t1, h0, h1, mj0, mj1)
    re = 0.0
    im = 0.0
    A2 = A * A
    for i in range(count):
        if seg[i] < 0:
            x = h0[i]
            dm = mj1[i] - mj0[i]
            re += dm * math.sqrt(max(A2 - x * x, 0.0))
            im -= dm * x
            continue
        m0, m1, m2, m3, g0, g1, g2, g3 = _segment(rec_e, rec_m, rec_d, seg[i], kap)
        w = t1[i] - t0[i]
        for q in range(tv.size):
            t = t0[i] + w * tv[q]
            x = min(max(_poly(g0, g1, g2, g3, t), -A), A)
            dm = (m1 + t * (2.0 * m2 + 3.0 * t * m3)) * w * wv[q]
            re += dm * math.sqrt(max(A2 - x * x, 0.0))
            im -= dm * x
    f = 2.0 / (math.pi * A2)
    return complex(f * re, f * im)


@numba.njit(cache=True)
def _branch_at(x, rec_e, rec_m, rec_d, kap, seg, t0, t1, h0, h1, mj0, mj1, count):
    """``M`` on the realised branch at ``H = x`` (clipped to the branch's range)."""
    x = min(max(x, h0[0]), h1[count - 1])
    lo, hi = 0, count - 1
    while lo < hi:  # first piece with h1 >= x
        mid = (lo + hi) // 2
        if h1[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    i = lo
    if seg[i] < 0:
        return mj1[i]
    m0, m1, m2, m3, g0, g1, g2, g3 = _segment(rec_e, rec_m, rec_d, seg[i], kap)
    ta, tb = t0[i], t1[i]
    t = ta + (tb - ta) * (x - h0[i]) / (h1[i] - h0[i]) if h1[i] > h0[i] else tb
    for _it in range(100):  # Newton on the monotone cubic, kept inside [ta, tb]
        f = _poly(g0, g1, g2, g3, t) - x
        if f > 0.0:
            tb = t
        else:
            ta = t
        df = g1 + t * (2.0 * g2 + 3.0 * t * g3)
        tn = t - f / df if df > 0.0 else 0.5 * (ta + tb)
        if not (ta <= tn <= tb):
            tn = 0.5 * (ta + tb)
        done = abs(tn - t) <= 1e-15 or tb - ta <= 1e-15
        t = tn
        if done:
            break
    return _poly(m0, m1, m2, m3, t)


@numba.njit(cache=True)
def _work(cap):
    seg = np.empty(4 * cap, dtype=np.int64)
    return (
        np.empty(cap),
        np.empty(cap),
        np.empty(cap),
        seg,
        np.empty(4 * cap),
        np.empty(4 * cap),
        np.empty(4 * cap),
        np.empty(4 * cap),
        np.empty(4 * cap),
        np.empty(4 * cap),
    )


@numba.njit(cache=True)
def _df_loop(A, lam, a, k, c, kap, tol, nmin, cap, tv, wv, out):
    rec_e, rec_m, rec_d, seg, t0, t1, h0, h1, mj0, mj1 = _work(cap)
    for i in range(A.size):
        if A[i] <= 0.0:  # small-signal limit: M_irr frozen, reversible slope with mean field
            rev = c[i] * lam[i] / (3.0 * a[i])
            out[i] = rev / (1.0 - kap[i] * rev) if kap[i] * rev < 1.0 else np.nan
            continue
        n = _steady(A[i], lam[i], a[i], k[i], c[i], kap[i], tol, nmin, rec_e, rec_m, rec_d)
        if n < 2:
            out[i] = complex(np.nan, np.nan)
        else:
            out[i] = _branch_df(
                A[i], rec_e, rec_m, rec_d, n, kap[i], seg, t0, t1, h0, h1, mj0, mj1, tv, wv
            )


@numba.njit(cache=True)
def _steady_rows(A, lam, a, k, c, kap, tol, nmin, cap):
    """Steady-branch nodes of the rows, packed one after another: ``(buffer, offsets)``.

    Row ``i`` is ``buffer[offsets[i]:offsets[i + 1]] = [n, rec_e, rec_m, rec_d]`` (``n``
    nodes, exact in float64; ``n = 0`` where no loop was found). Solving and evaluating are
    apart so that :class:`SteadyCache` can keep a row's nodes and evaluate them later at other
    inputs (:func:`_eval_rows`), bit for bit as if solved again. The monotone pieces are not
    kept: :func:`_pieces` costs ~1 us a row against ~50 us for the solve, and would more than
    triple the memory.
    """
    rec_e, rec_m, rec_d = np.empty(cap), np.empty(cap), np.empty(cap)
    off = np.empty(A.size + 1, dtype=np.int64)
    off[0] = 0
    buf = np.empty(512 * max(A.size, 1))
    for i in range(A.size):
        n = _steady(A[i], lam[i], a[i], k[i], c[i], kap[i], tol, nmin, rec_e, rec_m, rec_d)
        n = n if n > 1 else 0
        o = off[i]
        off[i + 1] = o + 1 + 3 * n
        # element loops, not slice assignments: those compile numba's shape-mismatch error
        # messages (its string formatting) on a fresh install
        if off[i + 1] > buf.size:
            grown = np.empty(max(2 * buf.size, off[i + 1]))
            for j in range(o):
                grown[j] = buf[j]
            buf = grown
        buf[o] = n
        for j in range(n):
            buf[o + 1 + j] = rec_e[j]
            buf[o + 1 + n + j] = rec_m[j]
            buf[o + 1 + 2 * n + j] = rec_d[j]
    return buf[: off[A.size]], off


@numba.njit(cache=True)
def _eval_rows(buf, off, A, kap, x_flat, x_index, out):
    """The branch of packed row ``i`` (:func:`_steady_rows`) at ``x_flat[x_index[i]:x_index[i + 1]]``.

    The pieces of each row (:func:`_pieces`), then :func:`_branch_at` at its inputs.
    """
    cap = 1
    for i in range(off.size - 1):
        cap = max(cap, int(buf[off[i]]))
    seg = np.empty(4 * cap, dtype=np.int64)
    t0, t1, h0, h1 = np.empty(4 * cap), np.empty(4 * cap), np.empty(4 * cap), np.empty(4 * cap)
    mj0, mj1 = np.empty(4 * cap), np.empty(4 * cap)
    for i in range(off.size - 1):
        o = off[i] + 1
        n = int(buf[o - 1])
        rec_e, rec_m, rec_d = buf[o : o + n], buf[o + n : o + 2 * n], buf[o + 2 * n : o + 3 * n]
        count = 0
        if n > 1:
            count = _pieces(rec_e, rec_m, rec_d, n, kap[i], A[i], seg, t0, t1, h0, h1, mj0, mj1)
        for j in range(x_index[i], x_index[i + 1]):
            if count < 1:
                out[j] = np.nan
            else:
                out[j] = _branch_at(
                    x_flat[j], rec_e, rec_m, rec_d, kap[i], seg, t0, t1, h0, h1, mj0, mj1, count
                )


@numba.njit(cache=True)
def _table(A, lam, a, k, c, kap, tol, nmin, cap, n_out):
    """The realised branch sampled at ``n_out`` points per piece, and the number of nodes."""
    rec_e, rec_m, rec_d, seg, t0, t1, h0, h1, mj0, mj1 = _work(cap)
    n = _steady(A, lam, a, k, c, kap, tol, nmin, rec_e, rec_m, rec_d)
    if n < 2:
        return np.empty(0), np.empty(0), n
    count = _pieces(rec_e, rec_m, rec_d, n, kap, A, seg, t0, t1, h0, h1, mj0, mj1)
    xs = np.empty(count * n_out + 1)
    ys = np.empty(count * n_out + 1)
    xs[0], ys[0] = -A, rec_m[0]
    m = 1
    for i in range(count):
        if seg[i] < 0:
            xs[m], ys[m] = h0[i], mj1[i]
            m += 1
            continue
        m0, m1, m2, m3, g0, g1, g2, g3 = _segment(rec_e, rec_m, rec_d, seg[i], kap)
        for q in range(1, n_out + 1):
            t = t0[i] + (t1[i] - t0[i]) * q / n_out
            xs[m], ys[m] = _poly(g0, g1, g2, g3, t), _poly(m0, m1, m2, m3, t)
            m += 1
    xs[m - 1] = A
    return xs[:m].copy(), ys[:m].copy(), n


def _capacity(n_min):
    return max(_CAP, 64 * int(n_min))


def _flat(*values):
    arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values))
    return arrays[0].shape, [np.ascontiguousarray(v.reshape(-1)) for v in arrays]


class SteadyCache:
    """Packed steady branches (:func:`_steady_rows`) of recently seen rows, bounded, per process.

    The exact ``voltage`` chain evaluates the branch of one ``(amplitude, theta)`` row several
    times in a row at new inputs (node placement at 32, then 64 nodes, then the search's
    first evaluation), and each steady-loop solve costs ~50 us against ~1 us per input. A
    row is keyed by the bytes of its kernel inputs ``(|A|, lambda_s, a, k, c, alpha, tol,
    n_min)``: equal bytes mean equal inputs, and the stored branch is what a new solve would
    write, so results are bit-identical with or without the cache, whatever was called
    before. At most ``max_rows`` rows and ``max_floats`` packed floats are kept, least
    recently used rows going first (:meth:`_keep`); the defaults hold one batched call of
    the chain (32 walkers x 119 points took 3808 rows, 1.4e6 floats) and bound the memory
    to 16 MiB of branches plus ~300 bytes a row of keys and bookkeeping (< 19 MiB);
    ``max_rows = 0`` turns the cache off. A lock guards the bookkeeping (threads); a forked
    child starts empty (:func:`os.register_at_fork`), a spawned one imports it empty.
    """

    def __init__(self, max_rows=8192, max_floats=1 << 21):
        self.max_rows, self.max_floats = int(max_rows), int(max_floats)
        self._reset()

    def _reset(self):
        self._lock = threading.Lock()
        self._rows = OrderedDict()
        self._floats = 0

    def clear(self):
        """Forget every row."""
        with self._lock:
            self._rows.clear()
            self._floats = 0

    def __len__(self):
        return len(self._rows)

    def branches(self, A, lam, a, k, c, kap, tol, n_min):
        """Packed branches of the rows (1-d float arrays of one length): ``(buffer, offsets)``."""
        m = A.size
        raw = np.empty((m, 8))
        raw[:, :6] = np.column_stack((A, lam, a, k, c, kap))
        raw[:, 6], raw[:, 7] = tol, n_min
        data = raw.tobytes()
        keys = [data[64 * i : 64 * (i + 1)] for i in range(m)]
        with self._lock:
            rows = [self._rows.get(key) for key in keys]
        todo = {}  # key -> first row needing a solve (rows repeated within the call solve once)
        for i, (key, row) in enumerate(zip(keys, rows)):
            if row is None and key not in todo:
                todo[key] = i
        if todo:
            sel = np.fromiter(todo.values(), dtype=np.int64, count=len(todo))
            buf, off = _steady_rows(
                *(v[sel] for v in (A, lam, a, k, c, kap)), tol, n_min, _capacity(n_min)
            )
            solved = {key: buf[off[j] : off[j + 1]].copy() for j, key in enumerate(todo)}
            rows = [solved[key] if row is None else row for key, row in zip(keys, rows)]
        self._keep(keys, rows)
        off = np.zeros(m + 1, dtype=np.int64)
        np.cumsum([row.size for row in rows], out=off[1:])
        return (np.concatenate(rows) if m else np.empty(0)), off

    def _keep(self, keys, rows):
        """Make a call's rows the most recent (in call order), then trim to the bounds.

        Rows of older calls go first, least recent first; a call larger than the bounds then
        loses its last rows, so that repeating it hits on its first ones (plain LRU would
        evict every row of a repeated large call before its reuse).
        """
        with self._lock:
            current = dict(zip(keys, rows))
            for key, row in current.items():
                if key in self._rows:
                    self._rows.move_to_end(key)
                else:
                    self._rows[key] = row
                    self._floats += row.size
            while len(self._rows) > self.max_rows or self._floats > self.max_floats:
                oldest = next(iter(self._rows))
                last = oldest in current  # only this call's rows are left
                self._floats -= self._rows.popitem(last=last)[1].size


#: The cache of :meth:`fitdf.models.jiles_atherton.JilesAtherton.ascending_branch`.
STEADY_CACHE = SteadyCache()
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=STEADY_CACHE._reset)
