"""MCMC with emcee: a posterior for every parameter, started from the least-squares optimum.

Likelihood
    The Gaussian of :meth:`fitdf.inference.problem.FitProblem.pointwise_loglike` with two
    *fitted* noise scales, one for magnitude and one for phase. Their priors are
    log-uniform (Jeffreys) on 0.001..1 (magnitude) and 0.1..50 degrees (phase), wide
    around the tables' printed precision (0.01, 1 degree), so the data say how well the
    model can do, instead of assuming it.
Priors
    Uniform on each parameter's internal coordinate inside its declared bounds: uniform
    for ordinary parameters, log-uniform for log-scaled ones.
Sampler
    ``emcee.EnsembleSampler(..., vectorize=True)``: the log-probability of all walkers is
    one batched call. Walkers start in a small Gaussian ball from the least-squares
    covariance, clipped inside the bounds. A seed fixes the whole chain.
Diagnostics
    Integrated autocorrelation time per parameter (emcee), a warning when the chain is
    shorter than 50 times it, acceptance fraction, and R-hat and bulk ESS from ArviZ
    (walkers as chains), PSIS-LOO and WAIC from the pointwise log-likelihood.
Point estimate
    ``values``, residuals and metrics use the draw of highest posterior; intervals are
    posterior percentiles (a warning says when the per-parameter medians fit far worse,
    the sign of a multimodal posterior).
"""

from __future__ import annotations

import warnings

import emcee
import numpy as np
import pandas as pd

from fitdf._arviz import az
from fitdf.inference.metrics import information_criteria, residual_metrics
from fitdf.inference.problem import FitProblem
from fitdf.inference.results import FitResult, PosteriorResult, residual_table

__all__ = [
    "fit_mcmc",
    "default_moves",
    "LogPosterior",
    "NOISE_BOUNDS",
    "chain_diagnostics",
    "autocorr_time",
    "is_converged",
    "RHAT_MAX",
    "MIN_STEPS_OVER_TAU",
]


def default_moves():
    """Differential-evolution moves: the posteriors here are correlated and skewed (winding
    resistance against inductance), where DE mixes several times faster than the stretch move."""
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


#: log10 bounds of the fitted noise scales (magnitude, phase in degrees).
NOISE_BOUNDS = np.array([[-3.0, 0.0], [-1.0, np.log10(50.0)]])


class LogPosterior:
    """Vectorised log-posterior over ``(n_walkers, P + 2)`` internal vectors."""

    def __init__(self, problem: FitProblem):
        self.problem = problem
        self.bounds = np.vstack([problem.internal_bounds(), NOISE_BOUNDS])

    def pointwise(self, X):
        P = self.problem.ndim
        return self.problem.pointwise_loglike(X[..., :P], 10.0 ** X[..., P], 10.0 ** X[..., P + 1])

    def __call__(self, X):
        X = np.atleast_2d(X)
        inside = np.all((X >= self.bounds[:, 0]) & (X <= self.bounds[:, 1]), axis=-1)
        out = np.full(X.shape[0], -np.inf)
        if inside.any():
            with np.errstate(all="ignore"):
                ll = np.sum(self.pointwise(X[inside]), axis=-1) + self.problem.log_prior(
                    X[inside][:, : self.problem.ndim]
                )
            out[inside] = np.where(np.isfinite(ll), ll, -np.inf)
        return out


def _initial_ball(problem, lsq: FitResult, n_walkers, rng, bounds):
    P = problem.ndim
    lo, hi = bounds[:, 0], bounds[:, 1]
    width = hi - lo
    radial, tang = problem.error_components(problem.predict(lsq.internal))
    sm = np.sqrt(np.mean(radial**2))
    sp = np.rad2deg(np.sqrt(np.mean(tang**2)) / max(np.mean(np.abs(problem.data.measured)), 1e-3))
    centre = np.concatenate([lsq.internal, np.log10([max(sm, 1.5e-3), max(sp, 0.15)])])
    centre = np.clip(centre, lo + 1e-6 * width, hi - 1e-6 * width)
    cov = lsq.info.get("covar_internal")
    cov = None if cov is None else np.asarray(cov, float)
    scale = np.full(P + 2, 1e-3) * width
    if cov is not None:
        # a ball of the least-squares size shortens the burn-in (walkers need not expand first)
        scale[:P] = (
            np.minimum(0.5 * np.sqrt(np.clip(np.diag(cov), 0, None)), 0.02 * width[:P])
            + 1e-6 * width[:P]
        )
    scale[P:] = 0.02
    p0 = centre + scale * rng.standard_normal((n_walkers, P + 2))
    return np.clip(p0, lo + 1e-9 * width, hi - 1e-9 * width)


#: R-hat at or above this is reported as not converged. Rank-normalised R-hat < 1.01 is the modern
#: target; walkers of one ensemble are not independent, so 1.05 is the threshold here.
RHAT_MAX = 1.05
#: The chain must be at least this many integrated autocorrelation times long.
MIN_STEPS_OVER_TAU = 50


def _as_arviz(chain, names) -> dict:
    """An emcee array ``(draw, walker, parameter)`` as ArviZ variables ``(chain, draw)``:
    walkers become ArviZ chains."""
    return {n: np.swapaxes(chain[..., i], 0, 1) for i, n in enumerate(names)}


def autocorr_time(chain) -> np.ndarray:
    """Integrated autocorrelation time per parameter of an emcee array ``(draw, walker, parameter)``
    (emcee's estimator, walkers averaged, no length check)."""
    return emcee.autocorr.integrated_time(chain, tol=0)


def chain_diagnostics(samples, names) -> dict:
    """Rank-normalised R-hat and bulk ESS per parameter (ArviZ) of an emcee array
    ``(draw, walker, parameter)``, walkers taken as chains."""
    full = az.from_dict(posterior=_as_arviz(samples, names))
    rhat = az.rhat(full)
    ess = az.ess(full)
    return {
        "rhat": {n: float(rhat[n]) for n in names},
        "ess_bulk": {n: float(ess[n]) for n in names},
    }


def is_converged(steps_over_tau, rhat) -> bool:
    """The convergence rule: at least 50 autocorrelation times and every R-hat below 1.05."""
    return bool(steps_over_tau >= MIN_STEPS_OVER_TAU and max(rhat.values()) < RHAT_MAX)


def _arviz_diagnostics(post_burn, names, loo_draws, loglik):
    """R-hat and bulk ESS on the whole post-burn chain; PSIS-LOO and WAIC on a subsample.

    ``post_burn`` and ``loo_draws`` are emcee arrays ``(draw, walker, parameter)``; ArviZ
    wants ``(chain, draw)``, so walkers become ArviZ chains.
    """
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        diag = chain_diagnostics(post_burn, names)
        idata = az.from_dict(
            posterior=_as_arviz(loo_draws, names), log_likelihood={"df": np.swapaxes(loglik, 0, 1)}
        )
        loo = az.loo(idata, pointwise=True)
        waic = az.waic(idata, pointwise=True)  # explicit: the rcParams default may be False
    # ArviZ's shape heuristic complains when walkers outnumber the (thinned) draws; that is expected here.
    caught = sorted(
        {
            str(x.message).split("\n")[0]
            for x in w
            if "More chains" not in str(x.message) and "refactor" not in str(x.message)
        }
    )
    pareto_k = np.asarray(loo.pareto_k)
    return {
        **diag,
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
        "n_pareto_k_bad": int(np.sum(pareto_k > 0.7)),
        "pointwise_elpd_loo": np.asarray(loo.loo_i).tolist(),
    }, caught


def fit_mcmc(
    problem: FitProblem,
    lsq: FitResult,
    seed: int = 0,
    n_walkers: int | None = None,
    n_steps: int = 1500,
    progress: bool = False,
    max_loo_draws: int = 1000,
    moves=None,
    max_steps: int | None = None,
    check_every: int = 250,
) -> PosteriorResult:
    """Sample the posterior of ``problem`` starting from the least-squares result ``lsq``.

    Runs at least ``n_steps`` steps, then keeps going in blocks of ``check_every`` until the
    chain is 50 integrated autocorrelation times long or ``max_steps`` (default
    ``n_steps``: no extension) is reached. The stopping rule only reads the chain, so a
    seed still fixes the result.
    """
    rng = np.random.default_rng(seed)
    # walkers stay near the optimum: its currents start the solver (on a copy: the caller's
    # problem, shared with the least-squares result, keeps its cold predictions)
    problem = problem.warm_started(lsq.internal)
    logpost = LogPosterior(problem)
    P = problem.ndim
    ndim = P + 2
    n_walkers = n_walkers or max(32, 2 * ndim + 2)
    n_walkers += n_walkers % 2
    p0 = _initial_ball(problem, lsq, n_walkers, rng, logpost.bounds)
    moves = moves if moves is not None else default_moves()
    sampler = emcee.EnsembleSampler(n_walkers, ndim, logpost, vectorize=True, moves=moves)
    # emcee's wrapper of the log-probability prints a traceback for any exception, Ctrl-C and
    # SIGTERM included (the command line stops with one line); it only adds args we don't use
    sampler.log_prob_fn = logpost
    sampler.random_state = np.random.RandomState(seed).get_state()
    max_steps = max(n_steps, max_steps or n_steps)
    state = sampler.run_mcmc(p0, n_steps, progress=progress)
    tau = autocorr_time(sampler.get_chain())
    while sampler.iteration < max_steps and sampler.iteration < MIN_STEPS_OVER_TAU * np.nanmax(tau):
        state = sampler.run_mcmc(
            state, min(check_every, max_steps - sampler.iteration), progress=progress
        )
        tau = autocorr_time(sampler.get_chain())
    n_steps = sampler.iteration

    tau_max = float(np.nanmax(tau))
    burn = min(int(np.ceil(3 * tau_max)), n_steps // 2)
    thin = max(1, int(np.floor(np.nanmin(tau) / 2)))
    post_burn = sampler.get_chain(discard=burn)  # (draws, walkers, ndim)
    samples = post_burn[::thin]
    names = problem.names + ["sigma_magnitude", "sigma_phase_deg"]

    flat = samples.reshape(-1, ndim)
    # PSIS-LOO needs the pointwise log-likelihood: evaluate it on at most max_loo_draws draws
    step = max(1, int(np.ceil(flat.shape[0] / max_loo_draws)))
    loo_draws = samples[::step] if samples.shape[0] >= 2 * step else samples
    loglik = logpost.pointwise(loo_draws)  # (draws, walkers, n)
    diag, caught = _arviz_diagnostics(post_burn, names, loo_draws, loglik)
    diag.update(
        {
            "tau": dict(zip(names, map(float, tau))),
            "n_steps": n_steps,
            "n_walkers": n_walkers,
            "burn": burn,
            "thin": thin,
            "steps_over_tau": float(n_steps / tau_max),
            "acceptance_mean": float(np.mean(sampler.acceptance_fraction)),
            "acceptance_min": float(np.min(sampler.acceptance_fraction)),
            "n_draws": int(flat.shape[0]),
        }
    )
    diag["converged"] = is_converged(diag["steps_over_tau"], diag["rhat"])

    warns = []
    if diag["steps_over_tau"] < MIN_STEPS_OVER_TAU:
        warns.append(
            f"chain of {n_steps} steps is shorter than 50 autocorrelation times "
            f"(max tau {tau_max:.0f}); run more --steps"
        )
    if max(diag["rhat"].values()) >= RHAT_MAX:
        worst = max(diag["rhat"], key=diag["rhat"].get)
        warns.append(f"R-hat {diag['rhat'][worst]:.3f} for {worst} (>= 1.05)")
    if not 0.1 <= diag["acceptance_mean"] <= 0.9:
        warns.append(f"mean acceptance fraction {diag['acceptance_mean']:.2f} outside 0.1-0.9")
    if diag["n_pareto_k_bad"]:
        warns.append(
            f"PSIS-LOO: {diag['n_pareto_k_bad']} rows with Pareto k > 0.7 (LOO unreliable there)"
        )
    warns += [f"ArviZ: {c}" for c in caught if "pareto" not in c.lower()]

    nat = problem.to_natural(flat[:, :P])
    # Point estimate: the draw of highest posterior (MAP). The per-parameter median can
    # combine different modes of a multimodal posterior into a point that fits none.
    log_prob = sampler.get_log_prob(discard=burn)
    best_draw = post_burn.reshape(-1, ndim)[int(np.argmax(log_prob.reshape(-1)))]
    median_internal = np.median(flat[:, :P], axis=0)
    point = best_draw[:P]
    chi2_point = float(np.sum(problem.weighted_residuals(point) ** 2))
    chi2_median = float(np.sum(problem.weighted_residuals(median_internal) ** 2))
    if chi2_median > chi2_point + 2 * P + 10:
        warns.append(
            f"posterior is multimodal or strongly skewed: the per-parameter medians fit far worse "
            f"(chi2 {chi2_median:.0f}) than the best draw (chi2 {chi2_point:.0f}); values are the best draw"
        )
    values = {k: float(v) for k, v in problem.full_natural(point).items()}
    intervals = {}
    for i, s in enumerate(problem.specs):
        q = np.percentile(nat[:, i], [2.5, 16, 50, 84, 97.5])
        intervals[s.name] = dict(zip(["p2.5", "p16", "p50", "p84", "p97.5"], map(float, q)))
    for j, n in enumerate(["sigma_magnitude", "sigma_phase_deg"]):
        q = np.percentile(10 ** flat[:, P + j], [2.5, 16, 50, 84, 97.5])
        diag[f"{n}_interval"] = dict(zip(["p2.5", "p16", "p50", "p84", "p97.5"], map(float, q)))
    stderr = {s.name: float(np.std(nat[:, i])) for i, s in enumerate(problem.specs)}
    corr = pd.DataFrame(
        np.corrcoef(flat[:, :P], rowvar=False).reshape(P, P),
        index=problem.names,
        columns=problem.names,
    )

    predicted = problem.predict(point)
    metrics = {
        "n_points": problem.data.n,
        "n_params": P,
        **residual_metrics(predicted, problem.data.measured),
        **information_criteria(problem.weighted_residuals(point), P),
        **{
            k: diag[k]
            for k in ("looic", "looic_se", "waic", "waic_se", "elpd_loo", "elpd_loo_se", "p_loo")
        },
    }
    info = {
        "seed": seed,
        "n_steps": n_steps,
        "n_walkers": n_walkers,
        "start": "least squares",
        "point_estimate": "highest-posterior draw (MAP)",
        "noise_priors": "log-uniform: sigma_magnitude 0.001..1, sigma_phase 0.1..50 deg",
        "fixed": dict(problem.fixed),
    }
    return PosteriorResult(
        model=problem.model.name,
        chain=problem.chain.name,
        method="mcmc",
        label=problem.data.label,
        values=values,
        stderr=stderr,
        intervals=intervals,
        correlations=corr,
        metrics=metrics,
        residuals=residual_table(problem, predicted),
        warnings=warns,
        info=info,
        problem=problem,
        internal=point,
        samples=samples[..., :P],
        noise_samples=10 ** samples[..., P:],
        diagnostics=diag,
    )
