"""What the report's chains cost, and what converging them would cost at least.

Run from the repository root::

    python benchmarks/mcmc_budget.py                         # the committed report
    python benchmarks/mcmc_budget.py path/to/results.json --cores 8

Reads a report's ``results.json`` (its ``timing.jobs_s`` and each chain's diagnostics) and
prints, chain by chain: the likelihood evaluations of the pilot (its rounds times
``2 d + 2`` walkers times ``pilot_steps``) and of production (steps times chains), the job's
seconds per evaluation, the largest autocorrelation time, and the *floor*: the
evaluations the convergence rule needs at that autocorrelation time with no pilot at all,
``n_chains x 50 tau`` (50 autocorrelation times per chain; with 8 chains that is also the
bulk ESS of 400), and its seconds at the measured cost per evaluation. R-hat < 1.01 usually
needs more (the chains that converge stopped at 90-150 autocorrelation times), so the floor
is a lower bound.

Then the report as a whole: the job-seconds outside MCMC, the MCMC floor, the wall time
they need on ``--cores`` at best (job-seconds over cores; the figures, which run after
the jobs, added), and the longest single job at its floor (no number of cores makes the
report shorter than that), and how many times the work would have to shrink to fit a
10-minute aim (600 s). And the same for fewer sampled laws: MCMC for the best one or two
sampled laws of each block only (by the least-squares order), at their cost as run and
at their floor.

The autocorrelation time is the chain's estimate where it stopped: for a chain that
stopped unconverged it is low, if anything (it was still growing), so the floor is
optimistic there too. No thresholds: numbers only.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fitdf.report.upgrade import read_results

ROOT = Path(__file__).resolve().parents[1]
AIM_S = 600.0


def pilot_walkers(d: int, n_walkers=None) -> int:
    """The pilot's walkers for ``d`` sampled dimensions (as ``fit_mcmc`` sets them)."""
    w = max(n_walkers or 0, 2 * d + 2)
    return w + w % 2


def chain_rows(results: dict) -> list[dict]:
    jobs = results["timing"]["jobs_s"]
    walkers_setting = results["settings"].get("n_walkers")
    # (``fit_mcmc``'s default pilot round: ``min(300, n_steps)``)
    pilot_steps = min(300, results["settings"]["n_steps"])
    rows = []
    for key, block in results["blocks"].items():
        for law, fit in block["fits_posterior"].items():
            if fit.get("method", "mcmc") != "mcmc":
                continue  # (a nested-sampling posterior: no chain)
            g = fit["diagnostics"]
            d = len(g["tau"])
            pilot = (
                len(g["pilot_rounds"])
                * g.get("pilot_steps", pilot_steps)
                * pilot_walkers(d, walkers_setting)
            )
            production = g["n_steps"] * g["n_walkers"]
            seconds = jobs[f"mcmc {key} {law}"]
            per_eval = seconds / (pilot + production)
            tau = max(g["tau"].values())
            floor_evals = g["n_walkers"] * 50 * tau
            rows.append(
                {
                    "block": key,
                    "law": law,
                    "d": d,
                    "pilot": pilot,
                    "production": production,
                    "seconds": seconds,
                    "ms_per_eval": 1e3 * per_eval,
                    "tau": tau,
                    "converged": g["converged"],
                    "floor_evals": floor_evals,
                    "floor_s": floor_evals * per_eval,
                    "lsq_s": jobs.get(f"{key} {law}", 0.0),
                }
            )
    return rows


def best_sampled(results: dict, top: int) -> set:
    """``(block, law)`` of the best ``top`` sampled laws of each block (least-squares order)."""
    chosen = set()
    for key, block in results["blocks"].items():
        sampled = [law for law in block["order_lsq"] if law in block["fits_posterior"]]
        chosen |= {(key, law) for law in sampled[:top]}
    return chosen


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="?", default=str(ROOT / "reports" / "results.json"))
    parser.add_argument("--cores", type=int, default=2)
    ns = parser.parse_args(argv)
    results = read_results(ns.results)
    rows = chain_rows(results)
    if not rows:
        print(
            f"{ns.results}: no emcee chains (its posteriors are nested sampling's); pass the "
            "results.json of a report made with ReportSettings(sampler='emcee')"
        )
        return 2
    print(
        f"{'block':<16s} {'law':<15s} {'d':>2s} {'pilot ev':>9s} {'prod ev':>8s} {'pilot %':>7s} "
        f"{'job s':>6s} {'ms/ev':>6s} {'tau':>6s} {'conv':>4s} {'floor ev':>9s} {'floor s':>7s}"
    )
    for r in rows:
        share = 100 * r["pilot"] / (r["pilot"] + r["production"])
        print(
            f"{r['block']:<16s} {r['law']:<15s} {r['d']:>2d} {r['pilot']:>9d} {r['production']:>8d} "
            f"{share:>6.0f}% {r['seconds']:>6.0f} {r['ms_per_eval']:>6.2f} {r['tau']:>6.1f} "
            f"{'yes' if r['converged'] else 'no':>4s} {r['floor_evals']:>9.0f} {r['floor_s']:>7.0f}"
        )
    jobs = results["timing"]["jobs_s"]
    mcmc_s = sum(r["seconds"] for r in rows)
    other_s = sum(v for k, v in jobs.items() if not k.startswith("mcmc "))
    floor_s = sum(r["floor_s"] for r in rows)
    pilot_s = sum(r["seconds"] * r["pilot"] / (r["pilot"] + r["production"]) for r in rows)
    figures_s = results["timing"].get("figures_s", 0.0)
    longest = max(rows, key=lambda r: r["lsq_s"] + r["floor_s"])
    best_wall = (other_s + floor_s) / ns.cores + figures_s
    print()
    print(
        f"report as run: {results['timing']['total_s']:.0f} s on {results['timing']['workers']} workers"
    )
    print(f"  job-seconds: MCMC {mcmc_s:.0f} (pilot {pilot_s:.0f}), everything else {other_s:.0f}")
    print(f"  converged: {sum(r['converged'] for r in rows)} of {len(rows)} chains")
    print(f"MCMC floor at these autocorrelation times and costs: {floor_s:.0f} job-s")
    print(
        f"  wall time on {ns.cores} cores at best: ({other_s:.0f} + {floor_s:.0f}) / {ns.cores} "
        f"+ figures {figures_s:.0f} = {best_wall:.0f} s (aim {AIM_S:.0f} s: "
        f"{'within reach' if best_wall <= AIM_S else 'out of reach'} with these samplers)"
    )
    print(
        f"  longest job at its floor: {longest['block']} {longest['law']}, least squares "
        f"{longest['lsq_s']:.0f} s + MCMC {longest['floor_s']:.0f} s (the wall time on any "
        f"number of cores is at least this)"
    )
    budget = AIM_S - figures_s
    need = (other_s + floor_s) / (ns.cores * budget)
    print(
        f"  to fit in {AIM_S:.0f} s on {ns.cores} cores the work would have to shrink {need:.1f}x "
        f"(least squares and MCMC together)"
    )
    for top in (1, 2):
        chosen = best_sampled(results, top)
        part = [r for r in rows if (r["block"], r["law"]) in chosen]
        as_run = sum(r["seconds"] for r in part)
        floor = sum(r["floor_s"] for r in part)
        print(
            f"MCMC for the best {top} sampled law{'s' if top > 1 else ''} of each block only "
            f"({len(part)} chains, {sum(r['converged'] for r in part)} converged as run): "
            f"MCMC {as_run:.0f} job-s as run, floor {floor:.0f}; wall on {ns.cores} cores at "
            f"best {(other_s + as_run) / ns.cores + figures_s:.0f} s as run, "
            f"{(other_s + floor) / ns.cores + figures_s:.0f} s at the floor"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
