"""Limit cycles of a fitted core: the batched refinement against one scipy solve per candidate.

Run from the repository root::

    python benchmarks/bench_limit_cycles.py            # about a minute
    python benchmarks/bench_limit_cycles.py --quick    # one timed repeat

A least-squares fit of proportional_width to Table B.1 (exact ``voltage`` chain, seed 0)
in the thesis plant ``K/((1+s)(1+0.25s)(1+1.1s))`` at time scale 2.5, twelve gains 20-300
(as the report's limit-cycle section solves Tables 5.1/5.2). Two ways, in one process:

* **scipy per candidate** (the peer): every candidate cell of every gain refined by its own
  :func:`scipy.optimize.least_squares` (``trf``, ``diff_step`` the refinement's
  ``harmonic.REFINE_DIFF_STEP``, tolerances 1e-15), one single-point evaluation of the
  core's DF per residual, and the critical gain's peak by
  :func:`scipy.optimize.minimize_scalar` over ``ln A`` with a :func:`scipy.optimize.brentq`
  in ``ln omega`` at each amplitude;
* **fitdf**: :func:`fitdf.loop.harmonic.limit_cycles` -- all candidates refined at once
  (Levenberg-Marquardt, two batched evaluations of the DF per iteration) and the peak by
  rounds of 17 amplitudes whose crossings :func:`scipy.optimize.elementwise.find_root`
  finds together.

Both start from the same grid (160 x 320 points, one batched evaluation, timed apart). The
table gives each way's time (median of the repeats, after one untimed call) for the
refinement of the cycles and for the critical gain, their ratio, and how far the two ways'
cycles and critical gains are apart. Nothing is asserted (the agreement is tested:
tests/test_limitcycle.py); the load average is printed.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np
from bench_voltage import median_time, timed_repeats  # (benchmarks/ is the script's folder)
from scipy.optimize import brentq, least_squares, minimize_scalar

from fitdf.inference.api import fit
from fitdf.limit_cycle_tables import THESIS_PLANT
from fitdf.loop import critical as critical_module
from fitdf.loop import harmonic
from fitdf.loop.nonlinearity import _evaluate_N, as_describing_function
from fitdf.loop.plant import as_loop_plant

GAINS = np.geomspace(20.0, 300.0, 12)


def scipy_cycles(lp, N, gains, A_grid, w_grid, Ngrid):
    """``(gain, ln A, ln omega)`` of every root, one ``least_squares`` per candidate."""
    lu, lv = np.log(A_grid), np.log(w_grid)
    bounds = (np.array([lu[0], lv[0]]), np.array([lu[-1], lv[-1]]))
    out = []
    for g in gains:
        F = 1.0 + lp.response(w_grid, [g])[0][None, :] * Ngrid
        for i, j in harmonic._candidates(F, 40):

            def fun(x, g=g):
                A, w = np.exp(x)
                H = lp.response([w], [g])[0, 0] * _evaluate_N(N, np.array([A]), np.array([w]))[0]
                if not np.isfinite(H) or H == 0:
                    return np.array([50.0, np.pi])
                return np.array([np.log(abs(H)), np.angle(-H)])

            sol = least_squares(
                fun,
                np.clip([lu[i], lv[j]], *bounds),
                bounds=bounds,
                xtol=1e-15,
                ftol=1e-15,
                gtol=1e-15,
                diff_step=harmonic.REFINE_DIFF_STEP,
                max_nfev=400,
            )
            if np.sum(np.abs(sol.fun)) <= harmonic.ROOT_TOL and not any(
                g == h and np.all(np.abs(sol.x - y) < harmonic.DEDUP_TOL) for h, y in out
            ):
                out.append((g, sol.x))
    return out


def scipy_peak(lp, N, A_grid, w_grid, i, j):
    """The critical gain's peak of ``|G0 N|`` along ``arg = -pi``: minimize_scalar of brentq."""
    lu, lw = np.log(A_grid), np.log(w_grid)
    jl, jh = max(j - 3, 0), min(j + 4, lw.size - 1)

    def H(u, v):
        w = np.exp(v)
        return (
            lp.response([w], [1.0])[0, 0] * _evaluate_N(N, np.array([np.exp(u)]), np.array([w]))[0]
        )

    def along(u):
        a, b = H(u, lw[jl]).imag, H(u, lw[jh]).imag
        if np.sign(a) == np.sign(b):
            return 0.0
        v = brentq(lambda v: H(u, v).imag, lw[jl], lw[jh], xtol=1e-13)
        h = H(u, v)
        return -h.real if h.real < 0 else 0.0

    res = minimize_scalar(
        lambda u: -along(u),
        bounds=(lu[max(i - 1, 0)], lu[min(i + 1, lu.size - 1)]),
        method="bounded",
        options={"xatol": 1e-10},
    )
    return along(res.x)


def main(argv=None) -> int:
    repeats = timed_repeats(__doc__, argv)
    res = fit("B.1", "proportional_width", seed=0, n_starts=2)
    lp = as_loop_plant(THESIS_PLANT, 2.5)
    N, _, _ = as_describing_function(res, 0.0)
    A_grid, w_grid = harmonic._grids(lp, None, (0.02, 10.0), None, 160, 320)
    t = time.perf_counter()
    Ngrid = _evaluate_N(N, A_grid[:, None], w_grid[None, :])
    t_grid = time.perf_counter() - t
    G = lp.response(w_grid, GAINS)
    _, i, j, _ = critical_module._crossover_peak(G[:1] / GAINS[0] * Ngrid, A_grid, w_grid)
    ways = {  # name -> (the scipy peer, fitdf)
        "cycles": (
            lambda: scipy_cycles(lp, N, GAINS, A_grid, w_grid, Ngrid),
            lambda: harmonic._solve_gains(lp, N, GAINS, A_grid, w_grid, Ngrid, G, 40),
        ),
        "peak": (
            lambda: scipy_peak(lp, N, A_grid, w_grid, i, j),
            lambda: critical_module._peak_polish(lp, N, 1.0, A_grid, w_grid, i, j)[0],
        ),
    }
    times = {k: [median_time(f, repeats) for f in fs] for k, fs in ways.items()}
    (ref, new), (p_ref, p_new) = ([f() for f in fs] for fs in ways.values())
    (t_ref, t_new), (t_pref, t_pnew) = times.values()

    ref_roots = {round(g, 9): x for g, x in ref}
    apart = max(
        (
            np.max(
                np.abs(
                    np.array([np.log(c.amplitude), np.log(c.omega)]) - ref_roots[round(c.gain, 9)]
                )
            )
            for c in new
            if round(c.gain, 9) in ref_roots
        ),
        default=np.nan,
    )
    print(f"grid of the DF, {A_grid.size} x {w_grid.size} points (shared): {t_grid:.2f} s")
    print(f"{'':34s} {'scipy per candidate':>20s} {'fitdf batched':>14s} {'speed-up':>9s}")
    print(f"{'cycles of 12 gains':34s} {t_ref:19.3f}s {t_new:13.3f}s {t_ref / t_new:8.1f}x")
    print(
        f"{'critical gain (peak polish)':34s} {t_pref:19.3f}s {t_pnew:13.3f}s {t_pref / t_pnew:8.1f}x"
    )
    print(
        f"cycles found: {len(ref)} and {len(new)}; largest difference in (ln A, ln omega) {apart:.1e}; "
        f"critical gains 1/peak {1 / p_ref:.9g} and {1 / p_new:.9g}"
    )
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
