"""Compiled kernels of the ``voltage`` chain (:mod:`fitdf.chains.voltage`).

Three entry points, each compiled for one float64 signature (``cache=True``):

* :func:`place_nodes` -- where to tabulate a branch, from a coarse table of it;
* :func:`half_periods` -- the rising half period of many points at once (``prange``):
  the peak current reached and the first harmonics of flux linkage and current;
* :func:`half_period_wave` -- the same for one point, recording the waveform.

The method and its accuracy are described in :mod:`fitdf.chains.voltage`.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["place_nodes", "half_periods", "half_period_wave", "N_OUT"]

#: Columns of :func:`half_periods`' output: peak current, flux harmonics (sin, cos),
#: current harmonics (sin, cos).
N_OUT = 5


@numba.njit(cache=True, parallel=True)
def place_nodes(u0, B0, weights, out):
    """Nodes ``out[p]`` (``M`` values from ``u0[0]`` to ``u0[-1]``) for the branch ``B0[p]``.

    ``B0[p]`` is a coarse table of the branch at the normalised currents ``u0``. The nodes
    equidistribute ``wx |du|/2 + wy |dB|/range + wk |d angle|/pi`` (``weights = (wx, wy,
    wk)``) along it, the angle being that of the chords of the normalised curve and each
    change of angle shared by the two cells next to it: the current range, the steep parts
    (the flux swing of a saturated core) and the bends (kinks, knees) all get nodes.
    """
    P, M0 = B0.shape
    M = out.shape[1]
    wx, wy, wk = weights[0], weights[1], weights[2]
    for p in numba.prange(P):
        b = B0[p]
        hb = np.empty(M0)
        m = b[0]
        for j in range(M0):
            if b[j] > m:
                m = b[j]
            hb[j] = m
        rng = hb[M0 - 1] - hb[0]
        inv = 1.0 / rng if rng > 0 and np.isfinite(rng) else 0.0
        ang = np.empty(M0 - 1)
        for j in range(M0 - 1):
            ang[j] = np.arctan2((hb[j + 1] - hb[j]) * inv, 0.5 * (u0[j + 1] - u0[j]))
        S = np.empty(M0)
        S[0] = 0.0
        for j in range(M0 - 1):
            d = wx * 0.5 * (u0[j + 1] - u0[j]) + wy * (hb[j + 1] - hb[j]) * inv
            if j > 0:
                d += wk * 0.5 * abs(ang[j] - ang[j - 1]) / np.pi
            if j < M0 - 2:
                d += wk * 0.5 * abs(ang[j + 1] - ang[j]) / np.pi
            S[j + 1] = S[j] + d
        total = S[M0 - 1]
        j = 0
        out[p, 0] = u0[0]
        for q in range(1, M - 1):
            target = total * q / (M - 1)
            while j < M0 - 2 and S[j + 1] < target:
                j += 1
            d = S[j + 1] - S[j]
            t = (target - S[j]) / d if d > 0 else 0.0
            out[p, q] = u0[j] + t * (u0[j + 1] - u0[j])
        out[p, M - 1] = u0[M0 - 1]


@numba.njit(cache=True)
def _refine(x, B, xr, Br):
    """Monotone hull of the table ``(x, B)``, each cell split in two (``2M - 1`` nodes).

    ``B`` is replaced by its running maximum: the flux cannot fall while the current
    rises (a falling part becomes a flat, across which the current jumps). Every cell gets
    an interior node: where the two cells on either side are straight (slopes equal to
    ``1e-9`` of the table's slope scale) and their lines meet inside it, at that
    intersection -- the exact kink of a piecewise-linear branch, wherever it falls --
    otherwise at the chord's midpoint (no change).
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
        if 2 <= j <= M - 4:
            sl = s[j - 1]
            sr = s[j + 1]
            if abs(sl - s[j - 2]) <= tol and abs(s[j + 2] - sr) <= tol and abs(sl - sr) > 1e3 * tol:
                xs = (hb[j + 1] - hb[j] - sr * x[j + 1] + sl * x[j]) / (sl - sr)
                if x[j] < xs < x[j + 1]:
                    xm = xs
                    bm = min(max(hb[j] + sl * (xs - x[j]), hb[j]), hb[j + 1])
        xr[2 * j + 1] = xm
        Br[2 * j + 1] = bm
    xr[2 * M - 2] = x[M - 1]
    Br[2 * M - 2] = hb[M - 1]


@numba.njit(cache=True)
def _integrate(x, B, V, R, w, phi0, n, wave_i, wave_l):
    """One rising half period of ``R i + w dlam/dtheta = V sin(theta)``, ``lam = B(i)``.

    ``(x, B)``: the branch, non-decreasing, linear between nodes and flat beyond the last.
    Starts at ``i = x[0]`` at ``theta = phi0`` and runs to ``phi0 + pi`` in ``n`` steps:
    BDF2 (backward Euler first), each step's implicit equation
    ``R i + c B(i) = rhs`` solved exactly on the table with a pointer that only moves
    forward; once the current would fall (past its maximum) it is held.

    Returns ``(i_max, ls, lc, cs, cc)``: the largest current reached -- including, when a
    step lands on a flat (zero inductance, the current jumps), the current ``V sin/R`` at
    the phase where the flux reached the flat, found by extrapolating the flux over the
    step -- and ``(2/pi) int lam sin``, ``(2/pi) int lam cos``, the same for ``i``, over
    the half period (trapezoid rule), the full-period Fourier coefficients under half-wave
    symmetry. ``wave_i``, ``wave_l`` (length ``n + 1``, or 0) receive the samples.
    """
    M = x.shape[0]
    h = np.pi / n
    rec = wave_i.shape[0] > 0
    i = x[0]
    lam = B[0]
    i_max = i
    j = 0                # the current lies in cell [x[j], x[j + 1]] (j = M - 1: beyond)
    lam_1 = lam          # flux one step back
    s = np.sin(phi0)
    c = np.cos(phi0)
    ls = 0.5 * lam * s
    lc = 0.5 * lam * c
    cs = 0.5 * i * s
    cc = 0.5 * i * c
    if rec:
        wave_i[0] = i
        wave_l[0] = lam
    ch = np.cos(h)
    sh = np.sin(h)
    for k in range(1, n + 1):
        s_prev = s
        if k % 64 == 0:   # phases by rotation, re-anchored against drift
            s = np.sin(phi0 + k * h)
            c = np.cos(phi0 + k * h)
        else:
            s, c = s * ch + c * sh, c * ch - s * sh
        v = V * s
        if k == 1:
            coef = w / h
            rhs = v + coef * lam
        else:
            coef = 1.5 * w / h
            rhs = v + (w / h) * (2.0 * lam - 0.5 * lam_1)
        lam_1 = lam
        lam_prev = lam
        i_prev = i
        if R * i + coef * lam < rhs:    # else: the current would fall; hold it
            while j < M - 1 and R * x[j + 1] + coef * B[j + 1] < rhs:
                j += 1
            if j >= M - 1:
                i = (rhs - coef * B[M - 1]) / R
                lam = B[M - 1]
                flat = True
            else:
                f0 = R * x[j] + coef * B[j]
                f1 = R * x[j + 1] + coef * B[j + 1]
                t = (rhs - f0) / (f1 - f0)
                t = min(max(t, 0.0), 1.0)
                i_new = x[j] + t * (x[j + 1] - x[j])
                if i_new > i:
                    i = i_new
                lam = B[j] + t * (B[j + 1] - B[j])
                flat = B[j + 1] == B[j]
            if flat and lam > lam_prev:
                # The flux reached a flat inside this step: there the inductance vanishes
                # and the current jumps to V sin/R. Phase of arrival from the flux rate.
                e_prev = V * s_prev - R * i_prev
                tau = 1.0
                if e_prev > 0:
                    tau = min((lam - lam_prev) * w / (e_prev * h), 1.0)
                th = phi0 + (k - 1 + tau) * h
                i_jump = V * np.sin(th) / R
                if j < M - 1:       # not beyond the flat's end (none if it reaches the table's)
                    q = j
                    while q < M - 1 and B[q + 1] == B[q]:
                        q += 1
                    if q < M - 1:
                        i_jump = min(i_jump, x[q])
                if i_jump > i_max:
                    i_max = i_jump
        if i > i_max:
            i_max = i
        wt = 0.5 if k == n else 1.0
        ls += wt * lam * s
        lc += wt * lam * c
        cs += wt * i * s
        cc += wt * i * c
        if rec:
            wave_i[k] = i
            wave_l[k] = lam
    f = 2.0 * h / np.pi
    return i_max, ls * f, lc * f, cs * f, cc * f


@numba.njit(cache=True, parallel=True)
def half_periods(x, B, V, R, w, phi0, n, out):
    """Rising half periods of the rows of the branch tables ``x``, ``B`` (``(P, M)``).

    Per row: amplitude ``V``, resistance ``R``, angular frequency ``w`` and starting phase
    ``phi0``; ``n`` steps. ``out[p]`` receives the ``N_OUT`` values of :func:`_integrate`
    (the table is first made monotone and refined, :func:`_refine`).
    """
    P, M = x.shape
    empty = np.empty(0)
    for p in numba.prange(P):
        xr = np.empty(2 * M - 1)
        Br = np.empty(2 * M - 1)
        _refine(x[p], B[p], xr, Br)
        r = _integrate(xr, Br, V[p], R[p], w[p], phi0[p], n, empty, empty)
        for q in range(N_OUT):
            out[p, q] = r[q]


@numba.njit(cache=True)
def half_period_wave(x, B, V, R, w, phi0, n, wave_i, wave_l):
    """One row of :func:`half_periods`, recording current and flux (``n + 1`` samples each)
    into ``wave_i`` and ``wave_l``; returns the values of :func:`_integrate`."""
    M = x.shape[0]
    xr = np.empty(2 * M - 1)
    Br = np.empty(2 * M - 1)
    _refine(x, B, xr, Br)
    return _integrate(xr, Br, V, R, w, phi0, n, wave_i, wave_l)
