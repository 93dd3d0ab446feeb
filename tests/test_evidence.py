"""The evidence's dependence on the prior box (fitdf.inference.evidence): the box scaled in
internal coordinates, the evidence of a sub-box from the posterior's draws against a closed
form, and the Occam factor a well-determined posterior shows under it."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.special import ndtr
from synthetic import mcmc_problem
from test_nested import R_PRIOR, SMALL, SPECS, gaussian_log_evidence, gaussian_loglike, stub_problem

import fitdf.inference.evidence as evidence
from fitdf.inference.api import resolve_data
from fitdf.inference.evidence import prior_sensitivity, restricted_log_evidence
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.nested import (
    PriorTransform,
    fit_nested,
    run_nautilus,
    systematic_resample,
)
from fitdf.inference.problem import FitProblem
from fitdf.models import model_names
from fitdf.report.upgrade import read_results

COMMITTED = Path(__file__).resolve().parents[1] / "reports" / "results.json"


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


def _sub_box_prior(bounds):
    """The prior of ``SPECS`` (``r`` log-normal) on an internal box ``bounds`` ``(P, 2)``."""
    stub = stub_problem(SPECS, {"r": R_PRIOR})
    stub.internal_bounds = lambda: np.asarray(bounds, float)
    return PriorTransform(stub)


def test_a_sub_box_evidence_from_the_posteriors_draws_matches_its_closed_form():
    """A Gaussian likelihood under a uniform, a log-uniform and a truncated-normal prior; the
    sub-box cuts the first Gaussian at its mean and the third's tail, and narrows the
    truncated normal's box (so its normalisation changes). The evidence restricted from the
    full box's draws matches the sub-box's closed form within three of its errors, and
    the share inside within three binomial errors."""
    full = PriorTransform(stub_problem(SPECS, {"r": R_PRIOR}))
    mean, sd = np.array([0.4, 0.7, 2.1]), np.array([0.05, 0.1, 0.08])
    sub_bounds = np.array([[0.4, 1.5], [0.0, 1.5], [1.8, 2.2]])
    sub = _sub_box_prior(sub_bounds)
    ns, error, *_ = run_nautilus(full, gaussian_loglike(mean, sd), 3, seed=0, **SMALL)
    points, log_w, _ = ns.posterior()
    w = np.exp(log_w - log_w.max())
    draws = points[systematic_resample(w / w.sum(), 4000, np.random.default_rng(0))]
    log_z, shift_error, share = restricted_log_evidence(ns.log_z, draws, ns.n_eff, full, sub)

    truth = gaussian_log_evidence(sub_bounds, {2: R_PRIOR}, mean, sd)
    truth_full = gaussian_log_evidence(full.bounds, {2: R_PRIOR}, mean, sd)
    sigma = math.hypot(error, shift_error)
    assert 0.02 < shift_error < 0.1
    assert abs(log_z - truth) <= 3 * sigma, (log_z, truth, sigma)
    # the share: the posterior's mass in the sub-box, a product of normal masses (the third
    # parameter's posterior is the product of likelihood and prior normals)
    v = 1.0 / (1.0 / sd[2] ** 2 + 1.0 / R_PRIOR[1] ** 2)
    mu, w2 = v * (mean[2] / sd[2] ** 2 + R_PRIOR[0] / R_PRIOR[1] ** 2), math.sqrt(v)
    mass = [
        (ndtr((b - m) / s) - ndtr((a - m) / s)) / (ndtr((B - m) / s) - ndtr((A - m) / s))
        for (a, b), (A, B), m, s in zip(sub_bounds, full.bounds, [*mean[:2], mu], [*sd[:2], w2])
    ]
    expected_share = float(np.prod(mass))
    assert 0.3 < expected_share < 0.6
    assert abs(share - expected_share) <= 3 * math.sqrt(share * (1 - share) / ns.n_eff)
    # and the identity: the restricted evidence is the full one times the share over the
    # prior mass ratio, so its shift from the full closed form is the share's logarithm plus
    # the ratio of the densities
    assert truth - truth_full == pytest.approx(
        math.log(expected_share)
        + float(sub.log_density(sub_bounds.mean(axis=1)[None])[0])
        - float(full.log_density(sub_bounds.mean(axis=1)[None])[0]),
        abs=1e-9,
    )
    with pytest.raises(ValueError, match="not inside"):
        restricted_log_evidence(ns.log_z, draws, ns.n_eff, sub, full)


class _Posterior:
    """What :func:`prior_sensitivity` reads of a nested fit: its problem, best point, draws
    and diagnostics."""

    def __init__(self, problem, internal, draws):
        self.problem, self.internal = problem, internal
        self.samples = draws[:, None, :]
        self.diagnostics = {
            "log_evidence": -10.0,
            "log_evidence_error": 0.05,
            "n_effective": 800.0,
            "converged": True,
        }


def test_the_halved_box_is_restricted_from_the_draws_or_sampled_when_few_fall_inside(
    monkeypatch,
):
    """Draws about the best point: the halved box holds them all and needs no sampling
    (shift: ln 2 per uniform dimension, the prior density doubling there); draws far from
    it: too few inside, so the halved box is sampled, as the doubled one always is."""
    problem = mcmc_problem()
    lo, hi = problem.internal_bounds().T
    centre = 0.5 * (lo + hi)
    rng = np.random.default_rng(0)
    sampled = []

    def fake_fit(prob, lsq, seed=0, **options):
        """A run whose draws all sit at the old box's centre, with ``ln Z = -10 + gap``."""
        sampled.append(prob.internal_bounds())
        return SimpleNamespace(
            diagnostics={
                "log_evidence": -10.0 + gap,
                "log_evidence_error": 0.07,
                "converged": True,
                "n_effective": 500.0,
                "n_likelihood_evaluations": 3000,
                "seconds": 12.5,
            },
            samples=np.repeat(centre[None, None], 600, axis=0),
        )

    monkeypatch.setattr(evidence, "fit_nested", fake_fit)
    near = centre + 0.01 * (hi - lo) * rng.standard_normal((2000, lo.size))
    prior, sub = PriorTransform(problem), PriorTransform(problem.with_box_scaled(0.5, centre))
    wide = PriorTransform(problem.with_box_scaled(2.0))
    occam_half = float(sub.log_density(centre[None])[0] - prior.log_density(centre[None])[0])
    occam_double = float(wide.log_density(centre[None])[0] - prior.log_density(centre[None])[0])
    uniform = len(problem.names) - len(problem.priors)
    assert occam_half > (uniform - 0.5) * math.log(2)  # ln 2 per uniform dimension, and more
    assert occam_double < 0

    gap = occam_double  # the wider run agrees with the bound: all its draws inside the old box
    s = prior_sensitivity(_Posterior(problem, centre, near), lsq=None, seed=3)
    half, double = s["boxes"]
    assert half["estimate"] == "restricted" and half["posterior_share"] == 1.0
    assert half["shift"] == pytest.approx(occam_half, abs=1e-12) and half["shift_error"] == 0.0
    # no draw of the wider run outside the old box: the shift is the Occam factor, exactly
    assert double["estimate"] == "widened" and double["consistent"] and double["converged"]
    assert double["shift"] == pytest.approx(occam_double, abs=1e-12)
    assert double["shift_error"] == 0.0 and double["share_outside"] == 0.0
    assert double["sampled_log_evidence"] == -10.0 + occam_double
    # what the run cost, for the report's cost table (its posterior's seconds told apart)
    assert double["seconds"] == 12.5 and double["n_likelihood_evaluations"] == 3000
    assert len(sampled) == 1
    np.testing.assert_allclose(
        sampled[0], problem.with_box_scaled(2.0).internal_bounds(), rtol=1e-12
    )

    # three draws of 2000 in the half box about the best point: its share's error is above
    # 0.3, so it is sampled; a wider run 5 nats below the bound missed the posterior
    far = np.repeat(lo[None] + 0.02 * (hi - lo), 2000, axis=0)
    far[:3] = centre
    gap = occam_double - 5.0
    s = prior_sensitivity(_Posterior(problem, centre, far), lsq=None, seed=3)
    assert [b["estimate"] for b in s["boxes"]] == ["sampled", "widened"]
    assert len(sampled) == 3
    double = s["boxes"][1]
    assert not double["consistent"] and not double["converged"]
    assert double["lower_bound"] == pytest.approx(-10.0 + occam_double)
    assert double["log_evidence"] >= double["lower_bound"]


def test_a_widened_box_evidence_is_stratified_and_matches_its_closed_form():
    """A Gaussian likelihood that the prior's box cuts (the first mean 0.1 from its upper edge
    at 2, sd 0.08) and a box twice as wide in that parameter: the part inside the old box
    is exact from its evidence, the part outside comes from the wider run's draws; the sum
    matches the wider box's closed form within three of its errors, and a wider run that
    reports an evidence far below the part inside is not consistent."""
    mean, sd = np.array([1.9, 0.7, 2.1]), np.array([0.08, 0.1, 0.08])
    full = PriorTransform(stub_problem(SPECS, {"r": R_PRIOR}))
    wide_bounds = full.bounds.copy()
    wide_bounds[0] = [-1.0, 5.0]
    wide = _sub_box_prior(wide_bounds)
    loglike = gaussian_loglike(mean, sd)
    ns, error, *_ = run_nautilus(full, loglike, 3, seed=0, **SMALL)
    nw, wide_error, *_ = run_nautilus(wide, loglike, 3, seed=1, **SMALL)
    points, log_w, _ = nw.posterior()
    w = np.exp(log_w - log_w.max())
    draws = points[systematic_resample(w / w.sum(), 4000, np.random.default_rng(0))]
    out = evidence.widened_log_evidence(
        ns.log_z, error, full, wide, nw.log_z, wide_error, draws, nw.n_eff
    )
    truth = gaussian_log_evidence(wide_bounds, {2: R_PRIOR}, mean, sd)
    truth_in = gaussian_log_evidence(full.bounds, {2: R_PRIOR}, mean, sd) + math.log(3 / 6)
    # the posterior's share outside the old box: the normal's tail beyond 2
    tail = float(1 - ndtr((2.0 - mean[0]) / sd[0]))
    assert 0.05 < tail < 0.2
    assert abs(out["share_outside"] - tail) <= 3 * math.sqrt(tail * (1 - tail) / nw.n_eff)
    assert out["lower_bound"] == pytest.approx(ns.log_z + math.log(0.5), abs=1e-12)
    assert abs(out["lower_bound"] - truth_in) <= 3 * error
    assert out["consistent"] and 0 < out["log_evidence_error"] < 0.1
    assert abs(out["log_evidence"] - truth) <= 3 * out["log_evidence_error"], (out, truth)
    missed = evidence.widened_log_evidence(
        ns.log_z, error, full, wide, ns.log_z - 20, wide_error, draws, nw.n_eff
    )
    assert not missed["consistent"] and missed["log_evidence"] >= missed["lower_bound"]
    with pytest.raises(ValueError, match="does not hold"):
        evidence.widened_log_evidence(ns.log_z, error, wide, full, 0.0, 0.1, draws, nw.n_eff)


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


# ------------------------------------------------------------------ the records' invariant
def _record(**box):
    """A sensitivity record of the prior's ``ln Z = 100`` with one doubled box: by default
    stratified, 10 uniform parameters (bound ``100 - 10 ln 2``), its run on the bound."""
    least = 100.0 - 10 * math.log(2)
    out = {"factor": 2.0, "estimate": "widened", "lower_bound": least, "log_evidence": least,
           "shift": least - 100.0, "consistent": True, "converged": True}  # fmt: skip
    out.update(box)
    return {"log_evidence": 100.0, "log_evidence_error": 0.05, "boxes": [out]}


def test_no_record_claims_a_shift_its_wider_box_cannot_give():
    """A doubled box of P uniform parameters lowers ln Z by at most P ln 2: its stratified
    evidence is never below the part inside the prior's box, and a run that missed that
    part is not converged. The committed report once held a doubled box of Deltamax's
    cubic law (10 parameters) shifted by -31.2 and marked converged, from before the
    stratified estimate: such a record is refused."""
    violations = evidence.sensitivity_violations
    assert violations(_record()) == []  # on the bound: allowed
    old = _record(estimate="sampled", lower_bound=None, shift=-31.2, log_evidence=68.8)
    assert violations(old) == ["box x2: not stratified (estimate 'sampled', no lower bound)"]
    low = 100.0 - 10 * math.log(2) - 1e-6  # a shift of -6.93 less a millionth: too far
    below = violations(_record(log_evidence=low, shift=low - 100.0))
    assert [v.split(":")[1].split()[:2] for v in below] == [["ln", "Z"], ["shift", "-6.93147"]]
    assert "below its bound" in below[0] and "below the least the box allows" in below[1]
    assert violations(_record(shift=-5.0)) == ["box x2: shift -5 is not ln Z - the prior's ln Z"]
    missed = _record(consistent=False)
    assert violations(missed) == ["box x2: converged although its run missed the posterior inside"]
    assert violations(_record(consistent=False, converged=False)) == []
    halved = _record(factor=0.5, estimate="restricted", lower_bound=None, shift=+20.0)
    assert violations(halved) == []  # a box inside the prior's: no bound from below


@pytest.mark.skipif(not COMMITTED.exists(), reason="no committed reports/results.json")
def test_the_committed_report_holds_no_doubled_box_from_before_the_stratified_estimate():
    """Every prior-sensitivity record of the committed report passes
    :func:`~fitdf.inference.evidence.sensitivity_violations` (fails until the report is
    regenerated: its doubled boxes were sampled before the stratified estimate)."""
    results = read_results(COMMITTED)
    wrong = {
        (key, law): evidence.sensitivity_violations(sens)
        for key, block in results["blocks"].items()
        for law, fit in block["fits_posterior"].items()
        if (sens := fit["diagnostics"].get("prior_sensitivity"))
    }
    assert {k: v for k, v in wrong.items() if v} == {}
