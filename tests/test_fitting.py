"""Least-squares fitting: parameter recovery from synthetic data, determinism, row policy, errors."""

import copy

import numpy as np
import pandas as pd
import pytest
from synthetic import synthetic_frame

import fitdf
from fitdf.errors import DataError, ModelError, OptionError
from fitdf.inference.api import DEFAULT_CHAIN, resolve_data
from fitdf.inference.mcmc import fit_mcmc
from fitdf.inference.problem import FitProblem

CHAIN = {"r_series": 100.0, "gain": 0.95}

#: True parameters per model (Permalloy-like magnitudes) and parameters held fixed in the
#: recovery test because the synthetic amplitude range cannot identify them.
TRUTH = {
    "constant_width": ({"k": 80.0, "b": 2e-4, "c": 0.04}, {}),
    "proportional_width": ({"k": 60.0, "c": 0.035, "m": 0.3}, {}),
    "proportional_width_fig42": ({"k": 60.0, "c": 0.035, "m": 0.3}, {}),
    "rayleigh": ({"mu0": 20.0, "gamma": 8e4, "c_sat": 0.038}, {}),
    "frequency_hc": ({"k": 60.0, "c": 0.035, "m": 0.25, "hc_a": 8e-6, "hc_b": 2e-7}, {}),
    # eq 4.8's alpha = 0.5, beta = 1e6 A^-2, h0 = 2e-5 A in CubicHc's coordinates
    "cubic_hc": (
        {
            "k": 60.0,
            "c": 0.035,
            "h1": 4e-4,
            "m1": 0.315,
            "tail_slope": 0.05,
            "h0_ratio": 0.05,
            "bend": 0.64 / 1.9,
        },
        {"h0_ratio": 0.05, "h1": 4e-4, "tail_slope": 0.05},
    ),
}

#: CubicHc's width-law coordinates (its parameters other than k and c).
LAW = ("h1", "m1", "tail_slope", "h0_ratio", "bend")


def synthetic(model, seed=0, chain=DEFAULT_CHAIN):
    values, _ = TRUTH[model]
    return synthetic_frame(
        model, {**values, **CHAIN}, chain=chain, source_impedances=(0.0, 600.0), seed=seed
    )


#: The exact chain's DF moves in steps of ~1e-6 as its tables shift with the parameters
#: (fitdf.inference.lsq.DIFF_STEP): least squares recovers the laws through it, but the
#: covariance of a 7-parameter law with weakly determined terms (frequency_hc) comes out too
#: narrow there, so every law is checked through the smooth winding chain and the laws
#: below through the exact one too.
RECOVERY_CASES = [(m, "winding") for m in TRUTH] + [
    (m, "voltage") for m in ("constant_width", "proportional_width", "rayleigh")
]


@pytest.mark.parametrize(("model", "chain"), RECOVERY_CASES)
def test_least_squares_recovers_known_parameters(model, chain):
    values, fixed = TRUTH[model]
    result = fitdf.fit(
        synthetic(model, chain=chain), model, chain=chain, policy="all", seed=3, fixed=fixed
    )
    truth = {**values, **CHAIN}
    for name in result.problem.names:
        iv = result.intervals[name]
        # one noise draw: the truth within 3.29 standard errors (a 99.9 % interval), so only a
        # real error fails; the 95 % coverage over many draws is a slow test
        # (tests/test_recovery_independent.py)
        half = 0.5 * (iv["p84"] - iv["p16"])
        assert abs(result.values[name] - truth[name]) <= 3.29 * half, (name, truth[name], iv)
        assert np.isfinite(result.stderr[name])
    # noise of 0.005 in magnitude and 0.5 deg in phase: the fit must reach that level
    assert result.metrics["rms_magnitude"] < 0.008
    assert result.metrics["rms_phase_deg"] < 1.0
    assert result.info["n_agree"] >= 2


def test_fit_is_deterministic_for_a_seed():
    frame = synthetic("proportional_width")
    # two random starts are enough to show it (six cost 21 s on 2 cores)
    a = fitdf.fit(frame, "proportional_width", policy="all", seed=5, n_starts=2)
    b = fitdf.fit(frame, "proportional_width", policy="all", seed=5, n_starts=2)
    assert a.values == b.values
    assert a.info["starts_chi2"] == b.info["starts_chi2"]


def test_fit_does_not_mutate_its_input():
    frame = synthetic("constant_width")
    before = frame.copy()
    fitdf.fit(frame, "constant_width", policy="all", seed=0)
    pd.testing.assert_frame_equal(frame, before)


def test_result_predict_matches_residual_table():
    frame = synthetic("constant_width")
    r = fitdf.fit(frame, "constant_width", policy="all", seed=0)
    rows = r.residuals
    pred = r.predict(rows["input_v"], rows["frequency_hz"], rows["source_impedance_ohm"])
    np.testing.assert_allclose(np.abs(pred), rows["df_predicted"], rtol=1e-12)
    np.testing.assert_allclose(
        np.angle(pred, deg=True), rows["phase_lead_predicted_deg"], atol=1e-9
    )
    d = r.to_dict()
    assert {p["parameter"] for p in d["parameters"]} == set(r.values)
    assert len(d["rows_used"]) == len(frame)
    assert "RMS complex" in r.summary()


def test_winding_fit_on_real_data_gives_leading_phase_and_reports_rows():
    r = fitdf.fit("B.3", "rayleigh", seed=0)
    used = r.residuals
    assert len(used) == r.metrics["n_points"]
    assert (used["table"] == "B.3").all()
    # the measured phase is a lead, and the winding chain reproduces that sign
    assert np.median(used["phase_lead_predicted_deg"]) > 0
    assert r.metrics["rms_complex"] < 0.2


def test_joint_fit_has_one_calibration_gain_per_table():
    # (the parameters do not depend on the chain: the cheap one, one start)
    r = fitdf.fit("permalloy", "proportional_width", chain="winding", seed=0, n_starts=1)
    gains = [n for n in r.problem.names if n.startswith("gain")]
    assert gains == ["gain[B.1]", "gain[B.3]"]
    assert set(r.residuals["source_impedance_ohm"]) == {0.0, 600.0}


def test_direct_chain_cannot_produce_a_lead():
    r = fitdf.fit("B.3", "constant_width", chain="direct", seed=0)
    assert (r.residuals["phase_lead_predicted_deg"] <= 1e-9).all()


def test_row_policy_changes_the_rows_used():
    default = resolve_data("B.3", "default")
    everything = resolve_data("B.3", "all")
    strict = resolve_data("B.3", "strict")
    assert strict.n <= default.n <= everything.n
    # B.3 f=10 prints an input of 0.01 V between rows of 0.25 V and up: excluded by default
    assert default.n < everything.n
    assert 0.01 not in default.amplitude and 0.01 in everything.amplitude


def test_source_impedance_selection_and_error():
    d = resolve_data("permalloy", source_impedance=600)
    assert set(d.source_impedance) == {600.0}
    with pytest.raises(OptionError, match="no rows at source impedance 50"):
        resolve_data("permalloy", source_impedance=50)


def test_bad_inputs_raise_clear_errors(tmp_path):
    with pytest.raises(ModelError, match="unknown law 'nope'"):
        fitdf.fit("B.3", "nope")
    with pytest.raises(ModelError, match="unknown"):
        fitdf.fit("B.3", "rayleigh", chain="nope")
    with pytest.raises(OptionError, match="unknown method"):
        fitdf.fit("B.3", "rayleigh", method="bayes")
    with pytest.raises(ModelError, match="cannot fix unknown parameter"):
        fitdf.fit("B.3", "rayleigh", fixed={"zz": 1.0})
    with pytest.raises(DataError):
        fitdf.fit(str(tmp_path / "missing.csv"), "rayleigh")


def test_bound_warning_when_parameter_pinned():
    frame = synthetic("proportional_width", chain="winding")
    r = fitdf.fit(frame, "frequency_hc", chain="winding", policy="all", seed=0)
    # hc_b (quadratic frequency term) is absent from proportional-width data: pinned at 0
    assert any("hc_b" in w and "bound" in w for w in r.warnings)


def test_batched_residuals_equal_looped():
    p = FitProblem(resolve_data("permalloy"), "cubic_hc", "winding")
    rng = np.random.default_rng(0)
    lo, hi = p.internal_bounds().T
    X = lo + (hi - lo) * rng.uniform(0.3, 0.7, size=(5, p.ndim))
    batch = p.weighted_residuals(X)
    looped = np.array([p.weighted_residuals(x) for x in X])
    np.testing.assert_allclose(batch, looped, rtol=1e-10, atol=1e-10)


def test_warm_start_also_polishes_the_screens_best_points(monkeypatch):
    from fitdf.inference import lsq
    from fitdf.inference.lsq import fit_lsq

    # every start polished to its end (no stop in a known basin): the starts are compared
    monkeypatch.setattr(lsq, "MERGE_CHI2", -1.0)
    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    cold = fit_lsq(problem, seed=0, n_starts=2)
    warm = fit_lsq(problem, seed=0, starts=cold.internal, also_screen=1)
    assert warm.info["n_starts"] == 2 and warm.info["n_screen"] == 256
    # the second start is the screen's best point, the cold fit's first start: same polish
    assert warm.info["starts_chi2"][1] == pytest.approx(cold.info["starts_chi2"][0], rel=1e-9)
    # a polish started at the optimum stays there
    assert warm.info["starts_chi2"][0] == pytest.approx(min(cold.info["starts_chi2"]), rel=1e-6)
    only = fit_lsq(problem, seed=0, starts=cold.internal)
    assert only.info["n_starts"] == 1 and only.info["n_screen"] == 0


def test_a_fit_without_uncertainties_has_the_same_optimum_and_skips_the_covariance(monkeypatch):
    """Cross-validation folds read only the optimum: ``uncertainties=False`` saves the
    covariance's ``2 P + 1`` evaluations and changes nothing else."""
    from fitdf.inference import lsq
    from fitdf.inference.lsq import fit_lsq

    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    full = fit_lsq(problem, seed=0, n_starts=2)
    calls = []
    monkeypatch.setattr(lsq, "covariance", lambda *a: calls.append(a))
    bare = fit_lsq(problem, seed=0, n_starts=2, uncertainties=False)
    # (the polish's merge test still asks for the first start's covariance, once the second
    # start comes within MERGE_CHI2 of it: not the result's)
    assert len(calls) == 1
    np.testing.assert_array_equal(bare.internal, full.internal)
    assert bare.metrics["chi2"] == full.metrics["chi2"]
    assert all(np.isnan(v) for v in bare.stderr.values())
    assert np.isfinite(list(full.stderr.values())).all()
    assert not any("covariance" in w for w in bare.warnings)


def test_a_start_that_reaches_a_known_basin_stops_there(monkeypatch):
    """Later starts stop once within MERGE_CHI2 / MERGE_SIGMAS of an optimum an earlier
    start reached: the same optimum, for fewer evaluations."""
    from fitdf.inference import lsq

    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    merged = lsq.fit_lsq(problem, seed=0, n_starts=4)
    window = lsq.MERGE_CHI2
    monkeypatch.setattr(lsq, "MERGE_CHI2", -1.0)
    full = lsq.fit_lsq(problem, seed=0, n_starts=4)
    assert not any(full.info["starts_merged"])
    flags = merged.info["starts_merged"]
    assert any(flags) and not flags[0]
    best = min(full.info["starts_chi2"])
    # the same basin: a merged start stops within MERGE_CHI2 above an earlier optimum, so
    # the merged run's best may lie above the full run's by the rest of the valley's crawl
    # (0.02 of 630.5 with scipy 1.17; 0 with earlier builds), never by more than the window
    assert best - 1e-9 <= min(merged.info["starts_chi2"]) <= best + window
    costs = merged.info["starts_chi2"]
    for i, flag in enumerate(flags):
        if flag:  # stopped no lower than, and at most MERGE_CHI2 above, an earlier optimum
            earlier = [c for c, f in zip(costs[:i], flags[:i]) if not f]
            assert any(c - 1e-9 <= costs[i] <= c + window for c in earlier)
    assert merged.info["nfev_total"] < full.info["nfev_total"]
    # the reported point is the best start's (not its parameters against the full run's:
    # this valley is flat, k 5.2 and 12.9 H lie 0.02 apart in chi-square with scipy 1.17)
    chi2 = float(np.sum(problem.weighted_residuals(merged.internal) ** 2))
    assert chi2 == pytest.approx(min(costs), rel=1e-9)


def test_a_basins_covariance_is_computed_once_a_start_comes_within_merge_chi2(monkeypatch):
    """The merge test reads an earlier optimum's covariance only for a start whose
    chi-square lies within MERGE_CHI2 above that optimum's: just outside the window it is
    never computed, just inside once (however many evaluations fall inside), and the polish
    is the same either way."""
    from fitdf.inference import lsq

    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    lo, hi = problem.internal_bounds().T
    start = lo + 0.45 * (hi - lo)
    _, x0, c0 = lsq._polish(problem, start, max_nfev=4000)
    calls = []
    real = lsq.covariance
    monkeypatch.setattr(lsq, "covariance", lambda p, x: calls.append(x) or real(p, x))
    far = lo + 0.9 * (hi - lo)  # an optimum elsewhere: the polish never merges into it
    for offset, n_calls in ((-0.05, 0), (0.05, 1)):
        calls.clear()
        basin = lsq._Basin(problem, far, c0 - lsq.MERGE_CHI2 + offset)
        out, x, cost = lsq._polish(problem, start, max_nfev=4000, known=[basin])
        assert len(calls) == n_calls
        assert not out.merged
        np.testing.assert_array_equal(x, x0)
        assert cost == c0


def test_basins_covariances_on_demand_leave_the_fit_unchanged(monkeypatch):
    """Each basin's covariance computed on demand gives the fit it gave computed as soon as
    the basin was found (the same starts, optimum and uncertainties), for fewer
    covariances."""
    from fitdf.inference import lsq

    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    calls = []
    real = lsq.covariance
    monkeypatch.setattr(lsq, "covariance", lambda p, x: calls.append(x) or real(p, x))
    lazy = lsq.fit_lsq(problem, seed=0, n_starts=4)
    n_lazy = len(calls)

    class Eager(lsq._Basin):
        def __init__(self, *args):
            super().__init__(*args)
            _ = self.covariance  # at once, as each basin was found

    monkeypatch.setattr(lsq, "_Basin", Eager)
    calls.clear()
    eager = lsq.fit_lsq(problem, seed=0, n_starts=4)
    assert lazy.info["starts_chi2"] == eager.info["starts_chi2"]
    assert lazy.info["starts_merged"] == eager.info["starts_merged"]
    np.testing.assert_array_equal(lazy.internal, eager.internal)
    assert lazy.info["covar_internal"] == eager.info["covar_internal"]
    assert lazy.stderr == eager.stderr
    assert n_lazy < len(calls)


def _interior_and_edges(problem):
    """An interior point with one coordinate on its upper bound and one on its lower bound."""
    lo, hi = problem.internal_bounds().T
    x = lo + 0.37 * (hi - lo)
    x[0], x[-1] = hi[0], lo[-1]
    return x, lo, hi


def test_polish_jacobian_is_scipys_forward_difference_in_one_batch():
    """The polish's batched Jacobian evaluates the points scipy's ``least_squares(diff_step=
    ...)`` would (steps ``DIFF_STEP |x|``, backward at a bound), so the polish follows
    scipy's path, except that a step of the calibration gain rescales the prediction
    instead of solving the chain again; and its columns are the slopes (against central
    differences over a 10x larger step, one point at a time)."""
    from scipy.optimize._numdiff import approx_derivative  # scipy's own 2-point scheme

    from fitdf.inference import lsq

    problem = FitProblem(resolve_data("B.3"), "constant_width", "winding")
    x, lo, hi = _interior_and_edges(problem)
    x[1] = 0.3 if lo[1] < 0.3 < hi[1] else x[1]  # |x| < 1: a step relative to |x| itself
    assert problem.output_scale_indices == [problem.names.index("gain")]
    solved = [i for i in range(problem.ndim) if i not in problem.output_scale_indices]
    seen = []

    def recorded(v):
        seen.append(np.atleast_2d(v).copy())
        return FitProblem.predict(problem, v)

    spy = copy.copy(problem)
    spy.predict = recorded
    jac, n = lsq._batched_jacobian(spy, x, None, lo, hi)
    assert n == len(solved) + 1 and len(seen) == 1  # one batched call, the gain's step not in it
    ours = seen.pop()
    ref = approx_derivative(
        lambda v: spy.objective_residuals(v),
        x,
        method="2-point",
        rel_step=lsq.DIFF_STEP,
        bounds=(lo, hi),
    )
    theirs = np.vstack(seen)
    np.testing.assert_array_equal(ours[1:], theirs[-problem.ndim :][solved])  # the same points
    np.testing.assert_allclose(jac, ref, rtol=1e-6, atol=1e-6)  # (batched vs one by one: ~1e-11)
    # given the residuals and prediction at x, only the shifted points are solved: the same
    at_x = (problem.objective_residuals(x), problem.predict(x))
    again, n_again = lsq._batched_jacobian(problem, x, at_x, lo, hi)
    assert n_again == len(solved)
    np.testing.assert_allclose(again, jac, rtol=1e-6, atol=1e-6)
    # a joint fit's two gains, each a rescaling of its own table's rows, against scipy
    joint = FitProblem(resolve_data("permalloy"), "constant_width", "winding")
    assert [joint.names[i] for i in joint.output_scale_indices] == ["gain[B.1]", "gain[B.3]"]
    z = joint.internal_bounds()[:, 0] + 0.41 * np.diff(joint.internal_bounds()).ravel()
    jz, nz = lsq._batched_jacobian(joint, z, None, *joint.internal_bounds().T)
    assert nz == joint.ndim - 1
    ref = approx_derivative(
        joint.objective_residuals,
        z,
        method="2-point",
        rel_step=lsq.DIFF_STEP,
        bounds=tuple(joint.internal_bounds().T),
    )
    np.testing.assert_allclose(jz, ref, rtol=1e-6, atol=1e-9 * np.abs(ref).max())
    # slopes: central differences at an interior point (the box edges are one-sided)
    y = lo + 0.41 * (hi - lo)
    jac_y, _ = lsq._batched_jacobian(problem, y, None, lo, hi)
    for i in range(problem.ndim):
        h = 1e-3 * abs(y[i])
        up, down = y.copy(), y.copy()
        up[i] += h
        down[i] -= h
        central = (problem.objective_residuals(up) - problem.objective_residuals(down)) / (2 * h)
        np.testing.assert_allclose(
            jac_y[:, i], central, rtol=2e-3, atol=2e-3 * np.abs(central).max()
        )


def test_polish_reaches_scipys_optimum_and_keeps_its_budget():
    """Against lmfit + scipy's own finite differences from the same start: the same optimum.
    ``max_nfev`` counts the Jacobian's points too: a small budget stops the polish (at most
    one Jacobian past it) with a message saying so."""
    import lmfit

    from fitdf.inference import lsq

    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    lo, hi = problem.internal_bounds().T
    start = lo + 0.45 * (hi - lo)
    params = lmfit.Parameters()
    for i, v in enumerate(start):
        params.add(f"p{i}", value=v, min=lo[i], max=hi[i])

    def residual(p):
        return problem.objective_residuals(np.array([p[f"p{i}"].value for i in range(len(start))]))

    ref = lmfit.minimize(
        residual, params, method="least_squares", diff_step=lsq.DIFF_STEP, max_nfev=4000
    )
    out, x, cost = lsq._polish(problem, start, max_nfev=4000)
    assert cost == pytest.approx(float(np.sum(ref.residual**2)), rel=1e-8)
    # the same cost to 1e-8; the point to 1e-4 in log10 (0.02 %) along the flat valley
    # both stop in (1.9e-5 apart in the magnitude-and-phase residual)
    np.testing.assert_allclose(x, [ref.params[f"p{i}"].value for i in range(len(x))], atol=1e-4)
    # the count: every trial point and every Jacobian point solved, which is scipy's count
    # less the gain's step in each Jacobian (a rescaling, not a solve)
    assert out.nfev == pytest.approx(ref.nfev - out.njev, rel=0.05)

    short, _, short_cost = lsq._polish(problem, start, max_nfev=20)
    assert 20 <= short.nfev <= 20 + problem.ndim + 1
    assert not short.success and "model evaluations" in short.message
    assert short_cost > cost


def test_fit_names_the_rows_where_the_width_law_reaches_the_widest_loop():
    """Least squares and MCMC carry the model's limit warning, for the rows whose peak core
    current puts the fitted cubic law on the clip m = b/A = 1 (a Deltamax-like loop)."""
    from fitdf.models.cubic_hc import cubic_law, cubic_shape, cubic_width

    values, _ = TRUTH["cubic_hc"]
    law = {n: float(v) for n, v in cubic_law(**{n: values[n] for n in LAW}).items()}
    # eq 4.8's alpha 0.5 -> 1.5: m > 1 below h1, the widest loop at low currents
    square = {**values, **cubic_shape(**{**law, "alpha": 1.5})}
    frame = synthetic_frame(
        "cubic_hc", {**square, **CHAIN}, chain="winding", source_impedances=(0.0, 600.0)
    )
    fixed = {n: v for n, v in {**square, **CHAIN}.items() if n != "m1"}
    r = fitdf.fit(frame, "cubic_hc", chain="winding", policy="all", fixed=fixed, n_starts=1)
    assert r.values["m1"] == pytest.approx(float(square["m1"]), rel=0.05)
    current = r.problem.core_currents(r.internal)
    on_clip = cubic_width(current, **cubic_law(**{n: r.values[n] for n in LAW})) >= 0.99 * current
    assert 0 < on_clip.sum() < current.size  # some rows on the clip, not all
    (warning,) = [w for w in r.warnings if "widest loop" in w]
    assert f"at {on_clip.sum()} of {current.size} rows" in warning
    post = fit_mcmc(r.problem, r, n_steps=60, pilot_steps=40, max_pilot_rounds=1)
    assert any("widest loop" in w for w in post.warnings)
    plain = fitdf.fit(
        synthetic("cubic_hc", chain="winding"),
        "cubic_hc",
        chain="winding",
        policy="all",
        fixed={n: v for n, v in {**values, **CHAIN}.items() if n != "m1"},
        n_starts=1,
    )
    assert not any("widest loop" in w for w in plain.warnings)


def test_a_budget_spent_at_the_polish_last_evaluation_ends_it_there():
    """lmfit evaluates scipy's answer once more, through the stop callback, outside its own
    handler: with the budget exactly the evaluations a polish takes, the callback asks to
    stop at that evaluation. The polish ends at the same answer, not in lmfit's
    AbortFitException (the report's least squares died of it with lmfit 1.3.4)."""
    from fitdf.inference import lsq

    problem = FitProblem(resolve_data("B.1"), "constant_width", "winding")
    lo, hi = problem.internal_bounds().T
    start = lo + 0.45 * (hi - lo)
    full, x_full, cost_full = lsq._polish(problem, start, max_nfev=4000)
    assert full.success and full.nfev < 4000
    out, x, cost = lsq._polish(problem, start, max_nfev=full.nfev)
    np.testing.assert_array_equal(x, x_full)
    assert cost == cost_full
    assert "model evaluations" in out.message and not out.merged


# ------------------------------------------------------------------ laws that need more starts
def test_a_law_with_a_start_multiple_gets_that_many_more_starts():
    from fitdf.models import get_model

    assert get_model("cubic_hc").start_multiple == 4
    assert get_model("constant_width").start_multiple == 1
    r = fitdf.fit("B.3", "cubic_hc", chain="direct", seed=0, n_starts=1)  # (any chain)
    assert r.info["n_starts"] == 4 and len(r.info["starts_chi2"]) == 4


@pytest.mark.slow
def test_cubic_hc_needs_its_start_multiple_on_deltamax(monkeypatch):
    """cubic_hc's best basin on Deltamax is reached from few starts: the law's kinks
    (``CubicHc``) split B.2's chi-square into basins 180 or more apart (AMD EPYC, 24 starts:
    1175 | 1355-1400 | 1450-1530 | 1750+). There, seeds 0/1/2 with 24 starts each reached
    1175 from one start of the 24, and six starts missed it on all three (1378/1373/1384).
    Which start lands in which basin moves with the polish's last digits, so with the CPU: on
    the machine that made the committed report seed 1 with 24 starts ended at 1322 and six
    starts gave 1310/1674/1717. Asserted is what holds on both: the basin of the best of 24
    starts is reached by at most a quarter of them (six starts then miss it with probability
    at least (3/4)^6 = 18 %), and six starts end 100 above it on at least one of three seeds."""
    from fitdf.models import get_model

    law = get_model("cubic_hc")
    r = fitdf.fit("B.2", "cubic_hc", seed=1)
    starts = np.asarray(r.info["starts_chi2"])
    best = r.metrics["chi2"]
    assert starts.size == 24 and best <= starts.min()  # (the best start, polished once more)
    assert best < 1400
    assert np.count_nonzero(starts < best + 50) <= 6
    monkeypatch.setattr(law, "start_multiple", 1)
    six = [fitdf.fit("B.2", "cubic_hc", seed=seed).metrics["chi2"] for seed in (0, 1, 2)]
    assert max(six) > best + 100
