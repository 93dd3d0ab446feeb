"""MCMC with emcee: a posterior for every parameter, started from the least-squares optimum.

Provides :func:`fit_mcmc`, which samples the posterior of a
:class:`~fitdf.inference.problem.FitProblem` from its least-squares fit and returns a
:class:`~fitdf.inference.results.PosteriorResult`; the vectorised log-posterior
:class:`LogPosterior` and the sampler's coordinates :class:`BoxCoordinates`; the diagnostics
:func:`autocorr_time` and :func:`chain_diagnostics`; and the convergence rule
:func:`is_converged` with its thresholds :data:`MIN_STEPS_OVER_TAU` (autocorrelation
times), :data:`RHAT_MAX` and :data:`MIN_ESS`.

Notes
-----
The likelihood is the Gaussian of
:meth:`~fitdf.inference.problem.FitProblem.pointwise_loglike` with two fitted noise scales,
magnitude and phase, under log-uniform priors on
:data:`~fitdf.inference.noise.NOISE_RANGES` (wide around the tables' printed precision); by
default they are integrated out of the likelihood (:mod:`fitdf.inference.noise`) and drawn
afterwards for the draws PSIS-LOO uses. Each parameter has a uniform prior on its internal
coordinate inside its bounds (log-uniform for log-scaled parameters), times the problem's
Gaussian priors (the winding resistance's). The walkers move in the logit coordinates of that box, with the
log-Jacobian added, so the posterior is unchanged. A pilot of at least ``2 d + 2`` walkers
starts in a ball of the least-squares covariance, runs one round of differential evolution,
then rounds of the production moves adapted to the previous round, until a round's draws
keep the previous round's shape and its moves accept (at least two adapted rounds, at most
``max_pilot_rounds``); it is discarded. Production continues ``n_chains`` of its walkers as
independent Metropolis-Hastings chains with the fixed moves of
:func:`fitdf.inference.proposals.production_moves`, and is extended in blocks until
:func:`is_converged` holds (its integrated autocorrelation times, rank-normalised R-hat and
bulk ESS) or ``max_steps`` is reached; it stops earlier once :data:`MIN_STEPS_OVER_TAU`
autocorrelation times exceed ``max_steps``, and a chain that reaches ``max_steps`` on course
for them but short of R-hat or ESS may go on to ``extend_steps``. The point estimate is the draw of highest posterior, intervals
are posterior percentiles, and the warnings name what the posterior does not settle
(:mod:`fitdf.inference.caveats`); the result is assembled as nested sampling's is
(:func:`fitdf.inference.posterior.posterior_result`). A seed fixes the whole run.

References
----------
Foreman-Mackey, D., Hogg, D. W., Lang, D. and Goodman, J., "emcee: the MCMC hammer",
Publ. Astron. Soc. Pac. 125, 306 (2013).

Vehtari, A., Gelman, A., Simpson, D., Carpenter, B. and Bürkner, P.-C.,
"Rank-normalization, folding, and localization: an improved R-hat for assessing convergence
of MCMC", Bayesian Analysis 16, 667 (2021).

Vehtari, A., Gelman, A. and Gabry, J., "Practical Bayesian model evaluation using
leave-one-out cross-validation and WAIC", Statistics and Computing 27, 1413 (2017).
"""

from __future__ import annotations

import emcee
import numpy as np
import pandas as pd
from scipy.special import expit, log_expit, logit

from fitdf._arviz import arviz, walkers_as_chains
from fitdf.inference.convergence import MIN_ESS, MIN_STEPS_OVER_TAU, RHAT_MAX
from fitdf.inference.noise import NOISE_BOUNDS, NOISE_NAMES, NoiseMarginal
from fitdf.inference.posterior import PERCENTS, QUANTILES, posterior_result, recorded_warnings
from fitdf.inference.priors import noise_priors_text
from fitdf.inference.problem import FitProblem
from fitdf.inference.proposals import (
    PriorCoordinateProposal,
    StudentTProposal,
    production_moves,
)
from fitdf.inference.results import FitResult, PosteriorResult

__all__ = [
    "fit_mcmc",
    "default_moves",
    "LogPosterior",
    "NOISE_BOUNDS",
    "PILOT_STEPS",
    "chain_diagnostics",
    "autocorr_time",
    "is_converged",
    "RHAT_MAX",
    "MIN_STEPS_OVER_TAU",
    "MIN_ESS",
    "StudentTProposal",
]


def default_moves():
    """Differential-evolution moves: the posteriors here are correlated and skewed (winding
    resistance against inductance), where DE mixes several times faster than the stretch move."""
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


class LogPosterior:
    """Vectorised log-posterior over ``(n_walkers, ndim)`` internal vectors.

    ``ndim`` is ``P + 2`` (the parameters, then ``log10`` of the two noise scales), or
    ``P`` with ``marginal_noise=True``: the noise scales are then integrated out of the
    likelihood (:class:`fitdf.inference.noise.NoiseMarginal`), the posterior of the
    parameters is the same, and :meth:`with_noise` draws the scales for given parameters.
    With ``logit=True`` it takes the sampler's coordinates ``z`` of
    :class:`BoxCoordinates` instead, and adds the log-Jacobian, so that the posterior of
    the internal vector is the same.
    """

    def __init__(self, problem: FitProblem, logit: bool = False, marginal_noise: bool = False):
        self.problem = problem
        self.noise = NoiseMarginal(problem) if marginal_noise else None
        self.bounds = (
            problem.internal_bounds()
            if marginal_noise
            else np.vstack([problem.internal_bounds(), NOISE_BOUNDS])
        )
        self.box = BoxCoordinates(self.bounds) if logit else None

    @property
    def ndim(self) -> int:
        return self.bounds.shape[0]

    def pointwise(self, X):
        """Log-likelihood per row of full vectors ``(..., P + 2)`` (noise scales included)."""
        P = self.problem.ndim
        return self.problem.pointwise_loglike(X[..., :P], 10.0 ** X[..., P], 10.0 ** X[..., P + 1])

    def with_noise(self, X, rng):
        """Full vectors ``(..., P + 2)``: internal parameter vectors ``(..., P)`` with
        ``log10`` noise scales drawn from their law given each (marginal mode only)."""
        radial, tang = self.problem.error_components(self.problem.predict(X))
        return np.concatenate([X, self.noise.draw(radial, tang, rng)], axis=-1)

    def to_internal(self, Z):
        """Internal vectors (prior box) of sampler coordinates (the identity without logit)."""
        return Z if self.box is None else self.box.to_box(Z)

    def to_sampler(self, X):
        return X if self.box is None else self.box.from_box(X)

    def __call__(self, Z):
        Z = np.atleast_2d(Z)
        if self.box is not None:
            return self._box_posterior(self.box.to_box(Z)) + self.box.log_jacobian(Z)
        return self._box_posterior(Z)

    def _box_posterior(self, X):
        inside = np.all((X >= self.bounds[:, 0]) & (X <= self.bounds[:, 1]), axis=-1)
        out = np.full(X.shape[0], -np.inf)
        if inside.any():
            X_in = X[inside]
            P = self.problem.ndim
            with np.errstate(all="ignore"):
                if self.noise is None:
                    ll = np.sum(self.pointwise(X_in), axis=-1)
                else:
                    radial, tang = self.problem.error_components(self.problem.predict(X_in))
                    ll = self.noise.log_likelihood(radial, tang)
                ll = ll + self.problem.log_prior(X_in[:, :P])
            out[inside] = np.where(np.isfinite(ll), ll, -np.inf)
        return out


class BoxCoordinates:
    """Logit coordinates of the prior box: ``z = log((x - lo) / (hi - x))`` per parameter.

    A parameter the data leave undetermined fills its box with a flat posterior, and one
    the data push against a bound piles up at it; a random walk or a t proposal in ``x``
    then puts many draws outside the box (rejected: acceptance of a few per cent). In
    ``z`` the box is the whole line, the flat posterior becomes a logistic density and the
    pile-up at a bound an exponential tail, both of which Gaussian proposals sample well.
    The density in ``z`` is that in ``x`` times ``dx/dz = (hi - lo) s(z) s(-z)``
    (``s`` the logistic function), so the posterior of ``x`` is unchanged.
    """

    def __init__(self, bounds):
        bounds = np.asarray(bounds, float)
        self.lo = bounds[:, 0]
        self.width = bounds[:, 1] - bounds[:, 0]
        self._log_width = float(np.sum(np.log(self.width)))

    def to_box(self, z):
        return self.lo + self.width * expit(z)

    def from_box(self, x):
        return logit(np.clip((np.asarray(x, float) - self.lo) / self.width, 1e-12, 1 - 1e-12))

    def log_jacobian(self, z):
        """``log |dx/dz|`` summed over the last axis."""
        z = np.asarray(z, float)
        return self._log_width + np.sum(log_expit(z) + log_expit(-z), axis=-1)


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


def _as_arviz(chain, names) -> dict:
    """An emcee array ``(draw, walker, parameter)`` as ArviZ variables ``(chain, draw)``:
    walkers become ArviZ chains."""
    return {n: np.swapaxes(chain[..., i], 0, 1) for i, n in enumerate(names)}


def autocorr_time(chain) -> np.ndarray:
    """Integrated autocorrelation time per parameter of an emcee array ``(draw, walker, parameter)``
    (emcee's estimator, walkers averaged, no length check); NaN for a parameter that never
    moved (a few steps of a chain that accepted nothing)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return emcee.autocorr.integrated_time(chain, tol=0)


def chain_diagnostics(samples, names) -> dict:
    """Rank-normalised R-hat and bulk ESS per parameter (ArviZ) of an emcee array
    ``(draw, walker, parameter)``, walkers taken as chains."""
    az = arviz()
    with walkers_as_chains():
        full = az.from_dict(posterior=_as_arviz(samples, names))
        rhat = az.rhat(full)
        ess = az.ess(full)
    return {
        "rhat": {n: float(rhat[n]) for n in names},
        "ess_bulk": {n: float(ess[n]) for n in names},
    }


def is_converged(steps_over_tau, rhat, ess_bulk=None) -> bool:
    """The convergence rule: at least :data:`MIN_STEPS_OVER_TAU` autocorrelation times, every
    R-hat below :data:`RHAT_MAX` and (when given) every bulk ESS at least :data:`MIN_ESS`."""
    ess_ok = ess_bulk is None or min(ess_bulk.values()) >= MIN_ESS
    return bool(steps_over_tau >= MIN_STEPS_OVER_TAU and max(rhat.values()) < RHAT_MAX and ess_ok)


def _tau_range(tau, n_steps):
    """Smallest and largest finite autocorrelation time; the chain's length if none is finite
    (no parameter moved: one autocorrelation time is then the whole chain, at least)."""
    finite = np.asarray(tau, float)[np.isfinite(tau)]
    if not finite.size:
        return float(n_steps), float(n_steps)
    return float(finite.min()), float(finite.max())


#: A pilot round has settled when its draws' shape (:func:`_shape_change`) differs from
#: the previous round's by at most this ...
SETTLED_SHAPE_CHANGE = 0.25
#: ... and its adapted moves accepted at least this fraction.
SETTLED_ACCEPTANCE = 0.15
#: ... after at least this many adapted rounds: the first is compared with differential
#: evolution's, and a kernel move built on draws that cover only part of the posterior
#: accepts well inside that part, so one adapted round can pass both tests on a posterior
#: it has not covered (constant_width on B.3 does: acceptance 0.40 and a shape change below
#: 0.25 after one round, and production from it does not mix, R-hat 1.25).
MIN_ADAPTED_ROUNDS = 2


def _shape_change(before, after) -> float:
    """How far the draws ``(n, d)`` of one pilot round moved from the previous round's: the
    largest over parameters of the mean's shift in units of the new spread and of
    ``|log|`` of the ratio of spreads. Near 0 when both rounds sample the same
    posterior; large while the walkers still climb or spread along a ridge (which a
    steady log-posterior alone does not show)."""
    sd_before, sd_after = np.std(before, axis=0), np.std(after, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.abs(np.mean(after, axis=0) - np.mean(before, axis=0)) / sd_after
        spread = np.abs(np.log(sd_after / sd_before))
    both = np.concatenate([shift, spread])
    return float(np.max(np.where(np.isfinite(both), both, np.inf)))


def _burn(tau, n_steps):
    return min(int(np.ceil(3 * _tau_range(tau, n_steps)[1])), n_steps // 2)


def _run_until_converged(
    sampler,
    state,
    n_steps,
    max_steps,
    check_every,
    names,
    progress,
    to_internal=None,
    extend_to=None,
):
    """Run ``n_steps``, then blocks of ``check_every`` until :func:`is_converged` or ``max_steps``.

    Stops early, too, once the chain cannot converge within ``max_steps``: when 50 times its
    autocorrelation time so far already exceeds ``max_steps`` (the estimate from a short
    chain is low, if anything, so this gives up only on chains that are surely too slow).
    Past ``max_steps``, up to ``extend_to`` (default: no further), only a chain that reached
    ``max_steps`` on course for 50 autocorrelation times (the rule above) goes on, while its
    R-hat or bulk ESS is short: it mixes well enough and needs more draws, not another
    sampler (Preisach on B.1 and B.2: at 4000 steps, 60 autocorrelation times and R-hat 1.02,
    ESS 310-430). It goes on while 50 autocorrelation times fit in ``extend_to``: the rule
    above with the extended limit, not 50 times within the steps run so far, which would
    stop a chain whenever its estimate, moving by a few per cent from check to check, ticks
    up.
    Returns ``(tau, given_up)``: ``given_up`` is that projected length, else None.
    ``to_internal`` maps the sampler's coordinates to the reported ones (the diagnostics
    are those of the reported parameters).
    """
    to_internal = to_internal or (lambda z: z)
    extend_to = max(max_steps, extend_to or max_steps)
    # (fewer independent chains than dimensions are not "linearly independent walkers", the
    # check emcee makes for its ensemble moves)
    state = sampler.run_mcmc(state, n_steps, progress=progress, skip_initial_state_check=True)
    while True:
        chain = to_internal(sampler.get_chain())
        tau = autocorr_time(chain)
        n = sampler.iteration
        tau_max = _tau_range(tau, n)[1]
        needed = MIN_STEPS_OVER_TAU * tau_max
        if n >= max_steps:
            if n >= extend_to or needed > extend_to:
                return tau, None
        elif needed > max_steps:
            return tau, int(np.ceil(needed))
        d = chain_diagnostics(chain[_burn(tau, n) :], names)
        if is_converged(n / tau_max, d["rhat"], d["ess_bulk"]):
            return tau, None
        limit = max_steps if n < max_steps else extend_to
        state = sampler.run_mcmc(
            state, min(check_every, limit - n), progress=progress, skip_initial_state_check=True
        )


def _pooled(pool, last):
    """The pooled draws of the adapted pilot rounds (the last round's before there are any)."""
    return np.concatenate(pool) if pool else last


def _pilot(logpost, start, pilot_steps, max_pilot_rounds, random_state, rng, progress) -> dict:
    """The pilot (:func:`fit_mcmc`; discarded): differential evolution from the walkers
    ``start``, then rounds of the moves adapted to the previous round's second half (a better
    estimate of the posterior's shape: they mix several times faster than DE), until a
    round's draws have the previous round's shape (:data:`SETTLED_SHAPE_CHANGE`) and its
    moves accept (:data:`SETTLED_ACCEPTANCE`), or ``max_pilot_rounds``: walkers started at
    the least-squares optimum may still be spreading along a ridge, or moving to where the
    fitted noise puts the mass. One random stream (``random_state``, emcee's) runs through
    every round. Returns the walkers' last positions ``start``, the stream's
    ``random_state``, each round's shape change and acceptance (``rounds``), the last
    round's second half (``draws``, None without a pilot) and the adapted rounds' draws
    (``pool``).
    """
    ndim, logit = logpost.ndim, logpost.box is not None
    out = {"start": start, "random_state": random_state, "rounds": [], "draws": None, "pool": []}
    if pilot_steps <= 0:
        return out
    round_moves, previous, pool = default_moves(), None, out["pool"]
    for k in range(1 + max(int(max_pilot_rounds), 1)):
        pilot = emcee.EnsembleSampler(len(start), ndim, logpost, vectorize=True, moves=round_moves)
        # emcee's wrapper of the log-probability prints a traceback for any exception,
        # Ctrl-C and SIGTERM included (the command line stops with one line); it only
        # adds args we don't use
        pilot.log_prob_fn = logpost
        pilot.random_state = random_state
        start = pilot.run_mcmc(
            start, pilot_steps, progress=progress, skip_initial_state_check=True
        ).coords
        random_state = pilot.random_state
        draws = pilot.get_chain(discard=pilot_steps // 2, flat=True)
        change = np.inf if previous is None else _shape_change(previous, draws)
        acceptance = float(np.mean(pilot.acceptance_fraction))
        out["rounds"].append({"shape_change": change, "acceptance": acceptance})
        settled = change <= SETTLED_SHAPE_CHANGE and acceptance >= SETTLED_ACCEPTANCE
        if k >= MIN_ADAPTED_ROUNDS and settled:
            break
        previous = draws
        if k >= 1:  # the adapted rounds' draws, pooled: a lobe visited once stays covered
            pool.append(draws)
        round_moves = production_moves(draws, _pooled(pool, draws), rng, logit=logit)
    out.update(start=start, random_state=random_state, draws=draws)
    return out


#: Steps of a pilot round (no more than ``n_steps``).
PILOT_STEPS = 300


def fit_mcmc(
    problem: FitProblem,
    lsq: FitResult,
    seed: int = 0,
    n_walkers: int | None = None,
    n_steps: int = 1000,
    progress: bool = False,
    max_loo_draws: int = 1000,
    moves=None,
    max_steps: int | None = None,
    check_every: int = 250,
    pilot_steps: int | None = None,
    n_chains: int = 8,
    max_pilot_rounds: int = 6,
    logit: bool = True,
    extend_steps: int | None = None,
    marginal_noise: bool = True,
) -> PosteriorResult:
    """Sample the posterior of ``problem`` starting from the least-squares result ``lsq``.

    One function, read top to bottom as the run goes: the start, the pilot, the production
    chain and what is kept of it share the random state in that order; each stage that has a
    job of its own is a helper (:func:`_pilot`, :func:`_production_moves`,
    :func:`_run_until_converged`, :func:`_map_point`, :func:`_mcmc_info`).

    A pilot of rounds of ``pilot_steps`` (default ``min(PILOT_STEPS, n_steps)``) with
    ``n_walkers`` walkers (at least ``2 d + 2``): one of differential evolution, then up to
    ``max_pilot_rounds`` of adapted moves until settled; it adapts the production moves
    (module docstring) and is discarded;
    production continues ``n_chains`` of its walkers as independent chains. ``moves``, if
    given, replace the adapted ones (and production keeps every walker).
    Production runs at least ``n_steps`` steps, then keeps going in blocks of
    ``check_every`` until the chain is converged (:func:`is_converged`) or ``max_steps``
    (default ``n_steps``: no extension) is reached, or until 50 of its autocorrelation
    times exceed ``max_steps`` (it cannot converge there); a chain that reaches ``max_steps``
    so, short of R-hat or ESS, goes on up to ``extend_steps`` while 50 autocorrelation times
    fit in it (default None: it stops at ``max_steps``). The stopping rule only reads the
    chain, so a seed still fixes the result. ``logit`` (default) moves the walkers in the
    logit coordinates of the prior box (module docstring); False, in the internal
    coordinates themselves. ``marginal_noise`` (default) integrates the two noise scales
    out of the likelihood and draws them afterwards for the draws PSIS-LOO uses
    (:mod:`fitdf.inference.noise`); False samples them with the parameters.
    """
    rng = np.random.default_rng(seed)
    # walkers stay near the optimum: its currents start the solver (on a copy: the caller's
    # problem, shared with the least-squares result, keeps its cold predictions)
    problem = problem.warm_started(lsq.internal)
    logpost = LogPosterior(problem, logit=logit, marginal_noise=marginal_noise)
    P = problem.ndim
    ndim = logpost.ndim
    names = (problem.names + list(NOISE_NAMES))[:ndim]  # the sampled coordinates
    # the pilot's differential evolution needs at least twice as many walkers as dimensions
    n_walkers = max(n_walkers or 0, 2 * ndim + 2)
    n_walkers += n_walkers % 2
    pilot_steps = min(PILOT_STEPS, n_steps) if pilot_steps is None else int(pilot_steps)
    # (the ball has the noise scales' coordinates too; the same draws whether or not they
    # are integrated out)
    p0 = _initial_ball(problem, lsq, n_walkers, rng, np.vstack([logpost.bounds[:P], NOISE_BOUNDS]))
    start = logpost.to_sampler(p0[:, :ndim])
    random_state = np.random.RandomState(seed).get_state()
    pilot = _pilot(logpost, start, pilot_steps, max_pilot_rounds, random_state, rng, progress)
    start, random_state, pilot_rounds = pilot["start"], pilot["random_state"], pilot["rounds"]
    adapted = moves is None and pilot["draws"] is not None
    free = []  # the coordinates the prior-coordinate move draws (names)
    if adapted:
        moves, free = _production_moves(pilot, names, rng, logit)
        # independent chains: few and long (R-hat needs each chain long, not many of them)
        start = start[: min(n_chains, n_walkers)]
    elif moves is None:
        moves = default_moves()
    sampler = emcee.EnsembleSampler(len(start), ndim, logpost, vectorize=True, moves=moves)
    sampler.log_prob_fn = logpost
    sampler.random_state = random_state
    n_walkers = len(start)
    max_steps = max(n_steps, max_steps or n_steps)
    # (diagnostics of the internal parameters, not of the sampler's logit coordinates)
    tau, given_up = _run_until_converged(
        sampler,
        start,
        n_steps,
        max_steps,
        check_every,
        names,
        progress,
        to_internal=logpost.to_internal,
        extend_to=extend_steps,
    )
    n_steps = sampler.iteration

    tau_min, tau_max = _tau_range(tau, n_steps)
    burn = _burn(tau, n_steps)
    thin = max(1, int(np.floor(tau_min / 2)))
    post_burn = logpost.to_internal(sampler.get_chain(discard=burn))  # (draws, walkers, ndim)
    samples = post_burn[::thin]

    flat = samples.reshape(-1, ndim)
    # PSIS-LOO needs the pointwise log-likelihood: evaluate it on at most max_loo_draws draws
    step = max(1, int(np.ceil(flat.shape[0] / max_loo_draws)))
    loo_draws = samples[::step] if samples.shape[0] >= 2 * step else samples
    # the noise scales of those draws: sampled with them, or drawn given them when the
    # sampler had them integrated out (the same joint posterior)
    loo_full = loo_draws if logpost.noise is None else logpost.with_noise(loo_draws, rng)
    with recorded_warnings() as caught:
        diag = chain_diagnostics(post_burn, names)
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
            "pilot_steps": pilot_steps,
            "pilot_rounds": pilot_rounds,
            "max_steps": max_steps,
            "extend_steps": extend_steps,
            "steps_needed": given_up,
        }
    )
    diag["converged"] = is_converged(diag["steps_over_tau"], diag["rhat"], diag["ess_bulk"])
    point = _map_point(sampler, logpost, burn, post_burn)[:P]
    intervals, stderr, corr = _summaries(problem, flat[:, :P])
    info = _mcmc_info(problem, seed, n_steps, n_walkers, pilot_steps, adapted, free, logit)
    info["point_estimate"] += " of the parameters' marginal posterior" if marginal_noise else ""
    info["noise"] = (
        "integrated out while sampling (Gauss-Legendre in log sigma), drawn given each "
        "draw used for PSIS-LOO"
        if marginal_noise
        else "sampled"
    )
    n_loo, n_chains_loo = loo_draws.shape[:2]
    return posterior_result(
        problem,
        "mcmc",
        point=point,
        samples=samples[..., :P],
        intervals=intervals,
        stderr=stderr,
        correlations=corr,
        # (every draw's when the sampler carried them; the LOO draws' when they were
        # integrated out)
        noise_draws=(samples if logpost.noise is None else loo_full)[..., P:],
        loo_draws=loo_full[..., :P],
        loo_noise=loo_full[..., P:],
        diagnostics=diag,
        info=info,
        sampler_warnings=_chain_warnings(diag, given_up, tau_max),
        point_warnings=_median_warnings(problem, point, flat[:, :P]),
        caught=caught,
        sampled_noise=logpost.noise is None,
        loo_description=(
            f"{n_loo} draws of each of {n_chains_loo} chains: every {step} of the "
            f"{samples.shape[0]} kept after a burn-in of {burn} steps and thinning by {thin}"
        ),
    )


def _production_moves(pilot: dict, names: list, rng, logit: bool) -> tuple[list, list]:
    """The production moves adapted to the pilot's draws, and the coordinates the
    prior-coordinate move draws (by name)."""
    draws = pilot["draws"]
    moves = production_moves(draws, _pooled(pilot["pool"], draws), rng, logit=logit)
    free = [
        names[j]
        for move, _ in moves
        if isinstance(getattr(move, "get_proposal", None), PriorCoordinateProposal)
        for j in move.get_proposal.columns
    ]
    return moves, free


def _mcmc_info(problem, seed, n_steps, n_walkers, pilot_steps, adapted, free, logit) -> dict:
    """The run's record (``PosteriorResult.info``) but for how the noise was handled."""
    return {
        "seed": seed,
        "n_steps": n_steps,
        "n_walkers": n_walkers,
        "start": "least squares",
        "pilot_steps": pilot_steps,
        "moves": _moves_text(adapted, pilot_steps),
        "coordinates": "logit of the prior box" if logit else "internal",
        "drawn_from_prior": free,
        "point_estimate": "highest-posterior draw (MAP)",
        "noise_priors": noise_priors_text(),
        "noise": None,
        "fixed": dict(problem.fixed),
    }


def _map_point(sampler, logpost, burn: int, post_burn: np.ndarray) -> np.ndarray:
    """The kept draw of highest posterior density (MAP), internal coordinates.

    Not the per-parameter median: that can combine different modes of a multimodal
    posterior into a point that fits none.
    """
    log_prob = sampler.get_log_prob(discard=burn)
    if logpost.box is not None:  # the posterior density of the internal vector, not of z
        log_prob = log_prob - logpost.box.log_jacobian(sampler.get_chain(discard=burn))
    return post_burn.reshape(-1, post_burn.shape[-1])[int(np.argmax(log_prob.reshape(-1)))]


def _moves_text(adapted: bool, pilot_steps: int) -> str:
    """The sampler's moves, in words (``info["moves"]``)."""
    if adapted:
        return (
            "pilot (discarded): DE 0.8 + DE snooker 0.2, then the production moves adapted "
            "to it; production: independent chains, kernel-density independence 0.4 (the "
            "adapted rounds' draws, defensive t) + differential evolution on those draws 0.4 "
            "+ random walk 0.2 (the last round's covariance); where the pilot leaves "
            "coordinates free, a draw of one of them from its prior 0.2, the others x 0.8"
        )
    return "given" if pilot_steps > 0 else "DE 0.8 + DE snooker 0.2 (no pilot)"


def _summaries(problem, flat):
    """Intervals, standard errors and correlations of equal-weight internal draws ``(n, P)``."""
    P = problem.ndim
    nat = problem.to_natural(flat)
    intervals = {}
    for i, s in enumerate(problem.specs):
        q = np.percentile(nat[:, i], list(PERCENTS))
        intervals[s.name] = dict(zip(QUANTILES, map(float, q)))
    stderr = {s.name: float(np.std(nat[:, i])) for i, s in enumerate(problem.specs)}
    corr = pd.DataFrame(
        np.corrcoef(flat, rowvar=False).reshape(P, P),
        index=problem.names,
        columns=problem.names,
    )
    return intervals, stderr, corr


def _chain_warnings(diag, given_up, tau_max) -> list[str]:
    """What keeps the chain from converging (:func:`is_converged`) and an acceptance
    outside 0.1-0.9, one warning each."""
    n_steps, max_steps = diag["n_steps"], diag["max_steps"]
    warns = []
    if given_up:
        warns.append(
            f"stopped at {n_steps} steps: at its autocorrelation time (max tau {tau_max:.0f}) "
            f"the chain needs ~{given_up} steps to converge, more than max_steps {max_steps}"
        )
    elif diag["steps_over_tau"] < MIN_STEPS_OVER_TAU:
        warns.append(
            f"chain of {n_steps} steps is shorter than {MIN_STEPS_OVER_TAU} autocorrelation "
            f"times (max tau {tau_max:.0f}); run more --steps"
        )
    if max(diag["rhat"].values()) >= RHAT_MAX:
        worst = max(diag["rhat"], key=diag["rhat"].get)
        warns.append(f"R-hat {diag['rhat'][worst]:.3f} for {worst} (>= {RHAT_MAX})")
    if min(diag["ess_bulk"].values()) < MIN_ESS:
        worst = min(diag["ess_bulk"], key=diag["ess_bulk"].get)
        warns.append(f"bulk ESS {diag['ess_bulk'][worst]:.0f} for {worst} (< {MIN_ESS})")
    if not 0.1 <= diag["acceptance_mean"] <= 0.9:
        warns.append(f"mean acceptance fraction {diag['acceptance_mean']:.2f} outside 0.1-0.9")
    return warns


def _median_warnings(problem, point, flat) -> list[str]:
    """A posterior whose per-parameter medians (of the draws ``(n, P)``) fit far worse than
    the point estimate: multimodal or strongly skewed, so the medians are no estimate."""
    P = problem.ndim
    chi2_point = float(np.sum(problem.weighted_residuals(point) ** 2))
    median = np.median(flat, axis=0)
    chi2_median = float(np.sum(problem.weighted_residuals(median) ** 2))
    if chi2_median > chi2_point + 2 * P + 10:
        return [
            f"posterior is multimodal or strongly skewed: the per-parameter medians fit far worse "
            f"(chi2 {chi2_median:.0f}) than the best draw (chi2 {chi2_point:.0f}); values are the best draw"
        ]
    return []
