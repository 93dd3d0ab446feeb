"""The evidence's dependence on the prior box (fitdf.inference.evidence): the box scaled in
internal coordinates, and the Occam factor a well-determined posterior shows under it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from synthetic import mcmc_problem

from fitdf.inference.api import resolve_data
from fitdf.inference.evidence import prior_sensitivity
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.nested import fit_nested
from fitdf.inference.problem import FitProblem
from fitdf.models import model_names


def test_the_box_scales_in_internal_coordinates_about_its_centre_or_a_point():
    problem = mcmc_problem()
    lo, hi = problem.internal_bounds().T
    wide = problem.with_box_scaled(2.0)
    wlo, whi = wide.internal_bounds().T
    # doubled about the centre, up to a parameter's physical limits (the loop width m of
    # proportional_width stays in [0, 1]; the others have none)
    limit_lo, limit_hi = np.array([s.internal_limits() for s in problem.specs]).T
    free = np.isinf(limit_lo) & np.isinf(limit_hi)
    assert free.any() and not free.all()
    np.testing.assert_allclose(wlo, np.maximum(lo - 0.5 * (hi - lo), limit_lo), rtol=1e-12)
    np.testing.assert_allclose(whi, np.minimum(hi + 0.5 * (hi - lo), limit_hi), rtol=1e-12)
    np.testing.assert_allclose((whi - wlo)[free], 2 * (hi - lo)[free], rtol=1e-12)
    m = problem.names.index("m")
    assert (wlo[m], whi[m]) == (0.0, 1.0)
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
    """Every parameter determined well inside its box (no prior but the box): the evidence
    scales as the box's inverse volume, ln Z shifts by -ln(V'/V): halving the box adds ln 2
    per parameter, doubling takes ln 2 off per parameter it doubles (the loop width m stops
    at its limits 0 and 1, so its box grows by 1/0.99 only)."""
    problem = mcmc_problem()
    problem.priors.clear()  # the box alone: the Occam factor is exact
    lsq = fit_lsq(problem, seed=0, n_starts=2)
    result = fit_nested(problem, lsq, seed=1, n_live=500)
    assert result.diagnostics["converged"]
    s = prior_sensitivity(result, lsq, seed=1, n_live=500)
    lo, hi = problem.internal_bounds().T
    for box in s["boxes"]:
        f = box["factor"]
        scaled = problem.with_box_scaled(f, about=result.internal if f < 1 else None)
        slo, shi = scaled.internal_bounds().T
        expect = -float(np.sum(np.log((shi - slo) / (hi - lo))))
        error = math.hypot(box["log_evidence_error"], s["log_evidence_error"])
        assert abs(box["shift"] - expect) <= 3 * error + 0.05, (box, expect, error)


def test_a_widened_box_stays_inside_every_laws_physical_limits():
    """The doubled box of every law stops at its parameters' limits: Jiles-Atherton's
    reversible fraction c and mean-field ratio zeta stay in [0, 1] (beyond them its steady
    loop has no solution, and a solve there took 10-30 s), a loop width stays >= 0."""
    rows = resolve_data("B.4", "default", None)
    for law in model_names():
        problem = FitProblem(rows, law, "voltage", None, None, None)
        wide = problem.with_box_scaled(2.0)
        for s, (a, b) in zip(wide.specs, wide.internal_bounds()):
            low, high = s.internal_limits()
            assert low <= a < b <= high, (law, s.name, a, b)
            assert s.from_internal(a) >= (s.limits or (-np.inf,))[0], (law, s.name)
    ja = FitProblem(rows, "jiles_atherton", "voltage", None, None, None).with_box_scaled(2.0)
    bounds = {s.name: s.bounds for s in ja.specs}
    assert bounds["zeta"] == (0.0, 1.0) and bounds["c"][1] == pytest.approx(1.0)
