"""The evidence's dependence on the prior box (fitdf.inference.evidence): the box scaled in
internal coordinates, and the Occam factor a well-determined posterior shows under it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synthetic import mcmc_problem

from fitdf.inference.evidence import prior_sensitivity
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.nested import fit_nested


def test_the_box_scales_in_internal_coordinates_about_its_centre_or_a_point():
    problem = mcmc_problem()
    lo, hi = problem.internal_bounds().T
    wide = problem.with_box_scaled(2.0)
    wlo, whi = wide.internal_bounds().T
    np.testing.assert_allclose(whi - wlo, 2 * (hi - lo), rtol=1e-12)
    np.testing.assert_allclose(0.5 * (wlo + whi), 0.5 * (lo + hi), rtol=1e-12)
    # halved about a point near the lower edge: the half box stays inside the old one
    about = lo + 0.1 * (hi - lo)
    half = problem.with_box_scaled(0.5, about=about)
    hlo, hhi = half.internal_bounds().T
    np.testing.assert_allclose(hhi - hlo, 0.5 * (hi - lo), rtol=1e-12)
    np.testing.assert_allclose(hlo, lo, rtol=1e-12, atol=1e-12)
    assert problem.names == half.names and problem.priors == half.priors
    # a log parameter's box is one of decades: natural bounds 10^(internal bounds)
    i = next(k for k, s in enumerate(problem.specs) if s.log)
    assert half.specs[i].bounds[0] == pytest.approx(10 ** hlo[i], rel=1e-12)
    # the original is untouched
    np.testing.assert_array_equal(problem.internal_bounds().T, (lo, hi))


@pytest.mark.slow
def test_a_well_determined_posterior_shows_the_occam_factor():
    """Every parameter determined well inside its box (no prior but the box): halving the box
    multiplies the evidence by 2 per parameter, doubling divides it by 2 (ln Z -+ d ln 2)."""
    problem = mcmc_problem()
    problem.priors.clear()  # the box alone: the Occam factor is exact
    lsq = fit_lsq(problem, seed=0, n_starts=2)
    result = fit_nested(problem, lsq, seed=1, n_live=500)
    assert result.diagnostics["converged"]
    s = prior_sensitivity(result, lsq, seed=1, n_live=500)
    d = problem.ndim
    for box in s["boxes"]:
        expect = -d * math.log(box["factor"])
        error = math.hypot(box["log_evidence_error"], s["log_evidence_error"])
        assert abs(box["shift"] - expect) <= 3 * error + 0.05, (box, expect, error)
