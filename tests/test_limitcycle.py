"""Harmonic balance against closed forms, Loeb's criterion, gain sweeps, and the thesis loop."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import brentq
from synthetic import synthetic_frame

from fitdf.cli import main
from fitdf.errors import OptionError
from fitdf.inference.api import fit
from fitdf.limit_cycle_tables import (
    THESIS_PLANT,
    estimate_thesis_scales,
    limit_cycle_statements,
    thesis_limit_cycle_comparison,
)
from fitdf.loop import harmonic
from fitdf.loop.fitted import fitted_limit_cycles
from fitdf.loop.harmonic import (
    DEDUP_TOL,
    ROOT_TOL,
    _distinct_roots,
    critical_gain,
    limit_cycles,
)
from fitdf.loop.nonlinearity import _evaluate_N, as_describing_function
from fitdf.loop.plant import as_loop_plant
from fitdf.loop.presentation import limit_cycle_text
from fitdf.plots.limit_cycles import plot_nyquist, plot_thesis_comparison

PLANT = "K/(s(s+1)(s+2))"  # -180 deg at w = sqrt(2), |G(j sqrt 2)| = K / 6


def relay(M=1.0, h=0.1):
    """Ideal relay with hysteresis: N = 4M/(pi A) (sqrt(1 - (h/A)^2) - j h/A)."""

    def N(A, w):
        A = np.asarray(A, float)
        with np.errstate(all="ignore"):
            out = 4 * M / (np.pi * A) * (np.sqrt(1 - (h / A) ** 2) - 1j * h / A)
        return np.where(A > h, out, np.nan)

    return N


def saturation_df(A):
    A = np.asarray(A, float)
    with np.errstate(all="ignore"):
        r = np.minimum(1.0 / A, 1.0)
        return (2 / np.pi) * (np.arcsin(r) + r * np.sqrt(1 - r * r))


def saturation(A, w):
    return saturation_df(A) + 0j


def dead_zone_relay(M=1.0, delta=0.5):
    """N = 4M/(pi A) sqrt(1 - (delta/A)^2) for A > delta, else 0; maximum 2M/(pi delta) at A = sqrt(2) delta."""

    def N(A, w):
        A = np.asarray(A, float)
        with np.errstate(all="ignore"):
            out = 4 * M / (np.pi * A) * np.sqrt(np.clip(1 - (delta / A) ** 2, 0, None))
        return np.where(A > delta, out, 0.0) + 0j

    return N


def relay_analytic(K, M=1.0, h=0.1):
    """Closed form: Im G(jw) = -pi h / (4M) is a quintic in w; then Re G gives A."""
    c = np.pi * h / (4 * M)
    # G = K / (jw (1+jw)(2+jw)): Im G = -K (2 - w^2) / (w (9 w^2 + (2 - w^2)^2))
    quintic = np.polysub(
        K * np.array([-1.0, 0.0, 2.0]),
        np.polymul([c, 0.0], np.polyadd([9.0, 0.0, 0.0], np.polymul([-1, 0, 2], [-1, 0, 2]))),
    )
    roots = np.roots(quintic)
    w = roots[(np.abs(roots.imag) < 1e-9) & (roots.real > 0)].real
    assert w.size == 1
    w = float(w[0])
    G = K / (1j * w * (1 + 1j * w) * (2 + 1j * w))
    A = np.hypot(4 * M / np.pi * abs(G.real), h)
    return A, w


@pytest.mark.parametrize("K", [1.0, 2.0, 5.0])
def test_relay_with_hysteresis_matches_closed_form(K):
    r = limit_cycles(PLANT, relay(), gains=[K], amplitude_range=(0.1001, 50))
    assert len(r.intersections) == 1
    c = r.intersections[0]
    A, w = relay_analytic(K)
    assert c.amplitude == pytest.approx(A, rel=1e-6)
    assert c.omega == pytest.approx(w, rel=1e-6)
    assert c.stable and c.loeb > 0
    assert abs(1 + c.G * c.N) < 1e-8


def test_saturation_critical_gain_and_amplitude():
    gains = [3.0, 5.5, 6.5, 8.0, 12.0, 20.0]
    r = limit_cycles("1/(s(s+1)(s+2))", saturation, gains=gains, amplitude_range=(0.01, 100))
    assert r.critical_gain == pytest.approx(6.0, rel=1e-6)
    table = r.stable_cycles()
    below = table[table["gain"] < 6]
    assert below["amplitude"].isna().all()
    above = table[table["gain"] > 6]
    for _, row in above.iterrows():
        A_exact = brentq(
            lambda a: saturation_df(a) - 6.0 / row["gain"], 1.0 + 1e-12, 1e3, xtol=1e-14
        )
        assert row["amplitude"] == pytest.approx(A_exact, rel=1e-6)
        assert row["omega_rad_s"] == pytest.approx(np.sqrt(2), rel=1e-8)
    assert all(c.stable for c in r.intersections)


def test_loeb_stable_and_unstable_cycles():
    """A dead-zone relay crosses the plant twice: the small cycle is unstable, the large one stable."""
    M, delta, K = 1.0, 0.5, 9.0
    r = limit_cycles(PLANT, dead_zone_relay(M, delta), gains=[K], amplitude_range=(0.3, 30))
    cycles = sorted(r.intersections, key=lambda c: c.amplitude)
    assert [c.stable for c in cycles] == [False, True]
    assert cycles[0].loeb < 0 < cycles[1].loeb
    # N(A) = 6/K: q A^4 - A^2 + delta^2 = 0 with q = (pi (6/K) / (4M))^2
    q = (np.pi * (6 / K) / (4 * M)) ** 2
    roots = np.sqrt((1 + np.array([-1, 1]) * np.sqrt(1 - 4 * q * delta**2)) / (2 * q))
    np.testing.assert_allclose([c.amplitude for c in cycles], roots, rtol=1e-6)
    # the pair is born as a double root at K = 6 / N_max = 3 pi delta / M, A = sqrt(2) delta
    crit = critical_gain(
        PLANT.replace("K", "1"), dead_zone_relay(M, delta), amplitude_range=(0.3, 30)
    )
    assert crit["gain"] == pytest.approx(3 * np.pi * delta / M, rel=1e-7)
    assert crit["amplitude"] == pytest.approx(np.sqrt(2) * delta, rel=1e-4)
    assert not crit["at_boundary"]
    # below the critical gain nothing, not even a spurious root near the tangency
    assert (
        limit_cycles(
            PLANT, dead_zone_relay(M, delta), gains=[0.99 * crit["gain"]], amplitude_range=(0.3, 30)
        ).intersections
        == ()
    )


def test_gain_sweep_is_monotone():
    gains = np.geomspace(0.5, 20, 12)
    t = limit_cycles(PLANT, relay(), gains=gains, amplitude_range=(0.1001, 100)).stable_cycles()
    assert t["amplitude"].notna().all()
    assert np.all(np.diff(t["amplitude"]) > 0)  # relay: A grows with K
    assert np.all(np.diff(t["omega_rad_s"]) > 0)  # and w climbs towards sqrt(2)
    assert t["omega_rad_s"].max() < np.sqrt(2)
    s = limit_cycles(
        PLANT, saturation, gains=np.geomspace(6.5, 60, 8), amplitude_range=(0.01, 100)
    ).stable_cycles()
    assert np.all(np.diff(s["amplitude"]) > 0)


def test_frequency_dependent_N_equals_moving_the_lag_into_the_plant():
    """N(A, w) = N_sat(A) / (1 + j w T) in 1/(s(s+1)) must give the cycles of N_sat in 1/(s(s+1)(1+sT))."""
    T = 0.5

    def lagged(A, w):
        return saturation_df(A) / (1 + 1j * np.asarray(w) * T)

    gains = [4.0, 10.0]
    a = limit_cycles(
        "K/(s(s+1))", lagged, gains=gains, amplitude_range=(0.01, 100), omega_range=(0.05, 50)
    )
    b = limit_cycles(
        "K/(s(s+1)(1+0.5s))",
        saturation,
        gains=gains,
        amplitude_range=(0.01, 100),
        omega_range=(0.05, 50),
    )
    ta, tb = a.table(), b.table()
    np.testing.assert_allclose(ta["amplitude"], tb["amplitude"], rtol=1e-7)
    np.testing.assert_allclose(ta["omega_rad_s"], tb["omega_rad_s"], rtol=1e-7)
    assert list(ta["stable"]) == list(tb["stable"]) == [True, True]
    np.testing.assert_allclose(ta["loeb"], tb["loeb"], rtol=1e-3)
    assert a.critical_gain == pytest.approx(b.critical_gain, rel=1e-6)


def test_gain_inside_the_plant_uses_bisection():
    """K^2 G0: not linear in K, so the critical gain comes from the bisection (sqrt(6) for saturation)."""
    r = limit_cycles("K^2/(s(s+1)(s+2))", saturation, gains=[3.0], amplitude_range=(0.01, 100))
    assert r.critical_gain == pytest.approx(np.sqrt(6.0), rel=1e-6)
    A = brentq(lambda a: saturation_df(a) - 6.0 / 9.0, 1.0 + 1e-12, 1e3)
    assert r.intersections[0].amplitude == pytest.approx(A, rel=1e-6)


def test_time_scale_scales_frequency_only():
    a = limit_cycles(PLANT, relay(), gains=[2.0], amplitude_range=(0.1001, 50))
    b = limit_cycles(PLANT, relay(), gains=[2.0], amplitude_range=(0.1001, 50), time_scale=4.0)
    assert b.intersections[0].amplitude == pytest.approx(a.intersections[0].amplitude, rel=1e-7)
    assert b.intersections[0].omega == pytest.approx(4.0 * a.intersections[0].omega, rel=1e-7)


def test_response_table_json_and_plot():
    r = limit_cycles(PLANT, dead_zone_relay(), gains=[3.0, 9.0], amplitude_range=(0.3, 30))
    t = r.table()
    assert list(t["oscillation"]) == [False, True, True]
    assert {"gain", "amplitude", "omega_rad_s", "frequency_hz", "stable", "loeb"} <= set(t.columns)
    json.dumps(r.to_dict(), allow_nan=False)
    fig = plot_nyquist(r)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "Re" and len(ax.lines) >= 4


def test_nyquist_figure_is_framed_where_the_loci_meet():
    """The framed panel holds every cycle with a margin, far closer than the whole loci (the
    second panel, with the framed region outlined); without a cycle, the first one (at the
    critical gain) is framed and its plant locus drawn."""
    r = limit_cycles(PLANT, dead_zone_relay(), gains=[9.0], amplitude_range=(0.3, 30))
    fig = plot_nyquist(r)
    framed, whole = fig.axes[:2]
    (x0, x1), (y0, y1) = framed.get_xlim(), framed.get_ylim()
    for c in r.intersections:
        assert x0 < c.G.real < x1 and y0 < c.G.imag < y1
        margin = min(c.G.real - x0, x1 - c.G.real, c.G.imag - y0, y1 - c.G.imag)
        assert margin > 0.1 * abs(c.G)
    (wx0, wx1), (wy0, wy1) = whole.get_xlim(), whole.get_ylim()
    assert (wx1 - wx0) > 5 * (x1 - x0) and (wy1 - wy0) > 5 * (y1 - y0)
    assert len(whole.patches) == 1  # the framed region
    labels = framed.get_legend_handles_labels()[1]
    assert "stable cycle (Loeb)" in labels and "unstable cycle (Loeb)" in labels
    none = limit_cycles(PLANT, dead_zone_relay(), gains=[3.0], amplitude_range=(0.3, 30))
    assert none.intersections == ()
    framed = plot_nyquist(none).axes[0]
    labels = framed.get_legend_handles_labels()[1]
    assert "first cycle" in labels and any("(critical gain)" in t for t in labels)
    Gc = -1 / dead_zone_relay()(np.sqrt(2) * 0.5, np.sqrt(2))  # N's peak, on -1/N
    (x0, x1), (y0, y1) = framed.get_xlim(), framed.get_ylim()
    assert x0 < Gc.real < x1 and y0 < Gc.imag < y1 and x1 - x0 < 3.0


def test_thesis_comparison_figure_explains_every_element():
    """Every kind of mark has a legend entry, and the title says what each setting is."""
    rows = []
    for setting, alpha, beta in (("unscaled", 1.0, 1.0), ("held_out", 2.2, 0.675)):
        for rs, table in ((0.0, "B.1"), (600.0, "B.3")):
            for K, dies in ((50.0, True), (100.0, False), (300.0, False)):
                rows.append(
                    {
                        "setting": setting,
                        "core": "permalloy",
                        "source_impedance_ohm": rs,
                        "table": table,
                        "model": "preisach",
                        "alpha": alpha,
                        "beta": beta,
                        "system_gain": K,
                        "amplitude_v": 0.4 if dies else K / 100,
                        "omega_rad_s": 9.0 if dies else 10 + K / 50,
                        "dies_out": dies,
                        "amplitude_pred": alpha * K / 90,
                        "omega_pred": alpha * (10 + K / 45),
                        "critical_gain_pred": 30.0 * alpha,
                        "amplitude_sim": alpha * K / 95,
                        "omega_sim": alpha * (10 + K / 48),
                    }
                )
    fig = plot_thesis_comparison(pd.DataFrame(rows))
    title = " ".join(fig.get_suptitle().split())
    assert (
        "solid: unscaled, the plant and the system gain as printed (\u03b1 = \u03b2 = 1)" in title
    )
    assert "\u03b1 and \u03b2 fitted to the other three blocks" in title
    labels = [t.get_text() for t in fig.axes[1].get_legend().get_texts()]
    for rs, table in (("0", "B.1"), ("600", "B.3")):
        for what in (
            f"measured, {rs} ohm ({table}, preisach)",
            f'printed in a row marked "oscillations die out", {rs} ohm',
            f"measured die-out bracket, {rs} ohm",
            f"predicted largest stable cycle, unscaled (\u03b1 = \u03b2 = 1), {rs} ohm",
            "predicted largest stable cycle, scales fitted to the other blocks "
            f"(\u03b1 2.2, \u03b2 0.675), {rs} ohm",
            f"simulated loop, unscaled (\u03b1 = \u03b2 = 1), {rs} ohm",
            f"simulated loop, scales fitted to the other blocks, {rs} ohm",
            f"predicted gain below which no cycle exists, unscaled (\u03b1 = \u03b2 = 1), {rs} ohm",
            "predicted gain below which no cycle exists, scales fitted to the other blocks, "
            f"{rs} ohm",
        ):
            assert what in labels, (what, labels)
    # per panel and block: measured, die-out values, and per setting a line, simulated points
    # and a critical gain
    drawn = sum(len(ax.lines) for ax in fig.axes)
    assert drawn == 2 * 2 * (2 + 2 * 3)
    assert len(labels) == 2 * 9


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"gains": [-1.0]}, "positive"),
        ({"gains": None}, "contains K"),
        ({"gains": [1.0], "amplitude_range": (2.0, 1.0)}, "low < high"),
    ],
)
def test_option_errors(kwargs, match):
    kwargs.setdefault("amplitude_range", (0.2, 10))
    with pytest.raises(OptionError, match=match):
        limit_cycles(PLANT, relay(), **kwargs)


def test_callable_needs_an_amplitude_range_and_bad_nonlinearity():
    with pytest.raises(OptionError, match="amplitude_range"):
        limit_cycles("1/(s(s+1))", saturation)
    with pytest.raises(OptionError, match="nonlinearity"):
        limit_cycles("1/(s(s+1))", 3.0, amplitude_range=(1, 2))


class _StubFit:
    """Anything with predict(amplitude, frequency_hz, source_impedance) is a nonlinearity."""

    def __init__(self, lead_deg=40.0):
        self.lead = np.deg2rad(lead_deg)

    def predict(self, amplitude, frequency, source_impedance=0.0):
        A = np.asarray(amplitude, float)
        return (
            saturation_df(A / 0.5)
            * np.exp(1j * self.lead)
            * np.ones_like(np.asarray(frequency, float))
        )


def test_estimate_thesis_scales_recovers_known_scales():
    """Tables generated by harmonic balance with alpha = 2.5, beta = 0.3 give those numbers back."""
    fit = _StubFit()
    alpha, beta = 2.5, 0.3
    K = np.array([500.0, 1000.0, 2000.0, 4000.0])
    r = limit_cycles(
        THESIS_PLANT, fit, beta * K, amplitude_range=(0.01, 50), time_scale=alpha
    ).stable_cycles()
    assert r["amplitude"].notna().all()
    rows = pd.DataFrame(
        {
            "core": "stub",
            "source_impedance_ohm": 0.0,
            "system_gain": K,
            "amplitude_v": r["amplitude"],
            "omega_rad_s": r["omega_rad_s"],
        }
    )
    est = estimate_thesis_scales(rows, {("stub", 0.0): fit})
    assert est["alpha"] == pytest.approx(alpha, rel=1e-6)
    assert est["beta"] == pytest.approx(beta, rel=1e-6)
    assert est["rms_phase_deg"] < 1e-5


@pytest.fixture(scope="module")
def b1_fit():
    """A small fit to Table B.1 (exact voltage chain)."""
    return fit("B.1", "proportional_width", seed=0, n_starts=2)


#: The loop of the fitted-core tests: the thesis plant at time scale 2.5, the core at 0 ohm.
THESIS_LOOP = dict(source_impedance=0.0, time_scale=2.5, amplitude_range=(0.02, 10))


def _thesis_loop_parts(res):
    """``(plant, N)`` of the loop :data:`THESIS_LOOP` with the fitted core ``res``: the
    pieces the tests' own scans evaluate, apart from the solver."""
    lp = as_loop_plant(THESIS_PLANT, THESIS_LOOP["time_scale"])
    N, _, _ = as_describing_function(res, THESIS_LOOP["source_impedance"])
    return lp, N


def test_fitted_core_in_the_thesis_loop(b1_fit):
    """A small fit to Table B.1: cycles lie in the second quadrant (phase lead, Graph 5.21) and balance."""
    res = b1_fit
    r = limit_cycles(THESIS_PLANT, res, gains=[50.0, 150.0], **THESIS_LOOP)
    assert r.intersections, f"no cycle with the fitted values {res.values}"
    for c in r.intersections:
        assert abs(1 + c.G * c.N) < 2e-6  # ROOT_TOL: the floor of the exact chain's DF
        assert c.G.real < 0 < c.G.imag  # second quadrant
        assert np.angle(c.N) > 0  # the core's voltage transfer leads
    text = limit_cycle_text(
        {
            "plant": THESIS_PLANT,
            "model": res.model,
            "chain": res.chain,
            "data": "B.1",
            "source_impedance_ohm": 0.0,
            **r.to_dict(),
        }
    )
    assert "die out below gain" in text
    # every column is explained under the table, Loeb's sign too
    legend = " ".join(text.split("\n\n")[2].split())
    for column in ("gain:", "amplitude:", "omega, f:", "stable:", "loeb:"):
        assert column in legend
    assert "above 0 stable, below 0 unstable" in legend
    assert max(map(len, text.splitlines())) <= 100


@pytest.mark.slow  # 12 s; the fitted core cycles of the other tests here run by default
def test_fitted_core_cycles_at_every_gain_match_a_scan_of_the_balance_curve(b1_fit):
    """An independent path: scan ``arg(-G0 N) = 0`` over a fine grid of amplitudes and
    frequencies (no least squares, no candidate cells); along that curve the gain of a
    cycle is ``K(A) = 1 / |G0 N|``, so the cycles of a gain are where ``K(A)`` crosses it.
    The solver must find each of them. (With finite differences over 1e-9 in its
    refinement it missed the cycles of B.1's fits at some gains: the exact chain's DF
    jitters on that scale.)"""
    lp, N = _thesis_loop_parts(b1_fit)
    # (below about 0.6 this fit's K(A) turns over: more than one cycle per gain)
    A = np.geomspace(0.6, 6.0, 140)
    w = np.geomspace(5.0, 30.0, 1200)
    G0 = lp.response(w, [1.0])[0]
    phase = np.angle(-G0[None, :] * _evaluate_N(N, A[:, None], w[None, :]))
    curve = []
    for i in range(A.size):  # the curve is single-valued in A here: one crossing per row
        j = np.flatnonzero(np.diff(np.sign(phase[i])) != 0)
        j = j[np.abs(phase[i, j] - phase[i, j + 1]) < 1.0]  # not the wrap at +-pi
        assert j.size == 1
        j = j[0]
        t = phase[i, j] / (phase[i, j] - phase[i, j + 1])
        wc = w[j] * (w[j + 1] / w[j]) ** t
        curve.append(1.0 / abs(lp.response([wc], [1.0])[0, 0] * N(A[i], wc)))
    K = np.array(curve)
    assert np.all(np.diff(K) > 0)  # one cycle per gain in this box
    assert K[0] < 40.0 and K[-1] > 150.0  # every gain below has its cycle inside the box
    gains = np.array([40.0, 55.55095776698429, 75.0, 101.0, 150.0])
    expected = np.exp(np.interp(gains, K, np.log(A)))
    r = limit_cycles(THESIS_PLANT, b1_fit, gains=gains, **THESIS_LOOP)
    for g, a in zip(gains, expected):
        found = [c.amplitude for c in r.intersections if c.gain == g]
        assert found == [pytest.approx(a, rel=0.01)], (g, a, found)


def test_loeb_of_a_fitted_core_is_the_slope_of_a_plane_through_the_balance(b1_fit):
    """Loeb's sine of the crossing angle at a fitted core's cycles, against an independent
    path: ``F = 1 + G N`` on a 7 x 7 patch (+-0.01 in ``ln A`` and ``ln omega``) around the
    cycle, its derivatives from a least-squares quadratic surface, not two differences.
    (Near the lowest gain's cycle the surface's slopes still move with the patch: 0.8716,
    0.8734, 0.8773 over +-0.03, +-0.01, +-0.005, against Loeb's 0.8817: hence 0.015.)
    The exact chain's DF jitters by ~1e-5 between points 1e-8 apart; with differences over
    1e-6 the verdict was that noise (0.70 or 0.09 at one cycle, "unstable" at gain 68.5
    between stable cycles)."""
    lp, N = _thesis_loop_parts(b1_fit)
    gains = np.geomspace(20.0, 300.0, 12)
    r = limit_cycles(THESIS_PLANT, b1_fit, gains=gains, **THESIS_LOOP)
    # (below ~30 the cycles die out: one cycle at each of the other ten gains)
    assert [c.gain for c in r.intersections] == pytest.approx(gains[2:])
    offsets = np.linspace(-0.01, 0.01, 7)
    du, dv = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
    design = np.column_stack([np.ones_like(du), du, dv, du**2, du * dv, dv**2])
    for c in r.intersections:
        u, v = np.log(c.amplitude) + du, np.log(c.omega) + dv
        F = 1 + lp.response(np.exp(v), [c.gain])[0] * _evaluate_N(N, np.exp(u), np.exp(v))
        coef = np.linalg.lstsq(design, F, rcond=None)[0]
        Fa, Fw = coef[1], coef[2]
        expected = (np.conj(Fa) * Fw).imag / (abs(Fa) * abs(Fw))
        assert c.stable and c.loeb == pytest.approx(expected, abs=0.015), (c.gain, c.loeb)


# ------------------------------------------------------------------ the command's path, checked
#: The loop of the command-line checks: the thesis plant, ``G0(j omega)`` written out below.
CLI_PLANT = "K/((1+s)(1+0.25s)(1+1.1s))"


def _g0(w):
    return 1.0 / ((1 + 1j * w) * (1 + 0.25j * w) * (1 + 1.1j * w))


def backlash_df(X, k, b, c, n=200_001):
    """The DF of the clipped backlash (constant_width's loop: slope ``k``, half-width ``b``,
    saturation ``c``) at amplitude ``X``, by Fourier integration of the loop over one period
    (not the thesis's closed form the law evaluates). Trapezoid rule, periodic integrand with
    kinks: error ~1e-9 at this ``n``."""
    theta = np.linspace(-np.pi / 2, 3 * np.pi / 2, n)  # rising branch, then falling
    x = X * np.sin(theta)
    bottom = -min(c, k * max(X - b, 0.0))

    def rising(u):
        return np.clip(k * (u - b), bottom, c)

    y = np.where(theta <= np.pi / 2, rising(x), -rising(-x))
    in_phase = np.trapezoid(y * np.sin(theta), theta) / np.pi
    quadrature = np.trapezoid(y * np.cos(theta), theta) / np.pi
    return (in_phase + 1j * quadrature) / X


def backlash_cycles(K, values, box):
    """The cycles of ``K G0`` closed around the ``direct`` chain's clipped backlash
    (``values``: its fitted ``k``, ``b``, ``c``, ``input_scale``), found without the solver:
    ``N`` does not depend on ``omega``, so for each amplitude the phase balance
    ``arg G0(j omega) = -pi - arg N(A)`` fixes ``omega`` (``arg G0`` falls monotonically from
    0 to -3 pi / 2), and the cycles are where ``K |G0| |N|`` crosses 1 along that curve.
    Returns ``(A, omega, stable)`` per cycle: stable when ``K |G0 N|`` falls through 1 as
    ``A`` grows (a larger cycle decays back), and the balance's residual function."""
    k, b, c, s = (values[n] for n in ("k", "b", "c", "input_scale"))

    def N(A):  # the direct chain: the law's DF at model input A / input_scale
        return backlash_df(A / s, k, b, c)

    def omega_at(A):
        target = -np.pi - np.angle(N(A))
        return brentq(
            lambda w: -(np.arctan(w) + np.arctan(0.25 * w) + np.arctan(1.1 * w)) - target,
            1e-6,
            1e6,
            xtol=1e-14,
            rtol=1e-14,
        )

    def log_gain(A):
        return np.log(K * abs(_g0(omega_at(A))) * abs(N(A)))

    grid = np.geomspace(*box, 80)
    g = np.array([log_gain(a) for a in grid])
    cycles = []
    for i in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:])):
        A = brentq(log_gain, grid[i], grid[i + 1], xtol=1e-14, rtol=1e-13)
        cycles.append((A, omega_at(A), bool(g[i] > 0 > g[i + 1])))

    def residual(u, v):  # the solver's [ln|G N|, arg(-G N)], computed here
        H = K * _g0(np.exp(v)) * N(np.exp(u))
        return np.array([np.log(abs(H)), np.angle(-H)])

    return cycles, residual


def solver_tolerance(residual, A, w, h=1e-5):
    """How far in ``ln A`` and ``ln omega`` a root the solver accepts can lie from the true
    one: it accepts ``|r|_1 <= ROOT_TOL`` (:data:`fitdf.loop.harmonic.ROOT_TOL`), and to
    first order ``dx = J^-1 dr``, so ``|dx_i| <= max_j |J^-1_ij| ROOT_TOL`` (J: the
    residual's Jacobian at the true root, by central differences)."""
    u, v = np.log(A), np.log(w)
    J = np.column_stack(
        [
            (residual(u + h, v) - residual(u - h, v)) / (2 * h),
            (residual(u, v + h) - residual(u, v - h)) / (2 * h),
        ]
    )
    return np.max(np.abs(np.linalg.inv(J)), axis=1) * ROOT_TOL


def test_limit_cycles_of_the_command_match_an_independent_balance(tmp_path):
    """``fitdf limit-cycle`` end to end (parsing, fit, harmonic balance, JSON and table) on a
    core whose cycles can be found another way: rows of a clipped backlash (constant_width
    through the direct chain) fitted by the command, then the cycles of the loop closed
    around the *fitted* parameters it prints, by a 1-D search along the phase balance with
    the DF integrated numerically. Amplitude and frequency of every cycle must agree within
    what the solver's tolerance allows (a relative 1e-4 or so: a 1% error fails), the
    stability verdict too, and no cycle may be missing or printed twice."""
    truth = {"k": 2.0, "b": 0.05, "c": 0.5, "input_scale": 4.0}
    frame = synthetic_frame(
        "constant_width",
        truth,
        chain="direct",
        source_impedances=(0.0,),
        amplitudes=np.geomspace(0.25, 10.0, 14),
        sigma_magnitude=0.0,
        sigma_phase_deg=0.0,
    )
    csv = tmp_path / "backlash.csv"
    frame.to_csv(csv, index=False)
    gains = [5.0, 8.0, 15.0]
    argv = ["limit-cycle", str(csv), "--plant", CLI_PLANT, "--gain", *map(str, gains)]
    argv += ["--model", "constant_width", "--chain", "direct"]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main([*argv, "--json"]) == 0
    record = json.loads(out.getvalue())
    box = record["amplitude_range"]
    assert box == [0.25, 10.0]  # the rows' amplitudes
    printed = {g: [c for c in record["intersections"] if c["gain"] == g] for g in gains}
    n_checked = 0
    for K in gains:
        expected, residual = backlash_cycles(K, record["parameters"], box)
        assert len(printed[K]) == len(expected), (K, printed[K], expected)
        for c, (A, w, stable) in zip(printed[K], expected):
            tol_u, tol_v = solver_tolerance(residual, A, w)
            assert max(tol_u, tol_v) < 2e-3  # the check can see a 1% error
            assert abs(np.log(c["amplitude"] / A)) <= tol_u, (K, c["amplitude"], A, tol_u)
            assert abs(np.log(c["omega_rad_s"] / w)) <= tol_v, (K, c["omega_rad_s"], w, tol_v)
            assert c["frequency_hz"] == pytest.approx(c["omega_rad_s"] / (2 * np.pi), rel=1e-12)
            assert c["stable"] == stable and (c["loeb"] > 0) == stable
            n_checked += 1
    assert n_checked >= 4  # both cycles at the lowest gain, one stable cycle at the others
    # the table prints the same cycles, one line each
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(argv) == 0
    rows = [line.split() for line in out.getvalue().splitlines()]
    rows = [r for r in rows if len(r) == 6 and r[4] in ("yes", "no")]
    assert len(rows) == len(record["intersections"])
    for r, c in zip(rows, record["intersections"]):
        assert float(r[0]) == c["gain"]
        assert float(r[1]) == pytest.approx(c["amplitude"], rel=1e-3)
        assert float(r[2]) == pytest.approx(c["omega_rad_s"], rel=1e-3)


def test_a_cycle_reached_from_two_starts_is_printed_once(monkeypatch):
    """B.3 (preisach, 600 ohm) in the thesis plant at gain 300: two starts of the refinement
    reach each of its two cycles. A fitted core's DF jitters by ~1e-5 between points a hair
    apart (the exact circuit's tolerance), so, depending on the build, the two starts stop
    up to ~1e-5 apart in ``ln A`` and ``ln omega``: the case where one cycle was printed
    twice. The refinement's results are moved apart by that much here, on every build: one
    row per cycle must remain, within :data:`ROOT_TOL` of where it is without the shift."""
    refine = harmonic._refine
    accepted = []

    def jittered(plant, N, gains, x0, bounds):
        x, res = refine(plant, N, gains, x0, bounds)
        accepted.append(int(np.sum(res <= ROOT_TOL)))
        return x + 1e-5 * (np.arange(len(x)) % 2)[:, None], res

    argv = ["limit-cycle", "B.3", "--plant", CLI_PLANT, "--gain", "300", "--model", "preisach"]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main([*argv, "--json"]) == 0
    plain = json.loads(out.getvalue())["intersections"]
    monkeypatch.setattr(harmonic, "_refine", jittered)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main([*argv, "--json"]) == 0
    shifted = json.loads(out.getvalue())["intersections"]
    assert [c["stable"] for c in plain] == [False, True]  # a small unstable, a large stable one
    assert accepted[0] > len(plain)  # (not vacuous: some cycle was reached from two starts)
    assert len(shifted) == len(plain)
    for a, b in zip(plain, shifted):
        assert abs(np.log(a["amplitude"] / b["amplitude"])) < ROOT_TOL
        assert abs(np.log(a["omega_rad_s"] / b["omega_rad_s"])) < ROOT_TOL


def test_distinct_roots_merge_within_the_solvers_tolerance():
    """Rows ``(ln A, ln omega)`` of refined starts: one row per cycle of each gain, the
    smallest residual kept; a root that missed :data:`ROOT_TOL` is none."""
    u, v = np.log(1.408), np.log(12.19)
    x = np.array(
        [
            [u, v],
            [u + 1e-5, v - 1e-5],  # the same cycle, reached from another start
            [u + 0.3, v + 0.1],  # another cycle of that gain
            [u, v],  # the same place at another gain: another cycle
            [u + 0.5 * DEDUP_TOL, v],  # and again there
            [u - 0.2, v],  # not a root
        ]
    )
    res = np.array([3e-6, 1e-15, 1e-12, 1e-12, 2e-12, 2 * ROOT_TOL])
    owner = np.array([0, 0, 0, 1, 1, 0])
    assert list(_distinct_roots(x, res, owner)) == [1, 2, 3]
    assert DEDUP_TOL == ROOT_TOL


def jittery_relay(M=1.0, h=0.1, jitter=2e-5):
    """The relay with hysteresis, its DF jittering by ``jitter`` (relative) from point to
    point as a fitted core's does (the exact circuit's tolerance): refined from two starts, one
    cycle stops at two places ~1e-5 apart."""
    exact = relay(M, h)

    def N(A, w):
        u, v = np.log(np.asarray(A, float)), np.log(np.asarray(w, float))
        noise = np.sin(1e7 * u + 3e7 * v) + 1j * np.cos(2e7 * u - 1e7 * v)
        return exact(A, w) * (1 + jitter * noise)

    return N


@pytest.mark.parametrize("K, grid", [(3.0, (97, 211)), (5.0, (60, 90)), (8.0, (97, 211))])
def test_a_jittering_describing_function_gives_each_cycle_once(K, grid):
    r = limit_cycles(
        PLANT,
        jittery_relay(),
        gains=[K],
        amplitude_range=(0.1001, 50),
        n_amplitude=grid[0],
        n_omega=grid[1],
    )
    (c,) = r.intersections
    A, w = relay_analytic(K)
    assert abs(np.log(c.amplitude / A)) < ROOT_TOL and abs(np.log(c.omega / w)) < ROOT_TOL


@pytest.mark.slow
def test_thesis_comparison_uses_the_fits_it_is_given(monkeypatch):
    """The report hands its own fits in: the comparison must not fit again and must take
    the lowest-AICc candidate of each table (the slow test below checks that the answer
    is the one fitting afresh gives)."""
    import fitdf.limit_cycle_tables.comparison as thesis

    candidates = {t: [fit(t, "rayleigh", seed=0, n_starts=1)] for t in ["B.1", "B.3", "B.2", "B.5"]}
    candidates["B.1"].append(fit("B.1", "constant_width", seed=0, n_starts=1))

    def no_fitting(*args, **kwargs):
        raise AssertionError("fitted again although the fits were given")

    monkeypatch.setattr(thesis, "fit", no_fitting)
    df = thesis_limit_cycle_comparison(candidates=candidates)
    for t, fits in candidates.items():
        best = min(fits, key=lambda r: r.metrics["aicc"])
        assert df.attrs["fits"][t] == {
            "model": best.model,
            "values": best.values,
            "rms_complex": best.metrics["rms_complex"],
        }
        assert set(df.loc[df["table"] == t, "model"]) == {best.model}
    aicc = [r.metrics["aicc"] for r in candidates["B.1"]]
    assert abs(aicc[0] - aicc[1]) > 1.0  # the choice on B.1 is a real one
    # scales given: a third setting at those scales (the one not given is 1), the same as
    # harmonic balance called directly with them
    given = thesis_limit_cycle_comparison(candidates=candidates, time_scale=2.0)
    assert list(dict.fromkeys(given["setting"])) == ["unscaled", "held_out", "given"]
    g = given[(given["setting"] == "given") & (given["table"] == "B.2")]
    assert (g["alpha"] == 2.0).all() and (g["beta"] == 1.0).all()
    assert given.attrs["scales"]["given"] == {"alpha": 2.0, "beta": 1.0}
    direct = limit_cycles(
        THESIS_PLANT,
        candidates["B.2"][0],
        g["system_gain"].to_numpy(),
        amplitude_range=(0.01, 20.0),
        omega_range=(0.03, 300.0),
        time_scale=2.0,
    ).stable_cycles()
    np.testing.assert_allclose(g["omega_pred"], direct["omega_rad_s"], rtol=1e-6)
    assert given.attrs["critical_gains"][0]["predicted"]["given"]["critical_gain"] > 0


def test_fitted_limit_cycles_need_an_impedance_when_the_data_have_two():
    with pytest.raises(OptionError, match="several source impedances"):
        fitted_limit_cycles("permalloy", THESIS_PLANT, [100.0], None, model="constant_width")
    with pytest.raises(OptionError, match="plant"):
        fitted_limit_cycles("B.1", "K/(s+", [100.0], 0.0, model="constant_width")


@pytest.mark.slow
def test_thesis_comparison_runs():
    """End to end with fits of one law: every row in both settings, the unscaled setting at
    alpha = beta = 1 and equal to harmonic balance called directly, the held-out scales those
    of the other blocks' rows, the simulated loop near harmonic balance."""
    candidates = {t: [fit(t, "proportional_width", seed=0)] for t in ["B.1", "B.3", "B.2", "B.5"]}
    df = thesis_limit_cycle_comparison(candidates=candidates, time_domain=True)
    assert len(df) == 2 * 38
    assert list(dict.fromkeys(df["setting"])) == ["unscaled", "held_out"]
    assert set(df["table"]) == {"B.1", "B.2", "B.3", "B.5"}
    un = df[df["setting"] == "unscaled"]
    assert (un["alpha"] == 1.0).all() and (un["beta"] == 1.0).all()
    b3 = un[un["table"] == "B.3"]
    direct = limit_cycles(
        THESIS_PLANT,
        candidates["B.3"][0],
        b3["system_gain"].to_numpy(),
        source_impedance=600.0,
        amplitude_range=(0.01, 20.0),
        omega_range=(0.03, 300.0),
    )
    np.testing.assert_allclose(b3["amplitude_pred"], direct.stable_cycles()["amplitude"], rtol=1e-6)
    assert b3["critical_gain_pred"].iloc[0] == pytest.approx(direct.critical_gain, rel=1e-9)
    held = df.attrs["scales"]["held_out"]
    ho = df[(df["setting"] == "held_out") & (df["table"] == "B.3")]
    assert ho["alpha"].iloc[0] == held["B.3"]["alpha"] and "B.3" not in held["B.3"]["fitted_on"]
    # the loop in time, started on the predicted cycle, keeps it to the describing-function
    # approximation's few percent on this low-pass plant (measured: amplitude 4 %, frequency
    # 2 % at most); where harmonic balance finds no cycle the simulated loop never settles on
    # one, and well below the critical gain it dies out
    cycle = np.isfinite(df["amplitude_pred"])
    assert "oscillates" not in set(df.loc[~cycle, "sim_state"])
    far = ~cycle & (df["system_gain"] < 0.8 * df["critical_gain_pred"])
    assert far.sum() >= 3 and (df.loc[far, "sim_state"] == "dies out").all()
    assert set(df.loc[cycle, "sim_state"]) <= {"oscillates", "unsettled"}
    settled = df[cycle & (df["sim_state"] == "oscillates")]
    assert len(settled) >= 0.9 * cycle.sum()
    assert np.abs(np.log(settled["amplitude_pred"] / settled["amplitude_sim"])).max() < 0.06
    assert np.abs(np.log(settled["omega_pred"] / settled["omega_sim"])).max() < 0.04
    assert limit_cycle_statements(df.attrs) == df.attrs["statements"]
    fig = plot_thesis_comparison(df)
    assert len(fig.axes) == 4


# ------------------------------------------------------------------ when harmonic balance says nothing
@pytest.mark.parametrize("plant", [PLANT, "K/((1+s)(1+0.25s)(1+1.1s))", "K/(s^2+s+1)"])
def test_an_ordinary_plant_gets_no_warning(plant):
    r = limit_cycles(plant, relay(), gains=[1.0, 5.0], amplitude_range=(0.11, 10))
    assert r.warnings == () and r.to_dict()["warnings"] == []


@pytest.mark.parametrize(
    ("plant", "pole"), [("K/(s-1)", "s = 1"), ("K/((s+2)(s^2-0.2s+4))", "s = 0.1+1.997j")]
)
def test_an_open_loop_unstable_plant_is_flagged(plant, pole):
    """No cycle found does not mean a stable loop: the answer says so."""
    r = limit_cycles(plant, relay(), gains=[10.0], amplitude_range=(0.11, 10))
    assert len(r.warnings) == 1, r.warnings
    assert "unstable in open loop" in r.warnings[0] and pole in r.warnings[0]
    assert "does not mean the loop is stable" in r.warnings[0]
    assert r.to_dict()["warnings"] == list(r.warnings)


@pytest.mark.parametrize("plant", ["K(s+2)/(s+1)", "K(s^2+1)/(s+3)", "K"])
def test_a_plant_that_is_not_low_pass_is_flagged(plant):
    r = limit_cycles(plant, relay(), gains=[1.0], amplitude_range=(0.11, 10))
    assert any("not low-pass" in w and "filter" in w for w in r.warnings), r.warnings


def test_a_cycle_whose_third_harmonic_passes_is_flagged():
    """A lightly damped resonance at three times the cycle's frequency amplifies the harmonic."""
    resonant = "10K/(s(s+1)(s+2)(s^2+0.126s+10))"  # |G| peaks at omega = 3.16
    r = limit_cycles(resonant, relay(), gains=[1.0], amplitude_range=(0.11, 10))
    (c,) = r.intersections
    assert c.omega == pytest.approx(1.066, rel=0.01)
    assert len(r.warnings) == 1 and "third harmonic" in r.warnings[0]
    plain = limit_cycles(PLANT, relay(), gains=[1.0], amplitude_range=(0.11, 10))
    assert plain.intersections and plain.warnings == ()


def _relay_table_record(plant):
    """The CLI's limit-cycle record of a relay in ``plant`` at K = 10."""
    r = limit_cycles(plant, relay(), gains=[10.0], amplitude_range=(0.11, 10))
    return {
        **r.to_dict(),
        "model": "relay",
        "chain": "none",
        "data": "closed form",
        "source_impedance_ohm": 0.0,
    }


def test_limit_cycle_table_prints_the_warnings():
    record = _relay_table_record("K/(s-1)")
    text = limit_cycle_text(record)
    assert f"{10:>10.4g} {'none':>12s}" in text  # no cycle at K = 10 ...
    last = text.split("\nWarning: ")[-1]  # (the last paragraph: a warning, wrapped)
    assert last.startswith("the plant is unstable in open loop") and "gain" not in last
    assert max(map(len, text.splitlines())) <= 100


def test_the_table_does_not_promise_decay_for_an_unstable_plant():
    record = _relay_table_record("K/((1+s)(1+0.25s))")
    assert record["critical_gain"] is not None
    assert "Oscillations die out below gain" in limit_cycle_text(record)
    record["warnings"] = ["the plant is unstable in open loop (pole at s = 1): ..."]
    text = limit_cycle_text(record)
    assert "die out" not in text and "No periodic solution below gain" in text
