"""Posteriors in ArviZ's format, and the one path both samplers' results are assembled by.

A posterior leaves fitdf as ArviZ's InferenceData (``PosteriorResult.to_inference_data``) and
as netCDF files (``fitdf fit --posterior-out``): draws in physical units, the pointwise
log-likelihood, the evidence and the prior. Read back by ArviZ alone, a file gives the LOO-IC
fitdf reports. Both samplers (emcee, nautilus) build their result by
:func:`fitdf.inference.posterior.posterior_result`.
"""

from __future__ import annotations

import contextlib
import io
import json
from types import SimpleNamespace

import arviz as az
import numpy as np
import pytest
from synthetic import MCMC_TRUTH, mcmc_problem

from fitdf.inference import posterior, priors
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.mcmc import fit_mcmc
from fitdf.inference.nested import fit_nested
from fitdf.inference.noise import NOISE_BOUNDS, NOISE_NAMES
from fitdf.inference.posterior_data import posterior_filename, write_posteriors
from fitdf.inference.results import PointwiseLikelihood

#: ArviZ's own warnings on a small posterior's PSIS-LOO and WAIC (fitdf records them in a
#: fit's warnings; here ArviZ is called directly)
pytestmark = pytest.mark.filterwarnings(
    "ignore:Estimated shape parameter of Pareto:UserWarning",
    "ignore:For one or more samples the posterior variance:UserWarning",
)

#: Held fixed, so that the small posterior below samples in seconds (three parameters).
FIXED = {"m": MCMC_TRUTH["m"], "gain": MCMC_TRUTH["gain"]}


@pytest.fixture(scope="module")
def fits():
    """A least-squares fit, and small posteriors of it by both samplers (not converged: the
    export and the assembly are what is tested, not the samplers); nested sampling's
    PSIS-LOO on a random subset of its equal-weight draws. About 8 s of CPU."""
    problem = mcmc_problem()
    problem = type(problem)(problem.data, problem.model, problem.chain, fixed=FIXED)
    lsq = fit_lsq(problem, seed=0, n_starts=1)
    nested = fit_nested(
        problem, lsq, seed=5, n_live=50, max_evaluations=1500, n_draws=300, max_loo_draws=120
    )
    mcmc = fit_mcmc(problem, lsq, seed=3, n_steps=60, max_steps=60, n_walkers=8, pilot_steps=30)
    return {"lsq": lsq, "nested": nested, "mcmc": mcmc}


# ------------------------------------------------------------ the file, read by ArviZ alone
def test_netcdf_files_read_back_by_arviz_give_the_reported_looic(fits, tmp_path):
    """One file per posterior (least squares has none), named by data and law; ArviZ's own
    ``loo`` and ``waic`` on the file give fitdf's LOO-IC and WAIC to the last digit: for
    nested sampling's one chain as ArviZ computes them by default, for emcee's chains with
    the relative efficiency fitdf's PSIS used (``loo_reff``)."""
    results = [fits["lsq"], fits["nested"], fits["mcmc"]]
    written = write_posteriors(results, tmp_path / "posteriors")
    assert [p.name for p in written] == [
        "data_proportional_width_winding_nested.nc",
        "data_proportional_width_winding_mcmc.nc",
    ]
    for r, path in zip(results[1:], written):
        idata = az.from_netcdf(path)
        m = r.metrics
        loo = az.loo(idata, scale="deviance", reff=idata.attrs["loo_reff"])
        assert loo.elpd_loo == m["looic"] and loo.se == m["looic_se"], r.method
        waic = az.waic(idata, scale="deviance")
        assert waic.elpd_waic == m["waic"] and waic.se == m["waic_se"], r.method
        assert idata.attrs["looic"] == m["looic"] and idata.attrs["method"] == r.method
    nested = az.from_netcdf(written[0])
    assert az.loo(nested, scale="deviance").elpd_loo == fits["nested"].metrics["looic"]
    assert nested.attrs["loo_reff"] == 1.0 and fits["mcmc"].pointwise.reff != 1.0


def test_file_names_say_data_and_law():
    def name(label):
        law = SimpleNamespace(label=label, model="rayleigh", chain="voltage", method="nested")
        return posterior_filename(law)

    assert name("B.3") == "B.3_rayleigh_voltage_nested.nc"
    assert name("core 1.CSV") == "core_1_rayleigh_voltage_nested.nc"
    assert name("deltamax @ 600 ohm") == "deltamax_600_ohm_rayleigh_voltage_nested.nc"
    assert name("../x/y.csv") == "x_y_rayleigh_voltage_nested.nc"  # never a path or hidden


def test_the_file_holds_the_evidence_and_the_prior(fits, tmp_path):
    r = fits["nested"]
    (path,) = write_posteriors([r], tmp_path)
    idata = az.from_netcdf(path)
    d = r.diagnostics
    assert idata.attrs["log_evidence"] == d["log_evidence"]
    assert idata.attrs["log_evidence_error"] == d["log_evidence_error"]
    assert idata.attrs["method_title"] == "nautilus nested sampling"
    assert json.loads(idata.attrs["prior"]) == r.info["prior"]
    assert json.loads(idata.attrs["fixed"]) == FIXED
    for s in r.problem.specs:
        a = idata.posterior[s.name].attrs
        assert a["unit"] == s.unit_label and a["description"] == s.description
        assert (a["prior_lower"], a["prior_upper"]) == s.bounds
        assert a["prior"] == ("log-uniform" if s.log else "uniform")
    for name, (lo, hi) in zip(NOISE_NAMES, 10.0**NOISE_BOUNDS):
        a = idata.posterior[name].attrs
        assert a["prior"] == "log-uniform" and (a["prior_lower"], a["prior_upper"]) == (lo, hi)
    assert "evidence" not in " ".join(fits["mcmc"].to_inference_data().attrs)


def test_the_relative_efficiency_is_the_one_psis_used():
    """``psis_loo``'s ``reff`` is ArviZ's own: ``arviz.loo`` given it reproduces the record,
    and on these 400 draws PSIS's tail (``3 sqrt(S / reff)`` draws) depends on it, so another
    value gives another LOO."""
    rng = np.random.default_rng(4)
    y = rng.normal(0.0, 1.0, 30)
    e = rng.normal(0.0, 1.0 / np.sqrt(30), (50, 8, 1))
    for t in range(1, 50):  # AR(1) chains, phi 0.2: a relative efficiency of about 2/3
        e[t] += 0.2 * e[t - 1]
    mu = y.mean() + e
    loglik = -0.5 * (y - mu) ** 2 - 0.5 * np.log(2 * np.pi)
    record, _, reff = posterior.psis_loo(mu, loglik, ["mu"])
    idata = az.from_dict(
        posterior={"mu": np.swapaxes(mu[..., 0], 0, 1)},
        log_likelihood={"y": np.swapaxes(loglik, 0, 1)},
    )
    assert 0.5 < reff < 0.9
    assert az.loo(idata, reff=reff).elpd_loo == record["elpd_loo"]
    assert az.loo(idata, reff=2 * reff).elpd_loo != record["elpd_loo"]
    one = az.from_dict(
        posterior={"mu": mu[:, 0, 0][None]}, log_likelihood={"y": loglik[:, 0][None]}
    )
    assert posterior.relative_efficiency(one) == 1.0


# ------------------------------------------------------------ physical units, the draws
@pytest.mark.parametrize("key", ["nested", "mcmc"])
def test_inference_data_is_in_physical_units_and_explains_its_log_likelihood(fits, key):
    """The posterior's variables are the parameters in natural units and the noise scales;
    the Gaussian likelihood of each row at those values is the file's log-likelihood (a
    variable in internal units, a swapped noise column or chain/draw axes fail here)."""
    r = fits[key]
    idata = r.to_inference_data()
    problem = r.problem
    post = idata.posterior
    assert list(post.data_vars) == [*problem.names, *NOISE_NAMES]
    n_chains, n_draws = post.sizes["chain"], post.sizes["draw"]
    assert (n_draws, n_chains) == r.pointwise.draws.shape[:2]
    for s in problem.specs:
        assert (post[s.name].values > 0).all() or not s.log
    internal = np.stack(
        [np.log10(post[s.name].values) if s.log else post[s.name].values for s in problem.specs],
        axis=-1,
    )
    loglik = problem.pointwise_loglike(
        internal, post["sigma_magnitude"].values, post["sigma_phase_deg"].values
    )
    np.testing.assert_allclose(idata.log_likelihood["df"].values, loglik, rtol=1e-10)
    assert idata.log_likelihood["df"].dims == ("chain", "draw", "row")
    np.testing.assert_array_equal(
        idata.observed_data["df_measured"].values, r.residuals["df_measured"].to_numpy()
    )
    np.testing.assert_array_equal(
        idata.constant_data["frequency_hz"].values, problem.data.frequency
    )


def test_nested_draws_are_the_fits_equal_weight_draws(fits):
    """Nested sampling's exported draws are the random subset of its equal-weight sample
    (one chain) that PSIS-LOO used."""
    r = fits["nested"]
    assert r.pointwise.draws.shape == (120, 1, r.n_params) and r.samples.shape[:2] == (300, 1)
    kept = {tuple(x) for x in r.samples[:, 0, :]}
    assert all(tuple(x) in kept for x in r.pointwise.draws[:, 0, :])
    assert r.pointwise.description.startswith("120 (a random choice, seed 5) of the 300 draws")


# ------------------------------------------------------------ one assembly for both samplers
def test_both_samplers_assemble_one_kind_of_result(fits):
    """The same fields, LOO record, metrics and pointwise draws from emcee and from nautilus:
    both pass through :func:`fitdf.inference.posterior.posterior_result`."""
    mcmc, nested = fits["mcmc"], fits["nested"]
    loo_keys = set(posterior.LOO_METRICS) | {"pareto_k_max", "n_pareto_k_bad", "pointwise_elpd_loo"}
    for r in (mcmc, nested):
        assert loo_keys <= set(r.diagnostics)
        assert {f"{n}_interval" for n in NOISE_NAMES} <= set(r.diagnostics)
        assert isinstance(r.pointwise, PointwiseLikelihood)
        n_draws, n_chains, _ = r.pointwise.draws.shape
        assert r.pointwise.log_likelihood.shape == (n_draws, n_chains, r.metrics["n_points"])
        assert r.pointwise.noise.shape == (n_draws, n_chains, 2)
        assert r.info["noise_priors"] == priors.noise_priors_text()
        np.testing.assert_allclose(
            np.sum(r.diagnostics["pointwise_elpd_loo"]), r.metrics["elpd_loo"], rtol=1e-12
        )
    evidence = ["log_evidence", "log_evidence_error"]
    assert list(nested.metrics) == [*mcmc.metrics, *evidence]
    assert set(nested.to_dict()) == set(mcmc.to_dict())
    assert (mcmc.method_title, nested.method_title) == ("emcee MCMC", "nautilus nested sampling")


def test_the_noise_priors_are_stated_from_their_bounds(monkeypatch):
    assert priors.noise_priors_text() == (
        "log-uniform: sigma_magnitude 0.001..0.3, sigma_phase 0.1..50 deg"
    )
    monkeypatch.setattr(priors, "NOISE_BOUNDS", np.log10([[0.002, 0.5], [0.2, 30.0]]))
    assert priors.noise_priors_text() == (
        "log-uniform: sigma_magnitude 0.002..0.5, sigma_phase 0.2..30 deg"
    )


# ------------------------------------------------------------ fitdf fit --posterior-out
def run_here(*args):
    from fitdf.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:
            code = exc.code
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize(
    "extra, fragment",
    [
        (("--method", "lsq"), "--posterior-out needs a posterior"),
        (("--method", "nested"), "is a file, not a folder"),
    ],
)
def test_posterior_out_is_checked_before_any_fit(tmp_path, monkeypatch, extra, fragment):
    """An unusable folder, or no posterior to write, is a one-line error and exit 2 before
    any data is fitted."""
    import fitdf.inference.ranking as ranking

    def no_fit(*a, **k):
        raise AssertionError("fitted before the output folder was checked")

    monkeypatch.setattr(ranking, "compare_fits", no_fit)
    blocker = tmp_path / "file"
    blocker.write_text("")
    code, out, err = run_here("fit", "B.1", *extra, "--posterior-out", str(blocker))
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert fragment in err and "Traceback" not in err


@pytest.mark.slow  # about a minute of nested sampling on 2 cores
def test_fit_writes_posteriors_that_arviz_reads_with_the_same_looic(tmp_path):
    """The user's path: ``fitdf fit --method nested --posterior-out``, then ArviZ alone."""
    folder = tmp_path / "out"
    args = ("fit", "B.1", "--models", "rayleigh", "--chain", "winding", "--method", "nested")
    code, out, err = run_here(
        *args, "--no-cv", "--workers", "1", "--no-cache", "--json", "--posterior-out", str(folder)
    )
    assert code == 0, err
    fit = json.loads(out)["fits"][0]
    idata = az.from_netcdf(folder / "B.1_rayleigh_winding_nested.nc")
    assert az.loo(idata, scale="deviance").elpd_loo == fit["metrics"]["looic"]
    assert json.loads(idata.attrs["prior"])["r_series"]["distribution"].startswith("log-normal")
    assert idata.posterior["r_series"].attrs["unit"] == "ohm"
