"""The comparison report: every model fitted to every core, ranked, plotted, written atomically.

:func:`generate_report` fits every registered model (exact ``voltage`` chain) to each block of
Appendix B -- Permalloy B.1 (0 ohm) and B.3 (600 ohm), Deltamax B.2 (0 ohm) and B.5
(600 ohm), Supermalloy B.4 (600 ohm) -- and jointly to each core measured at both
impedances (Permalloy B.1+B.3, Deltamax B.2+B.5), by least squares, and samples the
posteriors of the best (by nested sampling, or emcee); ranks the models; predicts across
source impedance; compares limit cycles with Tables 5.1/5.2; and writes

* ``results.json`` -- every number of the report (see :mod:`fitdf.report.render`);
* ``figures/*.png`` -- the figures (:mod:`fitdf.plots`);
* ``README.md`` and ``index.html`` -- the same report as Markdown (renders on a
  code-hosting site) and as one self-contained HTML file;
* ``costs.json`` -- the seconds each job took, on which machine (:mod:`fitdf.report.costs`).

This module orchestrates; the settings are :mod:`fitdf.report.settings`, the jobs
:mod:`fitdf.report.jobs`, the folder's atomic swap and its guard :mod:`fitdf.report.output`.

Cost and parallelism
    Fits are independent jobs run by :class:`fitdf.executor.Executor`: in
    ``workers`` local processes, or on a Dask cluster given its ``scheduler`` address;
    each job depends only on its inputs and the seed, so the report is identical to a
    serial run (``workers=1``). Figures are drawn where their job runs and sent back as
    bytes (a cluster worker's disk is not the report's). Least squares runs for every
    model; the posteriors, the leave-one-frequency-out cross-validation and the
    cross-impedance prediction run for the ``*_top`` best least-squares models of each block
    (``None`` = all) -- the rest would multiply the run time without changing what the report
    shows. The refit through the approximate chain (``winding``) starts from the exact chain's
    optimum and the best point of the usual screen (:func:`fitdf.report.jobs.job_approx`), not
    from a full multi-start: a third of the cost. Jobs are submitted longest first (their
    expected seconds, :func:`fitdf.report.costs.expected_seconds`), for a short pool tail.
Kept jobs
    Given a job cache (:class:`fitdf.jobcache.JobCache`; ``fitdf report`` keeps one in the
    user's cache folder), every finished job is kept as it finishes and looked up before it
    runs: a run stopped midway (Ctrl-C, SIGTERM, a crash) is resumed by the same command.
    The key covers the job, the settings and seed, the code, the bundled data and the
    machine (:func:`job_cache`), so a kept result is the one the job would compute again;
    ``timing.reused_jobs`` lists them.
Progress
    A run has three phases -- least squares; then the posteriors, cross-validation, the
    approximate chain's refits, cross-impedance and limit cycles, as far as the settings ask
    for them (:func:`fitdf.report.costs.phase_labels`); then the figures. It opens with two
    lines (stderr) saying what it computes and about how long it takes at the speed of the
    machine the committed report was made on, then shows one bar for the whole run whose time
    left is weighted by each job's expected cost and calibrated by the jobs finished on this
    machine (:mod:`fitdf.report.costs`, :mod:`fitdf.report.progress`).
Output
    Built in a temporary sibling of the report folder that then replaces it: an interrupted
    or failed run leaves the previous report as it was; a run that would replace a more
    complete report is refused before it starts (:mod:`fitdf.report.output`).
"""

from __future__ import annotations

import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from fitdf import __version__
from fitdf.data.datasets import data_dir
from fitdf.executor import Executor
from fitdf.inference.api import resolve_data
from fitdf.inference.ranking import ranking_table
from fitdf.jobcache import JobCache, default_cache_folder, run_salt
from fitdf.machine import machine_record
from fitdf.report import costs
from fitdf.report import jobs as job
from fitdf.report import sections as rs
from fitdf.report.output import (
    check_replace,
    remove_stale,
    swap_in,
    temporary_folder,
    write_outputs,
)
from fitdf.report.physics import physics_record
from fitdf.report.progress import RunProgress
from fitdf.report.settings import (
    LIMIT_CYCLE_BLOCKS,
    ReportSettings,
    posterior_laws,
    run_record,
    settings_record,
)
from fitdf.report.supermalloy import supermalloy_figure, supermalloy_fits
from fitdf.report.upgrade import SCHEMA_VERSION
from fitdf.report.words import report_words

__all__ = [
    "generate_report",
    "collect",
    "job_cache",
    "printed_blocks",
]


# ------------------------------------------------------------------ computation
def _long_first(item):
    """Sort key of the second phase's jobs: the long kinds first, and within a kind the jobs
    expected to take longest (a short pool tail)."""
    key, _ = item
    return (costs.SECOND_PHASE_ORDER.index(key[0]), -costs.expected_seconds(key))


def _top(ranked: list[str], n):
    return list(ranked) if n is None else list(ranked)[: max(int(n), 0)]


def _lsq_order(models, blocks) -> list:
    """``(block, model)`` of the least-squares jobs: those expected to take longest first (a
    short pool tail)."""
    return sorted(
        ((b, m) for b in blocks for m in models),
        key=lambda bm: (
            -costs.expected_seconds((bm[0].key, bm[1])),
            blocks.index(bm[0]),
            models.index(bm[1]),
        ),
    )


def _least_squares(settings, seed, runner, models, blocks) -> dict:
    """Every model on every block through the exact chain."""
    jobs = {
        (b.key, m): (job.job_lsq, (b.data, m, seed, settings.n_starts, settings.chain))
        for b, m in _lsq_order(models, blocks)
    }
    return runner.run(jobs, costs.phase_labels(settings)[0])


def printed_blocks(blocks) -> list:
    """The blocks whose default rows differ from the rows as printed (a reversed column)."""
    out = []
    for b in blocks:
        default, printed = (resolve_data(b.data, policy) for policy in ("default", "as_printed"))
        same = default.n == printed.n and all(
            np.array_equal(getattr(default, k), getattr(printed, k))
            for k in ("amplitude", "frequency", "source_impedance", "measured")
        )
        if not same:
            out.append(b)
    return out


def _second_phase(settings, seed, runner, models, blocks, lsq, ranked, figdir) -> dict:
    """The posteriors and cross-validation of each block's best models, every model refitted
    through the approximate chain, the best refitted with rate-dependent losses and to the rows
    as printed, cross-impedance, limit cycles. Returns each kind's results by their keys, in
    the order the jobs are defined here (not the order they ran in)."""
    jobs = _limit_job(settings, seed, models, lsq)
    for b in blocks:
        jobs.update(_posterior_jobs(settings, seed, b.key, ranked[b.key], lsq))
        jobs.update(_refit_jobs(settings, seed, b.key, ranked[b.key], models, lsq))
    jobs.update(_data_jobs(settings, seed, models, blocks, ranked))
    done = (
        runner.run(dict(sorted(jobs.items(), key=_long_first)), costs.phase_labels(settings)[1])
        if jobs
        else {}
    )
    # the posteriors under one name, whichever sampler drew them
    kinds = {"nested": "posterior", "mcmc": "posterior"}
    out = {kind: {} for kind in ("posterior", "cv", "cross", "approx", "dynamic", "printed")}
    for key in jobs:
        kind = kinds.get(key[0], key[0])
        if kind in out:
            out[kind][key[1:]] = done[key]
    out["limit"] = job.keep_files(done[("limit",)], figdir) if ("limit",) in done else None
    return out


def _limit_job(settings, seed, models, lsq) -> dict:
    """The limit-cycle comparison's job (none when the settings leave it out)."""
    if not settings.limit_cycles:
        return {}
    winners = rs.aicc_winners(lsq, models, LIMIT_CYCLE_BLOCKS)
    # the report's own fits of those blocks (the same data, chain, seed and starts a
    # fresh comparison would fit again)
    candidates = {k: [lsq[(k, m)] for m in winners if (k, m) in lsq] for k in LIMIT_CYCLE_BLOCKS}
    return {
        ("limit",): (job.job_limit_cycles, (seed, winners or None, settings.n_starts, candidates))
    }


def _posterior_jobs(settings, seed, key, ranked, lsq) -> dict:
    """The posterior jobs of block ``key``'s best laws (``ranked``: its laws, best first;
    which of them: :func:`~fitdf.report.settings.posterior_laws`)."""
    jobs = {}
    aicc = {m: lsq[(key, m)].metrics["aicc"] for m in ranked}
    for i, m in enumerate(posterior_laws(settings, key, aicc)):
        if settings.sampler == "nested":
            jobs[("nested", key, m)] = (
                job.job_nested,
                (
                    lsq[(key, m)],
                    seed,
                    settings.nested_live,
                    settings.nested_networks,
                    settings.nested_max_evaluations,
                    i < settings.sensitivity_top,
                ),
            )
        else:
            jobs[("mcmc", key, m)] = (
                job.job_mcmc,
                (lsq[(key, m)], seed, settings.n_steps, settings.n_walkers)
                + settings.step_limits(m),
            )
    return jobs


def _refit_jobs(settings, seed, key, ranked, models, lsq) -> dict:
    """Block ``key``'s cross-validations, rate-dependent refits and approximate-chain refits."""
    jobs = {}
    for m in _top(ranked, settings.cv_top):
        jobs[("cv", key, m)] = (job.job_cv, (lsq[(key, m)], seed, settings.cv_starts))
    if settings.dynamic_chain:
        cv_laws = set(_top(ranked, settings.cv_top))
        dynamic = [m for m in ranked if m not in settings.dynamic_skip]
        for m in _top(dynamic, settings.dynamic_top):
            jobs[("dynamic", key, m)] = (
                job.job_dynamic,
                (
                    lsq[(key, m)],
                    seed,
                    settings.dynamic_chain,
                    settings.dynamic_cv,
                    settings.dynamic_cv and m not in cv_laws,
                ),
            )
    if settings.approximate_chain:
        for m in models:
            jobs[("approx", key, m)] = (
                job.job_approx,
                (lsq[(key, m)], seed, settings.approximate_chain, settings.approximate_screen),
            )
    return jobs


def _data_jobs(settings, seed, models, blocks, ranked) -> dict:
    """The fits to the rows as printed and the cross-impedance predictions."""
    jobs = {}
    for b in printed_blocks(blocks):
        for m in _top(ranked[b.key], settings.printed_top):
            jobs[("printed", b.key, m)] = (
                job.job_printed,
                (b.data, m, seed, settings.n_starts, settings.chain),
            )
    for core, train, test, train_key, _ in settings.cross:
        for m in _top(ranked.get(train_key, models), settings.cross_top):
            jobs[("cross", core, train, test, m)] = (
                job.job_cross,
                (core, m, train, test, seed, settings.n_starts, settings.chain),
            )
    return jobs


def _figures(settings, runner, blocks, lsq, ranked, second, figdir) -> dict:
    posterior, cross = second["posterior"], second["cross"]
    jobs = {}
    for b in blocks:
        payload = rs.block_payload(
            b,
            [lsq[(b.key, m)] for m in ranked[b.key]],
            [posterior[(b.key, m)] for m in ranked[b.key] if (b.key, m) in posterior],
            settings,
        )
        jobs[("block", b.key)] = (job.job_figures, ("block", payload))
    for core, train, test, train_key, test_key in settings.cross:
        ms = [m for m in ranked.get(train_key, []) if (core, train, test, m) in cross]
        if ms:  # the training fits are the report's own fits of the training block (same data, seed, starts)
            payload = {
                "direction": (core, train, test, train_key, test_key),
                "gains": {m: cross[(core, train, test, m)][0]["calibration_gain"] for m in ms},
                "train": [lsq[(train_key, m)] for m in ms],
            }
            jobs[("cross", core, train, test)] = (job.job_figures, ("cross", payload))
    jobs[("thesis",)] = (job.job_figures, ("thesis", None))
    done = runner.run(jobs, costs.phase_labels(settings)[2])
    return {k: job.keep_files(v, figdir) for k, v in done.items()}


def collect(settings: ReportSettings, seed: int, figdir: Path, runner: Executor) -> dict:
    """Run every fit and figure; return the JSON-ready results (:mod:`fitdf.report.render`
    renders them)."""
    models, blocks = settings.model_list(), settings.block_list()
    timing = {}
    t0 = time.perf_counter()
    lsq = _least_squares(settings, seed, runner, models, blocks)
    ranked = {
        b.key: list(ranking_table([lsq[(b.key, m)] for m in models])["model"]) for b in blocks
    }
    t1 = time.perf_counter()
    second = _second_phase(settings, seed, runner, models, blocks, lsq, ranked, figdir)
    t2 = time.perf_counter()
    figures = _figures(settings, runner, blocks, lsq, ranked, second, figdir)
    timing.update(
        {
            "least_squares_s": t1 - t0,
            "second_phase_s": t2 - t1,
            "figures_s": time.perf_counter() - t2,
        }
    )

    def pick(kind, key):
        return {m: second[kind][(key, m)] for m in ranked[key] if (key, m) in second[kind]}

    results = {
        "blocks": {
            b.key: rs.block_record(
                b,
                [lsq[(b.key, m)] for m in ranked[b.key]],
                pick("posterior", b.key),
                pick("cv", b.key),
                figures[("block", b.key)],
                chain_comparison=rs.chain_comparison(
                    [lsq[(b.key, m)] for m in ranked[b.key]],
                    [
                        second["approx"][(b.key, m)]
                        for m in models
                        if (b.key, m) in second["approx"]
                    ],
                    top=settings.plot_top,
                ),
            )
            for b in blocks
        },
        "cross_impedance": rs.cross_record(settings.cross, second["cross"], figures),
        "small_signal": rs.small_signal_record(lsq),
        "limit_cycles": second["limit"]
        if second["limit"] is not None
        else rs.limit_cycles_switched_off(),
        "audit": rs.audit_record(),
        "thesis_graphs": figures[("thesis",)],
        "models": rs.model_descriptions(models),
    }
    results["physics"] = physics_record(
        results,
        audit_findings=results["audit"]["findings"],
        printed={k: v for k, v in second["printed"].items()},
        dynamic={k: (fit, cv) for k, (fit, cv, _) in second["dynamic"].items()},
        static_cv={
            **{k: v for k, v in second["cv"].items()},
            **{k: s for k, (_, _, s) in second["dynamic"].items() if s is not None},
        },
        supermalloy=supermalloy_fits(lsq, ranked, second["dynamic"]),
    )
    supermalloy = results["physics"]["supermalloy"]
    if supermalloy:  # drawn from its record, like the summary figure
        supermalloy["figure"] = supermalloy_figure(supermalloy, figdir)
    # The opening figure reads the assembled record (cheap: drawn here, not as a pool job).
    results["summary_figure"] = rs.summary_figure(results, figdir)
    timing["jobs_s"] = dict(runner.seconds)
    timing["reused_jobs"] = list(runner.reused)
    results["timing"] = timing
    return results


#: Libraries a job's result or figure depends on beyond the machine record's numerical stack:
#: ArviZ's diagnostics decide when a chain stops, the others draw and tabulate.
_CACHE_LIBRARIES = ("pandas", "matplotlib", "arviz", "xarray", "corner", "control", "llvmlite")


def job_cache(folder, settings: ReportSettings, seed: int) -> JobCache:
    """The job cache of a report with these ``settings`` and ``seed``, in ``folder`` (None: the
    user's cache folder, :func:`fitdf.jobcache.default_cache_folder`).

    Its salt names everything the report's jobs' arguments are made from: the settings
    (the number of local workers aside), the seed, the Dask scheduler if any, the machine
    record, the versions of the libraries the results and figures depend on, and a digest of
    fitdf's source and of the bundled data. Another setting, seed, cluster, CPU, library
    version, code or data file keeps its entries apart."""
    salt = run_salt(
        {
            "settings": settings_record(settings),
            "seed": int(seed),
            # a cluster's workers compute on their own CPUs, not this machine's
            "scheduler": settings.scheduler,
        },
        (Path(__file__).resolve().parents[1], Path(str(data_dir()))),
        _CACHE_LIBRARIES,
    )
    return JobCache(default_cache_folder() if folder is None else folder, salt)


#: Where ``fitdf report`` writes its report unless told (``--out``): a folder of the current
#: directory's own, not the committed report of a clone (``reports/``).
DEFAULT_OUT = "fitdf-report"


def generate_report(
    out_dir=DEFAULT_OUT,
    seed: int = 0,
    quick: bool = False,
    progress: bool = True,
    methods=("lsq", "posterior"),
    *,
    settings: ReportSettings | None = None,
    cache: JobCache | None = None,
    replace: bool = False,
) -> Path:
    """Fit, rank and plot everything and write the report into ``out_dir`` atomically.

    Parameters
    ----------
    out_dir : str or Path
        Report folder (replaced as a whole; its parent is created if missing). A report
        already there is replaced only by a run that computes at least what it holds, or
        with ``replace``.
    seed : int
        Seed of every fit; the same seed gives the same numbers on the same CPU and libraries
        (``results['timing']['machine']``, :mod:`fitdf.machine`).
    quick : bool
        Least squares only, with the same models, starts and seed as the full run (so
        the same rankings), no cross-validation, one model per cross-impedance
        direction. For tests and a first look.
    progress : bool
        What the run computes and about how long it takes, one progress bar for the whole
        run (with the time left) and the total run time, on stderr; False prints nothing.
    methods : sequence
        ``("lsq", "posterior")`` or ``("lsq",)``; ignored when ``quick``.
    settings : ReportSettings, optional
        Full control (overrides ``quick`` and ``methods``).
    cache : JobCache, optional
        Keep finished jobs there and take kept ones from it; made by :func:`job_cache` for
        the same ``settings`` and ``seed`` (None: every job runs).
    replace : bool
        Replace the report in ``out_dir`` even when it holds more than this run computes.

    Returns
    -------
    pathlib.Path
        ``out_dir``.

    Raises
    ------
    fitdf.report.output.LesserReport
        ``out_dir`` holds a report this run would lose something of (its posteriors, a
        law, ...), and not ``replace``: raised before anything is computed.

    Examples
    --------
    >>> from fitdf.report import generate_report
    >>> generate_report("fitdf-report", seed=0)          # doctest: +SKIP
    """
    settings = settings or ReportSettings.for_run(quick, methods)
    out_dir = Path(out_dir).resolve()
    record, run = settings_record(settings), run_record(settings, seed)
    if not replace:
        check_replace(out_dir, record, run["command"])
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    remove_stale(out_dir)
    tmp = temporary_folder(out_dir)
    try:
        figdir = tmp / "figures"
        figdir.mkdir()
        with (
            Executor(settings.workers, settings.scheduler, progress, cache=cache) as runner,
            _display(settings, runner, progress, cache is not None),
        ):
            results = collect(settings, seed, figdir, runner)
        total = time.perf_counter() - start
        results["timing"]["total_s"] = total
        results["timing"]["workers"] = runner.workers
        results["timing"]["cores"] = os.cpu_count()
        results["timing"]["machine"] = machine_record()
        results = {
            "schema_version": SCHEMA_VERSION,
            "fitdf_version": __version__,
            "seed": int(seed),
            "quick": bool(quick),
            "settings": record,
            "run": run,
            **results,
        }
        results.update(report_words(results))
        write_outputs(results, tmp)
        swap_in(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if progress:
        where = f" on {settings.scheduler}" if settings.scheduler else ""
        kept = (
            f"; {len(runner.reused)} of {len(runner.seconds)} jobs taken from {cache.root}"
            if cache is not None and runner.reused
            else ""
        )
        print(
            f"fitdf report: wrote {out_dir} in {time.perf_counter() - start:.0f} s "
            f"({runner.workers} worker{'s' if runner.workers > 1 else ''}{where}{kept})",
            file=sys.stderr,
        )
    return out_dir


def _display(settings: ReportSettings, runner: Executor, progress: bool, cached: bool):
    """The run's progress display, attached to ``runner``; with ``progress``, the line saying
    what the run computes and about how long it takes is printed first (stderr)."""
    models, blocks = settings.model_list(), settings.block_list()
    keys = [b.key for b in blocks]
    folds = {}
    if settings.cv_top != 0:
        for b in blocks:
            d = resolve_data(b.data, "default", None)
            folds[b.key] = len(set(zip(d.source_impedance.tolist(), d.frequency.tolist())))
    lsq_keys = [(b.key, m) for b, m in _lsq_order(models, blocks)]
    printed = [b.key for b in printed_blocks(blocks)]
    labels = costs.phase_labels(settings)
    phases, what = costs.plan(settings, models, keys, lsq_keys, folds, labels, printed)
    if progress:
        line = costs.start_line(
            what,
            costs.estimate(phases, runner.workers),
            runner.workers,
            rough=costs.rough(settings),
            cached=cached,
        )
        print(line, file=sys.stderr, flush=True)
    runner.display = RunProgress(
        phases,
        costs.expected_seconds,
        runner.workers,
        kind=costs.job_kind,
        enabled=progress,
        reference="at the committed machine's speed",
    )
    return runner.display
