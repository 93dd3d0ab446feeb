"""One report chain at a time: least squares, then MCMC with the report's settings.

Run:  python benchmarks/bench_chain.py B.5:cubic_hc [B.1:preisach ...] [--seed 0]
          [--steps MAX EXTEND]

For each ``block:law`` (a report block, ``permalloy-joint`` and ``deltamax-joint`` included)
it fits the law by least squares as the report does, then runs the report's MCMC job on it
(the same ``n_steps``, step limits of the law, ``ReportSettings.step_limits``, and checks;
``--steps`` replaces the step limits), and prints one row: the least-squares chi-square and
seconds, the chain's length, steps over its largest autocorrelation time, largest R-hat,
smallest bulk ESS, mean acceptance, whether it meets the convergence rule, and the MCMC's
seconds. The jobs are deterministic: with the same seed, CPU and libraries this is the
report's chain step for step, so a change to a law's coordinates or to the sampler can be
measured chain by chain without a full report. No thresholds: numbers only.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _report_fit import report_lsq

from fitdf.report.jobs import job_mcmc
from fitdf.report.settings import ReportSettings


def run(block_key: str, law: str, seed: int, settings: ReportSettings, limits=None) -> None:
    t0 = time.perf_counter()
    lsq = report_lsq(block_key, law, seed, settings)
    t1 = time.perf_counter()
    limits = limits or settings.step_limits(law)
    post = job_mcmc(lsq, seed, settings.n_steps, settings.n_walkers, *limits)
    t2 = time.perf_counter()
    d = post.diagnostics
    rhat, ess = max(d["rhat"].values()), min(d["ess_bulk"].values())
    print(
        f"{block_key:<16s} {law:<15s} {lsq.metrics['chi2']:>9.1f} {t1 - t0:>6.1f}s "
        f"{d['n_steps']:>6d} {d['steps_over_tau']:>9.1f} {rhat:>8.3f} "
        f"{ess:>7.0f} {d['acceptance_mean']:>6.3f} "
        f"{'yes' if d['converged'] else 'no':>9s} {t2 - t1:>7.1f}s",
        flush=True,
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("chains", nargs="+", metavar="BLOCK:LAW")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--steps",
        type=int,
        nargs=2,
        metavar=("MAX", "EXTEND"),
        help="the chains' max_steps and extend_steps (default: the report's for each law)",
    )
    args = parser.parse_args(argv)
    settings = ReportSettings.for_run()
    print(
        f"{'block':<16s} {'law':<15s} {'lsq chi2':>9s} {'lsq':>7s} {'steps':>6s} "
        f"{'steps/tau':>9s} {'R-hat':>8s} {'ESS':>7s} {'accept':>6s} {'converged':>9s} {'mcmc':>8s}"
    )
    for spec in args.chains:
        block_key, _, law = spec.partition(":")
        run(block_key, law, args.seed, settings, args.steps)


if __name__ == "__main__":
    main()
