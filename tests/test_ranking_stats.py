"""Every ranking statistic against numbers computed by hand, from the formulas written out here.

Convention (:mod:`fitdf.inference.metrics`): with ``N`` weighted residuals ``r`` (two per data
row) and ``k`` fitted parameters, ``chi2 = sum r^2``, ``redchi = chi2 / (N - k)``, and the noise
scale is profiled out of the Gaussian likelihood (lmfit's convention)::

    AIC  = N ln(chi2 / N) + 2 k
    AICc = AIC + 2 k (k + 1) / (N - k - 1)
    BIC  = N ln(chi2 / N) + k ln N

Ranking (:func:`fitdf.inference.ranking.ranking_table`): ``delta_aicc = AICc - min AICc``, Akaike
weight ``w_i = exp(-delta_i / 2) / sum_j exp(-delta_j / 2)``; least-squares rows are
indistinguishable when ``|AICc_i - AICc_j| < 2``; MCMC rows when ``|elpd_loo_i - elpd_loo_j| <
2 dse`` with ``dse = sqrt(n var(elpd_i - elpd_j))`` over the ``n`` pointwise elpd values, as
:func:`arviz.compare` computes it (checked here against ArviZ called directly).

The results are light stand-ins (``types.SimpleNamespace``) carrying what ``ranking_table``
reads; their metrics come from the real :func:`information_criteria` and
:func:`residual_metrics` wherever a formula is under test.
"""

import math
from types import SimpleNamespace

import arviz as az
import lmfit
import numpy as np
import pytest
from scipy import stats

from fitdf.errors import OptionError
from fitdf.inference.metrics import information_criteria, phase_difference_deg, residual_metrics
from fitdf.inference.posterior import psis_loo
from fitdf.inference.ranking import (
    _elpd_data,
    bayes_factor_scale,
    best_by_aicc,
    ranking_table,
)


def stand_in(model, aicc, *, method="lsq", rms=0.01, k=3, n=20, diagnostics=None, **metrics):
    """A fitted result as ranking_table sees it, with the given AICc and RMS complex residual."""
    return SimpleNamespace(
        model=model,
        chain="winding",
        method=method,
        warnings=[],
        diagnostics=diagnostics or {},
        metrics={
            "n_params": k,
            "n_points": n,
            "rms_complex": rms,
            "rms_magnitude": rms,
            "rms_phase_deg": 1.0,
            "redchi": 1.0,
            "aicc": aicc,
            "bic": aicc,
            **metrics,
        },
    )


def fitted(model, errors, k, sigma=0.01):
    """A least-squares stand-in whose complex residual on row i is ``sigma * errors[i]``.

    The weighted residuals are the residual's two parts over the noise scale ``sigma``, so
    ``chi2 = sum |errors|^2`` and ``rms_complex = sigma sqrt(chi2 / n)``.
    """
    errors = np.asarray(errors, complex)
    measured = 0.8 * np.exp(1j * np.linspace(0.1, 1.0, errors.size))
    predicted = measured + sigma * errors
    weighted = np.concatenate([errors.real, errors.imag])
    return SimpleNamespace(
        model=model,
        chain="winding",
        method="lsq",
        warnings=[],
        diagnostics={},
        metrics={
            "n_points": errors.size,
            "n_params": k,
            **residual_metrics(predicted, measured),
            **information_criteria(weighted, k),
        },
    )


def by_model(table):
    return table.set_index("model")


# --- metrics.py ------------------------------------------------------------------------------


def test_information_criteria_by_hand():
    r = np.array([0.5, -1.0, 1.5, 2.0, -0.5, 1.0])
    N, k = 6, 2
    chi2 = 0.25 + 1.0 + 2.25 + 4.0 + 0.25 + 1.0  # 8.75
    base = N * math.log(chi2 / N)  # 6 ln(1.458333) = 2.263765
    ic = information_criteria(r, k)
    assert ic["n_residuals"] == N
    assert ic["chi2"] == pytest.approx(8.75, rel=1e-14)
    assert ic["redchi"] == pytest.approx(8.75 / 4, rel=1e-14)  # chi2 / (N - k) = 2.1875
    assert ic["aic"] == pytest.approx(base + 2 * k, rel=1e-12)
    assert ic["aic"] == pytest.approx(6.263765, abs=1e-6)
    assert ic["aicc"] == pytest.approx(base + 2 * k + 2 * k * (k + 1) / (N - k - 1), rel=1e-12)
    assert ic["aicc"] == pytest.approx(10.263765, abs=1e-6)  # AIC + 12 / 3
    assert ic["bic"] == pytest.approx(base + k * math.log(N), rel=1e-12)
    assert ic["bic"] == pytest.approx(5.847284, abs=1e-6)  # + 2 ln 6 = 3.583519
    assert all(type(v) in (int, float) for v in ic.values())


def test_information_criteria_match_lmfit():
    """The same numbers as lmfit's own chisqr, redchi, aic and bic for a least-squares fit."""
    x = np.arange(8.0)
    y = np.array([0.1, 1.2, 1.9, 3.2, 3.8, 5.1, 6.0, 7.2])
    params = lmfit.Parameters()
    params.add("a", 1.0)
    params.add("b", 0.0)
    fit = lmfit.minimize(lambda p: (p["a"] * x + p["b"] - y) / 0.1, params)
    ic = information_criteria(fit.residual, fit.nvarys)
    assert ic["chi2"] == pytest.approx(fit.chisqr, rel=1e-12)
    assert ic["redchi"] == pytest.approx(fit.redchi, rel=1e-12)
    assert ic["aic"] == pytest.approx(fit.aic, rel=1e-12)
    assert ic["bic"] == pytest.approx(fit.bic, rel=1e-12)


def test_information_criteria_edge_cases():
    # AICc needs N - k - 1 > 0, the reduced chi-square N > k
    at_limit = information_criteria([1.0, 2.0, 2.0], 2)  # N - k - 1 = 0
    assert at_limit["aicc"] == np.inf and at_limit["redchi"] == pytest.approx(9.0)
    saturated = information_criteria([1.0, 2.0], 2)
    assert saturated["aicc"] == np.inf and math.isnan(saturated["redchi"])
    one_left = information_criteria([1.0, 1.0, 1.0, 1.0], 2)  # N - k - 1 = 1: AIC + 12
    assert one_left["aicc"] == pytest.approx(4 * math.log(1.0) + 4 + 12)
    # a perfect fit stays finite (chi2 floored at 1e-300), with the same penalty structure
    perfect = information_criteria(np.zeros(10), 3)
    assert perfect["chi2"] == 0.0
    assert perfect["aic"] == pytest.approx(10 * math.log(1e-300 / 10) + 6)
    assert perfect["bic"] - perfect["aic"] == pytest.approx(3 * math.log(10) - 6)
    # no parameters: no penalty at all
    none = information_criteria([1.0, -1.0, 1.0, -1.0], 0)
    assert none["aic"] == none["aicc"] == none["bic"] == pytest.approx(0.0, abs=1e-15)


def test_information_criteria_are_computed_in_double_precision():
    # single-precision residuals are squared and summed in float64: squaring in float32 alone
    # is off by 6e-8 here, which would move N ln(chi2 / N) (N = 1001) by 6e-5
    r32 = (np.linspace(-2, 2, 1001) * 0.1).astype(np.float32)
    r64 = r32.astype(float)  # the same numbers, exactly
    ic = information_criteria(r32, 3)
    assert ic == information_criteria(r64, 3)
    assert ic["chi2"] == pytest.approx(math.fsum(x * x for x in r64.tolist()), rel=1e-14)


def test_residual_metrics_by_hand():
    deg = np.pi / 180
    measured = np.array([1.0, 1j, -1.0, 0.0])
    predicted = np.array([1.1, 1j * np.exp(10j * deg), np.exp(-175j * deg), 0.2])
    # |M - D|: 0.1, 2 sin 5 deg, 2 sin 2.5 deg, 0.2; |M| - |D|: 0.1, 0, 0, 0.2
    # phase: 0, 10, 5 (-175 - 180 wraps to +5) degrees; the row with D = 0 has none
    m = residual_metrics(predicted, measured)
    complex_sq = [0.01, (2 * math.sin(5 * deg)) ** 2, (2 * math.sin(2.5 * deg)) ** 2, 0.04]
    assert m["rms_complex"] == pytest.approx(math.sqrt(sum(complex_sq) / 4), rel=1e-12)
    assert m["rms_magnitude"] == pytest.approx(math.sqrt(0.05 / 4), rel=1e-12)
    assert m["rms_phase_deg"] == pytest.approx(math.sqrt((0 + 100 + 25) / 3), rel=1e-12)
    assert math.isnan(residual_metrics([0.5], [0.0])["rms_phase_deg"])


def test_phase_difference_is_wrapped_to_half_open_interval():
    deg = np.pi / 180
    got = phase_difference_deg(
        np.exp(np.array([-179, 179, 30]) * 1j * deg), np.exp(np.array([179, -179, -30]) * 1j * deg)
    )
    np.testing.assert_allclose(got, [2.0, -2.0, 60.0], atol=1e-9)
    # exactly opposite: +180, never -180 (1 * conj(-1 + 0j) = -1 - 0j has angle -180)
    assert phase_difference_deg(np.array([1 + 0j]), np.array([-1 + 0j]))[0] == 180.0
    assert phase_difference_deg(np.array([-1 + 0j]), np.array([1 + 0j]))[0] == 180.0


# --- ranking.py: deltas, Akaike weights, the tie rule --------------------------------------


def test_delta_aicc_and_akaike_weights_by_hand():
    results = [
        stand_in("a", 10.0, rms=0.03),
        stand_in("b", 11.5, rms=0.01),
        stand_in("c", 14.0, rms=0.02),
    ]
    t = by_model(ranking_table(results))
    np.testing.assert_allclose(t.loc[["a", "b", "c"], "delta_aicc"], [0.0, 1.5, 4.0])
    # w ~ exp(-delta / 2): 1, exp(-0.75) = 0.4723666, exp(-2) = 0.1353353; sum 1.6077018
    raw = np.array([1.0, math.exp(-0.75), math.exp(-2.0)])
    np.testing.assert_allclose(t.loc[["a", "b", "c"], "aicc_weight"], raw / raw.sum(), rtol=1e-12)
    np.testing.assert_allclose(
        t.loc[["a", "b", "c"], "aicc_weight"], [0.622006, 0.293814, 0.084179], atol=1e-6
    )
    # weights depend on differences only
    shifted = by_model(ranking_table([stand_in(r.model, r.metrics["aicc"] - 1e3) for r in results]))
    np.testing.assert_allclose(
        shifted.loc[["a", "b", "c"], "aicc_weight"], raw / raw.sum(), rtol=1e-12
    )


def test_aicc_tie_rule_threshold_is_two():
    results = [
        stand_in("a", 10.0),
        stand_in("b", 11.9),  # 1.9 above a: a tie
        stand_in("c", 12.0),  # exactly 2 above a: not a tie; 0.1 above b: a tie
        stand_in("d", 30.0),  # 18 to 20 above the others: alone
        stand_in("e", 10.5, method="mcmc"),  # other method: never an AICc tie
    ]
    t = by_model(ranking_table(results))
    assert t.loc["a", "indistinguishable_from"] == "b/winding"
    assert t.loc["b", "indistinguishable_from"] == "a/winding, c/winding"
    assert t.loc["c", "indistinguishable_from"] == "b/winding"
    assert t.loc["d", "indistinguishable_from"] == ""
    assert t.loc["e", "indistinguishable_from"] == ""  # MCMC without pointwise elpd: no tie


def test_ranking_order_rank_column_and_best_by_aicc():
    results = [
        stand_in("a", 12.0, rms=0.02),
        stand_in("b", 10.0, rms=0.03),
        stand_in("c", 11.0, rms=0.02),  # same RMS as a: the lower AICc goes first
        stand_in("d", 10.0, rms=0.05),  # same AICc as b, later: best_by_aicc keeps b
    ]
    t = ranking_table(results, rank_by="rms_complex")
    assert list(t["model"]) == ["c", "a", "b", "d"] and list(t["rank"]) == [1, 2, 3, 4]
    # by default the selection rule's order: AICc, the first of equals first
    assert list(ranking_table(results)["model"]) == ["b", "d", "c", "a"]
    assert best_by_aicc(results).model == "b"
    assert list(t.columns[:4]) == ["rank", "model", "chain", "method"]
    assert (t["n_params"] == 3).all() and (t["n_points"] == 20).all()
    with pytest.raises(OptionError, match="choose one of rms_complex, rms_magnitude, "):
        ranking_table(results, rank_by="nope")


def test_cross_validation_and_warnings_columns():
    results = [stand_in("a", 10.0, rms=0.01), stand_in("b", 11.0, rms=0.02)]
    results[1].warnings.extend(["one", "two"])
    t = by_model(ranking_table(results, cv={1: {"cv_rms_complex": 0.05}}))
    assert np.isnan(t.loc["a", "cv_rms_complex"]) and t.loc["b", "cv_rms_complex"] == 0.05
    assert t.loc["a", "warnings"] == 0 and t.loc["b", "warnings"] == 2
    ordered = ranking_table(
        results,
        rank_by="cv_rms_complex",
        cv={0: {"cv_rms_complex": 0.09}, 1: {"cv_rms_complex": 0.05}},
    )
    assert list(ordered["model"]) == ["b", "a"]
    for ic in ("looic", "waic"):  # information criteria of posteriors only
        with pytest.raises(OptionError, match="needs posteriors"):
            ranking_table(results, rank_by=ic)


#: The ranking table's columns, in order: a ``ranking_row`` of schemas/results.schema.json (its
#: required properties, in that order), then the MCMC comparison columns.
TABLE_COLUMNS = [
    "rank", "model", "chain", "method", "n_params", "n_points", "rms_complex", "rms_magnitude",
    "rms_phase_deg", "redchi", "aicc", "bic", "looic", "looic_se", "waic", "cv_rms_complex",
    "log_evidence", "log_evidence_error", "warnings", "delta_aicc", "aicc_weight",
    "indistinguishable_from", "elpd_loo_diff", "elpd_loo_dse", "loo_weight",
    "log_bayes_factor_next", "log_bayes_factor_next_error", "bayes_factor_verdict",
]  # fmt: skip


def test_table_columns_and_empty_mcmc_columns_are_float_nan():
    # least squares only, no cross-validation: every column is there, in the schema's order, and
    # the columns without a value are float columns of NaN (not None), whatever the methods
    t = ranking_table([stand_in("a", 10.0), stand_in("b", 11.0)])
    assert list(t.columns) == TABLE_COLUMNS
    for col in (
        "looic",
        "looic_se",
        "waic",
        "cv_rms_complex",
        "elpd_loo_diff",
        "loo_weight",
        "log_evidence",
        "log_bayes_factor_next",
    ):
        assert t[col].dtype == np.float64, col
        assert np.isnan(t[col].to_numpy()).all(), col
    with_cv = ranking_table([stand_in("a", 10.0)], cv={0: {"cv_rms_complex": 0.05}})
    assert list(with_cv.columns) == TABLE_COLUMNS and with_cv.loc[0, "cv_rms_complex"] == 0.05


def test_aicc_overturns_the_rms_order_for_many_parameters_on_few_points():
    # 6 rows = 12 weighted residuals. The 6-parameter model fits a little better (chi2 11 vs 12,
    # RMS 4 % lower) than the 2-parameter one.
    simple = fitted("simple", np.full(6, 1 + 1j), k=2)  # chi2 = 6 * 2 = 12
    rich = fitted("rich", np.full(6, math.sqrt(11 / 12) * (1 + 1j)), k=6)  # chi2 = 11
    # AICc(simple) = 12 ln(12/12) + 4 + 2*2*3/9 = 5.333333
    # AICc(rich)   = 12 ln(11/12) + 12 + 2*6*7/5 = -1.044137 + 12 + 16.8 = 27.755863
    assert simple.metrics["aicc"] == pytest.approx(4 + 12 / 9, abs=1e-12)
    assert rich.metrics["aicc"] == pytest.approx(12 * math.log(11 / 12) + 12 + 16.8, rel=1e-12)
    assert rich.metrics["aicc"] == pytest.approx(27.755863, abs=1e-6)
    assert rich.metrics["rms_complex"] == pytest.approx(0.01 * math.sqrt(2 * 11 / 12))
    assert rich.metrics["rms_complex"] < simple.metrics["rms_complex"]
    by_rms = ranking_table([simple, rich], rank_by="rms_complex")
    assert list(by_rms["model"]) == ["rich", "simple"]
    by_aicc = ranking_table([simple, rich])  # the default order
    assert list(by_aicc["model"]) == ["simple", "rich"]
    t = by_model(by_aicc)
    assert t.loc["rich", "delta_aicc"] == pytest.approx(27.755863 - 5.333333, abs=1e-5)
    assert t.loc["simple", "aicc_weight"] == pytest.approx(0.9999865, abs=1e-7)
    assert t.loc["simple", "indistinguishable_from"] == ""
    # eleven parameters on the six rows' twelve numbers: not ranked (AICc needs k + 2)
    richer = fitted("richer", np.full(6, 0.1 * (1 + 1j)), k=11)
    assert list(ranking_table([simple, richer])["model"]) == ["simple"]


def test_aicc_keeps_the_rms_order_when_the_extra_parameters_pay():
    simple = fitted("simple", np.full(6, 1 + 1j), k=2)  # chi2 = 12
    rich = fitted("rich", np.full(6, 0.5 * (1 + 1j)), k=4)  # chi2 = 3: half the RMS
    # AICc(rich) = 12 ln(3/12) + 8 + 2*4*5/7 = -16.635532 + 8 + 5.714286 = -2.921246
    assert rich.metrics["aicc"] == pytest.approx(-2.921246, abs=1e-6)
    assert rich.metrics["bic"] == pytest.approx(12 * math.log(0.25) + 4 * math.log(12))
    for rank_by in ("rms_complex", "aicc", "bic", "redchi"):
        assert list(ranking_table([simple, rich], rank_by=rank_by)["model"]) == ["rich", "simple"]
    t = by_model(ranking_table([simple, rich]))
    # delta = 5.333333 + 2.921246 = 8.254579: weight of simple exp(-4.127290) / (1 + ...)
    assert t.loc["simple", "delta_aicc"] == pytest.approx(8.254579, abs=1e-6)
    w = math.exp(-8.254579 / 2)
    assert t.loc["simple", "aicc_weight"] == pytest.approx(w / (1 + w), rel=1e-5)
    assert t.loc["rich", "redchi"] == pytest.approx(3 / 8) and t.loc["simple", "redchi"] == 1.2


# --- MCMC rows: PSIS-LOO, WAIC and the LOO tie rule against ArviZ called directly ---------


N_OBS = 40
Y = np.random.default_rng(0).normal(0.0, 1.0, N_OBS)


def normal_model_draws(shift, seed, n_draws=250, n_walkers=8):
    """emcee-shaped draws ``(draw, walker, 1)`` of the mean of Y, offset by ``shift``, and the
    pointwise log-likelihood ``(draw, walker, n)`` of Y under N(mean, 1)."""
    rng = np.random.default_rng(seed)
    mu = Y.mean() + shift + rng.normal(0, 1 / math.sqrt(N_OBS), (n_draws, n_walkers, 1))
    return mu, stats.norm.logpdf(Y, loc=mu, scale=1.0)


def mcmc_stand_in(model, shift, seed):
    mu, loglik = normal_model_draws(shift, seed)
    diag, caught, _ = psis_loo(mu, loglik, ["mu"])
    assert not caught
    metrics = {k: diag[k] for k in ("looic", "looic_se", "waic", "elpd_loo", "p_loo")}
    return stand_in(model, 0.0, method="mcmc", diagnostics=diag, **metrics)


def direct_idata(shift, seed):
    """The same draws, straight into ArviZ in its own (chain, draw) layout."""
    mu, loglik = normal_model_draws(shift, seed)
    return az.from_dict(
        posterior={"mu": mu[..., 0].T}, log_likelihood={"y": np.swapaxes(loglik, 0, 1)}
    )


SHIFTS = {"near": (0.0, 1), "close": (0.05, 2), "far": (0.6, 3)}


@pytest.fixture(scope="module")
def mcmc_results():
    return [mcmc_stand_in(name, *args) for name, args in SHIFTS.items()]


def test_loo_and_waic_match_arviz(mcmc_results):
    for r, (shift, seed) in zip(mcmc_results, SHIFTS.values()):
        idata = direct_idata(shift, seed)
        loo, waic = az.loo(idata, pointwise=True), az.waic(idata)
        d = r.diagnostics
        assert d["looic"] == pytest.approx(-2 * loo.elpd_loo, rel=1e-12)
        assert d["looic_se"] == pytest.approx(2 * loo.se, rel=1e-12)
        assert d["elpd_loo"] == pytest.approx(loo.elpd_loo, rel=1e-12)
        assert d["p_loo"] == pytest.approx(loo.p_loo, rel=1e-12)
        assert d["waic"] == pytest.approx(-2 * waic.elpd_waic, rel=1e-12)
        assert d["waic_se"] == pytest.approx(2 * waic.se, rel=1e-12)
        assert d["elpd_waic"] == pytest.approx(waic.elpd_waic, rel=1e-12)
        assert d["elpd_waic_se"] == pytest.approx(waic.se, rel=1e-12)
        np.testing.assert_allclose(d["pointwise_elpd_loo"], np.asarray(loo.loo_i), rtol=1e-12)
        assert d["pareto_k_max"] == pytest.approx(float(np.max(loo.pareto_k)))
        assert d["n_pareto_k_bad"] == 0


def test_influential_rows_and_arviz_warnings_are_reported():
    # 10 observations, the last an outlier a normal model with sigma = 0.4 cannot absorb; 60
    # walkers x 50 draws, so ArviZ also warns that the layout has more chains than draws
    rng = np.random.default_rng(0)
    y = np.append(rng.normal(0.0, 1.0, 9), 4.5)
    mu = y.mean() + rng.normal(0.0, 0.1, (50, 60, 1))
    loglik = stats.norm.logpdf(y, loc=mu, scale=0.4)
    diag, caught, _ = psis_loo(mu, loglik, ["mu"])
    with pytest.warns(UserWarning) as record:
        idata = az.from_dict(
            posterior={"mu": mu[..., 0].T}, log_likelihood={"y": np.swapaxes(loglik, 0, 1)}
        )
        loo = az.loo(idata, pointwise=True)
        az.waic(idata)
    k = np.asarray(loo.pareto_k)
    assert diag["pareto_k_max"] == pytest.approx(k.max()) and 0.7 < k.max() < 1.7
    assert diag["n_pareto_k_bad"] == np.sum(k > 0.7) == 1
    # ArviZ's own warnings, first line each, without the expected layout complaint
    messages = [str(w.message) for w in record]
    assert any("More chains" in m for m in messages)
    expected = sorted({m.split("\n")[0] for m in messages if "More chains" not in m})
    assert caught == expected and len(caught) == 2
    assert caught[0].startswith("Estimated shape parameter of Pareto distribution")
    assert caught[1].endswith("This could be indication of WAIC starting to fail. ")


def test_pointwise_loo_whatever_the_arviz_defaults(mcmc_results):
    # a user's ArviZ configuration must not change what fit_mcmc computes
    mu, loglik = normal_model_draws(*SHIFTS["near"])
    with az.rc_context({"stats.ic_pointwise": False}):
        diag = psis_loo(mu, loglik, ["mu"])[0]
    assert diag == mcmc_results[0].diagnostics


def test_loo_columns_and_ties_match_arviz_compare(mcmc_results):
    direct = az.compare({n: direct_idata(*args) for n, args in SHIFTS.items()}, ic="loo")
    t = by_model(ranking_table(mcmc_results, rank_by="looic"))
    for name in SHIFTS:
        assert t.loc[name, "elpd_loo_diff"] == pytest.approx(
            direct.loc[name, "elpd_diff"], abs=1e-9
        )
        assert t.loc[name, "elpd_loo_dse"] == pytest.approx(direct.loc[name, "dse"], abs=1e-9)
        assert t.loc[name, "loo_weight"] == pytest.approx(direct.loc[name, "weight"], abs=1e-6)
    assert list(t.index) == list(direct.index)  # LOO-IC order is ArviZ's elpd order
    for r in mcmc_results:  # the fits' own LOO-IC and WAIC, passed through
        for col in ("looic", "looic_se", "waic"):
            assert t.loc[r.model, col] == r.metrics[col]
    # elpd difference and its standard error by hand, from the pointwise elpd
    best = np.asarray(mcmc_results[0].diagnostics["pointwise_elpd_loo"])
    assert direct.index[0] == "near"
    for r in mcmc_results[1:]:
        diff = best - np.asarray(r.diagnostics["pointwise_elpd_loo"])
        assert t.loc[r.model, "elpd_loo_diff"] == pytest.approx(diff.sum(), rel=1e-9)
        assert t.loc[r.model, "elpd_loo_dse"] == pytest.approx(
            math.sqrt(diff.size * np.var(diff)), rel=1e-9
        )
    # the tie rule, pair by pair: |elpd_diff| < 2 dse of arviz.compare on the two
    for i, a in enumerate(SHIFTS):
        for b in list(SHIFTS)[i + 1 :]:
            pair = az.compare({a: direct_idata(*SHIFTS[a]), b: direct_idata(*SHIFTS[b])}).iloc[1]
            tie = abs(pair["elpd_diff"]) < 2 * pair["dse"]
            assert (f"{b}/winding" in t.loc[a, "indistinguishable_from"]) == tie, (a, b, pair)
            assert (f"{a}/winding" in t.loc[b, "indistinguishable_from"]) == tie, (a, b, pair)
    # the constructed case has both outcomes: a shift of 0.05 is a tie, one of 0.6 is not, by a
    # margin a threshold of 3 dse (or 20) would reverse
    assert t.loc["near", "indistinguishable_from"] == "close/winding"
    assert t.loc["far", "indistinguishable_from"] == ""
    far = t.loc["far"]
    assert 2 * far["elpd_loo_dse"] < far["elpd_loo_diff"] < 3 * far["elpd_loo_dse"]


def test_ranking_does_not_depend_on_arviz_defaults(mcmc_results):
    table = ranking_table(mcmc_results)
    other = {
        "stats.ic_compare_method": "BB-pseudo-BMA",
        "stats.ic_scale": "deviance",
        "stats.information_criterion": "waic",
    }
    with az.rc_context(other):
        again = ranking_table(mcmc_results)
    assert again.equals(table)


def test_mcmc_rows_without_comparable_loo(mcmc_results):
    # no pointwise elpd (e.g. a result read back without diagnostics): no LOO tie, no LOO columns
    bare = stand_in("bare", 0.0, method="mcmc")
    t = by_model(ranking_table([*mcmc_results, bare]))
    assert t.loc["bare", "indistinguishable_from"] == ""
    assert np.isnan(t.loc["bare", "loo_weight"]) and t.loc["near", "loo_weight"] > 0
    assert t.loc["near", "indistinguishable_from"] == "close/winding"
    # pointwise elpd on other rows: not comparable, so no tie and no ArviZ comparison at all
    other = mcmc_stand_in("other_rows", *SHIFTS["near"])
    other.diagnostics["pointwise_elpd_loo"] = other.diagnostics["pointwise_elpd_loo"][:-1]
    t = by_model(ranking_table([*mcmc_results, other]))
    assert t.loc["other_rows", "indistinguishable_from"] == ""
    assert "other_rows" not in t.loc["near", "indistinguishable_from"]
    assert t[["elpd_loo_diff", "elpd_loo_dse", "loo_weight"]].isna().all().all()


def test_loo_columns_are_empty_on_least_squares_rows(mcmc_results):
    same = mcmc_stand_in("twin", *SHIFTS["near"])
    t = ranking_table([*mcmc_results, same, stand_in("lsq", 5.0)])
    lsq = t[t["method"] == "lsq"].iloc[0]
    assert np.isnan(lsq[["elpd_loo_diff", "elpd_loo_dse", "loo_weight"]].astype(float)).all()
    mcmc = t[t["method"] == "mcmc"]
    assert mcmc["loo_weight"].notna().all()
    # the same posterior twice cannot be told apart (zero difference, zero dse)
    assert by_model(t).loc["twin", "indistinguishable_from"] == "near/winding, close/winding"
    assert by_model(t).loc["twin", "elpd_loo_dse"] == 0.0


def test_elpd_data_is_arvizs_loo_rebuilt(mcmc_results):
    # what ranking hands arviz.compare is what arviz.loo returns for the same draws: elpd, its
    # standard error sqrt(n var(elpd_i)), p_loo, the warning flag and the pointwise values
    for r, (shift, seed) in zip(mcmc_results, SHIFTS.values()):
        loo = az.loo(direct_idata(shift, seed), pointwise=True)
        e = _elpd_data(r)
        assert e["elpd_loo"] == pytest.approx(loo.elpd_loo, rel=1e-12)
        assert e["se"] == pytest.approx(loo.se, rel=1e-12)
        assert e["se"] == pytest.approx(math.sqrt(N_OBS * np.var(np.asarray(loo.loo_i))))
        assert e["p_loo"] == pytest.approx(loo.p_loo, rel=1e-12)
        assert e["warning"] is False and loo.warning is False
        np.testing.assert_allclose(e["loo_i"], np.asarray(loo.loo_i), rtol=1e-12)
        assert e["scale"] == loo.scale == "log"
    # an influential row (Pareto k > 0.7, the same threshold as ArviZ at 3000 draws): a warning
    rng = np.random.default_rng(0)
    y = np.append(rng.normal(0.0, 1.0, 9), 4.5)
    mu = y.mean() + rng.normal(0.0, 0.1, (50, 60, 1))
    loglik = stats.norm.logpdf(y, loc=mu, scale=0.4)
    diag = psis_loo(mu, loglik, ["mu"])[0]
    with pytest.warns(UserWarning):  # more walkers than draws, and the Pareto k
        idata = az.from_dict(
            posterior={"mu": mu[..., 0].T}, log_likelihood={"y": np.swapaxes(loglik, 0, 1)}
        )
        loo = az.loo(idata, pointwise=True)
    e = _elpd_data(stand_in("bad", 0.0, method="mcmc", diagnostics=diag))
    assert diag["n_pareto_k_bad"] == 1 and e["warning"] is True and loo.warning is True
    assert e["p_loo"] == pytest.approx(loo.p_loo, rel=1e-12)
    assert e["se"] == pytest.approx(loo.se, rel=1e-12)


def test_elpd_data_from_pointwise_values_alone(mcmc_results):
    # a result that kept only the pointwise elpd (no p_loo, no Pareto count): no warning, p_loo
    # unknown, and it still ranks against the others
    loo_i = np.asarray(mcmc_results[0].diagnostics["pointwise_elpd_loo"])
    bare = stand_in("bare", 0.0, method="mcmc", diagnostics={"pointwise_elpd_loo": list(loo_i)})
    e = _elpd_data(bare)
    assert e["warning"] is False and math.isnan(e["p_loo"])
    assert e["elpd_loo"] == pytest.approx(loo_i.sum(), rel=1e-12)
    t = by_model(ranking_table([*mcmc_results, bare]))
    assert t.loc["bare", "elpd_loo_diff"] == pytest.approx(0.0, abs=1e-9)  # same elpd as "near"
    assert "near/winding" in t.loc["bare", "indistinguishable_from"]


def loo_only(model, pointwise):
    return stand_in(model, 0.0, method="mcmc", diagnostics={"pointwise_elpd_loo": list(pointwise)})


def test_loo_tie_needs_a_difference_below_two_standard_errors():
    # pointwise differences [1, 1, 0, 0]: elpd_diff = 2, dse = sqrt(4 var) = sqrt(4 * 0.25) = 1,
    # all exact in binary: exactly 2 dse apart is not a tie (as the AICc rule: less than 2)
    a = loo_only("a", [-1.0, -1.0, -1.0, -1.0])
    b = loo_only("b", [-2.0, -2.0, -1.0, -1.0])
    t = by_model(ranking_table([a, b]))
    assert t.loc["b", "elpd_loo_diff"] == 2.0 and t.loc["b", "elpd_loo_dse"] == 1.0
    assert t.loc["a", "indistinguishable_from"] == t.loc["b", "indistinguishable_from"] == ""
    # differences [1, 0.875, 0, 0]: elpd_diff 1.875, dse = sqrt(0.88671875) = 0.941657: a tie
    c = loo_only("c", [-2.0, -1.875, -1.0, -1.0])
    t = by_model(ranking_table([a, c]))
    assert t.loc["c", "elpd_loo_diff"] == 1.875
    assert t.loc["c", "elpd_loo_dse"] == pytest.approx(math.sqrt(0.88671875), rel=1e-12)
    assert t.loc["a", "indistinguishable_from"] == "c/winding"


def test_bayes_factors_between_evidence_neighbours_on_the_kass_raftery_scale():
    """ln B of each posterior over the next by evidence, its error in quadrature, the verdict on
    2 ln B (Kass & Raftery 1995: < 2 bare mention, 2-6 positive, 6-10 strong, > 10 very
    strong), and ties where 2 ln B < 2."""
    assert [bayes_factor_scale(x) for x in (0.0, 0.99, 1.0, 2.99, 3.0, 4.99, 5.0)] == [
        "not worth more than a bare mention",
        "not worth more than a bare mention",
        "positive",
        "positive",
        "strong",
        "strong",
        "very strong",
    ]
    rows = [
        stand_in(
            name,
            10.0,
            method="nested",
            diagnostics={"log_evidence": log_z, "log_evidence_error": err},
        )
        for name, log_z, err in (("a", -10.0, 0.1), ("b", -13.5, 0.2), ("c", -14.0, 0.2))
    ]
    t = ranking_table(rows, rank_by="log_evidence").set_index("model")
    assert list(t.index) == ["a", "b", "c"]
    assert t.loc["a", "log_bayes_factor_next"] == pytest.approx(3.5)
    assert t.loc["a", "log_bayes_factor_next_error"] == pytest.approx(math.hypot(0.1, 0.2))
    assert t.loc["a", "bayes_factor_verdict"] == "strong"  # 2 ln B = 7
    assert t.loc["b", "bayes_factor_verdict"] == "not worth more than a bare mention"  # 1.0
    assert (
        np.isnan(t.loc["c", "log_bayes_factor_next"]) and t.loc["c", "bayes_factor_verdict"] == ""
    )
    assert t.loc["b", "indistinguishable_from"].startswith("c/")  # 2 ln B = 1
    assert t.loc["a", "indistinguishable_from"] == ""
