"""Jiles-Atherton kernels: Langevin anhysteretic, exponential integrator, steady loops.

The numba kernels of :mod:`fitdf.models.jiles_atherton`: the Langevin function and the
anhysteretic (vectorised and compiled); the relaxation of ``M_irr`` integrated exactly for
a cubic-Hermite ``M_an`` (:func:`_relax`); the forced response ``Q`` on universal nodes
(:func:`_grid`, :func:`_q_table`), the steady loop from it in closed form
(:func:`_steady_closed`) and its branch nodes (:func:`_nodes_closed`); and, for ``zeta >
1`` (a folding ``H(H_e)``, outside the bounds), the half cycle integrated step by step to
its fixed point by a safeguarded secant (:func:`_half_cycle`, :func:`_steady`). The
formulation is in :mod:`fitdf.models.jiles_atherton` and, in full, in the documentation's
method pages (hysteresis laws); Jiles and Atherton (1986) for the model.

numba caches a compiled caller (``cache=True``) by the caller's own source file: after
editing this module, delete ``fitdf/models/__pycache__/*.nb[ic]``, or the callers in
:mod:`fitdf.models._ja_branch` keep the old kernels.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["langevin", "coupling", "anhysteretic"]

# Fine tabulation: cubic-Hermite interpolation error per step below _TOL lambda_s, at least
# _NMIN steps per branch; the coarse one (the rough branch, and the secant's first passes
# for zeta > 1); node capacity.
_TOL, _NMIN = 1e-7, 24
_COARSE_TOL, _COARSE_NMIN = 1e-5, 8
_CAP = 1 << 13
# Closure |M_top + M_b| of the secant stages (zeta > 1), in lambda_s. The coarse stage only
# brings the fine one within its reach (the two tabulations differ by ~1e-5 lambda_s
# anyway); the fine closure is 100x below the fine tabulation's own error (tol 1e-7 per step).
_COARSE_CLOSURE, _CLOSURE = 1e-6, 1e-9


@numba.njit(cache=True)
def _langevin2(z):
    """``L(z)``, ``L'(z)`` (series below |z| = 0.1, closed form above)."""
    az = abs(z)
    if az < 0.1:
        z2 = z * z
        L = z * (1.0 / 3.0 - z2 * (1.0 / 45.0 - z2 * (2.0 / 945.0 - z2 / 4725.0)))
        L1 = 1.0 / 3.0 - z2 * (1.0 / 15.0 - z2 * (2.0 / 189.0 - z2 * 2.0 / 675.0))
        return L, L1
    one_q = -math.expm1(-2.0 * az)
    q = 1.0 - one_q
    coth = (1.0 + q) / one_q
    s = 1.0 if z > 0 else -1.0
    return s * (coth - 1.0 / az), 1.0 / (az * az) - 4.0 * q / (one_q * one_q)


def langevin(z):
    """Langevin function ``L(z) = coth z - 1/z`` (series below ``|z| = 0.1``), vectorised."""
    z = np.asarray(z, dtype=float)
    az = np.maximum(np.abs(z), 0.1)
    one_q = -np.expm1(-2.0 * az)
    big = np.sign(z) * ((2.0 - one_q) / one_q - 1.0 / az)
    z2 = z * z
    small = z * (1.0 / 3.0 - z2 * (1.0 / 45.0 - z2 * (2.0 / 945.0 - z2 / 4725.0)))
    return np.where(np.abs(z) < 0.1, small, big)


def coupling(*, lambda_s, a, zeta, **_):
    """Mean-field coupling ``alpha = 3 zeta a / lambda_s`` (1/H): ``i_e = i + alpha lambda``; ``alpha_JA = alpha L_0``."""
    return 3.0 * np.asarray(zeta, float) * np.asarray(a, float) / np.asarray(lambda_s, float)


def anhysteretic(x, *, lambda_s, a, zeta, **_):
    """Anhysteretic flux linkage: ``lambda = lambda_s L((x + alpha lambda)/a)`` solved for ``lambda``.

    Single-valued for ``zeta <= 1`` (the bounds; at ``zeta = 1`` its slope at the origin is
    infinite); solved by bisection on ``[-lambda_s, lambda_s]`` (the right side minus
    ``lambda`` is then decreasing). It is the ``k -> 0`` (and ``c -> 1``) limit of the loop.
    """
    al = coupling(lambda_s=lambda_s, a=a, zeta=zeta)
    x, lam, a_, al = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (x, lambda_s, a, al))
    )
    lo, hi = -lam.copy(), lam.copy()
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        up = lam * langevin((x + al * mid) / a_) > mid
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    return 0.5 * (lo + hi)


_PHI4 = np.array([1.0 / math.factorial(i + 4) for i in range(16)])  # phi_4(-z) = sum (-z)^i/(i+4)!


@numba.njit(cache=True)
def _phis(z):
    """``phi_1 .. phi_4`` at ``-z`` (``z >= 0``), ``phi_j(x) = Int_0^1 e^{(1-u)x} u^{j-1}/(j-1)! du``.

    Below ``z = 1``: ``phi_4`` by its Taylor series (16 terms, error < 1e-19), then
    ``phi_j = 1/j! - z phi_{j+1}``; above, ``phi_1 = (1 - e^{-z})/z`` and ``phi_{j+1} = (1/j! - phi_j)/z``.
    """
    if z < 1.0:
        p4 = 0.0
        for i in range(15, -1, -1):
            p4 = p4 * -z + _PHI4[i]
        p3 = 1.0 / 6.0 - z * p4
        p2 = 0.5 - z * p3
        return 1.0 - z * p2, p2, p3, p4
    p1 = -math.expm1(-z) / z
    p2 = (1.0 - p1) / z
    p3 = (0.5 - p2) / z
    return p1, p2, p3, (1.0 / 6.0 - p3) / z


@numba.njit(cache=True)
def _cubic(f0, d0, f1, d1, step):
    """Power coefficients in ``t`` in [0, 1] of the Hermite cubic with values and ``d/ds`` slopes."""
    c1 = step * d0
    c2 = 3.0 * (f1 - f0) - step * (2.0 * d0 + d1)
    c3 = 2.0 * (f0 - f1) + step * (d0 + d1)
    return f0, c1, c2, c3


@numba.njit(cache=True)
def _poly(c0, c1, c2, c3, t):
    return c0 + t * (c1 + t * (c2 + t * c3))


@numba.njit(cache=True)
def _relax(y0, c0, c1, c2, c3, t0, t1, step, k):
    """``M_irr`` at ``t1`` from ``y0`` at ``t0`` for ``dy/ds = (f - y)/k``, ``f`` the cubic; exact.

    On ``t = t0 + w u``, ``f = q0 + q1 u + q2 u^2 + q3 u^3`` and
    ``y = y0 e^{-z} + z (q0 phi_1 + q1 phi_2 + 2 q2 phi_3 + 6 q3 phi_4)(-z)``, ``z = w step / k``.
    """
    w = t1 - t0
    if w <= 0.0:
        return y0
    q0 = _poly(c0, c1, c2, c3, t0)
    q1 = w * (c1 + t0 * (2.0 * c2 + 3.0 * t0 * c3))
    q2 = w * w * (c2 + 3.0 * t0 * c3)
    q3 = w * w * w * c3
    z = w * step / k
    p1, p2, p3, p4 = _phis(z)
    return y0 * math.exp(-z) + z * (q0 * p1 + q1 * p2 + 2.0 * q2 * p3 + 6.0 * q3 * p4)


@numba.njit(cache=True)
def _envelope(z):
    """Upper bound ``min(0.13, 24/|z|^5)`` of the Langevin function's fourth derivative."""
    z2 = z * z
    return min(0.13, 24.0 / (z2 * z2 * abs(z) + 1e-300))


@numba.njit(cache=True)
def _step_size(he, a, k, c, lam, trans, tol, d_min, d_max):
    """Step in ``H_e`` keeping the cubic-Hermite error of ``M`` below ``tol lam``.

    Langevin part: ``step^4 |d4 M_an| / 384 <= tol lam`` with :func:`_envelope` (checked at
    both ends). Relaxation: ``M_irr`` is the quasi-static solution (as smooth as ``M_an``)
    plus a transient ``trans e^{-s/k}`` (``trans = k dM_an/dH_e`` at the switch), whose fourth
    derivative is ``trans / k^4``.
    """
    q = 384.0 * tol
    env = _envelope(he / a)
    step = a * math.sqrt(math.sqrt(q / env))
    env = max(env, _envelope((he + step) / a))
    step = min(step, a * math.sqrt(math.sqrt(q / env)))
    tr = (1.0 - c) * trans
    if tr > 0.0:
        step = min(step, k * math.sqrt(math.sqrt(q * lam / tr)))
    return min(max(step, d_min), d_max)


@numba.njit(cache=True)
def _tip(A, he, mi, man, c0, c1, c2, c3, step, k, c, kap, relaxing, t_end, h_end):
    """``t`` in ``[0, t_end]`` where ``H = A`` (regula falsi, Illinois) and ``M_irr`` there."""
    h0 = he - kap * ((1.0 - c) * mi + c * man)
    lo, hi, f_lo, f_hi = 0.0, t_end, h0 - A, h_end - A
    side = 0
    t = t_end
    mi_t = mi
    for _it in range(200):
        t = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        mi_t = _relax(mi, c0, c1, c2, c3, 0.0, t, step, k) if relaxing else mi
        ft = he + t * step - kap * ((1.0 - c) * mi_t + c * _poly(c0, c1, c2, c3, t)) - A
        if ft > 0.0:
            hi, f_hi = t, ft
            if side == 1:
                f_lo *= 0.5
            side = 1
        elif ft < 0.0:
            lo, f_lo = t, ft
            if side == -1:
                f_hi *= 0.5
            side = -1
        if ft == 0.0 or hi - lo <= 1e-15:
            break
    return t, mi_t


@numba.njit(cache=True)
def _half_cycle(A, lam, a, k, c, kap, Mb, tol, nmin, record, rec_e, rec_m, rec_d):
    """Ascending branch from ``(-A, Mb)`` until ``H = A``. Returns ``(M_top, n_nodes)``.

    With ``record``, nodes ``(H_e, M, dM/dH_e)`` go to ``rec_e``, ``rec_m``, ``rec_d``; the
    first is ``H = -A``, the last ``H = A`` (``H = H_e - alpha M``). Each step interpolates
    ``M_an`` by its Hermite cubic and integrates ``M_irr`` exactly for it; the switch of the
    irreversible term (``M_an`` reaching ``M_irr``) and the tip are nodes.
    """
    he = -A + kap * Mb
    L, L1 = _langevin2(he / a)
    man, dman = lam * L, lam * L1 / a
    mi = (Mb - c * man) / (1.0 - c)
    span = 2.0 * A + 2.0 * kap * abs(Mb)  # the H_e range of the steady branch
    d_max = span / nmin
    d_min = 1e-10 * span
    small = 1e-13 * lam
    trans = abs(man - mi - k * dman) if man - mi > -small else 0.0
    n = 0
    cap = rec_e.size
    for _ in range(8 * cap):
        lag = man - mi
        relaxing = lag > -small
        if record:
            if n >= cap:
                return np.nan, n
            dmi = max(lag, 0.0) / k
            rec_e[n], rec_m[n], rec_d[n] = he, (1.0 - c) * mi + c * man, (1.0 - c) * dmi + c * dman
            n += 1
        step = _step_size(he, a, k, c, lam, trans, tol, d_min, d_max)
        he1 = he + step
        L, L1 = _langevin2(he1 / a)
        man1, dman1 = lam * L, lam * L1 / a
        c0, c1, c2, c3 = _cubic(man, dman, man1, dman1, step)
        t_end = 1.0
        mi1 = mi
        if relaxing:
            mi1 = _relax(mi, c0, c1, c2, c3, 0.0, 1.0, step, k)
        elif man1 > mi:  # the switch lies inside: end the step there (a node)
            lo, hi = 0.0, 1.0
            for _it in range(100):
                mid = 0.5 * (lo + hi)
                if _poly(c0, c1, c2, c3, mid) > mi:
                    hi = mid
                else:
                    lo = mid
                if hi - lo < 1e-14:
                    break
            t_end = hi
        m_end = (1.0 - c) * mi1 + c * _poly(c0, c1, c2, c3, t_end)
        h_end = he + t_end * step - kap * m_end
        if h_end >= A:
            t, mi_t = _tip(A, he, mi, man, c0, c1, c2, c3, step, k, c, kap, relaxing, t_end, h_end)
            f_t = _poly(c0, c1, c2, c3, t)
            m_t = (1.0 - c) * mi_t + c * f_t
            if record:
                if n >= cap:
                    return np.nan, n
                df_t = (c1 + t * (2.0 * c2 + 3.0 * t * c3)) / step
                d_t = ((1.0 - c) * max(f_t - mi_t, 0.0) / k if relaxing else 0.0) + c * df_t
                rec_e[n], rec_m[n], rec_d[n] = A + kap * m_t, m_t, d_t
                n += 1
            return m_t, n
        if relaxing:
            trans *= math.exp(-step / k)
        elif t_end < 1.0:  # stopped at the switch: exact Langevin there; a transient starts
            he1 = he + t_end * step
            L, L1 = _langevin2(he1 / a)
            man1, dman1 = lam * L, lam * L1 / a
            trans = k * dman1
        he, man, dman, mi = he1, man1, dman1, mi1
    return np.nan, n


@numba.njit(cache=True)
def _solve(A, lam, a, k, c, kap, x, slope, tol, nmin, tol_root, record, rec_e, rec_m, rec_d):
    """Safeguarded secant for ``g(M_b) = M_top(M_b) + M_b = 0`` on ``[-lam, lam]``."""
    lo, hi = -lam, lam
    top, nrec = _half_cycle(A, lam, a, k, c, kap, x, tol, nmin, record, rec_e, rec_m, rec_d)
    gx = top + x
    x_old, g_old = np.inf, gx
    for _ in range(60):
        if not gx == gx:
            return x, slope, -1
        if gx < 0.0:
            lo = max(lo, x)
        else:
            hi = min(hi, x)
        if abs(gx) <= tol_root or hi - lo <= tol_root or abs(x - x_old) <= 1e-15 * lam:
            return x, slope, nrec
        x_new = x - gx / slope
        if not (lo < x_new < hi):
            x_new = 0.5 * (lo + hi)
        x_old, g_old = x, gx
        x = x_new
        top, nrec = _half_cycle(A, lam, a, k, c, kap, x, tol, nmin, record, rec_e, rec_m, rec_d)
        gx = top + x
        if gx != g_old and x != x_old:
            new_slope = (gx - g_old) / (x - x_old)
            if new_slope > 0.0:
                slope = new_slope
    return x, slope, nrec


@numba.njit(cache=True)
def _steady(A, lam, a, k, c, kap, tol, nmin, rec_e, rec_m, rec_d):
    """Nodes of the converged ascending branch; returns their number (-1: not found).

    A secant stage on the coarse tabulation (``_COARSE_TOL``, ``_COARSE_NMIN``) brings
    ``M_b`` close; a second one on the asked tabulation records the branch. Asked for a
    tabulation no finer than the coarse one (``tol >= _COARSE_TOL``), the first stage
    records and is the only one: the rough branch of a root search's first stage.
    """
    L, L1 = _langevin2(A / a)
    one_stage = tol >= _COARSE_TOL
    x, slope, n = _solve(
        A,
        lam,
        a,
        k,
        c,
        kap,
        -lam * L,
        1.0,
        tol if one_stage else _COARSE_TOL,
        nmin if one_stage else _COARSE_NMIN,
        _COARSE_CLOSURE * lam,
        one_stage,
        rec_e,
        rec_m,
        rec_d,
    )
    if not one_stage:
        record = not one_stage  # True, but typed bool: the literal True would compile _solve
        x, slope, n = _solve(  # and _half_cycle a second time
            A, lam, a, k, c, kap, x, slope, tol, nmin, _CLOSURE * lam, record, rec_e, rec_m, rec_d
        )
    return n if n > 1 else -1


# --- The steady loop from the forced response -----------------------------------------------

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
