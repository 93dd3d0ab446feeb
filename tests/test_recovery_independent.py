"""Recovery from data made by an independent code path (never the one being fitted).

The fitter predicts with the laws' closed-form (or fast) describing functions and the
chain's vectorised solver. The data here come from the numerical referee
(:func:`fitdf.numerical_df.numerical_describing_function`, a Fourier integral of the loop)
and a scalar root finder (:func:`scipy.optimize.brentq` on ``I |R + Z(I)| = V``), both in
``tests/referee.py``, with noise at the tables' printed precision (DF to 3 decimals,
phase to 0.1 degree, after Gaussian noise of 0.005 and 0.5 degree). A sign or factor
error in the closed forms, the chain or the current solver shows up as a truth outside
the reported intervals (99.9 % for one noise draw; the 95 % coverage over many draws is
a slow test).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from referee import referee_row

import fitdf

AMPLITUDES = np.array([0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0])
FREQUENCIES = (3.0, 6.0, 10.0)
CHAIN = {"r_series": 60.0, "gain": 0.95}
TRUTH = {
    "constant_width": {"k": 80.0, "b": 2e-4, "c": 0.04},
    "rayleigh": {"mu0": 20.0, "gamma": 8e4, "c_sat": 0.038},
    "proportional_width": {"k": 60.0, "c": 0.035, "m": 0.3},
}


def referee_frame(model, theta, seed, source_impedances=(0.0, 600.0)):
    rng = np.random.default_rng(seed)
    rows = [
        referee_row(model, theta, CHAIN, v, f, rs, rng)
        for rs in source_impedances
        for f in FREQUENCIES
        for v in AMPLITUDES
    ]
    return pd.DataFrame(rows)


def _within(result, truth, z=3.29):
    """Truth within ``z`` standard errors (from the 68 % interval): 3.29 is a 99.9 % interval,
    so a single noise draw fails this only by a real error, not by chance."""
    out = {}
    for name in result.problem.names:
        iv = result.intervals[name]
        half = 0.5 * (iv["p84"] - iv["p16"])
        out[name] = abs(result.values[name] - truth[name]) <= z * half
    return out


def _inside_95(result, truth):
    return {
        name: result.intervals[name]["p2.5"] <= truth[name] <= result.intervals[name]["p97.5"]
        for name in result.problem.names
    }


@pytest.mark.parametrize("model", list(TRUTH))
def test_winding_fit_recovers_truth_from_referee_data(model):
    truth = {**TRUTH[model], **CHAIN}
    frame = referee_frame(model, TRUTH[model], seed=11)
    result = fitdf.fit(frame, model, chain="winding", policy="all", seed=2, geometry=None)
    inside = _within(result, truth)
    assert all(inside.values()), (inside, result.values, result.intervals)
    # residuals at the noise level: 0.005 in magnitude, 0.5 deg (+ rounding) in phase
    assert result.metrics["rms_magnitude"] < 0.008
    assert result.metrics["rms_phase_deg"] < 1.0


@pytest.mark.slow
def test_coverage_of_the_95_percent_intervals_over_seeds():
    """Over repeated noise draws the least-squares 95 % intervals hold the truth ~95 % of the time."""
    model = "constant_width"
    truth = {**TRUTH[model], **CHAIN}
    hits, total = 0, 0
    for seed in range(12):
        frame = referee_frame(model, TRUTH[model], seed=100 + seed)
        result = fitdf.fit(
            frame, model, chain="winding", policy="all", seed=seed, n_starts=3, geometry=None
        )
        inside = _inside_95(result, truth)
        hits += sum(inside.values())
        total += len(inside)
    # 60 intervals: binomial(60, 0.95) has a 99.9 % lower quantile of ~0.82
    assert hits / total >= 0.82, (hits, total)
