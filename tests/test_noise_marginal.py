"""Noise scales integrated out of the likelihood, and the production proposals.

The grid quadrature of :mod:`fitdf.inference.noise` is checked against independent paths:
the magnitude factor in closed form (an incomplete gamma function), the phase factor by
adaptive quadrature over the problem's own per-row scales, the conditional draws against
the exact law of the magnitude scale, and the whole sampler against sampling the scales
with the parameters.
"""

import numpy as np
import pytest
from scipy import integrate, stats
from scipy.special import gammainc, gammaln, logsumexp
from synthetic import mcmc_problem

from fitdf.inference.api import resolve_data
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.mcmc import LogPosterior, fit_mcmc
from fitdf.inference.noise import NOISE_BOUNDS, NoiseMarginal
from fitdf.inference.problem import FitProblem
from fitdf.inference.proposals import KernelProposal, StudentTProposal


@pytest.fixture(scope="module")
def problem():
    return mcmc_problem()


@pytest.fixture(scope="module")
def lsq(problem):
    return fit_lsq(problem, seed=0)


def _log_magnitude_factor(radial):
    """``log Int (2 pi s^2)^(-n/2) exp(-S / 2 s^2) p(s) ds``, ``p`` log-uniform on the
    magnitude bounds: ``(1/2) (2/S)^(n/2) Gamma(n/2) [P(n/2, S/2 lo^2) - P(n/2, S/2 hi^2)]``
    over ``ln(10) (log10 hi - log10 lo)`` (``P`` the regularised lower incomplete gamma)."""
    n, S = radial.size, float(np.sum(radial**2))
    (lo, hi) = NOISE_BOUNDS[0]
    a = n / 2
    bracket = gammainc(a, S / (2 * 10.0 ** (2 * lo))) - gammainc(a, S / (2 * 10.0 ** (2 * hi)))
    return (
        -a * np.log(2 * np.pi)
        + np.log(0.5)
        + a * np.log(2 / S)
        + gammaln(a)
        + np.log(bracket)
        - np.log(np.log(10.0) * (hi - lo))
    )


def _log_phase_factor(problem, tang):
    """``log Int prod_i N(t_i; 0, s_t,i(sigma_p)) p(sigma_p) d log10 sigma_p`` by adaptive
    quadrature, the per-row scales from :meth:`FitProblem.scales`."""
    lo, hi = NOISE_BOUNDS[1]

    def log_f(u):
        _, st = problem.scales(np.array([1.0]), np.array([10.0**u]))
        return float(
            np.sum(-0.5 * (tang / st[0]) ** 2 - np.log(st[0])) - 0.5 * tang.size * np.log(2 * np.pi)
        )

    grid = np.linspace(lo, hi, 2001)
    values = np.array([log_f(u) for u in grid])
    peak, top = grid[np.argmax(values)], values.max()
    value, _ = integrate.quad(
        lambda u: np.exp(log_f(u) - top), lo, hi, points=[peak], epsabs=0, epsrel=1e-12, limit=400
    )
    return top + np.log(value / (hi - lo))


@pytest.mark.parametrize("scale", [1.0, 30.0, 1e-3])
def test_marginal_likelihood_against_closed_form_and_quadrature(problem, lsq, scale):
    # scale 1: both scales' posteriors inside the box; 30: magnitude and phase residuals
    # large; 1e-3: the magnitude scale pushed against its lower bound 0.001
    radial, tang = problem.error_components(problem.predict(lsq.internal))
    radial, tang = scale * radial, scale * tang
    expected = _log_magnitude_factor(radial) + _log_phase_factor(problem, tang)
    got = NoiseMarginal(problem).log_likelihood(radial[None], tang[None])[0]
    # a bump, the phase scale's flat floor below 0.6 degrees, and a steep pile-up at the
    # magnitude's lower bound: the composite Gauss-Legendre rule resolves all three
    assert got == pytest.approx(expected, abs=1e-8)


def test_log_posterior_marginal_is_the_joint_integrated_over_the_noise(problem, lsq):
    """The marginal log-posterior equals ``log`` of the joint one (the sampler's other mode,
    through ``pointwise_loglike``) summed over a fine grid of both noise scales."""
    joint, marginal = LogPosterior(problem), LogPosterior(problem, marginal_noise=True)
    theta = lsq.internal + np.array([0.0, 0.0, 0.002, 0.0, 0.0])
    # the joint log-posterior is c + F(u) + G(v) (the scales enter separate factors), so
    # log Int Int = log Int e^(c+F+G0) du + log Int e^(c+F0+G) dv - (c+F0+G0); each 1-D
    # integral by the trapezoid rule on a grid of 6000 nodes over the whole box
    base = np.concatenate([theta, [-2.0, 0.0]])
    logs = []
    for j, (lo, hi) in enumerate(NOISE_BOUNDS):
        u = np.linspace(lo, hi, 6001)
        X = np.tile(base, (u.size, 1))
        X[:, problem.ndim + j] = u
        lp = joint(X)
        w = np.full(u.size, (hi - lo) / (u.size - 1))
        w[[0, -1]] *= 0.5
        logs.append(logsumexp(lp + np.log(w / (hi - lo))))
    expected = logs[0] + logs[1] - joint(base[None])[0]
    assert marginal(theta[None])[0] == pytest.approx(expected, abs=1e-6)
    assert marginal.ndim == problem.ndim and joint.ndim == problem.ndim + 2


def test_noise_draws_follow_their_conditional_law(problem, lsq):
    # given the residuals, 1/sigma_m^2 is Gamma(n/2, rate S/2) truncated to the box
    radial, tang = problem.error_components(problem.predict(lsq.internal))
    n, S = radial.size, float(np.sum(radial**2))
    draws = NoiseMarginal(problem).draw(
        np.tile(radial, (20000, 1)), np.tile(tang, (20000, 1)), np.random.default_rng(1)
    )
    law = stats.gamma(n / 2, scale=2 / S)
    (lo, hi) = NOISE_BOUNDS[0]
    c_lo, c_hi = law.cdf(10.0 ** (-2 * hi)), law.cdf(10.0 ** (-2 * lo))
    q = np.array([0.05, 0.25, 0.5, 0.75, 0.95])
    exact = -0.5 * np.log10(law.ppf(c_hi - q * (c_hi - c_lo)))  # log10 sigma quantiles
    spread = exact[-1] - exact[0]
    np.testing.assert_allclose(np.quantile(draws[:, 0], q), exact, atol=0.02 * spread)
    # the phase scale: its conditional mean of log10 sigma_p by quadrature
    lo, hi = NOISE_BOUNDS[1]
    u = np.linspace(lo, hi, 20001)
    _, st = problem.scales(np.ones(u.size), 10.0**u)
    logp = np.sum(-0.5 * (tang / st) ** 2 - np.log(st), axis=-1)
    p = np.exp(logp - logp.max())
    mean = np.sum(u * p) / np.sum(p)
    sd = np.sqrt(np.sum((u - mean) ** 2 * p) / np.sum(p))
    assert np.mean(draws[:, 1]) == pytest.approx(mean, abs=0.03 * sd)
    assert np.std(draws[:, 1]) == pytest.approx(sd, rel=0.03)


@pytest.mark.slow
def test_sampling_with_the_noise_integrated_out_keeps_the_posterior(problem, lsq):
    """Integrating the scales out changes the sampler, not the posterior: the parameters'
    and the noise scales' intervals agree with those of sampling all of them jointly."""
    kw = dict(seed=6, n_steps=1500, max_steps=4000)
    marginal = fit_mcmc(problem, lsq, marginal_noise=True, **kw)
    joint = fit_mcmc(problem, lsq, marginal_noise=False, **kw)
    assert marginal.diagnostics["converged"] and joint.diagnostics["converged"]
    for name in problem.names:
        a, b = marginal.intervals[name], joint.intervals[name]
        width = b["p84"] - b["p16"]
        # medians within 0.2 of the 68 % width (ESS >= 400 each: ~0.05 expected)
        assert a["p50"] == pytest.approx(b["p50"], abs=0.2 * width), name
        assert a["p84"] - a["p16"] == pytest.approx(width, rel=0.15), name
    for name in ("sigma_magnitude_interval", "sigma_phase_deg_interval"):
        a, b = marginal.diagnostics[name], joint.diagnostics[name]
        assert a["p50"] == pytest.approx(b["p50"], rel=0.05), name
        assert a["p84"] / a["p16"] == pytest.approx(b["p84"] / b["p16"], rel=0.1), name
    assert marginal.info["noise"].startswith("integrated out")


def test_kernel_proposal_density_and_correction():
    rng = np.random.default_rng(0)
    draws = rng.standard_normal((300, 3)) * [1.0, 0.1, 3.0] + [0.0, 5.0, -2.0]
    prop = KernelProposal(draws, np.random.default_rng(1), max_centres=200, defensive=0.1)
    assert prop.centres.shape == (200, 3)
    # the mixture written out with scipy's densities
    cov = np.cov(prop.centres, rowvar=False)
    h = 200 ** (-1 / 7)
    x = rng.standard_normal((5, 3)) * [1.0, 0.1, 3.0] + [0.0, 5.0, -2.0]
    kernels = np.mean(
        [stats.multivariate_normal(c, h**2 * cov).pdf(x) for c in prop.centres], axis=0
    )
    tail = stats.multivariate_t(prop.centres.mean(axis=0), 1.5**2 * cov, df=5).pdf(x)
    np.testing.assert_allclose(np.exp(prop.log_density(x)), 0.9 * kernels + 0.1 * tail, rtol=1e-6)
    # an independence move: the correction is log q(x) - log q(x'), whatever x is
    q, corr = prop(x, np.random.RandomState(2))
    np.testing.assert_allclose(corr, prop.log_density(x) - prop.log_density(q), rtol=1e-12)
    # and its proposals follow q: their mean is the centres' (the kernels are centred)
    many, _ = prop(np.zeros((40000, 3)), np.random.RandomState(3))
    sd = np.sqrt(np.diag(cov))
    assert np.all(np.abs(many.mean(axis=0) - prop.centres.mean(axis=0)) < 0.05 * sd)


def test_student_t_normalising_constant():
    cov = np.array([[2.0, 0.3], [0.3, 0.5]])
    t = StudentTProposal([1.0, -1.0], cov, nu=5.0, scale=1.2)
    x = np.array([[0.0, 0.0], [1.0, -1.0], [3.0, 2.0]])
    ref = stats.multivariate_t([1.0, -1.0], 1.2**2 * cov, df=5).logpdf(x)
    np.testing.assert_allclose(t.log_density(x) + t.log_norm, ref, rtol=1e-12)


def test_the_predict_nothing_mode_is_gone(monkeypatch):
    """constant_width on B.3: the least-squares optimum against the point an earlier report's
    chain converged to (k = 0.35 H, b = 0.12 A: every row inside the dead band, DF = 0).
    With the phase error measured on the predicted DF that point fitted every phase, and
    with the magnitude scale free up to 1 it had the higher posterior (by 25 log units).
    Measured on the measured |D|, with a zero DF's phase error that of a random phase, it
    lies far below, with the magnitude box at 0.3 or at 1."""
    import fitdf.inference.noise as noise_module
    from fitdf.inference.api import resolve_geometry

    rows = resolve_data("B.3", "default", None)
    problem = FitProblem(rows, "constant_width", "voltage", geometry=resolve_geometry("auto", rows))
    lsq_point = {"k": 49.264, "b": 1.0548e-4, "c": 0.041379, "r_series": 53.296, "gain": 0.95310}
    nothing = {"k": 0.34898, "b": 0.12072, "c": 0.0090893, "r_series": 54.825, "gain": 1.1913}
    X = np.array([problem.to_internal(v) for v in (lsq_point, nothing)])
    assert np.all(problem.predict(X[1]) == 0) and np.abs(problem.predict(X[0])).min() > 0.1
    fitted, degenerate = LogPosterior(problem, marginal_noise=True)(X)
    assert fitted - degenerate > 150
    monkeypatch.setattr(noise_module, "NOISE_BOUNDS", np.array([[-3.0, 0.0], [-1.0, np.log10(50)]]))
    fitted, degenerate = LogPosterior(problem, marginal_noise=True)(X)
    assert fitted - degenerate > 150
    # the former residual, |M| sin(dphi) on the predicted DF, is what made it a mode
    D = problem.data.measured
    monkeypatch.setattr(
        FitProblem,
        "error_components",
        lambda self, M: (
            (M * np.conj(D / np.abs(D))).real - np.abs(D),
            (M * np.conj(D / np.abs(D))).imag,
        ),
    )
    fitted, degenerate = LogPosterior(problem, marginal_noise=True)(X)
    assert degenerate > fitted + 20


def test_error_components_are_magnitude_and_phase():
    """The two residual parts are |M| - |D| and |D| (arg M - arg D), wrapped; a zero DF
    misses the phase by pi/sqrt(3), a zero measurement has no phase part."""
    from fitdf.inference.api import resolve_geometry
    from fitdf.inference.problem import UNDEFINED_PHASE_ERROR

    rows = resolve_data("B.3", "default", None)
    problem = FitProblem(rows, "constant_width", "voltage", geometry=resolve_geometry("auto", rows))
    D = problem.data.measured
    rng = np.random.default_rng(0)
    dphi = rng.uniform(-3.1, 3.1, D.size)
    gain = rng.uniform(0.5, 1.5, D.size)
    M = D * gain * np.exp(1j * dphi)
    mag, arc = problem.error_components(M)
    np.testing.assert_allclose(mag, (gain - 1) * np.abs(D), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(arc, np.abs(D) * dphi, rtol=1e-10)
    # 3 rad ahead and 3 rad behind are the same distance from pi: wrapped, not 6 rad apart
    _, a = problem.error_components(D * np.exp(1j * 3.5))
    np.testing.assert_allclose(a, np.abs(D) * (3.5 - 2 * np.pi), rtol=1e-10)
    _, a = problem.error_components(np.zeros_like(D))
    np.testing.assert_allclose(a, np.abs(D) * UNDEFINED_PHASE_ERROR, rtol=1e-12)
    # against the first-order split along the measured phasor, for small errors
    small = (
        D * (1 + 1e-4 * rng.standard_normal(D.size)) * np.exp(1e-4j * rng.standard_normal(D.size))
    )
    u = D / np.abs(D)
    mag, arc = problem.error_components(small)
    e = (small - D) * np.conj(u)
    np.testing.assert_allclose(mag, e.real, atol=1e-7 * np.abs(D).max())
    np.testing.assert_allclose(arc, e.imag, atol=1e-7 * np.abs(D).max())


def test_noise_scale_against_its_cap_is_named():
    """A noise scale whose draws pile up at a bound of NOISE_BOUNDS is reported (the
    magnitude's cap: the law gives up its magnitudes); one inside the box is not."""
    from fitdf.inference.caveats import noise_bound_warnings

    rng = np.random.default_rng(0)
    (m_lo, m_hi), (p_lo, p_hi) = NOISE_BOUNDS
    inside = np.column_stack([rng.uniform(-2.0, -1.5, 4000), rng.uniform(0.0, 0.5, 4000)])
    assert noise_bound_warnings(inside) == []
    # 5 % of the magnitude draws within 1 % of the box from its upper bound 0.3
    at_cap = inside.copy()
    at_cap[:200, 0] = m_hi - 0.005 * (m_hi - m_lo)
    (w,) = noise_bound_warnings(at_cap)
    assert "sigma_magnitude runs into its upper bound 0.3" in w and "gives up its magnitudes" in w
    assert "5 % of the draws" in w
    # 2 % is below the rule's 2.5 %
    at_cap[80:200, 0] = -1.8
    assert noise_bound_warnings(at_cap) == []
    # the phase scale at its lower bound 0.1 degree
    low = inside.copy()
    low[:400, 1] = p_lo + 0.001
    (w,) = noise_bound_warnings(low)
    assert "sigma_phase_deg runs into its lower bound 0.1" in w
