"""nautilus's batch size (points per likelihood call) at equal evidence: Preisach on B.3.

Run:  python benchmarks/nautilus_batch.py [--batches 100 300 600] [--seeds 1 2] [--out FILE]

Fits Preisach to Table B.3 by least squares as the report does, then samples its posterior
with :func:`fitdf.inference.nested.fit_nested` (the report's live points and networks) at
each batch size and seed, the batch sizes in a rotated order per seed so that a change of
the machine's load falls on all of them. Prints per run ln Z and its error, the likelihood
evaluations, the likelihood calls' share of the time, wall and CPU seconds; then per batch
size the means. Settings are at equal evidence when their ln Z agree within 0.1. ``--out``
appends one JSON line per run. Numbers only, no thresholds.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _report_fit import report_lsq

from fitdf.inference import nested
from fitdf.report.settings import ReportSettings


class _Timed:
    """The likelihood, timed: its seconds and calls (the rest of a run is nautilus's)."""

    def __init__(self, fn):
        self.fn, self.seconds, self.calls = fn, 0.0, 0

    def __call__(self, x):
        t0 = time.perf_counter()
        try:
            return self.fn(x)
        finally:
            self.seconds += time.perf_counter() - t0
            self.calls += 1

    def __getattr__(self, name):  # the wrapped likelihood's noise marginal and counters
        return getattr(self.fn, name)


def run(lsq, n_batch: int, seed: int) -> dict:
    saved = nested.NestedLikelihood
    timers = []

    def timed_likelihood(problem):
        timers.append(_Timed(saved(problem)))
        return timers[-1]

    nested.NestedLikelihood = timed_likelihood
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        res = nested.fit_nested(lsq.problem, lsq, seed=seed, n_batch=n_batch)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        nested.NestedLikelihood = saved
    d = res.diagnostics
    return {
        "n_batch": n_batch,
        "seed": seed,
        "log_z": d["log_evidence"],
        "log_z_error": d["log_evidence_error"],
        "n_like": d["n_likelihood_evaluations"],
        "calls": timers[0].calls,
        "likelihood_s": timers[0].seconds,
        "sampler_s": d["seconds"],
        "wall_s": wall,
        "cpu_s": cpu,
        "converged": d["converged"],
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, nargs="+", default=[100, 300, 600])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    lsq = report_lsq("B.3", "preisach", 0, ReportSettings.for_run())
    rows = []
    print("n_batch seed   ln Z    err  evals calls like_s  wall_s  cpu_s conv", flush=True)
    for k, seed in enumerate(args.seeds):
        order = args.batches[k % len(args.batches) :] + args.batches[: k % len(args.batches)]
        for n_batch in order:
            r = run(lsq, n_batch, seed)
            rows.append(r)
            print(
                f"{r['n_batch']:7d} {seed:4d} {r['log_z']:7.2f} {r['log_z_error']:6.3f} "
                f"{r['n_like']:6d} {r['calls']:5d} {r['likelihood_s']:6.1f} "
                f"{r['wall_s']:7.1f} {r['cpu_s']:6.1f} {r['converged']}",
                flush=True,
            )
            if args.out:
                with args.out.open("a") as fh:
                    fh.write(json.dumps(r) + "\n")
    print("\nper batch size (means over seeds):")
    for n_batch in args.batches:
        sel = [r for r in rows if r["n_batch"] == n_batch]
        m = {k: float(np.mean([r[k] for r in sel])) for k in ("log_z", "n_like", "wall_s", "cpu_s")}
        spread = max(r["log_z"] for r in sel) - min(r["log_z"] for r in sel)
        print(
            f"  {n_batch:4d}: ln Z {m['log_z']:.2f} (spread {spread:.2f}), "
            f"{m['n_like']:.0f} evaluations, {m['wall_s']:.0f} s wall, {m['cpu_s']:.0f} s CPU"
        )


if __name__ == "__main__":
    main()
