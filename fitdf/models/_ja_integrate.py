"""Jiles-Atherton kernels: Langevin anhysteretic, exponential integrator, steady loops.

The numba kernels of :mod:`fitdf.models.jiles_atherton`: the Langevin function and the
anhysteretic (vectorised and compiled); the relaxation of ``M_irr`` integrated exactly for
a cubic-Hermite ``M_an`` (:func:`_relax`); and, for ``zeta > 1`` (a folding ``H(H_e)``,
outside the bounds), the half cycle integrated step by step to its fixed point by a
safeguarded secant (:func:`_half_cycle`, :func:`_steady`). The steady loop in closed form
from the forced response, for ``zeta <= 1``, is :mod:`fitdf.models._ja_closed`. The
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
