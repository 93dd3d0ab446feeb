"""MCMC: reproducibility, diagnostics, vectorised log-probability, posterior recovery."""

import numpy as np
import pytest
from synthetic import MCMC_TRUTH as TRUE
from synthetic import mcmc_problem, synthetic_frame

from fitdf.inference.api import resolve_data
from fitdf.inference.caveats import posterior_bound_warnings
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.mcmc import LogPosterior, fit_mcmc
from fitdf.inference.problem import FitProblem


@pytest.fixture(scope="module")
def problem():
    return mcmc_problem()


@pytest.fixture(scope="module")
def lsq(problem):
    return fit_lsq(problem, seed=0)


def test_log_posterior_is_vectorised_and_bounded(problem, lsq):
    lp = LogPosterior(problem)
    X = np.tile(np.concatenate([lsq.internal, [-2.0, 0.0]]), (6, 1))
    X[1, 0] = lp.bounds[0, 1] + 1.0  # outside the prior box
    X[2:, 2] += np.linspace(-0.01, 0.01, 4)
    batch = lp(X)
    looped = np.array([lp(x[None])[0] for x in X])
    np.testing.assert_allclose(batch, looped, rtol=1e-12)
    assert batch[1] == -np.inf and np.all(np.isfinite(batch[[0, 2, 3, 4, 5]]))


def test_chain_is_reproducible_with_a_seed(problem, lsq):
    # short, but through every random part: the ball, the pilot's adapted rounds (kernel
    # centres drawn), production and the noise scales drawn for PSIS-LOO
    kw = dict(n_steps=40, n_walkers=16, pilot_steps=30, max_pilot_rounds=2)
    a = fit_mcmc(problem, lsq, seed=4, **kw)
    b = fit_mcmc(problem, lsq, seed=4, **kw)
    np.testing.assert_array_equal(a.samples, b.samples)
    np.testing.assert_array_equal(a.noise_samples, b.noise_samples)
    assert len(a.diagnostics["pilot_rounds"]) == 3
    c = fit_mcmc(problem, lsq, seed=5, **kw)
    assert not np.array_equal(a.samples, c.samples)


def test_short_chain_reports_diagnostics_and_warns(problem, lsq):
    r = fit_mcmc(problem, lsq, seed=1, n_steps=150, n_walkers=16)
    d = r.diagnostics
    # the noise scales are integrated out: the sampler's coordinates are the parameters
    assert set(d["tau"]) == set(problem.names)
    assert r.noise_samples.shape[-1] == 2 and np.all(r.noise_samples > 0)
    assert 0.05 < d["acceptance_mean"] < 0.95
    assert d["steps_over_tau"] < 50 and not d["converged"]
    assert any("shorter than 50 autocorrelation times" in w for w in r.warnings)
    assert np.isfinite(r.metrics["looic"]) and np.isfinite(r.metrics["waic"])
    band = r.predictive_band([0.5, 1.0, 2.0], 6.0, 600.0)
    assert band["magnitude"].shape == (5, 3)
    assert np.all(np.diff(band["magnitude"], axis=0) >= 0)  # quantiles ordered


@pytest.mark.slow
def test_posterior_covers_true_parameters_and_converges(problem, lsq):
    r = fit_mcmc(problem, lsq, seed=2, n_steps=2500, n_walkers=32)
    assert r.diagnostics["converged"], r.diagnostics
    for name in problem.names:
        iv = r.intervals[name]
        assert iv["p2.5"] <= TRUE[name] <= iv["p97.5"], (name, iv)
    # the fitted noise scales find the injected noise (0.005 magnitude, 0.5 deg phase, then rounding)
    sm = r.diagnostics["sigma_magnitude_interval"]
    assert 0.003 < sm["p50"] < 0.008
    lsq_sigma = lsq.stderr
    for name in ("k", "m"):  # posterior width agrees with the least-squares error within a factor 2
        assert 0.5 < r.stderr[name] / lsq_sigma[name] < 2.0


def test_sampling_leaves_the_least_squares_problem_cold():
    # MCMC starts the exact chain's solver at the optimum's currents; a root found from
    # another start differs within the solver's tolerance (~1e-5 here), so doing that on
    # the shared problem made the least-squares result's predictions depend on whether a
    # chain had run in the same process (a report's serial and pooled runs differed)
    frame = synthetic_frame("proportional_width", TRUE, chain="winding", seed=3)
    problem = FitProblem(resolve_data(frame, policy="all"), "proportional_width", "voltage")
    lsq = fit_lsq(problem, seed=0, n_starts=1)
    before = problem.predict(lsq.internal)
    post = fit_mcmc(problem, lsq, seed=0, n_steps=4, n_walkers=16)
    np.testing.assert_array_equal(problem.predict(lsq.internal), before)
    assert problem.warm_current is None and post.problem.warm_current is not None
    # the warm copy is the same problem otherwise: same parameters, data and chain
    assert post.problem.names == problem.names and post.problem.chain is problem.chain


def test_shape_change_of_pilot_rounds():
    from fitdf.inference.mcmc import _shape_change

    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(4000, 3)), rng.normal(size=(4000, 3))
    assert _shape_change(a, b) < 0.1  # the same law: settled
    wider = b * np.array([1.0, 3.0, 1.0])
    assert _shape_change(a, wider) == pytest.approx(np.log(3.0), abs=0.1)  # still spreading
    shifted = b + np.array([0.0, 0.0, 1.0])
    assert _shape_change(a, shifted) == pytest.approx(1.0, abs=0.1)  # still moving


@pytest.mark.slow  # 18 s; _shape_change, the rule it applies, is tested by default
def test_pilot_rounds_stop_once_settled(problem, lsq):
    # a near-Gaussian posterior: two adapted rounds after differential evolution settle it
    r = fit_mcmc(problem, lsq, seed=3, n_steps=200, n_walkers=16)
    rounds = r.diagnostics["pilot_rounds"]
    assert 3 <= len(rounds) <= 7  # differential evolution, then at least two adapted rounds
    last = rounds[-1]
    if len(rounds) < 7:  # stopped early: because the last round had settled
        assert last["shape_change"] <= 0.25 and last["acceptance"] >= 0.15
    assert all(x["shape_change"] > 0.25 or x["acceptance"] < 0.15 for x in rounds[2:-1])
    # with one round allowed, the pilot is differential evolution + one adapted round
    one = fit_mcmc(problem, lsq, seed=3, n_steps=200, n_walkers=16, max_pilot_rounds=1)
    assert len(one.diagnostics["pilot_rounds"]) == 2


def test_box_coordinates_round_trip_and_jacobian():
    from fitdf.inference.mcmc import BoxCoordinates

    bounds = np.array([[-3.0, 0.0], [1e-3, 2.0], [10.0, 10.5]])
    box = BoxCoordinates(bounds)
    rng = np.random.default_rng(0)
    x = bounds[:, 0] + rng.uniform(0.001, 0.999, (50, 3)) * (bounds[:, 1] - bounds[:, 0])
    z = box.from_box(x)
    np.testing.assert_allclose(box.to_box(z), x, rtol=1e-12, atol=1e-12)
    # log |dx/dz| against central differences, coordinate by coordinate (diagonal map)
    h = 1e-6
    numeric = np.zeros(len(z))
    for j in range(3):
        dz = np.zeros(3)
        dz[j] = h
        numeric += np.log((box.to_box(z + dz)[:, j] - box.to_box(z - dz)[:, j]) / (2 * h))
    np.testing.assert_allclose(box.log_jacobian(z), numeric, rtol=1e-6, atol=1e-8)
    assert np.all(np.isfinite(box.to_box(np.array([[-800.0, 800.0, 0.0]]))))


def test_logit_posterior_is_the_box_posterior_times_the_jacobian(problem, lsq):
    plain, logit = LogPosterior(problem), LogPosterior(problem, logit=True)
    X = np.tile(np.concatenate([lsq.internal, [-2.0, 0.0]]), (4, 1))
    X[:, 2] += np.linspace(-0.01, 0.01, 4)
    Z = logit.to_sampler(X)
    np.testing.assert_allclose(logit.to_internal(Z), X, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(logit(Z), plain(X) + logit.box.log_jacobian(Z), rtol=1e-12)


def test_sampling_in_logit_coordinates_keeps_the_posterior(problem, lsq, monkeypatch):
    """A known posterior: half a Gaussian piled against the lower bound of the first
    parameter, every other parameter (and both noise scales) flat in its box. The draws,
    mapped back from the sampler's logit coordinates, must have those marginals; a wrong
    or missing Jacobian would push the flat ones into logistic shapes."""
    from fitdf.inference.mcmc import NOISE_BOUNDS

    lo, hi = problem.internal_bounds().T
    sd = 0.05 * (hi[0] - lo[0])

    def known(self, internal, sigma_magnitude=None, sigma_phase_deg=None):
        internal = np.asarray(internal, float)
        out = np.zeros(internal.shape[:-1] + (self.data.n,))
        out[..., 0] = -0.5 * ((internal[..., 0] - lo[0]) / sd) ** 2
        return out

    monkeypatch.setattr(FitProblem, "pointwise_loglike", known)
    # (the noise scales sampled with the parameters: the known posterior replaces the
    # likelihood they enter)
    r = fit_mcmc(problem, lsq, seed=3, n_steps=1000, max_steps=4000, marginal_noise=False)
    d = r.diagnostics
    assert d["converged"], (d["steps_over_tau"], max(d["rhat"].values()))
    first = r.samples[..., 0].ravel()
    # half-normal from the bound: mean sd sqrt(2/pi), sd sd sqrt(1 - 2/pi); ESS >= 400 -> ~5 %
    assert np.mean(first - lo[0]) == pytest.approx(sd * np.sqrt(2 / np.pi), rel=0.1)
    assert np.std(first) == pytest.approx(sd * np.sqrt(1 - 2 / np.pi), rel=0.1)
    flat = np.concatenate(
        [
            r.samples[..., 1:].reshape(-1, problem.ndim - 1),
            np.log10(r.noise_samples).reshape(-1, 2),
        ],
        axis=1,
    )
    box = np.vstack([np.stack([lo, hi], axis=1)[1:], NOISE_BOUNDS])
    u = (flat - box[:, 0]) / (box[:, 1] - box[:, 0])  # uniform on [0, 1]: mean 1/2, sd 0.289
    np.testing.assert_allclose(u.mean(axis=0), 0.5, atol=0.05)
    np.testing.assert_allclose(u.std(axis=0), np.sqrt(1 / 12), rtol=0.1)
    # 16 % of the half-normal lies within 1 % of the box from the bound; 1 % of a flat one
    (bound,) = [w for w in r.warnings if "runs into" in w]
    assert f"posterior of {problem.names[0]} runs into its lower bound" in bound
    # the flat ones span more than a decade (log) or half their box: the data leave them open
    open_ = {
        w.split("do not determine ")[1].split(":")[0] for w in r.warnings if "do not determine" in w
    }
    assert open_ == set(problem.names[1:]) == {"c", "m", "r_series", "gain"}


def test_posterior_bound_warning_counts_the_draws_at_a_bound(problem):
    lo, hi = problem.internal_bounds().T
    rng = np.random.default_rng(0)
    draws = lo + (hi - lo) * rng.random((20000, problem.ndim))
    assert posterior_bound_warnings(problem, draws) == []  # flat: 1 % near each bound
    # piled at the upper bound: exponential with scale 1 % of the box, 1 - 1/e within it
    draws[:, 1] = hi[1] - 0.01 * (hi[1] - lo[1]) * rng.exponential(size=len(draws))
    (warning,) = posterior_bound_warnings(problem, draws)
    assert f"posterior of {problem.names[1]} runs into its upper bound" in warning
    assert "63 % of the draws" in warning


def test_arviz_shape_notice_stays_off_the_terminal():
    """A chain stopped early and thinned can hand ArviZ fewer draws per walker than its
    shape heuristic expects; its log line (which reached the report's terminal) is dropped
    while fitdf computes diagnostics, and only then. (ArviZ logs a message once per
    process, so its cache is cleared to make each check count.)"""
    import logging
    import warnings

    from fitdf._arviz import arviz
    from fitdf.inference.mcmc import chain_diagnostics

    az = arviz()
    log = az._log
    seen = []
    handler = logging.Handler()
    handler.emit = lambda record: seen.append(record.getMessage())
    log.addHandler(handler)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            log.cache.clear()
            d = chain_diagnostics(np.random.default_rng(0).normal(size=(1, 8, 2)), ["a", "b"])
            assert set(d["rhat"]) == {"a", "b"}
            assert not any("Shape validation" in m for m in seen)
            log.cache.clear()
            az.rhat(az.from_dict(posterior={"a": np.zeros((8, 1))}))  # outside: still logged
    finally:
        log.removeHandler(handler)
    assert any("Shape validation" in m for m in seen)
