"""The report's jobs: one function per kind of job, each a top-level function of its inputs and
the seed (so that it pickles to a worker process or a Dask cluster, and a job cache can key it).

Least squares (:func:`job_lsq`), the posterior by nested sampling (:func:`job_nested`) or by
emcee (:func:`job_mcmc`), cross-validation (:func:`job_cv`), the refits through another chain
(:func:`job_approx`, :func:`job_dynamic`), the fits to the rows as printed
(:func:`job_printed`), cross-impedance (:func:`job_cross`), the limit cycles
(:func:`job_limit_cycles`) and the figures (:func:`job_figures`). A job that draws files
draws them where it runs and returns them as bytes (:func:`drawn`): a cluster worker's disk is
not the report's; :func:`keep_files` writes them into the report.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from fitdf.inference.api import fit
from fitdf.inference.cross_impedance import cross_impedance
from fitdf.inference.evidence import prior_sensitivity
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.material import with_material
from fitdf.inference.mcmc import fit_mcmc
from fitdf.inference.nested import fit_nested
from fitdf.inference.problem import FitProblem
from fitdf.inference.ranking import cross_validate
from fitdf.report import sections as rs

__all__ = [
    "job_lsq",
    "job_nested",
    "job_mcmc",
    "job_approx",
    "job_cv",
    "job_dynamic",
    "job_printed",
    "job_cross",
    "job_limit_cycles",
    "job_figures",
    "drawn",
    "keep_files",
]


def job_lsq(data, model, seed, n_starts, chain):
    """``model`` fitted to the rows ``data`` names by least squares through ``chain``."""
    return fit(data, model, chain=chain, method="lsq", seed=seed, n_starts=n_starts)


def job_nested(lsq, seed, n_live, n_networks, max_evaluations, sensitivity=False):
    """The posterior and evidence of ``lsq``'s problem; with ``sensitivity`` also the evidence
    with the prior box halved and doubled (``diagnostics["prior_sensitivity"]``)."""
    options = {"n_live": n_live, "n_networks": n_networks, "max_evaluations": max_evaluations}
    result = with_material(fit_nested(lsq.problem, lsq, seed=seed, **options))
    if sensitivity:
        result.diagnostics["prior_sensitivity"] = prior_sensitivity(
            result, lsq, seed=seed, **options
        )
    return result


def job_mcmc(lsq, seed, n_steps, n_walkers, max_steps=None, extend_steps=None):
    """The posterior of ``lsq``'s problem by emcee, started about ``lsq``'s optimum."""
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


def job_approx(lsq, seed, chain, also_screen=1):
    """``lsq``'s law and data refitted through the approximate ``chain``, polished from the
    exact chain's optimum (both chains share their parameters) and from the best
    ``also_screen`` points of the usual screen: the approximation's nearest optimum, and a
    look elsewhere."""
    p = lsq.problem
    problem = FitProblem(p.data, p.model, chain, p.noise, p.fixed, p.geometry)
    return with_material(fit_lsq(problem, seed=seed, starts=lsq.internal, also_screen=also_screen))


def job_cv(lsq, seed, n_starts):
    """``lsq``'s leave-one-frequency-out cross-validation."""
    return cross_validate(lsq, seed=seed, n_starts=n_starts)


def job_dynamic(lsq, seed, chain, cross_validated, static_cv):
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


def job_printed(data, model, seed, n_starts, chain):
    """``model`` fitted to ``data``'s rows as printed (no column reversed)."""
    return fit(
        data, model, chain=chain, method="lsq", seed=seed, n_starts=n_starts, policy="as_printed"
    )


def job_cross(core, model, train_ohm, test_ohm, seed, n_starts, chain):
    """``model`` fitted to ``core`` at ``train_ohm`` and predicting it at ``test_ohm`` (records)."""
    return cross_impedance(
        core,
        models=[model],
        chain=chain,
        train_ohm=train_ohm,
        test_ohm=test_ohm,
        seed=seed,
        n_starts=n_starts,
    ).to_dict(orient="records")


def drawn(fn, *args):
    """``fn(*args, folder)`` with a fresh folder where the job runs; its result and the files it
    wrote, as ``(result, {relative path: bytes})`` (see :func:`keep_files`)."""
    with tempfile.TemporaryDirectory(prefix="fitdf-figures-") as folder:
        result = fn(*args, Path(folder))
        files = {
            p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(Path(folder).rglob("*"))
            if p.is_file()
        }
    return result, files


def keep_files(drawn, figdir: Path):
    """Write the files of a :func:`drawn` job into ``figdir``; return the job's result."""
    result, files = drawn
    for name, data in files.items():
        path = figdir / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    return result


def job_limit_cycles(seed, models, n_starts, candidates):
    """The Tables 5.1/5.2 comparison and its figure (:func:`drawn`)."""
    return drawn(rs.limit_cycle_section, seed, models, n_starts, candidates)


def job_figures(kind, payload):
    """One group of the report's figures (:func:`fitdf.report.sections.make_figures`)."""
    return drawn(rs.make_figures, kind, payload)
