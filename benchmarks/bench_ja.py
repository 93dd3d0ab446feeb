"""Jiles-Atherton branch: fresh against cached parameter sets, the steady loop, the step tolerance.

Run from the repository root::

    python benchmarks/bench_ja.py            # about a minute
    python benchmarks/bench_ja.py --quick    # fewer repeats and a smaller grid
    python benchmarks/bench_ja.py --fits     # and the least-squares fits of Part 4 (~10 s)

Part 1 (cost). (a) One ``voltage`` predict of the Permalloy joint block (73 rows, the
report's Permalloy fit scattered by 1e-3 in the internal coordinates) with **fresh**
parameter sets, new at every call as an optimiser and a sampler give them, against the
**cached** case, the same sets at every call (their forced responses kept by
:data:`~fitdf.models._ja_branch.RESPONSE_CACHE`), interleaved call by call: one set from
a cold start (a least-squares evaluation) and eight sets warm-started at the fit's currents
(one step of the report's eight MCMC chains); the ratio fresh / cached, aim at most 1.5.
(b) The steady loop and nodes of each row of one such predict (every amplitude its search
tried, recorded) by the closed form of :mod:`fitdf.models._ja_integrate` against the
integrated fixed point (half cycles to a safeguarded secant root, coarse then fine, as
:func:`~fitdf.models._ja_integrate._steady` does beyond ``zeta = 1``), the same rows in one
process, and the largest difference of their branches relative to the tip. (c) One predict
with the chain's guess and coarse stage on the rough branch (the default) and on the exact
one, interleaved, and the largest difference of the two DFs. Medians of repeats; the two
cores are shared, so the load average is printed.

Part 2 (tolerance) compares step controls ``(tol, n_min)`` of the tabulation with a ``tol =
1e-11, n_min = 96`` reference on three grids: draws over the box of :class:`JilesAtherton`
(uniform in the internal, mostly logarithmic, coordinates), realistic fitted values
(``lambda_s`` 0.01-0.1 V s, ``a``, ``k`` 1e-4..1e-2 A, ``c`` 0.05-0.5, ``zeta`` 0.1-1) and
the report's fits (:data:`REPORT_FITS`, scattered by 10 %), each at amplitudes 1e-5..1 A
(half decades). ``branch`` is the largest ``|B - B_ref|`` over 257 uniform ``x`` in
``[-A, A]`` divided by the tip ``B_ref(A)`` (what the chain tabulates), ``N`` the largest
``|N - N_ref| / |N_ref|``, ``Im N`` the largest ``|Im N - Im N_ref| / |Im N_ref|`` where
``|Im N_ref| >= 0.01 |N_ref|``; ``loop`` the time of one steady loop and its DF (forced
responses kept) and ``speed-up`` against the first candidate (``tol = 1e-8, n_min = 24``);
``lost`` and ``ref-`` count rows where a candidate or the reference found no loop. Part 3
runs the ``voltage`` chain itself on the report's fits and their cores' tables with each
setting, against the reference. Last, the module's default ``(tol, n_min)`` and the fastest
candidate that keeps the branch within 2e-5 of the tip on the realistic grids and the
chain's DF within 2e-5 of the reference.

Part 4 (``--fits``) times ``fitdf.fit(key, "jiles_atherton", method="lsq", seed=0)`` on
Tables B.1, B.3 and the joint Permalloy block, and prints each against :data:`FIT_BEFORE`,
the same fits with the integrated steady loop and its row cache, measured back to back on
the same machine (absolute seconds: compare on one machine only). Nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
from bench_voltage import median_time  # noqa: E402  (benchmarks/ is the script's folder)

import fitdf  # noqa: E402
from fitdf.chains import VoltageChain  # noqa: E402
from fitdf.inference.api import resolve_data, resolve_geometry  # noqa: E402
from fitdf.inference.problem import FitProblem  # noqa: E402
from fitdf.models import jiles_atherton  # noqa: E402
from fitdf.models._ja_branch import (  # noqa: E402
    RESPONSE_CACHE,
    ROW_MEMO,
    _capacity,
    _eval_row,
    _loop,
    _pieces,
    _work,
    grid,
    response_tables,
)
from fitdf.models._ja_integrate import _NMIN, _TOL, _steady, coupling  # noqa: E402
from fitdf.models.jiles_atherton import (  # noqa: E402
    JilesAtherton,
    _steady_branch,
    ja_describing_function,
)

REFERENCE = (1e-11, 96)
CANDIDATES = [(1e-8, 24), (3e-8, 24), (1e-7, 24), (1e-7, 16), (3e-7, 16), (1e-6, 24), (1e-6, 12)]
BRANCH_LIMIT = 2e-5
FRESH_AIM = 1.5
#: Fixed inputs of the timings: least-squares Jiles-Atherton fits of each report block (taken
#: when zeta was bounded at 0.99), the core, then ``(lambda_s, a, k, c, zeta, r_series)``.
REPORT_FITS = {
    "B.1": ("permalloy", (0.044227, 3.68e-4, 8.72e-4, 0.163991, 0.99, 53.61)),
    "B.3": ("permalloy", (0.040635, 3.24e-4, 4.54e-4, 0.114519, 0.99, 53.76)),
    "permalloy": ("permalloy", (0.043204, 3.92e-4, 4.38e-4, 0.14449, 0.99, 54.73)),
    "B.2": ("deltamax", (0.042843, 1.4702e-2, 6.14e-4, 0.10012, 0.99, 42.44)),
    "B.5": ("deltamax", (0.037992, 2.243e-3, 3.77e-4, 0.005745, 0.99, 42.72)),
    "deltamax": ("deltamax", (0.042843, 3.435e-3, 3.35e-4, 0.031582, 0.99, 87.64)),
    "B.4": ("supermalloy", (0.051683, 4.62e-4, 2.18e-4, 0.162603, 0.882514, 53.64)),
}
#: Part 4's reference: seconds of each fit with the integrated steady loop (the secant on
#: half cycles, a row cache of solved loops), on the machine of the README's figures.
FIT_BEFORE = {"B.1": 8.61, "B.3": 7.47, "permalloy": 13.48}


def forget():
    """Empty the forced-response cache and the row memo."""
    RESPONSE_CACHE.clear()
    ROW_MEMO.clear()


def permalloy_problem():
    rows = resolve_data("permalloy", "default", None)
    problem = FitProblem(
        rows, "jiles_atherton", "voltage", None, None, resolve_geometry("auto", rows)
    )
    lam, a, k, c, zeta, r_s = REPORT_FITS["permalloy"][1]
    values = dict(lambda_s=lam, a=a, k=k, c=c, zeta=zeta, r_series=r_s)
    values.update({n: 1.0 for n in problem.names if n.startswith("gain")})
    return problem, problem.to_internal(values)


def fresh_vs_cached(repeats):
    """Part 1a: a predict with new parameter sets at every call against the same sets."""
    problem, centre = permalloy_problem()
    warm = problem.warm_started(centre)
    rng = np.random.default_rng(0)
    print(
        f"Part 1: cost; load average {os.getloadavg()[0]:.1f}\n"
        f"{'voltage predict, Permalloy (73 rows)':40s} {'fresh':>10s} {'cached':>10s} {'ratio':>6s}"
    )
    ratios = []
    for label, prob, walkers in (
        ("1 set, cold start (least squares)", problem, 1),
        ("8 sets, warm start (MCMC step)", warm, 8),
    ):

        def draw():
            return centre + 1e-3 * rng.standard_normal((walkers, centre.size))

        same = draw()
        prob.predict(same)
        t_fresh, t_cached = [], []
        for _ in range(repeats):
            new = draw()
            t0 = time.perf_counter()
            prob.predict(new)
            t1 = time.perf_counter()
            prob.predict(same)
            t2 = time.perf_counter()
            t_fresh.append(t1 - t0)
            t_cached.append(t2 - t1)
        fresh, cached = float(np.median(t_fresh)), float(np.median(t_cached))
        ratios.append(fresh / cached)
        print(f"{label:40s} {fresh * 1e3:7.2f} ms {cached * 1e3:7.2f} ms {fresh / cached:6.2f}")
    print(
        f"fresh / cached at most {max(ratios):.2f} (aim {FRESH_AIM}: "
        f"{'met' if max(ratios) <= FRESH_AIM else 'not met'})"
    )


def recorded_rows(problem, point):
    """The ``(A, theta)`` rows of every exact-branch call of one predict (cold start)."""
    seen = []
    exact = JilesAtherton.__dict__["ascending_branch"]

    def record(cls, x, amplitude, frequency=0.0, **theta):
        A = np.broadcast_to(
            amplitude,
            np.broadcast_shapes(*(np.shape(v) for v in theta.values()), np.shape(amplitude)),
        )
        cols = [np.ravel(A)] + [np.ravel(np.broadcast_to(v, A.shape)) for v in theta.values()]
        seen.append(np.column_stack(cols))
        return exact.__func__(cls, x, amplitude, frequency, **theta)

    JilesAtherton.ascending_branch = classmethod(record)
    try:
        problem.predict(point)
    finally:
        JilesAtherton.ascending_branch = exact
    rows = np.unique(np.vstack(seen), axis=0)
    return np.abs(rows[:, 0]), rows[:, 1:]


def closed_against_integrated(repeats):
    """Part 1b: the steady loop and nodes per row, closed form against integrated."""
    problem, centre = permalloy_problem()
    A, th = recorded_rows(problem, centre)
    lam, a, k, c, zeta = th.T
    kap = coupling(lambda_s=lam, a=a, zeta=zeta)
    tabs, row = response_tables(lam, a, k, _TOL)
    G, cap = grid(_TOL), _capacity(_NMIN)
    rec, _ = _work(cap)
    big = tuple(np.empty(cap) for _ in range(3))

    def closed():
        for i in range(A.size):
            p = (lam[i], a[i], k[i], c[i], kap[i])
            _loop(A[i], p, _TOL, _NMIN, cap, G, tabs[row[i]], rec)

    def integrated():
        for i in range(A.size):
            _steady(A[i], lam[i], a[i], k[i], c[i], kap[i], _TOL, _NMIN, *big)

    t_int, t_closed = (median_time(fn, repeats) / A.size for fn in (integrated, closed))
    u = np.linspace(-1.0, 1.0, 257)
    B = _steady_branch(A[:, None] * u, A[:, None], *(v[:, None] for v in th.T), _TOL, _NMIN)
    worst = 0.0
    ref, pcs = _work(_capacity(96))
    for i in range(A.size):
        n = _steady(A[i], lam[i], a[i], k[i], c[i], kap[i], 1e-11, 96, *ref)
        count = _pieces(*ref, n, kap[i], A[i], *pcs)
        B_ref = np.empty(u.size)
        _eval_row(A[i] * u, 0, u.size, B_ref, *ref, kap[i], *pcs, count)
        worst = max(worst, np.max(np.abs(B[i] - B_ref)) / B_ref[-1])
    print(
        f"{'steady loop + nodes, ' + str(A.size) + ' rows':40s} {t_int * 1e6:7.2f} us "
        f"{t_closed * 1e6:7.2f} us {t_int / t_closed:6.2f}  (integrated / closed form; "
        f"branch within {worst:.1e} of the tip of the integrated tol = 1e-11 loop)"
    )


def rough_coarse_stage(repeats):
    """Part 1c: one predict with the coarse stage on the rough branch and on the exact one."""
    problem, point = permalloy_problem()
    rough = JilesAtherton.__dict__["rough_branch"]

    def predict():
        forget()
        return problem.predict(point)

    times, dfs = {}, {}
    for label in ("exact", "rough", "exact", "rough"):
        if label == "exact":
            JilesAtherton.rough_branch = JilesAtherton.__dict__["ascending_branch"]
        times.setdefault(label, []).append(median_time(predict, repeats))
        dfs[label] = predict()
        JilesAtherton.rough_branch = rough
    exact_t, rough_t = (float(np.median(times[x])) for x in ("exact", "rough"))
    print(
        f"{'predict, coarse stage on exact / rough':40s} {exact_t * 1e3:7.2f} ms "
        f"{rough_t * 1e3:7.2f} ms {exact_t / rough_t:6.2f}  max |dDF| "
        f"{np.abs(dfs['exact'] - dfs['rough']).max():.1e}"
    )


def grids(n):
    rng = np.random.default_rng(1)
    lo = np.array([p.internal_bounds[0] for p in JilesAtherton.params])
    hi = np.array([p.internal_bounds[1] for p in JilesAtherton.params])
    internal = rng.uniform(lo, hi, (n, 5))
    box = np.column_stack(
        [p.from_internal(internal[:, i]) for i, p in enumerate(JilesAtherton.params)]
    )
    fitted = np.column_stack(
        [
            10 ** rng.uniform(-2, -1, n),
            10 ** rng.uniform(-4, -2, n),
            10 ** rng.uniform(-4, -2, n),
            rng.uniform(0.05, 0.5, n),
            rng.uniform(0.1, 1.0, n),
        ]
    )
    fits = np.array([v[1][:5] for v in REPORT_FITS.values()])
    report = fits[rng.integers(0, len(fits), n)] * np.exp(0.1 * rng.standard_normal((n, 5)))
    report[:, 4] = np.minimum(report[:, 4], 1.0)
    amps = 10 ** np.arange(-5.0, 0.25, 0.5)
    out = {}
    for name, theta in (("box", box), ("fitted", fitted), ("report", report)):
        rows = np.repeat(theta, amps.size, axis=0)
        out[name] = (np.tile(amps, n), *rows.T)
    return out


def tolerance(n):
    """Part 2: per grid and step control, the errors against the reference and the loop time."""
    u = np.linspace(-1.0, 1.0, 257)
    print(
        f"\nPart 2: step control against tol = {REFERENCE[0]:g}, n_min = {REFERENCE[1]}; "
        f"{n} parameter draws x 11 amplitudes per grid"
    )
    print(
        f"{'grid':7s} {'tol':>6s} {'n_min':>5s} {'branch':>9s} {'N':>9s} {'Im N':>9s} "
        f"{'loop':>9s} {'speed-up':>8s} {'lost':>4s} {'ref-':>4s}  worst branch row"
    )
    results = {}
    for name, (A, lam, a, k, c, zeta) in grids(n).items():
        kw = dict(lambda_s=lam, a=a, k=k, c=c, zeta=zeta)
        cols = [v[:, None] for v in (lam, a, k, c, zeta)]

        def branch(tol, n_min):
            ROW_MEMO.clear()
            return _steady_branch(A[:, None] * u, A[:, None], *cols, tol, n_min)

        B_ref = branch(*REFERENCE)
        N_ref = ja_describing_function(A, tol=REFERENCE[0], n_min=REFERENCE[1], **kw)
        ref_ok = np.isfinite(B_ref).all(axis=1) & np.isfinite(N_ref)
        t_first = None
        for cand in CANDIDATES:
            B = branch(*cand)
            t_loop = (
                min(
                    median_time(
                        lambda cand=cand: ja_describing_function(
                            A, tol=cand[0], n_min=cand[1], **kw
                        ),
                        1,
                    )
                    for _ in range(3)
                )
                / A.size
            )
            N = ja_describing_function(A, tol=cand[0], n_min=cand[1], **kw)
            t_first = t_first or t_loop
            good = ref_ok & np.isfinite(B).all(axis=1) & np.isfinite(N)
            e_rows = np.max(np.abs(B - B_ref), axis=1) / np.abs(B_ref[:, -1])
            i = int(np.argmax(np.where(good, e_rows, -1.0)))
            e_n = np.max(np.abs(N - N_ref)[good] / np.abs(N_ref[good]))
            lossy = good & (np.abs(N_ref.imag) >= 0.01 * np.abs(N_ref))
            e_i = np.max(np.abs((N - N_ref).imag)[lossy] / np.abs(N_ref.imag[lossy]))
            lost, skipped = int(np.sum(ref_ok & ~good)), int(np.sum(~ref_ok))
            results[name, cand] = (e_rows[i], t_first / t_loop, lost)
            print(
                f"{name:7s} {cand[0]:6.0e} {cand[1]:5d} {e_rows[i]:9.1e} {e_n:9.1e} {e_i:9.1e} "
                f"{t_loop * 1e6:6.1f} us {t_first / t_loop:8.2f} {lost:4d} {skipped:4d}  "
                f"A/a {A[i] / a[i]:.0e}, A/k {A[i] / k[i]:.0e}, zeta {zeta[i]:.2f}"
            )
    return results


def chain_errors():
    """Part 3: the ``voltage`` chain's DF on the report's fits, each step control against the reference."""
    print(
        "\nPart 3: voltage-chain DF of the report's fits on their cores' tables, "
        "max |DF - DF_ref| / |DF_ref|"
    )
    chain = VoltageChain.configured(threads=1)
    print(f"{'fit':10s} " + " ".join(f"{t:5.0e}/{n:<3d}" for t, n in CANDIDATES))
    worst = dict.fromkeys(CANDIDATES, 0.0)
    for name, (core, values) in REPORT_FITS.items():
        d = resolve_data(core)
        V, f, Rs = d.amplitude, d.frequency, d.source_impedance
        th, ct = np.array(values[:5]), np.array([values[5], 1.0])
        dfs = {}
        try:
            for setting in [REFERENCE, *CANDIDATES]:
                jiles_atherton._TOL, jiles_atherton._NMIN = setting
                dfs[setting] = chain.predict(JilesAtherton, V, f, Rs, th, ct)
        finally:
            jiles_atherton._TOL, jiles_atherton._NMIN = _TOL, _NMIN
        ref = dfs[REFERENCE]
        errs = [float(np.max(np.abs(dfs[c] - ref) / np.abs(ref))) for c in CANDIDATES]
        for c, e in zip(CANDIDATES, errs):
            worst[c] = max(worst[c], e)
        print(f"{name:10s} " + " ".join(f"{e:9.1e}" for e in errs))
    return worst


def recommend(results, chain_worst):
    """The fastest step control within :data:`BRANCH_LIMIT` on the realistic grids."""
    realistic = ("fitted", "report")
    passing = [
        c
        for c in CANDIDATES
        if all(results[g, c][0] < BRANCH_LIMIT and results[g, c][2] == 0 for g in realistic)
        and chain_worst[c] < BRANCH_LIMIT
    ]
    print(f"\ndefault tol = {_TOL:g}, n_min = {_NMIN}")
    if not passing:
        print(f"no setting keeps the branch within {BRANCH_LIMIT:g} of the tip on {realistic}")
        return
    best = max(passing, key=lambda c: min(results[g, c][1] for g in realistic))
    print(
        f"fastest setting with branch error < {BRANCH_LIMIT:g} of the tip on the realistic "
        f"grids and chain DF error < {BRANCH_LIMIT:g}: tol = {best[0]:g}, n_min = {best[1]} "
        f"(branch {max(results[g, best][0] for g in realistic):.1e}, chain DF "
        f"{chain_worst[best]:.1e}, loop {min(results[g, best][1] for g in realistic):.2f}x "
        f"faster; box grid branch {results['box', best][0]:.1e}, default there "
        f"{results['box', CANDIDATES[0]][0]:.1e})"
    )


def fits():
    """Part 4: the least-squares fits of B.1, B.3 and the Permalloy joint block."""
    print(
        f"\nPart 4: fitdf.fit(key, 'jiles_atherton', method='lsq', seed=0); load average "
        f"{os.getloadavg()[0]:.1f}"
    )
    fitdf.fit("B.3", "jiles_atherton", method="lsq", seed=0, n_starts=1)  # compiled, warm
    total = 0.0
    for key, before in FIT_BEFORE.items():
        t0 = time.perf_counter()
        result = fitdf.fit(key, "jiles_atherton", method="lsq", seed=0)
        dt = time.perf_counter() - t0
        total += dt
        print(
            f"{key:10s} {dt:6.2f} s (integrated steady loop {before:6.2f} s: "
            f"{dt / before:.2f}); chi-square {result.metrics['chi2']:.4f}"
        )
    before = sum(FIT_BEFORE.values())
    print(
        f"{'all':10s} {total:6.2f} s (integrated steady loop {before:6.2f} s: {total / before:.2f})"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--fits", action="store_true", help="also time Part 4's fits")
    args = parser.parse_args()
    repeats = 5 if args.quick else 15
    fresh_vs_cached(3 * repeats)
    closed_against_integrated(3 if args.quick else 5)
    rough_coarse_stage(repeats)
    results = tolerance(40 if args.quick else 160)
    recommend(results, chain_errors())
    if args.fits:
        fits()


if __name__ == "__main__":
    main()
