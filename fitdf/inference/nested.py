"""Nested sampling: the posterior and the evidence of a fit, by nautilus.

Provides :func:`fit_nested`, which samples the posterior of a
:class:`~fitdf.inference.problem.FitProblem` and estimates its evidence (marginal
likelihood), returning a :class:`~fitdf.inference.results.PosteriorResult`; the normalised
prior as a map of the unit cube, :class:`PriorTransform`; the likelihood it weighs,
:class:`NestedLikelihood`; the error of nautilus's evidence, :func:`log_evidence_error`; and
the convergence rule :func:`is_converged` with its thresholds :data:`MIN_EFFECTIVE` (400
effective draws) and :data:`MAX_LOG_EVIDENCE_ERROR` (0.3).

Notes
-----
**The prior.** Nested sampling integrates the likelihood over a normalised prior, so the
prior is explicit, and it decides the evidence. Each parameter's is a map of the unit
interval to its internal coordinate (:class:`PriorTransform`): uniform on its box
(:meth:`FitProblem.internal_bounds`), which is log-uniform in natural units for a
log-scaled parameter, or, for a parameter with a Gaussian prior in ``problem.priors``
(the series resistance's log-normal), that normal truncated to the box, by its
inverse distribution function. The two noise scales are integrated out of the likelihood
under their normalised log-uniform priors (:mod:`fitdf.inference.noise`). These are the
priors MCMC samples (:mod:`fitdf.inference.mcmc`) with their constants, so both give the
same posterior; the result states each in physical units (``info["prior"]``).

**The likelihood** is the noise-marginal one, :meth:`NoiseMarginal.log_likelihood` of the
residuals, evaluated on batches of points (one call of the measurement chain per batch);
the unnormalised :meth:`FitProblem.log_prior` is not added: the prior is in the map.

**The sampler** is nautilus (Lange 2023): importance nested sampling (Skilling 2006 for
nested sampling) in shells bounded by neural-network emulators of the likelihood's
iso-contours. It explores shells of shrinking likelihood until the live set holds less
than ``f_live`` of the evidence, then draws more points from the shells that add most to
the evidence's error until the effective sample size (Kish's, of the importance weights)
reaches its target. The evidence is the sum of the shells' mean likelihood times volume.

**The evidence's error.** nautilus gives no error of ``log Z``. :func:`log_evidence_error`
propagates the two sampling errors of its estimate, shell by shell: each shell's
importance-sampling mean (relative variance ``1 / n_eff,i - 1 / n_i`` over the ``n_i``
draws from its bound) and each bound's volume, a rejection-sampling fraction (relative
variance ``(1 - a) / (n a)`` for acceptance ``a`` of ``n`` draws); bounds are independent,
so the relative variances add, weighted by each shell's share of the evidence squared.
``tests/test_nested.py`` checks it against Gaussian likelihoods whose evidence is known.

**Convergence** (:func:`is_converged`): at least :data:`MIN_EFFECTIVE` effective draws (the
bulk ESS MCMC asks for, :data:`fitdf.inference.mcmc.MIN_ESS`) and an evidence error of at
most :data:`MAX_LOG_EVIDENCE_ERROR`. The
run goes on, in rounds of a larger target of effective draws, until both hold or the
evaluations reach ``max_evaluations``.

**Outputs.** The point estimate is the point of highest posterior density (likelihood times
prior density) of all evaluated, the exploration's included; intervals, standard errors and
correlations are weighted percentiles and moments of the weighted draws; ``samples`` are
``n_draws`` of them resampled to equal weights (systematic resampling, shape
``(n_draws, 1, P)``); PSIS-LOO and WAIC are those of up to ``max_loo_draws`` of these (a
random choice), with the noise scales drawn given each as MCMC does, and ``pointwise`` holds
them with their pointwise log-likelihood. From the draws on, the result is assembled as
MCMC's is (:func:`fitdf.inference.posterior.posterior_result`). ``diagnostics`` holds ``log_evidence``, ``log_evidence_error``, ``n_effective``,
``n_likelihood_evaluations``, ``converged`` and the sampler's settings; a seed fixes the
whole run.

References
----------
Skilling, J., "Nested sampling for general Bayesian computation", Bayesian Analysis 1,
833 (2006).

Lange, J. U., "nautilus: boosting Bayesian importance nested sampling with deep learning",
Mon. Not. R. Astron. Soc. 525, 3181 (2023).

Kish, L., Survey Sampling, Wiley, New York (1965): the effective sample size of weights.

Vehtari, A., Gelman, A. and Gabry, J., "Practical Bayesian model evaluation using
leave-one-out cross-validation and WAIC", Statistics and Computing 27, 1413 (2017).
"""

from __future__ import annotations

import time
from importlib.metadata import version as _package_version

import numpy as np
import pandas as pd
from scipy.special import logsumexp
from scipy.stats import truncnorm

from fitdf.inference.convergence import MAX_LOG_EVIDENCE_ERROR, MIN_EFFECTIVE
from fitdf.inference.noise import NoiseMarginal
from fitdf.inference.posterior import PERCENTS, QUANTILES, posterior_result
from fitdf.inference.priors import (
    noise_law_prior_description,
    noise_law_priors_text,
    noise_prior_description,
    noise_priors_text,
    prior_description,
)
from fitdf.inference.problem import FitProblem
from fitdf.inference.results import FitResult, PosteriorResult

__all__ = [
    "fit_nested",
    "run_nautilus",
    "PriorTransform",
    "NestedLikelihood",
    "log_evidence_error",
    "is_converged",
    "convergence_warnings",
    "next_effective_target",
    "kish_size",
    "weighted_quantiles",
    "systematic_resample",
    "MIN_EFFECTIVE",
    "MAX_LOG_EVIDENCE_ERROR",
    "SAMPLERS",
]

#: The samplers :func:`fit_nested` runs (``benchmarks/compare_samplers.py`` compares others).
SAMPLERS = ("nautilus",)
#: nautilus's live points and networks per bound, chosen by ``benchmarks/compare_samplers.py``:
#: on the Preisach and cubic posteriors of B.3 and B.5, 300 live points and one network
#: reach the evidence of 500 and 1000 live points (within 0.21 in ln Z, the spread of runs)
#: in 40-80 % of the evaluations of 1000, and one network trains in a quarter of the time
#: of nautilus's four.
DEFAULT_LIVE = 300
DEFAULT_NETWORKS = 1
#: Points per likelihood call, nautilus's own default, measured by
#: ``benchmarks/nautilus_batch.py`` on the Preisach posterior of B.3 against 300 (the live
#: points) and 600: the same evidence (ln Z within 0.01 on each seed), but nautilus builds a
#: bound only between batches, so a larger batch draws more points from a bound the live set
#: has outgrown: 31 % more evaluations and 12-14 % more CPU at 300 (two seeds), 73 % and
#: 30 % at 600 (one), though an evaluation costs less in a larger batch.
DEFAULT_BATCH = 100


class PriorTransform:
    """The normalised prior of ``problem``: a map of the unit cube to internal coordinates.

    Uniform on each parameter's box (:meth:`FitProblem.internal_bounds`; log-uniform in
    natural units for a log-scaled parameter); a parameter with a Gaussian prior in
    ``problem.priors`` ``(centre, sigma)`` (internal coordinates) gets that normal
    truncated to its box, by its inverse distribution function. With a fitted noise law
    (``problem.noise_law``) its parameters follow the law's, ``log10`` of each uniform on
    :attr:`~fitdf.inference.noise_models.NoiseLaw.bounds`.

    Parameters
    ----------
    problem : FitProblem
    """

    def __init__(self, problem: FitProblem):
        self.specs = list(problem.specs)
        self.names = list(problem.names)
        self.bounds = np.asarray(problem.internal_bounds(), float).reshape(-1, 2)
        self.noise_law = getattr(problem, "noise_law", None)
        if self.noise_law is not None:
            self.names += list(self.noise_law.names)
            self.bounds = np.vstack([self.bounds, self.noise_law.bounds])
        self.lo = self.bounds[:, 0]
        self.width = self.bounds[:, 1] - self.bounds[:, 0]
        self.priors = dict(problem.priors)
        #: column -> (centre, sigma, a, b) of the truncated normals (a, b standardised bounds)
        self.gaussian = {}
        for name, (centre, sigma) in problem.priors.items():
            i = self.names.index(name)
            a, b = (self.bounds[i] - centre) / sigma
            self.gaussian[i] = (float(centre), float(sigma), float(a), float(b))

    @property
    def ndim(self) -> int:
        return len(self.names)

    def __call__(self, u):
        """Internal vectors ``(..., P)`` of unit-cube points ``(..., P)``."""
        u = np.asarray(u, float)
        x = self.lo + self.width * u
        for i, (centre, sigma, a, b) in self.gaussian.items():
            x[..., i] = truncnorm.ppf(u[..., i], a, b, loc=centre, scale=sigma)
        return x

    def log_density(self, x):
        """The prior's log density of internal vectors ``(..., P)`` (normalised; ``-inf``
        outside the box)."""
        x = np.asarray(x, float)
        inside = np.all((x >= self.lo) & (x <= self.lo + self.width), axis=-1)
        uniform = [i for i in range(self.ndim) if i not in self.gaussian]
        out = -np.sum(np.log(self.width[uniform])) * np.ones(x.shape[:-1])
        for i, (centre, sigma, a, b) in self.gaussian.items():
            with np.errstate(divide="ignore"):
                out = out + truncnorm.logpdf(x[..., i], a, b, loc=centre, scale=sigma)
        return np.where(inside, out, -np.inf)

    def describe(self) -> dict:
        """Each parameter's prior in its natural units
        (:func:`fitdf.inference.priors.prior_description`), a noise law's parameters'
        included."""
        out = prior_description(self.specs, self.priors)
        if self.noise_law is not None:
            out.update(noise_law_prior_description(self.noise_law))
        return out


class NestedLikelihood:
    """The log-likelihood of ``problem`` for batches of internal vectors.

    The noise-marginal one (:class:`~fitdf.inference.noise.NoiseMarginal`) of vectors
    ``(n, P)``; with a fitted noise law (``problem.noise_law``) vectors ``(n, P + k)``, the
    parameters then the law's ``k`` (``log10``), and the law's
    :meth:`~fitdf.inference.noise_models.NoiseLaw.pointwise` summed over the rows. Calls
    :meth:`FitProblem.predict` once per batch and returns ``(n,)``; a prediction that is
    not finite counts as likelihood 0 (``-inf``). Counts its evaluations in
    :attr:`n_calls`.
    """

    def __init__(self, problem: FitProblem):
        self.problem = problem
        self.law = problem.noise_law
        self.noise = NoiseMarginal(problem) if self.law is None else None
        self.context = None if self.law is None else self.law.context(problem.data)
        self.n_calls = 0

    def __call__(self, x):
        x = np.atleast_2d(np.asarray(x, float))
        self.n_calls += x.shape[0]
        P = self.problem.ndim
        with np.errstate(all="ignore"):
            radial, tang = self.problem.error_components(self.problem.predict(x[:, :P]))
            if self.law is None:
                ll = self.noise.log_likelihood(radial, tang)
            else:
                ll = np.sum(self.law.pointwise(x[:, P:], radial, tang, self.context), axis=-1)
        return np.where(np.isfinite(ll), ll, -np.inf)


def _log1m_variance(n_sample, n_reject) -> float:
    """Variance of ``log(1 - n_reject / n_sample)``, a binomial acceptance (delta method)."""
    if not n_sample:
        return 0.0
    a = 1.0 - n_reject / n_sample
    return float((1.0 - a) / (n_sample * a)) if a > 0 else np.inf


def _bound_log_volume_variance(bound) -> float:
    """Variance of nautilus's estimate of ``log`` of a bound's volume: the rejection
    fractions it is estimated by (the unit cube's and an ellipsoid's volumes are exact)."""
    var = 0.0
    for part in (bound, getattr(bound, "outer_bound", None)):
        if part is not None and hasattr(part, "n_reject"):
            var += _log1m_variance(part.n_sample, part.n_reject)
    return var


def log_evidence_error(sampler) -> float:
    """Standard error of a nautilus sampler's ``log Z`` (module docstring, *The evidence's
    error*): the shells' importance-sampling errors and their bounds' volume errors."""
    start = (
        sampler.shell_end_exp
        if sampler.discard_exploration and sampler.explored
        else np.zeros(len(sampler.log_l), int)
    )
    log_z_shell, rel_var = [], []
    for i, bound in enumerate(sampler.bounds):
        log_l = np.asarray(sampler.log_l[i][start[i] :], float)
        n_draws = sampler.shell_n_sample[i] - (
            sampler.shell_n_sample_exp[i] if sampler.discard_exploration and sampler.explored else 0
        )
        if log_l.size == 0 or not np.any(np.isfinite(log_l)):
            continue
        s1, s2 = logsumexp(log_l), logsumexp(2.0 * log_l)
        # 1 / n_eff - 1 / n of the shell's draws (zero likelihood outside the shell)
        var_is = max(np.exp(s2 - 2.0 * s1) - 1.0 / max(n_draws, 1), 0.0)
        log_z_shell.append(sampler.shell_log_l[i] + sampler.shell_log_v[i])
        rel_var.append(var_is + _bound_log_volume_variance(bound))
    if not log_z_shell:
        return float("inf")
    share = np.exp(np.asarray(log_z_shell) - logsumexp(log_z_shell))
    return float(np.sqrt(np.sum(share**2 * np.asarray(rel_var))))


def kish_size(log_weights) -> float:
    """Kish's effective sample size ``(sum w)^2 / sum w^2`` of (unnormalised) log weights."""
    lw = np.asarray(log_weights, float)
    return float(np.exp(2.0 * logsumexp(lw) - logsumexp(2.0 * lw)))


def is_converged(n_effective, log_evidence_error_) -> bool:
    """The convergence rule: at least :data:`MIN_EFFECTIVE` effective draws and an evidence
    error of at most :data:`MAX_LOG_EVIDENCE_ERROR`."""
    return bool(
        n_effective >= MIN_EFFECTIVE
        and np.isfinite(log_evidence_error_)
        and log_evidence_error_ <= MAX_LOG_EVIDENCE_ERROR
    )


def next_effective_target(n_effective, log_evidence_error_) -> float:
    """The next round's target of effective draws: the evidence's error falls as
    ``1 / sqrt(n_eff)``, so what :data:`MAX_LOG_EVIDENCE_ERROR` needs with a margin of 1.2,
    and at least 1.5 times the draws so far."""
    ratio = log_evidence_error_ / MAX_LOG_EVIDENCE_ERROR
    return float(n_effective) * max(1.5, 1.2 * ratio**2)


def convergence_warnings(
    n_effective, log_evidence_error_, finished, n_evaluations, max_evaluations
) -> list[str]:
    """What keeps a run from converging (:func:`is_converged`), one warning each: stopped at
    ``max_evaluations``, fewer than :data:`MIN_EFFECTIVE` effective draws, an evidence error
    above :data:`MAX_LOG_EVIDENCE_ERROR` (or none)."""
    out = []
    if not finished:
        out.append(
            f"stopped at {n_evaluations} likelihood evaluations (max_evaluations {max_evaluations})"
        )
    if n_effective < MIN_EFFECTIVE:
        out.append(f"{n_effective:.0f} effective draws (< {MIN_EFFECTIVE})")
    if not log_evidence_error_ <= MAX_LOG_EVIDENCE_ERROR:
        out.append(f"log-evidence error {log_evidence_error_:.2f} (> {MAX_LOG_EVIDENCE_ERROR})")
    return out


def weighted_quantiles(x, weights, q) -> np.ndarray:
    """Quantiles ``q`` (fractions) of ``x`` ``(n,)`` under normalised ``weights``: the inverse
    of the weighted distribution function through the midpoints of the sorted weights."""
    order = np.argsort(x)
    xs, ws = np.asarray(x, float)[order], np.asarray(weights, float)[order]
    cdf = np.cumsum(ws) - 0.5 * ws
    return np.interp(q, cdf / np.sum(ws), xs)


def systematic_resample(weights, n: int, rng) -> np.ndarray:
    """Indices of ``n`` equal-weight draws from normalised ``weights`` (systematic resampling:
    one uniform offset, so a draw's count differs from ``n w`` by less than one)."""
    cdf = np.cumsum(weights)
    cdf /= cdf[-1]
    positions = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cdf, positions), len(weights) - 1)


class _Padded:
    """A prior map of ``ndim`` coordinates fed a cube of more: it drops the extra ones."""

    def __init__(self, transform, ndim: int):
        self.transform = transform
        self.ndim = ndim

    def __call__(self, u):
        return self.transform(np.asarray(u, float)[..., : self.ndim])


def run_nautilus(
    transform,
    loglike,
    ndim: int,
    seed: int = 0,
    n_live: int = DEFAULT_LIVE,
    n_networks: int = DEFAULT_NETWORKS,
    n_batch: int = DEFAULT_BATCH,
    f_live: float = 0.01,
    n_effective: float = MIN_EFFECTIVE,
    max_evaluations: int = 100_000,
    discard_exploration: bool = True,
):
    """Run nautilus on the vectorised ``loglike`` of ``transform``'s prior until
    :func:`is_converged` or ``max_evaluations``: first to ``n_effective`` effective draws,
    then in rounds of a target grown as the evidence's error asks (``~ 1 / sqrt(n_eff)``).

    Returns ``(sampler, log_evidence_error, rounds, finished)``: the nautilus sampler, its
    evidence's error (:func:`log_evidence_error`), one record per round, and False if it
    stopped at ``max_evaluations``. nautilus needs two dimensions at least: a problem of
    one gets a second cube coordinate that the prior map drops (it changes neither the
    posterior nor the evidence).
    """
    import nautilus  # (about a second to import, with scikit-learn: only when sampling)

    if ndim < 2:
        transform = _Padded(transform, ndim)
    sampler = nautilus.Sampler(
        transform,
        loglike,
        n_dim=max(ndim, 2),
        n_live=n_live,
        n_networks=n_networks,
        n_batch=n_batch,
        vectorized=True,
        pass_dict=False,
        seed=seed,
    )
    target, rounds = float(n_effective), []
    while True:
        finished = sampler.run(
            f_live=f_live,
            n_eff=target,
            n_like_max=max_evaluations,
            discard_exploration=discard_exploration,
        )
        error = log_evidence_error(sampler)
        rounds.append(
            {"n_eff_target": target, "n_like": int(sampler.n_like), "log_evidence_error": error}
        )
        if not finished or is_converged(sampler.n_eff, error):
            return sampler, error, rounds, bool(finished)
        target = next_effective_target(sampler.n_eff, error)


def _highest_posterior(ns, transform: PriorTransform, P: int) -> np.ndarray:
    """The point estimate: the highest posterior density (likelihood x prior density) of
    every point evaluated, the exploration's included."""
    every = transform(np.concatenate(ns.points)[:, :P])  # (a padded cube has a column more)
    log_post = np.concatenate(ns.log_l) + transform.log_density(every)
    return every[int(np.argmax(log_post))]


def _sampler_settings(
    ns, seed, n_live, n_networks, f_live, n_effective, max_evaluations, discard_exploration
) -> dict:
    """nautilus's settings as run (``info["sampler"]``)."""
    return {
        "name": "nautilus",
        "version": _package_version("nautilus-sampler"),
        "n_live": n_live,
        "n_networks": n_networks,
        "n_batch": int(ns.n_batch),
        "f_live": f_live,
        "n_eff_target": n_effective,
        "max_evaluations": max_evaluations,
        "discard_exploration": discard_exploration,
        "vectorized": True,
        "seed": seed,
    }


def _nested_info(problem, lsq, transform, seed: int, settings: dict, n_draws: int) -> dict:
    """The run's record (``PosteriorResult.info``)."""
    law = problem.noise_law
    if law is None:
        noise = {
            "prior": {**transform.describe(), **noise_prior_description()},
            "point_estimate": "highest-posterior draw (MAP) of the parameters' marginal posterior",
            "noise_priors": noise_priors_text(),
            "noise": (
                "integrated out of the likelihood (Gauss-Legendre in log sigma), drawn given "
                "each draw used for PSIS-LOO"
            ),
        }
    else:
        noise = {
            "prior": transform.describe(),
            "point_estimate": "highest-posterior draw (MAP), the noise law's parameters included",
            "noise_priors": noise_law_priors_text(law),
            "noise": f"the {law.name} noise law's parameters sampled with the parameters",
        }
    return {
        "seed": seed,
        "sampler": settings,
        "start": "the prior (nested sampling); the chain's solver starts cold",
        "lsq_chi2": float(lsq.metrics.get("chi2", np.nan)),
        **noise,
        "samples": f"{n_draws} draws resampled to equal weights (systematic)",
        "fixed": dict(problem.fixed),
    }


def _noise_law_record(law, point, points, weights) -> dict:
    """The sampled noise law's parameters (``info["noise_law"]``): ``values`` and ``log10``
    at the point estimate, the weighted posterior ``median`` and ``intervals``
    (:data:`PERCENTS`) of each, in its unit
    (:data:`~fitdf.inference.noise_models.PARAMETER_UNITS`)."""
    intervals = {}
    for j, name in enumerate(law.names):
        q = weighted_quantiles(points[:, j], weights, [p / 100 for p in PERCENTS])
        intervals[name] = dict(zip(QUANTILES, map(float, 10.0**q)))
    return {
        "name": law.name,
        "sampled": True,
        "values": law.natural(point),
        "log10": [float(v) for v in point],
        "median": {name: iv["p50"] for name, iv in intervals.items()},
        "intervals": intervals,
    }


def fit_nested(
    problem: FitProblem,
    lsq: FitResult,
    seed: int = 0,
    n_live: int = DEFAULT_LIVE,
    n_networks: int = DEFAULT_NETWORKS,
    n_batch: int = DEFAULT_BATCH,
    f_live: float = 0.01,
    n_effective: int = MIN_EFFECTIVE,
    max_evaluations: int = 100_000,
    discard_exploration: bool = True,
    n_draws: int | None = None,
    max_loo_draws: int = 1000,
    sampler: str = "nautilus",
) -> PosteriorResult:
    """Sample the posterior of ``problem`` and estimate its evidence by nested sampling.

    Parameters
    ----------
    problem : FitProblem
    lsq : FitResult
        The least-squares fit of ``problem`` (its chi-square is recorded; the sampler
        draws from the prior, and the chain's solver starts cold).
    seed : int
        Fixes the whole run (the sampler, its networks, the resampling, the noise draws).
    n_live : int
        nautilus's live points: more find narrow or separate modes more surely, for
        evaluations in the exploration (:data:`DEFAULT_LIVE`).
    n_networks : int
        Networks in each bound's emulator (:data:`DEFAULT_NETWORKS`; nautilus's own
        default is 4, which costs more in training than the likelihood here).
    n_batch : int
        Points per likelihood call (:data:`DEFAULT_BATCH`).
    f_live : float
        The exploration ends when the live set holds less than this share of the evidence.
    n_effective : int
        The first target of effective draws (then more while the evidence's error is above
        :data:`MAX_LOG_EVIDENCE_ERROR`).
    max_evaluations : int
        At most this many likelihood evaluations; a run stopped there is not converged.
    discard_exploration : bool
        Drop the exploration's draws from the posterior and evidence (default): the bounds
        are built on those draws, which biases an estimate that keeps them and leaves its
        error underestimated (``tests/test_nested.py``); the sampling phase's draws are
        independent of the bounds.
    n_draws : int, optional
        Equal-weight draws in ``samples`` (default: the effective draws, at least 1000).
    max_loo_draws : int
        At most this many of those for PSIS-LOO and WAIC.
    sampler : {"nautilus"}
        The nested sampler (``benchmarks/compare_samplers.py`` chose it).

    Returns
    -------
    PosteriorResult
        With ``method="nested"``; ``diagnostics`` as the module docstring says.
    """
    if sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; choose one of {', '.join(SAMPLERS)}")
    rng = np.random.default_rng(seed)
    # (the chain's solver starts cold: the sampler draws from the whole prior box, where a
    # start at the optimum's currents is no faster)
    transform = PriorTransform(problem)
    loglike = NestedLikelihood(problem)
    law = problem.noise_law
    P = problem.ndim
    ndim = transform.ndim  # P, or P + k with a fitted noise law's parameters
    t0 = time.perf_counter()
    ns, error, rounds, finished = run_nautilus(
        transform,
        loglike,
        ndim,
        seed=seed,
        n_live=n_live,
        n_networks=n_networks,
        n_batch=n_batch,
        f_live=f_live,
        n_effective=n_effective,
        max_evaluations=max_evaluations,
        discard_exploration=discard_exploration,
    )
    seconds = time.perf_counter() - t0
    points, log_w, log_l = ns.posterior()  # internal vectors, normalised log weights
    weights = np.exp(log_w - logsumexp(log_w))
    n_eff = float(ns.n_eff)
    log_z = float(ns.log_z)

    full_point = _highest_posterior(ns, transform, ndim)
    point = full_point[:P]

    n_draws = int(n_draws or max(1000, int(np.ceil(n_eff))))
    idx = systematic_resample(weights, n_draws, rng)
    flat = points[idx]
    n_loo = min(max_loo_draws, n_draws)
    loo_idx = np.sort(rng.choice(n_draws, n_loo, replace=False))
    loo_draws = flat[loo_idx]
    extra = {"log_evidence": log_z, "log_evidence_error": error}
    if law is None:
        radial, tang = problem.error_components(problem.predict(loo_draws))
        loo_noise = noise_draws = loglike.noise.draw(radial, tang, rng)  # log10 (n, 2)
    else:  # the law's parameters were sampled: each draw carries its own
        loo_draws, loo_noise, noise_draws = loo_draws[:, :P], loo_draws[:, P:], flat[:, P:]
        # (AICc and BIC of the law's likelihood at the point estimate, as least squares
        # gives them at its optimum: the noise parameters counted)
        ll_point = float(loglike(full_point[None, :])[0])
        extra.update(law.criteria(ll_point, P, loglike.context))
    intervals, stderr, corr = _weighted_summaries(problem, points[:, :P], weights)

    settings = _sampler_settings(
        ns, seed, n_live, n_networks, f_live, n_effective, max_evaluations, discard_exploration
    )
    draws = (int(points.shape[0]), n_draws)
    diag = _run_diagnostics(ns, problem, error, rounds, finished, draws, seconds, settings)
    info = _nested_info(problem, lsq, transform, seed, settings, n_draws)
    if law is not None:  # the noise parameters' intervals from the weighted draws, as the law's
        info["noise_law"] = _noise_law_record(law, full_point[P:], points[:, P:], weights)
        diag.update({f"{n}_interval": iv for n, iv in info["noise_law"]["intervals"].items()})
    which = "all" if n_loo == n_draws else f"{n_loo} (a random choice, seed {seed}) of the"
    return posterior_result(
        problem,
        "nested",
        point=point,
        samples=flat[:, None, :P],
        intervals=intervals,
        stderr=stderr,
        correlations=corr,
        noise_draws=noise_draws[:, None, :],
        loo_draws=loo_draws[:, None, :],
        loo_noise=loo_noise[:, None, :],
        diagnostics=diag,
        info=info,
        sampler_warnings=convergence_warnings(n_eff, error, finished, ns.n_like, max_evaluations),
        loo_description=(
            f"{which} {n_draws} draws resampled to equal weights (systematic, seed {seed}) from "
            "nautilus's weighted draws: one chain"
        ),
        extra_metrics=extra,
        sampled_noise=law is not None,
        noise_law=law,
    )


def _run_diagnostics(ns, problem, error, rounds, finished, draws, seconds, settings) -> dict:
    """The run's record for a result's ``diagnostics`` (module docstring, **Outputs**): the
    evidence and its error, the effective draws and evaluations, :func:`is_converged`, the
    numbers of weighted points and of draws resampled from them (``draws``), the sampler's
    ``settings``, and emcee's fields for the consumers that read them (independent
    weighted draws: the ESS is the effective draws', R-hat and autocorrelation times none).
    """
    n_eff = float(ns.n_eff)
    return {
        "log_evidence": float(ns.log_z),
        "log_evidence_error": error,
        "n_effective": n_eff,
        "n_likelihood_evaluations": int(ns.n_like),
        "effective_per_evaluation": n_eff / max(int(ns.n_like), 1),
        "converged": is_converged(n_eff, error),
        "finished": finished,
        "rounds": rounds,
        "n_points": draws[0],
        "n_draws": draws[1],
        "n_bounds": len(ns.bounds),
        "seconds": seconds,
        "sampler": settings,
        "ess_bulk": {n: n_eff for n in problem.names},
        "rhat": {n: float("nan") for n in problem.names},
        "tau": {n: float("nan") for n in problem.names},
        "steps_over_tau": float("nan"),
        "acceptance_mean": float("nan"),
    }


def _weighted_summaries(problem, points, weights):
    """Intervals (weighted quantiles), standard errors and correlations (weighted moments)
    of internal ``points`` ``(n, P)`` with normalised ``weights``."""
    nat = problem.to_natural(points)
    intervals, stderr = {}, {}
    for i, s in enumerate(problem.specs):
        q = weighted_quantiles(points[:, i], weights, [p / 100 for p in PERCENTS])
        intervals[s.name] = dict(zip(QUANTILES, map(float, s.from_internal(q))))
        mean = np.sum(weights * nat[:, i])
        stderr[s.name] = float(np.sqrt(np.sum(weights * (nat[:, i] - mean) ** 2)))
    centred = points - np.sum(weights[:, None] * points, axis=0)
    cov = (weights[:, None] * centred).T @ centred
    sd = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    corr = pd.DataFrame(cov / np.outer(sd, sd), index=problem.names, columns=problem.names)
    return intervals, stderr, corr
