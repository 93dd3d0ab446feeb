"""Compiled kernels of the ``voltage`` chain (:mod:`fitdf.chains.voltage`).

Each ``numba.njit(cache=True)`` function is compiled for one signature (float64 arrays
that may be written to: a read-only array, such as a broadcast view, is another type to numba
and would compile a kernel a second time on a fresh install; :func:`kernel_array` makes the
tables so):

* :func:`place_nodes` -- where to tabulate a branch, from a table of it;
* :func:`half_periods` -- the rising half period of many points at once (rows in a
  compiled loop, split over threads only on request): the peak current reached and the
  first harmonics of the flux linkage (the helpers :func:`_refine` and
  :func:`_integrate` do the work);
* :func:`half_period_wave` -- the same for one point, recording the waveform.

The per-point root search of the peak current is :mod:`fitdf.chains._secant`.

The method is summarised in :mod:`fitdf.chains.voltage` and described in full in the
documentation's method pages (measurement chains).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = [
    "place_nodes",
    "half_periods",
    "half_period_wave",
    "kernel_array",
    "rate_current",
    "N_OUT",
]


def kernel_array(a, shape=None) -> np.ndarray:
    """``a`` (broadcast to ``shape`` if given) as the kernels' one array type: float64,
    C-contiguous and writeable (copied only when it is not already)."""
    a = np.asarray(a, dtype=float)
    if shape is not None and a.shape != tuple(shape):
        a = np.broadcast_to(a, shape)
    if a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, order="C")


#: Weight of BDF2's local-error estimate in the step control of the rate-dependent path
#: (:func:`_integrate`): the weight at which the largest DF error against the time-stepping
#: reference of ``tests/test_dynamic_chain.py`` (its twelve points) is least, 3.6e-5,
#: against 1.3e-4 at 10, 2.4e-4 at 100 (where the steps are so short that the table's own
#: error shows, at 0 ohm in deep saturation) and 1.7e-4 without the estimate.
LTE_WEIGHT = 30.0

#: Columns of :func:`half_periods`' output: peak current (of the branch), flux harmonics
#: (sin, cos), number of steps, peak total current (the same on the static path).
N_OUT = 5


@numba.njit(cache=True)
def place_nodes(u0, B0, weights, out):
    """Nodes ``out[p]`` (``M`` values from ``u0[p, 0]`` to ``u0[p, -1]``) for the branch ``B0[p]``.

    ``B0[p]`` is a table of the branch at the (normalised) currents ``u0[p]``. The new
    nodes equidistribute ``wx |du|/2 + wy |dB|/range + wk |sin(bend)|/2`` (``weights =
    (wx, wy, wk)``) along it, the bend being the angle between consecutive chords of the
    normalised curve, shared by the two cells next to it: the current range, the steep
    parts (the flux swing of a saturated core) and the bends (kinks, knees) all get nodes.
    """
    P, M0 = B0.shape
    M = out.shape[1]
    wx, wy, wk = weights[0], weights[1], weights[2]
    for p in range(P):
        b = B0[p]
        u = u0[p]
        hb = np.empty(M0)
        m = b[0]
        for j in range(M0):
            if b[j] > m:
                m = b[j]
            hb[j] = m
        rng = hb[M0 - 1] - hb[0]
        inv = 1.0 / rng if rng > 0 and np.isfinite(rng) else 0.0
        tx = np.empty(M0 - 1)  # unit chords of the normalised curve
        ty = np.empty(M0 - 1)
        for j in range(M0 - 1):
            dx = 0.5 * (u[j + 1] - u[j])
            dy = (hb[j + 1] - hb[j]) * inv
            ln = np.sqrt(dx * dx + dy * dy)
            tx[j] = dx / ln if ln > 0 else 1.0
            ty[j] = dy / ln if ln > 0 else 0.0
        S = np.empty(M0)
        S[0] = 0.0
        for j in range(M0 - 1):
            d = wx * 0.5 * (u[j + 1] - u[j]) + wy * (hb[j + 1] - hb[j]) * inv
            if j > 0:  # bend: |sin| of the angle between chords (both at most 1)
                d += wk * 0.25 * abs(tx[j - 1] * ty[j] - ty[j - 1] * tx[j])
            if j < M0 - 2:
                d += wk * 0.25 * abs(tx[j] * ty[j + 1] - ty[j] * tx[j + 1])
            S[j + 1] = S[j] + d
        total = S[M0 - 1]
        j = 0
        out[p, 0] = u[0]
        for q in range(1, M - 1):
            target = total * q / (M - 1)
            while j < M0 - 2 and S[j + 1] < target:
                j += 1
            d = S[j + 1] - S[j]
            t = (target - S[j]) / d if d > 0 else 0.0
            out[p, q] = u[j] + t * (u[j + 1] - u[j])
        out[p, M - 1] = u[M0 - 1]


@numba.njit(cache=True)
def _refine(x, B, xr, Br):
    """Monotone hull of the table ``(x, B)``, each cell split in two (``2M - 1`` nodes).

    ``B`` is replaced by its running maximum: the flux cannot fall while the current
    rises (a falling part becomes a flat, across which the current jumps). Every cell gets
    an interior node: where the two cells on either side are straight (slopes equal to
    ``1e-9`` of the table's slope scale) and their lines meet inside it, at that
    intersection -- the exact kink of a piecewise-linear branch, wherever it falls --; on
    smooth stretches at the chord's midpoint bent by the local curvature (the cubic
    through four nodes on an even grid); otherwise at the chord's midpoint.
    """
    M = x.shape[0]
    hb = np.empty(M)
    m = B[0]
    for j in range(M):
        if B[j] > m:
            m = B[j]
        hb[j] = m
    s = np.empty(M - 1)
    smax = 0.0
    for j in range(M - 1):
        dx = x[j + 1] - x[j]
        s[j] = (hb[j + 1] - hb[j]) / dx if dx > 0 else 0.0
        if abs(s[j]) > smax:
            smax = abs(s[j])
    span = x[M - 1] - x[0]
    scale = (hb[M - 1] - hb[0]) / span if span > 0 else 0.0
    tol = 1e-9 * (scale + smax)
    for j in range(M - 1):
        xr[2 * j] = x[j]
        Br[2 * j] = hb[j]
        xm = 0.5 * (x[j] + x[j + 1])
        bm = 0.5 * (hb[j] + hb[j + 1])
        snapped = False
        if 2 <= j <= M - 4:
            sl = s[j - 1]
            sr = s[j + 1]
            if abs(sl - s[j - 2]) <= tol and abs(s[j + 2] - sr) <= tol and abs(sl - sr) > 1e3 * tol:
                xs = (hb[j + 1] - hb[j] - sr * x[j + 1] + sl * x[j]) / (sl - sr)
                if x[j] < xs < x[j + 1]:
                    xm = xs
                    bm = min(max(hb[j] + sl * (xs - x[j]), hb[j]), hb[j + 1])
                    snapped = True
        if not snapped and 1 <= j <= M - 3:
            # smooth stretch (consecutive slope changes of one sign, within a factor of 3):
            # the middle bends by -h^2 B''/8, B'' averaged over the two sides -- on an even
            # grid the cubic through the four nodes around the cell
            d1 = s[j] - s[j - 1]
            d2 = s[j + 1] - s[j]
            if d1 * d2 > 0 and abs(d1) < 3.0 * abs(d2) and abs(d2) < 3.0 * abs(d1):
                h = x[j + 1] - x[j]
                b2 = d1 / (x[j + 1] - x[j - 1]) + d2 / (x[j + 2] - x[j])
                bm = min(max(bm - 0.125 * h * h * b2, hb[j]), hb[j + 1])
        xr[2 * j + 1] = xm
        Br[2 * j + 1] = bm
    xr[2 * M - 2] = x[M - 1]
    Br[2 * M - 2] = hb[M - 1]


@numba.njit(cache=True)
def rate_current(e, c_cl, c_ex):
    """Rate-dependent current ``g(e) = c_cl e + c_ex sign(e) |e|^(1/2)`` (A) of the EMF ``e`` (V).

    Bertotti's loss separation in the dynamic-field form (G. Bertotti, IEEE Trans. Magn. 24
    (1988) 621; S.E. Zirka et al., IEEE Trans. Magn. 42 (2006) 2121): the field is
    ``H_stat(B) + k_cl dB/dt + k_ex sign(dB/dt) |dB/dt|^(1/2)``; in winding units the
    classical and excess terms are this current (:mod:`fitdf.chains.dynamic`).
    """
    r = np.sqrt(abs(e))
    return c_cl * e + (c_ex * r if e >= 0.0 else -c_ex * r)


@numba.njit(cache=True)
def _dyn_emf(A, C, bq):
    """Root ``e`` of ``A e + bq sign(e) |e|^(1/2) + C = 0`` (``A > 0``, ``bq >= 0``): exact.

    The left side increases with ``e``, so ``e`` has the sign of ``-C``; with
    ``u = |e|^(1/2)`` it is the quadratic ``A u^2 + bq u - |C| = 0``, whose positive root is
    taken in the form without cancellation, ``2 |C| / (bq + sqrt(bq^2 + 4 A |C|))``.
    """
    if bq == 0.0:
        return -C / A
    m = abs(C)
    u = 2.0 * m / (bq + np.sqrt(bq * bq + 4.0 * A * m))
    return u * u if C < 0.0 else -u * u


@numba.njit(cache=True)
def _dyn_step(x, B, j, i, lam, R, alpha, beta, v, c_cl, c_ex, s_ext):
    """One implicit step with the rate-dependent current: ``R i_h + R g(e) + e = v``.

    ``e = alpha lam - beta`` is the step's difference quotient of the flux (BDF2 or the
    trapezoidal first step) and ``lam = B(i_h)`` the table (linear between nodes, the last
    cell's line beyond). The residual increases with ``i_h`` (``g`` and ``B`` do not fall),
    so the cell is found by the pointer that only moves forward, as on the static path.
    Inside the cell ``i_h`` is linear in ``e``: without the excess term the equation is
    linear and solved exactly; with it, it is :func:`_dyn_emf`'s quadratic in
    ``|e|^(1/2)``, solved exactly, and one Newton step in ``i_h`` removes the rounding of
    ``e - e0`` on a nearly flat cell. On a flat the flux is fixed, the current takes the
    rest of the voltage, and a negative EMF is clipped to 0 (as on the static path).
    Returns ``(j, i_h, lam, e, flat)``; a step whose residual is already positive holds
    the state (the current would fall) and returns ``e = 0``.
    """
    M = x.shape[0]
    e = alpha * lam - beta
    if R * i + R * rate_current(e, c_cl, c_ex) + e >= v:
        return j, i, lam, 0.0, False
    while j < M - 1:
        e = alpha * B[j + 1] - beta
        if R * x[j + 1] + R * rate_current(e, c_cl, c_ex) + e >= v:
            break
        j += 1
    if j >= M - 1:  # beyond the tip: the last cell's line
        x0, B0, s, dx = x[M - 1], B[M - 1], s_ext, np.inf
    else:
        x0, B0, dx = x[j], B[j], x[j + 1] - x[j]
        s = (B[j + 1] - B0) / dx if dx > 0 else 0.0
    e0 = alpha * B0 - beta
    flat = s == 0.0
    if flat:  # the flux is fixed, the current takes the rest of the voltage
        e = e0
        i_new = (v - e - R * rate_current(e, c_cl, c_ex)) / R
        i_new = min(max(i_new, x0), x0 + dx)
        lam_new = B0
        if e < 0.0:  # on a flat the EMF is 0, never negative (as on the static path)
            e = 0.0
            i_new = v / R
    else:
        # in the current t beyond x0: e = e0 + alpha s t, residual r0 + a_lin t + R c_ex sqrt
        a_lin = R + (1.0 + R * c_cl) * alpha * s
        r0 = R * x0 + (1.0 + R * c_cl) * e0 - v
        if c_ex == 0.0:  # linear: exact
            t = -r0 / a_lin
        else:
            k = R / (alpha * s)  # di_h/de along the line
            e = _dyn_emf(k + 1.0 + R * c_cl, R * x0 - k * e0 - v, R * c_ex)
            t = (e - e0) / (alpha * s)
            # one Newton step in t: e - e0 loses digits where the slope s is small
            e = e0 + alpha * s * t
            r = r0 + a_lin * t + R * rate_current(e, 0.0, c_ex)
            if e != 0.0:
                t -= r / (a_lin + 0.5 * R * c_ex * alpha * s / np.sqrt(abs(e)))
        t = min(max(t, 0.0), dx)
        i_new = x0 + t
        lam_new = B0 + s * t
        e = alpha * lam_new - beta
    return j, max(i_new, i), lam_new, e, flat


@numba.njit(cache=True)
def _hold_peak(x, B, j, j_new, i, lam, i_top, s_ext):
    """The state at a step that passed the current's peak: ``(j, i, lam)``.

    The step's solution (in cell ``j_new``, from ``i`` in cell ``j``) lies above
    ``i_top = v / R``, i.e. its EMF is negative while the current rises, which the
    ascending branch does not allow. The current is held at ``max(i_top, i)`` -- where it
    meets ``V sin/R`` (EMF 0), or where it was if it had already passed -- and the flux is
    the branch's there (the pointer moves back to its cell; beyond the tip, the last cell's
    line), never below the flux ``lam`` already reached.
    """
    M = x.shape[0]
    i_c = max(i_top, i)
    while j_new > j and x[j_new] > i_c:
        j_new -= 1
    if j_new >= M - 1:
        lam_c = B[M - 1] + s_ext * (i_c - x[M - 1])
    else:
        dx = x[j_new + 1] - x[j_new]
        t = min(max((i_c - x[j_new]) / dx, 0.0), 1.0) if dx > 0 else 0.0
        lam_c = B[j_new] + t * (B[j_new + 1] - B[j_new])
    return j_new, i_c, max(lam_c, lam)


@numba.njit(cache=True)
def _integrate(x, B, V, R, w, phi0, n, dsig, wave, c_cl=0.0, c_ex=0.0):
    """One rising half period of ``R i + w dlam/dtheta = V sin(theta)``, ``lam = B(i)``.

    ``(x, B)``: the branch, non-decreasing, linear between nodes and continued beyond the
    last one along the last cell's line (a loop too small for the trajectory continues
    smoothly; a saturated tip continues flat).
    Starts at ``i = x[0]`` at ``theta = phi0`` and runs to ``phi0 + pi``: variable-step
    BDF2 (trapezoidal first step), each step's implicit equation ``a i + c B(i) = rhs``
    solved exactly on the table with a pointer that only moves forward; once the current
    would fall (past its maximum) it is held. Steps are ``pi / n`` unless the state moves
    by more than ``dsig`` along the branch (current over ``2 x[-1]`` plus flux over its
    range) -- the sharp rise of the current into saturation -- where they shrink (down to
    ``pi / (64 n)``; a genuine jump onto a flat cannot be resolved and is accepted).
    While the current rises on the ascending branch its EMF ``B'(i) di/dt`` is not
    negative, i.e. ``i <= V sin/R``; a step whose solution has ``R i > v`` (BDF2's difference
    quotient carries the flux rate of the steps before past the current's peak: by a
    current of order ``|e| / R`` where the flux stops at a kink into a nearly flat
    saturation) is shortened to ``pi / (64 n)`` to locate the peak, and the current is
    then held at ``max(v / R, i)`` with its flux on the branch (:func:`_hold_peak`); on an
    exact flat it is held at once (the jump below). The recorded current and ``i_max`` are
    the held ones. (On the rate-dependent path the same: ``R i_h > v`` is ``e < 0``, and
    the held state has ``e = 0``, ``g = 0``.)

    Returns ``(i_max, ls, lc, n_steps, i_peak)``: the largest current reached -- including,
    when a step lands on a flat (zero inductance, the current jumps), the current ``V sin/R``
    at the phase where the flux reached the flat, extrapolated over the step -- then
    ``(2/pi) int lam sin`` and ``(2/pi) int lam cos`` over the half period (trapezoid
    rule): the full-period Fourier coefficients of the flux under half-wave symmetry, the
    number of steps and the largest total current. ``wave`` (``(K, 3)``, or ``(0, 3)``)
    receives ``theta, i, lam`` per step (at most ``K - 1`` steps are recorded).

    With ``c_cl`` or ``c_ex`` nonzero the winding current is ``i = i_h + g(e)``
    (:func:`rate_current`, ``lam = B(i_h)``) and each step solves
    ``R i_h + R g(e) + e = v`` by :func:`_dyn_step`; ``i_max`` is then the largest ``i_h``
    (the branch's amplitude, whose root the search finds), ``i_peak`` and ``wave`` the total
    current's. With both 0 the static step runs unchanged (bit-identical results) and
    ``i_peak = i_max``.

    One compiled loop, long by design: the step's state (the two previous points of BDF2,
    the table cell, the rate-dependent terms, the peak held) lives in locals for the whole
    half period; split into numba functions, every step of the hot loop would pass it on.
    """
    M = x.shape[0]
    h0 = np.pi / n
    h_min = h0 / 64.0
    t_end = phi0 + np.pi
    K = wave.shape[0]
    i_scale = 2.0 * max(abs(x[0]), abs(x[M - 1]))
    l_range = B[M - 1] - B[0]
    inv_i = 1.0 / i_scale if i_scale > 0 else 0.0
    inv_l = 1.0 / l_range if l_range > 0 else 0.0
    dx_last = x[M - 1] - x[M - 2]
    s_ext = (B[M - 1] - B[M - 2]) / dx_last if dx_last > 0 else 0.0
    i = x[0]
    lam = B[0]
    i_max = i
    dyn = c_cl != 0.0 or c_ex != 0.0
    i_tot = i  # total winding current (= i on the static path)
    i_peak = i
    j = 0  # the current lies in cell [x[j], x[j + 1]] (j = M - 1: beyond)
    lam_1 = lam  # flux one step back
    h_1 = 0.0  # previous step (0: none yet)
    lam_2 = lam  # two steps back, and the step before the previous (rate-dependent path)
    h_2 = 0.0
    th = phi0
    s = np.sin(th)
    c = np.cos(th)
    ls = 0.0
    lc = 0.0
    ss = 0.0  # the same trapezoid sums of sin and cos alone (for the flux offset, below)
    sc = 0.0
    if K > 0:
        wave[0, 0] = th
        wave[0, 1] = i
        wave[0, 2] = lam
    steps = 0
    h_try = h0
    ch0 = np.cos(h0)
    sh0 = np.sin(h0)
    w_h0 = w / h0
    coef0 = 1.5 * w_h0
    while th < t_end:
        h = h_try
        if th + h >= t_end - 1e-9 * h0:
            h = t_end - th
            th_new = t_end
        else:
            th_new = th + h
        if h == h0:  # the regular step: rotate the phase
            s_new = s * ch0 + c * sh0
            c_new = c * ch0 - s * sh0
        else:
            s_new = np.sin(th_new)
            c_new = np.cos(th_new)
        v = V * s_new
        a = R
        # Whether the step can still be shortened. The last step of the half period is cut
        # to end at ``t_end`` and may exceed ``h_try`` by up to 1e-9 h0: a step asked to be
        # ``h_min`` can come out a rounding above it, and shortening it again would give
        # the same step forever.
        shrinkable = h > h_min * (1.0 + 1e-6)
        # the step's EMF is e = alpha lam_new - beta (used by the rate-dependent step)
        if h_1 == 0.0:  # trapezoidal first step (second order from the turning point)
            a = 0.5 * R
            coef = w / h
            rhs = coef * lam + 0.5 * (v + V * s) - 0.5 * R * i
            alpha = 2.0 * coef
            beta = alpha * lam + (V * s - R * i_tot)
        elif h == h0 and h_1 == h0:  # BDF2
            coef = coef0
            beta = w_h0 * (2.0 * lam - 0.5 * lam_1)
            rhs = v + beta
            alpha = coef
        else:  # variable-step BDF2
            r = h / h_1
            coef = w * (1.0 + 2.0 * r) / ((1.0 + r) * h)
            beta = (w / h) * ((1.0 + r) * lam - r * r / (1.0 + r) * lam_1)
            rhs = v + beta
            alpha = coef
        j_new = j
        i_new = i
        lam_new = lam
        e_new = 0.0
        jump = False
        if dyn:
            j_new, i_new, lam_new, e_new, flat = _dyn_step(
                x, B, j, i, lam, R, alpha, beta, v, c_cl, c_ex, s_ext
            )
            jump = flat and lam_new > lam
            if e_new < 0.0 and not flat:
                # The flux's extremum lies inside the step (BDF2 lets the flux still rise
                # under a negative EMF): localise it, then hold. Rising on, i_h would creep
                # past the peak by R g(e) / R = c_ex |e|^(1/2), which the square root makes
                # large for the smallest |e|. ``e < 0`` is ``R i_h > v`` (``R g(e) + e`` has
                # the sign of ``e``): the static path's condition, and the same hold, where
                # ``e = 0``, ``g = 0`` and ``i_h = v/R`` (or the current already reached).
                if shrinkable:
                    h_try = max(0.25 * h, h_min)
                    continue
                j_new, i_new, lam_new = _hold_peak(x, B, j, j_new, i, lam, v / R, s_ext)
                e_new = 0.0
        elif a * i + coef * lam < rhs:  # else: the current would fall; hold it
            while j_new < M - 1 and a * x[j_new + 1] + coef * B[j_new + 1] < rhs:
                j_new += 1
            if j_new >= M - 1:  # beyond the tip: the last cell's line
                i_new = x[M - 1] + (rhs - a * x[M - 1] - coef * B[M - 1]) / (a + coef * s_ext)
                lam_new = B[M - 1] + s_ext * (i_new - x[M - 1])
                flat = s_ext == 0.0
            else:
                f0 = a * x[j_new] + coef * B[j_new]
                f1 = a * x[j_new + 1] + coef * B[j_new + 1]
                t = min(max((rhs - f0) / (f1 - f0), 0.0), 1.0)
                i_new = max(x[j_new] + t * (x[j_new + 1] - x[j_new]), i)
                lam_new = B[j_new] + t * (B[j_new + 1] - B[j_new])
                flat = B[j_new + 1] == B[j_new]
            if flat and R * i_new > v:
                # on a flat the EMF is 0 (no flux change), never negative: BDF2's
                # difference quotient overshoots after the kink where the flux stops
                i_new = max(v / R, i)
            elif R * i_new > v and i_new > i:
                # A negative EMF while the current rises: on the ascending branch
                # ``e = B'(i) di/dt >= 0``, so the current's peak (where it meets V sin/R)
                # lies inside the step and BDF2's difference quotient, carrying the flux
                # rate of the steps before, overshoots it -- by a current of order
                # ``|e| / R`` where the cell is nearly flat (the flux stops at a kink into
                # saturation). Locate the peak to ``h_min``, then hold the current there.
                if shrinkable:
                    h_try = max(0.25 * h, h_min)
                    continue
                j_new, i_new, lam_new = _hold_peak(x, B, j, j_new, i, lam, v / R, s_ext)
            jump = flat and lam_new > lam
        move = (i_new - i) * inv_i + (lam_new - lam) * inv_l
        if dyn and h_2 > 0.0 and lam_new > lam and i_new > i:
            # BDF2's local error from the quadratic extrapolation of the flux, as a current
            # through the step's chord: where the EMF collapses into saturation the current
            # is most sensitive to the flux (and the square root makes the EMF's approach
            # to 0 abrupt), while the step moves little
            t0 = -(h_1 + h_2)
            pred = (
                lam_2 * (h_1 + h) * h / ((t0 + h_1) * t0)
                + lam_1 * (h - t0) * h / ((h_1 + t0) * h_1)
                + lam * (h - t0) * (h + h_1) / (t0 * -h_1)
            )
            move += LTE_WEIGHT * abs(lam_new - pred) * (i_new - i) / (lam_new - lam) * inv_i
        if move > dsig and shrinkable and not jump:
            h_try = max(h * max(0.2, 0.8 * dsig / move), h_min)
            continue  # reject; the pointer j is unchanged
        if jump:
            # The flux reached a flat inside this step: there the inductance vanishes
            # and the current jumps to V sin/R. Phase of arrival from the flux rate.
            e_prev = V * s - R * i_tot
            tau = 1.0
            if e_prev > 0:
                tau = min((lam_new - lam) * w / (e_prev * h), 1.0)
            i_jump = V * np.sin(th + tau * h) / R
            if j_new < M - 1:  # not beyond the flat's end (none if it reaches the table's)
                q = j_new
                while q < M - 1 and B[q + 1] == B[q]:
                    q += 1
                if q < M - 1:
                    i_jump = min(i_jump, x[q])
            if i_jump > i_max:
                i_max = i_jump
            if i_jump > i_peak:
                i_peak = i_jump
        # accept
        hh = 0.5 * (th_new - th)
        ls += hh * (lam * s + lam_new * s_new)
        lc += hh * (lam * c + lam_new * c_new)
        ss += hh * (s + s_new)
        sc += hh * (c + c_new)
        h_2 = h_1
        lam_2 = lam_1
        h_1 = h
        lam_1 = lam
        th = th_new
        s = s_new
        c = c_new
        i = i_new
        lam = lam_new
        j = j_new
        if i > i_max:
            i_max = i
        i_tot = i + rate_current(e_new, c_cl, c_ex) if dyn else i
        if i_tot > i_peak:
            i_peak = i_tot
        steps += 1
        if steps < K:
            wave[steps, 0] = th
            wave[steps, 1] = i_tot
            wave[steps, 2] = lam
        h_try = h0 if move <= 0.5 * dsig else min(h0, 2.0 * h_1, h_1 * 0.8 * dsig / move)
        if h_try < h_min:
            h_try = h_min
    # The flux measured from the midpoint of its ends: integrating the EMF by parts leaves
    # the boundary term ``-(lam_start + lam_end)(sin + j cos)(phi0)``, which vanishes only
    # at the exact steady state. Away from it (every amplitude the root search tries) the
    # offset is ``B'(I) G / 2``, and on a steep side (a nearly rectangular loop, ``B'`` of
    # 10^3 H) a ``G`` of 1e-7 A would move the DF by order 1: with the offset removed the
    # coefficients are those of the EMF of the trajectory computed, smooth in ``I``.
    off = 0.5 * (B[0] + lam)
    f = 2.0 / np.pi
    return i_max, (ls - off * ss) * f, (lc - off * sc) * f, float(steps), i_peak


@numba.njit(cache=True)
def _half_periods_rows(x, B, V, R, w, phi0, n, dsig, out, start, stop, c_cl, c_ex):
    M = x.shape[1]
    empty = np.empty((0, 3))
    xr = np.empty(2 * M - 1)
    Br = np.empty(2 * M - 1)
    for p in range(start, stop):
        _refine(x[p], B[p], xr, Br)
        r = _integrate(xr, Br, V[p], R[p], w[p], phi0[p], n, dsig, empty, c_cl[p], c_ex[p])
        for q in range(N_OUT):
            out[p, q] = r[q]


@numba.njit(cache=True, parallel=True)
def _half_periods_parallel(x, B, V, R, w, phi0, n, dsig, out, chunks, c_cl, c_ex):
    P = x.shape[0]
    size = (P + chunks - 1) // chunks
    for c in numba.prange(chunks):
        _half_periods_rows(
            x, B, V, R, w, phi0, n, dsig, out, c * size, min(P, (c + 1) * size), c_cl, c_ex
        )


#: Below this many rows times steps a call runs on one thread even when more are allowed
#: (a parallel region costs more than it saves).
PARALLEL_WORK = 100_000


def half_periods(x, B, V, R, w, phi0, n, dsig, out, threads=1, c_cl=None, c_ex=None):
    """Rising half periods of the rows of the branch tables ``x``, ``B`` (``(P, M)``).

    Per row: amplitude ``V``, resistance ``R``, angular frequency ``w`` and starting phase
    ``phi0``; ``n`` steps, refined where the state moves more than ``dsig``. ``out[p]``
    receives the ``N_OUT`` values of :func:`_integrate` (the table is first made monotone
    and refined, :func:`_refine`). With ``threads > 1`` large calls are split over that
    many of numba's threads (on a machine whose cores are busy this is slower: measured in
    ``benchmarks/bench_voltage.py``). ``c_cl``, ``c_ex`` (``(P,)``, default 0): the
    coefficients of the rate-dependent current (:func:`rate_current`) per row.
    """
    P = x.shape[0]
    c_cl = np.zeros(P) if c_cl is None else kernel_array(c_cl, (P,))
    c_ex = np.zeros(P) if c_ex is None else kernel_array(c_ex, (P,))
    if threads > 1 and P * n >= PARALLEL_WORK:
        # (numba's thread count is asked only here: it costs ~30 us a call, and this runs
        # at every step of every root search)
        chunks = min(int(threads), numba.get_num_threads(), P)
        if chunks > 1:
            _half_periods_parallel(x, B, V, R, w, phi0, n, dsig, out, chunks, c_cl, c_ex)
            return
    _half_periods_rows(x, B, V, R, w, phi0, n, dsig, out, 0, P, c_cl, c_ex)


@numba.njit(cache=True)
def half_period_wave(x, B, V, R, w, phi0, n, dsig, wave, c_cl=0.0, c_ex=0.0):
    """One row of :func:`half_periods`, recording ``theta, i, lam`` of each step into the
    rows of ``wave`` (``(K, 3)``; ``i`` is the total current); returns the values of
    :func:`_integrate`."""
    M = x.shape[0]
    xr = np.empty(2 * M - 1)
    Br = np.empty(2 * M - 1)
    _refine(x, B, xr, Br)
    return _integrate(xr, Br, V, R, w, phi0, n, dsig, wave, c_cl, c_ex)
