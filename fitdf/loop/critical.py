"""The critical gain of harmonic balance: the smallest loop gain with a limit cycle in the box.

For ``G = K G0`` a solution needs ``K = -1 / (G0 N)`` real and positive, so the
solutions of all gains lie on the curve ``arg(G0 N) = -pi`` and the smallest gain is
``1 / max |G0 N|`` along it (:func:`_critical`; the public entry point is
:func:`fitdf.loop.harmonic.critical_gain`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.optimize.elementwise import find_root

from fitdf.loop.nonlinearity import _evaluate_N


def _crossover_peak(H, A_grid, w_grid):
    """Largest ``|H|`` on the curve ``arg H = -pi`` of the grid ``H`` (shape ``(nA, nw)``).

    Returns ``(peak, i, j, w_cross)``: grid row, the cell's left column and the
    interpolated crossing frequency; ``peak = 0`` when the curve does not exist.
    """
    im, re = H.imag, H.real
    s0, s1 = im[:, :-1], im[:, 1:]
    cross = (
        np.isfinite(s0)
        & np.isfinite(s1)
        & (np.sign(s0) != np.sign(s1))
        & (re[:, :-1] < 0)
        & (re[:, 1:] < 0)
    )
    if not cross.any():
        return 0.0, -1, -1, np.nan
    with np.errstate(all="ignore"):
        t = np.where(cross, s0 / (s0 - s1), 0.0)
    mag = np.where(cross, -(re[:, :-1] + t * (re[:, 1:] - re[:, :-1])), -np.inf)
    i, j = np.unravel_index(np.argmax(mag), mag.shape)
    lw = np.log(w_grid)
    return float(mag[i, j]), int(i), int(j), float(np.exp(lw[j] + t[i, j] * (lw[j + 1] - lw[j])))


#: Amplitudes per round of the peak's search along the curve, and rounds: each round
#: spans two spacings of the previous one around its best point, so the spacing shrinks
#: from two grid cells / 16 by 8x a round (to ~1e-5 in ``ln A`` after four, where the
#: peak, flat at its maximum, is within ~1e-10 of its limit).
POLISH_POINTS, POLISH_ROUNDS = 17, 4


def _along(plant, N, gain, u, v_lo, v_hi):
    """Where each ``u = ln A`` meets the curve ``arg(G N) = -pi`` in ``[v_lo, v_hi]`` (``ln omega``):
    ``(-Re(G N) there, v)``, NaN where ``Im(G N)`` has no sign change in the interval or the
    crossing is on the positive real axis. All ``u`` at once: the root in ``v`` by
    :func:`scipy.optimize.elementwise.find_root`, one evaluation of ``N`` per iteration."""

    def H(v, uu):
        w = np.exp(v)
        return plant.response(w, [gain])[0] * _evaluate_N(N, np.exp(uu), w)

    u = np.asarray(u, float)
    ends = H(np.concatenate([np.full(u.shape, v_lo), np.full(u.shape, v_hi)]), np.tile(u, 2)).imag
    a, b = ends[: u.size], ends[u.size :]
    ok = np.isfinite(a) & np.isfinite(b) & (np.sign(a) != np.sign(b))
    peak, v = np.full(u.shape, np.nan), np.full(u.shape, np.nan)
    if ok.any():
        res = find_root(
            lambda vv, uu: H(vv, uu).imag,
            (np.full(ok.sum(), v_lo), np.full(ok.sum(), v_hi)),
            args=(u[ok],),
            tolerances={"xatol": 1e-13, "xrtol": 0.0, "fatol": 0.0, "frtol": 0.0},
        )
        v[ok] = res.x
        h = H(v[ok], u[ok])
        peak[ok] = np.where(h.real < 0, -h.real, np.nan)
    return peak, v


def _peak_polish(plant, N, gain, A_grid, w_grid, i, j):
    """Maximise ``|G N|`` along ``arg(G N) = -pi`` near grid cell ``(i, j)`` (1-D in ln A):
    rounds of :data:`POLISH_POINTS` amplitudes, each around the previous round's best, every
    point of a round in one batched search (:func:`_along`). The edges of the box are tried
    too: the peak may sit exactly on one."""
    lu, lw = np.log(A_grid), np.log(w_grid)
    jl, jh = max(j - 3, 0), min(j + 4, lw.size - 1)
    lo_u, hi_u = lu[max(i - 1, 0)], lu[min(i + 1, lu.size - 1)]
    best = (np.nan, lu[i], np.nan)
    if hi_u > lo_u:
        for _ in range(POLISH_ROUNDS):
            us = np.linspace(lo_u, hi_u, POLISH_POINTS)
            peak, v = _along(plant, N, gain, us, lw[jl], lw[jh])
            if not np.isfinite(peak).any():
                break
            k = int(np.nanargmax(peak))
            best = (peak[k], us[k], v[k])
            spacing = us[1] - us[0]
            lo_u, hi_u = max(us[k] - spacing, us[0]), min(us[k] + spacing, us[-1])
    else:
        peak, v = _along(plant, N, gain, np.array([lu[i]]), lw[jl], lw[jh])
        best = (peak[0], lu[i], v[0])
    edges = [uu for uu in (lu[0], lu[-1]) if abs(uu - best[1]) < 1.5 * (lu[1] - lu[0])]
    if edges:
        p2, v2 = _along(plant, N, gain, np.array(edges), lw[jl], lw[jh])
        for pk, vv, uu in zip(p2, v2, edges):
            if np.isfinite(pk) and (not np.isfinite(best[0]) or pk >= best[0]):
                best = (pk, uu, vv)
    peak, u, v = best
    return float(peak), float(u), float(v)


def _critical(lp, N, A_grid, w_grid, Ngrid, gain_bracket):
    none = {
        "gain": float("inf"),
        "amplitude": float("nan"),
        "omega": float("nan"),
        "at_boundary": False,
    }

    def peak_at(gain):
        return _crossover_peak(lp.response(w_grid, [gain])[0][None, :] * Ngrid, A_grid, w_grid)

    if lp.linear_in_gain:
        k_ref = 1.0
    else:
        lo, hi = np.log(gain_bracket[0]), np.log(gain_bracket[1])
        if peak_at(np.exp(hi))[0] < 1.0:
            return none
        if peak_at(np.exp(lo))[0] >= 1.0:
            hi = lo
        for _ in range(60):  # bisection on ln K of "a solution exists" (grid test)
            if hi - lo < 1e-6:
                break
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if peak_at(np.exp(mid))[0] >= 1.0 else (mid, hi)
        k_ref = float(
            np.exp(
                _polished_root(
                    lambda g: _polished_peak(lp, N, g, A_grid, w_grid, Ngrid)[0] - 1.0, lo, hi
                )
            )
        )
    peak, u, v = _polished_peak(lp, N, k_ref, A_grid, w_grid, Ngrid)
    if not np.isfinite(peak) or peak <= 0:
        return none
    gain = k_ref / peak if lp.linear_in_gain else k_ref
    step = np.log(A_grid[1] / A_grid[0])
    at_edge = bool(
        min(abs(u - np.log(A_grid[0])), abs(u - np.log(A_grid[-1]))) < 1e-6 * max(step, 1)
    )
    return {
        "gain": float(gain),
        "amplitude": float(np.exp(u)),
        "omega": float(np.exp(v)),
        "at_boundary": at_edge,
    }


def _polished_peak(lp, N, gain, A_grid, w_grid, Ngrid):
    """Grid maximum of ``|G N|`` on ``arg(G N) = -pi``, polished; ``(peak, ln A, ln w)``."""
    peak, i, j, w = _crossover_peak(lp.response(w_grid, [gain])[0][None, :] * Ngrid, A_grid, w_grid)
    if peak <= 0:
        return 0.0, np.nan, np.nan
    pk, u, v = _peak_polish(lp, N, gain, A_grid, w_grid, i, j)
    if np.isfinite(pk) and pk >= peak * (1 - 1e-9):
        return pk, u, v
    return peak, float(np.log(A_grid[i])), float(np.log(w))


def _polished_root(f, lo, hi):
    """Root of ``f(exp(x))`` near the grid bracket ``[lo, hi]`` of ``ln K`` (widened until it brackets)."""
    a, b = lo, hi
    fa, fb = f(np.exp(a)), f(np.exp(b))
    for _ in range(20):
        if fa < 0 <= fb:
            return brentq(lambda x: f(np.exp(x)), a, b, xtol=1e-12)
        width = b - a + 1e-6
        if fa >= 0:
            a -= width
            fa = f(np.exp(a))
        if fb < 0:
            b += width
            fb = f(np.exp(b))
    return hi
