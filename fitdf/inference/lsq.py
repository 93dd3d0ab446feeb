"""Least squares: a batched quasi-random screen of the parameter box, then lmfit polishes.

The answer must not depend on luck: ``n_screen`` Sobol points (plus the declared
starting guess) are evaluated in *one* batched call, the ``n_starts`` best are polished
with lmfit's trust-region least squares, and the result reports which start won and how
many polished starts agree with it (chi-square within 1 of the best). The polishes that
ended within :data:`RESTART_WINDOW` of the best are restarted where they stopped while
that still lowers chi-square (:func:`_polish_further`): in the flat valleys of these
problems the trust region shrinks on the exact chain's noise and scipy stops on its step
tolerance short of the floor (B.1 proportional_width: 423.3 where 24 starts find 419.6).
The starts are polished in turn, and one that comes within :data:`MERGE_CHI2` and
:data:`MERGE_SIGMAS` of an optimum an earlier start reached stops there (it counts as
agreeing with it): most starts of these problems end in the same basin, and its floor is
crawled along once instead of ``n_starts`` times.
"""

from __future__ import annotations

import functools
import warnings

import lmfit
import numpy as np
import pandas as pd
from scipy.stats import qmc

from fitdf.inference.caveats import bound_warnings, identifiability_warnings
from fitdf.inference.metrics import information_criteria, residual_metrics
from fitdf.inference.problem import FitProblem
from fitdf.inference.results import FitResult, residual_table

__all__ = ["fit_lsq"]

_Z95 = 1.959963984540054
_SQRT_EPS = float(np.sqrt(np.finfo(float).eps))  # scipy's fallback relative step (2-point)
#: Relative finite-difference step of the polish's Jacobian (:func:`_batched_jacobian`;
#: scipy's ``rel_step`` rule: ``DIFF_STEP |x|`` in the internal coordinate). The exact
#: chain is a discretised steady state: its DF moves in steps of ~1e-6 as table nodes
#: shift with the parameters, so differences over scipy's default ~1e-8 step measure that
#: jitter, not the slope; 1e-4 is far above it and far below any curvature that matters.
DIFF_STEP = 1e-4


def _screen(problem: FitProblem, rng, n_screen: int, n_starts: int):
    lo, hi = problem.internal_bounds().T
    sob = qmc.Sobol(problem.ndim, scramble=True, seed=rng).random(n_screen)
    points = np.vstack([problem.start_internal(), lo + sob * (hi - lo)])
    with np.errstate(all="ignore"):
        cost = np.sum(problem.objective_residuals(points) ** 2, axis=-1)
    cost = np.where(np.isfinite(cost), cost, np.inf)
    return points[np.argsort(cost, kind="stable")[:n_starts]]


#: A polish that scipy stops on its step tolerance in a long, flat valley (the law's scale
#: against the winding resistance, at one source impedance) has often not reached the
#: valley's floor: its trust region shrank on the exact chain's discretisation noise. The
#: starts that ended within this chi-square of the best are started again from where they
#: stopped (the others only tell which basins there are) ...
RESTART_WINDOW = 10.0
#: ... while that lowers chi-square by more than this (a tenth of a unit: far below what
#: moves AICc or a ranking) ...
RESTART_GAIN = 0.1
#: ... at most this many times, within the start's ``max_nfev``.
MAX_RESTARTS = 5


#: A polish whose chi-square comes within this much above an optimum an earlier start
#: already reached (and no lower) ...
MERGE_CHI2 = 1.0
#: ... at most this many standard deviations of that optimum away (its least-squares
#: covariance; 1 % of the box's width per parameter where that is singular), stops there:
#: it is in that basin, and the rest of its way (the slow crawl along the valley's floor)
#: would be spent again on the same optimum (Jiles-Atherton on Permalloy: five of six
#: starts end within 1e-3 of each other's chi-square, and the merged starts take half the
#: evaluations).
MERGE_SIGMAS = 3.0


def _polish(problem: FitProblem, start, max_nfev: int, known=()):
    """One trust-region least-squares run from ``start``: ``(out, x, chi2)``.

    The Jacobian is :func:`_batched_jacobian` (the ``P`` shifted vectors in one batched
    call); ``max_nfev`` counts every model evaluation, the Jacobian's included
    (``out.nfev``). ``known`` holds the :class:`_Basin` of optima found by earlier
    starts: the run stops as soon as it is within :data:`MERGE_CHI2` and
    :data:`MERGE_SIGMAS` of one of them (``out.merged`` is then True)."""
    lo, hi = problem.internal_bounds().T
    width = np.where(hi > lo, hi - lo, 1.0)

    params = lmfit.Parameters()
    for i, v in enumerate(start):
        params.add(f"p{i}", value=float(np.clip(v, lo[i], hi[i])), min=lo[i], max=hi[i])

    def vector(p):
        return np.array([p[f"p{i}"].value for i in range(problem.ndim)])

    evaluations = [0]
    last = {}  # residuals and prediction of the last trial point, which the Jacobian reuses

    def residual(p):
        x = vector(p)
        predicted = problem.predict(x)
        r = _finite(problem.objective_residuals_from(x, predicted))
        evaluations[0] += 1
        last.clear()
        last[x.tobytes()] = (r, predicted)
        return r

    def jacobian(p):
        x = vector(p)
        jac, n = _batched_jacobian(problem, x, last.get(x.tobytes()), lo, hi)
        evaluations[0] += n
        return jac

    def near(x, basin):
        if basin.covariance is not None:
            d = x - basin.x
            try:
                return float(d @ np.linalg.solve(basin.covariance, d)) <= MERGE_SIGMAS**2
            except np.linalg.LinAlgError:  # numerically singular: the box's width instead
                pass
        return np.max(np.abs(x - basin.x) / width) <= 0.01

    merged, spent = [], []

    def stop(p, _iteration, resid, *args, **kws):
        if evaluations[0] >= max_nfev:
            spent.append(True)
            return True
        if not known:
            return False
        x, cost = vector(p), float(np.sum(resid**2))
        # (the chi-square first: a basin's covariance is computed only once a start is
        # within MERGE_CHI2 of its optimum)
        if any(b.cost <= cost <= b.cost + MERGE_CHI2 and near(x, b) for b in known):
            merged.append(True)
        return bool(merged)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # lmfit/scipy numerical chatter; outcome is checked below
        minimizer = lmfit.Minimizer(
            residual,
            params,
            iter_cb=stop,
            # the budget is kept by ``stop`` (lmfit would not count the Jacobian's points)
            max_nfev=10 * max_nfev + 10,
            jac=jacobian,
        )
        try:
            out = minimizer.minimize(method="least_squares")
        except lmfit.minimizer.AbortFitException:
            # lmfit (1.3.4) evaluates scipy's answer once more, through ``stop``, outside
            # its own handler: a stop asked for there (the budget just spent, or the answer
            # in a known basin) ends the polish at that answer, as one asked for during it
            out = minimizer.result
    out.merged = bool(merged) and not spent
    if spent:
        out.message = f"Fit aborted: number of model evaluations >= {max_nfev}"
    x = vector(out.params)
    cost = float(np.sum(residual(out.params) ** 2))
    out.nfev = evaluations[0] - 1  # (not the re-evaluation just above)
    return out, x, cost


def _finite(r):
    """Non-finite residuals (a failed evaluation) as a large finite value, which the trust
    region steps back from."""
    return np.where(np.isfinite(r), r, 1e6)


def _batched_jacobian(problem: FitProblem, x, at_x, lo, hi):
    """Forward-difference Jacobian of the objective residuals at ``x``, all ``P`` shifted
    vectors (and ``x`` itself unless ``at_x``, its ``(residuals, prediction)``, is given)
    in one batched call: ``(J, evaluations)``.

    The steps are scipy's for ``least_squares(..., diff_step=DIFF_STEP)`` (``2-point``):
    ``DIFF_STEP |x_i|`` (``sqrt(eps) max(1, |x_i|)`` where that rounds to nothing), taken
    backward where the forward step leaves the box, so the polish takes the path it took
    with scipy's own differences (the same optima to ~1e-8 on the cases benchmarked).
    The difference: scipy evaluates the ``P`` points one by one; one batched call costs
    less (Permalloy, 73 rows, per vector: cubic_hc 1.3 against 2.2 ms, constant_width 1.1
    against 1.8 ms, Preisach 6.4 against 7.9 ms). And the points that move only a
    calibration gain (:attr:`FitProblem.output_scale_indices`) are the prediction at ``x``
    rescaled, not solved again: one or two chain solves fewer per Jacobian, the same
    differences to rounding.
    """
    P = x.size
    sign = np.where(x >= 0, 1.0, -1.0)
    h = DIFF_STEP * sign * np.abs(x)
    h = np.where((x + h) - x == 0, _SQRT_EPS * sign * np.maximum(1.0, np.abs(x)), h)
    h = np.where((x + h < lo) | (x + h > hi), -h, h)
    shifted = x + np.diag(h)
    dx = np.diagonal(shifted) - x  # the step as represented
    rescale = np.zeros(P, bool)
    rescale[problem.output_scale_indices] = True
    solve = shifted[~rescale]
    batch = solve if at_x is not None else np.vstack([x[None], solve])
    with np.errstate(all="ignore"):
        M = problem.predict(batch)
        if at_x is None:
            r0, m0, M = _finite(problem.objective_residuals_from(x, M[0])), M[0], M[1:]
        else:
            r0, m0 = at_x
        R = np.empty((P, r0.size))
        R[~rescale] = _finite(problem.objective_residuals_from(solve, M))
        if rescale.any():
            moved = shifted[rescale]
            R[rescale] = _finite(
                problem.objective_residuals_from(moved, problem.rescaled(m0, x, moved))
            )
    return ((R - r0) / dx[:, None]).T, len(batch)


def _polish_further(problem: FitProblem, polished, max_nfev: int):
    """Restart a polish ``(out, x, chi2)`` where it stopped while that still pays
    (:data:`RESTART_GAIN`); ``out.nfev`` then counts every restart."""
    out, x, cost = polished
    used = out.nfev
    for _ in range(MAX_RESTARTS):
        if used >= max_nfev:
            break
        again, x_again, cost_again = _polish(problem, x, max_nfev - used)
        used += again.nfev
        if not cost_again < cost:
            break
        gain = cost - cost_again
        out, x, cost = again, x_again, cost_again
        if gain <= RESTART_GAIN:
            break
    out.nfev = used
    return out, x, cost


#: Step of the central differences of the covariance's Jacobian (internal units: decades for
#: log parameters, relative for the others). 10x DIFF_STEP: a Jacobian is only as good as
#: the DF's jitter (~1e-6..1e-5 in the exact chain) over the step, and lmfit's, at the
#: optimiser's forward step, made intervals up to 2x too narrow (a recovery test).
COV_STEP = 1e-3


def covariance(problem: FitProblem, x):
    """Covariance of the internal parameters at the optimum ``x``: ``(J'J)^-1 chi2/(m - P)``.

    ``J`` by central differences (:data:`COV_STEP`, one-sided at a bound), all ``2P``
    evaluations in one batched call; scaled by the reduced chi-square like lmfit's
    ``scale_covar``. None if ``J'J`` is singular or the chi-square not finite.
    """
    lo, hi = problem.internal_bounds().T
    P = problem.ndim
    h = COV_STEP * np.where([s.log for s in problem.specs], 1.0, np.maximum(np.abs(x), 1.0))
    up, down = np.minimum(x + h, hi), np.maximum(x - h, lo)
    X = np.repeat(x[None], 2 * P, axis=0)
    X[np.arange(P), np.arange(P)] = up
    X[P + np.arange(P), np.arange(P)] = down
    with np.errstate(all="ignore"):
        R = problem.objective_residuals(X)
        r0 = problem.objective_residuals(x)
    J = ((R[:P] - R[P:]) / (up - down)[:, None]).T
    m = r0.size
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(r0))) or m <= P:
        return None
    try:
        inv = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(inv)):
        return None
    return inv * float(np.sum(r0**2)) / (m - P)


def _uncertainties(problem: FitProblem, x, covar):
    names = problem.names
    stderr, intervals = {}, {}
    sig = (
        np.sqrt(np.clip(np.diag(covar), 0, None)) if covar is not None else np.full(len(x), np.nan)
    )
    for i, s in enumerate(problem.specs):
        value = float(s.from_internal(x[i]))
        stderr[s.name] = float(np.log(10) * value * sig[i]) if s.log else float(sig[i])
        # Gaussian in the internal coordinate, cut at the declared bounds (a parameter pinned
        # on a bound has a meaningless covariance; its interval is then the bound-limited one).
        lo, hi = s.internal_bounds
        q = {
            "p2.5": x[i] - _Z95 * sig[i],
            "p16": x[i] - sig[i],
            "p50": x[i],
            "p84": x[i] + sig[i],
            "p97.5": x[i] + _Z95 * sig[i],
        }
        intervals[s.name] = {k: float(s.from_internal(np.clip(v, lo, hi))) for k, v in q.items()}
    if covar is not None:
        d = np.where(sig > 0, sig, np.nan)
        corr = covar / np.outer(d, d)
    else:
        corr = np.full((len(x), len(x)), np.nan)
    return stderr, intervals, pd.DataFrame(corr, index=names, columns=names)


def fit_lsq(
    problem: FitProblem,
    seed: int = 0,
    n_starts: int = 6,
    n_screen: int = 256,
    max_nfev: int = 400,
    starts=None,
    also_screen: int = 0,
    uncertainties: bool = True,
) -> FitResult:
    """Least-squares fit of ``problem`` (see the module docstring for the strategy).

    With a fitted noise law (``problem.noise_law``, :mod:`fitdf.inference.noise_models`)
    the law's parameters and the noise parameters are fitted together by maximum
    likelihood (:func:`_fit_with_noise`); otherwise the fixed scales weigh the residuals.

    ``n_starts`` screened starts are polished, times the law's ``start_multiple``
    (:class:`~fitdf.models.base.HysteresisModel`: more for a law whose chi-square has kinks).

    ``starts`` (internal vectors, ``(k, P)``), if given, are polished instead of screening
    the box: a warm start, e.g. a cross-validation fold from the full data's optimum.
    With ``starts``, ``also_screen`` more starts come from the screen (a warm start that
    still looks elsewhere in the box). ``uncertainties=False`` skips the covariance (its
    ``2 P + 1`` evaluations): for a fit only its optimum is read from, such as a
    cross-validation fold; the optimum is the same.

    Returns
    -------
    FitResult
        ``info`` holds ``starts_chi2`` (cost of every polished start), ``starts_merged``
        (which stopped in a basin an earlier start had reached), ``best_start``,
        ``n_agree``, ``nfev_total`` and the settings.
    """
    kw = dict(n_starts=n_starts, n_screen=n_screen, max_nfev=max_nfev, also_screen=also_screen)
    if problem.noise_law is not None:
        return _fit_with_noise(problem, seed, starts, uncertainties, kw)
    return _fit_fixed(problem, seed, starts=starts, uncertainties=uncertainties, **kw)


def _fit_fixed(
    problem: FitProblem,
    seed: int = 0,
    n_starts: int = 6,
    n_screen: int = 256,
    max_nfev: int = 400,
    starts=None,
    also_screen: int = 0,
    uncertainties: bool = True,
) -> FitResult:
    """:func:`fit_lsq` at the fixed scales of ``problem`` (its row scales where set)."""
    starts, n_screen = _starts(problem, seed, n_starts, n_screen, starts, also_screen)
    polished = _polish_starts(problem, starts, max_nfev)
    costs = np.array([cost for *_, cost in polished])
    best = int(np.argmin(costs))
    out, x, _ = polished[best]
    n_agree = int(np.sum(costs - costs[best] <= 1.0))

    covar = covariance(problem, x) if uncertainties else None
    stderr, intervals, corr = _uncertainties(problem, x, covar)
    values = {k: float(v) for k, v in problem.full_natural(x).items()}
    predicted = problem.predict(x)
    wres = problem.weighted_residuals(x)
    metrics = {
        "n_points": problem.data.n,
        "n_params": problem.ndim,
        **residual_metrics(predicted, problem.data.measured),
        **information_criteria(wres, problem.ndim),
    }
    no_covar = covar is None and uncertainties
    warns = _fit_warnings(problem, x, intervals, no_covar, out, n_agree, len(starts))
    info = {
        "seed": seed,
        "n_screen": n_screen,
        "n_starts": len(starts),
        "starts_chi2": costs.tolist(),
        "starts_merged": [bool(o.merged) for o, *_ in polished],
        "nfev_total": int(sum(o.nfev for o, *_ in polished)),
        "best_start": best,
        "n_agree": n_agree,
        "nfev": int(out.nfev),
        "success": bool(out.success),
        "noise": problem.noise.to_dict(),
        "fixed": dict(problem.fixed),
        "covar_internal": None if covar is None else np.asarray(covar).tolist(),
    }
    return FitResult(
        model=problem.model.name,
        chain=problem.chain.name,
        method="lsq",
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
        internal=x,
    )


def _starts(problem, seed, n_starts, n_screen, starts, also_screen):
    """The internal vectors :func:`fit_lsq` polishes, and the screen's size (0 when none
    was screened)."""
    if starts is None:
        n_starts = n_starts * problem.model.start_multiple
        return _screen(problem, np.random.default_rng(seed), n_screen, n_starts), n_screen
    starts = np.atleast_2d(np.asarray(starts, float))
    if also_screen <= 0:
        return starts, 0
    screened = _screen(problem, np.random.default_rng(seed), n_screen, also_screen)
    return np.vstack([starts, screened]), n_screen


class _Basin:
    """An optimum a start reached: its internal point ``x``, its ``cost`` (chi-square) and,
    computed on first use (most basins are never approached again within
    :data:`MERGE_CHI2`), its :func:`covariance`."""

    def __init__(self, problem: FitProblem, x, cost: float):
        self.problem, self.x, self.cost = problem, x, cost

    @functools.cached_property
    def covariance(self):
        return covariance(self.problem, self.x)


def _polish_starts(problem, starts, max_nfev) -> list:
    """Each start polished (:func:`_polish`, merging into the basins found before), then the
    ones near the best cost polished further: ``(out, x, cost)`` per start."""
    polished, known = [], []
    for s in starts:
        polished.append(_polish(problem, s, max_nfev, known))
        out, x, cost = polished[-1]
        if not out.merged:
            known.append(_Basin(problem, x, cost))
    floor = min(cost for *_, cost in polished)
    # (a start stopped in a known basin is not restarted: that basin's own start is)
    return [
        _polish_further(problem, p, max_nfev)
        if p[2] <= floor + RESTART_WINDOW and not p[0].merged
        else p
        for p in polished
    ]


def _fit_warnings(problem, x, intervals, no_covar, out, n_agree, n_starts) -> list[str]:
    """What :func:`fit_lsq` warns of at the optimum ``x``: bounds, identifiability, the
    law's limits, a missing covariance, no convergence, a lone winning start."""
    warns = (
        bound_warnings(problem, x)
        + identifiability_warnings(problem, intervals)
        + problem.limit_warnings(x)
    )
    if no_covar:
        warns.append("covariance matrix not available (singular Jacobian): uncertainties are NaN")
    if not out.success:
        warns.append(f"least squares did not converge: {out.message}")
    if n_agree < 2 and n_starts > 1:
        warns.append(f"only the winning start reached the best chi-square (of {n_starts} starts)")
    return warns


#: Rounds of the noise fit's alternation (:func:`_fit_with_noise`) at most ...
NOISE_ROUNDS = 10
#: ... stopping when a round raises the penalised log-likelihood by less than this (a
#: hundredth of a unit: far below what moves AICc).
NOISE_TOLERANCE = 0.01


def _fit_with_noise(problem: FitProblem, seed, starts, uncertainties, kw) -> FitResult:
    """Maximum likelihood of the law's and the noise law's parameters together.

    The multi-start search runs at the fixed printed scales (or polishes ``starts``); then
    rounds alternate the noise parameters' maximum likelihood at fixed residuals with a
    weighted least-squares polish at fixed row scales (Student-t: the EM weights), each an
    ascent of the likelihood penalised by the priors, until a round gains less than
    :data:`NOISE_TOLERANCE`. ``metrics`` then hold ``log_likelihood`` and AICc and BIC of it
    with the noise parameters counted (``n_noise_params``); ``info["noise_law"]`` the
    fitted noise parameters.
    """
    law = problem.noise_law
    ctx = law.context(problem.data)
    result = _fit_fixed(problem, seed, starts=starts, uncertainties=False, **kw)
    x, theta, objective, rounds = result.internal, None, -np.inf, 0
    while True:
        radial, tang = problem.error_components(problem.predict(x))
        theta, loglike = law.fit(radial, tang, ctx, theta)
        penalised = loglike - 0.5 * float(np.sum(problem.prior_residuals(x) ** 2))
        if rounds >= NOISE_ROUNDS or penalised - objective < NOISE_TOLERANCE:
            break
        objective, rounds = penalised, rounds + 1
        weighted = problem.with_row_scales(*law.weights_scales(theta, radial, tang, ctx))
        step = _fit_fixed(weighted, seed, starts=x, uncertainties=False, max_nfev=kw["max_nfev"])
        x = step.internal
    # the covariance and the metrics at the last round's row scales (a polish from ``x``
    # there moves it by the tolerance at most), the noise parameters refitted at its optimum
    final = problem.with_row_scales(*law.weights_scales(theta, radial, tang, ctx))
    result = _fit_fixed(final, seed, starts=x, uncertainties=uncertainties, max_nfev=kw["max_nfev"])
    radial, tang = problem.error_components(problem.predict(result.internal))
    theta, loglike = law.fit(radial, tang, ctx, theta)
    n = law.n_terms(ctx)
    result.metrics.update(law.criteria(loglike, problem.ndim, ctx))
    result.info["noise_law"] = {
        "name": law.name,
        "values": law.natural(theta),
        "log10": [float(v) for v in theta],
        "rounds": rounds,
        "n_terms": n,
    }
    result.warnings.extend(
        f"noise parameter {name} is on a bound of its prior's box: the rows do not determine it"
        for name in law.on_bound(theta)
    )
    return result
