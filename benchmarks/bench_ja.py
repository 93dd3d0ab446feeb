"""Jiles-Atherton branch: the steady-loop cache in the ``voltage`` chain, and the step tolerance.

Run from the repository root::

    python benchmarks/bench_ja.py            # under a minute
    python benchmarks/bench_ja.py --quick    # fewer repeats and a smaller grid

Part 1 (cache) times :meth:`JilesAtherton.ascending_branch` in the chain's pattern, 73 rows
(Permalloy-like parameters, amplitudes 1e-4..1e-2 A) called at the same amplitudes with 32
uniform nodes, 64 other nodes and 64 nodes again (what node placement and the fine search's
first evaluation do), with the cache of :mod:`fitdf.models._ja_branch` on and off
(``STEADY_CACHE.max_rows = 0``: every row solved); then one ``FitProblem.predict`` of the
``voltage`` chain on the Permalloy table (73 points) both ways; then one predict at the
report's Permalloy fit with the chain's guess and coarse stage on the rough branch (the
default) and on the exact one, interleaved, and the largest difference of the two DFs.
Medians of repeats; the two cores are shared, so the load average is printed.

Part 2 (tolerance) compares step controls ``(tol, n_min)`` of the steady-loop integration
with a ``tol = 1e-11, n_min = 96`` reference on three grids: draws over the box of
:class:`JilesAtherton` (uniform in the internal, mostly logarithmic, coordinates), realistic
fitted values (``lambda_s`` 0.01-0.1 V s, ``a``, ``k`` 1e-4..1e-2 A, ``c`` 0.05-0.5,
``zeta`` 0.1-0.9) and the report's fits (:data:`REPORT_FITS`, scattered by 10 %), each at
amplitudes 1e-5..1 A (half decades). ``branch`` is the largest ``|B - B_ref|`` over 257
uniform ``x`` in ``[-A, A]`` divided by the tip ``B_ref(A)`` (what the chain tabulates),
``N`` the largest ``|N - N_ref| / |N_ref|``, ``Im N`` the largest ``|Im N - Im N_ref| /
|Im N_ref|`` where ``|Im N_ref| >= 0.01 |N_ref|``; ``solve`` the time of one steady loop
(the branch's cost) and ``speed-up`` against the first candidate (``tol = 1e-8, n_min =
24``); ``lost`` and ``ref-`` count rows where a candidate or the reference found no loop.
Part 3 runs the ``voltage`` chain itself on the report's fits and their cores' tables with
each setting, against the reference. Last, the module's default ``(tol, n_min)`` and the
fastest candidate that keeps the branch within 2e-5 of the tip on the realistic grids and
the chain's DF within 2e-5 of the reference. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
from bench_voltage import median_time  # noqa: E402  (benchmarks/ is the script's folder)

from fitdf.chains import VoltageChain  # noqa: E402
from fitdf.inference.api import resolve_data, resolve_geometry  # noqa: E402
from fitdf.inference.problem import FitProblem  # noqa: E402
from fitdf.models import jiles_atherton  # noqa: E402
from fitdf.models._ja_branch import (  # noqa: E402
    STEADY_CACHE,
    _capacity,
    _eval_rows,
    _steady_rows,
)
from fitdf.models._ja_integrate import _NMIN, _TOL, coupling  # noqa: E402
from fitdf.models.jiles_atherton import JilesAtherton, ja_describing_function  # noqa: E402

PERMALLOY_LIKE = dict(lambda_s=0.06, a=2.9e-4, k=2.9e-4, c=0.2, zeta=0.5)
REFERENCE = (1e-11, 96)
CANDIDATES = [(1e-8, 24), (3e-8, 24), (1e-7, 24), (1e-7, 16), (3e-7, 16), (1e-6, 24), (1e-6, 12)]
BRANCH_LIMIT = 2e-5
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


def cached(on):
    STEADY_CACHE.clear()
    STEADY_CACHE.max_rows = 4096 if on else 0


def chain_pattern(repeats):
    m = 73
    rng = np.random.default_rng(0)
    A = np.sort(10 ** rng.uniform(-4, -2, (m, 1)), axis=0)
    th = {k: np.full((m, 1), v) for k, v in PERMALLOY_LIKE.items()}
    u32 = np.linspace(-1.0, 1.0, 32)
    u64a = np.sin(0.5 * np.pi * np.linspace(-1.0, 1.0, 64))
    u64b = np.sin(0.5 * np.pi * np.linspace(-1.0, 1.0, 64) ** 3)

    def three():
        STEADY_CACHE.clear()
        for u in (u32, u64a, u64b):
            JilesAtherton.ascending_branch(A * u, A, **th)

    rows = resolve_data("permalloy", "default", None)
    problem = FitProblem(
        rows, "jiles_atherton", "voltage", None, None, resolve_geometry("auto", rows)
    )
    start = problem.start_internal()

    def predict():
        STEADY_CACHE.clear()
        problem.predict(start)

    print(f"Part 1: cache, {m} rows; load average {os.getloadavg()[0]:.1f}")
    print(f"{'':34s} {'no cache':>10s} {'cache':>10s} {'ratio':>6s}")
    for label, fn in (("ascending_branch x3 (32, 64, 64)", three), ("voltage predict", predict)):
        times = []
        for on in (False, True):
            cached(on)
            times.append(median_time(fn, repeats))
        print(
            f"{label:34s} {times[0] * 1e3:8.2f} ms {times[1] * 1e3:8.2f} ms {times[0] / times[1]:6.2f}"
        )
    cached(True)
    rough_coarse_stage(problem, repeats)


def rough_coarse_stage(problem, repeats):
    """One ``voltage`` predict at the report's Permalloy fit with the coarse stage and the
    guess on the rough branch (the default) and on the exact branch, interleaved."""
    lam, a, k, c, zeta, r_w = REPORT_FITS["permalloy"][1]
    values = dict(lambda_s=lam, a=a, k=k, c=c, zeta=zeta, r_series=r_w)
    values.update({n: 1.0 for n in problem.names if n.startswith("gain")})
    point = problem.to_internal(values)
    rough = JilesAtherton.__dict__["rough_branch"]

    def predict():
        STEADY_CACHE.clear()
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
        f"{'voltage predict, coarse stage on':34s} {exact_t * 1e3:8.2f} ms exact branch "
        f"{rough_t * 1e3:8.2f} ms rough branch {exact_t / rough_t:6.2f}x; "
        f"max |dDF| {np.abs(dfs['exact'] - dfs['rough']).max():.1e}"
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
            rng.uniform(0.1, 0.9, n),
        ]
    )
    fits = np.array([v[1][:5] for v in REPORT_FITS.values()])
    report = fits[rng.integers(0, len(fits), n)] * np.exp(0.1 * rng.standard_normal((n, 5)))
    report[:, 4] = np.minimum(report[:, 4], 0.99)
    amps = 10 ** np.arange(-5.0, 0.25, 0.5)
    out = {}
    for name, theta in (("box", box), ("fitted", fitted), ("report", report)):
        rows = np.repeat(theta, amps.size, axis=0)
        out[name] = (np.tile(amps, n), *rows.T)
    return out


def branch_values(A, lam, a, k, c, zeta, tol, n_min, u):
    """``B(u A; A)`` rows by the kernels (:func:`_steady_rows`, :func:`_eval_rows`); solve time."""
    kap = coupling(lambda_s=lam, a=a, zeta=zeta)
    t0 = time.perf_counter()
    buf, off = _steady_rows(A, lam, a, k, c, kap, tol, n_min, _capacity(n_min))
    t_solve = time.perf_counter() - t0
    x = np.ascontiguousarray((A[:, None] * u).reshape(-1))
    index = np.arange(A.size + 1) * u.size
    out = np.empty(x.size)
    _eval_rows(buf, off, A, kap, x, index, out)
    return out.reshape(A.size, u.size), t_solve / A.size


def tolerance(n):
    """Part 2: per grid and step control, the errors against the reference and the solve time."""
    u = np.linspace(-1.0, 1.0, 257)
    print(
        f"\nPart 2: step control against tol = {REFERENCE[0]:g}, n_min = {REFERENCE[1]}; "
        f"{n} parameter draws x 11 amplitudes per grid"
    )
    print(
        f"{'grid':7s} {'tol':>6s} {'n_min':>5s} {'branch':>9s} {'N':>9s} {'Im N':>9s} "
        f"{'solve':>9s} {'speed-up':>8s} {'lost':>4s} {'ref-':>4s}  worst branch row"
    )
    results = {}
    for name, (A, lam, a, k, c, zeta) in grids(n).items():
        kw = dict(lambda_s=lam, a=a, k=k, c=c, zeta=zeta)
        B_ref, _ = branch_values(A, lam, a, k, c, zeta, *REFERENCE, u)
        N_ref = ja_describing_function(A, tol=REFERENCE[0], n_min=REFERENCE[1], **kw)
        ref_ok = np.isfinite(B_ref).all(axis=1) & np.isfinite(N_ref)
        t_default = None
        for cand in CANDIDATES:
            branch_values(A[:8], lam[:8], a[:8], k[:8], c[:8], zeta[:8], *cand, u)  # compile
            B, t_solve = min(
                (branch_values(A, lam, a, k, c, zeta, *cand, u) for _ in range(3)),
                key=lambda r: r[1],
            )
            N = ja_describing_function(A, tol=cand[0], n_min=cand[1], **kw)
            t_default = t_default or t_solve
            good = ref_ok & np.isfinite(B).all(axis=1) & np.isfinite(N)
            e_rows = np.max(np.abs(B - B_ref), axis=1) / np.abs(B_ref[:, -1])
            i = int(np.argmax(np.where(good, e_rows, -1.0)))
            e_n = np.max(np.abs(N - N_ref)[good] / np.abs(N_ref[good]))
            lossy = good & (np.abs(N_ref.imag) >= 0.01 * np.abs(N_ref))
            e_i = np.max(np.abs((N - N_ref).imag)[lossy] / np.abs(N_ref.imag[lossy]))
            lost, skipped = int(np.sum(ref_ok & ~good)), int(np.sum(~ref_ok))
            results[name, cand] = (e_rows[i], t_default / t_solve, lost)
            print(
                f"{name:7s} {cand[0]:6.0e} {cand[1]:5d} {e_rows[i]:9.1e} {e_n:9.1e} {e_i:9.1e} "
                f"{t_solve * 1e6:6.1f} us {t_default / t_solve:8.2f} {lost:4d} {skipped:4d}  "
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
                STEADY_CACHE.clear()
                dfs[setting] = chain.predict(JilesAtherton, V, f, Rs, th, ct)
        finally:
            jiles_atherton._TOL, jiles_atherton._NMIN = _TOL, _NMIN
            STEADY_CACHE.clear()
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
        f"{chain_worst[best]:.1e}, solve {min(results[g, best][1] for g in realistic):.2f}x "
        f"faster; box grid branch {results['box', best][0]:.1e}, default there "
        f"{results['box', CANDIDATES[0]][0]:.1e})"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    chain_pattern(5 if args.quick else 15)
    results = tolerance(40 if args.quick else 160)
    recommend(results, chain_errors())


if __name__ == "__main__":
    main()
