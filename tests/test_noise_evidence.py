"""Nested sampling under a fitted noise law (fitdf/inference/nested.py with
fitdf/inference/noise_models.py): the law's parameters sampled with the law's.

The evidence of the ``constant`` law, sampled explicitly, is checked against a brute-force
quadrature written here (the two scales' integrals on a fine grid, the law's parameter on
another); the evidence must prefer the noise law the rows were made with, the rows' noise
drawn here by numpy (not through the noise laws). The law is a constant-width loop read
without a circuit (the ``direct`` chain, closed form), so one likelihood call costs
microseconds and the runs are the sampler's own cost.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.special import logsumexp

import fitdf
from fitdf.chains import get_chain
from fitdf.data.fitdata import FitData
from fitdf.inference.nested import NestedLikelihood, PriorTransform, is_converged, run_nautilus
from fitdf.inference.noise_models import PARAMETER_BOUNDS, get_noise_law
from fitdf.inference.problem import FitProblem
from fitdf.models import get_model

MODEL = "constant_width"
TRUTH = {"k": 1.0, "b": 0.003, "c": 0.5}
#: Everything but ``c`` held: one law parameter, log-uniform on its box (1e-4 .. 10).
FIXED = {"k": 1.0, "b": 0.003, "input_scale": 1.0}
INPUTS = np.geomspace(0.01, 5.0, 20)
FREQUENCIES = (3.0, 6.0)
SMALL = {"n_live": 200, "n_networks": 1}


def clean_df():
    """The law's DF at the rows (the chain's closed form, at the truth)."""
    V = np.tile(INPUTS, len(FREQUENCIES))
    F = np.repeat(FREQUENCIES, INPUTS.size)
    theta = np.array([TRUTH[p.name] for p in get_model(MODEL).params])
    d = get_chain("direct").predict(get_model(MODEL), V, F, np.zeros(V.size), theta, [1.0])
    return V, F, d


def noisy_rows(seed, s_m, s_p_deg, r_m=0.0, r_p=0.0) -> FitData:
    """Rows read with a floor and a reading resolution (volts of output, the factor 1: no
    output column), drawn by numpy: magnitude error ``hypot(s_m, r_m / V)``, phase error
    ``hypot(s_p, r_p / V_out)`` rad."""
    rng = np.random.default_rng(seed)
    V, F, d = clean_df()
    v_out = np.abs(d) * V
    mag = np.abs(d) + np.hypot(s_m, r_m / V) * rng.standard_normal(V.size)
    phase = np.angle(d) + np.hypot(np.deg2rad(s_p_deg), r_p / v_out) * rng.standard_normal(V.size)
    frame = pd.DataFrame(
        {
            "table": "T",
            "frequency_hz": F,
            "input_v": V,
            "df_reported": mag,
            "phase_lead_deg": np.rad2deg(phase),
        }
    )
    return FitData.from_frame(frame)


def problem_of(data, noise):
    return FitProblem(data, MODEL, "direct", None, FIXED, None, noise_law=noise)


def sample(problem, seed=0):
    transform = PriorTransform(problem)
    ns, error, _, finished = run_nautilus(
        transform, NestedLikelihood(problem), transform.ndim, seed=seed, **SMALL
    )
    assert finished and is_converged(ns.n_eff, error)
    return float(ns.log_z), float(error)


def brute_force_log_evidence(problem, n_theta=20001):
    """The constant law's ``ln Z`` by quadrature: for each ``log10 c`` of a grid on its box,
    the magnitude and phase scales integrated on grids of 4001 nodes in ``log10`` (the
    trapezoid rule; log-uniform priors on :data:`PARAMETER_BOUNDS`), then ``log10 c`` by
    the trapezoid rule on a grid fine around the likelihood's peak."""
    ((lo, hi),) = problem.internal_bounds()
    d_abs = np.abs(problem.data.measured)
    n = d_abs.size

    def log_like(x):
        pred = problem.predict(x[:, None])
        radial = np.abs(pred) - d_abs
        tang = d_abs * np.angle(pred / problem.data.measured)
        out = 0.0
        for e2, scale_of, (a, b) in (
            (np.sum(radial**2, -1), lambda s: s * np.ones(n), PARAMETER_BOUNDS["s_m"]),
            (np.sum((tang / d_abs) ** 2, -1), None, PARAMETER_BOUNDS["s_p_deg"]),
        ):
            u = np.linspace(np.log10(a), np.log10(b), 4001)
            s = 10.0**u
            if scale_of is None:  # the arc's scale is |D_i| s_p (rad)
                s_rad = np.deg2rad(s)
                lg = -0.5 * e2[:, None] / s_rad**2 - n * np.log(s_rad) - np.sum(np.log(d_abs))
            else:
                lg = -0.5 * e2[:, None] / s**2 - n * np.log(s)
            w = np.full(u.size, u[1] - u[0])
            w[[0, -1]] *= 0.5
            out = out + logsumexp(lg + np.log(w / (u[-1] - u[0])), axis=-1)
        return out - n * np.log(2.0 * np.pi)

    coarse = np.linspace(lo, hi, 2001)
    peak = coarse[np.argmax(log_like(coarse))]
    x = np.linspace(max(lo, peak - 0.05), min(hi, peak + 0.05), n_theta)
    ll = log_like(x)
    # the window holds the mass: its ends are far below the peak
    assert ll.max() - max(ll[0], ll[-1]) > 40.0
    w = np.full(x.size, x[1] - x[0])
    w[[0, -1]] *= 0.5
    return float(logsumexp(ll + np.log(w / (hi - lo))))


# ------------------------------------------------------------------ the likelihood and prior
def test_likelihood_is_the_laws_pointwise_summed_and_the_prior_its_box():
    data = noisy_rows(1, 0.01, 1.0)
    law = get_noise_law("reading")
    problem = problem_of(data, "reading")
    t = PriorTransform(problem)
    assert t.names == ["c", "s_m", "s_p_deg", "r_m", "r_p"]
    np.testing.assert_allclose(t.bounds[1:], law.bounds)
    u = np.random.default_rng(0).random((7, t.ndim))
    x = t(u)
    np.testing.assert_allclose(x[:, 1:], law.bounds[:, 0] + u[:, 1:] * np.diff(law.bounds).T)
    # the prior is normalised on the whole box, the noise coordinates' included
    assert t.log_density(x)[0] == pytest.approx(-np.log(5.0) - np.sum(np.log(np.diff(law.bounds))))
    got = NestedLikelihood(problem)(x)
    ctx = law.context(data)
    for i in range(len(x)):
        radial, tang = problem.error_components(problem.predict(x[i, :1]))
        assert got[i] == pytest.approx(np.sum(law.pointwise(x[i, 1:], radial, tang, ctx)), 1e-12)
    assert t.describe()["r_m"] == {
        "distribution": "log-uniform",
        "bounds": list(PARAMETER_BOUNDS["r_m"]),
        "unit": "V",
        "integrated_out": False,
    }


def test_printed_noise_keeps_the_marginal_likelihood():
    """Without a fitted law the sampled vector is the law's alone and the likelihood the
    noise-marginal one (:class:`fitdf.inference.noise.NoiseMarginal`)."""
    problem = problem_of(noisy_rows(1, 0.01, 1.0), None)
    like = NestedLikelihood(problem)
    assert like.law is None and PriorTransform(problem).ndim == 1
    x = np.array([[-0.5], [np.log10(0.5)], [0.2]])
    radial, tang = problem.error_components(problem.predict(x))
    np.testing.assert_array_equal(like(x), like.noise.log_likelihood(radial, tang))


# ------------------------------------------------------------------ the evidence
@pytest.mark.slow
def test_constant_law_evidence_is_the_brute_force_quadratures():
    """The constant law's two scales sampled beside ``c`` (3 dimensions): ``ln Z`` within
    twice its stated error of the quadrature (whose own error is below 1e-4)."""
    problem = problem_of(noisy_rows(2, 0.01, 1.0), "constant")
    truth = brute_force_log_evidence(problem)
    # the quadrature's grids are converged: a coarser one changes it by < 1e-4
    assert brute_force_log_evidence(problem, n_theta=5001) == pytest.approx(truth, abs=1e-4)
    log_z, error = sample(problem)
    assert 0.0 < error < 0.15
    assert abs(log_z - truth) <= 2.0 * error, (log_z, truth, error)


@pytest.mark.slow
def test_evidence_prefers_the_noise_the_rows_were_made_with():
    """Rows read with reading resolutions (2 mV: below 0.2 V of input they overtake the
    floors): the reading law's evidence far above the constant law's. Rows with the floors
    alone: the constant law's above the reading law's by the Occam factor of the two
    resolutions the rows do not need (about ln 4 each: the resolutions below ~1e-4 V, a
    quarter of their four-decade boxes, change no row's scale by much)."""
    reading_rows = noisy_rows(3, 0.005, 0.5, r_m=2e-3, r_p=2e-3)
    z_r, e_r = sample(problem_of(reading_rows, "reading"))
    z_c, e_c = sample(problem_of(reading_rows, "constant"))
    assert z_r - z_c > 20.0 + 3.0 * np.hypot(e_r, e_c), (z_r, z_c)

    floor_rows = noisy_rows(4, 0.01, 1.0)
    z_r, e_r = sample(problem_of(floor_rows, "reading"))
    z_c, e_c = sample(problem_of(floor_rows, "constant"))
    assert 1.0 + 3.0 * np.hypot(e_r, e_c) < z_c - z_r < 6.0, (z_c, z_r, e_r, e_c)


@pytest.mark.slow
def test_nested_fit_records_the_sampled_noise_law():
    """Through :func:`fitdf.fit`: the noise law's parameters with intervals, its name, the
    log-likelihood at the point estimate and the pointwise log-likelihood of the LOO draws
    are the law's; the resolutions used to make the rows lie in their 95 % intervals."""
    data = noisy_rows(5, 0.005, 0.5, r_m=2e-3, r_p=2e-3)
    post = fitdf.fit(
        data, MODEL, chain="direct", method="nested", noise="reading", fixed=FIXED,
        geometry=None, n_starts=1, nested=SMALL,
    )  # fmt: skip
    law, problem = get_noise_law("reading"), post.problem
    rec = post.info["noise_law"]
    assert rec["name"] == "reading" and rec["sampled"]
    truth = {"s_m": 0.005, "s_p_deg": 0.5, "r_m": 2e-3, "r_p": 2e-3}
    for name, iv in rec["intervals"].items():
        assert iv["p2.5"] <= iv["p16"] <= iv["p50"] <= iv["p84"] <= iv["p97.5"], name
        assert iv["p2.5"] <= truth[name] <= iv["p97.5"], (name, iv)
        assert post.diagnostics[f"{name}_interval"] == iv
    ctx = law.context(problem.data)
    errors = problem.error_components(problem.predict(post.internal))
    total = np.sum(law.pointwise(rec["log10"], *errors, ctx))
    assert post.metrics["log_likelihood"] == pytest.approx(total, abs=1e-9)
    pw = post.pointwise
    assert pw.noise.shape[-1] == 4 and post.noise_samples.shape[-1] == 4
    radial, tang = problem.error_components(problem.predict(pw.draws))
    np.testing.assert_allclose(
        pw.log_likelihood, law.pointwise(np.log10(pw.noise), radial, tang, ctx), rtol=1e-12
    )
    assert "noise law reading, log-uniform" in post.info["noise_priors"]
    assert post.info["prior"]["r_p"]["distribution"] == "log-uniform"
