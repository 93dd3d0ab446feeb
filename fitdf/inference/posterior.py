"""One posterior, whichever sampler drew it: the result emcee's MCMC and nested sampling return.

emcee's MCMC (:mod:`fitdf.inference.mcmc`) and nautilus's nested sampling
(:mod:`fitdf.inference.nested`) draw a posterior differently and summarise it differently
(equal-weight draws against weighted ones). From their draws on, they share one path,
:func:`posterior_result`: the pointwise log-likelihood of the draws chosen for PSIS-LOO,
with their noise scales; PSIS-LOO and WAIC by ArviZ (:func:`psis_loo`, :func:`loo_record`);
the noise scales' intervals; the warnings; the metrics at the point estimate; and the
:class:`~fitdf.inference.results.PosteriorResult` with its draws.

The warnings come in one order for both: the sampler's own (convergence), PSIS-LOO's (rows
with Pareto k above 0.7) and ArviZ's, the sampler's on its point estimate, a posterior
piled against a bound of its box (:func:`~fitdf.inference.caveats.posterior_bound_warnings`)
or the law's validity at the point estimate, a noise scale against its prior's bound, and
parameters the data leave undetermined
(:func:`~fitdf.inference.caveats.identifiability_warnings`).
"""

from __future__ import annotations

import contextlib
import warnings

import numpy as np

from fitdf._arviz import arviz, walkers_as_chains
from fitdf.inference.caveats import (
    identifiability_warnings,
    noise_bound_warnings,
    posterior_bound_warnings,
)
from fitdf.inference.metrics import information_criteria, residual_metrics
from fitdf.inference.noise import NOISE_NAMES
from fitdf.inference.results import PointwiseLikelihood, PosteriorResult, residual_table

__all__ = [
    "posterior_result",
    "psis_loo",
    "loo_record",
    "relative_efficiency",
    "recorded_warnings",
    "noise_intervals",
    "QUANTILES",
    "PERCENTS",
    "LOO_METRICS",
    "PARETO_K_BAD",
]

#: The posterior percentiles every interval gives, and their names.
PERCENTS = (2.5, 16, 50, 84, 97.5)
QUANTILES = ("p2.5", "p16", "p50", "p84", "p97.5")
#: The PSIS-LOO and WAIC figures a posterior's metrics carry.
LOO_METRICS = ("looic", "looic_se", "waic", "waic_se", "elpd_loo", "elpd_loo_se", "p_loo")
#: A row whose Pareto k exceeds this makes PSIS-LOO unreliable there (Vehtari et al. 2017).
PARETO_K_BAD = 0.7


@contextlib.contextmanager
def recorded_warnings():
    """Within: every warning is recorded, not shown; the yielded list receives, on exit,
    the first line of each, except ArviZ's notice about its refactor and its complaint
    about more chains than draws (fitdf's emcee walkers are ArviZ's chains, and a chain
    thinned to few draws is expected: the sampler's diagnostics say so)."""
    caught: list[str] = []
    with warnings.catch_warnings(record=True) as records, walkers_as_chains():
        warnings.simplefilter("always")
        try:
            yield caught
        finally:
            caught += [
                str(r.message).split("\n")[0]
                for r in records
                if "More chains" not in str(r.message) and "refactor" not in str(r.message)
            ]


def loo_record(loo, waic) -> dict:
    """The PSIS-LOO and WAIC summary a posterior's diagnostics carry, from ArviZ's
    ``loo(..., pointwise=True)`` and ``waic(...)``: elpd with standard errors, the deviance-scale
    LOO-IC and WAIC, the largest Pareto k and the rows above :data:`PARETO_K_BAD`, and the
    pointwise elpd."""
    pareto_k = np.asarray(loo.pareto_k)
    return {
        "elpd_loo": float(loo.elpd_loo),
        "elpd_loo_se": float(loo.se),
        "p_loo": float(loo.p_loo),
        "looic": float(-2 * loo.elpd_loo),
        "looic_se": float(2 * loo.se),
        "elpd_waic": float(waic.elpd_waic),
        "elpd_waic_se": float(waic.se),
        "waic": float(-2 * waic.elpd_waic),
        "waic_se": float(2 * waic.se),
        "pareto_k_max": float(np.max(pareto_k)),
        "n_pareto_k_bad": int(np.sum(pareto_k > PARETO_K_BAD)),
        "pointwise_elpd_loo": np.asarray(loo.loo_i).tolist(),
    }


def relative_efficiency(idata) -> float:
    """The relative efficiency ``arviz.loo`` gives PSIS for ``idata``: 1 for one chain, else
    the mean over the posterior's variables of their ESS (``method="mean"``) over the number
    of draws."""
    posterior = idata.posterior
    if posterior.sizes["chain"] == 1:
        return 1.0
    ess = arviz().ess(posterior, method="mean")
    n = posterior.sizes["chain"] * posterior.sizes["draw"]
    return float(np.hstack([ess[v].values.flatten() for v in ess.data_vars]).mean() / n)


def psis_loo(draws, log_likelihood, names) -> tuple[dict, list[str], float]:
    """PSIS-LOO and WAIC (ArviZ) of the draws ``(draw, chain, k)`` named ``names`` with their
    pointwise log-likelihood ``(draw, chain, n)``: ``(record, warnings, reff)``, the
    :func:`loo_record`, the first lines of ArviZ's warnings (:func:`recorded_warnings`) and
    the relative efficiency PSIS used (:func:`relative_efficiency`)."""
    az = arviz()
    with recorded_warnings() as caught:
        idata = az.from_dict(
            posterior={n: np.swapaxes(draws[..., i], 0, 1) for i, n in enumerate(names)},
            log_likelihood={"df": np.swapaxes(log_likelihood, 0, 1)},
        )
        loo = az.loo(idata, pointwise=True)
        waic = az.waic(idata, pointwise=True)  # explicit: the rcParams default may be False
        reff = relative_efficiency(idata)
    return loo_record(loo, waic), sorted(set(caught)), reff


def noise_intervals(log10_noise, law=None) -> dict:
    """``{"sigma_magnitude_interval": {...}, "sigma_phase_deg_interval": {...}}``: the
    :data:`PERCENTS` of the noise scales of draws ``(..., 2)`` (log10); with a fitted noise
    ``law``, ``{"<name>_interval": ...}`` of each of its parameters, draws ``(..., k)``."""
    out = {}
    for j, name in enumerate(NOISE_NAMES if law is None else law.names):
        q = np.percentile(10 ** log10_noise[..., j].ravel(), list(PERCENTS))
        out[f"{name}_interval"] = dict(zip(QUANTILES, map(float, q)))
    return out


def posterior_result(
    problem,
    method: str,
    *,
    point,
    samples,
    intervals: dict,
    stderr: dict,
    correlations,
    noise_draws,
    loo_draws,
    loo_noise,
    diagnostics: dict,
    info: dict,
    sampler_warnings=(),
    point_warnings=(),
    caught=(),
    sampled_noise: bool = False,
    loo_description: str = "",
    extra_metrics: dict | None = None,
    noise_law=None,
) -> PosteriorResult:
    """The :class:`~fitdf.inference.results.PosteriorResult` of a sampler's draws.

    Parameters
    ----------
    problem : FitProblem
    method : {"mcmc", "nested"}
    point : numpy.ndarray
        The point estimate (internal vector): ``values``, residuals and metrics are its.
    samples : numpy.ndarray
        The posterior's equal-weight draws ``(draw, chain, P)`` (internal).
    intervals, stderr, correlations
        The posterior's summaries, as the sampler computes them from its draws.
    noise_draws : numpy.ndarray
        ``log10`` noise scales ``(draw, chain, 2)`` of the draws that have them (with
        ``noise_law``, its ``k`` parameters): their intervals, bound warnings and
        ``noise_samples``.
    loo_draws, loo_noise : numpy.ndarray
        The draws ``(draw, chain, P)`` for PSIS-LOO and WAIC and their ``log10`` noise
        scales ``(draw, chain, 2)`` (or ``k``).
    diagnostics, info : dict
        The sampler's; ``diagnostics`` gains the :func:`loo_record` and the
        :func:`noise_intervals` (where it has none of its own).
    sampler_warnings, point_warnings : sequence of str
        The sampler's warnings on its run and on its point estimate (module docstring).
    caught : sequence of str
        ArviZ warnings the sampler's own diagnostics raised (:func:`recorded_warnings`).
    sampled_noise : bool
        The sampler moved the noise scales (its LOO relative efficiency counts them).
    loo_description : str
        Which draws ``loo_draws`` are
        (:attr:`~fitdf.inference.results.PointwiseLikelihood.description`).
    extra_metrics : dict, optional
        Added to the metrics (nested sampling: the evidence).
    noise_law : NoiseLaw, optional
        The fitted noise law the sampler moved the parameters of
        (:mod:`fitdf.inference.noise_models`): the pointwise log-likelihood is its
        (:meth:`~fitdf.inference.noise_models.NoiseLaw.pointwise`), the noise draws its
        parameters. None: the two Gaussian scales of
        :meth:`~fitdf.inference.problem.FitProblem.pointwise_loglike`.
    """
    P = problem.ndim
    if noise_law is None:
        log_likelihood = problem.pointwise_loglike(
            loo_draws, 10.0 ** loo_noise[..., 0], 10.0 ** loo_noise[..., 1]
        )
        noise_names = list(NOISE_NAMES)
    else:
        radial, tang = problem.error_components(problem.predict(loo_draws))
        ctx = noise_law.context(problem.data)
        log_likelihood = noise_law.pointwise(loo_noise, radial, tang, ctx)
        noise_names = list(noise_law.names)
    coordinates, names = loo_draws, list(problem.names)
    if sampled_noise:
        coordinates = np.concatenate([loo_draws, loo_noise], axis=-1)
        names += noise_names
    record, loo_caught, reff = psis_loo(coordinates, log_likelihood, names)
    caught = sorted(set(caught) | set(loo_caught))
    # (a sampler's own noise intervals, from weighted draws, stand before the draws')
    diag = {**record, **noise_intervals(noise_draws, noise_law), **diagnostics}

    warns = list(sampler_warnings)
    if diag["n_pareto_k_bad"]:
        warns.append(
            f"PSIS-LOO: {diag['n_pareto_k_bad']} rows with Pareto k > {PARETO_K_BAD} "
            "(LOO unreliable there)"
        )
    warns += [f"ArviZ: {c}" for c in caught if "pareto" not in c.lower()]
    warns += list(point_warnings)
    warns += posterior_bound_warnings(problem, samples) + problem.limit_warnings(point)
    warns += noise_bound_warnings(noise_draws, law=noise_law)
    warns += identifiability_warnings(problem, intervals)

    predicted = problem.predict(point)
    metrics = {
        "n_points": problem.data.n,
        "n_params": P,
        **residual_metrics(predicted, problem.data.measured),
        **information_criteria(problem.weighted_residuals(point), P),
        **{k: diag[k] for k in LOO_METRICS},
        **(extra_metrics or {}),
    }
    return PosteriorResult(
        model=problem.model.name,
        chain=problem.chain.name,
        method=method,
        label=problem.data.label,
        values={k: float(v) for k, v in problem.full_natural(point).items()},
        stderr=stderr,
        intervals=intervals,
        correlations=correlations,
        metrics=metrics,
        residuals=residual_table(problem, predicted),
        warnings=warns,
        info=info,
        problem=problem,
        internal=point,
        samples=samples,
        noise_samples=10**noise_draws,
        diagnostics=diag,
        pointwise=PointwiseLikelihood(
            draws=loo_draws,
            noise=10**loo_noise,
            log_likelihood=log_likelihood,
            reff=reff,
            description=loo_description,
        ),
    )
