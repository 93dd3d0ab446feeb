"""The critical gain of harmonic balance: the smallest loop gain with a limit cycle in the box.

For ``G = K G0`` a solution needs ``K = -1 / (G0 N)`` real and positive, so the
solutions of all gains lie on the curve ``arg(G0 N) = -pi`` and the smallest gain is
``1 / max |G0 N|`` along it (:func:`_critical`; the public entry point is
:func:`fitdf.loop.harmonic.critical_gain`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq, minimize_scalar

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


def _peak_polish(plant, N, gain, A_grid, w_grid, i, j):
    """Maximise ``|G N|`` along ``arg(G N) = -pi`` near grid cell ``(i, j)`` (1-D in ln A)."""
    lu, lw = np.log(A_grid), np.log(w_grid)
    jl, jh = max(j - 3, 0), min(j + 4, lw.size - 1)

    def along(u):
        def imag(v):
            return (
                plant.response([np.exp(v)], [gain])[0, 0]
                * _evaluate_N(N, np.array([np.exp(u)]), np.array([np.exp(v)]))[0]
            ).imag

        a, b = imag(lw[jl]), imag(lw[jh])
        if not (np.isfinite(a) and np.isfinite(b)) or np.sign(a) == np.sign(b):
            return np.nan, np.nan
        v = brentq(imag, lw[jl], lw[jh], xtol=1e-13)
        H = (
            plant.response([np.exp(v)], [gain])[0, 0]
            * _evaluate_N(N, np.array([np.exp(u)]), np.array([np.exp(v)]))[0]
        )
        return (-H.real if H.real < 0 else np.nan), v

    lo_u, hi_u = lu[max(i - 1, 0)], lu[min(i + 1, lu.size - 1)]
    if hi_u > lo_u:
        res = minimize_scalar(
            lambda u: -np.nan_to_num(along(u)[0], nan=0.0),
            bounds=(lo_u, hi_u),
            method="bounded",
            options={"xatol": 1e-10},
        )
        u = float(res.x)
    else:
        u = lu[i]
    peak, v = along(u)
    for uu in (lu[0], lu[-1]):  # the peak may sit exactly on an edge of the box
        if abs(uu - u) < 1.5 * (lu[1] - lu[0]):
            p2, v2 = along(uu)
            if np.isfinite(p2) and (not np.isfinite(peak) or p2 >= peak):
                peak, v, u = p2, v2, uu
    return peak, u, v


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
