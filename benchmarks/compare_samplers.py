"""Nested samplers on the hard posteriors: nautilus, dynesty and UltraNest against emcee.

Run from the repository root (each sampler must be installed: ``pip install
nautilus-sampler dynesty ultranest``)::

    python benchmarks/compare_samplers.py run B.3:cubic_hc:nautilus:0 [...] [--max-evals 60000]
    python benchmarks/compare_samplers.py table          # the runs so far, and emcee's
    python benchmarks/compare_samplers.py weight         # versions and dependency weight

``run`` takes ``block:law:sampler:seed`` (``block`` a bundled table, ``B.4/dynamic`` for the
``dynamic`` chain; otherwise the ``voltage`` chain), fits the law by least squares
(``fitdf.fit(block, law, method="lsq")``, kept in ``--lsq-cache``), and samples the
posterior fitdf's nested engine samples (:mod:`fitdf.inference.nested`): the same prior
(:class:`~fitdf.inference.nested.PriorTransform`: uniform on the box, log-uniform for log
parameters, the series resistance's truncated log-normal) and the same noise-marginal
likelihood (:class:`~fitdf.inference.nested.NestedLikelihood`, the chain's solver started
cold), run until the convergence rule of
:func:`fitdf.inference.nested.is_converged` (400 effective draws, Kish, and a log-evidence
error of at most 0.3) or ``--max-evals`` evaluations. It appends one JSON record to
``--out``: evaluations (counted in the likelihood), effective draws, their ratio,
log-evidence and the sampler's error of it, wall and CPU seconds and the seconds inside
the likelihood, converged or not.

The samplers, with settings chosen to meet the rule:

* **nautilus** (Lange 2023): :func:`fitdf.inference.nested.run_nautilus`, ``--live``
  live points (default 1000), 4 networks, batches of 100 points per likelihood call, the
  exploration's draws discarded; its error is
  :func:`~fitdf.inference.nested.log_evidence_error`. The record also gives the figures
  with the exploration kept (more draws, a biased estimate).
* **dynesty** (Speagle 2020): static nested sampling, ``--live`` live points (default
  500), multi-ellipsoid bounds, its default sampling for the dimension, stopping at
  ``dlogz`` 0.1; its error is its own ``logzerr``. dynesty calls the likelihood one point
  at a time (no vectorised calls), which costs a chain several times its batched cost per
  point: compare evaluations, not seconds.
* **UltraNest** (Buchner 2021): ``ReactiveNestedSampler`` with vectorised calls, at least
  ``--live`` live points (default 400), ``min_ess`` 400, ``dlogz`` 0.5, its default
  region (MLFriends) sampling; its error is its own ``logzerr`` (bootstrapped).

``table`` prints the records (per block and law: evaluations, effective draws per
evaluation, log-evidence +- error, the spread of log-evidence over seeds, wall seconds,
converged) beside emcee's chain in the committed report (``reports/results.json``: its
evaluations, pilot and production, as ``mcmc_budget.py`` counts them, and smallest bulk
ESS), then the choice. ``weight`` prints each sampler's version, what it installs beyond
fitdf's own dependencies, and the size of those files.

References
----------
Lange, J. U., "nautilus: boosting Bayesian importance nested sampling with deep learning",
Mon. Not. R. Astron. Soc. 525, 3181 (2023).

Speagle, J. S., "dynesty: a dynamic nested sampling package for estimating Bayesian
posteriors and evidences", Mon. Not. R. Astron. Soc. 493, 3132 (2020).

Buchner, J., "UltraNest - a robust, general purpose Bayesian inference engine", J. Open
Source Softw. 6, 3001 (2021).

Skilling, J., "Nested sampling for general Bayesian computation", Bayesian Analysis 1, 833
(2006).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
import time
from importlib.metadata import PackageNotFoundError, distribution, requires
from importlib.metadata import version as package_version
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before NumPy loads BLAS
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from mcmc_budget import chain_rows  # noqa: E402

import fitdf  # noqa: E402
from fitdf.inference.api import resolve_data, resolve_geometry  # noqa: E402
from fitdf.inference.nested import (  # noqa: E402
    MAX_LOG_EVIDENCE_ERROR,
    MIN_EFFECTIVE,
    NestedLikelihood,
    PriorTransform,
    is_converged,
    kish_size,
    log_evidence_error,
    run_nautilus,
)
from fitdf.inference.problem import FitProblem  # noqa: E402
from fitdf.report.upgrade import read_results  # noqa: E402

SAMPLERS = ("nautilus", "dynesty", "ultranest")
DISTRIBUTIONS = {"nautilus": "nautilus-sampler", "dynesty": "dynesty", "ultranest": "ultranest"}
DEFAULT_LIVE = {"nautilus": 1000, "dynesty": 500, "ultranest": 400}
OUT = Path(__file__).resolve().parent / "compare_samplers.json"  # the committed records


class Counted:
    """The likelihood, counting evaluations and the seconds spent in it."""

    def __init__(self, loglike):
        self.loglike = loglike
        self.n = 0
        self.seconds = 0.0

    def __call__(self, x):
        t0 = time.perf_counter()
        x = np.asarray(x, float)
        out = self.loglike(x)
        self.n += 1 if x.ndim == 1 else x.shape[0]
        self.seconds += time.perf_counter() - t0
        return out

    def single(self, x):
        """One point ``(P,)`` -> a float (dynesty's calls)."""
        return float(self(np.asarray(x, float)[None, :])[0])


def block_chain(block: str) -> tuple[str, str]:
    """``B.4/dynamic`` -> ``("B.4", "dynamic")``; ``B.3`` -> ``("B.3", "voltage")``."""
    key, _, chain = block.partition("/")
    return key, chain or "voltage"


def problem_and_start(block: str, law: str, cache: Path):
    """The fit problem of ``law`` on ``block`` and its least-squares optimum (internal), as
    ``fitdf.fit(key, law, chain=..., method="lsq")`` gives them (kept in ``cache``)."""
    key, chain = block_chain(block)
    kept = json.loads(cache.read_text()) if cache.exists() else {}
    name = f"{block}:{law}"
    if name not in kept:
        t0 = time.perf_counter()
        lsq = fitdf.fit(key, law, chain=chain, method="lsq")
        kept[name] = {
            "internal": list(map(float, lsq.internal)),
            "seconds": time.perf_counter() - t0,
        }
        cache.write_text(json.dumps(kept, indent=1))
        return lsq.problem, lsq.internal
    rows = resolve_data(key, "default", None)
    problem = FitProblem(rows, law, chain, None, None, resolve_geometry("auto", rows))
    return problem, np.asarray(kept[name]["internal"], float)


def run_nautilus_case(transform, loglike, ndim, seed, max_evals, n_live, n_networks=4):
    ns, error, rounds, finished = run_nautilus(
        transform,
        loglike,
        ndim,
        seed=seed,
        n_live=n_live,
        n_networks=n_networks,
        max_evaluations=max_evals,
        discard_exploration=True,
    )
    out = {
        "log_z": float(ns.log_z),
        "log_z_error": error,
        "n_eff": float(ns.n_eff),
        "finished": finished,
        "settings": {
            "n_live": n_live,
            "n_networks": n_networks,
            "n_batch": int(ns.n_batch),
            "f_live": 0.01,
            "discard_exploration": True,
            "rounds": rounds,
        },
    }
    ns.discard_exploration = False  # the same run's figures with the exploration kept
    out["exploration_kept"] = {
        "log_z": float(ns.log_z),
        "log_z_error": log_evidence_error(ns),
        "n_eff": float(ns.n_eff),
    }
    ns.discard_exploration = True
    return out


def run_dynesty(transform, loglike, ndim, seed, max_evals, n_live, n_networks=None):
    import dynesty

    sampler = dynesty.NestedSampler(
        loglike.single, transform, ndim, nlive=n_live, bound="multi",
        rstate=np.random.default_rng(seed),
    )  # fmt: skip
    sampler.run_nested(dlogz=0.1, maxcall=max_evals, print_progress=False)
    res = sampler.results
    return {
        "log_z": float(res.logz[-1]),
        "log_z_error": float(res.logzerr[-1]),
        "n_eff": kish_size(res.logwt),
        "finished": loglike.n < max_evals,
        "settings": {"nlive": n_live, "bound": "multi", "sample": type(getattr(sampler, "internal_sampler", sampler)).__name__,
                     "dlogz": 0.1, "vectorized": False},
    }  # fmt: skip


def run_ultranest(transform, loglike, ndim, seed, max_evals, n_live, n_networks=None):
    import ultranest

    logging.getLogger("ultranest").setLevel(logging.WARNING)
    np.random.seed(seed)  # noqa: NPY002  (UltraNest draws from NumPy's global generator)
    names = [f"x{i}" for i in range(ndim)]
    sampler = ultranest.ReactiveNestedSampler(
        names, loglike, transform, vectorized=True, ndraw_min=128, ndraw_max=4096
    )
    res = sampler.run(
        min_num_live_points=n_live, min_ess=MIN_EFFECTIVE, dlogz=0.5, frac_remain=0.01,
        max_ncalls=max_evals, show_status=False, viz_callback=False,
    )  # fmt: skip
    w = np.asarray(res["weighted_samples"]["weights"], float)
    return {
        "log_z": float(res["logz"]),
        "log_z_error": float(res["logzerr"]),
        "n_eff": kish_size(np.log(np.clip(w, 1e-300, None))),
        "finished": loglike.n < max_evals,
        "settings": {"min_num_live_points": n_live, "min_ess": MIN_EFFECTIVE, "dlogz": 0.5,
                     "frac_remain": 0.01, "region": "MLFriends", "vectorized": True},
    }  # fmt: skip


RUNNERS = {"nautilus": run_nautilus_case, "dynesty": run_dynesty, "ultranest": run_ultranest}


def run(
    spec: str, max_evals: int, out: Path, cache: Path, n_live: int | None, n_networks: int = 4
) -> dict:
    block, law, sampler, seed = spec.split(":")
    seed = int(seed)
    problem, _ = problem_and_start(block, law, cache)  # (the solver starts cold, as the engine's)
    transform = PriorTransform(problem)
    loglike = Counted(NestedLikelihood(problem))
    n_live = n_live or DEFAULT_LIVE[sampler]
    t0, c0 = time.perf_counter(), time.process_time()
    rec = RUNNERS[sampler](transform, loglike, problem.ndim, seed, max_evals, n_live, n_networks)
    rec.update(
        {
            "block": block,
            "law": law,
            "sampler": sampler,
            "version": package_version(DISTRIBUTIONS[sampler]),
            "seed": seed,
            "ndim": problem.ndim,
            "n_like": loglike.n,
            "max_evals": max_evals,
            "wall_s": time.perf_counter() - t0,
            "cpu_s": time.process_time() - c0,
            "likelihood_s": loglike.seconds,
            "load_average": os.getloadavg()[0],
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
        }
    )
    rec["converged"] = is_converged(rec["n_eff"], rec["log_z_error"])
    rec["eff_per_eval"] = rec["n_eff"] / max(rec["n_like"], 1)
    records = json.loads(out.read_text()) if out.exists() else []
    records.append(rec)
    out.write_text(json.dumps(records, indent=1))
    print(
        f"{block} {law} {sampler} seed {seed}: {rec['n_like']} evaluations, "
        f"{rec['n_eff']:.0f} effective ({rec['eff_per_eval']:.4f}/evaluation), "
        f"log Z {rec['log_z']:.2f} +- {rec['log_z_error']:.2f}, {rec['wall_s']:.0f} s wall "
        f"({rec['likelihood_s']:.0f} s likelihood), converged {rec['converged']}",
        flush=True,
    )
    return rec


#: emcee's chains for these posteriors in the last report sampled by emcee (EPYC, 2 cores):
#: pilot and production evaluations, smallest bulk ESS, job seconds.
EMCEE_EPYC = {
    ("B.3", "cubic_hc"): {"evals": 85200, "ess": 26, "seconds": 251, "converged": False},
    ("B.3", "preisach"): {"evals": 75000, "ess": 21, "seconds": 583, "converged": False},
}


def emcee_rows(results_path: Path) -> dict:
    """``(block, law)`` -> emcee's chain in a report: evaluations, smallest bulk ESS, job s
    (:data:`EMCEE_EPYC` for what a report sampled by nested sampling lacks)."""
    results = read_results(results_path) if results_path.exists() else None
    out = dict(EMCEE_EPYC)
    if results is None:
        return out
    for r in chain_rows(results):
        g = results["blocks"][r["block"]]["fits_posterior"][r["law"]]["diagnostics"]
        out[(r["block"], r["law"])] = {
            "evals": r["pilot"] + r["production"],
            "ess": min(g["ess_bulk"].values()),
            "seconds": r["seconds"],
            "converged": g["converged"],
        }
    return out


def variant(record) -> tuple[str, str]:
    """``(sampler, settings label)``: nautilus's runs are told apart by live points and
    networks (`` 500/1``); the others by sampler alone."""
    if record["sampler"] != "nautilus":
        return record["sampler"], ""
    s = record["settings"]
    return "nautilus", f" {s['n_live']}/{s['n_networks']}"


def variants(records) -> list:
    """The samplers and settings in ``records``, in :data:`SAMPLERS` order, nautilus's by
    live points."""
    found = {variant(r) for r in records}
    return sorted(found, key=lambda v: (SAMPLERS.index(v[0]), int(v[1].split("/")[0] or 0), v[1]))


def table(out: Path, results_path: Path) -> None:
    records = json.loads(out.read_text()) if out.exists() else []
    emcee = emcee_rows(results_path)
    cases = sorted({(r["block"], r["law"]) for r in records})
    head = (
        f"{'block':<12s} {'law':<9s} {'sampler':<17s} {'runs':>4s} {'evals':>7s} {'n_eff':>6s} "
        f"{'eff/eval':>8s} {'log Z':>8s} {'+-':>5s} {'spread':>6s} {'wall s':>7s} {'like %':>6s} "
        f"{'conv':>5s}"
    )
    print(head)
    for block, law in cases:
        key = block_chain(block)[0]
        e = emcee.get((key, law)) if block_chain(block)[1] == "voltage" else None
        if block_chain(block)[1] == "dynamic":
            e = None
        if e:
            print(
                f"{block:<12s} {law:<9s} {'emcee':<17s} {1:>4d} {e['evals']:>7d} {e['ess']:>6.0f} "
                f"{e['ess'] / e['evals']:>8.4f} {'':>8s} {'':>5s} {'':>6s} {e['seconds']:>7.0f} "
                f"{'':>6s} {'yes' if e['converged'] else 'no':>5s}  (report, EPYC)"
            )
        for sampler, label in variants(records):
            rs = [
                r
                for r in records
                if (r["block"], r["law"]) == (block, law) and variant(r) == (sampler, label)
            ]
            if not rs:
                continue
            z = np.array([r["log_z"] for r in rs])
            spread = f"{np.ptp(z):.2f}" if len(rs) > 1 else ""
            conv = sum(r["converged"] for r in rs)
            print(
                f"{block:<12s} {law:<9s} {sampler + label:<17s} {len(rs):>4d} "
                f"{np.mean([r['n_like'] for r in rs]):>7.0f} "
                f"{np.mean([r['n_eff'] for r in rs]):>6.0f} "
                f"{np.mean([r['eff_per_eval'] for r in rs]):>8.4f} {np.mean(z):>8.2f} "
                f"{np.mean([r['log_z_error'] for r in rs]):>5.2f} {spread:>6s} "
                f"{np.mean([r['wall_s'] for r in rs]):>7.0f} "
                f"{100 * np.mean([r['likelihood_s'] / r['wall_s'] for r in rs]):>6.0f} "
                f"{conv}/{len(rs):<3d}"
            )
    print(
        f"\nconverged: at least {MIN_EFFECTIVE} effective draws (Kish) and a log-evidence error "
        f"of at most {MAX_LOG_EVIDENCE_ERROR}; emcee: bulk ESS (R-hat, 50 tau besides)"
    )
    for sampler, label in variants(records):
        rs = [r for r in records if variant(r) == (sampler, label)]
        conv = sum(r["converged"] for r in rs)
        print(f"{sampler + label}: {conv} of {len(rs)} runs converged; median effective draws "
              f"per evaluation {np.median([r['eff_per_eval'] for r in rs]):.4f}, median wall "
              f"{np.median([r['wall_s'] for r in rs]):.0f} s")  # fmt: skip


def _site_size(dist_name: str) -> int:
    """Bytes of the files a distribution installed (its RECORD)."""
    d = distribution(dist_name)
    total = 0
    for f in d.files or []:
        p = Path(d.locate_file(f))
        if p.is_file():
            total += p.stat().st_size
    return total


def _closure(dist_name: str, seen=None, skip=()) -> set:
    """The distributions ``dist_name`` requires (no extras), transitively, itself included,
    leaving out those in ``skip`` and what only they require."""
    seen = set() if seen is None else seen
    key = dist_name.lower().replace("_", "-")
    if key in seen or key in skip:
        return seen
    try:
        reqs = requires(dist_name) or []
    except PackageNotFoundError:
        return seen
    seen.add(key)
    for r in reqs:
        if "extra ==" in r:
            continue
        name = r.split(";")[0].strip()
        for sep in "<>=!~[ (":
            name = name.split(sep)[0]
        _closure(name, seen, skip)
    return seen


def weight() -> None:
    """Each sampler's version, what it installs beyond fitdf's own dependencies, their size."""
    base = _closure("fitdf", skip=set(DISTRIBUTIONS.values()))  # fitdf without its sampler
    for s in SAMPLERS:
        dist = DISTRIBUTIONS[s]
        try:
            v = package_version(dist)
        except PackageNotFoundError:
            print(f"{s}: not installed")
            continue
        extra = sorted(_closure(dist) - base)
        sizes = {e: _site_size(e) for e in extra}
        print(
            f"{s} ({dist} {v}): {sum(sizes.values()) / 2**20:.1f} MiB beyond fitdf's dependencies: "
            + ", ".join(f"{e} {package_version(e)} ({sizes[e] / 2**20:.1f} MiB)" for e in extra)
        )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p_run = sub.add_parser("run", help="run block:law:sampler:seed ..., one after the other")
    p_run.add_argument("specs", nargs="+")
    p_run.add_argument("--max-evals", type=int, default=60_000)
    p_run.add_argument("--live", type=int, default=None, help="live points (default per sampler)")
    p_run.add_argument("--networks", type=int, default=4, help="nautilus's networks per bound")
    p_table = sub.add_parser("table", help="print the runs recorded so far beside emcee's")
    p_table.add_argument("--results", type=Path, default=ROOT / "reports" / "results.json")
    sub.add_parser("weight", help="versions and dependency weight of the samplers")
    for p in (p_run, p_table):
        p.add_argument("--out", type=Path, default=OUT)
    p_run.add_argument("--lsq-cache", type=Path, default=OUT.with_name("compare_samplers_lsq.json"))
    args = parser.parse_args(argv)
    if args.command == "run":
        for spec in args.specs:
            run(spec, args.max_evals, args.out, args.lsq_cache, args.live, args.networks)
    elif args.command == "table":
        table(args.out, args.results)
    else:
        weight()


if __name__ == "__main__":
    main()
