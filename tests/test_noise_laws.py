"""The measurement-noise laws (fitdf.inference.noise_models): their scales at the boundaries,
the Student-t density against scipy, recovery of known noise and law parameters from data
whose noise is made the way an analyser reads (an independent generator, below), and the
command line's option."""

from __future__ import annotations

import contextlib
import io
import subprocess

import numpy as np
import pandas as pd
import pytest
from referee import referee_winding_df
from scipy import stats

import fitdf
from fitdf.data.fitdata import FitData
from fitdf.errors import OptionError
from fitdf.inference.api import MCMC_NOISE, resolve_data
from fitdf.inference.noise_models import (
    NOISE_LAWS,
    PARAMETER_BOUNDS,
    get_noise_law,
    output_gain,
    student_logpdf,
)


def _frame(input_v, df, phase_deg, h1=None, table="T"):
    out = {
        "table": table,
        "frequency_hz": 6.0,
        "input_v": np.asarray(input_v, float),
        "df_reported": np.asarray(df, float),
        "phase_lead_deg": np.asarray(phase_deg, float),
    }
    if h1 is not None:
        out["h1_output_v"] = np.asarray(h1, float)
    return pd.DataFrame(out)


def _data(input_v, df, phase_deg, gain=None):
    h1 = None if gain is None else np.asarray(df) * np.asarray(input_v) / gain
    return FitData.from_frame(_frame(input_v, df, phase_deg, h1))


# ------------------------------------------------------------------ the scales
def test_reading_scales_at_their_boundaries():
    """Far above the crossover the floors alone, far below it the reading terms alone, at the
    crossover each term equal: the magnitude's at ``V = g r_m / s_m``, the phase's where the
    output is ``r_p / s_p``."""
    g, s_m, s_p, r_m, r_p = 3.3, 0.01, 1.0, 1e-3, 2e-3
    law = get_noise_law("reading")
    cross = g * r_m / s_m  # 0.33 V
    v = np.array([1e3 * cross, cross, 1e-3 * cross])
    D = np.full(3, 0.9)
    data = _data(v, D, np.zeros(3), gain=g)
    ctx = law.context(data)
    assert ctx["gain"] == pytest.approx(g, rel=1e-12)
    theta = np.log10([s_m, s_p, r_m, r_p])
    sm, st = law.scales(theta, ctx)
    assert sm[0] == pytest.approx(s_m, rel=1e-6)
    assert sm[1] == pytest.approx(np.sqrt(2.0) * s_m, rel=1e-12)
    assert sm[2] == pytest.approx(g * r_m / v[2], rel=1e-6)
    # the phase error in radians is sqrt(s_p^2 + (r_p / V_out)^2), V_out = |D| V / g
    v_out = D * v / g
    phase = st / D
    expected = np.hypot(np.deg2rad(s_p), r_p / v_out)
    np.testing.assert_allclose(phase, expected, rtol=1e-12)
    assert phase[0] == pytest.approx(np.deg2rad(s_p), rel=1e-6)
    assert phase[2] == pytest.approx(r_p / v_out[2], rel=1e-6)


def test_constant_scales_do_not_depend_on_the_input():
    law = get_noise_law("constant")
    data = _data([0.01, 1.0, 10.0], [0.5, 0.9, 0.0], [10.0, 1.0, 0.0])
    sm, st = law.scales(np.log10([0.02, 2.0]), law.context(data))
    np.testing.assert_allclose(sm, 0.02)
    np.testing.assert_allclose(st, np.array([0.5, 0.9, 0.0]) * np.deg2rad(2.0), rtol=1e-12)


def test_a_row_without_phase_has_no_arc_term():
    """DF = 0: its arc residual (and scale) change nothing; it counts one term, not two."""
    law = get_noise_law("reading")
    data = _data([0.01, 1.0], [0.0, 0.9], [0.0, 3.0])
    ctx = law.context(data)
    theta = law.start()
    radial = np.array([0.01, 0.02])
    a = law.pointwise(theta, radial, np.array([0.0, 0.01]), ctx)
    b = law.pointwise(theta, radial, np.array([5.0, 0.01]), ctx)
    assert a[0] == b[0] and a[1] == b[1]
    assert law.n_terms(ctx) == 3


def test_output_gain_is_the_tables_factor_and_one_without_outputs():
    fd = resolve_data("B.1")
    g = output_gain(fd)
    # the audit's factor of B.1's blocks: 3.294-3.300 (the footnote's 1250/417 = 2.998)
    assert np.all((g > 3.28) & (g < 3.31)), np.unique(g)
    np.testing.assert_allclose(output_gain(resolve_data("B.3")), 1.0, atol=0.005)
    assert np.all(output_gain(_data([0.1, 1.0], [0.9, 0.9], [1.0, 1.0])) == 1.0)


def test_gaussian_pointwise_is_the_normal_density():
    law = get_noise_law("reading")
    data = _data([0.05, 0.5, 5.0], [0.5, 0.8, 0.9], [20.0, 5.0, 1.0], gain=1.0)
    ctx = law.context(data)
    theta = np.log10([0.01, 1.5, 1e-3, 3e-3])
    sm, st = law.scales(theta, ctx)
    radial, tang = np.array([0.03, -0.01, 0.002]), np.array([-0.05, 0.02, 0.001])
    expected = stats.norm.logpdf(radial, scale=sm) + stats.norm.logpdf(tang, scale=st)
    np.testing.assert_allclose(law.pointwise(theta, radial, tang, ctx), expected, rtol=1e-12)


# ------------------------------------------------------------------ Student-t
@pytest.mark.parametrize("nu", [1.0, 1.5, 4.0, 30.0, 100.0])
def test_student_logpdf_is_scipys(nu):
    z = np.array([-80.0, -3.0, -0.5, 0.0, 0.7, 2.5, 40.0])
    np.testing.assert_allclose(student_logpdf(z, nu), stats.t.logpdf(z, nu), rtol=1e-12)


def test_student_pointwise_is_scipys_scaled_t():
    law = get_noise_law("reading-student")
    data = _data([0.05, 0.5, 5.0], [0.5, 0.8, 0.0], [20.0, 5.0, 0.0], gain=1.0)
    ctx = law.context(data)
    theta = np.log10([0.01, 1.5, 1e-3, 3e-3, 3.0])
    sm, st = law.scales(theta, ctx)
    radial, tang = np.array([0.3, -0.01, 0.002]), np.array([-0.05, 0.02, 0.0])
    expected = stats.t.logpdf(radial, 3.0, scale=sm) + np.where(
        [True, True, False], stats.t.logpdf(tang, 3.0, scale=st), 0.0
    )
    np.testing.assert_allclose(law.pointwise(theta, radial, tang, ctx), expected, rtol=1e-12)


def test_student_weights_are_its_em_weights():
    """Row scales of the least-squares step: sigma / sqrt((nu + 1) / (nu + z^2))."""
    law = get_noise_law("student")
    data = _data([0.5, 0.5], [0.8, 0.8], [5.0, 5.0])
    ctx = law.context(data)
    theta = np.log10([0.01, 1.0, 4.0])
    radial = np.array([0.0, 0.05])  # z = 0 and 5
    sm, _ = law.weights_scales(theta, radial, np.zeros(2), ctx)
    np.testing.assert_allclose(sm, 0.01 / np.sqrt(5.0 / np.array([4.0, 29.0])), rtol=1e-12)


# ------------------------------------------------------------------ recovery
TRUTH_LAW = {"k": 60.0, "c": 0.035, "m": 0.3}
TRUTH_CHAIN = {"r_series": 60.0, "gain": 0.95}
#: Known noise: floors 0.005 and 0.5 degree; reading resolutions 0.3 mV (magnitude) and
#: 0.6 mV (phase) of an output read through a factor 3.3 (Table B.1's): the reading terms
#: overtake the floors below about 0.2 V.
TRUTH_NOISE = {"s_m": 0.005, "s_p_deg": 0.5, "r_m": 3e-4, "r_p": 6e-4}
GAIN = 3.3


def analyser_frame(seed, noise=TRUTH_NOISE):
    """Rows read as the analyser reads them (written here, not through the noise laws): the
    referee's DF (tests/referee.py) gives the output phasor ``U = DF V / g``; its amplitude is
    read with an error of ``r_m`` volts and its phase with ``r_p / |U|`` rad, the DF formed as
    ``g x reading / V``, then the floors' errors added and the cells rounded."""
    rng = np.random.default_rng(seed)
    rows = []
    for rs in (0.0, 600.0):
        for f in (3.0, 6.0, 10.0):
            for v in np.geomspace(0.02, 5.0, 16):
                d = referee_winding_df(
                    "proportional_width", TRUTH_LAW, v, f, rs + 60.0, TRUTH_CHAIN["gain"]
                )
                u = d * v / GAIN
                amp = abs(u) + noise["r_m"] * rng.standard_normal()
                phase = np.angle(u) + noise["r_p"] / abs(u) * rng.standard_normal()
                df = GAIN * amp / v + noise["s_m"] * rng.standard_normal()
                lead = np.rad2deg(phase) + noise["s_p_deg"] * rng.standard_normal()
                rows.append(
                    {
                        "table": "analyser",
                        "source_impedance_ohm": rs,
                        "frequency_hz": f,
                        "input_v": v,
                        "h1_output_v": round(amp, 6),
                        "df_reported": round(df, 4),
                        "phase_lead_deg": round(lead, 2),
                    }
                )
    return pd.DataFrame(rows)


def test_reading_law_recovers_known_noise_and_law_parameters():
    frame = analyser_frame(seed=5)
    kw = dict(chain="winding", policy="all", seed=1, geometry=None, n_starts=3)
    reading = fitdf.fit(frame, "proportional_width", noise="reading", **kw)
    constant = fitdf.fit(frame, "proportional_width", noise="constant", **kw)
    fitted = reading.info["noise_law"]["values"]
    # 96 rows, about half on each side of the crossover: each scale's relative standard
    # error is ~1 / sqrt(2 x 48) = 10 %; 35 % is 3.5 of them
    for name, true in TRUTH_NOISE.items():
        assert abs(np.log(fitted[name] / true)) < np.log(1.35), (name, fitted)
    truth = {**TRUTH_LAW, **TRUTH_CHAIN}
    for name in reading.problem.names:
        iv = reading.intervals[name]
        half = 0.5 * (iv["p84"] - iv["p16"])
        assert abs(reading.values[name] - truth[name]) <= 3.29 * half, (name, reading.values)
    # the growing error is what the evidence sees: AICc far lower than the constant law's
    assert constant.metrics["aicc"] - reading.metrics["aicc"] > 20.0
    # the reported likelihood is the law's at the reported optimum
    law, problem = get_noise_law("reading"), reading.problem
    errors = problem.error_components(problem.predict(reading.internal))
    total = np.sum(
        law.pointwise(reading.info["noise_law"]["log10"], *errors, law.context(problem.data))
    )
    assert reading.metrics["log_likelihood"] == pytest.approx(total, abs=1e-9)
    # the law's parameters are refitted under the fitted noise (weighted by it), not left at
    # the printed-scale optimum (that optimum with its best noise parameters is 13 lower)
    printed = fitdf.fit(frame, "proportional_width", **kw)
    at_printed = printed.problem.error_components(printed.problem.predict(printed.internal))
    _, loglike_printed = law.fit(*at_printed, law.context(printed.problem.data))
    assert total - loglike_printed > 5.0, (total, loglike_printed)
    # the fit's text states the fitted law from those numbers
    text = " ".join(reading.summary(width=1000).split())
    line = " ".join(f"{k} {v:.3g}" for k, v in fitted.items())
    assert f"noise law reading (fitted; log-likelihood {total:.2f}): {line}" in text


def test_without_reading_errors_the_resolutions_are_not_determined():
    """Noise of floors only: the reading resolutions fall toward their lower bounds (or below
    what the rows resolve), and the reading law buys at most a little likelihood for them."""
    noise = {**TRUTH_NOISE, "r_m": 0.0, "r_p": 0.0}
    frame = analyser_frame(seed=6, noise=noise)
    kw = dict(chain="winding", policy="all", seed=1, geometry=None, n_starts=3)
    reading = fitdf.fit(frame, "proportional_width", noise="reading", **kw)
    constant = fitdf.fit(frame, "proportional_width", noise="constant", **kw)
    fitted = reading.info["noise_law"]["values"]
    # a resolution of 1e-5 V moves the smallest row's DF error by 3.3e-5 / 0.02 = 0.0017,
    # a third of the floor; anything the rows would resolve is 3x that
    assert fitted["r_m"] < 3e-5 and fitted["r_p"] < 3e-5, fitted
    assert reading.metrics["log_likelihood"] - constant.metrics["log_likelihood"] < 3.0
    assert reading.metrics["aicc"] > constant.metrics["aicc"] - 2.0


def test_printed_is_the_default():
    frame = analyser_frame(seed=7)
    kw = dict(chain="winding", policy="all", seed=1, geometry=None, n_starts=2)
    a = fitdf.fit(frame, "proportional_width", **kw)
    b = fitdf.fit(frame, "proportional_width", noise="printed", **kw)
    assert a.metrics["chi2"] == b.metrics["chi2"] and "noise_law" not in b.info
    assert a.problem.noise_law is None and b.problem.noise_law is None


# ------------------------------------------------------------------ options
def test_noise_law_names_and_bounds():
    assert tuple(NOISE_LAWS) == ("printed", "constant", "reading", "student", "reading-student")
    from fitdf import cli_parser

    assert cli_parser.NOISE_CHOICES == tuple(NOISE_LAWS)
    assert cli_parser.MCMC_NOISE == MCMC_NOISE
    for name, (lo, hi) in PARAMETER_BOUNDS.items():
        assert 0 < lo < hi, name
    with pytest.raises(OptionError, match="unknown noise law 'gaussian'"):
        get_noise_law("gaussian")
    with pytest.raises(OptionError, match="'reading' needs method 'lsq' or 'nested'"):
        fitdf.fit("B.2", "rayleigh", method="mcmc", noise="reading")


def _run_here(*args):
    from fitdf.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:
            code = exc.code
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


@pytest.mark.parametrize(
    "args, fragment",
    [
        (("--noise", "gaussian"), "--noise: invalid choice: 'gaussian'"),
        (
            ("--noise", "reading", "--method", "mcmc"),
            "--noise reading needs --method lsq or nested",
        ),
        (
            ("--noise", "student", "--method", "both"),
            "--noise student needs --method lsq or nested",
        ),
    ],
)
def test_cli_bad_noise_option_is_a_one_line_error(args, fragment):
    proc = _run_here("fit", "B.2", *args)
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert fragment in lines[0], lines[0]


@pytest.mark.slow
def test_cross_validation_scores_held_out_rows_by_the_noise_law():
    """On rows with reading noise the reading law predicts the held-out frequency blocks'
    rows more probably than the constant law (their log density), and the score is the sum
    of the folds'."""
    from fitdf.inference.ranking import cross_validate

    frame = analyser_frame(seed=8)
    kw = dict(chain="winding", policy="all", seed=1, geometry=None, n_starts=2)
    scores = {}
    for name in ("constant", "reading"):
        cv = cross_validate(fitdf.fit(frame, "proportional_width", noise=name, **kw), seed=1)
        assert cv["cv_folds"] == 6
        folds = [fold["log_score"] for fold in cv["cv_per_fold"]]
        assert cv["cv_log_score"] == pytest.approx(sum(folds), abs=1e-9)
        scores[name] = cv["cv_log_score"]
    assert scores["reading"] - scores["constant"] > 20.0, scores
