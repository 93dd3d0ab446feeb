"""The comparison report: every model fitted to every core, ranked, plotted, written atomically.

:func:`generate_report` fits every registered model (exact ``voltage`` chain) to each block of
Appendix B -- Permalloy B.1 (0 ohm) and B.3 (600 ohm), Deltamax B.2 (0 ohm) and B.5
(600 ohm), Supermalloy B.4 (600 ohm) -- and jointly to each core measured at both
impedances (Permalloy B.1+B.3, Deltamax B.2+B.5), by least squares and MCMC; ranks
the models; predicts across source impedance; compares limit cycles with Tables
5.1/5.2 (when :mod:`fitdf.loop.harmonic` is available); and writes

* ``results.json`` -- every number of the report (see :mod:`fitdf.report.render`);
* ``figures/*.png`` -- the figures (:mod:`fitdf.plots`);
* ``README.md`` and ``index.html`` -- the same report as Markdown (renders on a
  code-hosting site) and as one self-contained HTML file.

Cost and parallelism
    Fits are independent jobs run by :class:`fitdf.executor.Executor`: in
    ``workers`` local processes, or on a Dask cluster given its ``scheduler`` address;
    each job depends only on its inputs and the seed, so the report is identical to a
    serial run (``workers=1``). Figures are drawn where their job runs and sent back as
    bytes (a cluster worker's disk is not the report's). Least squares runs for every
    model; MCMC, the leave-one-frequency-out cross-validation and the cross-impedance
    prediction run for the ``*_top`` best least-squares models of each block (``None`` =
    all) -- the rest would multiply the run time without changing what the report shows.
    The refit through the approximate chain (``winding``) starts from the exact chain's
    optimum and the best point of the usual screen (:func:`_job_approx`), not from a
    full multi-start: a third of the cost.
Kept jobs
    Given a job cache (:class:`fitdf.jobcache.JobCache`; ``fitdf report`` keeps one in the
    user's cache folder), every finished job is kept as it finishes and looked up before it
    runs: a run stopped midway (Ctrl-C, SIGTERM, a crash) is resumed by the same command.
    The key covers the job, the settings and seed, the code, the bundled data and the
    machine (:func:`job_cache`), so a kept result is the one the job would compute again;
    ``timing.reused_jobs`` lists them.
Progress
    A run has three phases -- least squares; then MCMC, cross-validation, the approximate
    chain's refits, cross-impedance and limit cycles, as far as the settings ask for them
    (:func:`fitdf.report.costs.phase_labels`); then the figures. It opens with two lines
    (stderr) saying what it computes and about how long it takes at the speed of the machine
    the committed report was made on, then shows one bar for the whole run whose time left
    is weighted by each job's expected cost and calibrated by the jobs finished on this
    machine (:mod:`fitdf.report.costs`, :mod:`fitdf.report.progress`).
Atomic output
    Everything is built in a temporary sibling of ``out_dir`` which then replaces it
    (two renames, the old report restored if the second fails): an interrupted or
    failed run leaves the previous report as it was. The temporary folder is named
    ``.<out>.tmp-<pid>-*``; one whose process is gone (a run killed outright) is removed
    by the next run.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from fitdf import __version__
from fitdf.data.datasets import data_dir
from fitdf.errors import OptionError
from fitdf.executor import Executor
from fitdf.inference.api import DEFAULT_CHAIN, fit, resolve_data
from fitdf.inference.cross_impedance import cross_impedance
from fitdf.inference.evidence import prior_sensitivity
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.material import with_material
from fitdf.inference.mcmc import fit_mcmc
from fitdf.inference.nested import DEFAULT_LIVE, DEFAULT_NETWORKS, fit_nested
from fitdf.inference.problem import FitProblem
from fitdf.inference.ranking import cross_validate, ranking_table
from fitdf.jobcache import JobCache, default_cache_folder, run_salt
from fitdf.machine import machine_record
from fitdf.models import get_model, model_names
from fitdf.report import costs, render
from fitdf.report import sections as rs
from fitdf.report.physics import physics_record
from fitdf.report.progress import RunProgress
from fitdf.report.supermalloy import supermalloy_figure
from fitdf.report.words import report_words

__all__ = [
    "generate_report",
    "ReportSettings",
    "BLOCKS",
    "CROSS_DIRECTIONS",
    "collect",
    "write_outputs",
    "run_record",
]


@dataclass(frozen=True)
class Block:
    """One set of rows fitted together."""

    key: str
    data: str  # name for fitdf.datasets.load / fitdf.fit
    core: str
    title: str


#: The blocks of the report: each table alone, and each core at 0 + 600 ohm jointly.
BLOCKS = (
    Block("B.1", "B.1", "permalloy", "Permalloy at 0 ohm (Table B.1)"),
    Block("B.3", "B.3", "permalloy", "Permalloy at 600 ohm (Table B.3)"),
    Block("B.2", "B.2", "deltamax", "Deltamax at 0 ohm (Table B.2)"),
    Block("B.5", "B.5", "deltamax", "Deltamax at 600 ohm (Table B.5)"),
    Block("B.4", "B.4", "supermalloy", "Supermalloy at 600 ohm (Table B.4)"),
    Block(
        "permalloy-joint",
        "permalloy",
        "permalloy",
        "Permalloy at 0 and 600 ohm jointly (Tables B.1 + B.3)",
    ),
    Block(
        "deltamax-joint",
        "deltamax",
        "deltamax",
        "Deltamax at 0 and 600 ohm jointly (Tables B.2 + B.5)",
    ),
)
#: Cross-impedance predictions: (core, train ohm, test ohm, train block, test block).
CROSS_DIRECTIONS = (
    ("permalloy", 0.0, 600.0, "B.1", "B.3"),
    ("permalloy", 600.0, 0.0, "B.3", "B.1"),
    ("deltamax", 0.0, 600.0, "B.2", "B.5"),
    ("deltamax", 600.0, 0.0, "B.5", "B.2"),
)
#: Blocks whose fits the limit-cycle comparison uses (thesis Tables 5.1, 5.2).
LIMIT_CYCLE_BLOCKS = ("B.1", "B.3", "B.2", "B.5")
#: The blocks whose best law the default report samples, one per core: each core measured at
#: both source impedances jointly (Permalloy, Deltamax), and Supermalloy's one table.
CORE_BLOCKS = ("permalloy-joint", "deltamax-joint", "B.4")


@dataclass(frozen=True)
class ReportSettings:
    """What the report computes. ``ReportSettings.for_run(...)`` gives the three runs' settings.

    Attributes
    ----------
    models : tuple of str or None
        Models to fit (None: every registered model).
    blocks : tuple of str or None
        Keys of :data:`BLOCKS` (None: all).
    methods : tuple
        ``("lsq",)`` or ``("lsq", "mcmc")``: least squares only, or also posteriors.
    n_starts : int
        Least-squares starts (the library default; fewer starts miss optima).
    mcmc_top, cv_top, cross_top : int or None
        Posteriors, cross-validation and cross-impedance for the best N least-squares models
        of a block (None: all models; 0: none).
    sampler : {"nested", "emcee"}
        How the posteriors are sampled: nested sampling (the posterior and the evidence,
        :func:`fitdf.inference.nested.fit_nested`; its rule: 400 effective draws, evidence
        error <= 0.3) or emcee (:func:`fitdf.inference.mcmc.fit_mcmc`).
    nested_live, nested_networks, nested_max_evaluations : int
        Nested sampling's live points, networks per bound, and the evaluations at which a run
        stops unconverged.
    posterior_blocks : tuple of str or None
        The blocks whose best ``mcmc_top`` laws get posteriors (None: every block).
    sensitivity_top : int
        For the best this many sampled laws of each block, the evidence again with the prior
        box halved (about the best fit) and doubled (about its centre): how much the Bayes
        factors depend on the prior (nested sampling only).
    n_steps, max_steps, n_walkers : int
        MCMC production steps at least, at most (the chain is extended until it is
        converged: :func:`fitdf.inference.mcmc.is_converged`) and walkers (None: twice the
        dimensions plus two, the fewest differential evolution allows).
    extend_steps : int or None
        A chain that reaches ``max_steps`` on course for 50 autocorrelation times but is
        short of R-hat or ESS goes on up to this many steps, while 50 autocorrelation times
        fit in them (``fit_mcmc(extend_steps=...)``); the chains too slow for ``max_steps``
        still stop at it, or before.
    closed_form_step_factor : int
        ``max_steps`` and ``extend_steps`` are this many times longer for the laws whose
        describing function is in closed form (``HysteresisModel.closed_form``): through the
        exact chain they cost 0.9-3.3 ms per parameter set against Preisach's 3.5-10 ms, so the
        same time buys them more steps. Of those laws only cubic_hc needs them: its kinked
        posterior (the joint ``h1`` between rows) mixes slowly, and on B.1 it converged at
        14400 steps (benchmarks/README.md); the others converge within
        the common limits.
    mcmc_skip : tuple of str
        Laws left out of the report's posteriors (the best laws *without* them are sampled;
        default none).
    cv_starts : int or None
        Least-squares starts per cross-validation fold (None: polished from the block's
        optimum, :func:`fitdf.inference.ranking.cross_validate`).
    cross : tuple
        Cross-impedance directions (subset of :data:`CROSS_DIRECTIONS`).
    limit_cycles : bool
        Run the Tables 5.1/5.2 limit-cycle comparison when the module is available.
    plot_top : int
        Models drawn in the residual figure; the loci show the best two.
    workers : int
        Local worker processes (1: serial; results are identical).
    scheduler : str or None
        Address of a Dask distributed scheduler (``tcp://host:8786``) to run the jobs on
        instead of local processes (results are identical); None: local.
    chain : str
        The measurement chain of every fit (default: the exact ``voltage`` circuit).
    approximate_chain : str or None
        A second chain every model is also fitted through by least squares, to show how
        far an approximation (``winding``: sinusoidal current) moves the ranking, the
        predictions and the fitted constants; None (the default) skips it
        (``fitdf report --compare-chain winding``).
    approximate_screen : int
        Starts from the usual screen that refit adds to the exact chain's optimum (0: the
        nearest optimum of the approximation only; ``--quick``).
    dynamic_chain : str or None
        The chain with rate-dependent losses (``dynamic``: Bertotti's dynamic fields) the
        best ``dynamic_top`` laws of each block (``dynamic_skip`` aside)
        are refitted through by least squares, ranked beside the static fits by AICc and, with
        ``dynamic_cv``, cross-validation (:mod:`fitdf.report.physics`); None skips them.
    printed_top : int
        On every block whose rows the audit's reversed column changes (the default row
        policy reverses it), the best ``printed_top`` laws are also fitted to the rows as
        printed (policy ``as_printed``), to show both.
    """

    models: tuple | None = None
    blocks: tuple | None = None
    methods: tuple = ("lsq", "mcmc")
    n_starts: int = 6
    mcmc_top: int | None = 3
    sampler: str = "nested"
    nested_live: int = DEFAULT_LIVE
    nested_networks: int = DEFAULT_NETWORKS
    nested_max_evaluations: int = 100_000
    posterior_blocks: tuple | None = None
    sensitivity_top: int = 0
    n_steps: int = 300
    max_steps: int = 4000
    extend_steps: int | None = 6000
    closed_form_step_factor: int = 3
    n_walkers: int | None = None
    mcmc_skip: tuple = ()
    cv_top: int | None = 2
    cv_starts: int | None = None
    cross_top: int | None = 2
    cross: tuple = CROSS_DIRECTIONS
    limit_cycles: bool = True
    plot_top: int = 3
    workers: int = 2
    scheduler: str | None = None
    chain: str = DEFAULT_CHAIN
    approximate_chain: str | None = None
    approximate_screen: int = 1
    dynamic_chain: str | None = "dynamic"
    dynamic_top: int | None = 2
    dynamic_skip: tuple = ()
    dynamic_cv: bool = True
    printed_top: int | None = 2

    @classmethod
    def for_run(
        cls,
        quick: bool = False,
        methods=("lsq", "mcmc"),
        *,
        full: bool = False,
        scheduler: str | None = None,
        compare_chain: str | None = None,
    ) -> ReportSettings:
        """The settings of the three runs of ``fitdf report``.

        The default: every law on every block by least squares, cross-validation,
        cross-impedance, limit cycles, the rate-dependent refits, and the posteriors and
        evidences of the best two laws of each core (:data:`CORE_BLOCKS`) by nested sampling,
        so that each core has a Bayes factor.
        ``full``: the posteriors of the best three laws of every block, and the evidence's
        sensitivity to the prior for the best two. ``quick``: least squares only (the same
        models, starts and seeds, so the same rankings), no cross-validation, one law per
        cross-impedance direction and per refit; every section is still produced.
        ``compare_chain``: also refit every law through this approximate chain (``winding``).
        ``scheduler``: run on that Dask cluster (see :class:`ReportSettings`).
        """
        methods = tuple(methods)
        bad = set(methods) - {"lsq", "mcmc"}
        if bad or "lsq" not in methods:
            raise OptionError(f"methods must be ('lsq',) or ('lsq', 'mcmc'), got {methods}")
        if quick and full:
            raise OptionError("--quick and --full exclude each other")
        common = {"scheduler": scheduler, "approximate_chain": compare_chain}
        if quick:
            return cls(
                methods=("lsq",),
                mcmc_top=0,
                cv_top=0,
                cross_top=1,
                approximate_screen=0,
                dynamic_top=1,
                dynamic_cv=False,
                printed_top=1,
                **common,
            )
        sampled = "mcmc" in methods
        if full:
            return cls(methods=methods, mcmc_top=3 if sampled else 0, sensitivity_top=2, **common)
        return cls(
            methods=methods,
            mcmc_top=2 if sampled else 0,
            posterior_blocks=CORE_BLOCKS,
            **common,
        )

    def step_limits(self, model: str) -> tuple:
        """``(max_steps, extend_steps)`` of ``model``'s chains (``closed_form_step_factor``)."""
        factor = self.closed_form_step_factor if get_model(model).closed_form else 1
        extend = None if self.extend_steps is None else factor * self.extend_steps
        return factor * self.max_steps, extend

    def model_list(self) -> list[str]:
        return list(self.models) if self.models else model_names()

    def block_list(self) -> list[Block]:
        keys = self.blocks or [b.key for b in BLOCKS]
        unknown = set(keys) - {b.key for b in BLOCKS}
        if unknown:
            raise OptionError(f"unknown report block(s) {', '.join(sorted(unknown))}")
        return [b for b in BLOCKS if b.key in keys]


# ------------------------------------------------------------------ jobs (top level: picklable)
def _job_lsq(data, model, seed, n_starts, chain):
    return fit(data, model, chain=chain, method="lsq", seed=seed, n_starts=n_starts)


def _job_nested(lsq, seed, n_live, n_networks, max_evaluations, sensitivity=False):
    """The posterior and evidence of ``lsq``'s problem; with ``sensitivity`` also the evidence
    with the prior box halved and doubled (``diagnostics["prior_sensitivity"]``)."""
    options = {"n_live": n_live, "n_networks": n_networks, "max_evaluations": max_evaluations}
    result = with_material(fit_nested(lsq.problem, lsq, seed=seed, **options))
    if sensitivity:
        result.diagnostics["prior_sensitivity"] = prior_sensitivity(
            result, lsq, seed=seed, **options
        )
    return result


def _job_mcmc(lsq, seed, n_steps, n_walkers, max_steps=None, extend_steps=None):
    return with_material(
        fit_mcmc(
            lsq.problem,
            lsq,
            seed=seed,
            n_steps=n_steps,
            n_walkers=n_walkers,
            max_steps=max_steps,
            check_every=100,
            extend_steps=extend_steps,
        )
    )


def _job_approx(lsq, seed, chain, also_screen=1):
    """``lsq``'s law and data refitted through the approximate ``chain``, polished from the
    exact chain's optimum (both chains share their parameters) and from the best
    ``also_screen`` points of the usual screen: the approximation's nearest optimum, and a
    look elsewhere."""
    p = lsq.problem
    problem = FitProblem(p.data, p.model, chain, p.noise, p.fixed, p.geometry)
    return with_material(fit_lsq(problem, seed=seed, starts=lsq.internal, also_screen=also_screen))


def _job_cv(lsq, seed, n_starts):
    return cross_validate(lsq, seed=seed, n_starts=n_starts)


def _job_dynamic(lsq, seed, chain, cross_validated, static_cv):
    """``lsq``'s law and data refitted through the rate-dependent ``chain``: polished from the
    static optimum with the loss coefficients at the bottom of their boxes (the static fit)
    and at their typical values, and from the best point of the usual screen. Returns the fit,
    its cross-validation (None unless ``cross_validated``) and, when ``static_cv``, the static
    fit's."""
    p = lsq.problem
    problem = FitProblem(p.data, p.model, chain, p.noise, p.fixed, p.geometry)
    losses = [s for s in problem.specs if s.name not in lsq.values]
    starts = [
        problem.to_internal({**lsq.values, **{s.name: pick(s) for s in losses}})
        for pick in (lambda s: s.bounds[0], lambda s: s.default)
    ]
    fit = with_material(fit_lsq(problem, seed=seed, starts=starts, also_screen=1))
    cv = cross_validate(fit, seed=seed) if cross_validated else None
    return fit, cv, cross_validate(lsq, seed=seed) if static_cv else None


def _job_printed(data, model, seed, n_starts, chain):
    """``model`` fitted to ``data``'s rows as printed (no column reversed)."""
    return fit(
        data, model, chain=chain, method="lsq", seed=seed, n_starts=n_starts, policy="as_printed"
    )


def _job_cross(core, model, train_ohm, test_ohm, seed, n_starts, chain):
    return cross_impedance(
        core,
        models=[model],
        chain=chain,
        train_ohm=train_ohm,
        test_ohm=test_ohm,
        seed=seed,
        n_starts=n_starts,
    ).to_dict(orient="records")


def _drawn(fn, *args):
    """``fn(*args, folder)`` with a fresh folder where the job runs; its result and the files it
    wrote, as ``(result, {relative path: bytes})`` (see :func:`_keep_files`)."""
    with tempfile.TemporaryDirectory(prefix="fitdf-figures-") as folder:
        result = fn(*args, Path(folder))
        files = {
            p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(Path(folder).rglob("*"))
            if p.is_file()
        }
    return result, files


def _keep_files(drawn, figdir: Path):
    """Write the files of a :func:`_drawn` job into ``figdir``; return the job's result."""
    result, files = drawn
    for name, data in files.items():
        path = figdir / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    return result


def _job_limit_cycles(seed, models, n_starts, candidates):
    return _drawn(rs.limit_cycle_section, seed, models, n_starts, candidates)


def _job_figures(kind, payload):
    return _drawn(rs.make_figures, kind, payload)


# ------------------------------------------------------------------ computation
_KIND_ORDER = {
    "limit": 0,
    "nested": 1,
    "mcmc": 1,
    "dynamic": 2,
    "approx": 3,
    "cv": 4,
    "printed": 5,
    "cross": 6,
}


def _long_first(item):
    """Sort key of the second phase's jobs: long kinds and large blocks first (a short pool tail)."""
    key, (_, args) = item
    size = (
        rs.expected_cost(args[0].problem.data.label, key[2])
        if key[0] in ("nested", "mcmc", "cv", "approx", "dynamic")
        else 0.0
    )
    return (_KIND_ORDER[key[0]], -size)


def _top(ranked: list[str], n):
    return list(ranked) if n is None else list(ranked)[: max(int(n), 0)]


def _lsq_order(models, blocks) -> list:
    """``(block, model)`` of the least-squares jobs: costly models and large blocks first (a
    short pool tail)."""
    return sorted(
        ((b, m) for b in blocks for m in models),
        key=lambda bm: (
            -rs.expected_cost(bm[0].data, bm[1]),
            blocks.index(bm[0]),
            models.index(bm[1]),
        ),
    )


def _least_squares(settings, seed, runner, models, blocks) -> dict:
    """Every model on every block through the exact chain."""
    jobs = {
        (b.key, m): (_job_lsq, (b.data, m, seed, settings.n_starts, settings.chain))
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
    """MCMC and cross-validation of each block's best models, every model refitted through the
    approximate chain, the best refitted with rate-dependent losses and to the rows as printed,
    cross-impedance, limit cycles."""
    jobs = {}
    if settings.limit_cycles:
        winners = rs.aicc_winners(lsq, models, LIMIT_CYCLE_BLOCKS)
        # the report's own fits of those blocks (the same data, chain, seed and starts a
        # fresh comparison would fit again)
        candidates = {
            k: [lsq[(k, m)] for m in winners if (k, m) in lsq] for k in LIMIT_CYCLE_BLOCKS
        }
        jobs[("limit",)] = (
            _job_limit_cycles,
            (seed, winners or None, settings.n_starts, candidates),
        )
    for b in blocks:
        sampled = [m for m in ranked[b.key] if m not in settings.mcmc_skip]
        posterior = settings.posterior_blocks is None or b.key in settings.posterior_blocks
        n_sampled = settings.mcmc_top if "mcmc" in settings.methods and posterior else 0
        for i, m in enumerate(_top(sampled, n_sampled)):
            if settings.sampler == "nested":
                jobs[("nested", b.key, m)] = (
                    _job_nested,
                    (
                        lsq[(b.key, m)],
                        seed,
                        settings.nested_live,
                        settings.nested_networks,
                        settings.nested_max_evaluations,
                        i < settings.sensitivity_top,
                    ),
                )
            else:
                jobs[("mcmc", b.key, m)] = (
                    _job_mcmc,
                    (lsq[(b.key, m)], seed, settings.n_steps, settings.n_walkers)
                    + settings.step_limits(m),
                )
        for m in _top(ranked[b.key], settings.cv_top):
            jobs[("cv", b.key, m)] = (_job_cv, (lsq[(b.key, m)], seed, settings.cv_starts))
        if settings.dynamic_chain:
            cv_laws = set(_top(ranked[b.key], settings.cv_top))
            dynamic = [m for m in ranked[b.key] if m not in settings.dynamic_skip]
            for m in _top(dynamic, settings.dynamic_top):
                jobs[("dynamic", b.key, m)] = (
                    _job_dynamic,
                    (
                        lsq[(b.key, m)],
                        seed,
                        settings.dynamic_chain,
                        settings.dynamic_cv,
                        settings.dynamic_cv and m not in cv_laws,
                    ),
                )
        if settings.approximate_chain:
            for m in models:
                jobs[("approx", b.key, m)] = (
                    _job_approx,
                    (
                        lsq[(b.key, m)],
                        seed,
                        settings.approximate_chain,
                        settings.approximate_screen,
                    ),
                )
    for b in printed_blocks(blocks):
        for m in _top(ranked[b.key], settings.printed_top):
            jobs[("printed", b.key, m)] = (
                _job_printed,
                (b.data, m, seed, settings.n_starts, settings.chain),
            )
    for core, train, test, train_key, _ in settings.cross:
        for m in _top(ranked.get(train_key, models), settings.cross_top):
            jobs[("cross", core, train, test, m)] = (
                _job_cross,
                (core, m, train, test, seed, settings.n_starts, settings.chain),
            )
    done = (
        runner.run(dict(sorted(jobs.items(), key=_long_first)), costs.phase_labels(settings)[1])
        if jobs
        else {}
    )
    out = {
        kind: {k[1:]: v for k, v in done.items() if k[0] == kind}
        for kind in ("mcmc", "cv", "cross", "approx", "dynamic", "printed")
    }
    # the posteriors, whichever sampler drew them
    out["mcmc"].update({k[1:]: v for k, v in done.items() if k[0] == "nested"})
    out["limit"] = _keep_files(done[("limit",)], figdir) if ("limit",) in done else None
    return out


def _figures(settings, runner, blocks, lsq, ranked, second, figdir) -> dict:
    mcmc, cross = second["mcmc"], second["cross"]
    jobs = {}
    for b in blocks:
        payload = rs.block_payload(
            b,
            [lsq[(b.key, m)] for m in ranked[b.key]],
            [mcmc[(b.key, m)] for m in ranked[b.key] if (b.key, m) in mcmc],
            settings,
        )
        jobs[("block", b.key)] = (_job_figures, ("block", payload))
    for core, train, test, train_key, test_key in settings.cross:
        ms = [m for m in ranked.get(train_key, []) if (core, train, test, m) in cross]
        if ms:  # the training fits are the report's own fits of the training block (same data, seed, starts)
            payload = {
                "direction": (core, train, test, train_key, test_key),
                "gains": {m: cross[(core, train, test, m)][0]["calibration_gain"] for m in ms},
                "train": [lsq[(train_key, m)] for m in ms],
            }
            jobs[("cross", core, train, test)] = (_job_figures, ("cross", payload))
    jobs[("thesis",)] = (_job_figures, ("thesis", None))
    done = runner.run(jobs, costs.phase_labels(settings)[2])
    return {k: _keep_files(v, figdir) for k, v in done.items()}


def collect(settings: ReportSettings, seed: int, figdir: Path, runner: Executor) -> dict:
    """Run every fit and figure; return the JSON-ready results (see report_render)."""
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
            "mcmc_cv_cross_limit_s": t2 - t1,
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
                pick("mcmc", b.key),
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
        supermalloy=_supermalloy(lsq, ranked, second["dynamic"]),
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


def _supermalloy(lsq, ranked, dynamic) -> tuple:
    """Table B.4's best law that was refitted with rate-dependent losses: ``(static, dynamic)``
    fits (``(None, None)`` when B.4 was not fitted)."""
    laws = [m for m in ranked.get("B.4", []) if ("B.4", m) in dynamic]
    if not laws:
        best = ranked.get("B.4", [None])[0]
        return (lsq.get(("B.4", best)), None) if best else (None, None)
    return lsq[("B.4", laws[0])], dynamic[("B.4", laws[0])][0]


def write_outputs(results: dict, out_dir: Path) -> None:
    """results.json, README.md and index.html into ``out_dir`` (figures already there)."""
    out_dir = Path(out_dir)
    text = json.dumps(results, indent=1, allow_nan=False, ensure_ascii=False)
    (out_dir / "results.json").write_text(text + "\n", encoding="utf-8")
    (out_dir / "README.md").write_text(render.render_markdown(results), encoding="utf-8")
    (out_dir / "index.html").write_text(render.render_html(results, out_dir), encoding="utf-8")


def _tmp_pattern(out_dir: Path) -> re.Pattern:
    """Names of the temporary folders of ``out_dir``: ``.<name>.tmp-<pid>-<random>``."""
    return re.compile(rf"\.{re.escape(out_dir.name)}\.tmp-(\d+)-")


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists (anything but POSIX: assume it does)."""
    if os.name != "posix" or pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def _remove_stale(out_dir: Path) -> list[Path]:
    """Remove the temporary folders of ``out_dir`` whose run is gone (killed outright)."""
    pattern, removed = _tmp_pattern(out_dir), []
    for path in out_dir.parent.iterdir():
        match = pattern.match(path.name)
        if match and path.is_dir() and not _running(int(match.group(1))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def _swap_in(tmp: Path, out_dir: Path) -> None:
    """Replace ``out_dir`` by ``tmp``; on failure the old ``out_dir`` is restored."""
    if not out_dir.exists():
        os.replace(tmp, out_dir)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old-", dir=out_dir.parent))
    old.rmdir()
    os.replace(out_dir, old)
    try:
        os.replace(tmp, out_dir)
    except BaseException:
        os.replace(old, out_dir)
        raise
    shutil.rmtree(old, ignore_errors=True)


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
            "settings": _settings_record(settings),
            "seed": int(seed),
            # a cluster's workers compute on their own CPUs, not this machine's
            "scheduler": settings.scheduler,
        },
        (Path(__file__).resolve().parents[1], Path(str(data_dir()))),
        _CACHE_LIBRARIES,
    )
    return JobCache(default_cache_folder() if folder is None else folder, salt)


def generate_report(
    out_dir="reports",
    seed: int = 0,
    quick: bool = False,
    progress: bool = True,
    methods=("lsq", "mcmc"),
    *,
    settings: ReportSettings | None = None,
    cache: JobCache | None = None,
) -> Path:
    """Fit, rank and plot everything and write the report into ``out_dir`` atomically.

    Parameters
    ----------
    out_dir : str or Path
        Report folder (replaced as a whole; its parent is created if missing).
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
        ``("lsq", "mcmc")`` or ``("lsq",)``; ignored when ``quick``.
    settings : ReportSettings, optional
        Full control (overrides ``quick`` and ``methods``).
    cache : JobCache, optional
        Keep finished jobs there and take kept ones from it; made by :func:`job_cache` for
        the same ``settings`` and ``seed`` (None: every job runs).

    Returns
    -------
    pathlib.Path
        ``out_dir``.

    Examples
    --------
    >>> from fitdf.report import generate_report
    >>> generate_report("reports", seed=0)          # doctest: +SKIP
    """
    settings = settings or ReportSettings.for_run(quick, methods)
    out_dir = Path(out_dir).resolve()
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    _remove_stale(out_dir)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-{os.getpid()}-", dir=out_dir.parent))
    try:
        os.chmod(tmp, 0o755)  # mkdtemp makes it private; the report is meant to be read
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
        results["timing"]["machine"] = machine_record()
        results = {
            "fitdf_version": __version__,
            "seed": int(seed),
            "quick": bool(quick),
            "settings": _settings_record(settings),
            "run": run_record(settings, seed),
            **results,
        }
        results.update(report_words(results))
        write_outputs(results, tmp)
        _swap_in(tmp, out_dir)
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


#: The runs of ``fitdf report``, each with its command-line option.
RUNS = {"quick": "--quick", "default": "", "full": "--full"}


def run_record(settings: ReportSettings, seed: int) -> dict:
    """Which run of ``fitdf report`` made a report of ``settings`` and ``seed``, and the command
    that makes it again: ``{"run": "quick" | "default" | "full" | None, "command": str | None}``
    (None: settings no option of the command gives, such as a test's)."""
    made = _settings_record(settings)
    for name, option in RUNS.items():
        run = ReportSettings.for_run(
            quick=name == "quick",
            full=name == "full",
            compare_chain=settings.approximate_chain,
        )
        if _settings_record(run) == made:
            words = ["fitdf report", option]
            if settings.approximate_chain:
                words.append(f"--compare-chain {settings.approximate_chain}")
            if int(seed) != 0:
                words.append(f"--seed {int(seed)}")
            return {"run": name, "command": " ".join(w for w in words if w)}
    return {"run": None, "command": None}


def _settings_record(settings: ReportSettings) -> dict:
    d = asdict(settings)
    d["models"] = settings.model_list()
    d["blocks"] = [b.key for b in settings.block_list()]
    d["cross"] = [list(c) for c in settings.cross]
    d["methods"] = list(settings.methods)
    d.pop("workers")  # where the jobs ran does not change any number
    d.pop("scheduler")
    return d
