"""The realised Jiles-Atherton branch: steady loops, monotone pieces, describing function.

Per row ``(A, theta)`` the compiled kernels solve the steady loop on the forced response of
its parameter set (:func:`~fitdf.models._ja_closed._steady_closed`), lay out the nodes
``(H_e, M, dM/dH_e)`` of its ascending branch, cut the parametric cubics into pieces
monotone in ``H`` (folds become vertical jumps), and on them integrate ``N(A)``, invert
``H(H_e)`` to evaluate the branch at given inputs, or sample it for tables; one kernel call
takes every row of a call, with no Python per row. :class:`ResponseCache` keeps the
tabulated forced responses of recent parameter sets (one per ``(lambda_s, a, k)``, whatever
the amplitudes), :class:`RowMemo` the nodes of the previous call's rows: the ``voltage``
chain evaluates one set's branches at many amplitudes, and some rows again at new inputs,
in a row of calls. Both give the bits a new solve would.
"""

from __future__ import annotations

import functools
import math
import os
import threading
from collections import OrderedDict

import numba
import numpy as np

from fitdf.models._ja_closed import _grid, _nodes_closed, _q_table, _steady_closed
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
def _eval_row(x, lo, hi, out, rec_e, rec_m, rec_d, kap, seg, t0, t1, h0, h1, mj0, mj1, count):
    """``out[j] = M`` on the realised branch at ``H = x[j]`` for ``lo <= j < hi``.

    Inputs are clipped to the branch's range (the tips are the end nodes, whose ``H`` is
    ``+-A`` to rounding). The piece of an input is the first with ``h1 >= x``: found forward
    from the previous input's when that starts below it (inputs in ascending order take a
    step or two), else by bisection. Newton on the piece's monotone cubic ``H(t)``, kept
    inside the piece, stops once a step is below ``1e-10`` (the next would be below
    ``1e-19``). One loop with no calls: per input it costs a fifth of a call's overhead.
    """
    last = count - 1
    jt = seg[last]
    top = mj1[last]
    if jt >= 0:  # M at the end of the last piece
        st = rec_e[jt + 1] - rec_e[jt]
        f0, d0, f1, d1 = rec_m[jt], rec_d[jt], rec_m[jt + 1], rec_d[jt + 1]
        u = t1[last]
        top = f0 + u * (
            st * d0
            + u * (3.0 * (f1 - f0) - st * (2.0 * d0 + d1) + u * (2.0 * (f0 - f1) + st * (d0 + d1)))
        )
    i = 0
    for q in range(lo, hi):
        xq = x[q]
        if xq >= h1[last]:
            out[q] = top
            continue
        if xq <= h0[0]:
            out[q] = rec_m[0]
            continue
        if not (i < count and h0[i] < xq):
            i = 0
            b = last
            while i < b:
                mid = (i + b) // 2
                if h1[mid] < xq:
                    i = mid + 1
                else:
                    b = mid
        while h1[i] < xq:
            i += 1
        j = seg[i]
        if j < 0:
            out[q] = mj1[i]
            continue
        st = rec_e[j + 1] - rec_e[j]
        f0, d0, f1, d1 = rec_m[j], rec_d[j], rec_m[j + 1], rec_d[j + 1]
        m1 = st * d0
        m2 = 3.0 * (f1 - f0) - st * (2.0 * d0 + d1)
        m3 = 2.0 * (f0 - f1) + st * (d0 + d1)
        g0, g1, g2, g3 = rec_e[j] - kap * f0, st - kap * m1, -kap * m2, -kap * m3
        ta, tb = t0[i], t1[i]
        t = ta + (tb - ta) * (xq - h0[i]) / (h1[i] - h0[i]) if h1[i] > h0[i] else tb
        for _it in range(100):  # Newton on the monotone cubic, kept inside [ta, tb]
            f = g0 + t * (g1 + t * (g2 + t * g3)) - xq
            if f > 0.0:
                tb = t
            elif f < 0.0:
                ta = t
            else:
                break
            df = g1 + t * (2.0 * g2 + 3.0 * t * g3)
            tn = t - f / df if df > 0.0 else 0.5 * (ta + tb)
            if not (ta <= tn <= tb):
                tn = 0.5 * (ta + tb)
            done = abs(tn - t) <= 1e-10 or tb - ta <= 1e-15
            t = tn
            if done:
                break
        out[q] = f0 + t * (m1 + t * (m2 + t * m3))


@numba.njit(cache=True)
def _work(cap):
    """Work arrays of a row: its nodes ``(rec_e, rec_m, rec_d)`` and pieces (:func:`_pieces`)."""
    return (
        (np.empty(cap), np.empty(cap), np.empty(cap)),
        (
            np.empty(4 * cap, dtype=np.int64),
            np.empty(4 * cap),
            np.empty(4 * cap),
            np.empty(4 * cap),
            np.empty(4 * cap),
            np.empty(4 * cap),
            np.empty(4 * cap),
        ),
    )


@numba.njit(cache=True)
def _closed_form(lam, a, kap):
    """Whether the closed-form steady loop applies: ``zeta = alpha lambda_s / 3a <= 1``."""
    return kap * lam <= 3.0 * a * (1.0 + 1e-12)


#: Nodes a row's work arrays hold at first; they grow (up to ``max_cap``) for a row that needs
#: more (at the default tolerance a branch has at most ~300 nodes).
_CAP0 = 512


@numba.njit(cache=True)
def _loop(A, th, tol, nmin, max_cap, G, qt, rec):
    """Nodes of the steady rising branch of one row into ``rec``; their number (< 2: none;
    -2: more than ``rec`` holds, while it holds fewer than ``max_cap``: grow it, again).

    For ``zeta <= 1`` from the forced response ``qt`` (:func:`_steady_closed`,
    :func:`_nodes_closed`); beyond (a folding ``H(H_e)``, outside the bounds) by integrating
    half cycles to the fixed point (:func:`~fitdf.models._ja_integrate._steady`).
    """
    lam, a, k, c, kap = th
    rec_e, rec_m, rec_d = rec
    if not (A > 0.0 and A < np.inf):
        return -1
    if not _closed_form(lam, a, kap):
        n = _steady(A, lam, a, k, c, kap, tol, nmin, rec_e, rec_m, rec_d)
        return -2 if n < 2 and rec_e.size < max_cap else n
    sol, _ = _steady_closed(A, th, G, qt)
    if not (sol[0] == sol[0] and sol[5] == sol[5]):
        return -1
    n = _nodes_closed(A, th, tol, nmin, G, qt, sol, rec)
    return -2 if n < 0 and rec_e.size < max_cap else n


@numba.njit(cache=True)
def _grown(n, cap, max_cap):
    """The capacity after a row asked for more (:func:`_loop` returned -2)."""
    return min(8 * cap, max_cap) if n == -2 else cap


@numba.njit(cache=True)
def _tip(A, th, G, qt):
    """``M`` at the tip of the steady loop (``zeta <= 1``, ``A > 0``) without its nodes."""
    (m, _, man0, _, _, qs, _), _ = _steady_closed(A, th, G, qt)
    if not (m == m and qs == qs):
        return np.nan
    return -((1.0 - th[3]) * m + th[3] * man0)


@numba.njit(cache=True)
def _small_signal(lam, a, c, kap):
    """``N(0) = c L / (1 - zeta c)``, ``L = lambda_s / 3a``: ``M_irr`` frozen, reversible slope."""
    rev = c * lam / (3.0 * a)
    return rev / (1.0 - kap * rev) if kap * rev < 1.0 else np.nan


#: Below this fraction of ``min(a, k)`` a loop is its small-signal line to rounding (the
#: irreversible part's share of ``N`` is ``O(A/k)``, the curvature's ``O((A/a)^2)``), and is
#: taken as that line (where ``A^2`` would underflow).
_SMALL = 1e-17


@numba.njit(cache=True)
def _is_small(A, lam, a, k, kap):
    return A < _SMALL * min(a, k) and _closed_form(lam, a, kap)


@numba.njit(cache=True)
def _df_rows(P, tol, nmin, max_cap, G, tabs, row_tab, tv, wv, out):
    """``N`` of the rows ``P = (A, lambda_s, a, k, c, alpha)`` (:func:`_branch_df` on the
    nodes of :func:`_loop`; row ``i`` on the forced response ``tabs[row_tab[i]]``)."""
    A, lam, a, k, c, kap = P
    cap = _CAP0
    rec, pcs = _work(cap)
    for i in range(A.size):
        if A[i] <= 0.0 or _is_small(A[i], lam[i], a[i], k[i], kap[i]):
            out[i] = _small_signal(lam[i], a[i], c[i], kap[i])  # M_irr frozen, reversible slope
            continue
        th = (lam[i], a[i], k[i], c[i], kap[i])
        n = -2
        while n == -2:
            n = _loop(A[i], th, tol, nmin, max_cap, G, tabs[row_tab[i]], rec)
            if n == -2:
                cap = _grown(n, cap, max_cap)
                rec, pcs = _work(cap)
        if n < 2:
            out[i] = complex(np.nan, np.nan)
        else:
            out[i] = _branch_df(A[i], *rec, n, kap[i], *pcs, tv, wv)


#: How far past the last row it matched the memo looks for a row of the previous call.
_MEMO_REACH = 64


@numba.njit(cache=True)
def _branch_rows(P, tol, nmin, max_cap, G, tabs, row_tab, x_flat, x_index, out, memo, keep):
    """The branch of row ``i`` of ``P = (A, lambda_s, a, k, c, alpha)`` at
    ``x_flat[x_index[i]:x_index[i + 1]]`` into ``out``.

    Per row: the steady loop and its nodes (:func:`_loop`, on the forced response
    ``tabs[row_tab[i]]``), its pieces (:func:`_pieces`), then :func:`_eval_row` at its
    inputs. A row asked only at its tips ``x = +-A`` (the ``voltage`` chain's initial guess)
    needs no nodes; a row of amplitude 0 (or below :data:`_SMALL`) is the small-signal line
    ``N(0) x``; NaN where no loop was found.

    ``memo = (keys, buffer, offsets)`` holds the nodes of another call's rows (keys: the bits
    of ``(A, lambda_s, a, k, c, alpha)``; row ``q``'s nodes ``[rec_e, rec_m, rec_d]`` at
    ``buffer[offsets[q]:offsets[q + 1]]``): a row found there, at or a little past the row
    after the last one found (the rows of consecutive calls come in the same order), takes
    those nodes, the bits a solve would give. With ``keep``, returns this call's rows packed
    the same way (rows without nodes keyed -1, which no row matches), else empty arrays.

    One compiled loop over the rows: the memo's cursor and the packed output are carried
    from row to row, which a split into numba functions would pass back and forth.
    """
    A, lam, a, k, c, kap = P
    memo_key, memo_buf, memo_off = memo
    cap = _CAP0
    rec, pcs = _work(cap)
    m = A.size
    bits = np.empty((m, 6), dtype=np.int64)
    for v in range(6):
        col = P[v].view(np.int64)
        for i in range(m):
            bits[i, v] = col[i]
    key = np.full((m if keep else 0, 6), -1, dtype=np.int64)
    off = np.zeros(m + 1 if keep else 1, dtype=np.int64)
    buf = np.empty(3 * 64 * m if keep else 0)
    p = 0
    for i in range(m):
        if keep:
            off[i + 1] = off[i]
        lo, hi = x_index[i], x_index[i + 1]
        if lo == hi:
            continue
        Ai = A[i]
        if Ai == 0.0 or _is_small(Ai, lam[i], a[i], k[i], kap[i]):
            slope = _small_signal(lam[i], a[i], c[i], kap[i])
            for j in range(lo, hi):
                out[j] = slope * x_flat[j]
            continue
        th = (lam[i], a[i], k[i], c[i], kap[i])
        qt = tabs[row_tab[i]]
        tips = Ai > 0.0 and Ai < np.inf and _closed_form(lam[i], a[i], kap[i])
        for j in range(lo, hi):
            if x_flat[j] != Ai and x_flat[j] != -Ai:
                tips = False
                break
        if tips:
            top = _tip(Ai, th, G, qt)
            for j in range(lo, hi):
                out[j] = top if x_flat[j] > 0.0 else -top
            continue
        hit = -1
        for q in range(p, min(p + _MEMO_REACH, memo_key.shape[0])):
            same = True
            for v in range(6):
                if memo_key[q, v] != bits[i, v]:
                    same = False
                    break
            if same:
                hit = q
                break
        if hit >= 0:
            p = hit + 1
            o = memo_off[hit]
            n = (memo_off[hit + 1] - o) // 3
            if n > cap:
                cap = max(n, 8 * cap)
                rec, pcs = _work(cap)
            for j in range(n):
                rec[0][j], rec[1][j] = memo_buf[o + j], memo_buf[o + n + j]
                rec[2][j] = memo_buf[o + 2 * n + j]
        else:
            n = -2
            while n == -2:
                n = _loop(Ai, th, tol, nmin, max_cap, G, qt, rec)
                if n == -2:
                    cap = _grown(n, cap, max_cap)
                    rec, pcs = _work(cap)
        if keep:  # (element loops: slice assignments compile numba's error formatting)
            for v in range(6):
                key[i, v] = bits[i, v]
            nk = max(n, 0)
            o = off[i]
            if o + 3 * nk > buf.size:
                grown = np.empty(max(2 * buf.size, o + 3 * nk))
                for j in range(o):
                    grown[j] = buf[j]
                buf = grown
            for j in range(nk):
                buf[o + j], buf[o + nk + j], buf[o + 2 * nk + j] = rec[0][j], rec[1][j], rec[2][j]
            off[i + 1] = o + 3 * nk
        count = _pieces(*rec, n, kap[i], Ai, *pcs) if n > 1 else 0
        if count < 1:
            for j in range(lo, hi):
                out[j] = np.nan
        else:
            _eval_row(x_flat, lo, hi, out, *rec, kap[i], *pcs, count)
    return key, buf[: off[off.size - 1]], off


@numba.njit(cache=True)
def _table(A, th, tol, nmin, max_cap, G, qt, n_out):
    """The realised branch sampled at ``n_out`` points per piece, and the number of nodes."""
    kap = th[4]
    rec, pcs = _work(max_cap)
    n = _loop(A, th, tol, nmin, max_cap, G, qt, rec)
    if n < 2:
        return np.empty(0), np.empty(0), n
    rec_e, rec_m, rec_d = rec
    seg, t0, t1, h0, h1, mj0, mj1 = pcs
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


@numba.njit(cache=True)
def _q_tables(lam, a, k, G):
    """Forced responses (:func:`~fitdf.models._ja_closed._q_table`), one row per set."""
    out = np.empty((lam.size, G[0].size))
    for i in range(lam.size):
        _q_table(lam[i], a[i], k[i], G, out[i])
    return out


@numba.njit(cache=True)
def _runs(lam, a, k):
    """Starts of the runs of equal ``(lambda_s, a, k)`` (bitwise, NaN included) and each row's run."""
    m = lam.size
    run = np.empty(m, dtype=np.int64)
    starts = np.empty(m, dtype=np.int64)
    lb, ab, kb = lam.view(np.int64), a.view(np.int64), k.view(np.int64)
    r = -1
    for i in range(m):
        if i == 0 or lb[i] != lb[i - 1] or ab[i] != ab[i - 1] or kb[i] != kb[i - 1]:
            r += 1
            starts[r] = i
        run[i] = r
    return starts[: r + 1], run


#: Subdivisions of the universal steps where the forced response is tabulated: within
#: ``|H_e| <= _Z_IN a`` (where every loop much narrower than a step lies) and beyond.
_R_IN, _R_OUT, _Z_IN = 16, 2, 2.0


@functools.lru_cache(maxsize=16)
def grid(tol):
    """The universal nodes of tolerance ``tol`` (:func:`~fitdf.models._ja_closed._grid`)."""
    out = _grid(float(tol), _R_IN, _R_OUT, _Z_IN)
    for v in out:
        v.flags.writeable = False
    return out


def _capacity(n_min):
    return max(_CAP, 64 * int(n_min))


def _own(v):
    """``v`` flat, contiguous and writeable (one compiled signature for every caller)."""
    v = np.ravel(v)
    return v if v.flags.writeable else v.copy()


def _flat(*values):
    """The values broadcast together: ``(shape, [flat contiguous float arrays])``."""
    values = [np.asarray(v, dtype=float) for v in values]
    shape = np.broadcast_shapes(*(v.shape for v in values))
    return shape, [_own(v if v.shape == shape else np.broadcast_to(v, shape)) for v in values]


class ResponseCache:
    """Tabulated forced responses of recently seen parameter sets, bounded, per process.

    The steady loop of every amplitude comes from one table per ``(lambda_s, a, k)`` and
    tolerance (:func:`~fitdf.models._ja_closed._q_table`, ~900 nodes at the default
    ``tol``, ~40 us); the ``voltage`` chain asks for one set's branches at new amplitudes
    ~15 times per prediction. A table is keyed by the bytes of ``(lambda_s, a, k, tol)``:
    equal bytes mean equal inputs, and a kept table is what a new one would be, so results
    are bit-identical with or without the cache, whatever was called before. At most
    ``max_floats`` floats are kept (16 MiB by default, ~2300 sets), least recently used
    sets going first; ``max_floats = 0`` turns the cache off. A lock guards the bookkeeping
    (threads); a forked child starts empty (:func:`os.register_at_fork`), a spawned one
    imports it empty.
    """

    def __init__(self, max_floats=1 << 21):
        self.max_floats = int(max_floats)
        self._reset()

    def _reset(self):
        self._lock = threading.Lock()
        self._sets = OrderedDict()
        self._floats = 0

    def clear(self):
        """Forget every table."""
        with self._lock:
            self._sets.clear()
            self._floats = 0

    def __len__(self):
        return len(self._sets)

    def tables(self, lam, a, k, tol):
        """``(tables, row_table)``: one table per distinct ``(lambda_s, a, k)`` of the rows
        (2-d, a row each) and the table of each row."""
        m = lam.size
        if m == 0:
            return np.empty((0, grid(tol)[0].size)), np.zeros(0, dtype=np.int64)
        starts, run = _runs(lam, a, k)  # a call's rows come set by set
        key = np.empty((starts.size, 4))
        key[:, 0], key[:, 1], key[:, 2], key[:, 3] = lam[starts], a[starts], k[starts], tol
        raw = key.tobytes()
        keys = [raw[32 * j : 32 * (j + 1)] for j in range(starts.size)]
        slot = dict.fromkeys(keys)
        with self._lock:
            for kb in slot:
                slot[kb] = self._sets.get(kb)
        todo = [j for j, kb in enumerate(keys) if slot[kb] is None]
        if todo:
            sel = starts[todo]
            built = _q_tables(lam[sel], a[sel], k[sel], grid(tol))
            for j, t in zip(todo, built):
                if slot[keys[j]] is None:
                    slot[keys[j]] = t.copy()
        self._keep(slot)
        if len(slot) == 1:
            return slot[keys[0]][None], np.zeros(m, dtype=np.int64)
        where = {kb: j for j, kb in enumerate(slot)}
        row = np.array([where[kb] for kb in keys], dtype=np.int64)[run]
        return np.stack(list(slot.values())), row

    def _keep(self, current):
        """Make a call's tables the most recent, then trim to the bound (older calls' first)."""
        with self._lock:
            for kb, table in current.items():
                if kb in self._sets:
                    self._sets.move_to_end(kb)
                else:
                    self._sets[kb] = table
                    self._floats += table.size
            while self._sets and self._floats > self.max_floats:
                oldest = next(iter(self._sets))
                last = oldest in current  # only this call's tables are left
                self._floats -= self._sets.popitem(last=last)[1].size


#: The cache of the forced responses behind every steady loop of
#: :mod:`fitdf.models.jiles_atherton`.
RESPONSE_CACHE = ResponseCache()
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=RESPONSE_CACHE._reset)


def response_tables(lam, a, k, tol):
    """:meth:`ResponseCache.tables` of :data:`RESPONSE_CACHE`."""
    return RESPONSE_CACHE.tables(lam, a, k, tol)


class RowMemo(threading.local):
    """The nodes of the last :func:`_branch_rows` call per tabulation, per thread.

    The ``voltage`` chain asks for the branches of the same rows in consecutive calls at new
    inputs (node placement at 32, then 64 nodes, then the search's first evaluation): such a
    row takes the kept nodes instead of a solve (the same bits, so results do not depend on
    it). Only calls of at most ``max_rows`` rows are kept (~1.5 KiB a row at the default
    tolerance, at most ~7 KiB: a few MiB per thread); ``max_rows = 0`` turns it off.
    """

    max_rows = 2048

    def __init__(self):
        self.calls = {}

    def get(self, tol, n_min):
        """The kept ``(keys, buffer, offsets)`` of the tabulation, or empty ones."""
        return self.calls.get((tol, n_min), _NO_MEMO)

    def keep(self, tol, n_min, memo):
        self.calls[(tol, n_min)] = memo

    def clear(self):
        self.calls = {}


_NO_MEMO = (np.empty((0, 6), dtype=np.int64), np.empty(0), np.zeros(1, dtype=np.int64))
#: The memo of :meth:`fitdf.models.jiles_atherton.JilesAtherton.ascending_branch`.
ROW_MEMO = RowMemo()
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=ROW_MEMO.clear)
