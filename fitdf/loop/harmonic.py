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

import numpy as np
from scipy.optimize import least_squares

from fitdf.errors import OptionError
from fitdf.loop.assumptions import plant_warnings
from fitdf.loop.critical import _critical
from fitdf.loop.nonlinearity import _evaluate_N, as_describing_function
from fitdf.loop.plant import LoopPlant, as_loop_plant
from fitdf.loop.response import LimitCycle, LimitCycleResponse

__all__ = [
    "limit_cycles",
    "critical_gain",
    "LimitCycle",
    "LimitCycleResponse",
    "as_describing_function",
]

#: Accept a refined root when ``|ln|GN|| + |arg(-GN)|`` is below this: the floor of a
#: fitted core's DF, whose exact circuit is accurate to its ``df_tol`` (2e-4,
#: :class:`fitdf.chains.voltage.VoltageSettings`) and jitters by that order between points a
#: hair apart. How far depends on the build: with numpy 2.4 / numba 0.68 a root of B.1
#: proportional_width in the thesis plant at gain 75 stops at 1.1e-5 (the DF moves by
#: 2e-5 over 1e-8 in ``ln A``), where earlier builds reached 1e-8 and a tolerance of 1e-6
#: held; half the DF's own tolerance accepts what the circuit can resolve and no more.
#: A callable's roots converge to ~1e-15.
ROOT_TOL = 1e-4
#: Two roots closer than this in ``ln A`` and ``ln omega`` are one.
DEDUP_TOL = 1e-6
#: Step of the refinement's finite differences in ``ln A`` and ``ln omega``. A fitted
#: core's DF comes from the exact circuit, whose discretisation moves it by ~1e-6 between
#: points a hair apart: differences over 1e-9 measured that, not the slope, and the
#: refinement stalled short of roots that exist (B.1 constant_width in the plant
#: ``K/((1+s)(1+0.25s)(1+1.1s))``: cycles at gains 45 and 150, none found at 60-120).
#: 1e-4 is far above that and far below the scale on which ``F`` bends; the roots still
#: converge to ~1e-15 (the Jacobian only steers, the residual is exact).
REFINE_DIFF_STEP = 1e-4


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
    neigh = np.min(
        [
            pad[1 + di : pad.shape[0] - 1 + di, 1 + dj : pad.shape[1] - 1 + dj]
            for di in (-1, 0, 1)
            for dj in (-1, 0, 1)
            if di or dj
        ],
        axis=0,
    )
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
    sol = least_squares(
        fun,
        x0,
        bounds=bounds,
        method="trf",
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
        x_scale=1.0,
        diff_step=REFINE_DIFF_STEP,
        max_nfev=400,
    )
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
    for i, j in pts:  # a handful of candidates per gain, each refined by scipy
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
        out.append(
            LimitCycle(
                gain=float(gain),
                amplitude=float(A),
                omega=float(w),
                stable=bool(lo > 0),
                loeb=lo,
                N=complex(Nv),
                G=complex(Gv),
                residual=res,
            )
        )
    return sorted(out, key=lambda c: c.amplitude)


def critical_gain(
    plant,
    nonlinearity,
    *,
    amplitude_range=None,
    omega_range=None,
    source_impedance=0.0,
    n_amplitude=160,
    n_omega=320,
    gain_bracket=(1e-6, 1e9),
    time_scale=1.0,
) -> dict:
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
    return (
        np.geomspace(*amplitude_range, int(n_amplitude)),
        np.geomspace(*omega_range, int(n_omega)),
    )


def limit_cycles(
    plant,
    nonlinearity,
    gains=None,
    *,
    amplitude_range=None,
    omega_range=None,
    source_impedance=0.0,
    n_amplitude=160,
    n_omega=320,
    max_candidates=40,
    time_scale=1.0,
) -> LimitCycleResponse:
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
        Its ``warnings`` say when the plant breaks the hypotheses of harmonic balance
        (open-loop unstable, not low-pass: :mod:`fitdf.loop.assumptions`).

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
    Ngrid = _evaluate_N(N, A_grid[:, None], w_grid[None, :])  # the one expensive evaluation
    Gall = lp.response(w_grid, gains)
    found = []
    for k, g in enumerate(
        gains
    ):  # per gain: sign changes on the grid, then a few scipy refinements
        found.extend(_solve_gain(lp, N, g, A_grid, w_grid, Ngrid, Gall[k], max_candidates))
    crit = _critical(lp, N, A_grid, w_grid, Ngrid, (1e-6 * gains.min(), 1e6 * gains.max()))
    return LimitCycleResponse(
        plant_label=lp.label,
        nonlinearity_label=n_label,
        gains=gains,
        intersections=tuple(found),
        critical_gain=crit["gain"],
        critical_point={k: v for k, v in crit.items() if k != "gain"},
        amplitude_range=(float(A_grid[0]), float(A_grid[-1])),
        omega_range=(float(w_grid[0]), float(w_grid[-1])),
        plant=lp,
        describing_function=N,
        warnings=plant_warnings(lp, gains, found),
    )
