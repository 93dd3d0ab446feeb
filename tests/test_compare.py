"""Ranking, cross-validation and cross-impedance prediction."""

import numpy as np
import pandas as pd
import pytest
from synthetic import synthetic_frame

from fitdf.errors import OptionError
from fitdf.inference.cross_impedance import cross_impedance
from fitdf.inference.ranking import RANK_COLUMNS, cross_validate, fit_all, ranking_table

CHAIN = {"r_series": 100.0, "gain": 0.95}
RIVALS = ["constant_width", "proportional_width", "rayleigh"]
TRUTH = {
    "constant_width": {"k": 80.0, "b": 2e-4, "c": 0.04},
    "proportional_width": {"k": 60.0, "c": 0.035, "m": 0.3},
    "rayleigh": {"mu0": 20.0, "gamma": 8e4, "c_sat": 0.038},
}


@pytest.mark.parametrize(
    "truth",  # one truth by default (14 s on 2 cores), the two dearer ones with the slow tests
    [t if t == "constant_width" else pytest.param(t, marks=pytest.mark.slow) for t in RIVALS],
)
def test_data_generated_by_a_model_rank_it_first(truth):
    frame = synthetic_frame(
        truth, {**TRUTH[truth], **CHAIN}, source_impedances=(0.0, 600.0), seed=7
    )
    results = fit_all(frame, models=RIVALS, policy="all")
    table = ranking_table(results)
    assert table.iloc[0]["model"] == truth, table[["model", "rms_complex", "aicc"]]
    # and by a wide margin: the others misfit by far more than the noise
    assert table.iloc[1]["rms_complex"] > 2 * table.iloc[0]["rms_complex"]
    # the same fits ranked by AICc (compare() is fit_all + ranking_table)
    by_aicc = ranking_table(results, rank_by="aicc")
    assert by_aicc.iloc[0]["model"] == truth
    assert list(table["rank"]) == [1, 2, 3]


def test_ranking_columns_and_ties():
    frame = synthetic_frame("proportional_width", {**TRUTH["proportional_width"], **CHAIN}, seed=1)
    # through the cheap chain (the columns and the tie do not depend on it; ~5 s less)
    twice = ["proportional_width", "proportional_width"]
    results = fit_all(frame, models=twice, chains=("winding",), policy="all")
    table = ranking_table(results)
    for col in (
        "n_params",
        "rms_complex",
        "rms_magnitude",
        "rms_phase_deg",
        "redchi",
        "aicc",
        "bic",
        "delta_aicc",
        "aicc_weight",
        "indistinguishable_from",
    ):
        assert col in table
    # the same model twice cannot be told apart
    assert table.loc[0, "indistinguishable_from"] == "proportional_width/winding"
    with pytest.raises(OptionError, match="cannot rank by"):
        ranking_table(results, rank_by="nope")
    with pytest.raises(OptionError, match="needs posteriors"):
        ranking_table(results, rank_by="looic")
    assert set(RANK_COLUMNS) >= {"rms_complex", "aicc", "looic"}


@pytest.mark.slow  # 17 s; the tiny report runs cross-validation by default
def test_cross_validation_predicts_a_held_out_frequency():
    frame = synthetic_frame("proportional_width", {**TRUTH["proportional_width"], **CHAIN}, seed=2)
    r = fit_all(frame, models=["proportional_width"], policy="all")[0]
    cv = cross_validate(r)
    assert cv["cv_folds"] == 3
    # the right model predicts unseen frequencies nearly at the noise level ...
    assert cv["cv_rms_complex"] < 3 * r.metrics["rms_complex"]
    wrong = fit_all(frame, models=["rayleigh"], policy="all")[0]
    # ... and better than a wrong model does
    assert cross_validate(wrong)["cv_rms_complex"] > cv["cv_rms_complex"]


def test_cross_impedance_prediction_table_on_real_data():
    # through the cheap chain; the tiny report (test_report.py) predicts through the default one
    table = cross_impedance("permalloy", models=["proportional_width", "rayleigh"], chain="winding")
    assert set(table.columns) >= {
        "model",
        "train_ohm",
        "test_ohm",
        "train_rms_complex",
        "predict_rms_complex",
        "predict_rms_magnitude",
        "predict_rms_phase_deg",
        "calibration_gain",
    }
    assert (table["test_ohm"] == 600).all() and (table["n_test"] > 30).all()
    assert table["predict_rms_complex"].is_monotonic_increasing
    assert np.isfinite(table["predict_rms_complex"]).all()
    # averaged over the series resistance's prior: median 53.8 + 25 ohm (the Permalloy
    # winding's Appendix A estimate plus source and leads), nodes e^(-+sqrt(3) 0.45) about it
    for _, row in table.iterrows():
        expect = 78.8 * np.exp(0.45 * np.sqrt(3.0) * np.array([-1.0, 0.0, 1.0]))
        np.testing.assert_allclose(row["r_series_nodes"], expect, rtol=1e-12)
        np.testing.assert_allclose(row["r_series_weights"], [1 / 6, 2 / 3, 1 / 6], rtol=1e-15)
        # trained at 0 ohm, each node's core is the median's rescaled exactly: the same fit, to
        # the optimiser's precision (its polish from the rescaled optimum stops 4e-6 lower)
        np.testing.assert_allclose(
            row["train_rms_complex_nodes"], row["train_rms_complex"], rtol=1e-5
        )
        spread = row["predict_rms_complex_nodes"]
        assert (
            row["predict_rms_complex_min"]
            == min(spread)
            < max(spread)
            == row["predict_rms_complex_max"]
        )
        # the RMS of the weighted mean prediction is at most the weighted mean of the RMS
        assert row["predict_rms_complex"] <= np.dot(row["r_series_weights"], spread) + 1e-12


@pytest.mark.slow  # 25 s; test_cross_impedance_prediction_table_on_real_data runs by default
def test_cross_impedance_on_synthetic_truth():
    truth = {**TRUTH["rayleigh"], **CHAIN}
    frame = pd.concat(
        [
            synthetic_frame("rayleigh", truth, source_impedances=(0.0,), table="T0", seed=3),
            synthetic_frame("rayleigh", truth, source_impedances=(600.0,), table="T600", seed=4),
        ]
    )
    for train, test in ((0.0, 600.0), (600.0, 0.0)):
        table = cross_impedance(
            frame,
            models=["rayleigh", "constant_width"],
            policy="all",
            train_ohm=train,
            test_ohm=test,
            r_series=CHAIN["r_series"],
        )
        best = table.iloc[0]
        # with the winding resistance known, the generating model predicts the other impedance
        # at the noise level (0.005 in magnitude); the wrong model does not
        assert best["model"] == "rayleigh" and best["predict_rms_complex"] < 0.015, table
        assert table.iloc[1]["predict_rms_complex"] > 3 * best["predict_rms_complex"], table


def test_one_source_impedance_leaves_a_scale_symmetry():
    """Core scaled by s and series resistance scaled by s: identical measured DF (fitdf.data.cores)."""
    from fitdf.chains import get_chain
    from fitdf.models import get_model

    chain, model = get_chain("winding"), get_model("constant_width")
    V = np.linspace(0.05, 5, 40)
    f = np.full_like(V, 6.0)
    base = chain.predict(
        model, V, f, np.full_like(V, 600.0), np.array([80.0, 2e-4, 0.04]), np.array([100.0, 1.0])
    )
    s = 3.0  # k -> s k, b -> b / s, c unchanged; R = 700 -> 2100 = 600 + 1500
    scaled = chain.predict(
        model,
        V,
        f,
        np.full_like(V, 600.0),
        np.array([80.0 * s, 2e-4 / s, 0.04]),
        np.array([700.0 * s - 600.0, 1.0]),
    )
    np.testing.assert_allclose(scaled, base, rtol=1e-8, atol=1e-10)
    # while at 0 ohm the same two cores differ: a joint fit can tell them apart
    zero = np.zeros_like(V)
    a = chain.predict(model, V, f, zero, np.array([80.0, 2e-4, 0.04]), np.array([100.0, 1.0]))
    b = chain.predict(
        model, V, f, zero, np.array([80.0 * s, 2e-4 / s, 0.04]), np.array([700.0 * s - 600.0, 1.0])
    )
    assert np.max(np.abs(a - b)) > 0.05


def test_winding_resistance_estimates_from_appendix_a():
    from fitdf.data.cores import winding_resistance_estimate

    assert winding_resistance_estimate("permalloy") == pytest.approx(53.8, abs=0.1)
    assert winding_resistance_estimate("deltamax") == pytest.approx(42.6, abs=0.1)
    with pytest.raises(OptionError, match="winding resistance"):
        winding_resistance_estimate("ferrite")
