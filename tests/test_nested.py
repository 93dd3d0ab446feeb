"""Nested sampling (fitdf/inference/nested.py): the prior map, and evidences known in closed form.

The evidence of a Gaussian likelihood under a uniform or truncated-normal prior on a box is
a product of error functions; nautilus must recover it within the error it states
(:func:`~fitdf.inference.nested.log_evidence_error`), and so the Bayes factor of two nested
models. The default tests run small problems with one network per bound (seconds); the
slow ones repeat them over seeds and fit a real law through the engine.
"""

from __future__ import annotations

from types import SimpleNamespace

import nautilus
import numpy as np
import pytest
from scipy.special import ndtr
from scipy.stats import kstest, norm, truncnorm

import fitdf
from fitdf.errors import OptionError
from fitdf.inference import nested
from fitdf.inference.nested import (
    MAX_LOG_EVIDENCE_ERROR,
    MIN_EFFECTIVE,
    PriorTransform,
    convergence_warnings,
    is_converged,
    kish_size,
    next_effective_target,
    run_nautilus,
    systematic_resample,
    weighted_quantiles,
)
from fitdf.params import ParamSpec

#: A small run: few live points and one network per bound (the likelihoods here are cheap,
#: and the networks' training is what a run costs)
SMALL = {"n_live": 200, "n_networks": 1}


def stub_problem(specs, priors=None):
    """What :class:`PriorTransform` reads of a problem: specs, names, box, Gaussian priors."""
    return SimpleNamespace(
        specs=specs,
        names=[s.name for s in specs],
        internal_bounds=lambda: np.array([s.internal_bounds for s in specs]),
        priors=dict(priors or {}),
    )


SPECS = [
    ParamSpec("a", 0.0, (-1.0, 2.0)),  # uniform
    ParamSpec("k", 1.0, (0.01, 100.0), unit="H", log=True),  # log-uniform: log10 in [-2, 2]
    ParamSpec("r", 50.0, (1.0, 5000.0), unit="ohm", log=True),  # truncated log-normal
]
R_PRIOR = (1.9, 0.2)  # log10 centre, sigma of r


def gaussian_log_evidence(bounds, gaussian, mean, sd):
    """``log`` of the integral of ``prod_i N(x_i; mean_i, sd_i)`` over the prior: uniform on
    ``bounds[i]``, or for ``i`` in ``gaussian`` the normal ``(centre, sigma)`` truncated there.
    """
    out = 0.0
    for i, (lo, hi) in enumerate(bounds):
        m, s = mean[i], sd[i]
        if i in gaussian:
            c, t = gaussian[i]
            v = 1.0 / (1.0 / s**2 + 1.0 / t**2)  # the product's variance and mean
            mu = v * (m / s**2 + c / t**2)
            w = np.sqrt(v)
            out += (
                norm.logpdf(m, c, np.hypot(s, t))
                + np.log(ndtr((hi - mu) / w) - ndtr((lo - mu) / w))
                - np.log(ndtr((hi - c) / t) - ndtr((lo - c) / t))
            )
        else:
            out += np.log(ndtr((hi - m) / s) - ndtr((lo - m) / s)) - np.log(hi - lo)
    return float(out)


def gaussian_loglike(mean, sd):
    mean, sd = np.asarray(mean, float), np.asarray(sd, float)

    def loglike(x):
        return np.sum(norm.logpdf(np.atleast_2d(x), mean, sd), axis=-1)

    return loglike


# ------------------------------------------------------------------------ the prior map
def test_prior_transform_maps_the_cube_to_the_box():
    t = PriorTransform(stub_problem(SPECS, {"r": R_PRIOR}))
    u = np.random.default_rng(0).random((4000, 3))
    x = t(u)
    lo, hi = t.bounds[:, 0], t.bounds[:, 1]
    assert np.all(x >= lo) and np.all(x <= hi)
    assert np.allclose(t(np.zeros((1, 3))), lo) and np.allclose(t(np.ones((1, 3))), hi)
    # uniform columns: the box's quantiles exactly; log10 k uniform, so k log-uniform
    q = np.array([0.1, 0.5, 0.9])
    grid = np.column_stack([q, q, np.full(3, 0.5)])
    assert np.allclose(t(grid)[:, 0], -1.0 + 3.0 * q)
    assert np.allclose(10 ** t(grid)[:, 1], 10 ** (-2.0 + 4.0 * q))
    assert kstest(x[:, 0], "uniform", args=(-1.0, 3.0)).pvalue > 0.01


def test_prior_transform_truncated_normal_quantiles():
    centre, sigma = R_PRIOR
    t = PriorTransform(stub_problem(SPECS, {"r": R_PRIOR}))
    lo, hi = t.bounds[2]
    a, b = (lo - centre) / sigma, (hi - centre) / sigma
    u = np.linspace(0.001, 0.999, 41)
    x = t(np.column_stack([u, u, u]))[:, 2]
    # the map is the inverse distribution function: its CDF gives back the quantile
    assert np.allclose(truncnorm.cdf(x, a, b, loc=centre, scale=sigma), u, atol=1e-10)
    # a box that cuts the normal: the cut tail has no mass, quantiles follow the truncation
    cut = stub_problem([ParamSpec("r", 50.0, (30.0, 5000.0), log=True)], {"r": R_PRIOR})
    tc = PriorTransform(cut)
    xs = tc(np.linspace(0, 1, 101)[:, None])[:, 0]
    assert xs[0] == pytest.approx(np.log10(30.0)) and np.all(np.diff(xs) > 0)
    a_cut = (np.log10(30.0) - centre) / sigma
    median = truncnorm.ppf(0.5, a_cut, np.inf, loc=centre, scale=sigma)
    assert tc(np.array([[0.5]]))[0, 0] == pytest.approx(median, abs=1e-9)
    draws = tc(np.random.default_rng(1).random((4000, 1)))[:, 0]
    assert (
        kstest(draws, truncnorm(a_cut, (hi - centre) / sigma, loc=centre, scale=sigma).cdf).pvalue
        > 0.01
    )


def test_prior_log_density_is_normalised_and_describes_itself():
    t = PriorTransform(stub_problem(SPECS, {"r": R_PRIOR}))
    lo, hi = t.bounds[:, 0], t.bounds[:, 1]
    # the density is a product over columns: integrate each through x0, the cube's centre
    x0 = t(np.full((1, 3), 0.5))
    log_p0 = t.log_density(x0)[0]
    total = 0.0
    for i in range(3):
        g = np.linspace(lo[i], hi[i], 20001)
        x = np.repeat(x0, g.size, axis=0)
        x[:, i] = g
        total += np.log(np.trapezoid(np.exp(t.log_density(x) - log_p0), g))
    assert np.exp(total + log_p0) == pytest.approx(1.0, rel=1e-4)
    assert t.log_density(np.array([[3.0, 0.0, 1.0]]))[0] == -np.inf  # outside the box
    d = t.describe()
    assert d["a"] == {"distribution": "uniform", "bounds": [-1.0, 2.0], "unit": "-"}
    assert d["k"]["distribution"] == "log-uniform" and d["k"]["unit"] == "H"
    assert d["r"]["distribution"] == "log-normal truncated to the bounds"
    assert d["r"]["median"] == pytest.approx(10**1.9) and d["r"]["bounds"] == [1.0, 5000.0]
    assert d["r"]["sigma_ln"] == pytest.approx(0.2 * np.log(10))


# ------------------------------------------------------------------------ helpers
def test_weights_effective_size_quantiles_and_resampling():
    assert kish_size(np.zeros(50)) == pytest.approx(50)
    assert kish_size(np.log([1.0, 0.0 + 1e-300, 1.0])) == pytest.approx(2.0)
    x = np.arange(5.0)
    w = np.array([0.1, 0.2, 0.4, 0.2, 0.1])
    assert weighted_quantiles(x, w, 0.5) == pytest.approx(2.0)
    idx = systematic_resample(w, 1000, np.random.default_rng(0))
    counts = np.bincount(idx, minlength=5)
    assert np.all(np.abs(counts - 1000 * w) < 1)  # systematic: within one draw of n w
    assert is_converged(MIN_EFFECTIVE, MAX_LOG_EVIDENCE_ERROR)
    assert not is_converged(MIN_EFFECTIVE - 1, 0.01) and not is_converged(1e4, 0.31)
    assert not is_converged(1e4, np.nan)


# ------------------------------------------------------------------ the convergence rule's edges
#: Just below 400 effective draws, just above an evidence error of 0.3 (the rule as stated in
#: the documents and the command line's checks: >= 400 draws, error <= 0.3).
BELOW_400 = np.nextafter(400.0, 0.0)
ABOVE_03 = np.nextafter(0.3, 1.0)


def test_convergence_rule_at_its_two_boundaries():
    assert (MIN_EFFECTIVE, MAX_LOG_EVIDENCE_ERROR) == (400, 0.3)
    assert is_converged(400, 0.3) and is_converged(400.0, 0.0)
    assert not is_converged(BELOW_400, 0.0) and not is_converged(399, 0.3)
    assert not is_converged(400, ABOVE_03) and not is_converged(1e6, ABOVE_03)
    assert not is_converged(400, np.inf)


def test_convergence_warnings_at_the_same_boundaries():
    assert convergence_warnings(400, 0.3, True, 5000, 100_000) == []
    assert convergence_warnings(BELOW_400, 0.3, True, 5000, 100_000) == [
        "400 effective draws (< 400)"  # (399.99... printed to whole draws)
    ]
    assert convergence_warnings(400, ABOVE_03, True, 5000, 100_000) == [
        "log-evidence error 0.30 (> 0.3)"
    ]
    assert convergence_warnings(400, np.nan, True, 5000, 100_000) == [
        "log-evidence error nan (> 0.3)"
    ]
    assert convergence_warnings(1e3, 0.1, False, 100_000, 100_000) == [
        "stopped at 100000 likelihood evaluations (max_evaluations 100000)"
    ]


class ScriptedSampler:
    """A stand-in for ``nautilus.Sampler``: each ``run`` reaches the asked effective draws
    (or ``n_eff_short`` of them), costs 1000 evaluations and finishes unless told."""

    n_eff_short: list = []
    unfinished_at: int | None = None

    def __init__(self, *args, **kwargs):
        self.n_like, self.n_eff, self.calls = 0, 0.0, 0

    def run(self, f_live, n_eff, n_like_max, discard_exploration):
        short = self.n_eff_short[self.calls] if self.calls < len(self.n_eff_short) else None
        self.n_eff = float(short if short is not None else n_eff)
        self.n_like += 1000
        self.calls += 1
        return self.calls != self.unfinished_at


def run_scripted(monkeypatch, errors, n_eff_short=(), unfinished_at=None):
    """:func:`run_nautilus` on :class:`ScriptedSampler` with the evidence error of round
    ``i`` taken from ``errors[i]``; returns its rounds and whether it finished."""
    sampler = type(
        "S",
        (ScriptedSampler,),
        {"n_eff_short": list(n_eff_short), "unfinished_at": unfinished_at},
    )
    monkeypatch.setattr(nautilus, "Sampler", sampler)
    monkeypatch.setattr(nested, "log_evidence_error", lambda s: errors[s.calls - 1])
    _, error, rounds, finished = run_nautilus(None, None, 3)
    return rounds, finished


def test_stop_rule_stops_at_an_evidence_error_of_0_3_and_goes_on_above(monkeypatch):
    rounds, finished = run_scripted(monkeypatch, [0.3])
    assert finished and len(rounds) == 1 and rounds[0]["n_eff_target"] == 400
    # a hair above 0.3: another round, for 1.5 times the draws (1.2 (error / 0.3)^2 < 1.5)
    rounds, finished = run_scripted(monkeypatch, [ABOVE_03, 0.25])
    assert finished and [r["n_eff_target"] for r in rounds] == [400, 600]
    assert [r["log_evidence_error"] for r in rounds] == [ABOVE_03, 0.25]
    # twice 0.3: 1.2 * 4 = 4.8 times the draws, then stopped
    rounds, _ = run_scripted(monkeypatch, [0.6, 0.2])
    assert [r["n_eff_target"] for r in rounds] == [400, pytest.approx(1920)]


def test_stop_rule_needs_400_effective_draws_too(monkeypatch):
    rounds, finished = run_scripted(monkeypatch, [0.1, 0.1], n_eff_short=[BELOW_400])
    assert finished and len(rounds) == 2 and rounds[1]["n_eff_target"] == 1.5 * BELOW_400


def test_stop_rule_ends_a_run_stopped_by_its_evaluations(monkeypatch):
    rounds, finished = run_scripted(monkeypatch, [0.9, 0.9], unfinished_at=1)
    assert not finished and len(rounds) == 1


def test_next_target_grows_as_the_error_asks():
    assert next_effective_target(400, 0.3) == 600  # at least 1.5 times
    assert next_effective_target(400, 0.6) == pytest.approx(400 * 1.2 * 4)
    assert next_effective_target(1000, 0.3 * np.sqrt(1.25)) == pytest.approx(1500)


# ------------------------------------------------------------------------ known evidences
def _evidence_case():
    """Three parameters: uniform, log-uniform and truncated normal, a Gaussian likelihood
    narrower than the box in each (prior to posterior about 6 nats)."""
    t = PriorTransform(stub_problem(SPECS, {"r": R_PRIOR}))
    mean, sd = np.array([0.4, 0.7, 2.1]), np.array([0.05, 0.1, 0.08])
    truth = gaussian_log_evidence(t.bounds, {2: R_PRIOR}, mean, sd)
    return t, gaussian_loglike(mean, sd), truth


def test_gaussian_evidence_recovered_within_its_stated_error():
    """Within twice the stated error (one error holds a correct estimate 68 % of the time;
    the seeds of the slow test below check that the error is the scatter's size)."""
    t, loglike, truth = _evidence_case()
    ns, error, rounds, finished = run_nautilus(t, loglike, 3, seed=0, **SMALL)
    assert finished and is_converged(ns.n_eff, error)
    assert 0.0 < error < 0.1
    assert abs(ns.log_z - truth) <= 2 * error, (ns.log_z, truth, error)


def test_bayes_factor_of_nested_models_recovered():
    """Model 1: both means free; model 0: the second fixed at 0. The data (a Gaussian
    likelihood of the second mean centred 0.15, sd 0.1; uniform prior on [-1, 1]) favour
    neither much: ``log B10 = log(int N(m; 0.15, 0.1) dm / 2) - log N(0; 0.15, 0.1)``.
    Within twice the two evidences' errors combined, as above."""
    box = [(-1.0, 1.0), (-1.0, 1.0)]
    mean, sd = np.array([0.3, 0.15]), np.array([0.05, 0.1])
    both = PriorTransform(stub_problem([ParamSpec(n, 0.0, b) for n, b in zip("xy", box)]))
    one = PriorTransform(stub_problem([ParamSpec("x", 0.0, box[0])]))
    ns1, e1, *_ = run_nautilus(both, gaussian_loglike(mean, sd), 2, seed=0, **SMALL)
    fixed = norm.logpdf(0.0, mean[1], sd[1])
    ns0, e0, *_ = run_nautilus(
        one, lambda x: gaussian_loglike(mean[:1], sd[:1])(x) + fixed, 1, seed=0, **SMALL
    )
    log_b10 = np.log(0.5 * (ndtr((1 - 0.15) / 0.1) - ndtr((-1 - 0.15) / 0.1))) - fixed
    assert log_b10 == pytest.approx(
        gaussian_log_evidence(box, {}, mean, sd) - gaussian_log_evidence(box[:1], {}, mean, sd)
        - fixed
    )  # fmt: skip
    # (Savage-Dickey: B01 is the posterior density of the second mean at 0 over its prior's)
    posterior_mass = ndtr((1 - 0.15) / 0.1) - ndtr((-1 - 0.15) / 0.1)
    savage_dickey = norm.logpdf(0.0, 0.15, 0.1) - np.log(posterior_mass) - np.log(0.5)
    assert -log_b10 == pytest.approx(savage_dickey)
    assert abs((ns1.log_z - ns0.log_z) - log_b10) <= 2 * np.hypot(e0, e1), (
        ns1.log_z - ns0.log_z,
        log_b10,
        np.hypot(e0, e1),
    )


@pytest.mark.slow
def test_gaussian_evidence_over_seeds_within_three_sigma():
    t, loglike, truth = _evidence_case()
    pulls = []
    for seed in range(1, 7):
        ns, error, *_ = run_nautilus(t, loglike, 3, seed=seed, **SMALL)
        pulls.append((ns.log_z - truth) / error)
    pulls = np.array(pulls)
    assert np.all(np.abs(pulls) < 3), pulls
    assert np.sqrt(np.mean(pulls**2)) < 2.0, pulls  # the stated error is about the scatter


# ------------------------------------------------------------------------ a real fit
@pytest.mark.slow
def test_real_fit_converges_and_is_reproducible():
    """proportional_width on Table B.1 through the winding chain (5 parameters, the series
    resistance's log-normal prior): converged by the rule, the same with the same seed."""
    opts = {"n_live": 200, "n_networks": 1}
    post = fitdf.fit("B.1", "proportional_width", chain="winding", method="nested", nested=opts)
    d = post.diagnostics
    assert post.method == "nested" and d["converged"]
    assert d["n_effective"] >= MIN_EFFECTIVE and d["log_evidence_error"] <= MAX_LOG_EVIDENCE_ERROR
    assert np.isfinite(d["log_evidence"]) and d["n_likelihood_evaluations"] > 0
    assert d["sampler"]["name"] == "nautilus" and d["sampler"]["n_live"] == 200
    assert post.samples.shape[1:] == (1, post.n_params) and post.noise_samples.shape[1:] == (1, 2)
    assert post.info["prior"]["r_series"]["distribution"].startswith("log-normal")
    assert post.info["prior"]["sigma_magnitude"]["integrated_out"]
    for name, iv in post.intervals.items():
        assert iv["p2.5"] <= iv["p16"] <= iv["p50"] <= iv["p84"] <= iv["p97.5"], name
    assert (
        np.isfinite(post.metrics["looic"])
        and len(d["pointwise_elpd_loo"]) == post.metrics["n_points"]
    )
    again = fitdf.fit("B.1", "proportional_width", chain="winding", method="nested", nested=opts)
    assert again.diagnostics["log_evidence"] == d["log_evidence"]
    assert np.array_equal(again.samples, post.samples)
    assert post.to_dict()["diagnostics"]["log_evidence"] == d["log_evidence"]


def test_unknown_method_names_nested():
    with pytest.raises(OptionError, match="nested"):
        fitdf.fit("B.1", "proportional_width", method="hmc")
