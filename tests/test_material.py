"""Core geometry, unit conversions and law-generic material constants (fitdf.data.cores, fitdf.inference.material)."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

import fitdf
from fitdf.data.cores import (
    A_PER_M_PER_OERSTED,
    MU_0,
    STACKING_FACTOR,
    STACKING_FACTOR_RANGE,
    CoreGeometry,
    appendix_a_ranges,
    core_geometry,
    winding_resistance_estimate,
)
from fitdf.errors import OptionError
from fitdf.inference.material import (
    CHECK_QUANTITIES,
    DETERMINED_BY,
    SMALL_SIGNAL_RATIO,
    appendix_a_check,
    current_from_field,
    field_from_current,
    flux_linkage_from_induction,
    implied_stacking_factor,
    inductance_from_permeability,
    induction_from_flux_linkage,
    loop_landmarks,
    material_constants,
    permeability_from_inductance,
)
from fitdf.models.constant_width import ConstantWidth
from fitdf.models.frequency_hc import FrequencyHc
from fitdf.models.rayleigh import Rayleigh, coercive_force, frohlich_kennelly, remanence
from fitdf.report.physics_outline import _joint

IN = 0.0254


# --- geometry and unit conversions (hand-computed numbers) ----------------------------------


def test_permalloy_geometry_by_hand():
    g = core_geometry("permalloy")
    # 2.5 x 2.0 x 0.5 in, 1250 turns: l_e = pi * 2.25 in, A_e = 0.25 in * 0.5 in * 0.85
    assert g.turns == 1250
    assert g.l_e == pytest.approx(0.1795420, rel=1e-6)
    assert g.a_e == pytest.approx(0.125 * 0.0254**2 * 0.85, rel=1e-12)
    assert g.a_e == pytest.approx(6.854825e-5, rel=1e-6)
    assert g.stacking_factor == STACKING_FACTOR == 0.85
    assert g.r_winding_estimate == winding_resistance_estimate("permalloy")
    assert g.field_per_ampere == pytest.approx(6962.16, rel=1e-5)  # A/m per A
    assert float(g.field_oe(1.0)) == pytest.approx(87.489, rel=1e-4)  # Oe per A
    # mu_0 N^2 A_e / l_e = 4 pi 1e-7 * 1.5625e6 * 6.8548e-5 / 0.17954 = 7.4965e-4 H
    assert g.inductance_per_permeability == pytest.approx(7.49653e-4, rel=1e-5)
    # mu_i = 10,000-40,000 -> 7.5-30 H at the assumed stacking factor 0.85; the issue's
    # "roughly 9-35 H" is the gross section (stacking factor 1): 8.8-35.3 H.
    assert inductance_from_permeability(1e4, g) == pytest.approx(7.4965, rel=1e-4)
    gross = core_geometry("permalloy", stacking_factor=1.0)
    assert inductance_from_permeability(1e4, gross) == pytest.approx(8.8194, rel=1e-4)
    assert inductance_from_permeability(4e4, gross) == pytest.approx(35.278, rel=1e-4)


def test_deltamax_and_supermalloy_geometry():
    d = core_geometry("deltamax")
    assert d.turns == 2000
    assert d.l_e == pytest.approx(math.pi * 1.125 * IN, rel=1e-12)  # 0.08977 m
    assert d.a_e == pytest.approx(0.125 * 0.125 * IN**2 * 0.85, rel=1e-12)  # 8.5685e-6 m^2
    assert d.inductance_per_permeability == pytest.approx(4.7978e-4, rel=1e-4)
    assert d.field_per_ampere == pytest.approx(22278.9, rel=1e-5)
    s = core_geometry("Supermalloy")
    p = core_geometry("permalloy")
    assert (s.turns, s.l_e, s.a_e) == (p.turns, p.l_e, p.a_e)
    with pytest.raises(OptionError):
        core_geometry("ferrite")


def test_unit_constants_and_round_trips():
    assert A_PER_M_PER_OERSTED == pytest.approx(79.5775, rel=1e-6)
    assert MU_0 == pytest.approx(1.25663706e-6, rel=1e-8)
    g = core_geometry("permalloy")
    # B = lambda / (N A_e): 1e-2 V s -> 1e-2 / (1250 * 6.854825e-5) T = 0.116706 T = 1167.06 G
    assert float(g.induction(1e-2)) == pytest.approx(0.1167061, rel=1e-6)
    assert induction_from_flux_linkage(1e-2, g) == pytest.approx(1167.061, rel=1e-6)
    # mu_r = L l_e / (mu_0 N^2 A_e)
    assert permeability_from_inductance(10.0, g) == pytest.approx(10.0 / 7.49653e-4, rel=1e-5)
    x = np.array([0.003, 0.1, 7.0])
    np.testing.assert_allclose(field_from_current(current_from_field(x, g), g), x, rtol=1e-14)
    np.testing.assert_allclose(
        induction_from_flux_linkage(flux_linkage_from_induction(x, g), g), x, rtol=1e-14
    )
    np.testing.assert_allclose(
        permeability_from_inductance(inductance_from_permeability(x, g), g), x, rtol=1e-14
    )
    # 0.1 Oe on Permalloy: 7.9577 A/m * l_e / N = 1.1430 mA
    assert current_from_field(0.1, g) == pytest.approx(7.95775 * 0.179542 / 1250, rel=1e-5)
    assert isinstance(current_from_field(0.1, g), float)


def test_user_geometry_from_dimensions_matches_bundled_core():
    bundled = core_geometry("deltamax")
    user = CoreGeometry.from_dimensions(2000, 1.25 * IN, 1.0 * IN, 0.125 * IN, name="mine")
    assert user.l_e == pytest.approx(bundled.l_e, rel=1e-14)
    assert user.a_e == pytest.approx(bundled.a_e, rel=1e-14)
    assert user.inductance_per_permeability == pytest.approx(
        bundled.inductance_per_permeability, rel=1e-14
    )
    theta = {"mu0": 3.0, "gamma": 5e3, "c_sat": 0.02}
    a = material_constants(Rayleigh, theta, bundled, current_max=2e-3).appendix_a_values()
    b = material_constants(Rayleigh, theta, user, current_max=2e-3).appendix_a_values()
    for q in (
        "initial_permeability",
        "maximum_permeability",
        "coercive_force_Hc",
        "peak_flux_density_Bp",
        "residual_induction_Br",
        "squareness_Br_over_Bp",
    ):
        assert b[q] == pytest.approx(a[q], rel=1e-12)
    with pytest.raises(OptionError):
        CoreGeometry.from_dimensions(100, 0.01, 0.02, 0.005)
    with pytest.raises(OptionError):
        CoreGeometry.from_dimensions(100, 0.02, 0.01, 0.005, stacking_factor=1.2)


def test_appendix_a_ranges():
    r = appendix_a_ranges("permalloy")
    assert set(r) == {
        "initial_permeability",
        "maximum_permeability",
        "coercive_force_Hc",
        "peak_flux_density_Bp",
        "residual_induction_Br",
        "squareness_Br_over_Bp",
    }
    assert r["initial_permeability"] == (1e4, 4e4, "gauss/oersted")
    assert r["coercive_force_Hc"] == (0.02, 0.25, "oersted")  # union of 3 printed ranges
    assert r["peak_flux_density_Bp"] == (6500.0, 8000.0, "gauss")
    assert r["residual_induction_Br"] == (4000.0, 7000.0, "gauss")
    assert r["squareness_Br_over_Bp"] == (0.5, 0.9, "")
    d = appendix_a_ranges("deltamax")
    assert d["squareness_Br_over_Bp"] == (0.92, None, "")  # "0.92 min."
    assert d["coercive_force_Hc"] == (0.04, 0.60, "oersted")
    assert appendix_a_ranges("supermalloy")["coercive_force_Hc"] == (0.003, 0.10, "oersted")


# --- material constants against closed forms ------------------------------------------------


def test_rayleigh_constants_against_closed_forms():
    g = core_geometry("permalloy")
    mu0, gamma, i_max = 15.0, 2e4, 2e-3
    theta = {
        "mu0": mu0,
        "gamma": gamma,
        "c_sat": np.inf,
        "r_series": 61.0,
        "gain": 0.95,
    }  # chain keys ignored
    mc = material_constants(Rayleigh, theta, g, current_max=i_max)
    # N(0) = mu0 (eq 3.1); the tiny amplitude adds gamma * 1e-6 * i_max = 4e-5 H (Re N = mu0 + gamma A)
    assert mc.initial_inductance_h == pytest.approx(
        mu0 + gamma * SMALL_SIGNAL_RATIO * i_max, rel=1e-14
    )
    assert mc.initial_inductance_h == pytest.approx(mu0, rel=3e-6)
    assert mc.initial_converged
    assert mc.initial_permeability == pytest.approx(g.relative_permeability(mu0), rel=3e-6)
    # eqs 3.9, 3.10; tip (mu0 + gamma A) A
    assert mc.coercive_current_a == pytest.approx(
        float(coercive_force(i_max, mu0, gamma)), rel=1e-12
    )
    assert mc.residual_flux_linkage_vs == pytest.approx(float(remanence(i_max, gamma)), rel=1e-12)
    assert mc.peak_flux_linkage_vs == pytest.approx((mu0 + gamma * i_max) * i_max, rel=1e-14)
    assert mc.squareness == pytest.approx(gamma * i_max / (2 * (mu0 + gamma * i_max)), rel=1e-12)
    # B/H at the tip grows with amplitude: the maximum is at current_max (a lower bound)
    assert mc.maximum_inductance_h == pytest.approx(mu0 + gamma * i_max, rel=1e-12)
    assert mc.maximum_at_edge
    assert mc.coercive_force_oe == pytest.approx(
        float(g.field_oe(coercive_force(i_max, mu0, gamma))), rel=1e-12
    )
    assert mc.residual_induction_gauss == pytest.approx(
        float(g.induction_gauss(gamma * i_max**2 / 2)), rel=1e-12
    )
    assert mc.series_resistance_ohm == 61.0
    assert mc.winding_resistance_estimate_ohm == g.r_winding_estimate


def test_rayleigh_landmarks_vectorised_with_saturation():
    mu0, gamma, c_sat = 4.0, 3e4, 0.05
    a = np.geomspace(1e-6, 1e-2, 200)
    marks = loop_landmarks(Rayleigh, a, 0.0, mu0=mu0, gamma=gamma, c_sat=c_sat)
    # the odd, increasing limiter moves neither the zero (eq 3.10) ...
    np.testing.assert_allclose(marks["coercive"], coercive_force(a, mu0, gamma), rtol=1e-10)
    # ... while B_r and the tip go through it
    np.testing.assert_allclose(
        marks["residual"], frohlich_kennelly(remanence(a, gamma), c_sat), rtol=1e-12
    )
    np.testing.assert_allclose(
        marks["tip"], frohlich_kennelly((mu0 + gamma * a) * a, c_sat), rtol=1e-12
    )


def test_constant_width_constants_from_loop_geometry():
    # branch clip(k (x - b), -min(c, k (A - b)), c): zero at x = b, B_r = min(k b, c, k (A - b)),
    # tip min(c, k (A - b)), B_tip / A largest at the saturation corner A = b + c / k
    g = core_geometry("deltamax")
    k, b, c, i_max = 100.0, 3e-5, 0.03, 1e-3
    mc = material_constants(ConstantWidth, {"k": k, "b": b, "c": c}, g, current_max=i_max)
    assert mc.coercive_current_a == pytest.approx(b, rel=1e-12)
    assert mc.residual_flux_linkage_vs == pytest.approx(min(k * b, c, k * (i_max - b)), rel=1e-12)
    assert mc.peak_flux_linkage_vs == pytest.approx(min(c, k * (i_max - b)), rel=1e-12)
    assert mc.maximum_inductance_h == pytest.approx(k * c / (k * b + c), rel=1e-9)
    assert mc.maximum_amplitude_a == pytest.approx(b + c / k, rel=1e-6)
    assert not mc.maximum_at_edge
    assert mc.initial_inductance_h == 0.0  # the play: no small-signal inductance
    assert mc.initial_converged
    assert mc.coercive_force_a_per_m == pytest.approx(b * 2000 / g.l_e, rel=1e-12)
    # not saturated at current_max: B_r = k b, tip k (A - b)
    mc2 = material_constants(ConstantWidth, {"k": k, "b": b, "c": 1.0}, g, current_max=i_max)
    assert mc2.residual_flux_linkage_vs == pytest.approx(k * b, rel=1e-12)
    assert mc2.squareness == pytest.approx(b / (i_max - b), rel=1e-12)
    # a loop without height (A <= b): no coercive force
    marks = loop_landmarks(ConstantWidth, [0.5 * b, 2 * b], 0.0, k=k, b=b, c=c)
    assert math.isnan(marks["coercive"][0]) and marks["coercive"][1] == pytest.approx(b, rel=1e-12)
    mc3 = material_constants(ConstantWidth, {"k": k, "b": b, "c": c}, g, current_max=0.5 * b)
    assert math.isnan(mc3.coercive_force_oe) and math.isnan(mc3.squareness)


def test_frequency_dependent_law_needs_a_frequency():
    g = core_geometry("deltamax")
    theta = {"k": 100.0, "c": 0.03, "m": 0.3, "hc_a": 2e-6, "hc_b": 0.0}
    with pytest.raises(OptionError):
        material_constants(FrequencyHc, theta, g, current_max=1e-3)
    mc = material_constants(FrequencyHc, theta, g, current_max=1e-3, frequency=10.0)
    assert mc.coercive_current_a == pytest.approx(0.3 * 1e-3 + 2e-6 * 10.0, rel=1e-12)
    assert mc.frequency_hz == 10.0


# --- the check against Appendix A -----------------------------------------------------------


def _values(**over):
    v = {
        "initial_permeability": 2e4,
        "maximum_permeability": 1e5,
        "coercive_force_Hc": 0.1,
        "peak_flux_density_Bp": 7000.0,
        "residual_induction_Br": 5000.0,
        "squareness_Br_over_Bp": 0.7,
        "series_resistance": 50.0,
        "winding_resistance_estimate": 50.0,
    }
    v.update(over)
    return v


def test_appendix_a_check_edges_inclusive():
    ranges = appendix_a_ranges("permalloy")
    rows = appendix_a_check(_values(), ranges)
    assert [r["quantity"] for r in rows] == list(CHECK_QUANTITIES)
    assert all(r["inside"] for r in rows)
    keys = {"quantity", "fitted", "low", "high", "unit", "inside"}
    keys |= {"fitted_low", "fitted_high", "inside_range", "determined"}
    assert all(set(r) == keys for r in rows)
    for q, (lo, hi, _) in ranges.items():
        for value, expect in (
            (lo, True),
            (hi, True),
            (np.nextafter(lo, -np.inf), False),
            (np.nextafter(hi, np.inf), False),
            (float("nan"), False),
        ):
            row = {r["quantity"]: r for r in appendix_a_check(_values(**{q: value}), ranges)}[q]
            assert row["inside"] is expect, (q, value)
    # series resistance: the central 95 % of its log-normal prior, median the winding's
    # estimate + 25 ohm of source and leads, sigma 0.45: 75 / e^0.9 .. 75 e^0.9; edges included
    low, high = 75.0 / math.exp(0.9), 75.0 * math.exp(0.9)
    for value, expect in ((low, True), (high, True), (low * 0.999, False), (high * 1.001, False)):
        row = appendix_a_check(_values(series_resistance=value), ranges)[-1]
        assert row["quantity"] == "series_resistance" and row["inside"] is expect
        assert (row["low"], row["high"], row["unit"]) == (
            pytest.approx(low, rel=1e-12),
            pytest.approx(high, rel=1e-12),
            "ohm",
        )
    # no fitted resistance: no resistance row
    rows = appendix_a_check(_values(series_resistance=None), ranges)
    assert "series_resistance" not in [r["quantity"] for r in rows]


def test_appendix_a_check_open_range_and_json():
    ranges = appendix_a_ranges("deltamax")  # squareness "0.92 min."
    row = {r["quantity"]: r for r in appendix_a_check(_values(squareness_Br_over_Bp=5.0), ranges)}
    assert row["squareness_Br_over_Bp"]["inside"] and row["squareness_Br_over_Bp"]["high"] is None
    assert not {
        r["quantity"]: r for r in appendix_a_check(_values(squareness_Br_over_Bp=0.9199), ranges)
    }["squareness_Br_over_Bp"]["inside"]
    # from a real fit: plain Python types, JSON-serialisable
    g = core_geometry("permalloy")
    mc = material_constants(
        Rayleigh,
        {"mu0": 15.0, "gamma": 2e4, "c_sat": 0.3},
        g,
        current_max=2e-3,
        series_resistance=60.0,
    )
    rows = appendix_a_check(mc, appendix_a_ranges("permalloy"))
    json.dumps(rows)
    json.dumps(mc.to_dict())
    for r in rows:
        assert type(r["fitted"]) is float and type(r["low"]) is float and type(r["inside"]) is bool
        assert r["high"] is None or type(r["high"]) is float
    by_q = {r["quantity"]: r for r in rows}
    assert by_q["initial_permeability"]["fitted"] == pytest.approx(mc.initial_permeability)
    assert by_q["coercive_force_Hc"]["unit"] == "oersted"
    assert by_q["series_resistance"]["inside"]  # 60 within 53.8 +- 30 %


# --- the iron fraction (stacking factor) -----------------------------------------------------


def test_stacking_factor_is_a_range_for_thesis_cores_and_known_when_stated():
    g = core_geometry("permalloy")
    assert g.stacking_factor == STACKING_FACTOR and g.stacking_range == STACKING_FACTOR_RANGE
    # B and mu_r scale as 1/stacking factor: 0.85/0.90 and 0.85/0.50 at the range's ends
    assert g.iron_fraction_spread == pytest.approx((0.85 / 0.90, 0.85 / 0.50), rel=1e-15)
    known = core_geometry("permalloy", stacking_factor=0.7)
    assert known.stacking_range is None and known.iron_fraction_spread == (1.0, 1.0)
    with pytest.raises(OptionError, match="stacking range"):
        CoreGeometry.from_dimensions(1000, 0.06, 0.05, 0.01, stacking_range=(0.9, 0.95))


def test_implied_stacking_factor_by_hand():
    """The stacking factor at which the fitted peak flux is Appendix A's B_p, computed here from
    the printed dimensions alone: lambda_p / (N (OD - ID)/2 h B_p)."""
    g = core_geometry("permalloy")
    mu0, gamma, c_sat, i_max = 15.0, 2e4, 0.3, 2e-3
    mc = material_constants(
        Rayleigh, {"mu0": mu0, "gamma": gamma, "c_sat": c_sat}, g, current_max=i_max
    )
    gross = (2.5 - 2.0) / 2 * 0.5 * IN**2  # m^2, Appendix A: 2.5 x 2.0 x 0.5 in
    lam = mc.peak_flux_linkage_vs
    ranges = appendix_a_ranges("permalloy")  # B_p 6500-8000 G
    got = implied_stacking_factor(mc, ranges)
    assert got["low"] == pytest.approx(lam / (1250 * gross * 0.80), rel=1e-12)
    assert got["high"] == pytest.approx(lam / (1250 * gross * 0.65), rel=1e-12)
    assert got["range"] == list(STACKING_FACTOR_RANGE)
    assert got["consistent"] == (got["low"] <= 0.9 and got["high"] >= 0.5)
    # the check spans the inductions and permeabilities over the stacking range, not H_c
    rows = {r["quantity"]: r for r in appendix_a_check(mc, ranges)}
    bp = rows["peak_flux_density_Bp"]
    assert bp["fitted"] == pytest.approx(lam / (1250 * gross * 0.85) * 1e4, rel=1e-12)
    assert (bp["fitted_low"], bp["fitted_high"]) == pytest.approx(
        (lam / (1250 * gross * 0.90) * 1e4, lam / (1250 * gross * 0.50) * 1e4), rel=1e-12
    )
    assert bp["inside_range"] == (bp["fitted_high"] >= 6500 and bp["fitted_low"] <= 8000)
    hc = rows["coercive_force_Hc"]
    assert hc["fitted_low"] == hc["fitted_high"] == hc["fitted"]


def _exactly(target, f, x0):
    """The float ``x`` nearest ``x0`` at which ``f(x) == target`` exactly (a few ulps away)."""
    x = x0
    for _ in range(64):
        got = f(x)
        if got == target:
            return x
        x = float(np.nextafter(x, np.inf if got < target else -np.inf))
    raise AssertionError(f"no float gives {target!r} exactly near {x0!r}")


def test_iron_fraction_is_consistent_up_to_the_ends_of_its_range_inclusive():
    """The stacking factors the fitted peak flux and Appendix A's B_p imply meet the range
    0.50-0.90 when they touch it: the implied interval starting exactly at 0.90, or ending
    exactly at 0.50, is consistent; one ulp of flux further out it is not. The report's
    iron-fraction table says the same."""
    g = core_geometry("permalloy")
    assert (g.stacking_range, g.stacking_factor) == ((0.5, 0.9), 0.85)
    mc = material_constants(
        Rayleigh, {"mu0": 15.0, "gamma": 2e4, "c_sat": 0.3}, g, current_max=2e-3
    )
    ranges = appendix_a_ranges("permalloy")  # B_p 6500-8000 G
    gross = g.a_e / g.stacking_factor

    def implied(lam):
        return implied_stacking_factor(replace(mc, peak_flux_linkage_vs=lam), ranges)

    # low end of the implied interval (B_p at its top, 8000 G) exactly at the range's top
    lam = _exactly(0.9, lambda x: implied(x)["low"], 0.9 * g.turns * gross * 0.8)
    at_top = implied(lam)
    assert at_top["low"] == 0.9 and at_top["consistent"]
    past_top = implied(float(np.nextafter(lam, np.inf)))
    assert past_top["low"] > 0.9 and not past_top["consistent"]
    # high end (B_p at its bottom, 6500 G) exactly at the range's bottom
    lam = _exactly(0.5, lambda x: implied(x)["high"], 0.5 * g.turns * gross * 0.65)
    at_bottom = implied(lam)
    assert at_bottom["high"] == 0.5 and at_bottom["consistent"]
    below = implied(float(np.nextafter(lam, -np.inf)))
    assert below["high"] < 0.5 and not below["consistent"]
    # the report's table: "within" at the ends, "outside" past them
    for sf, word in (
        (at_top, "within"),
        (past_top, "outside"),
        (at_bottom, "within"),
        (below, "outside"),
    ):
        row = _joint([{"block": "b", "law": "rayleigh", "implied_stacking_factor": sf}], {})
        cell = row[1][2][0][2]
        assert cell.endswith(f"({word} 0.5-0.9)"), cell


def test_appendix_a_check_spans_the_stacking_range_to_its_ends_inclusive():
    """An induction derived at the nominal 0.85 is known over 0.85/0.90 to 0.85/0.50 of its
    value; a span whose end touches the Appendix A range exactly meets it, the next float
    beyond does not (the range's ends are set to the span's ends as computed)."""
    g = core_geometry("permalloy")
    mc = material_constants(
        Rayleigh, {"mu0": 15.0, "gamma": 2e4, "c_sat": 0.3}, g, current_max=2e-3
    )
    low_m, high_m = g.iron_fraction_spread
    assert (low_m, high_m) == (0.85 / 0.9, 0.85 / 0.5)

    def bp(value, low, high):
        ranges = {"peak_flux_density_Bp": (low, high, "gauss")}
        rows = appendix_a_check(replace(mc, peak_flux_density_gauss=value), ranges)
        return rows[0]

    def step(x, key, direction):  # the next float whose span end moves
        end = bp(x, 0.0, None)[key]
        while bp(x, 0.0, None)[key] == end:
            x = float(np.nextafter(x, direction))
        return x

    # the span's top (at 0.50) is the range's bottom: it meets; a smaller value does not
    x = 6500.0 / high_m
    top = bp(x, 0.0, None)["fitted_high"]
    assert top == x * high_m
    assert bp(x, top, None)["inside_range"] and not bp(x, top, None)["inside"]
    assert not bp(step(x, "fitted_high", -np.inf), top, None)["inside_range"]
    # the span's bottom (at 0.90) is the range's top: it meets; a larger value does not
    x = 8000.0 / low_m
    bottom = bp(x, 0.0, None)["fitted_low"]
    assert bottom == x * low_m
    assert bp(x, 0.0, bottom)["inside_range"] and not bp(x, 0.0, bottom)["inside"]
    assert not bp(step(x, "fitted_low", np.inf), 0.0, bottom)["inside_range"]


def test_what_the_data_determine():
    """Flux linkages are invariant under the current scale, fields are not, and inductions and
    permeabilities carry the iron fraction; a joint 0 + 600 ohm fit fixes the scale."""
    ranges = appendix_a_ranges("permalloy")
    single = {r["quantity"]: r["determined"] for r in appendix_a_check(_values(), ranges)}
    joint = {
        r["quantity"]: r["determined"] for r in appendix_a_check(_values(), ranges, joint=True)
    }
    data, iron = DETERMINED_BY[(False, False)], DETERMINED_BY[(True, False)]
    assert single["squareness_Br_over_Bp"] == joint["squareness_Br_over_Bp"] == data
    assert single["peak_flux_density_Bp"] == joint["peak_flux_density_Bp"] == iron
    assert single["coercive_force_Hc"] == DETERMINED_BY[(False, True)]
    assert joint["coercive_force_Hc"] == data
    assert single["initial_permeability"] == DETERMINED_BY[(True, True)]
    assert joint["initial_permeability"] == iron


def test_material_record_of_a_fit_says_what_its_rows_determine():
    """A joint (0 + 600 ohm) fit fixes the current scale, a one-table fit does not; both carry
    the iron fraction their peak flux implies with Appendix A's B_p."""
    joint = fitdf.fit("permalloy", "rayleigh", chain="winding", method="lsq", n_starts=1)
    single = fitdf.fit("B.1", "rayleigh", chain="winding", method="lsq", n_starts=1)
    for result, expect in ((joint, DETERMINED_BY[(False, False)]), (single, None)):
        rows = {r["quantity"]: r for r in result.material["appendix_a_check"]}
        hc = rows["coercive_force_Hc"]["determined"]
        assert hc == (expect or DETERMINED_BY[(False, True)])
        implied = result.material["constants"]["implied_stacking_factor"]
        lam = result.material["constants"]["peak_flux_linkage_vs"]
        g = result.problem.geometry
        gross = g.a_e / g.stacking_factor
        assert implied["low"] == pytest.approx(lam / (g.turns * gross * 0.80), rel=1e-12)
