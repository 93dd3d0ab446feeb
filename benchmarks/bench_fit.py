"""Fitting benchmark: least squares on every core, and MCMC throughput against lmfit's emcee.

Run:  python benchmarks/bench_fit.py [--quick]

Prints, side by side in one run:
1. least squares of every model (winding chain) on every core (0 and 600 ohm jointly):
   seconds per fit, parameter sets evaluated, sets per second, RMS complex residual;
2. MCMC on Permalloy (600 ohm), proportional_width, through fitdf's sampler (emcee,
   log-probability vectorised over walkers; pilot, then independent production chains)
   and through lmfit's own ``Minimizer.emcee`` (walker by walker through lmfit
   Parameters), same walkers and steps: seconds, largest autocorrelation time, ESS from
   the integrated autocorrelation time, ESS per second, and the ratio of the two (aim
   >= 10x). ``--quick``: Permalloy and two models only, 300 steps.
No thresholds are asserted: the numbers are printed.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import emcee
import lmfit

from fitdf.inference.api import resolve_data
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.mcmc import fit_mcmc
from fitdf.inference.problem import FitProblem
from fitdf.models import model_names


class CountingProblem(FitProblem):
    """Counts parameter vectors evaluated (a batch of W counts W)."""

    evaluations = 0

    def weighted_residuals(self, internal):
        internal = np.asarray(internal)
        CountingProblem.evaluations += int(np.prod(internal.shape[:-1])) if internal.ndim > 1 else 1
        return super().weighted_residuals(internal)


def bench_lsq(cores, models):
    print("== least squares (winding chain, 0 + 600 ohm jointly, multi-start 6 of 256 screened) ==")
    print(
        f"{'core':<12s} {'model':<26s} {'seconds':>8s} {'evals':>8s} {'evals/s':>9s} {'rms_complex':>12s}"
    )
    total = 0.0
    for core in cores:
        data = resolve_data(core)
        for model in models:
            problem = CountingProblem(data, model, "winding")
            CountingProblem.evaluations = 0
            t0 = time.perf_counter()
            r = fit_lsq(problem, seed=0)
            dt = time.perf_counter() - t0
            total += dt
            ev = CountingProblem.evaluations
            print(
                f"{core:<12s} {model:<26s} {dt:8.2f} {ev:8d} {ev / dt:9.0f} {r.metrics['rms_complex']:12.4f}"
            )
    print(f"total least-squares time: {total:.1f} s")


def _ess(chain):
    tau = emcee.autocorr.integrated_time(chain, tol=0)
    n = chain.shape[0] * chain.shape[1]
    return n / tau, tau


def bench_mcmc(core, model, steps, walkers):
    print(f"\n== MCMC on {core}, model {model}: {walkers} walkers x {steps} steps ==")
    data = resolve_data(core, source_impedance=600.0)
    problem = FitProblem(data, model, "winding")
    lsq = fit_lsq(problem, seed=0)

    t0 = time.perf_counter()
    post = fit_mcmc(problem, lsq, seed=1, n_walkers=walkers, n_steps=steps)
    t_ours = time.perf_counter() - t0
    ess_ours = min(post.diagnostics["ess_bulk"][n] for n in problem.names)
    # ESS of the full post-burn chain from emcee's integrated time, comparable with lmfit's
    # below; fitdf's production chain is n_walkers (8) independent chains after a pilot of
    # ``walkers`` walkers (its time is in t_ours)
    d = post.diagnostics
    tau_ours = np.array([d["tau"][n] for n in problem.names])
    ess_tau_ours = (d["n_steps"] - d["burn"]) * d["n_walkers"] / tau_ours.max()

    params = lmfit.Parameters()
    lo, hi = problem.internal_bounds().T
    for i, v in enumerate(lsq.internal):
        params.add(f"p{i}", value=float(v), min=lo[i], max=hi[i])

    def residual(p):
        x = np.array([p[f"p{i}"].value for i in range(problem.ndim)])
        return problem.weighted_residuals(x)

    mini = lmfit.Minimizer(residual, params)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = mini.emcee(
            steps=steps, nwalkers=walkers, burn=0, is_weighted=True, seed=1, progress=False
        )
    t_lmfit = time.perf_counter() - t0
    chain = res.flatchain.to_numpy().reshape(steps, walkers, -1)
    burn = post.diagnostics["burn"]
    ess_l, tau_l = _ess(chain[burn:])
    ess_tau_lmfit = float(np.min(ess_l))

    print(f"{'sampler':<28s} {'seconds':>8s} {'max tau':>8s} {'ESS':>9s} {'ESS/s':>9s}")
    print(
        f"{'fitdf (vectorised emcee)':<28s} {t_ours:8.2f} {tau_ours.max():8.1f} {ess_tau_ours:9.0f} "
        f"{ess_tau_ours / t_ours:9.1f}   (ArviZ multi-chain bulk ESS: {ess_ours:.0f}; pilot "
        f"{walkers} walkers x 2 x {d['pilot_steps']}, production {d['n_walkers']} chains)"
    )
    print(
        f"{'lmfit Minimizer.emcee':<28s} {t_lmfit:8.2f} {np.max(tau_l):8.1f} {ess_tau_lmfit:9.0f} "
        f"{ess_tau_lmfit / t_lmfit:9.1f}"
    )
    ratio = (ess_tau_ours / t_ours) / (ess_tau_lmfit / t_lmfit)
    print(
        f"ESS/s ratio fitdf / lmfit: {ratio:.1f}x (aim >= 10x: {'met' if ratio >= 10 else 'NOT met'})"
    )
    print("note: fitdf also samples two noise scales; lmfit's is_weighted=True keeps them fixed.")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer models and steps")
    args = ap.parse_args()
    cores = ["permalloy", "deltamax", "supermalloy"]
    models = model_names()
    if args.quick:
        cores, models = ["permalloy"], ["constant_width", "proportional_width"]
    bench_lsq(cores, models)
    bench_mcmc("permalloy", "proportional_width", steps=300 if args.quick else 1000, walkers=32)


if __name__ == "__main__":
    main()
