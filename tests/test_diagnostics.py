"""MCMC diagnostics against ArviZ and emcee called directly, on chains with known properties.

The chains are emcee-shaped ``(draw, walker, parameter)`` arrays fed through the functions
:func:`fitdf.inference.mcmc.fit_mcmc` itself uses (``chain_diagnostics``, ``autocorr_time``,
``is_converged``); the reference values come from ArviZ on the same numbers in its own
``(chain, draw)`` layout, with walkers as chains. A last test spies on ``fit_mcmc`` to check
it hands those functions the sampler's chain the right way round.

Also here: the cost of the winding chain's current solver, counted in model calls.
"""

import math
import warnings

import arviz as az
import emcee
import numpy as np
import pytest
import xarray as xr
from synthetic import mcmc_problem

import fitdf.inference.mcmc as mcmc
from fitdf.chains import solve_current
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.mcmc import (
    MIN_ESS,
    MIN_STEPS_OVER_TAU,
    RHAT_MAX,
    autocorr_time,
    chain_diagnostics,
    fit_mcmc,
    is_converged,
)
from fitdf.inference.posterior import psis_loo
from fitdf.models import get_model


def ar1(phi, n_draws, start, rng):
    """AR(1) walkers ``x_t = phi x_{t-1} + e_t`` with unit stationary variance, from ``start``
    (one value per walker); integrated autocorrelation time ``(1 + phi) / (1 - phi)``."""
    x = np.empty((n_draws, len(start)))
    x[0] = start
    e = rng.normal(0.0, math.sqrt(1 - phi**2), x.shape)
    for t in range(1, n_draws):
        x[t] = phi * x[t - 1] + e[t]
    return x


def arviz_reference(chain, name="x"):
    """R-hat and bulk ESS of an emcee array's first parameter, by ArviZ on ``(walker, draw)``."""
    idata = az.from_dict(posterior={name: chain[..., 0].T})
    return float(az.rhat(idata)[name]), float(az.ess(idata, method="bulk")[name])


def test_iid_chain_is_converged():
    rng = np.random.default_rng(0)
    chain = rng.normal(size=(2000, 16, 2))
    d = chain_diagnostics(chain, ["a", "b"])
    assert set(d) == {"rhat", "ess_bulk"} and list(d["rhat"]) == ["a", "b"]
    for i, name in enumerate(("a", "b")):
        assert abs(d["rhat"][name] - 1) < 0.01
        assert abs(d["ess_bulk"][name] - chain[..., 0].size) < 0.2 * chain[..., 0].size
        rhat, ess = arviz_reference(chain[..., i : i + 1])
        assert d["rhat"][name] == rhat and d["ess_bulk"][name] == ess
    assert is_converged(MIN_STEPS_OVER_TAU, d["rhat"])


def test_poorly_mixed_chain_is_not_converged_and_walkers_are_the_chains():
    # AR(1) with phi = 0.999 (tau ~ 2000) over 1000 draws, walkers started from -3 to 3
    rng = np.random.default_rng(1)
    chain = ar1(0.999, 1000, np.linspace(-3, 3, 8), rng)[..., None]
    d = chain_diagnostics(chain, ["x"])
    rhat, ess = arviz_reference(chain)
    assert d["rhat"]["x"] == rhat and d["ess_bulk"]["x"] == ess
    assert d["rhat"]["x"] > 2.0 and d["ess_bulk"]["x"] < 50
    assert not is_converged(1e6, d["rhat"])
    # draws taken as chains would hide it: the test above must fail if walkers and draws swap
    with pytest.warns(UserWarning, match="More chains"):
        swapped = float(az.rhat(az.from_dict(posterior={"x": chain[..., 0]}))["x"])
    assert swapped < d["rhat"]["x"] - 1.0


def test_bimodal_chain_is_not_converged():
    # half the walkers in each of two well separated modes, each mixing perfectly in its own
    rng = np.random.default_rng(2)
    chain = rng.normal(size=(1000, 16, 1)) + np.where(np.arange(16) < 8, 3.0, -3.0)[:, None]
    d = chain_diagnostics(chain, ["x"])
    assert d["rhat"]["x"] == arviz_reference(chain)[0]
    assert d["rhat"]["x"] > 1.5
    assert not is_converged(1e6, d["rhat"])


def test_convergence_rule_thresholds():
    assert RHAT_MAX == 1.01 and MIN_STEPS_OVER_TAU == 50 and MIN_ESS == 400
    assert is_converged(50.0, {"a": 1.0, "b": 1.0099})
    assert not is_converged(50.0, {"a": 1.0, "b": 1.01})  # R-hat must be below 1.01
    assert not is_converged(49.99, {"a": 1.0})  # and the chain 50 tau long
    assert not is_converged(1e6, {"a": 1.0, "b": 1.2})  # the worst parameter decides
    ok = {"a": 1.0, "b": 1.0}
    assert is_converged(50.0, ok, {"a": 400.0, "b": 5000.0})
    assert not is_converged(50.0, ok, {"a": 399.9, "b": 5000.0})  # every bulk ESS >= 400


def test_autocorrelation_time_of_an_ar1_chain():
    # tau = (1 + phi) / (1 - phi) = 19 for phi = 0.9
    rng = np.random.default_rng(3)
    phi = 0.9
    chain = np.stack(
        [ar1(phi, 5000, rng.normal(size=32), rng), ar1(0.5, 5000, rng.normal(size=32), rng)],
        axis=-1,
    )
    tau = autocorr_time(chain)
    np.testing.assert_array_equal(tau, emcee.autocorr.integrated_time(chain, tol=0))
    assert tau.shape == (2,)
    assert abs(tau[0] / ((1 + phi) / (1 - phi)) - 1) < 0.15
    assert abs(tau[1] / 3.0 - 1) < 0.15
    # however short the chain (here 15 draws, tau 19), fit_mcmc gets an estimate to decide on
    short = autocorr_time(chain[:15])
    assert np.all(np.isfinite(short)) and np.all(short > 0)


def normal_draws(n_obs=30, n_draws=200, n_walkers=8, seed=4):
    """emcee-shaped draws of a normal mean and their pointwise log-likelihood: well behaved, so
    ArviZ itself warns about nothing (all Pareto k small)."""
    rng = np.random.default_rng(seed)
    y = rng.normal(0.0, 1.0, n_obs)
    mu = y.mean() + rng.normal(0.0, 1 / math.sqrt(n_obs), (n_draws, n_walkers, 1))
    return mu, -0.5 * (y - mu) ** 2 - 0.5 * math.log(2 * math.pi)


def test_arviz_refactor_notice_is_not_a_fit_warning(monkeypatch):
    # ArviZ 0.x's notice about its coming 1.0 says nothing about a fit: if it is raised while
    # the diagnostics run, it must not reach the fit's warnings; any other ArviZ warning does
    mu, loglik = normal_draws()
    assert psis_loo(mu, loglik, ["mu"])[1] == []
    loo = az.loo

    def noisy_loo(*args, **kw):
        warnings.warn(
            "\nArviZ is undergoing a major refactor to improve flexibility and extensibility",
            FutureWarning,
            stacklevel=2,
        )
        warnings.warn("some other ArviZ notice\nsecond line", FutureWarning, stacklevel=2)
        return loo(*args, **kw)

    monkeypatch.setattr(az, "loo", noisy_loo)
    assert psis_loo(mu, loglik, ["mu"])[1] == ["some other ArviZ notice"]


def test_pareto_k_above_0_7_counts_as_bad(monkeypatch):
    # the count of unreliable rows is of k > 0.7, strictly (ArviZ's threshold at >= 2154 draws)
    mu, loglik = normal_draws(n_obs=5)
    k = np.array([0.1, 0.7, np.nextafter(0.7, 1.0), 1.3, 0.69])
    loo = az.loo

    def loo_with_k(*args, **kw):
        out = loo(*args, **kw)
        return az.ELPDData(
            data=[xr.DataArray(k) if i == "pareto_k" else v for i, v in out.items()],
            index=list(out.index),
        )

    monkeypatch.setattr(az, "loo", loo_with_k)
    diag = psis_loo(mu, loglik, ["mu"])[0]
    assert diag["n_pareto_k_bad"] == 2 and diag["pareto_k_max"] == 1.3


# --- the same functions inside fit_mcmc -----------------------------------------------------


@pytest.mark.parametrize("marginal", [pytest.param(True, marks=pytest.mark.slow), False])
def test_fit_mcmc_feeds_the_diagnostics_the_sampler_chain(monkeypatch, marginal):
    problem = mcmc_problem()
    lsq = fit_lsq(problem, seed=0, n_starts=2)
    seen = {}

    def spy(name, func):
        def wrapper(chain, *args):
            seen[name] = np.array(chain)
            return func(chain, *args)

        monkeypatch.setattr(mcmc, name, wrapper)

    spy("chain_diagnostics", chain_diagnostics)
    spy("autocorr_time", autocorr_time)
    n_steps, n_walkers = 150, 16
    r = fit_mcmc(
        problem,
        lsq,
        seed=1,
        n_steps=n_steps,
        n_walkers=n_walkers,
        marginal_noise=marginal,
        pilot_steps=50,  # (the pilot is not what is tested here)
        max_pilot_rounds=1,
    )
    # the sampler's coordinates: the parameters, with the noise scales unless integrated out
    names = problem.names + ([] if marginal else ["sigma_magnitude", "sigma_phase_deg"])
    d, ndim = r.diagnostics, len(names)
    # emcee's orientation: (draw, walker, parameter), the post-burn chain for R-hat and ESS;
    # production continues 8 of the pilot's walkers as independent chains
    assert d["n_walkers"] == 8 and r.info["n_walkers"] == 8
    n_walkers = d["n_walkers"]
    assert seen["autocorr_time"].shape == (n_steps, n_walkers, ndim)
    assert seen["chain_diagnostics"].shape == (n_steps - d["burn"], n_walkers, ndim)
    np.testing.assert_array_equal(seen["chain_diagnostics"], seen["autocorr_time"][d["burn"] :])
    tau = emcee.autocorr.integrated_time(seen["autocorr_time"], tol=0)
    assert list(d["tau"].values()) == list(map(float, tau))
    assert d["steps_over_tau"] == n_steps / np.max(tau)
    # the burn-in: the first three autocorrelation times (at most half the chain) are left out
    # of the diagnostics and of the posterior draws, which are the rest thinned by tau_min / 2
    assert d["burn"] == min(math.ceil(3 * np.max(tau)), n_steps // 2) and d["burn"] >= 3
    assert d["thin"] == max(1, math.floor(np.min(tau) / 2))
    P = len(problem.names)
    np.testing.assert_array_equal(
        r.samples, seen["autocorr_time"][d["burn"] :: d["thin"], :, :P], strict=True
    )
    for i, name in enumerate(names):
        rhat, ess = arviz_reference(seen["chain_diagnostics"][..., i : i + 1])
        assert d["rhat"][name] == rhat and d["ess_bulk"][name] == ess
    assert d["converged"] == is_converged(d["steps_over_tau"], d["rhat"], d["ess_bulk"])
    worst = max(d["rhat"].values())
    assert any(w.startswith("R-hat") for w in r.warnings) == (worst >= RHAT_MAX)


# --- the winding chain's current solver: cost in model calls --------------------------------

# test_chain.py's grid: 40 amplitudes x 3 frequencies x 2 source impedances, R = R_source + 70
_V, _F, _RS = (
    a.ravel()
    for a in np.meshgrid(np.logspace(-3, 1.3, 40), [3.0, 10.0, 50.0], [0.0, 600.0], indexing="ij")
)
# model calls (cold start, warm start) the solver makes today on that grid at the defaults
SOLVER_CALLS = {
    "constant_width": (19, 12),
    "proportional_width": (10, 6),
    "rayleigh": (11, 7),
    "frequency_hc": (18, 12),
    "cubic_hc": (12, 8),
}
SOLVER_EVALUATIONS = (19075, 12117)  # model evaluations (points), summed over the models


def test_current_solver_cost_in_model_calls():
    """A cost test by call count, not a timing: a change that keeps the solver accurate but
    brackets or refines worse (e.g. an inverted bracket update) fails here."""
    R = _RS + 70.0
    totals = np.zeros(2, int)
    for name, (cold_max, warm_max) in SOLVER_CALLS.items():
        model = get_model(name)
        kw = model.defaults()
        calls = []

        def impedance(i, idx):
            calls.append(idx.size)
            return 2j * np.pi * _F[idx] * model.describing_function(i, _F[idx], **kw)

        cold, z = solve_current(impedance, _V, R)
        n_cold, e_cold = len(calls), sum(calls)
        assert np.abs(cold * np.abs(R + z) / _V - 1).max() <= 1e-11
        calls.clear()
        nearby = cold * (1 + 1e-3 * np.sin(np.arange(_V.size)))
        warm, z = solve_current(impedance, _V, R, initial=nearby)
        assert np.abs(warm * np.abs(R + z) / _V - 1).max() <= 1e-11
        # one call of margin per start
        assert n_cold <= cold_max + 1, (name, n_cold)
        assert len(calls) <= warm_max + 1, (name, len(calls))
        totals += [e_cold, sum(calls)]
    # and 3 % on the number of points evaluated
    assert totals[0] <= 1.03 * SOLVER_EVALUATIONS[0], totals
    assert totals[1] <= 1.03 * SOLVER_EVALUATIONS[1], totals


def test_current_solver_cost_on_random_parameters():
    """The same count on 16 parameter sets drawn over constant_width's prior box, batched as
    MCMC walkers are: saturated cores behind a small R, where the bracket-width stop matters."""
    model = get_model("constant_width")
    rng = np.random.default_rng(5)
    lo, hi = np.array([p.internal_bounds for p in model.params]).T
    internal = rng.uniform(lo, hi, size=(16, lo.size))
    kw = {
        p.name: np.repeat(p.from_internal(internal[:, i]), _V.size)
        for i, p in enumerate(model.params)
    }
    V, F, R = np.tile(_V, 16), np.tile(_F, 16), np.tile(_RS + 70.0, 16)
    calls = []

    def impedance(i, idx):
        calls.append(idx.size)
        N = model.describing_function(i, F[idx], **{k: v[idx] for k, v in kw.items()})
        return 2j * np.pi * F[idx] * N

    current, z = solve_current(impedance, V, R)
    assert np.abs(current * np.abs(R + z) / V - 1).max() <= 1e-9
    assert len(calls) <= 27 + 1 and sum(calls) <= 1.03 * 49065, (len(calls), sum(calls))


# --- the solver's documented contract where test_chain.py does not reach -------------------


def linear(z):
    """A current-independent impedance ``z`` (ohm) at every point."""
    return lambda i, idx: np.full(np.shape(i), z, complex)


def test_current_solver_broadcasts_voltage_and_resistance():
    current, z = solve_current(linear(5j), 1.0, np.array([3.0, 4.0]))
    assert current.shape == z.shape == (2,)
    np.testing.assert_allclose(current, [1 / abs(3 + 5j), 1 / abs(4 + 5j)], rtol=1e-12)
    current, _ = solve_current(linear(5j), np.array([[1.0], [2.0]]), np.array([3.0, 4.0]))
    np.testing.assert_allclose(current, np.array([[1.0], [2.0]]) / np.abs([3 + 5j, 4 + 5j]))


def test_current_solver_unusable_starts_fall_back_to_v_over_r():
    # zero, negative, NaN and infinite guesses are not positive and finite
    guesses = np.array([0.0, -1.0, np.nan, np.inf, 0.1])
    current, _ = solve_current(linear(5j), np.ones(5), np.full(5, 3.0), initial=guesses)
    np.testing.assert_allclose(current, 1 / abs(3 + 5j), rtol=1e-12)


def test_current_solver_spends_no_search_on_non_positive_voltages():
    w = np.array([1.0, 2.0, 3.0, 4.0])
    seen = []

    def impedance(i, idx):  # Z(I) = j w (1 + I): Z(0) = j w
        seen.append(idx.copy())
        return 1j * w[idx] * (1 + i)

    V = np.array([0.0, 1.0, -2.0, 3.0])
    current, z = solve_current(impedance, V, np.full(4, 5.0))
    assert current[0] == current[2] == 0.0
    np.testing.assert_array_equal(z[[0, 2]], [1j, 3j])  # the model's small-signal limit Z(0)
    h = current[[1, 3]] * np.abs(5.0 + 1j * w[[1, 3]] * (1 + current[[1, 3]]))
    np.testing.assert_allclose(h, V[[1, 3]], rtol=1e-11)
    # evaluated twice (the start V / R, then Z(0)), never searched
    per_point = np.bincount(np.concatenate(seen), minlength=4)
    assert per_point[0] == per_point[2] == 2 and per_point[1] > 2


def test_current_solver_returns_nan_without_a_root():
    # a flux that stops growing, Z = j c / I: I |R + Z| = sqrt(R^2 I^2 + c^2) >= c never meets V < c
    current, _ = solve_current(lambda i, idx: 1j / i, np.array([0.5, 2.0]), np.array([1.0, 1.0]))
    assert np.isnan(current[0])
    assert current[1] == pytest.approx(math.sqrt(2.0**2 - 1.0), rel=1e-10)


def test_current_solver_respects_the_evaluation_budget():
    model = get_model("constant_width")
    kw = model.defaults()
    sizes = []

    def impedance(i, idx):
        sizes.append(idx.size)
        return 2j * np.pi * 10.0 * model.describing_function(i, 10.0, **kw)

    for budget, largest in ((8, 8), (None, 32)):  # one point: the K-section uses the budget
        sizes.clear()
        current, z = solve_current(impedance, np.array([2.0]), np.array([70.0]), budget=budget)
        assert abs(current[0] * abs(70.0 + z[0]) / 2.0 - 1) <= 1e-12
        assert max(sizes) == largest, sizes


class _AR1Sampler:
    """Stands in for emcee's sampler in :func:`mcmc._run_until_converged`: each run appends
    AR(1) draws to 8 independent walkers (stationary start, tau = (1 + phi) / (1 - phi))."""

    def __init__(self, phi, seed=0):
        self.phi, self.rng = phi, np.random.default_rng(seed)
        self.chain = self.rng.normal(size=(1, 8, 1))

    @property
    def iteration(self):
        return self.chain.shape[0]

    def run_mcmc(self, state, n, **_):
        more = ar1(self.phi, n + 1, self.chain[-1, :, 0], self.rng)[1:, :, None]
        self.chain = np.concatenate([self.chain, more])
        return state

    def get_chain(self):
        return self.chain


def test_a_chain_too_slow_for_max_steps_is_given_up_early():
    slow = _AR1Sampler(phi=0.98)  # tau ~ 99: 50 tau ~ 5000 steps, more than max_steps
    tau, given_up = mcmc._run_until_converged(slow, None, 300, 2000, 100, ["x"], False)
    assert slow.iteration < 2000  # stopped before spending max_steps
    assert given_up > 2000 and given_up == pytest.approx(MIN_STEPS_OVER_TAU * tau[0], abs=1)
    fast = _AR1Sampler(phi=0.5)  # tau = 3: converged within the budget, not given up
    tau, given_up = mcmc._run_until_converged(fast, None, 300, 2000, 100, ["x"], False)
    assert given_up is None and fast.iteration < 2000
    assert fast.iteration / tau[0] >= MIN_STEPS_OVER_TAU


class _SlowingSampler(_AR1Sampler):
    """An AR(1) chain whose correlation rises to ``phi_late`` after ``switch`` steps: its
    autocorrelation-time estimate grows while it runs."""

    def __init__(self, phi, phi_late, switch, seed=0):
        super().__init__(phi, seed)
        self.phi_early, self.phi_late, self.switch = phi, phi_late, switch

    def run_mcmc(self, state, n, **_):
        self.phi = self.phi_late if self.iteration >= self.switch else self.phi_early
        return super().run_mcmc(state, n)


def test_an_extended_chain_keeps_going_while_50_autocorrelation_times_fit_in_the_extension():
    """Past ``max_steps`` the chain stops only once 50 autocorrelation times would not fit in
    ``extend_to``: an estimate that grows a little (here the chain itself slows down) keeps
    it going towards convergence, where the rule "50 times within the steps run so far"
    stopped it at the first uptick."""
    kw = dict(extend_to=6000)
    ticking = _SlowingSampler(phi=0.9, phi_late=0.97, switch=800, seed=0)
    tau, given_up = mcmc._run_until_converged(ticking, None, 300, 800, 100, ["x"], False, **kw)
    n = ticking.iteration
    assert given_up is None and 800 < n < 6000 and _converged(ticking, tau)
    # along the way the estimate rose past the steps run: the old rule would have stopped
    trace = _SlowingSampler(phi=0.9, phi_late=0.97, switch=800, seed=0)
    trace.run_mcmc(None, 300)
    uptick = False
    while trace.iteration < n:
        trace.run_mcmc(None, 100)
        t = mcmc._tau_range(mcmc.autocorr_time(trace.get_chain()), trace.iteration)[1]
        uptick |= trace.iteration > 800 and MIN_STEPS_OVER_TAU * t > trace.iteration
    assert uptick


def _converged(sampler, tau):
    n = sampler.iteration
    d = mcmc.chain_diagnostics(sampler.get_chain()[mcmc._burn(tau, n) :], ["x"])
    return mcmc.is_converged(n / tau[0], d["rhat"], d["ess_bulk"])


def test_a_well_mixing_chain_short_of_draws_is_extended_past_max_steps():
    """50 autocorrelation times met at ``max_steps`` but R-hat or ESS short: the chain goes on
    up to ``extend_to`` until converged. A chain too slow for ``max_steps`` is not extended."""
    short = _AR1Sampler(phi=0.9, seed=0)  # tau ~ 19
    tau, given_up = mcmc._run_until_converged(short, None, 300, 800, 100, ["x"], False)
    assert given_up is None and short.iteration == 800
    assert short.iteration / tau[0] >= MIN_STEPS_OVER_TAU and not _converged(short, tau)
    extended = _AR1Sampler(phi=0.9, seed=0)  # the same draws, then more
    tau, given_up = mcmc._run_until_converged(
        extended, None, 300, 800, 100, ["x"], False, extend_to=3000
    )
    assert given_up is None and 800 < extended.iteration < 3000 and _converged(extended, tau)
    np.testing.assert_array_equal(extended.get_chain()[:800], short.get_chain())
    slow = _AR1Sampler(phi=0.98)  # tau ~ 99: given up before max_steps, not extended
    tau, given_up = mcmc._run_until_converged(
        slow, None, 300, 2000, 100, ["x"], False, extend_to=6000
    )
    assert given_up > 2000 and slow.iteration < 2000
