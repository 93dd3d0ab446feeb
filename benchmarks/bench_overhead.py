"""Where one MCMC step's log-posterior goes: the law, the circuit, and the bookkeeping around them.

Run:  python benchmarks/bench_overhead.py B.3:cubic_hc [B.1:preisach ...] [--walkers 8]

For each ``block:law`` it fits the law by least squares as the report does, then calls the
report's log-posterior (logit coordinates, noise integrated out) on ``--walkers`` sets
drawn from the least-squares covariance (seed 1), as one production step of the report's
eight chains does, and splits the time of a call into:

* ``branch``: the law's rising branch, tabulated at the nodes of every amplitude tried
  (:meth:`fitdf.chains.voltage._Points.branch`: NumPy for the closed forms, compiled for
  Preisach and Jiles-Atherton);
* ``kernel``: the compiled half period of the circuit (:func:`fitdf.chains._periodic.half_periods`);
* ``secant`` and ``place``: the compiled root-search update and node placement;
* ``rest``: everything else, the Python and NumPy of the root search's stages, which is
  paid per stage and iteration whatever the number of points (so it weighs most where
  the batch is small: eight chains, and the last iterations of a search, where a few
  points are still short of the tolerance).

Prints one row per ``block:law``: the rows of the block, the milliseconds of one call and of
each part, with its share. Timers wrap the functions in this process only (the library is
not changed). Numbers only, no thresholds.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _report_fit import report_lsq

import fitdf.chains.voltage as voltage
from fitdf.inference.mcmc import LogPosterior
from fitdf.report.settings import ReportSettings

PARTS = ("branch", "kernel", "secant", "place")


def _timed(spent: dict, label: str, fn):
    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            spent[label] += time.perf_counter() - t0

    return wrapper


def run(block_key: str, law: str, n_walkers: int, seconds: float) -> None:
    lsq = report_lsq(block_key, law, 0, ReportSettings.for_run())
    problem = lsq.problem.warm_started(lsq.internal)
    logpost = LogPosterior(problem, logit=True, marginal_noise=True)
    rng = np.random.default_rng(1)
    sets = rng.multivariate_normal(
        lsq.internal, np.asarray(lsq.info["covar_internal"]), size=n_walkers
    )
    lo, hi = logpost.bounds[:, 0], logpost.bounds[:, 1]
    z = logpost.to_sampler(np.clip(sets, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo)))
    logpost(z)  # compiled code loaded, caches warm

    spent = dict.fromkeys(PARTS, 0.0)
    saved = {
        "kernel": voltage.half_periods,
        "secant": voltage.secant_update,
        "place": voltage.place_nodes,
        "branch": voltage._Points.branch,
    }
    voltage.half_periods = _timed(spent, "kernel", saved["kernel"])
    voltage.secant_update = _timed(spent, "secant", saved["secant"])
    voltage.place_nodes = _timed(spent, "place", saved["place"])
    voltage._Points.branch = _timed(spent, "branch", saved["branch"])
    try:
        calls, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds or calls < 3:
            logpost(z)
            calls += 1
        total = (time.perf_counter() - t0) / calls
    finally:
        voltage.half_periods = saved["kernel"]
        voltage.secant_update = saved["secant"]
        voltage.place_nodes = saved["place"]
        voltage._Points.branch = saved["branch"]
    part = {k: v / calls for k, v in spent.items()}
    rest = total - sum(part.values())
    cells = "".join(f" {1e3 * part[k]:>7.2f} ({part[k] / total:>3.0%})" for k in PARTS)
    print(
        f"{block_key:<16s} {law:<15s} {problem.data.n:>4d} {1e3 * total:>8.2f}{cells} "
        f"{1e3 * rest:>7.2f} ({rest / total:>3.0%})",
        flush=True,
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("chains", nargs="+", metavar="BLOCK:LAW")
    parser.add_argument("--walkers", type=int, default=8, help="sets per call (default 8)")
    parser.add_argument("--seconds", type=float, default=3.0, help="timing per chain")
    args = parser.parse_args(argv)
    head = "".join(f" {p + ' ms':>13s}" for p in PARTS)
    print(f"{'block':<16s} {'law':<15s} {'rows':>4s} {'call ms':>8s}{head} {'rest ms':>13s}")
    for spec in args.chains:
        block_key, _, law = spec.partition(":")
        run(block_key, law, args.walkers, args.seconds)


if __name__ == "__main__":
    main()
