"""The compiled step of the ``voltage`` chain's root search of the peak current.

:func:`secant_update` is one step of :func:`fitdf.chains.voltage._search` (which documents
the rules) for many points at once, each with its own bracket and secant pairs;
``numba.njit(cache=True)`` as the kernels of :mod:`fitdf.chains._periodic`.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["secant_update", "BRACKET_FLOOR", "CURVATURE_SHARE"]

#: Relative width at which a bracket whose ends' DFs differ by more than half the larger is
#: accepted all the same (the DF then jumps at the root itself).
BRACKET_FLOOR = 1e-9

#: Where the DF jumps inside the bracket, the largest quadratic term of the DF at a secant
#: root (its curvature through the bracket's other end), as a share of ``df_tol``, with which
#: the root is accepted without an evaluation there.
CURVATURE_SHARE = 0.25

# Slots of the search state: the last two evaluations (A1, A2) and the two newest on
# each side of the root (L: G > 0, H: G <= 0).
_A1, _A2, _L1, _L2, _H1, _H2 = 0, 1, 2, 3, 4, 5


@numba.njit(cache=True)
def _pair(X, G, D, p, i1, i2):
    """Secant root, slope and linear DF at the root of the slots ``i1`` (newer), ``i2``."""
    x1, x2 = X[p, i1], X[p, i2]
    if not (np.isfinite(x1) and np.isfinite(x2)) or x1 == x2:
        return np.nan, np.nan, complex(np.nan, np.nan)
    s = (G[p, i1] - G[p, i2]) / (x1 - x2)
    if not np.isfinite(s) or s == 0.0:
        return np.nan, np.nan, complex(np.nan, np.nan)
    r = x1 - G[p, i1] / s
    d = D[p, i1] + (D[p, i1] - D[p, i2]) / (x1 - x2) * (r - x1)
    return r, s, d


@numba.njit(cache=True)
def secant_update(act, xs, gs, ds, it, X, G, D, F, C, done, tol, max_step, df_tol, confirm):
    """One step of the root search of ``G(I_p)`` for the points ``act`` (see
    :func:`fitdf.chains.voltage._search`, which documents the rules).

    ``xs, gs, ds``: the new evaluations (``I``, ``G``, DF) of the points ``act``.
    ``X, G, D`` (``(m, 6)``): the slots. ``F`` (``(m, 9)``): ``top = V/R``, Illinois values
    ``g_lo, g_hi``, last side, bracket width, next trial, root, the previous stage's slope
    of ``G`` (NaN: none), the slope followed. ``C`` (``(m, 3)`` complex): DF at the root,
    DF slope, the previous stage's DF slope (NaN: none). ``done`` is set where converged.
    ``confirm``: whether the last two evaluations' slope must be confirmed.

    Long by design: one compiled pass over the points applies :func:`_search`'s rules in
    their order to each point's slots, which it updates in place; the rules read one another's
    results for the same point within the step.
    """
    for k in range(act.shape[0]):
        p = act[k]
        x, g, d = xs[k], gs[k], ds[k]
        top = F[p, 0]
        slope0 = F[p, 7]
        dslope0 = C[p, 2]
        # push the slots
        X[p, _A2], G[p, _A2], D[p, _A2] = X[p, _A1], G[p, _A1], D[p, _A1]
        X[p, _A1], G[p, _A1], D[p, _A1] = x, g, d
        side = _L1 if g > 0 else _H1
        X[p, side + 1], G[p, side + 1], D[p, side + 1] = X[p, side], G[p, side], D[p, side]
        X[p, side], G[p, side], D[p, side] = x, g, d
        # Illinois: the value of an end kept twice in a row is halved
        if g > 0:
            if F[p, 3] == 1.0:
                F[p, 2] *= 0.5
            F[p, 1] = g
            F[p, 3] = 1.0
        else:
            if F[p, 3] == -1.0:
                F[p, 1] *= 0.5
            F[p, 2] = g
            F[p, 3] = -1.0
        if not np.isfinite(g):
            done[p] = True
            F[p, 6] = np.nan
            C[p, 0] = complex(np.nan, np.nan)
            continue
        lo = X[p, _L1] if np.isfinite(X[p, _L1]) else 0.0
        hi = X[p, _H1] if np.isfinite(X[p, _H1]) else top
        if it == 0:
            s0 = slope0 if np.isfinite(slope0) else -2.0
            step = min(max(g / s0, -max_step * x), max_step * x)
            rA, sA = x - step, s0
            dA = d + (dslope0 * (rA - x) if np.isfinite(dslope0.real) else 0.0)
        else:
            rA, sA, dA = _pair(X, G, D, p, _A1, _A2)
        rL, sL, dL = _pair(X, G, D, p, _L1, _L2)
        rH, sH, dH = _pair(X, G, D, p, _H1, _H2)
        jump = False
        confirmed = False
        # A slope confirms the last two evaluations' only if it comes from another pair: a
        # side's newest two are the same two when both evaluations fell on that side (G
        # approached from one side), and would confirm any curvature; the pair followed
        # in the step before (``F[p, 8]``, still unchanged here) then tells instead.
        same_L = X[p, _L1] == X[p, _A1] and X[p, _L2] == X[p, _A2]
        same_H = X[p, _H1] == X[p, _A1] and X[p, _H2] == X[p, _A2]
        previous = F[p, 8] if it > 1 else np.nan
        for sr in (np.nan if same_L else sL, np.nan if same_H else sH, slope0, previous):
            if np.isfinite(sr) and np.isfinite(sA):
                if sr / sA > 0 and abs(np.log(sr / sA)) <= np.log(2.0):
                    confirmed = True
                else:
                    jump = True
        inA = np.isfinite(rA) and lo < rA < hi
        inL = np.isfinite(rL) and lo < rL < hi
        inH = np.isfinite(rH) and lo < rH < hi
        use = -1
        if inA and (it == 0 or not jump):
            use = _A1
        elif inL and (not inH or abs(G[p, _L1]) <= abs(G[p, _H1])):
            use = _L1
        elif inH:
            use = _H1
        r, sr_, dr = np.nan, np.nan, complex(np.nan, np.nan)
        if use == _A1:
            r, sr_, dr = rA, sA, dA
        elif use == _L1:
            r, sr_, dr = rL, sL, dL
        elif use == _H1:
            r, sr_, dr = rH, sH, dH
        # Where the DFs at the bracket's ends differ by more than half the larger, the DF
        # jumps inside it -- at a dead zone's edge the loop closes and the DF falls to 0 --
        # and no interpolation between them is the root's. G jumps there too, but crosses 0
        # continuously just beyond the edge, where the DF has its value: the search narrows
        # on to that crossing instead of accepting the bracket.
        both = np.isfinite(X[p, _L1]) and np.isfinite(X[p, _H1])
        df_jump = both and abs(D[p, _H1] - D[p, _L1]) > 0.5 * max(abs(D[p, _H1]), abs(D[p, _L1]))
        conv = False
        if use >= 0:
            x1, d1, x2 = X[p, use], D[p, use], X[p, use + 1]
            close = abs(r - x1) <= tol * x1 and abs(dr - d1) <= df_tol
            # and, where the DF jumps inside the bracket, the DF's curvature through the
            # bracket's other end leaves a small quadratic term at the root: just beyond a
            # dead zone's edge the DF bends steeply, and the secant of two points farther
            # out can be nearly flat
            if df_jump and np.isfinite(x2) and x1 != x2:
                q = X[p, _H1] if G[p, use] > 0 else X[p, _L1]
                dq = D[p, _H1] if G[p, use] > 0 else D[p, _L1]
                if q != x1 and q != x2:
                    curv = ((d1 - D[p, use + 1]) / (x1 - x2) - (d1 - dq) / (x1 - q)) / (x2 - q)
                    if abs(curv) * abs(r - x1) * abs(r - x2) > CURVATURE_SHARE * df_tol:
                        close = False
            if it == 0:
                # one evaluation: only an exact hit (slopes from a coarser stage can be off
                # by 10x where the DF is sensitive, e.g. at the edge of a dead zone)
                conv = False
            else:
                unconfirmed_pair = use == _A1 or (use == _L1 and same_L) or (use == _H1 and same_H)
                conv = (
                    close
                    and abs(x1 - x2) <= 0.05 * x1
                    and (not unconfirmed_pair or confirmed or not confirm)
                )
            F[p, 8] = sr_
            if np.isfinite(x2) and x1 != x2:
                C[p, 1] = (D[p, use] - D[p, use + 1]) / (x1 - x2)
        narrow = hi - lo <= (BRACKET_FLOOR if df_jump else 0.125 * tol) * hi
        # (a bracket of tol with DFs close at its ends will do where a secant root lies inside
        # it; where none does, G jumps inside it -- the edge where the peak is reached by a
        # jump into saturation, G > 0 up to it -- and the bracket is narrowed to tol / 8, so
        # the peak current too is close to the edge; neither where the DF jumps inside it)
        close_ends = both and abs(D[p, _H1] - D[p, _L1]) <= 2.0 * df_tol and not df_jump
        if close_ends and use >= 0 and hi - lo <= tol * hi:
            narrow = True
        mid = 0.5 * (lo + hi)
        if hi > 4.0 * lo:
            mid = np.sqrt(lo * hi) if lo > 0 else 0.25 * min(hi, x)
        if g == 0.0:
            done[p] = True
            F[p, 6] = x
            C[p, 0] = d
            continue
        if conv:
            done[p] = True
            F[p, 6] = r
            C[p, 0] = dr
            continue
        if narrow:
            rn = min(max(r, lo), hi) if use >= 0 else mid
            dn = d
            if both:
                dn = D[p, _L1] + (rn - lo) / (hi - lo) * (D[p, _H1] - D[p, _L1])
            done[p] = True
            F[p, 6] = rn
            C[p, 0] = dn
            continue
        # next trial: the root followed, unless the bracket stalls (bisect every third step
        # if it has not halved) or a side's extrapolation leaves the bracket (bisect);
        # else regula falsi (Illinois) or (log-)bisection
        stalled = False
        if it % 3 == 2:
            stalled = hi - lo > 0.5 * F[p, 4]
            F[p, 4] = hi - lo
        glo, ghi = F[p, 1], F[p, 2]
        if use >= 0 and not stalled:
            nxt = r
            if not (np.isfinite(X[p, _L1]) and np.isfinite(X[p, _H1])):
                # no bracket yet: at most max_step (relative) per step
                nxt = min(max(nxt, x * (1.0 - max_step)), x * (1.0 + max_step))
        elif stalled or np.isfinite(rL) or np.isfinite(rH):
            nxt = mid
        else:
            nxt = mid
            if np.isfinite(X[p, _L1]) and np.isfinite(X[p, _H1]) and hi <= 4.0 * lo and ghi != glo:
                fal = (lo * ghi - hi * glo) / (ghi - glo)
                if lo < fal < hi:
                    nxt = fal
        F[p, 5] = nxt
