"""Limit cycles by harmonic balance with amplitude- and frequency-dependent DFs (thesis V.6).

A loop of a linear plant ``G(s)`` and a nonlinear element with describing function
``N(A, omega)`` (error -> element -> plant -> output, unity negative feedback, Fig 5.12)
can hold a sinusoid of amplitude ``A`` (at the element's input) and frequency ``omega``
when the first harmonic balances::

    F(A, omega) = 1 + G(j omega) N(A, omega) = 0,    i.e.   G(j omega) = -1 / N(A, omega).

:func:`limit_cycles` finds *every* solution inside a box of amplitudes and
frequencies: ``F`` on a coarse log-spaced grid (one vectorised evaluation of ``N``),
candidate cells where both ``Re F`` and ``Im F`` change sign or ``|F|`` has a small
local minimum, refinement of every candidate at once (Levenberg-Marquardt, batched evaluations of ``N``)
on ``(ln A, ln omega)`` of ``[ln|G N|, arg(-G N)]``, and de-duplication (roots of one gain
closer than the solver's tolerance, :data:`DEDUP_TOL`, are one cycle). The loop gain
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
#: hair apart. How far depends on the build and the solver: with numpy 2.4 / numba 0.68 one
#: ``scipy.optimize.least_squares`` per candidate stopped a root of B.1 proportional_width
#: in the thesis plant at gain 75 at 1.1e-5 (the DF moves by 2e-5 over 1e-8 in ``ln A``;
#: the batched refinement reaches ~1e-15 at most such roots, 8e-6 at one of ten in
#: ``benchmarks/bench_limit_cycles.py``); half the DF's own tolerance accepts what the
#: circuit can resolve and no more. A callable's roots converge to ~1e-15.
ROOT_TOL = 1e-4
#: Two accepted roots of one gain closer than this in both ``ln A`` and ``ln omega`` are one
#: cycle reached from two starts: the solver's own tolerance, :data:`ROOT_TOL`. A root is
#: accepted within ROOT_TOL of balance in ``[ln|G N|, arg(-G N)]``, whose derivatives in
#: ``ln A`` and ``ln omega`` are of order one away from a double root, so the solver places a
#: cycle to about ROOT_TOL in each coordinate (a relative 1e-4 in amplitude and frequency, the
#: fourth digit the table prints). Two starts that reach one cycle of a fitted core stop
#: where its DF's jitter lets them, ~1e-5 apart, which a tighter tolerance would report as two.
#: Of the roots it merges, the one with the smallest residual is kept.
DEDUP_TOL = ROOT_TOL
#: Step of the refinement's finite differences in ``ln A`` and ``ln omega``. A fitted
#: core's DF comes from the exact circuit, whose discretisation moves it by ~1e-6 between
#: points a hair apart: differences over 1e-9 measured that, not the slope, and the
#: refinement stalled short of roots that exist (B.1 constant_width in the plant
#: ``K/((1+s)(1+0.25s)(1+1.1s))``: cycles at gains 45 and 150, none found at 60-120).
#: At the edge of a saturation jump the DF also steps by ~1e-4 between amplitudes 2e-4
#: apart (B.1 proportional_width, 0 ohm, ``A`` 2.35 V at 1.8 Hz), and differences over 1e-4
#: stall there at a residual of 5e-3 (and lose the cycle at gain 87.6 of the thesis plant,
#: time scale 2.5); 1e-3 is far above both and still far below the scale on which
#: ``F`` bends; the roots converge to ~1e-15 (the Jacobian only steers, the residual is
#: exact).
REFINE_DIFF_STEP = 1e-3
#: Iterations of the refinement at most (each: a Jacobian and one or more trial steps).
REFINE_MAX_ITER = 100
#: Trial steps per iteration (``lambda`` grows 4x between them) before a start is taken as
#: converged as far as ``N`` allows.
REFINE_TRIALS = 12
#: Step of Loeb's central differences in ``ln A`` and ``ln omega``: far above the exact
#: chain's jitter (~1e-5 in ``1 + G N`` between points 1e-8 apart), far below the scale on
#: which ``F`` bends. B.1 proportional_width in the thesis plant (time scale 2.5, 12 gains
#: 20-300): the sine of the crossing angle as a function of the gain is smooth at 1e-2 and
#: 3e-2 (within 1e-3 of each other); at 1e-3 it still scatters by 0.04, at 1e-4 by 0.2, and
#: at 1e-6 it calls one cycle unstable (-0.20) between stable ones (0.94-0.98).
#: For a callable the sine moves by ~1e-4 from its limit (the relay with hysteresis of
#: :func:`limit_cycles`'s example: 5e-5).
LOEB_DIFF_STEP = 1e-2


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


def _response_at(plant: LoopPlant, omega, gains) -> np.ndarray:
    """``G(j omega_i; K_i)`` for paired arrays ``omega`` and ``gains`` (one plant
    evaluation per distinct gain)."""
    out = np.empty(omega.shape, complex)
    for g in np.unique(gains):
        sel = gains == g
        out[sel] = plant.response(omega[sel], [g])[0]
    return out


def _loop_gain(plant, N, gains, x):
    """``G N`` at rows ``x = (ln A, ln omega)``, gain per row, in one evaluation of ``N``."""
    w = np.exp(x[:, 1])
    return _response_at(plant, w, gains) * _evaluate_N(N, np.exp(x[:, 0]), w)


def _log_residual(plant, N, gains, x):
    """``[ln|H|, arg(-H)]`` with ``H = G N`` at rows ``x``: zero exactly at ``H = -1``; finite
    everywhere (``[50, pi]`` where ``H`` is not finite or zero)."""
    H = _loop_gain(plant, N, gains, x)
    bad = ~np.isfinite(H) | (H == 0)
    with np.errstate(all="ignore"):
        out = np.column_stack([np.log(np.abs(H)), np.angle(-H)])
    out[bad] = (50.0, np.pi)
    return out


def _wrapped(d):
    """Differences of ``[ln|H|, arg]`` rows with the angle taken modulo ``2 pi`` into ``(-pi, pi]``."""
    d = d.copy()
    d[..., 1] = -np.angle(np.exp(-1j * d[..., 1]))
    return d


def _solve_2x2(M, b):
    """``M x = b`` for stacks of 2x2 systems, ``x = 0`` where ``M`` is singular."""
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    ok = np.abs(det) > 1e-300
    det = np.where(ok, det, 1.0)
    x0 = (M[:, 1, 1] * b[:, 0] - M[:, 0, 1] * b[:, 1]) / det
    x1 = (M[:, 0, 0] * b[:, 1] - M[:, 1, 0] * b[:, 0]) / det
    return np.where(ok[:, None], np.column_stack([x0, x1]), 0.0)


def _refine(plant, N, gains, x0, bounds):
    """Roots of ``[ln|G N|, arg(-G N)]`` from the starts ``x0`` (rows ``(ln A, ln omega)``),
    every start at once: Levenberg-Marquardt inside the box ``bounds``.

    Each iteration is two evaluations of ``N`` for all the starts still moving: the
    Jacobian by differences of :data:`REFINE_DIFF_STEP` (backward at the upper bound), then
    trial steps ``-(J^T J + lambda diag(J^T J))^-1 J^T r`` clipped to the box, ``lambda``
    shrunk after a step that lowers ``|r|^2`` and grown (another trial) after one that
    does not. A start stops when a step no longer lowers ``|r|^2`` (at a root, the floor
    of ``N``: a callable's ~1e-15, a fitted core's jitter; elsewhere a local minimum, which
    the caller rejects by :data:`ROOT_TOL`), when its step is below 1e-14, or after
    :data:`REFINE_MAX_ITER` iterations. Batched because each evaluation of a fitted core's
    ``N`` is a solve of the exact circuit whose fixed cost dwarfs a point's (one point
    ~1.6 ms, 37 points ~3.9 ms): this replaced one ``scipy.optimize.least_squares`` per
    start, ~36 single-point evaluations each.

    Returns ``(x, residual)``: the last iterates and ``sum |[ln|H|, arg(-H)]|`` there.
    """
    lo, hi = bounds
    x = np.clip(np.asarray(x0, float).reshape(-1, 2), lo, hi)
    gains = np.asarray(gains, float)
    r = _log_residual(plant, N, gains, x)
    cost = np.sum(r**2, axis=1)
    lam = np.full(len(x), 1e-3)
    active = cost > 0
    h = REFINE_DIFF_STEP
    for _ in range(REFINE_MAX_ITER):
        idx = np.flatnonzero(active)
        if not idx.size:
            break
        k = idx.size
        step = np.where(x[idx] + h <= hi, h, -h)  # (k, 2)
        probes = np.concatenate([x[idx], x[idx]])
        probes[:k, 0] += step[:, 0]
        probes[k:, 1] += step[:, 1]
        rp = _log_residual(plant, N, np.concatenate([gains[idx], gains[idx]]), probes)
        J = np.stack(
            [_wrapped(rp[:k] - r[idx]) / step[:, :1], _wrapped(rp[k:] - r[idx]) / step[:, 1:]],
            axis=2,
        )  # (k, residual, parameter)
        JtJ = np.einsum("kri,krj->kij", J, J)
        grad = np.einsum("kri,kr->ki", J, r[idx])
        diag = np.einsum("kii->ki", JtJ) + 1e-12 * np.einsum("kii->k", JtJ)[:, None] + 1e-300
        pending = np.arange(k)
        for _ in range(REFINE_TRIALS):
            sel = idx[pending]
            M = JtJ[pending] + lam[sel, None, None] * np.einsum(
                "ki,ij->kij", diag[pending], np.eye(2)
            )
            dx = -_solve_2x2(M, grad[pending])
            xt = np.clip(x[sel] + dx, lo, hi)
            rt = _log_residual(plant, N, gains[sel], xt)
            ct = np.sum(rt**2, axis=1)
            better = ct < cost[sel]
            good = sel[better]
            tiny = np.max(np.abs(xt[better] - x[good]), axis=1) < 1e-14
            x[good], r[good], cost[good] = xt[better], rt[better], ct[better]
            lam[good] = np.maximum(lam[good] / 3.0, 1e-12)
            active[good[tiny | (ct[better] == 0)]] = False
            lam[sel[~better]] *= 4.0
            pending = pending[~better]
            if not pending.size:
                break
        active[idx[pending]] = False  # no step lowers |r|^2: converged as far as N allows
    return x, np.sum(np.abs(r), axis=1)


def _distinct_roots(x, res, owner) -> np.ndarray:
    """Indices of the distinct roots among refined starts: rows of ``x`` (``ln A``,
    ``ln omega``) whose residual ``res`` is at most :data:`ROOT_TOL`, one per cycle of each
    gain (``owner``: the gain's index per row). Roots of one gain within :data:`DEDUP_TOL` of
    a kept one in both coordinates are that cycle again; the smallest residual is kept.
    Returned in the order of the rows."""
    x, res, owner = np.asarray(x, float), np.asarray(res, float), np.asarray(owner)
    kept = []
    for i in sorted(np.flatnonzero(res <= ROOT_TOL), key=lambda i: (res[i], i)):
        same = (owner[kept] == owner[i]) & np.all(np.abs(x[kept] - x[i]) < DEDUP_TOL, axis=1)
        if not same.any():
            kept.append(i)
    return np.sort(np.asarray(kept, int))


def _solve_gains(plant, N, gains, A_grid, w_grid, Ngrid, Gall, max_candidates):
    """The cycles of every gain: candidate cells of each gain's grid, all refined at once
    (:func:`_refine`), de-duplicated, then ``N`` and Loeb's derivatives at the roots in one
    more evaluation."""
    lu, lv = np.log(A_grid), np.log(w_grid)
    bounds = (np.array([lu[0], lv[0]]), np.array([lu[-1], lv[-1]]))
    starts, owner = [np.zeros((0, 2))], [np.zeros(0, int)]
    for k in range(gains.size):
        pts = _candidates(1.0 + Gall[k][None, :] * Ngrid, max_candidates)
        starts.append(np.column_stack([lu[pts[:, 0]], lv[pts[:, 1]]]))
        owner.append(np.full(len(pts), k))
    owner = np.concatenate(owner)
    x, res = _refine(plant, N, gains[owner], np.concatenate(starts), bounds)
    roots = _distinct_roots(x, res, owner)
    if not roots.size:
        return []
    u, v, g, k = x[roots, 0], x[roots, 1], gains[owner[roots]], owner[roots]
    # Loeb's derivatives: central differences in ln A and ln omega, with the root itself
    hl = LOEB_DIFF_STEP
    us = np.concatenate([u, u + hl, u - hl, u, u])
    vs = np.concatenate([v, v, v, v + hl, v - hl])
    gs = np.tile(g, 5)
    ws = np.exp(vs)
    Gs = _response_at(plant, ws, gs)
    Ns = _evaluate_N(N, np.exp(us), ws)
    F = (1.0 + Gs * Ns).reshape(5, -1)
    Fa, Fw = (F[1] - F[2]) / (2 * hl), (F[3] - F[4]) / (2 * hl)
    den = np.abs(Fa) * np.abs(Fw)
    with np.errstate(all="ignore"):
        loeb = np.where((den > 0) & np.isfinite(den), (np.conj(Fa) * Fw).imag / den, np.nan)
    out = [
        (
            k[i],
            LimitCycle(
                gain=float(g[i]),
                amplitude=float(np.exp(u[i])),
                omega=float(np.exp(v[i])),
                stable=bool(loeb[i] > 0),
                loeb=float(loeb[i]),
                N=complex(Ns[i]),
                G=complex(Gs[i]),
                residual=float(res[roots[i]]),
            ),
        )
        for i in range(roots.size)
    ]
    # in the order of the gains given, each gain's cycles by amplitude
    return [c for _, c in sorted(out, key=lambda kc: (kc[0], kc[1].amplitude))]


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
    # per gain: sign changes on the grid; then every candidate refined at once
    found = _solve_gains(lp, N, gains, A_grid, w_grid, Ngrid, Gall, max_candidates)
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
