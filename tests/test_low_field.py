"""Low-field behaviour: the laws against Rayleigh's law, and the Preisach-Rayleigh law.

* The Rayleigh population's Everett function against the double integral of its density,
  its closed-form describing function against the Fourier integral of its loop, and the
  whole law's describing function against the numerical referee.
* Low-field slopes against Rayleigh's closed form (eq 3.7): the new law's, today's Gaussian
  Preisach (Rayleigh only below ~``sigma_c^2 i_c``, its constant exponentially small) and
  Jiles-Atherton (linear in ``A`` but with ``-Im N / (Re N - L0) = 1``, not ``4/(3 pi)``).
* The exact ``voltage`` chain with the new law against backward Euler through the same
  circuit (``tests/test_voltage_chain.py``'s reference) to 1e-4.
* Recovery of known parameters from data made by the referee (slow).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from referee import referee_row, reference_backward_euler
from scipy.integrate import dblquad

import fitdf
from fitdf.chains import VoltageChain
from fitdf.models import ADDITIONAL_MODELS, get_model, law_name, model_names
from fitdf.models.low_field import RAYLEIGH_RATIO, ja_low_field, rayleigh_slopes
from fitdf.models.preisach import rayleigh_constant as gaussian_gamma
from fitdf.models.preisach_rayleigh import (
    PreisachRayleigh,
    rayleigh_constant,
    rayleigh_everett,
    rayleigh_population_branch,
    rayleigh_population_df,
)
from fitdf.models.rayleigh import rayleigh_describing_function
from fitdf.numerical_df import numerical_describing_function

#: Permalloy-like (the report's B.3 Preisach fit with a Rayleigh population) and
#: Deltamax-like (a square Gaussian density, a reversible part saturating at ~26 uA).
THETA = {
    "round": dict(
        lambda_s=0.0377, i_c=3.2e-4, sigma_c=0.32, i_i=9.4e-5, l_rev=6.5, f_rev=0.095,
        f_ray=0.1, i_ray=3e-4,
    ),
    "square": dict(
        lambda_s=0.023, i_c=3.1e-4, sigma_c=0.08, i_i=7e-5, l_rev=2.8, f_rev=0.005,
        f_ray=0.02, i_ray=2e-4,
    ),
}  # fmt: skip
AMPS = np.array([1e-7, 1e-5, 1e-4, 2e-4, 5e-4, 1e-3, 3e-3, 5e-2])


# ---------------------------------------------------------------- the Rayleigh population
@pytest.mark.parametrize(
    "alpha, beta", [(1e-4, -3e-4), (5e-4, 2e-4), (-1e-4, -6e-4), (1e-3, -1e-3)]
)
def test_rayleigh_everett_is_the_density_integral(alpha, beta):
    s = 2e-4
    q = lambda b, a: math.exp(-(a * a + b * b) / (2 * s * s)) / (math.pi * s * s)  # noqa: E731
    ref, _ = dblquad(q, beta, alpha, lambda a: beta, lambda a: a, epsabs=1e-13, epsrel=1e-11)
    assert rayleigh_everett(alpha, beta, i_ray=s) == pytest.approx(ref, rel=1e-9, abs=1e-14)
    assert rayleigh_everett(beta, alpha, i_ray=s) == 0.0  # alpha <= beta: no relay
    assert rayleigh_everett(np.inf, -np.inf, i_ray=s) == 1.0  # unit mass


def test_population_branch_closes_and_is_odd():
    A, s = 3e-4, 2e-4
    assert rayleigh_population_branch(A, A, i_ray=s) == pytest.approx(
        -rayleigh_population_branch(-A, A, i_ray=s), rel=1e-14
    )
    x = np.linspace(-A, A, 101)
    assert np.all(np.diff(rayleigh_population_branch(x, A, i_ray=s)) > 0)


# a = A / i_ray across the series' switch (0.02), the Rayleigh region and saturation
@pytest.mark.parametrize("a", [1e-3, 0.0199, 0.0201, 0.3, 1.0, 5.0, 100.0])
def test_population_df_is_the_fourier_integral_of_its_loop(a):
    s = 2e-4
    N = rayleigh_population_df(a * s, i_ray=s)
    ref = numerical_describing_function(
        lambda x, amp, f=0.0: rayleigh_population_branch(x, amp, i_ray=s), a * s, n_points=2**15
    )
    assert abs(N - ref) <= 1e-9 * abs(ref), (N, ref)
    assert N.imag < 0  # relay loops run anticlockwise only


def test_population_df_down_to_zero_amplitude_is_rayleighs():
    """Down to underflow (the current solver tries 1e-44 A and less) the closed form is
    Rayleigh's ``gamma_R A (1 - 4j / (3 pi))``, ``gamma_R = 2 / (pi i_ray^2)`` per unit flux,
    without a division by ``A^2`` or a ``Phi(a) - 1/2`` that rounds to 0."""
    s = 1.5e-4
    A = np.array([1e-300, 1e-44, 1e-20, 1e-12])
    expected = 2 / (math.pi * s * s) * A * (1 - 1j * RAYLEIGH_RATIO)
    np.testing.assert_allclose(rayleigh_population_df(A, i_ray=s), expected, rtol=1e-12)
    assert rayleigh_population_df(0.0, i_ray=s) == 0.0


@pytest.mark.parametrize("name", list(THETA))
def test_law_df_matches_the_numerical_referee(name):
    th = THETA[name]
    N = PreisachRayleigh.describing_function(AMPS, **th)
    ref = PreisachRayleigh.numerical_describing_function(AMPS, n_points=2**15, **th)
    assert np.max(np.abs(N - ref) / np.abs(ref)) < 1e-7
    assert PreisachRayleigh.describing_function(0.0, **th) == th["l_rev"]


def test_law_reduces_to_preisach_without_the_population():
    th = dict(THETA["round"], f_ray=0.0)
    pre = {k: v for k, v in th.items() if k not in ("f_ray", "i_ray")}
    P = get_model("preisach")
    np.testing.assert_allclose(
        PreisachRayleigh.describing_function(AMPS, **th),
        P.describing_function(AMPS, **pre),
        rtol=1e-13,
    )
    x = np.linspace(-1e-3, 1e-3, 7)
    np.testing.assert_allclose(
        PreisachRayleigh.ascending_branch(x, 1e-3, **th),
        P.ascending_branch(x, 1e-3, **pre),
        rtol=1e-13,
        atol=1e-17,
    )


# ---------------------------------------------------------------- against Rayleigh's law
@pytest.mark.parametrize("name", list(THETA))
def test_low_field_slopes_are_rayleighs(name):
    """Below the scales of both populations the law is eq 3.7 with ``mu0 = l_rev`` and
    :func:`rayleigh_constant`; at ``A = i_ray`` it has left Rayleigh's region. (The
    reversible arctangent's in-phase part falls as ``l_rev A^2 / (4 i_r^2)``, 1.4 % of
    ``gamma A`` at 0.1 uA on the square loop: hence nA.)"""
    th = THETA[name]
    gamma = rayleigh_constant(**th)
    A = np.array([1e-9, 3e-9])
    s = rayleigh_slopes(PreisachRayleigh, A, **th)
    assert s["mu_i"] == pytest.approx(th["l_rev"], rel=1e-12)
    np.testing.assert_allclose(s["in_phase"], gamma, rtol=2e-3)
    np.testing.assert_allclose(s["quadrature"], gamma, rtol=2e-3)
    np.testing.assert_allclose(s["ratio"], RAYLEIGH_RATIO, rtol=3e-3)
    N = PreisachRayleigh.describing_function(A, **th)
    ray = rayleigh_describing_function(A, th["l_rev"], gamma)
    assert np.max(np.abs(N - ray) / np.abs(ray)) < 1e-4
    # the population's share, alone: gamma_R = 2 lambda_R / (pi i_ray^2)
    lam_r = (1 - th["f_rev"]) * th["f_ray"] * th["lambda_s"]
    without = rayleigh_constant(**dict(th, f_ray=0.0))
    assert gamma - (1 - th["f_ray"]) * without == pytest.approx(
        2 * lam_r / (math.pi * th["i_ray"] ** 2), rel=1e-12
    )
    end = rayleigh_slopes(PreisachRayleigh, np.array([th["i_ray"]]), **th)
    assert abs(end["quadrature"][0] / gamma - 1) > 0.1


def test_gaussian_preisach_is_rayleigh_only_below_sigma_c_squared_i_c():
    """Today's Preisach: the density at the origin is ``~exp(-1/(2 sigma_c^2))`` of a flat
    one and changes by ``e`` over ``sigma_c^2 i_c``; its loss follows Rayleigh's constant
    well below that and leaves it (rising exponentially) by ``A ~ sigma_c^2 i_c``."""
    P = get_model("preisach")
    th = {k: v for k, v in THETA["round"].items() if k not in ("f_ray", "i_ray")}
    gamma = gaussian_gamma(**th)
    flat = (
        (1 - th["f_rev"])
        * th["lambda_s"]
        * 2
        / (math.sqrt(2 * math.pi) * th["sigma_c"] * th["i_c"])
        / (math.sqrt(2 * math.pi) * th["i_i"])
    )  # f(0) g(0) without the Gaussian factor
    assert gamma / flat == pytest.approx(
        math.exp(-0.5 / th["sigma_c"] ** 2) / (2 * 0.5 * math.erfc(-1 / (th["sigma_c"] * 2**0.5))),
        rel=1e-12,
    )
    scale = th["sigma_c"] ** 2 * th["i_c"]
    low = rayleigh_slopes(P, np.array([1e-3 * scale]), **th)
    assert low["quadrature"][0] == pytest.approx(gamma, rel=1e-2)
    high = rayleigh_slopes(P, np.array([scale, 10 * scale]), **th)
    assert high["quadrature"][0] > 1.1 * gamma and high["quadrature"][1] > 3 * gamma


@pytest.mark.parametrize(
    "th",
    [
        dict(lambda_s=0.044, a=3.6e-4, k=8.7e-4, c=0.16, zeta=0.9),
        dict(lambda_s=0.05, a=4.3e-4, k=2.1e-4, c=0.3, zeta=0.5),
    ],
)
def test_jiles_atherton_small_loops_are_linear_but_twice_as_lossy_as_rayleigh(th):
    JA = get_model("jiles_atherton")
    L0, g = ja_low_field(**th)
    A = np.array([1e-4, 3e-4]) * th["k"]
    N = JA.describing_function(A, **th)
    np.testing.assert_allclose(N.real, L0 + g * A, rtol=2e-6)
    np.testing.assert_allclose(-N.imag, g * A, rtol=2e-3)
    s = rayleigh_slopes(JA, A, **th)
    np.testing.assert_allclose(s["ratio"], 1.0, rtol=3e-3)  # Rayleigh: 0.424
    assert s["mu_i"] == pytest.approx(L0, rel=1e-8)


# ---------------------------------------------------------------- the exact circuit
@pytest.mark.parametrize("V, f, Rs", [(0.1, 6.0, 600.0), (0.05, 3.0, 0.0), (1.0, 10.0, 600.0)])
def test_voltage_chain_matches_backward_euler_through_the_circuit(V, f, Rs):
    th = THETA["round"]
    theta = [th[n] for n in PreisachRayleigh.param_names()]
    r_series = 80.0
    op = VoltageChain.operating_point(PreisachRayleigh, V, f, Rs, theta, [r_series, 1.0])
    ref, I = reference_backward_euler(PreisachRayleigh, theta, V, f, Rs + r_series, op.current[0])
    assert abs(op.df[0] - ref) <= 1e-4, (op.df[0], ref)
    assert abs(op.current[0] / I - 1) <= 1e-4


# ---------------------------------------------------------------- registry
def test_available_by_name_but_not_a_default_law():
    assert "preisach_rayleigh" not in model_names()
    assert ADDITIONAL_MODELS["preisach_rayleigh"] is PreisachRayleigh
    assert get_model("Preisach_Rayleigh") is PreisachRayleigh
    assert law_name("PREISACH_RAYLEIGH") == "preisach_rayleigh"


# ---------------------------------------------------------------- recovery
TRUTH = dict(
    lambda_s=0.038, i_c=4e-4, sigma_c=0.2, i_i=6e-5, l_rev=6.0, f_rev=0.1, f_ray=0.15,
    i_ray=1.5e-4,
)  # fmt: skip
CHAIN = {"r_series": 60.0, "gain": 0.95}
#: Down to 0.02 V: at 600 ohm the current then reaches ~0.03 i_ray, the Rayleigh region.
INPUTS = np.array([0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0])


@pytest.mark.slow
def test_winding_fit_recovers_the_law_from_referee_data():
    rng = np.random.default_rng(7)
    frame = pd.DataFrame(
        [
            referee_row("preisach_rayleigh", TRUTH, CHAIN, v, f, rs, rng)
            for rs in (0.0, 600.0)
            for f in (3.0, 6.0, 10.0)
            for v in INPUTS
        ]
    )
    result = fitdf.fit(
        frame, "preisach_rayleigh", chain="winding", policy="all", seed=3, geometry=None
    )
    truth = {**TRUTH, **CHAIN}
    for name in result.problem.names:
        iv = result.intervals[name]
        half = 0.5 * (iv["p84"] - iv["p16"])
        assert abs(result.values[name] - truth[name]) <= 3.29 * half, (name, result.values, iv)
    assert result.metrics["rms_magnitude"] < 0.008
    assert result.metrics["rms_phase_deg"] < 1.0
    # the low-field constants themselves
    fitted = {k: result.values[k] for k in PreisachRayleigh.param_names()}
    assert rayleigh_constant(**fitted) == pytest.approx(rayleigh_constant(**TRUTH), rel=0.1)
