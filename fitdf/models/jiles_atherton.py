"""Jiles-Atherton model (Jiles & Atherton 1986) in winding units, steady loops by integration.

Model
-----
Jiles and Atherton (J. Magn. Magn. Mater. 61, 48-60, 1986) write the magnetisation as an
irreversible (pinned-wall) part and a reversible (wall-bowing) part,

    H_e   = H + alpha M                              (Weiss mean field)
    M_an  = M_s L(H_e / a),  L(z) = coth z - 1/z     (Langevin anhysteretic)
    dM_irr/dH_e = (M_an - M_irr) / (delta k)         (pinning energy balance)
    M     = M_irr + c (M_an - M_irr)                 (reversible part)

with ``delta = sign(dH)``. This module keeps these four relations as they stand and
integrates them in the effective field ``H_e``:

    dM/dH_e = X = (1 - c) chi_irr + c dM_an/dH_e,   chi_irr = max(delta (M_an - M_irr), 0) / k,
    dH/dH_e = 1 - alpha X,   hence   dM/dH = X / (1 - alpha X).

The 1986 paper's ``dM_irr/dH = (M_an - M_irr) / (delta k - alpha (M_an - M_irr))`` is this
with the mean field fed by ``M_irr`` instead of ``M`` (they agree for ``c = 0``); integrated
independently it moves the coercive field and remanence of the published loop by ~1 %
(tests). Formulation choices, and the known defects they remove:

* *Negative susceptibility after reversals.* Right after a reversal ``delta (M_an - M_irr)``
  is negative and the raw equation would move ``M_irr`` against the field. The standard fix
  (the "delta_M" switch) is used: ``chi_irr = 0`` until ``M_an`` catches up with ``M_irr``,
  so ``X >= 0``.
* *No singularity.* Starting from 0 at the switch, the lag obeys ``lag' = dM_an/dH_e - lag/k``,
  so ``lag <= k sup dM_an/dH_e`` and ``X <= M_s / 3a``. With ``zeta = alpha M_s / 3a < 1``
  (the parameter's bounds) ``alpha X <= zeta < 1``: ``dM/dH`` is positive and at most
  ``(M_s / 3a) / (1 - zeta)``, so the singular, negative or "avalanche" slopes of the H-form
  cannot occur. For ``zeta >= 1`` (spontaneously magnetised anhysteretic; functions accept
  it) ``H(H_e)`` may fold back; the part a rising ``H`` cannot reach is then cut into a
  vertical jump at the fold's field (an assumption about the avalanche), and the symmetric
  steady loop need not be unique.
* *Integration.* Over a step ``M_an`` is replaced by its cubic Hermite interpolant (values
  and slopes at both ends) and the irreversible equation, a linear relaxation of length
  ``k``, is integrated exactly for it (exponential integrator with the ``phi_1 .. phi_4``
  functions), so steps need not be small compared with ``k``. The switch and the tip are
  nodes. Steps keep the cubic-Hermite error of ``M`` below ``tol lambda_s`` (fourth
  derivatives of the Langevin function and of the relaxation transient), at least
  ``n_min`` per branch. The branch is stored as its nodes ``(H_e, M, dM/dH_e)``: a
  fourth-order parametric cubic in ``H_e``.
* *Steady state.* The symmetric loop of peak ``A`` is the fixed point of the half cycle:
  starting at ``(-A, M_b)`` the ascending branch must end at ``(A, -M_b)``. ``M_b`` is found
  by a safeguarded secant iteration (coarse steps first, then fine), a few half cycles even
  where cycling would take hundreds (``A << k``). The descending branch is the point
  reflection by construction; the tests check both branches against a brute-force
  multi-cycle integration from the demagnetised state.

Winding units
-------------
With ``N`` turns, path ``l_e``, section ``A_e``: ``H = N i / l_e`` and ``B = mu_0 (H + M)``,
whose ``mu_0 H`` term (``L_0 = mu_0 N^2 A_e / l_e``, ~3e-4 H for the Permalloy core, against
>= 1 H from ``M``) is neglected. The parameters are

    lambda_s = mu_0 N A_e M_s (V s),   a = a_JA l_e / N,   k = k_JA l_e / N (A),
    c = c_JA,   zeta = alpha_JA M_s / (3 a_JA),

and the output is ``lambda = mu_0 N A_e M``. In these units ``i_e = i + alpha lambda`` with
``alpha = 3 zeta a / lambda_s`` in 1/H (``= alpha_JA / L_0``, :func:`coupling`). The mean
field is parametrised by ``zeta`` rather than ``alpha`` because ``zeta < 1`` (no spontaneous
magnetisation) is a fixed box bound, while a bound on ``alpha`` would depend on ``a`` and
``lambda_s``. Material constants: ``B_s = lambda_s / (N A_e)``; anhysteretic initial
inductance ``(lambda_s / 3a) / (1 - zeta)``; small-signal inductance of the loop
``N(0) = c L / (1 - zeta c)``, ``L = lambda_s / 3a`` (``mu_i = N(0) l_e / (mu_0 N^2 A_e)``);
the coercive current (close to ``(1 - c) k`` for the published set) and remanence are read
off the loop by :func:`loop_figures`. Any consistent units work: ``lambda_s = M_s`` and
fields in A/m give the SI model (:data:`JA_1986`).

Describing function
-------------------
``N = (2/(pi A^2)) Int y_up'(x) [sqrt(A^2 - x^2) - j x] dx`` (eqs 2.1, 2.2 integrated by parts),
evaluated on the parametric branch piece by piece with a 10-node Gauss-Legendre rule in
``t = (1 - cos(pi v))/2`` (which removes the square-root end behaviour at the tips), plus
``dM [sqrt(A^2 - x^2) - j x]`` for each jump. The referee applied to
:meth:`JilesAtherton.ascending_branch` (the same cubics, inverted by Newton) agrees to ~1e-9;
against the exact solution of the equations the default ``tol = 1e-8`` is within 3e-7
(``Im N``: 7e-7) of a ``tol = 1e-10`` refinement over the tested parameter sets.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fitdf.models.base import HysteresisModel
from fitdf.params import ParamSpec

__all__ = [
    "JilesAtherton",
    "langevin",
    "anhysteretic",
    "coupling",
    "steady_loop",
    "loop_figures",
    "ja_describing_function",
    "JA_1986",
]

#: Parameter set attributed to Jiles & Atherton (1986) in SI units (fields in A/m, output M in A/m).
JA_1986 = {
    "lambda_s": 1.6e6,
    "a": 1100.0,
    "k": 400.0,
    "c": 0.2,
    "zeta": 1.6e-3 * 1.6e6 / (3 * 1100.0),
}

# Fine tabulation: cubic-Hermite interpolation error per step below _TOL lambda_s, at least
# _NMIN steps per branch; coarse passes for the first secant iterations; node capacity.
_TOL, _NMIN = 1e-8, 24
_COARSE_TOL, _COARSE_NMIN = 1e-5, 8
_CAP = 1 << 13
_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)
# Gauss-Legendre in v on [0, 1] through t = (1 - cos(pi v)) / 2: removes the square-root
# end behaviour of sqrt(A^2 - H^2) at the tips.
_V = 0.5 * (_GL_X + 1.0)
_T_OF_V = 0.5 * (1.0 - np.cos(np.pi * _V))
_W_OF_V = 0.5 * _GL_W * 0.5 * np.pi * np.sin(np.pi * _V)


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
    """Nodes of the converged ascending branch; returns their number (-1: not found)."""
    L, L1 = _langevin2(A / a)
    x, slope, n = _solve(
        A,
        lam,
        a,
        k,
        c,
        kap,
        -lam * L,
        1.0,
        _COARSE_TOL,
        _COARSE_NMIN,
        1e-9 * lam,
        False,
        rec_e,
        rec_m,
        rec_d,
    )
    x, slope, n = _solve(
        A, lam, a, k, c, kap, x, slope, tol, nmin, 1e-13 * lam, True, rec_e, rec_m, rec_d
    )
    return n if n > 1 else -1


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
def _branch_loop(A, lam, a, k, c, kap, tol, nmin, cap, x_flat, x_index, out):
    rec_e, rec_m, rec_d, seg, t0, t1, h0, h1, mj0, mj1 = _work(cap)
    for i in range(A.size):
        n = _steady(A[i], lam[i], a[i], k[i], c[i], kap[i], tol, nmin, rec_e, rec_m, rec_d)
        count = (
            _pieces(rec_e, rec_m, rec_d, n, kap[i], A[i], seg, t0, t1, h0, h1, mj0, mj1)
            if n > 1
            else 0
        )
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


def langevin(z):
    """Langevin function ``L(z) = coth z - 1/z`` (series below |z| = 0.1), vectorised."""
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

    Single-valued for ``zeta < 1``; solved by bisection on ``[-lambda_s, lambda_s]`` (the right
    side minus ``lambda`` is then decreasing). It is the ``k -> 0`` (and ``c -> 1``) limit of the loop.
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


def steady_loop(amplitude, *, lambda_s, a, k, c, zeta, tol=_TOL, n_min=_NMIN, n_out=4):
    """Samples of the ascending branch of the steady loop of peak ``amplitude`` (scalars).

    Parameters
    ----------
    amplitude : float
        Peak input ``A`` (A).
    lambda_s, a, k, c, zeta : float
        Model parameters (:class:`JilesAtherton`).
    tol, n_min : float, int
        Step control (module docstring).
    n_out : int
        Samples per monotone piece of the parametric branch (between nodes).

    Returns
    -------
    x, y : numpy.ndarray
        From ``(-A, -lambda_tip)`` to ``(A, lambda_tip)``; ``x`` non-decreasing (equal at a
        jump, only for ``zeta >= 1``), ``y`` non-decreasing. The descending branch is
        ``(-x[::-1], -y[::-1])``.
    """
    alpha = float(coupling(lambda_s=lambda_s, a=a, zeta=zeta))
    x, y, _ = _table(
        float(abs(amplitude)),
        float(lambda_s),
        float(a),
        float(k),
        float(c),
        alpha,
        tol,
        n_min,
        _capacity(n_min),
        n_out,
    )
    return x, y


def loop_figures(amplitude, *, lambda_s, a, k, c, zeta, tol=_TOL, n_min=_NMIN, n_out=16):
    """Coercive current, remanence, tip flux linkage and loop area of one steady loop (scalars).

    Read off :func:`steady_loop` samples: ``coercive`` is the zero of the ascending branch,
    ``remanence`` minus its value at ``x = 0`` (linear interpolation between samples),
    ``area`` ``Int (y_down - y_up) dx`` by the trapezoid rule (relative error ~``n_out^-2``).
    """
    x, y = steady_loop(
        amplitude, lambda_s=lambda_s, a=a, k=k, c=c, zeta=zeta, tol=tol, n_min=n_min, n_out=n_out
    )
    xd, yd = -x[::-1], -y[::-1]
    area = np.trapezoid(yd, xd) - np.trapezoid(y, x)
    return {
        "coercive": float(np.interp(0.0, y, x)),
        "remanence": float(-np.interp(0.0, x, y)),
        "tip": float(y[-1]),
        "area": float(area),
    }


def ja_describing_function(amplitude, *, lambda_s, a, k, c, zeta, tol=_TOL, n_min=_NMIN):
    """``N(A)`` (H) of the steady JA loop; all arguments broadcast; numba loop over points.

    Parameters
    ----------
    amplitude : array_like
        Peak current ``A`` (A); the sign is irrelevant.
    lambda_s, a, k, c, zeta : array_like
        Model parameters (:class:`JilesAtherton`).
    tol, n_min : float, int
        Step control: cubic-Hermite error per step below ``tol lambda_s``, at least ``n_min``
        steps per branch. The defaults are within 3e-7 of a ``tol = 1e-10`` refinement;
        ``tol = 1e-6, n_min = 12`` is ~2.5x faster, within 1e-5 (``Im N``: 6e-5).

    Returns
    -------
    numpy.ndarray of complex
        ``N`` with ``Im N <= 0``. At ``A = 0`` the small-signal limit ``c L / (1 - zeta c)``,
        ``L = lambda_s / 3a`` (for ``A << k`` the irreversible part hardly moves over a
        cycle). NaN where no steady loop was found (never met within the bounds in the tests).
    """
    alpha = coupling(lambda_s=lambda_s, a=a, zeta=zeta)
    shape, (A, lam, a_, k_, c_, al) = _flat(amplitude, lambda_s, a, k, c, alpha)
    out = np.empty(A.size, dtype=complex)
    _df_loop(np.abs(A), lam, a_, k_, c_, al, tol, n_min, _capacity(n_min), _T_OF_V, _W_OF_V, out)
    return out.reshape(shape)


class JilesAtherton(HysteresisModel):
    """Jiles-Atherton hysteresis in winding units (module docstring: formulation and mapping).

    Examples
    --------
    >>> import numpy as np
    >>> theta = dict(lambda_s=0.03, a=1e-3, k=1e-3, c=0.2, zeta=0.5)
    >>> N = JilesAtherton.describing_function(np.array([1e-4, 1e-3, 3e-2]), **theta)
    >>> bool(np.all(N.imag < 0)), bool(np.all(np.diff(np.abs(N[1:])) < 0))
    (True, True)
    """

    name = "jiles_atherton"
    title = "Jiles-Atherton model (Langevin anhysteretic, pinning, reversible bowing, mean field)"
    equations = "Jiles & Atherton (1986); steady loop by integration; DF eqs 2.1, 2.2"
    closed_form = False
    params = (
        ParamSpec(
            "lambda_s",
            0.03,
            (1e-4, 10.0),
            "V s",
            "saturation flux linkage mu0 N A_e M_s",
            "JA M_s",
            log=True,
            quantity="flux_linkage",
        ),
        ParamSpec(
            "a",
            1e-3,
            (1e-7, 1e-1),
            "A",
            "Langevin shape current a_JA l_e / N",
            "JA a",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "k",
            1e-3,
            (1e-7, 1e-1),
            "A",
            "pinning current k_JA l_e / N (~ coercive current)",
            "JA k",
            log=True,
            quantity="current",
        ),
        ParamSpec(
            "c", 0.2, (1e-3, 0.99), "", "reversible (wall-bowing) fraction", "JA c", log=True
        ),
        ParamSpec(
            "zeta",
            0.5,
            (0.0, 0.99),
            "",
            "mean-field ratio alpha_JA M_s / 3 a_JA (< 1: no spontaneous magnetisation)",
            "JA alpha",
            log=False,
        ),
    )

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, *, lambda_s, a, k, c, zeta):
        """Rising branch of the steady loop (the parametric cubic of its nodes); broadcasts.

        One steady loop is computed per distinct broadcast ``(amplitude, theta)`` element and
        evaluated (Newton inversion of ``H(H_e)``) at all the ``x`` that share it.
        """
        alpha = coupling(lambda_s=lambda_s, a=a, zeta=zeta)
        pshape = np.broadcast_shapes(*(np.shape(v) for v in (amplitude, lambda_s, a, k, c, alpha)))
        full = np.broadcast_shapes(np.shape(x), pshape)
        _, params = _flat(amplitude, lambda_s, a, k, c, alpha)
        owner = np.broadcast_to(np.arange(int(np.prod(pshape))).reshape(pshape), full).reshape(-1)
        xs = np.broadcast_to(np.asarray(x, dtype=float), full).reshape(-1)
        order = np.argsort(owner, kind="stable")
        index = np.searchsorted(owner[order], np.arange(params[0].size + 1))
        out = np.empty(xs.size)
        A, lam, a_, k_, c_, al = params
        _branch_loop(
            np.abs(A),
            lam,
            a_,
            k_,
            c_,
            al,
            _TOL,
            _NMIN,
            _capacity(_NMIN),
            np.ascontiguousarray(xs[order]),
            index,
            out,
        )
        result = np.empty_like(out)
        result[order] = out
        return result.reshape(full)

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, *, lambda_s, a, k, c, zeta):
        """``N(A)`` (H) from :func:`ja_describing_function`; ``frequency`` is only broadcast."""
        N = ja_describing_function(amplitude, lambda_s=lambda_s, a=a, k=k, c=c, zeta=zeta)
        return np.broadcast_to(N, np.broadcast_shapes(N.shape, np.shape(frequency))).copy()
