"""Jiles-Atherton kernels: the steady loop in closed form from the forced response.

For ``zeta <= 1``, the forced response ``Q`` on universal nodes (:func:`_grid`,
:func:`_q_table`), the steady loop from it in closed form (:func:`_steady_closed`) and its
branch nodes (:func:`_nodes_closed`); the kernels they share with the step-by-step
integration are in :mod:`fitdf.models._ja_integrate`. The formulation is in
:mod:`fitdf.models.jiles_atherton` and, in full, in the documentation's method pages.

numba caches a compiled caller (``cache=True``) by the caller's own source file: after
editing this module, delete ``fitdf/models/__pycache__/*.nb[ic]``, or the callers in
:mod:`fitdf.models._ja_branch` keep the old kernels.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fitdf.models._ja_integrate import _cubic, _envelope, _langevin2, _relax

#: The universal nodes reach ``|H_e| = _Z_FAR a``; beyond them ``Q`` is its asymptotic series.
_Z_FAR = 1e8


@numba.njit(cache=True)
def _grid(tol, r_in, r_out, z_in):
    """Universal nodes ``G = (zg, Lg, L1g, ahead)``: ``z = H_e / a``, ``L(z)``, ``L'(z)``.

    Steps from ``z = 0`` outwards (symmetric, to ``+-_Z_FAR``) keep the cubic-Hermite error
    of ``L`` below ``tol`` (the rule of :func:`_step_size` without the transient): a branch
    of tolerance ``tol`` takes its nodes there. Each step is split into ``r_in`` equal ones
    within ``|z| <= z_in`` and ``r_out`` beyond, and the forced response is tabulated at all
    of them (``r^4`` times more accurately; a loop much narrower than a step lies within
    ``z_in``). ``ahead[i]`` is the first branch node after node ``i``. The same for every
    parameter set, so computed once per ``tol``.
    """
    q = 384.0 * tol
    half = np.empty(64)
    half[0] = 0.0
    n = 1
    z = 0.0
    while z < _Z_FAR:
        env = _envelope(z)
        s = math.sqrt(math.sqrt(q / env))
        env = max(env, _envelope(z + s))
        z += min(s, math.sqrt(math.sqrt(q / env)))
        if n >= half.size:
            grown = np.empty(2 * half.size)
            for i in range(n):
                grown[i] = half[i]
            half = grown
        half[n] = z
        n += 1
    m = 0
    for i in range(n - 1):
        m += r_in if half[i + 1] <= z_in else r_out
    zg = np.empty(2 * m + 1)
    node = np.zeros(2 * m + 1, dtype=np.bool_)
    zg[m] = 0.0
    node[m] = True
    o = 0
    for i in range(n - 1):
        r = r_in if half[i + 1] <= z_in else r_out
        for p in range(1, r + 1):
            v = half[i + 1] if p == r else half[i] + (half[i + 1] - half[i]) * p / r
            zg[m + o + p] = v
            zg[m - o - p] = -v
        o += r
        node[m + o] = node[m - o] = True
    ahead = np.empty(zg.size, dtype=np.int64)
    nxt = zg.size
    for i in range(zg.size - 1, -1, -1):
        ahead[i] = nxt
        if node[i]:
            nxt = i
    Lg, L1g = np.empty(zg.size), np.empty(zg.size)
    for i in range(zg.size):
        Lg[i], L1g[i] = _langevin2(zg[i])
    return zg, Lg, L1g, ahead


@numba.njit(cache=True)
def _q_far(z, lam, L, kappa):
    """``Q`` beyond the nodes: ``lambda_s [L(z) - sum_n n! kappa^n / z^(n+1)]``, ``kappa = k/a``.

    The asymptotic series ``Q = sum (-k)^n d^n M_an/dH_e^n`` on the ``-1/z`` tail of ``L``,
    its terms kept while they shrink (at ``|z| >= 1e8``, ``kappa <= 1e6`` the fourth is below
    1e-20).
    """
    s = 0.0
    term = kappa / (z * z)
    for n in range(1, 12):
        s += term
        nxt = term * (n + 1) * kappa / z
        if abs(nxt) >= abs(term) or abs(nxt) < 1e-18 * abs(s):
            break
        term = nxt
    return lam * (L - s)


@numba.njit(cache=True)
def _cell_cubic(j, lam, a, G):
    """``M_an`` on cell ``j`` as the cubic in ``t`` the table integrates, and the cell's step."""
    zg, Lg, L1g, _ = G
    step = a * (zg[j + 1] - zg[j])
    c0, c1, c2, c3 = _cubic(
        lam * Lg[j], lam * L1g[j] / a, lam * Lg[j + 1], lam * L1g[j + 1] / a, step
    )
    return c0, c1, c2, c3, step


@numba.njit(cache=True)
def _q_table(lam, a, k, G, qt):
    """The forced response ``Q`` at the nodes ``a zg`` into ``qt``.

    ``dQ/dH_e = (M_an - Q) / k`` from the asymptotic value at the first node, cell by cell
    as in :func:`_half_cycle` (``M_an`` by its cubic Hermite interpolant, the relaxation
    integrated exactly for it): the error stays below the interpolation error.
    """
    zg, Lg, _, _ = G
    qt[0] = _q_far(zg[0], lam, Lg[0], k / a)
    for i in range(zg.size - 1):
        c0, c1, c2, c3, step = _cell_cubic(i, lam, a, G)
        qt[i + 1] = _relax(qt[i], c0, c1, c2, c3, 0.0, 1.0, step, k)


@numba.njit(cache=True)
def _cell(zg, z, j):
    """``j`` with ``zg[j] <= z < zg[j + 1]`` (-1 below the nodes, ``zg.size - 1`` above):
    the given ``j`` or a neighbour when that is it, else by bisection."""
    top = zg.size - 1
    if not z >= zg[0]:
        return -1
    if z >= zg[top]:
        return top
    if 0 <= j < top:
        if zg[j] <= z:
            if z < zg[j + 1]:
                return j
            if j + 2 <= top and z < zg[j + 2]:
                return j + 1
        elif j >= 1 and zg[j - 1] <= z:
            return j - 1
    lo, hi = 0, top
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if zg[mid] <= z:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True)
def _q_at(h, j, lam, a, k, G, qt):
    """``Q(h)`` in cell ``j`` (:func:`_cell`): the relaxation from the cell's first node,
    integrated exactly for the cell's cubic of ``M_an`` as the table was, so as accurate as
    the table whatever ``k`` (a cubic through ``Q`` would miss its memory of the rise at the
    origin, ``~e^(-H_e/k)``, on cells wider than ``k``)."""
    zg = G[0]
    z = h / a
    if j < 0 or j >= zg.size - 1:
        L, _ = _langevin2(z)
        return _q_far(z, lam, L, k / a)
    c0, c1, c2, c3, step = _cell_cubic(j, lam, a, G)
    return _relax(qt[j], c0, c1, c2, c3, 0.0, (z - zg[j]) / (zg[j + 1] - zg[j]), step, k)


@numba.njit(cache=True)
def _q_diff(h, j, hb, jb, qb, lam, a, k, G, qt):
    """``Q(h) - Q(hb)`` (cells ``j``, ``jb``; ``qb = Q(hb)``); in the same or neighbouring
    cells as the relaxation of ``Q - Q(hb)`` from ``hb`` (lags are added, not values: a
    loop much narrower than a cell keeps its relative precision)."""
    zg = G[0]
    top = zg.size - 1
    if j == jb and 0 <= j < top:
        c0, c1, c2, c3, step = _cell_cubic(j, lam, a, G)
        w = zg[j + 1] - zg[j]
        return _relax(0.0, c0 - qb, c1, c2, c3, (hb / a - zg[j]) / w, (h / a - zg[j]) / w, step, k)
    if j == jb + 1 and 0 <= jb and j < top:  # through the node j between them
        c0, c1, c2, c3, step = _cell_cubic(jb, lam, a, G)
        tb = (hb / a - zg[jb]) / (zg[j] - zg[jb])
        low = _relax(0.0, c0 - qb, c1, c2, c3, tb, 1.0, step, k)  # Q(node j) - Q(hb)
        c0, c1, c2, c3, step = _cell_cubic(j, lam, a, G)
        t = (h / a - zg[j]) / (zg[j + 1] - zg[j])
        return low + _relax(0.0, c0 - qt[j], c1, c2, c3, 0.0, t, step, k)
    return _q_at(h, j, lam, a, k, G, qt) - qb


#: A loop whose ``H_e`` span is below this fraction of ``a`` takes ``M_irr`` from one cubic
#: of ``M_an`` over its relaxing part (:func:`_thin_lag`) instead of the forced response,
#: whose rounding errors (of the size of the lag ``~k dM_an/dH_e``) would be comparable with
#: so thin a loop's increments; there the cubic's own error is below 1e-9 of the loop.
_THIN = 0.01


@numba.njit(cache=True)
def _thin_lag(h, hs, m, mans, dmans, lam, a, k):
    """``M_irr(h) - mi0`` from ``M_irr(hs) = mi0``, ``M_an`` by its cubic over ``[hs, h]``
    (from ``M_an``, ``dM_an/dH_e`` at ``hs``) and the relaxation integrated exactly for it;
    with ``M_an``, ``dM_an/dH_e`` at ``h``."""
    L, L1 = _langevin2(h / a)
    man, dman = lam * L, lam * L1 / a
    step = h - hs
    if step <= 0.0:
        return 0.0, man, dman
    c0, c1, c2, c3 = _cubic(mans - m, dmans, man - m, dman, step)
    return _relax(0.0, c0, c1, c2, c3, 0.0, 1.0, step, k), man, dman


@numba.njit(cache=True)
def _inv_langevin(y, z):
    """``z`` with ``L(z) = y`` (``|y| < 1``) and ``L'`` there, by Newton from ``z`` in a bracket.

    Newton stops once a step is below ``1e-9 |z|`` (the next would be below ``1e-18 |z|``):
    the last step is taken, and ``L'`` is that of the point before it.
    """
    ay = abs(y)
    if ay == 0.0:
        return 0.0, 1.0 / 3.0
    lo, hi = 3.0 * ay, max(3.0 * ay, 1.0 / (1.0 - ay))
    z = abs(z)
    if not lo <= z <= hi:
        z = min(max(ay * (3.0 - ay * ay) / (1.0 - ay * ay), lo), hi)  # Cohen's approximation
    L1 = 1.0 / 3.0
    for _ in range(100):
        L, L1 = _langevin2(z)
        f = L - ay
        if f > 0.0:
            hi = z
        elif f < 0.0:
            lo = z
        else:
            break
        zn = z - f / L1 if L1 > 0.0 else 0.5 * (lo + hi)
        if not lo <= zn <= hi:
            zn = 0.5 * (lo + hi)
        done = abs(zn - z) <= 1e-9 * z or hi - lo <= 2e-15 * hi
        z = zn
        if done:
            break
    return (z if y > 0.0 else -z), L1


@numba.njit(cache=True)
def _start_field(A, lam, a, c, kap, mb_irr, h):
    """``h0`` with ``h0 - alpha ((1 - c) mb_irr + c M_an(h0)) = -A`` (increasing for zeta <= 1),
    by Newton from ``h`` in the bracket ``-A -+ alpha lambda_s``: ``(h0, M_an, dM_an/dH_e)``.

    Newton stops once a step is below ``1e-9 (|h| + A)``; ``M_an`` is carried to first order
    over that last step (the error is of the next step's order, ~1e-18).
    """
    lo, hi = -A - kap * lam, -A + kap * lam
    if not lo <= h <= hi:
        h = min(max(h, lo), hi)
    scale = abs(h) + A
    for _ in range(100):
        L, L1 = _langevin2(h / a)
        f = h - kap * ((1.0 - c) * mb_irr + c * lam * L) + A
        if f > 0.0:
            hi = h
        elif f < 0.0:
            lo = h
        else:
            return h, lam * L, lam * L1 / a
        df = 1.0 - kap * c * lam * L1 / a
        hn = h - f / df if df > 0.0 else 0.5 * (lo + hi)
        if not lo <= hn <= hi:
            hn = 0.5 * (lo + hi)
        if abs(hn - h) <= 1e-9 * scale or hi - lo <= 2e-15 * scale:
            return hn, lam * (L + L1 * (hn - h) / a), lam * L1 / a
        h = hn
    L, L1 = _langevin2(h / a)
    return h, lam * L, lam * L1 / a


@numba.njit(cache=True)
def _steady_closed(A, th, G, qt):
    """The steady loop of peak ``A`` for ``th = (lambda_s, a, k, c, alpha)``, ``zeta <= 1``.

    The unknown is ``mi0 = M_irr`` at the loop's bottom ``(H, H_e) = (-A, h0)``, ``h0`` from
    the mean field (:func:`_start_field`). The rising branch is frozen until ``h_s =
    max(h0, a L^-1(mi0 / lambda_s))``, where ``M_an`` reaches ``mi0`` (:func:`_inv_langevin`),
    and relaxes after it, ``M_irr = mi0 + Q(h) - Q(h_s) + (Q(h_s) - mi0)(1 - e^(-(h -
    h_s)/k))``. The loop is symmetric, its tip at ``H_e = -h0``, when ``M_irr(-h0) = -mi0``::

        g(mi0) = 2 mi0 + Q(-h0) - Q(h_s) + (Q(h_s) - mi0)(1 - e^(-(-h0 - h_s)/k)) = 0,

    solved by Newton with the exact derivative, safeguarded by the bracket ``[-lambda_s,
    0]`` (``g(0) >= 0 > g(-lambda_s)``), from ``-Q(A + alpha M_an(A))`` (the tip of a loop
    whose transient has died out); ``Q(-h0) - Q(h_s)`` by :func:`_q_diff`. Newton stops once
    a step is below ``1e-8 |mi0|`` (the next would be ~1e-16 ``|mi0|``): that step is taken
    and the rest carried over it to first order; ``h0`` and the switch are solved at each
    step from the previous ones carried the same way. A loop spanning less than
    :data:`_THIN` ``a`` takes ``M_irr(-h0) - mi0`` from :func:`_thin_lag` instead.

    Returns ``(mi0, h0, M_an(h0), dM_an/dH_e(h0), h_s, Q(h_s), thin)`` (``Q(h_s) = 0`` for a
    thin loop; ``mi0`` NaN where Newton failed) and the number of Newton steps.
    """
    lam, a, k, c, kap = th
    zg = G[0]
    lo, hi = -lam, 0.0
    L, _ = _langevin2(A / a)
    guess = A + kap * lam * L
    m = -_q_at(guess, _cell(zg, guess / a, -1), lam, a, k, G, qt)
    if not lo < m < hi:
        m = 0.0
    h0, zsw = -A, 0.0
    dh0 = dzsw = 0.0
    js = j1 = -1
    man0 = dman0 = hs = qs = np.nan
    # thin: the span 2|h0| is about 2A / (1 - zeta c) (the small-signal slope with mean field)
    thin = 2.0 * A / max(1.0 - kap * c * lam / (3.0 * a), 1e-3) <= _THIN * a
    it = 0
    for it in range(1, 101):
        h0, man0, dman0 = _start_field(A, lam, a, c, kap, m, h0)
        dh0 = kap * (1.0 - c) / (1.0 - kap * c * dman0)
        zsw, L1 = _inv_langevin(m / lam, zsw)
        dzsw = 1.0 / (lam * L1) if L1 > 0.0 else 0.0
        hs, mans, dhs = h0, man0, dh0
        if a * zsw > h0:
            hs, mans, dhs = a * zsw, m, a * dzsw
        h1 = -h0
        dqs = 0.0
        if hs >= h1:  # frozen over the whole half cycle
            qs = m
            g, dg = 2.0 * m, 2.0
        elif thin:
            dmans = lam * L1 / a if hs > h0 else dman0
            r1, man1, _ = _thin_lag(h1, hs, m, mans, dmans, lam, a, k)
            x = (h1 - hs) / k
            em = -math.expm1(-x)
            g = 2.0 * m + r1
            dg = 2.0 - em - math.exp(-x) * (mans - m) / k * dhs - (man1 - m - r1) / k * dh0
            qs = 0.0
        else:
            js = _cell(zg, hs / a, js)
            j1 = _cell(zg, h1 / a, j1)
            qs = _q_at(hs, js, lam, a, k, G, qt)
            dq = _q_diff(h1, j1, hs, js, qs, lam, a, k, G, qt)
            x = (h1 - hs) / k
            em = -math.expm1(-x)
            g = 2.0 * m + dq + (qs - m) * em
            dqs = (mans - qs) / k * dhs
            dq1 = (man0 + qs + dq) / k * dh0  # (M_an - Q)/k at the tip, times dh1 = -dh0
            dg = 2.0 + dq1 - dqs + (dqs - 1.0) * em - (qs - m) * math.exp(-x) * (dh0 + dhs) / k
        if not g == g:
            break
        if g > 0.0:
            hi = m
        elif g < 0.0:
            lo = m
        else:
            return (m, h0, man0, dman0, hs, qs, thin), it
        mn = m - g / dg if dg > 0.0 else 0.5 * (lo + hi)
        if not lo < mn < hi:
            mn = 0.5 * (lo + hi)
        d = mn - m
        if abs(d) <= 1e-8 * abs(mn) or hi - lo <= 1e-15 * max(-lo, -hi) or abs(d) < 1e-300:
            man0 += dman0 * dh0 * d
            return (mn, h0 + dh0 * d, man0, dman0, hs + dhs * d, qs + dqs * d, thin), it
        m = mn
        h0 += dh0 * d  # the inner solutions carried to the new mi0 (first order)
        zsw += dzsw * d
    return (np.nan, h0, man0, dman0, hs, qs, thin), it


@numba.njit(cache=True)
def _nodes_closed(A, th, tol, nmin, G, qt, sol, rec):
    """Nodes ``(H_e, M, dM/dH_e)`` into ``rec`` of the steady rising branch ``sol``
    (:func:`_steady_closed`); their number (-1: more than ``rec`` holds).

    From ``h0`` to the tip ``-h0``: the universal nodes in between (their ``M_an`` and ``Q``
    as tabulated), and where a step must be shorter -- at least ``nmin`` per branch, the
    switch ``h_s``, the transient ``(Q(h_s) - mi0) e^(-(h - h_s)/k)`` (steps as in
    :func:`_step_size`) -- nodes where ``Q`` is integrated from the cell's node
    (:func:`_q_diff`). The tip's ``M`` is ``-M(h0)`` exactly.
    """
    lam, a, k, c, kap = th
    zg, Lg, L1g, ahead = G
    rec_e, rec_m, rec_d = rec
    m, h0, man0, dman0, hs, qs, thin = sol
    cap = rec_e.size
    h1 = -h0
    d_max = (h1 - h0) / nmin
    qtr = 384.0 * tol * lam
    size = zg.size
    mans = dmans = 0.0
    tr0 = (1.0 - c) * abs(qs - m)  # the transient's amplitude at the switch
    if thin:  # no universal nodes; M_irr by _thin_lag
        size = 0
        L, L1 = _langevin2(hs / a)
        mans, dmans = (m if hs > h0 else lam * L), lam * L1 / a
        tr0 = (1.0 - c) * abs(mans - m - k * dmans)
    mb = (1.0 - c) * m + c * man0
    rec_e[0], rec_m[0] = h0, mb
    rec_d[0] = c * dman0 + ((1.0 - c) * max(man0 - m, 0.0) / k if hs <= h0 else 0.0)
    n = 1
    j = _cell(zg, h0 / a, -1)  # zg[j] <= h / a < zg[j + 1]
    js = _cell(zg, hs / a, -1)
    h = h0
    for _ in range(8 * cap):
        g = ahead[j] if j >= 0 else 0  # the next universal node of the branch
        nxt = h + d_max
        if h < hs:
            nxt = min(nxt, hs)
        else:
            x = (h - hs) / k
            tr = tr0 * math.exp(-x) if x < 40.0 else 0.0
            if tr > 0.0:
                nxt = min(nxt, h + k * math.sqrt(math.sqrt(qtr / tr)))
        on_grid = g < size and a * zg[g] <= nxt
        if on_grid:
            nxt = a * zg[g]
        if n >= cap:
            return -1
        if nxt >= h1 - 1e-12 * d_max:  # (not a step of rounding errors before the tip)
            rec_e[n], rec_m[n] = h1, -mb
            rec_d[n] = c * dman0 + ((1.0 - c) * max(m - man0, 0.0) / k if hs < h1 else 0.0)
            return n + 1
        if on_grid:
            j = g
            man, dman = lam * Lg[g], lam * L1g[g] / a
        else:
            while j + 1 < size and a * zg[j + 1] <= nxt:
                j += 1
            L, L1 = _langevin2(nxt / a)
            man, dman = lam * L, lam * L1 / a
        if nxt < hs:
            mi, dmi = m, 0.0
        else:
            if thin:
                r, _, _ = _thin_lag(nxt, hs, m, mans, dmans, lam, a, k)
                mi = m + r
            else:
                x = (nxt - hs) / k
                if on_grid and js < g - 1:  # a node cells away from the switch: as tabulated
                    mi = m + (qt[g] - qs)
                else:
                    mi = m + _q_diff(nxt, j, hs, js, qs, lam, a, k, G, qt)
                mi += (qs - m) * (-math.expm1(-x) if x < 40.0 else 1.0)
            dmi = max(man - mi, 0.0) / k
        rec_e[n], rec_m[n], rec_d[n] = nxt, (1.0 - c) * mi + c * man, (1.0 - c) * dmi + c * dman
        n += 1
        h = nxt
    return -1
