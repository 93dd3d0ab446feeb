"""Series permeability at matched flux (fitdf.inference.permeability, .matched_flux) and the
printed precision of a reading (fitdf.data.precision), against computations made here."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from scipy.integrate import solve_ivp
from supermalloy_fits import DYNAMIC, STATIC, near_optimum

from fitdf import datasets
from fitdf.data.cores import core_geometry
from fitdf.data.fitdata import FitData
from fitdf.data.precision import reading_resolution
from fitdf.data.resolve import resolve_data
from fitdf.errors import ModelError
from fitdf.inference.matched_flux import DOUBLINGS, _rising, log_interp, matched_flux
from fitdf.inference.permeability import (
    drawn_permeability,
    reading_flux,
    row_permeability,
)
from fitdf.inference.problem import FitProblem
from fitdf.inference.small_signal import series_permeability

GEOMETRY = core_geometry("supermalloy")


# --- the inversion through Fig 5.10, against the circuit integrated in time ----------------


def _first_harmonic(t, y, w):
    """``(2/T) int y (sin + j cos) dt`` over the last period: the phasor of ``y`` with a lead
    positive (the convention of the readings)."""
    return 2.0 * np.mean(y * (np.sin(w * t) + 1j * np.cos(w * t)))


def test_inversion_recovers_a_lossy_linear_winding_from_its_simulated_reading():
    """A winding of inductance L with a core-loss resistance r_c in series, driven through R:
    the circuit integrated in time, its output's first harmonic taken numerically, then
    inverted: mu' = L / (mu_0 N^2 A_e / l_e), Q = w L / r_c, and the reading's flux is the
    first harmonic of lambda = L i + r_c int i dt (the EMF's integral)."""
    f, R, gain, V = 10.0, 680.0, 1.02, 0.1
    w = 2 * math.pi * f
    mu_true, q_true = 2.0e4, 3.0
    L = mu_true * GEOMETRY.inductance_per_permeability
    r_c = w * L / q_true

    def rhs(t, y):  # y = (i, int i dt)
        i = y[0]
        return [(V * math.sin(w * t) - (R + r_c) * i) / L, i]

    periods = 40  # L / (R + r_c) is 0.15 period: the start has died out by then
    t_end = periods / f
    last = np.linspace(t_end - 1 / f, t_end, 4096, endpoint=False)
    sol = solve_ivp(
        rhs, (0, t_end), [0.0, 0.0], t_eval=last, rtol=1e-11, atol=1e-14, method="DOP853"
    )
    i, q = sol.y
    emf = V * np.sin(w * last) - R * i  # the winding's terminal voltage
    df = gain * _first_harmonic(last, emf, w) / V
    mu = complex(series_permeability(df, f, R, gain, GEOMETRY))
    assert mu.real == pytest.approx(mu_true, rel=1e-6)
    assert mu.real / -mu.imag == pytest.approx(q_true, rel=1e-6)
    lam = L * i + r_c * q
    flux = abs(_first_harmonic(last, lam, w))
    assert float(reading_flux(df, V, f, gain)) == pytest.approx(flux, rel=1e-6)


# --- interpolation along the flux axis -------------------------------------------------------


def test_log_interp_is_exact_for_values_linear_in_log_flux():
    a, b = 3.0 + 1.0j, 2.0 - 0.5j
    flux = np.array([4e-3, 1e-3, 2e-3, 9e-3])  # unsorted on purpose
    y = a + b * np.log(flux)
    for level in (1.5e-3, 2e-3, 7e-3, 5e-4, 2e-2):  # inside, at a point, beyond both ends
        assert complex(log_interp(level, flux, y)) == pytest.approx(a + b * math.log(level))
    # a point is its own value exactly, whatever the segment search picks
    assert log_interp(2e-3, flux, y) == y[2]
    # a batch: one row per draw, each with its own points
    rng = np.random.default_rng(1)
    many = flux * np.exp(rng.uniform(-0.2, 0.2, size=(6, 4)))
    got = log_interp(3e-3, many, a + b * np.log(many))
    np.testing.assert_allclose(got, a + b * math.log(3e-3), rtol=1e-12)
    # but not for values linear in the flux itself: the interpolation is in log flux
    lin = 5.0 + 1e3 * flux
    assert log_interp(1.5e-3, flux, lin) != pytest.approx(5.0 + 1.5)
    assert log_interp(1e-3, flux[:1], lin[:1]) == lin[0]


# --- the printed precision ----------------------------------------------------------------


def test_reading_resolution_is_half_a_unit_of_the_printed_digit():
    frame = datasets.load("B.4")
    df, phase = reading_resolution(frame)
    by = {(f, v): (d, p) for f, v, d, p in zip(frame["frequency_hz"], frame["input_v"], df, phase)}
    assert by[(3.0, 0.1)] == (0.05, 0.5)  # DF "0.4", phase "66"
    assert by[(3.0, 0.35)][0] == 0.005  # "0.71"
    assert by[(30.0, 0.2)][0] == pytest.approx(0.0005)  # "0.825"
    # a DF printed "1" among two-decimal DFs is read at two decimals (the audit's rule)
    assert by[(30.0, 3.0)][0] == pytest.approx(0.005)
    # without the printed text, from the values' shortest form; a half-degree phase
    plain = pd.DataFrame(
        {
            "input_v": [0.1, 0.2],
            "df_reported": [0.45, 0.825],
            "phase_lead_deg": [12.0, 2.5],
            "frequency_hz": [3.0, 3.0],
        }
    )
    d, p = reading_resolution(plain)
    np.testing.assert_allclose(d, [0.005, 0.0005])
    np.testing.assert_allclose(p, [0.5, 0.05])


# --- the comparison on Table B.4 -----------------------------------------------------------


@pytest.fixture(scope="module")
def fits():
    return near_optimum("voltage", STATIC), near_optimum("dynamic", DYNAMIC)


@pytest.fixture(scope="module")
def compared(fits):
    return matched_flux(*fits, draws=400, seed=3)


def _by_hand(fit):
    """mu (complex) and flux of every measured row, through Fig 5.10 written out here."""
    d, v = fit.problem.data, fit.values
    R = d.source_impedance + v["r_series"]
    D = d.measured
    Z = R * D / (v["gain"] - D)
    mu = Z / (2j * np.pi * d.frequency) * GEOMETRY.l_e / (4e-7 * np.pi * 1250**2 * GEOMETRY.a_e)
    flux = np.abs(D) * d.amplitude / v["gain"] / (2 * np.pi * d.frequency)
    return mu, flux


def test_rows_are_inverted_with_the_fits_own_resistance_and_gain(fits, compared):
    static, dynamic = fits
    for fit in (static, dynamic):
        mu, flux = _by_hand(fit)
        rows = row_permeability(fit)
        np.testing.assert_allclose(rows["mu"], mu.real, rtol=1e-12)
        np.testing.assert_allclose(rows["mu_loss"], -mu.imag, rtol=1e-12)
        np.testing.assert_allclose(rows["q"], mu.real / -mu.imag, rtol=1e-12)
        np.testing.assert_allclose(rows["flux_vs"], flux, rtol=1e-12)
    assert compared.fits["static"]["r_total_ohm"] == pytest.approx(600 + STATIC["r_series"])
    assert compared.fits["dynamic"]["gain"] == dynamic.values["gain"]


def test_levels_are_each_frequencys_smallest_flux_and_doublings_of_the_largest(fits, compared):
    mu, flux = _by_hand(fits[0])
    d = fits[0].problem.data
    smallest = {
        f: flux[d.frequency == f][np.argmin(d.amplitude[d.frequency == f])]
        for f in np.unique(d.frequency)
    }
    common = max(smallest.values())
    assert compared.common_vs == pytest.approx(common, rel=1e-12)
    got = sorted(set(compared.levels["level_vs"]))
    # 6 and 10 c/s print the same flux at 0.1 V (0.045/6 = 0.075/10): one level
    expect = sorted({round(v, 12) for v in smallest.values()})
    expect += [common * 2**k for k in range(1, DOUBLINGS + 1)]
    np.testing.assert_allclose(got, expect, rtol=1e-9)
    # at its own level a frequency gives its smallest row itself
    own = compared.levels[compared.levels["own"]]
    assert sorted(own["frequency_hz"]) == sorted(smallest)
    for _, r in own.iterrows():
        f = r["frequency_hz"]
        row = np.flatnonzero(d.frequency == f)[np.argmin(d.amplitude[d.frequency == f])]
        assert r["level_vs"] == pytest.approx(smallest[f], rel=1e-9)
        assert r["mu"] == pytest.approx(mu[row].real, rel=1e-9)
        assert r["q"] == pytest.approx(mu[row].real / -mu[row].imag, rel=1e-9)
    # a frequency enters a level only where its rows span it: 3 c/s starts at the common one
    assert set(compared.levels.loc[compared.levels["frequency_hz"] == 3.0, "level_vs"]) == {
        v for v in got if v >= common * (1 - 1e-12)
    }


def test_a_frequency_between_its_rows_is_interpolated_in_log_flux(fits, compared):
    """At the common level 6 c/s lies between its 0.1 and 0.2 V rows: the straight line in
    (ln flux, mu) through them, computed here."""
    mu, flux = _by_hand(fits[0])
    d = fits[0].problem.data
    lo, hi = (np.flatnonzero((d.frequency == 6.0) & (d.amplitude == v))[0] for v in (0.1, 0.2))
    level = compared.common_vs
    assert flux[lo] < level < flux[hi]
    t = math.log(level / flux[lo]) / math.log(flux[hi] / flux[lo])
    expect = mu[lo] + t * (mu[hi] - mu[lo])
    got = compared.levels.set_index(["level_vs", "frequency_hz"]).loc[(level, 6.0)]
    assert got["mu"] == pytest.approx(expect.real, rel=1e-9)
    assert got["q"] == pytest.approx(expect.real / -expect.imag, rel=1e-9)
    assert got["mu_lo"] < got["mu"] < got["mu_hi"]


def test_frequency_dependence_is_a_power_law_with_its_t_interval(compared):
    at = compared.levels
    for _, r in compared.frequency.iterrows():
        t = at[at["level_vs"] == r["level_vs"]].sort_values("frequency_hz")
        f, mu = t["frequency_hz"].to_numpy(), t["mu"].to_numpy()
        assert r["n_frequencies"] == f.size and r["frequencies_hz"] == list(f)
        assert r["ratio"] == pytest.approx(mu.max() / mu.min(), rel=1e-12)
        assert r["first_over_last"] == pytest.approx(mu[0] / mu[-1], rel=1e-12)
        if f.size < 3:
            assert math.isnan(r["slope_se"]) and math.isnan(r["slope_lo"])
            assert r["contains_static"] is None
            continue
        (slope, icpt), res, *_ = np.polyfit(np.log(f), np.log(mu), 1, full=True)
        se = math.sqrt(res[0] / (f.size - 2) / np.sum((np.log(f) - np.log(f).mean()) ** 2))
        half = stats.t.ppf(0.975, f.size - 2) * se
        assert r["slope"] == pytest.approx(slope, rel=1e-9)
        assert r["slope_se"] == pytest.approx(se, rel=1e-9)
        assert (r["slope_lo"], r["slope_hi"]) == pytest.approx((slope - half, slope + half))
        assert r["scatter"] == pytest.approx(math.sqrt(res[0] / f.size), rel=1e-9)
        law = np.polyfit(np.log(f), np.log(t["mu_dynamic"].to_numpy()), 1)[0]
        assert r["slope_dynamic"] == pytest.approx(law, rel=1e-9)
        assert r["contains_dynamic"] == (slope - half <= law <= slope + half)


def test_the_rise_at_small_flux_is_read_off_the_levels(compared):
    at = compared.levels.set_index(["level_vs", "frequency_hz"])
    common = compared.common_vs
    for _, r in compared.small_flux.iterrows():
        own, top = at.loc[(r["flux_vs"], r["frequency_hz"])], at.loc[(common, r["frequency_hz"])]
        assert r["rise"] == pytest.approx(top["mu"] / own["mu"], rel=1e-12)
        assert r["rise_static"] == pytest.approx(top["mu_static"] / own["mu_static"], rel=1e-12)
        assert r["rise_dynamic"] == pytest.approx(top["mu_dynamic"] / own["mu_dynamic"])
        assert r["over_static"] == pytest.approx(own["mu"] / own["mu_static"], rel=1e-12)
        assert r["rise_lo"] <= r["rise"] <= r["rise_hi"] or r["flux_vs"] == common


def test_a_rate_independent_law_read_as_a_sinusoidal_current_has_no_frequency_dependence():
    """Through the ``winding`` chain the reading is ``gain Z/(R + Z)`` with ``Z = j w N(I)``:
    its inverted mu' is ``Re N(I)`` at the flux ``|N(I)| I``, the same curve at every
    frequency, so the law's slope at matched flux is 0 (to the curves' grid and the
    interpolation); this fails if the flux or mu' forgot the frequency or the gain."""
    fit = near_optimum("winding", STATIC)
    got = matched_flux(fit, draws=50)
    slopes = got.frequency["slope_static"].dropna()
    assert len(slopes) >= 4 and np.abs(slopes).max() < 1e-3


def test_printed_precision_draws_are_seeded_and_bracket_the_printed_corners(fits, compared):
    static = fits[0]
    # the rows' ranges are the central 95 % of the comparison's own draws
    flux, mu = drawn_permeability(static, GEOMETRY, 400, seed=3)
    np.testing.assert_allclose(compared.rows["mu_lo"], np.percentile(mu.real, 2.5, axis=0))
    np.testing.assert_allclose(compared.rows["mu_hi"], np.percentile(mu.real, 97.5, axis=0))
    np.testing.assert_allclose(compared.rows["flux_hi"], np.percentile(flux, 97.5, axis=0))
    a = drawn_permeability(static, GEOMETRY, 300, seed=5)
    b = drawn_permeability(static, GEOMETRY, 300, seed=5)
    c = drawn_permeability(static, GEOMETRY, 300, seed=6)
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])
    # the 3 c/s, 0.1 V row, printed 0.4 at 66 deg: its draws lie inside the four corners'
    # range of the printed rectangle (mu' is monotone in both there) and fill most of it
    d = static.problem.data
    row = np.flatnonzero((d.frequency == 3.0) & (d.amplitude == 0.1))[0]
    corners = [
        (0.4 + dm) * np.exp(1j * np.deg2rad(66 + dp)) for dm in (-0.05, 0.05) for dp in (-0.5, 0.5)
    ]
    R, g = 600 + static.values["r_series"], static.values["gain"]
    mu_c = series_permeability(np.array(corners), 3.0, R, g, GEOMETRY).real
    drawn = a[1][:, row].real
    assert mu_c.min() <= drawn.min() and drawn.max() <= mu_c.max()
    assert drawn.max() - drawn.min() > 0.5 * (mu_c.max() - mu_c.min())
    # read back through the circuit, each row's draws fill its printed rectangle: 50 c/s,
    # 0.2 V is printed 0.805 at 13 deg (half units 0.0005 and 0.5 deg)
    row = np.flatnonzero((d.frequency == 50.0) & (d.amplitude == 0.2))[0]
    Z = 2j * np.pi * 50.0 * GEOMETRY.inductance_per_permeability * a[1][:, row]
    back = g * Z / (R + Z)
    for value, centre, half in ((np.abs(back), 0.805, 5e-4), (np.angle(back, deg=True), 13, 0.5)):
        assert np.all(np.abs(value - centre) <= half * (1 + 1e-9))
        assert value.max() - value.min() > 1.8 * half


def test_one_table_at_one_impedance_and_a_geometry_are_required():
    joint = FitProblem(resolve_data("permalloy", "default"), "rayleigh", "voltage")
    fake = SimpleNamespace(problem=joint, values={"r_series": 60.0, "gain": 1.0})
    with pytest.raises(ModelError, match="one table at one source impedance"):
        row_permeability(fake, GEOMETRY)
    alone = FitProblem(resolve_data("B.4", "default"), "rayleigh", "voltage")
    fake = SimpleNamespace(problem=alone, values={"r_series": 60.0, "gain": 1.0})
    with pytest.raises(ModelError, match="geometry"):
        row_permeability(fake)


def test_rising_stretch_ends_where_the_flux_first_stops_rising():
    """A repeated flux (a row on the saturation flat) ends the stretch: the flux no longer
    orders the rows there."""
    flux = np.array([3.0, 1.0, 2.0, 2.0, 4.0])
    inputs = np.array([0.3, 0.1, 0.2, 0.25, 0.4])
    assert list(_rising(flux, inputs)) == [1, 2]
    assert list(_rising(np.array([1.0, 2.0, 3.0]), np.array([1.0, 2.0, 3.0]))) == [0, 1, 2]


def test_smallest_fluxes_a_rounding_apart_are_one_level_own_to_both(fits):
    """6 and 10 c/s print the same smallest flux; moved 1e-12 apart they stay one level, at
    which both give their own smallest row."""
    static = fits[0]
    d = static.problem.data
    row = np.flatnonzero((d.frequency == 10.0) & (d.amplitude == 0.1))[0]
    measured = d.measured.copy()
    measured[row] *= 1 + 1e-12
    moved = FitData(
        d.amplitude, d.frequency, d.source_impedance, measured, d.group, d.rows, d.label, d.core
    )
    p = static.problem
    problem = FitProblem(moved, p.model, p.chain, p.noise, p.fixed, p.geometry)
    got = matched_flux(dataclasses.replace(static, problem=problem), draws=20)
    own = got.levels[got.levels["own"]]
    shared = own.loc[own["frequency_hz"].isin([6.0, 10.0]), "level_vs"]
    assert len(shared) == 2 and shared.nunique() == 1
    assert sorted(got.small_flux["frequency_hz"]) == [3.0, 6.0, 10.0, 30.0, 50.0]
