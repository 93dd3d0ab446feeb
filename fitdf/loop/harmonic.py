"""Limit cycles by harmonic balance with amplitude- and frequency-dependent DFs (thesis V.6).

A loop of a linear plant ``G(s)`` and a nonlinear element with describing function
``N(A, omega)`` (error -> element -> plant -> output, unity negative feedback, Fig 5.12)
can hold a sinusoid of amplitude ``A`` (at the element's input) and frequency ``omega``
when the first harmonic balances::

    F(A, omega) = 1 + G(j omega) N(A, omega) = 0,    i.e.   G(j omega) = -1 / N(A, omega).

:func:`limit_cycles` finds *every* solution inside a box of amplitudes and
frequencies: ``F`` on a coarse log-spaced grid (one vectorised evaluation of ``N``),
candidate cells where both ``Re F`` and ``Im F`` change sign or ``|F|`` has a small
local minimum, refinement of each candidate with :func:`scipy.optimize.least_squares`
on ``(ln A, ln omega)`` of ``[ln|G N|, arg(-G N)]``, and de-duplication. The loop gain
``K`` (``G = K G0``) is swept, and the gain below which no solution exists is found
(:func:`critical_gain`).

Stability (Loeb's criterion, extended to ``N(A, omega)``)
-------------------------------------------------------------
Perturb a solution ``(A0, omega0)``: the amplitude becomes ``A0 + dA`` and the
oscillation ``exp((sigma + j omega) t)`` grows or decays slowly at the rate ``sigma``
(Krylov-Bogoliubov, thesis IV.1). Harmonic balance for the perturbed oscillation is
``F(A0 + dA, s) = 0`` with ``s = sigma + j(omega0 + d omega)``. Take ``F`` analytic in
``s`` -- true for ``G``, and an assumption for a frequency-dependent ``N``: that
``N(A, s / j)`` continues ``N(A, omega)`` analytically off the imaginary axis. Then by
Cauchy-Riemann ``dF/ds = -j dF/domega``, and to first order
``F_A dA + F_omega (d omega - j sigma) = 0``. With ``F = U + jV``, the real and
imaginary parts give ``sigma = dA (V_A U_w - U_A V_w) / (U_w^2 + V_w^2)``. The cycle is
stable when a larger amplitude decays (``sigma < 0`` for ``dA > 0``)::

    dU/dA dV/domega - dU/domega dV/dA > 0      (stable),     < 0 (unstable),

i.e. ``Im(conj(F_A) F_omega) > 0``: Loeb's criterion, unchanged in form, but with the
partial derivatives of ``F`` taken *through* ``N``'s dependence on ``omega`` as well.
For a frequency-independent ``N`` it reduces to the textbook rule (the plant locus
``G(j omega)``, traversed with increasing ``omega``, has the critical locus point for a
larger amplitude on its left). ``loeb`` reports ``Im(conj(F_A) F_w) / (|F_A| |F_w|)``
(derivatives in ``ln A``, ``ln omega``), the sine of the crossing angle: near 0 the
verdict is fragile.

Measured cores lead (Fig 5.10), so their ``-1/N`` loci lie in the second quadrant and
the intersections with the plant locus are there (Graphs 5.21, 5.22).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd
from scipy.optimize import brentq, least_squares, minimize_scalar

from fitdf.errors import OptionError
from fitdf.loop.plant import LoopPlant, as_loop_plant

__all__ = ["limit_cycles", "critical_gain", "LimitCycle", "LimitCycleResponse", "as_describing_function",
           "thesis_limit_cycle_comparison", "estimate_thesis_scales", "THESIS_PLANT", "THESIS_BLOCKS",
           "limit_cycle_command", "format_limit_cycle_table"]

#: Accept a refined root when ``|ln|GN|| + |arg(-GN)|`` is below this.
ROOT_TOL = 1e-9
#: Two roots closer than this in ``ln A`` and ``ln omega`` are one.
DEDUP_TOL = 1e-6


# ---------------------------------------------------------------- inputs
def as_describing_function(nonlinearity, source_impedance: float = 0.0):
    """``(N(A, omega), default amplitude range, label)`` for a fitted result or a callable.

    A fitted result (anything with ``predict(amplitude, frequency_hz, source_impedance)``)
    gives the *measured* DF of the core at ``source_impedance`` -- the element the
    thesis put in the loop; its default amplitude range is that of the rows it was
    fitted to. A callable must take ``(A, omega)`` (rad/s) and broadcast.
    """
    if hasattr(nonlinearity, "predict"):
        fitted = nonlinearity
        rs = float(source_impedance)

        def N(A, omega):
            return fitted.predict(A, np.asarray(omega, float) / (2.0 * np.pi), rs)

        rng = None
        data = getattr(getattr(fitted, "problem", None), "data", None)
        if data is not None:
            amp = np.asarray(data.amplitude, float)
            amp = amp[amp > 0]
            if amp.size:
                rng = (float(amp.min()), float(amp.max()))
        label = f"{getattr(fitted, 'model', 'fit')} ({getattr(fitted, 'chain', '')}) at {rs:g} ohm"
        return N, rng, label
    if callable(nonlinearity):
        return nonlinearity, None, getattr(nonlinearity, "__name__", "N")
    raise OptionError(f"cannot use a {type(nonlinearity).__name__} as a nonlinearity; give a fitted "
                      "result or a callable N(A, omega)")


def _evaluate_N(N, A, omega):
    """``N`` on the broadcast of ``A`` and ``omega``, NaN where it is not finite."""
    A, omega = np.broadcast_arrays(np.asarray(A, float), np.asarray(omega, float))
    with np.errstate(all="ignore"):
        out = np.broadcast_to(np.asarray(N(A, omega), complex), A.shape).copy()
    out[~np.isfinite(out)] = np.nan
    return out


# ---------------------------------------------------------------- results
@dataclass(frozen=True)
class LimitCycle:
    """One solution of ``1 + G(j omega) N(A, omega) = 0``.

    Attributes
    ----------
    gain : float
        Loop gain ``K``.
    amplitude : float
        Amplitude at the element's input (= plant output, unity feedback).
    omega : float
        Angular frequency (rad/s).
    stable : bool
        Loeb's criterion (module docstring).
    loeb : float
        Sine of the angle between ``F_A`` and ``F_omega``; positive = stable.
    N, G : complex
        The DF and the plant's frequency response at the solution.
    residual : float
        ``|ln|GN|| + |arg(-GN)|`` after refinement.
    """

    gain: float
    amplitude: float
    omega: float
    stable: bool
    loeb: float
    N: complex
    G: complex
    residual: float

    @property
    def frequency_hz(self) -> float:
        return self.omega / (2.0 * np.pi)

    def to_dict(self) -> dict:
        return {"gain": self.gain, "amplitude": self.amplitude, "omega_rad_s": self.omega,
                "frequency_hz": self.frequency_hz, "stable": bool(self.stable), "loeb": self.loeb,
                "df_magnitude": float(abs(self.N)), "df_phase_deg": float(np.angle(self.N, deg=True)),
                "plant_magnitude": float(abs(self.G)), "plant_phase_deg": float(np.angle(self.G, deg=True)),
                "residual": self.residual}


@dataclass(frozen=True)
class LimitCycleResponse:
    """All intersections of a gain sweep, the critical gain, and what is needed to plot them.

    Attributes
    ----------
    plant_label, nonlinearity_label : str
    gains : numpy.ndarray
    intersections : tuple of LimitCycle
        Every solution found, for every gain (ordered by gain, then amplitude).
    critical_gain : float
        Smallest ``K`` with a solution in the box (``inf``: none at any gain).
    critical_point : dict
        ``amplitude``, ``omega`` where the first solution appears, and ``at_boundary``
        (True when that is an edge of the amplitude box: the cycle then shrinks to the
        edge rather than appearing as a double root).
    amplitude_range, omega_range : tuple of float
    """

    plant_label: str
    nonlinearity_label: str
    gains: np.ndarray
    intersections: tuple
    critical_gain: float
    critical_point: dict
    amplitude_range: tuple
    omega_range: tuple
    plant: LoopPlant = field(repr=False, compare=False)
    describing_function: Callable = field(repr=False, compare=False)

    def at_gain(self, gain) -> list:
        return [c for c in self.intersections if np.isclose(c.gain, gain, rtol=1e-12, atol=0)]

    def table(self) -> pd.DataFrame:
        """One row per intersection; gains without any get a row of NaN (``oscillation`` False)."""
        rows = []
        for g in self.gains:
            found = self.at_gain(g)
            for c in found:
                rows.append({**c.to_dict(), "oscillation": True})
            if not found:
                rows.append({"gain": float(g), "amplitude": np.nan, "omega_rad_s": np.nan, "frequency_hz": np.nan,
                             "stable": False, "loeb": np.nan, "df_magnitude": np.nan, "df_phase_deg": np.nan,
                             "plant_magnitude": np.nan, "plant_phase_deg": np.nan, "residual": np.nan,
                             "oscillation": False})
        return pd.DataFrame(rows)

    def stable_cycles(self, which: str = "largest") -> pd.DataFrame:
        """One row per gain: the stable cycle (largest or smallest amplitude), NaN if none."""
        t = self.table()
        rows = []
        for g in self.gains:
            s = t[(t["gain"] == g) & t["stable"]]
            if s.empty:
                rows.append({"gain": float(g), "amplitude": np.nan, "omega_rad_s": np.nan, "frequency_hz": np.nan,
                             "n_stable": 0})
            else:
                r = s.sort_values("amplitude").iloc[-1 if which == "largest" else 0]
                rows.append({"gain": float(g), "amplitude": r["amplitude"], "omega_rad_s": r["omega_rad_s"],
                             "frequency_hz": r["frequency_hz"], "n_stable": len(s)})
        return pd.DataFrame(rows)

    def to_dict(self) -> dict:
        return {"plant": self.plant_label, "nonlinearity": self.nonlinearity_label,
                "gains": [float(g) for g in self.gains], "critical_gain": _finite(self.critical_gain),
                "critical_point": {k: (_finite(v) if isinstance(v, float) else v)
                                   for k, v in self.critical_point.items()},
                "amplitude_range": list(self.amplitude_range), "omega_range": list(self.omega_range),
                "intersections": [c.to_dict() for c in self.intersections]}

    def plot(self, **kwargs):
        """Nyquist-plane figure (Graphs 5.21/5.22); see :func:`fitdf.plots.limitcycle.plot_nyquist`."""
        from fitdf.plots.limit_cycles import plot_nyquist

        return plot_nyquist(self, **kwargs)


def _finite(v):
    v = float(v)
    return v if np.isfinite(v) else None


# ---------------------------------------------------------------- the solver
def _default_omega_range(plant: LoopPlant):
    corners = plant.corner_frequencies()
    if corners.size == 0:
        return (1e-2, 1e2)
    return (float(corners.min()) / 30.0, float(corners.max()) * 30.0)


def _candidates(F, max_candidates):
    """Grid indices ``(i, j)`` of cells that may hold a root of ``F`` (shape ``(nA, nw)``)."""
    valid = np.isfinite(F)
    re, im = F.real > 0, F.imag > 0

    def changes(b):
        corners = np.stack([b[:-1, :-1], b[1:, :-1], b[:-1, 1:], b[1:, 1:]])
        return corners.any(axis=0) & ~corners.all(axis=0)

    ok = valid[:-1, :-1] & valid[1:, :-1] & valid[:-1, 1:] & valid[1:, 1:]
    cells = changes(re) & changes(im) & ok
    mag = np.where(valid, np.abs(F), np.inf)
    ci, cj = np.nonzero(cells)
    # start each refinement at the cell's corner of smallest |F|
    corner_mag = np.stack([mag[ci, cj], mag[ci + 1, cj], mag[ci, cj + 1], mag[ci + 1, cj + 1]])
    k = np.argmin(corner_mag, axis=0)
    pi, pj = ci + (k % 2), cj + (k // 2)
    score = corner_mag.min(axis=0) if ci.size else np.zeros(0)
    # tangential touches (a double root near the critical gain) change no sign: local minima
    pad = np.pad(mag, 1, constant_values=np.inf)
    neigh = np.min([pad[1 + di:pad.shape[0] - 1 + di, 1 + dj:pad.shape[1] - 1 + dj]
                    for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj], axis=0)
    mi, mj = np.nonzero((mag < neigh) & (mag < 0.05))
    pi, pj = np.concatenate([pi, mi]), np.concatenate([pj, mj])
    score = np.concatenate([score, mag[mi, mj]])
    order = np.argsort(score, kind="stable")[:max_candidates]
    pts = np.unique(np.stack([pi[order], pj[order]], axis=1), axis=0)
    return pts


def _log_residual(H):
    """``[ln|H|, arg(-H)]``: zero exactly at ``H = -1``; finite everywhere."""
    if not np.isfinite(H) or H == 0:
        return np.array([50.0, np.pi])
    return np.array([np.log(abs(H)), np.angle(-H)])


def _refine(plant, N, gain, u0, v0, bounds):
    def fun(x):
        A, w = np.exp(x)
        H = plant.response([w], [gain])[0, 0] * _evaluate_N(N, np.array([A]), np.array([w]))[0]
        return _log_residual(H)

    x0 = np.clip([u0, v0], bounds[0], bounds[1])
    sol = least_squares(fun, x0, bounds=bounds, method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                        x_scale=1.0, diff_step=1e-9, max_nfev=400)
    return sol.x, float(np.sum(np.abs(sol.fun)))


def _loeb(plant, N, gain, u, v, h=1e-6):
    """``Im(conj(F_A) F_w) / (|F_A||F_w|)`` by central differences in ``ln A``, ``ln omega``."""
    us = np.array([u + h, u - h, u, u])
    vs = np.array([v, v, v + h, v - h])
    G = plant.response(np.exp(vs), [gain])[0]
    F = 1.0 + G * _evaluate_N(N, np.exp(us), np.exp(vs))
    Fa, Fw = (F[0] - F[1]) / (2 * h), (F[2] - F[3]) / (2 * h)
    den = abs(Fa) * abs(Fw)
    return float((np.conj(Fa) * Fw).imag / den) if den > 0 and np.isfinite(den) else float("nan")


def _solve_gain(plant, N, gain, A_grid, w_grid, Ngrid, Ggrid, max_candidates):
    F = 1.0 + Ggrid[None, :] * Ngrid
    pts = _candidates(F, max_candidates)
    lu, lv = np.log(A_grid), np.log(w_grid)
    bounds = (np.array([lu[0], lv[0]]), np.array([lu[-1], lv[-1]]))
    found = []
    for i, j in pts:   # a handful of candidates per gain, each refined by scipy
        x, res = _refine(plant, N, gain, lu[i], lv[j], bounds)
        if res > ROOT_TOL:
            continue
        if any(abs(x[0] - y[0]) < DEDUP_TOL and abs(x[1] - y[1]) < DEDUP_TOL for y, _ in found):
            continue
        found.append((x, res))
    out = []
    for x, res in found:
        A, w = np.exp(x)
        Gv = plant.response([w], [gain])[0, 0]
        Nv = _evaluate_N(N, np.array([A]), np.array([w]))[0]
        lo = _loeb(plant, N, gain, x[0], x[1])
        out.append(LimitCycle(gain=float(gain), amplitude=float(A), omega=float(w), stable=bool(lo > 0),
                              loeb=lo, N=complex(Nv), G=complex(Gv), residual=res))
    return sorted(out, key=lambda c: c.amplitude)


def _crossover_peak(H, A_grid, w_grid):
    """Largest ``|H|`` on the curve ``arg H = -pi`` of the grid ``H`` (shape ``(nA, nw)``).

    Returns ``(peak, i, j, w_cross)``: grid row, the cell's left column and the
    interpolated crossing frequency; ``peak = 0`` when the curve does not exist.
    """
    im, re = H.imag, H.real
    s0, s1 = im[:, :-1], im[:, 1:]
    cross = np.isfinite(s0) & np.isfinite(s1) & (np.sign(s0) != np.sign(s1)) & (re[:, :-1] < 0) & (re[:, 1:] < 0)
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
            return (plant.response([np.exp(v)], [gain])[0, 0]
                    * _evaluate_N(N, np.array([np.exp(u)]), np.array([np.exp(v)]))[0]).imag
        a, b = imag(lw[jl]), imag(lw[jh])
        if not (np.isfinite(a) and np.isfinite(b)) or np.sign(a) == np.sign(b):
            return np.nan, np.nan
        v = brentq(imag, lw[jl], lw[jh], xtol=1e-13)
        H = plant.response([np.exp(v)], [gain])[0, 0] * _evaluate_N(N, np.array([np.exp(u)]), np.array([np.exp(v)]))[0]
        return (-H.real if H.real < 0 else np.nan), v

    lo_u, hi_u = lu[max(i - 1, 0)], lu[min(i + 1, lu.size - 1)]
    if hi_u > lo_u:
        res = minimize_scalar(lambda u: -np.nan_to_num(along(u)[0], nan=0.0), bounds=(lo_u, hi_u),
                              method="bounded", options={"xatol": 1e-10})
        u = float(res.x)
    else:
        u = lu[i]
    peak, v = along(u)
    for uu in (lu[0], lu[-1]):   # the peak may sit exactly on an edge of the box
        if abs(uu - u) < 1.5 * (lu[1] - lu[0]):
            p2, v2 = along(uu)
            if np.isfinite(p2) and (not np.isfinite(peak) or p2 >= peak):
                peak, v, u = p2, v2, uu
    return peak, u, v


def critical_gain(plant, nonlinearity, *, amplitude_range=None, omega_range=None, source_impedance=0.0,
                  n_amplitude=160, n_omega=320, gain_bracket=(1e-6, 1e9), time_scale=1.0) -> dict:
    """The gain below which no limit cycle exists in the amplitude box.

    For ``G = K G0`` a solution needs ``K = -1 / (G0 N)`` real and positive, so the
    solutions of all gains lie on the curve ``arg(G0 N) = -pi`` and the smallest gain is
    ``1 / max |G0 N|`` along it. That maximum is taken directly (grid, then a 1-D
    polish); it equals the limit of a bisection on ``K`` of "a solution exists", without
    relying on sign changes that vanish where the first solution appears as a double
    root. When ``K`` enters the plant non-linearly, the same test (``max |G_K N| >= 1``
    along the curve) is bisected on ``ln K`` inside ``gain_bracket``.

    Returns
    -------
    dict
        ``gain`` (``inf`` if none), ``amplitude``, ``omega`` and ``at_boundary``.
    """
    lp = as_loop_plant(plant, time_scale)
    N, a_rng, _ = as_describing_function(nonlinearity, source_impedance)
    A_grid, w_grid = _grids(lp, a_rng, amplitude_range, omega_range, n_amplitude, n_omega)
    Ngrid = _evaluate_N(N, A_grid[:, None], w_grid[None, :])
    return _critical(lp, N, A_grid, w_grid, Ngrid, gain_bracket)


def _critical(lp, N, A_grid, w_grid, Ngrid, gain_bracket):
    none = {"gain": float("inf"), "amplitude": float("nan"), "omega": float("nan"), "at_boundary": False}

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
        for _ in range(60):   # bisection on ln K of "a solution exists" (grid test)
            if hi - lo < 1e-6:
                break
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if peak_at(np.exp(mid))[0] >= 1.0 else (mid, hi)
        k_ref = float(np.exp(_polished_root(lambda g: _polished_peak(lp, N, g, A_grid, w_grid, Ngrid)[0] - 1.0,
                                            lo, hi)))
    peak, u, v = _polished_peak(lp, N, k_ref, A_grid, w_grid, Ngrid)
    if not np.isfinite(peak) or peak <= 0:
        return none
    gain = k_ref / peak if lp.linear_in_gain else k_ref
    step = np.log(A_grid[1] / A_grid[0])
    at_edge = bool(min(abs(u - np.log(A_grid[0])), abs(u - np.log(A_grid[-1]))) < 1e-6 * max(step, 1))
    return {"gain": float(gain), "amplitude": float(np.exp(u)), "omega": float(np.exp(v)), "at_boundary": at_edge}


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


def _grids(lp, a_rng, amplitude_range, omega_range, n_amplitude, n_omega):
    amplitude_range = amplitude_range or a_rng
    if amplitude_range is None:
        raise OptionError("amplitude_range is needed for a callable nonlinearity, e.g. (0.01, 10)")
    omega_range = omega_range or _default_omega_range(lp)
    for name, (lo, hi) in (("amplitude_range", amplitude_range), ("omega_range", omega_range)):
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise OptionError(f"{name} must be two positive numbers, low < high; got ({lo}, {hi})")
    if n_amplitude < 8 or n_omega < 8:
        raise OptionError("the grids need at least 8 amplitudes and 8 frequencies")
    return (np.geomspace(*amplitude_range, int(n_amplitude)), np.geomspace(*omega_range, int(n_omega)))


def limit_cycles(plant, nonlinearity, gains=None, *, amplitude_range=None, omega_range=None,
                 source_impedance=0.0, n_amplitude=160, n_omega=320, max_candidates=40,
                 time_scale=1.0) -> LimitCycleResponse:
    """Every limit cycle of the loop ``plant`` + ``nonlinearity``, for every gain (thesis V.6).

    Parameters
    ----------
    plant : str, (num, den), control.TransferFunction or LoopPlant
        ``G0(s)``; text may contain the gain symbol ``K`` (:func:`fitdf.loop.plant.parse_plant`).
        Without ``K`` the loop is ``K G0``.
    nonlinearity : fitted result or callable
        A fitted result (``predict(amplitude, frequency_hz, source_impedance)``, the
        measured DF of the core, volts in and out) or any vectorised ``N(A, omega)``.
    gains : array_like, optional
        Loop gains ``K`` to solve at (default 1; required when the text uses ``K``).
    amplitude_range : (float, float), optional
        Box of amplitudes searched; default: the fitted data's range (required for a
        callable).
    omega_range : (float, float), optional
        Box of angular frequencies (rad/s); default: the plant's corner frequencies
        / 30 and x 30.
    source_impedance : float
        Source resistance (ohm) at which a fitted core's DF is taken.
    n_amplitude, n_omega : int
        Coarse grid sizes (log-spaced).
    max_candidates : int
        Refinements per gain at most (best candidates first).
    time_scale : float
        Use ``G(s / time_scale)`` (see :func:`as_loop_plant`).

    Returns
    -------
    LimitCycleResponse

    Examples
    --------
    A relay with hysteresis (``M = 1``, ``h = 0.1``) in a loop with ``1/(s(s+1)(s+2))``:

    >>> import numpy as np
    >>> def relay(A, w):
    ...     return 4 / (np.pi * A) * (np.sqrt(1 - (0.1 / A) ** 2) - 1j * 0.1 / A)
    >>> r = limit_cycles("K/(s(s+1)(s+2))", relay, gains=[1.0], amplitude_range=(0.11, 10))
    >>> c = r.intersections[0]
    >>> round(c.amplitude, 4), round(c.omega, 4), c.stable
    (0.3684, 1.053, True)
    """
    lp = as_loop_plant(plant, time_scale)
    N, a_rng, n_label = as_describing_function(nonlinearity, source_impedance)
    if gains is None:
        if lp.has_gain:
            raise OptionError("the plant contains K: give the gains to use")
        gains = [1.0]
    gains = np.atleast_1d(np.asarray(gains, float))
    if gains.ndim != 1 or gains.size == 0 or not np.all(np.isfinite(gains)) or np.any(gains <= 0):
        raise OptionError("gains must be positive finite numbers")
    A_grid, w_grid = _grids(lp, a_rng, amplitude_range, omega_range, n_amplitude, n_omega)
    Ngrid = _evaluate_N(N, A_grid[:, None], w_grid[None, :])   # the one expensive evaluation
    Gall = lp.response(w_grid, gains)
    found = []
    for k, g in enumerate(gains):   # per gain: sign changes on the grid, then a few scipy refinements
        found.extend(_solve_gain(lp, N, g, A_grid, w_grid, Ngrid, Gall[k], max_candidates))
    crit = _critical(lp, N, A_grid, w_grid, Ngrid, (1e-6 * gains.min(), 1e6 * gains.max()))
    return LimitCycleResponse(plant_label=lp.label, nonlinearity_label=n_label, gains=gains,
                              intersections=tuple(found), critical_gain=crit["gain"],
                              critical_point={k: v for k, v in crit.items() if k != "gain"},
                              amplitude_range=(float(A_grid[0]), float(A_grid[-1])),
                              omega_range=(float(w_grid[0]), float(w_grid[-1])), plant=lp,
                              describing_function=N)


# ---------------------------------------------------------------- thesis V.6 and the CLI
#: The plant of the analog-computer study (thesis V.6): amplidyne + generator.
THESIS_PLANT = "K/((1+s)(1+0.25s)(1+1.1s))"
#: Appendix B table fitted for each (core, source impedance) block of Tables 5.1/5.2.
THESIS_BLOCKS = {("permalloy", 0.0): "B.1", ("permalloy", 600.0): "B.3",
                 ("deltamax", 0.0): "B.2", ("deltamax", 600.0): "B.5"}


def _fit_best(data, models, seed, n_starts):
    """The lowest-AICc least-squares fit among ``models`` (all registered when None)."""
    from fitdf.inference.api import fit
    from fitdf.models import model_names

    names = [models] if isinstance(models, str) else list(models or model_names())
    fits = [fit(data, m, seed=seed, n_starts=n_starts) for m in names]
    return min(fits, key=lambda r: r.metrics["aicc"])


def _balance_terms(rows, fits):
    """``K N(A, omega)`` at the measured cycles (independent of the scalings) and ``omega``."""
    KN, omega = [], []
    keep = np.isfinite(rows[["system_gain", "amplitude_v", "omega_rad_s"]].to_numpy(float)).all(axis=1)
    if not keep.any():
        raise OptionError("no measured cycle with a finite gain, amplitude and frequency")
    for key, block in rows[keep].groupby(["core", "source_impedance_ohm"]):   # per block, vectorised in rows
        w = block["omega_rad_s"].to_numpy(float)
        N = fits[key].predict(block["amplitude_v"].to_numpy(float), w / (2 * np.pi), key[1])
        KN.append(block["system_gain"].to_numpy(float) * N)
        omega.append(w)
    return np.concatenate(KN), np.concatenate(omega)


def estimate_thesis_scales(rows, fits) -> dict:
    """Time scale ``alpha`` and gain scale ``beta`` from harmonic balance at the measured cycles.

    At a measured cycle ``(K, A, omega)`` harmonic balance requires
    ``beta K G0(j omega / alpha) N(A, omega) = -1``. Its phase involves ``alpha`` only:
    ``alpha`` minimises the squared phase residuals (grid in ``ln alpha`` over
    ``[0.1, 100]``, then a bounded 1-D polish); ``ln beta`` is then the mean of
    ``-ln |K G0 N|``. Returns ``alpha``, ``beta`` and the RMS residuals left
    (phase in degrees, magnitude as a factor).
    """
    lp = as_loop_plant(THESIS_PLANT)
    KN, omega = _balance_terms(rows, fits)

    def residuals(la):
        H = KN * lp.response(omega / np.exp(la), [1.0])[0]
        return np.angle(-H), np.log(np.abs(H))

    def cost(la):
        return float(np.mean(residuals(la)[0] ** 2))

    grid = np.linspace(np.log(0.1), np.log(100.0), 121)
    k = int(np.argmin([cost(la) for la in grid]))    # the phase cost may be multimodal
    res = minimize_scalar(cost, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]), method="bounded",
                          options={"xatol": 1e-9})
    ph, lm = residuals(res.x)
    log_beta = -float(np.mean(lm))
    return {"alpha": float(np.exp(res.x)), "beta": float(np.exp(log_beta)),
            "rms_phase_deg": float(np.degrees(np.sqrt(np.mean(ph ** 2)))),
            "rms_magnitude_factor": float(np.exp(np.sqrt(np.mean((lm + log_beta) ** 2)))), "n_rows": int(ph.size)}


def thesis_limit_cycle_comparison(seed=0, models=None, *, time_scale=None, gain_scale=None,
                                  amplitude_range=(0.01, 20.0), n_starts=6, time_domain=False) -> pd.DataFrame:
    """Predict the analog-computer limit cycles of Tables 5.1/5.2 from the Appendix B fits.

    Each (core, source impedance) block is predicted from the table measured on that
    core at that impedance (:data:`THESIS_BLOCKS`: Permalloy B.1 / B.3, Deltamax
    B.2 / B.5), with the lowest-AICc model among ``models`` (all registered models when
    None; a list compares per block, a single name forces it) in the winding chain.

    Assumptions (the thesis states neither where the amplitude was read nor the
    computer's scaling):

    * the loop is Fig 5.12 -- error -> core -> ``G`` -> output, unity feedback -- and
      the tabulated amplitude is the core's input voltage (= the plant output);
    * the core's DF in the loop is the one measured in Appendix B (volts out over volts
      in through the table's source impedance);
    * the analog computer ran the plant ``alpha`` times faster than written,
      ``G(s / alpha)`` (the core is real hardware, so its frequencies are physical), and
      the loop gain is ``beta`` times the "system gain" -- one ``alpha`` and one ``beta``
      for all rows of both tables. Unless given, both are estimated from the tables
      (:func:`estimate_thesis_scales`); ``df.attrs["scales"]`` also holds the per-block
      estimates, which show whether one pair fits all blocks.

    Returns
    -------
    pandas.DataFrame
        One row per table row: ``core``, ``source_impedance_ohm``, ``table``, ``model``,
        ``system_gain``, measured ``amplitude_v`` / ``omega_rad_s`` / ``dies_out``,
        predicted ``amplitude_pred`` / ``omega_pred`` (the largest stable cycle at
        ``beta K``), their ratios, ``n_stable``, the predicted ``critical_gain_pred`` of
        the block (system-gain units) and ``extrapolated`` (the predicted cycle lies
        outside the amplitudes or frequencies the fit saw). With ``time_domain=True``
        also ``amplitude_sim`` / ``omega_sim`` / ``oscillating_sim``: the loop simulated
        with the fitted core's loop operator (:mod:`fitdf.loop.simulate`), started at the
        measured amplitude. ``attrs`` holds ``alpha``, ``beta``, ``scales`` (joint and
        per-block estimates), ``agreement`` (RMS log ratios per block) and the fits.
    """
    from fitdf.data import datasets

    table = pd.concat([datasets.load("table_5_1"), datasets.load("table_5_2")], ignore_index=True)
    table["source_impedance_ohm"] = table["source_impedance_ohm"].astype(float)
    fits = {key: _fit_best(name, models, seed, n_starts) for key, name in THESIS_BLOCKS.items()}
    osc = table[np.isfinite(table["omega_rad_s"]) & np.isfinite(table["amplitude_v"]) & ~table["dies_out"]]
    joint = estimate_thesis_scales(osc, fits)
    per_block = {f"{c} {r:g} ohm": estimate_thesis_scales(b, fits)
                 for (c, r), b in osc.groupby(["core", "source_impedance_ohm"])}
    alpha = float(time_scale) if time_scale is not None else joint["alpha"]
    beta = float(gain_scale) if gain_scale is not None else joint["beta"]
    out = []
    for (core, rs), block in table.groupby(["core", "source_impedance_ohm"], sort=False):
        f = fits[(core, rs)]
        gains = block["system_gain"].to_numpy(float)
        resp = limit_cycles(THESIS_PLANT, f, beta * gains, source_impedance=rs, amplitude_range=amplitude_range,
                            time_scale=alpha)
        pred = resp.stable_cycles()
        d = f.problem.data
        amp_box, f_box = (d.amplitude.min(), d.amplitude.max()), (d.frequency.min(), d.frequency.max())
        for (_, row), (_, p) in zip(block.iterrows(), pred.iterrows()):
            fa, fw = p["amplitude"], p["omega_rad_s"]
            out.append({"core": core, "source_impedance_ohm": rs, "table": THESIS_BLOCKS[(core, rs)],
                        "model": f.model, "system_gain": row["system_gain"], "amplitude_v": row["amplitude_v"],
                        "omega_rad_s": row["omega_rad_s"], "dies_out": bool(row["dies_out"]),
                        "amplitude_pred": fa, "omega_pred": fw, "amplitude_ratio": fa / row["amplitude_v"],
                        "omega_ratio": fw / row["omega_rad_s"], "n_stable": int(p["n_stable"]),
                        "critical_gain_pred": resp.critical_gain / beta,
                        "extrapolated": bool(np.isfinite(fa) and not (amp_box[0] <= fa <= amp_box[1]
                                                                      and f_box[0] <= fw / (2 * np.pi) <= f_box[1]))})
    df = pd.DataFrame(out)
    if time_domain:
        df = _add_time_domain(df, fits, alpha, beta)
    df.attrs.update({"alpha": alpha, "beta": beta, "plant": THESIS_PLANT, "agreement": _agreement(df),
                     "critical_gains": _critical_summary(df),
                     "scales": {"joint": joint, **per_block},
                     "fits": {THESIS_BLOCKS[k]: {"model": f.model, "values": dict(f.values),
                                                "rms_complex": f.metrics["rms_complex"]} for k, f in fits.items()}})
    return df


def _agreement(df) -> dict:
    """RMS of ln(predicted / measured) for amplitude and frequency, per block and overall."""
    out = {}
    for key, g in [("all", df)] + [(f"{c} {r:g} ohm", g) for (c, r), g in df.groupby(["core", "source_impedance_ohm"])]:
        ok = ~g["dies_out"] & g["amplitude_ratio"].notna()
        out[key] = {"rms_log_amplitude_ratio": float(np.sqrt(np.mean(np.log(g.loc[ok, "amplitude_ratio"]) ** 2)))
                    if ok.any() else float("nan"),
                    "rms_log_omega_ratio": float(np.sqrt(np.mean(np.log(g.loc[ok, "omega_ratio"]) ** 2)))
                    if ok.any() else float("nan"),
                    "rows_predicted": int(ok.sum()), "rows_oscillating": int((~g["dies_out"]).sum())}
    return out


def _critical_summary(df) -> list:
    """Per block: the measured die-out gain, the smallest gain that oscillated, and the prediction."""
    rows = []
    for (core, rs), g in df.groupby(["core", "source_impedance_ohm"], sort=False):
        dead, live = g[g["dies_out"]], g[~g["dies_out"]]
        rows.append({"core": core, "source_impedance_ohm": rs, "table": g["table"].iloc[0],
                     "measured_dies_out_at": float(dead["system_gain"].max()) if not dead.empty else None,
                     "measured_lowest_oscillating": float(live["system_gain"].min()) if not live.empty else None,
                     "predicted_critical_gain": _finite(g["critical_gain_pred"].iloc[0])})
    return rows


def _add_time_domain(df, fits, alpha, beta, steps_per_period=200, periods=40):
    """Simulate every row's loop (one batch per block) with the fitted core's loop operator."""
    from fitdf.loop.simulate import CoreElement, simulate_loop

    parts = []
    for (core, rs), block in df.groupby(["core", "source_impedance_ohm"], sort=False):
        el = CoreElement.from_fit(fits[(core, rs)], rs)
        w = np.concatenate([block["omega_pred"].to_numpy(float), block["omega_rad_s"].to_numpy(float)])
        w = w[np.isfinite(w)]
        a0 = block["amplitude_v"].fillna(block["amplitude_pred"]).fillna(0.5).to_numpy(float)
        sim = simulate_loop(THESIS_PLANT, el, beta * block["system_gain"].to_numpy(float), time_scale=alpha,
                            dt=2 * np.pi / w.max() / steps_per_period, t_end=periods * 2 * np.pi / w.min(),
                            initial_output=a0).measure()
        block = block.copy()
        block["amplitude_sim"] = np.where(sim["oscillating"], sim["amplitude_h1"], np.nan)
        block["omega_sim"] = np.where(sim["oscillating"], sim["omega"], np.nan)
        block["oscillating_sim"] = sim["oscillating"].to_numpy(bool)
        parts.append(block)
    return pd.concat(parts).loc[df.index]


def limit_cycle_command(data, plant, gains, source_impedance, model=None, chain="winding", seed=0, *,
                        amplitude_range=None, omega_range=None, time_scale=1.0, n_starts=6, plot=None) -> dict:
    """What ``fitdf limit-cycle`` computes, as JSON-ready data.

    Fits ``model`` (or every registered model, keeping the lowest AICc) to ``data`` at
    ``source_impedance``, then solves harmonic balance with ``plant`` at ``gains``.

    Parameters
    ----------
    data : str
        Dataset (``"B.3"``), core or CSV path.
    plant : str
        Transfer function text, e.g. ``"K/((1+s)(1+0.25s)(1+1.1s))"``.
    gains : sequence of float
        Loop gains (replace ``K``; multiply the plant when it has no ``K``).
    source_impedance : float or None
        Ohm; selects the data rows and the DF used in the loop (None: the data's only
        source impedance; an OptionError if they hold several).
    model, chain, seed
        As in :func:`fitdf.fit`.
    amplitude_range, omega_range, time_scale
        As in :func:`limit_cycles`.
    n_starts : int
        Least-squares starts per model.
    plot : str or path, optional
        Write the Nyquist-plane figure (:meth:`LimitCycleResponse.plot`) there.
    """
    from fitdf.inference.api import fit, resolve_data
    from fitdf.models import model_names

    lp = as_loop_plant(plant, time_scale)   # a bad plant fails now, before any fitting
    if source_impedance is None:   # one impedance in the data: use it; several: the user must choose
        found = sorted(set(resolve_data(data).source_impedance.tolist()))
        if len(found) != 1:
            raise OptionError(f"{data}: rows at several source impedances ({', '.join(f'{r:g}' for r in found)} "
                              "ohm); choose one with --source-impedance")
        source_impedance = found[0]
    names = [model] if model else model_names()
    fits = [fit(data, name, chain=chain, seed=seed, source_impedance=source_impedance, n_starts=n_starts)
            for name in names]
    best = min(fits, key=lambda r: r.metrics["aicc"])
    resp = limit_cycles(lp, best, gains, source_impedance=source_impedance, amplitude_range=amplitude_range,
                        omega_range=omega_range)
    if plot is not None:
        try:
            resp.plot().savefig(plot)
        except (OSError, ValueError) as exc:   # unwritable path or unknown image format: the user's to fix
            raise OptionError(f"cannot write the figure to {plot}: {exc}") from exc
    return {"data": str(data), "source_impedance_ohm": float(source_impedance), "seed": int(seed),
            "model": best.model, "chain": best.chain, "time_scale": float(time_scale),
            "models_tried": [{"model": r.model, "aicc": _finite(r.metrics["aicc"]),
                              "rms_complex": _finite(r.metrics["rms_complex"])} for r in fits],
            "parameters": {k: _finite(v) for k, v in best.values.items()}, **resp.to_dict()}


def format_limit_cycle_table(result: dict) -> str:
    """Plain-text table of :func:`limit_cycle_command`'s result."""
    lines = [f"Limit cycles of {result['plant']} with the {result['model']} core "
             f"({result['chain']} chain) fitted to {result['data']} at {result['source_impedance_ohm']:g} ohm",
             f"amplitudes searched {result['amplitude_range'][0]:.3g}..{result['amplitude_range'][1]:.3g} V, "
             f"omega {result['omega_range'][0]:.3g}..{result['omega_range'][1]:.3g} rad/s",
             "", f"{'gain':>10s} {'amplitude V':>12s} {'omega rad/s':>12s} {'f Hz':>8s} {'stable':>7s} {'loeb':>7s}"]
    by_gain = {}
    for c in result["intersections"]:
        by_gain.setdefault(c["gain"], []).append(c)
    for g in result["gains"]:
        cycles = by_gain.get(g, [])
        if not cycles:
            lines.append(f"{g:>10.4g} {'none':>12s}")
        for c in cycles:
            lines.append(f"{g:>10.4g} {c['amplitude']:>12.4g} {c['omega_rad_s']:>12.4g} {c['frequency_hz']:>8.3g} "
                         f"{'yes' if c['stable'] else 'no':>7s} {c['loeb']:>7.2f}")
    crit = result.get("critical_gain")
    point = result.get("critical_point", {})
    lines.append("")
    if crit is None:
        lines.append("No gain gives a limit cycle in the amplitude range searched.")
    else:
        where = " (at the edge of the amplitude range)" if point.get("at_boundary") else ""
        lines.append(f"Oscillations die out below gain {crit:.4g}; the first cycle appears at "
                     f"A = {point.get('amplitude'):.3g} V, omega = {point.get('omega'):.3g} rad/s{where}.")
    return "\n".join(lines)
