"""The Tables 5.1/5.2 comparison's record and sentences (fitdf.limit_cycle_tables): the rules at their
boundaries against independent statistics, held-out scales that never see their block, the
simulated loop's verdicts, and every sentence recomputed from the fields it names."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from scipy.optimize import brentq

import fitdf.limit_cycle_tables.comparison as comparison
from fitdf._json import clean
from fitdf.data import datasets
from fitdf.inference.api import resolve_data
from fitdf.limit_cycle_tables import (
    THESIS_BLOCKS,
    THESIS_PLANT,
    estimate_thesis_scales,
    held_out_scales,
    limit_cycle_statements,
    per_block_scales,
)
from fitdf.limit_cycle_tables.data_bound import data_implied_critical_gains, row_balance_gains
from fitdf.limit_cycle_tables.summary import (
    LEVEL_CONFIDENCE,
    _position,
    mean_interval,
    slope_interval,
    summarise,
)

# ------------------------------------------------------------------ a synthetic comparison
#: Two cores, two impedances each; gains; the gains that died out; measured A = a K^0.6 and
#: omega = w K^0.25, each with a fixed wobble (the rows' scatter).
SPEC = {
    "B.1": ("permalloy", 0.0, [100.0, 200.0, 400.0, 800.0], [25.0, 50.0], 0.05, 3.0),
    "B.3": ("permalloy", 600.0, [400.0, 800.0, 1600.0, 3200.0], [200.0], 0.02, 2.5),
    "B.2": ("deltamax", 0.0, [100.0, 200.0, 400.0, 800.0], [50.0], 0.04, 3.5),
    "B.5": ("deltamax", 600.0, [200.0, 400.0, 800.0, 1600.0], [100.0], 0.03, 2.0),
}
WOBBLE = np.array([0.02, -0.015, 0.01, -0.02])
#: Per setting and block: (amplitude factor, omega factor, amplitude exponent, critical gain).
PREDICTION = {
    "unscaled": {
        "B.1": (0.5, 0.5, 0.6, 20.0),
        "B.3": (1.0, 0.5, 0.45, 90.0),
        "B.2": (0.55, 0.48, 0.6, 50.0),
        "B.5": (0.5, 0.52, 0.6, 150.0),
    },
    "held_out": {
        "B.1": (1.0, 1.0, 0.6, 40.0),
        "B.3": (2.0, 1.05, 0.45, 250.0),
        "B.2": (0.9, 0.95, 0.6, 60.0),
        "B.5": (0.8, 1.1, 0.6, 120.0),
    },
}


def synthetic_comparison() -> pd.DataFrame:
    """A long frame shaped like the comparison's, with known ratios, exponents and brackets;
    the simulated loop a fixed 2 % (amplitude) and 1 % (frequency) off harmonic balance."""
    rows = []
    for setting, per in PREDICTION.items():
        for table, (core, rs, gains, dead, a, w) in SPEC.items():
            fa, fw, pa, crit = per[table]
            kref = math.sqrt(gains[0] * gains[-1])  # predicted over measured is fa here
            for i, K in enumerate(dead + gains):
                dies = i < len(dead)
                wob = 1.0 + (0.0 if dies else WOBBLE[i - len(dead)])
                A, W = a * K**0.6 * wob, w * K**0.25 / wob
                Ap = fa * a * K**pa * kref ** (0.6 - pa)
                Wp = fw * w * K**0.25
                rows.append(
                    {
                        "setting": setting,
                        "core": core,
                        "source_impedance_ohm": rs,
                        "table": table,
                        "model": "law",
                        "alpha": 1.0,
                        "beta": 1.0,
                        "system_gain": K,
                        "amplitude_v": np.nan if dies and table == "B.5" else A,
                        "omega_rad_s": np.nan if dies else W,
                        "dies_out": dies,
                        "amplitude_pred": Ap,
                        "omega_pred": Wp,
                        "amplitude_ratio": Ap / A,
                        "omega_ratio": Wp / W,
                        "n_stable": 1,
                        "critical_gain_pred": crit,
                        "critical_omega_pred": 3.0 + crit / 100.0,
                        "extrapolated": setting == "unscaled" and K >= 800.0,
                        "sim_state": "unsettled" if dies and table == "B.2" else "oscillates",
                        "amplitude_sim": Ap * 1.02,
                        "omega_sim": Wp * 0.99,
                    }
                )
    return pd.DataFrame(rows)


SCALES = {
    "per_block": {t: {"alpha": 1.5 + i / 3, "beta": 0.2 + i / 3} for i, t in enumerate(SPEC)},
    "held_out": {
        t: {"alpha": 2.0 + i / 10, "beta": 0.6 + i / 10, "fitted_on": [o for o in SPEC if o != t]}
        for i, t in enumerate(SPEC)
    },
    "joint": {"alpha": 2.2, "beta": 0.68, "rms_phase_deg": 6.0, "rms_magnitude_factor": 1.33},
    "spread": {"alpha_min": 1.5, "alpha_max": 2.5, "beta_min": 0.2, "beta_max": 1.2},
    "given": None,
}


def record(df) -> dict:
    """The comparison's attrs as results.json holds them."""
    return clean({"scales": SCALES, **summarise(df)})


@pytest.fixture(scope="module")
def frame():
    return synthetic_comparison()


@pytest.fixture(scope="module")
def attrs(frame):
    return record(frame)


# ------------------------------------------------------------------ the rules, at their boundaries
def _oscillating(df, setting, table=None):
    g = df[(df["setting"] == setting) & ~df["dies_out"]]
    g = g[np.isfinite(g["amplitude_v"]) & np.isfinite(g["omega_rad_s"])]
    return g if table is None else g[g["table"] == table]


def test_level_interval_is_students():
    r = np.array([0.1, -0.05, 0.3, 0.02, 0.07])
    lo, hi = stats.t.interval(0.95, r.size - 1, loc=r.mean(), scale=stats.sem(r))
    mi = mean_interval(r)
    assert mi["mean"] == pytest.approx(r.mean(), rel=1e-12)
    assert mi["interval"] == pytest.approx([lo, hi], rel=1e-12)
    assert LEVEL_CONFIDENCE == 0.95
    assert np.isnan(mean_interval([0.3])["interval"]).all()


def test_slope_interval_is_the_regression_standard_error():
    x = np.log([100.0, 200.0, 400.0, 800.0, 1600.0])
    y = 0.6 * x + np.array([0.02, -0.01, 0.03, -0.02, 0.0])
    reg = stats.linregress(x, y)
    t = stats.t.ppf(0.975, x.size - 2)
    si = slope_interval(x, y)
    assert si["slope"] == pytest.approx(reg.slope, rel=1e-12)
    assert si["interval"] == pytest.approx(
        [reg.slope - t * reg.stderr, reg.slope + t * reg.stderr], rel=1e-12
    )
    assert np.isnan(slope_interval(x[:2], y[:2])["slope"])


@pytest.mark.parametrize("side", [-1, 1])
def test_level_verdict_flips_at_the_interval_edge(frame, side):
    """Shift one block's predictions so that the interval's lower edge sits just above or just
    below 0: the verdict follows (the rule is 'the 95 % interval of the mean log ratio holds 0')."""
    df = frame.copy()
    sel = (df["setting"] == "unscaled") & (df["table"] == "B.1")
    live = _oscillating(df, "unscaled", "B.1")
    r = np.log(live["amplitude_pred"] / live["amplitude_v"]).to_numpy()
    lo = mean_interval(r)["interval"][0]
    shift = -lo + side * 1e-6  # side = 1: lower edge at +1e-6 (0 outside), -1: inside
    df.loc[sel, "amplitude_pred"] *= math.exp(shift)
    got = summarise(df)["agreement"]["unscaled"]["B.1"]
    assert got["log_amplitude_ratio_interval"][0] == pytest.approx(side * 1e-6, abs=1e-9)
    assert got["amplitude_level_consistent"] is (side < 0)


@pytest.mark.parametrize("side", [-1, 1])
def test_trend_verdict_flips_at_the_interval_edge(frame, side):
    df = frame.copy()
    sel = (df["setting"] == "unscaled") & (df["table"] == "B.2")
    live = _oscillating(df, "unscaled", "B.2")
    x = np.log(live["system_gain"].to_numpy())
    hi = slope_interval(x, np.log(live["amplitude_v"].to_numpy()))["interval"][1]
    pred = slope_interval(x, np.log(live["amplitude_pred"].to_numpy()))["slope"]
    extra = hi - pred + side * 1e-6  # side = 1: just above the interval
    df.loc[sel, "amplitude_pred"] *= df.loc[sel, "system_gain"] ** extra
    got = summarise(df)["trends"]["unscaled"]["B.2"]["amplitude"]
    assert got["predicted_slope"] == pytest.approx(hi + side * 1e-6, abs=1e-9)
    assert got["consistent"] is (side < 0)


def test_trends_compare_the_rows_that_have_a_prediction(frame):
    """A row without a predicted cycle leaves the trend of its block measured and predicted on
    the other rows (both exponents on the same rows); below three rows there is no verdict."""
    df = frame.copy()
    b3 = (df["setting"] == "unscaled") & (df["table"] == "B.3")
    df.loc[b3 & (df["system_gain"] == 400.0), ["amplitude_pred", "omega_pred"]] = np.nan
    got = summarise(df)["trends"]["unscaled"]["B.3"]
    live = _oscillating(df, "unscaled", "B.3")
    live = live[np.isfinite(live["amplitude_pred"])]
    x = np.log(live["system_gain"].to_numpy())
    assert got["rows"] == 3
    assert got["amplitude"]["measured_slope"] == pytest.approx(
        stats.linregress(x, np.log(live["amplitude_v"].to_numpy())).slope, rel=1e-12
    )
    assert got["amplitude"]["predicted_slope"] == pytest.approx(0.45, rel=1e-9)
    df.loc[b3 & (df["system_gain"] == 800.0), ["amplitude_pred", "omega_pred"]] = np.nan
    two = summarise(df)["trends"]["unscaled"]["B.3"]
    assert two["rows"] == 2 and two["amplitude"]["consistent"] is None


def test_critical_position_at_the_bracket_ends():
    assert _position(50.0, 50.0, 100.0) == "inside"
    assert _position(50.0 * (1 - 1e-12), 50.0, 100.0) == "below"
    assert _position(100.0, 50.0, 100.0) == "inside"
    assert _position(100.0 * (1 + 1e-12), 50.0, 100.0) == "above"
    assert _position(float("nan"), 50.0, 100.0) == "none"
    assert _position(10.0, None, 100.0) == "inside"  # no row died out: nothing to be below


def test_summaries_recomputed_from_the_rows(frame, attrs):
    """Each field of the record against a computation from the rows written here."""
    for setting in PREDICTION:
        for table in SPEC:
            live = _oscillating(frame, setting, table)
            ag = attrs["agreement"][setting][table]
            ra = np.log(live["amplitude_pred"] / live["amplitude_v"]).to_numpy()
            rw = np.log(live["omega_pred"] / live["omega_rad_s"]).to_numpy()
            assert ag["rows_oscillating"] == ag["rows_predicted"] == len(SPEC[table][2])
            far = [k for k in SPEC[table][2] if k >= 800.0] if setting == "unscaled" else []
            assert ag["rows_extrapolated"] == len(far)
            assert ag["median_amplitude_ratio"] == pytest.approx(np.exp(np.median(ra)), rel=1e-12)
            assert ag["median_omega_ratio"] == pytest.approx(np.exp(np.median(rw)), rel=1e-12)
            assert ag["rms_log_omega_ratio"] == pytest.approx(np.sqrt(np.mean(rw**2)), rel=1e-12)
            tr = attrs["trends"][setting][table]["amplitude"]
            x = np.log(live["system_gain"].to_numpy())
            assert tr["measured_slope"] == pytest.approx(
                stats.linregress(x, np.log(live["amplitude_v"].to_numpy())).slope, rel=1e-12
            )
            td = attrs["time_domain"][setting][table]
            assert td["rms_log_amplitude_hb_over_sim"] == pytest.approx(np.log(1.02), rel=1e-9)
            assert td["rms_log_omega_hb_over_sim"] == pytest.approx(-np.log(0.99), rel=1e-9)
        assert attrs["agreement"][setting]["all"]["rows_extrapolated"] == sum(
            attrs["agreement"][setting][t]["rows_extrapolated"] for t in SPEC
        )
        # all rows: the median over every oscillating row of the setting
        live = _oscillating(frame, setting)
        all_ratio = np.exp(np.median(np.log(live["amplitude_pred"] / live["amplitude_v"])))
        assert attrs["agreement"][setting]["all"]["median_amplitude_ratio"] == pytest.approx(
            all_ratio, rel=1e-12
        )
    for c in attrs["critical_gains"]:
        core, rs, gains, dead, *_ = SPEC[c["table"]]
        assert c["measured_dies_out_at"] == max(dead)
        assert c["measured_lowest_oscillating"] == gains[0]
        for setting, per in PREDICTION.items():
            p = c["predicted"][setting]
            crit = per[c["table"]][3]
            assert p["critical_gain"] == crit
            assert p["position"] == ("below" if crit < max(dead) else "inside")
            assert p["die_out_over_predicted"] == pytest.approx(max(dead) / crit)
    # pairs: gains both impedances of a core oscillated at
    common = sorted(set(SPEC["B.1"][2]) & set(SPEC["B.3"][2])) + sorted(
        set(SPEC["B.2"][2]) & set(SPEC["B.5"][2])
    )
    assert [p["system_gain"] for p in attrs["impedance_order"]["unscaled"]["rows"]] == common
    assert [(d["table"], d["system_gain"]) for d in attrs["dies_out_rows"]] == [
        (t, k) for t, spec in SPEC.items() for k in spec[3]
    ]
    for d in attrs["dies_out_rows"]:
        assert d["settings"]["unscaled"]["predicted_to_oscillate"] is True


def test_an_order_whose_sign_is_wrong_does_not_agree(frame):
    df = frame.copy()
    sel = (df["setting"] == "unscaled") & (df["table"] == "B.5") & (df["system_gain"] == 400.0)
    io = summarise(df)["impedance_order"]["unscaled"]
    pair = next(p for p in io["rows"] if p["core"] == "deltamax" and p["system_gain"] == 400.0)
    # make the 600-ohm prediction cross the 0-ohm one: the sign of ln(q_600 / q_0) flips
    df.loc[sel, "omega_pred"] *= math.exp(-2 * pair["log_omega_ratio_predicted"])
    flipped = summarise(df)["impedance_order"]["unscaled"]
    assert np.sign(pair["log_omega_ratio_predicted"]) == np.sign(pair["log_omega_ratio_measured"])
    assert flipped["omega_agree"] == io["omega_agree"] - 1
    assert flipped["amplitude_agree"] == io["amplitude_agree"]


# ------------------------------------------------------------------ every sentence from its fields
def _r(values) -> str:
    v = [x for x in values if x is not None]
    return f"{min(v):.2f}-{max(v):.2f}"


def _per_block(attrs, setting, key):
    return [v[key] for k, v in attrs["agreement"][setting].items() if k != "all"]


def test_unscaled_and_held_out_sentences(attrs):
    s = limit_cycle_statements(attrs)
    u = attrs["agreement"]["unscaled"]["all"]
    assert s["unscaled"] == (
        "Unscaled (the plant as printed, the system gain as the loop gain, nothing fitted to "
        "Tables 5.1/5.2), harmonic balance with the fitted cores puts the frequency at "
        f"{u['median_omega_ratio']:.2f} of the measured one (median predicted over measured; "
        f"per block {_r(_per_block(attrs, 'unscaled', 'median_omega_ratio'))}) and the "
        f"amplitude at {u['median_amplitude_ratio']:.2f} (per block "
        f"{_r(_per_block(attrs, 'unscaled', 'median_amplitude_ratio'))}), over the "
        f"{u['rows_predicted']} of {u['rows_oscillating']} rows measured oscillating that have a "
        f"predicted cycle; {u['rows_extrapolated']} of those cycles lie outside the amplitudes or "
        "frequencies the fits saw."
    )
    h = attrs["agreement"]["held_out"]["all"]
    hs = SCALES["held_out"].values()
    assert s["held_out"] == (
        "With the scales fitted to three blocks and used on the fourth (leave one block out; "
        f"time scale {_r(x['alpha'] for x in hs)}, gain scale {_r(x['beta'] for x in hs)} "
        f"across the four fits), the frequency comes out at {h['median_omega_ratio']:.2f} of "
        "the measured one (per block "
        f"{_r(_per_block(attrs, 'held_out', 'median_omega_ratio'))}) and the amplitude at "
        f"{h['median_amplitude_ratio']:.2f} (per block "
        f"{_r(_per_block(attrs, 'held_out', 'median_amplitude_ratio'))}); "
        f"{h['rows_extrapolated']} of the {h['rows_predicted']} predicted cycles lie outside the "
        "amplitudes or frequencies the fits saw."
    )
    sp, j = SCALES["spread"], SCALES["joint"]
    assert s["scales"] == (
        "Fitted to each block's own rows (in-sample), the computer's time scale would be "
        f"{sp['alpha_min']:.2f}-{sp['alpha_max']:.2f} and its gain scale "
        f"{sp['beta_min']:.2f}-{sp['beta_max']:.2f}; one pair fitted to all rows (time "
        f"{j['alpha']:.2f}, gain {j['beta']:.2f}) leaves {j['rms_phase_deg']:.1f} deg RMS of "
        f"phase and a factor {j['rms_magnitude_factor']:.2f} RMS of magnitude in the balance: "
        "an in-sample fit of the scales, not a prediction."
    )


def _held(attrs, setting, q):
    blocks = {k: v for k, v in attrs["agreement"][setting].items() if k != "all"}
    names = [k for k, v in blocks.items() if v[f"{q}_level_consistent"]]
    return len(names), len(blocks), names


def test_levels_and_trends_sentences(attrs):
    s = limit_cycle_statements(attrs)
    parts = {}
    for q in ("omega", "amplitude"):
        bits = []
        for setting, word in (("unscaled", "unscaled"), ("held_out", "held out")):
            k, n, names = _held(attrs, setting, q)
            bits.append(f"{k} of {n} blocks {word}" + (f" ({', '.join(names)})" if names else ""))
        parts[q] = " and ".join(bits)
    assert s["levels"] == (
        "The level of the prediction is within its rows' scatter (the 95 % interval of the mean "
        f"log ratio holds 0) for the frequency in {parts['omega']}, and for the amplitude in "
        f"{parts['amplitude']}."
    )
    # the synthetic B.3 is the only block whose unscaled amplitude level is right (factor 1)
    assert _held(attrs, "unscaled", "amplitude")[2] == ["B.3"]
    tr = attrs["trends"]["unscaled"]
    bits = []
    for q, word in (("amplitude", "amplitude"), ("omega", "frequency")):
        k = sum(t[q]["consistent"] for t in tr.values())
        bits.append(
            f"the exponent of {word} in the system gain, measured "
            f"{_r(t[q]['measured_slope'] for t in tr.values())} across the blocks, is predicted "
            f"within its 95 % interval in {k} of {len(tr)} blocks (predicted "
            f"{_r(t[q]['predicted_slope'] for t in tr.values())})"
        )
    assert s["trends"] == f"Unscaled, {bits[0]}; {bits[1]}."
    # B.3's predicted exponent is 0.45 against a measured 0.6
    assert [t["amplitude"]["consistent"] for t in tr.values()] == [True, False, True, True]


def test_order_and_critical_sentences(attrs):
    s = limit_cycle_statements(attrs)
    o = attrs["impedance_order"]["unscaled"]
    ranges = []
    for q, word in (("amplitude", "amplitude"), ("omega", "frequency")):
        m = [math.exp(p[f"log_{q}_ratio_measured"]) for p in o["rows"]]
        p_ = [math.exp(p[f"log_{q}_ratio_predicted"]) for p in o["rows"]]
        ranges.append(f"{word} measured {_r(m)}, predicted {_r(p_)}")
    assert s["order"] == (
        f"At the {o['pairs']} system gains where both source impedances of a core oscillated, "
        "the unscaled prediction has the sign of the difference between the two impedances "
        f"as measured for the frequency at {o['omega_agree']} of {o['pairs']} and for the "
        f"amplitude at {o['amplitude_agree']} of {o['pairs']} (the value at the higher "
        "impedance over that at the lower: "
        f"{'; '.join(ranges)})."
    )
    cg, dead = attrs["critical_gains"], attrs["dies_out_rows"]
    counts = {
        st: [
            sum(c["predicted"][st]["position"] == p for c in cg)
            for p in ("below", "inside", "above")
        ]
        for st in ("unscaled", "held_out")
    }
    where = {
        st: f"below the measured die-out bracket in {b}, inside it in {i} and above it in {a} of "
        "the 4 blocks"
        for st, (b, i, a) in counts.items()
    }
    detail = "; ".join(
        f"{c['table']} {c['predicted']['unscaled']['critical_gain']:.0f} against "
        f"{c['measured_dies_out_at']:.0f}-{c['measured_lowest_oscillating']:.0f}"
        for c in cg
    )
    osc = {
        st: sum(d["settings"][st]["predicted_to_oscillate"] for d in dead)
        for st in ("unscaled", "held_out")
    }
    assert s["critical"] == (
        "The predicted critical gain (below it harmonic balance finds no cycle) against the "
        "measured bracket (the largest gain at which the oscillations died out, the smallest at "
        f"which they did not): unscaled, {where['unscaled']} ({detail}); held out, "
        f"{where['held_out']}. Harmonic balance predicts an oscillation at {osc['unscaled']} "
        f"(unscaled) and {osc['held_out']} (held out) of the {len(dead)} rows marked "
        '"oscillations die out".'
    )
    below = {st: c[0] for st, c in counts.items()}
    # unscaled: B.2 at 50 (the gain that died out: inside) and B.5 at 150 (inside 100-200);
    # held out: B.3 at 250 inside 200-400 too
    assert below == {"unscaled": 2, "held_out": 1}


def test_time_domain_sentences(attrs):
    s = limit_cycle_statements(attrs)
    dead = attrs["dies_out_rows"]
    for setting, word in (("unscaled", "unscaled"), ("held_out", "held out")):
        a = attrs["time_domain"][setting]["all"]
        states = [d["settings"][setting]["sim_state"] for d in dead]
        # synthetic: B.2's die-out row has not settled, the others oscillate
        assert states.count("unsettled") == 1 and states.count("oscillates") == 4
        assert s[f"time_domain_{setting}"] == (
            f"Simulated in time with the same fitted cores ({word}), the loop settles to the "
            f"cycle harmonic balance predicts at {a['rows_compared']} of the "
            f"{a['rows_oscillating']} rows measured oscillating; there harmonic balance is within "
            f"{a['rms_log_amplitude_hb_over_sim']:.3f} (amplitude) and "
            f"{a['rms_log_omega_hb_over_sim']:.3f} (frequency) RMS log ratio of the simulation "
            "-- the describing-function approximation -- while the simulation differs from the "
            f"table by {a['rms_log_amplitude_sim_over_measured']:.2f} and "
            f"{a['rms_log_omega_sim_over_measured']:.2f} -- the law, the loop's assumptions and "
            "the scales. The simulated loop oscillates at 4 of the 5 rows marked "
            '"oscillations die out" and has not settled at 1 (harmonic balance predicts an '
            "oscillation at 5)."
        )


def test_time_domain_verdict_when_simulation_and_balance_agree(frame):
    df = frame.copy()
    df.loc[df["sim_state"] == "unsettled", "sim_state"] = "oscillates"
    s = limit_cycle_statements(record(df))
    assert s["time_domain_unscaled"].endswith(
        'The simulated loop oscillates at 5 of the 5 rows marked "oscillations die out": '
        "harmonic balance and the simulation agree there, so the describing-function "
        "approximation does not explain those rows."
    )


def test_time_domain_verdict_is_row_by_row(frame):
    """Equal counts are not agreement: the simulation must oscillate at the very rows where
    harmonic balance predicts a cycle."""
    df = frame.copy()
    df.loc[df["sim_state"] == "unsettled", "sim_state"] = "oscillates"
    un = df["setting"] == "unscaled"
    b2 = un & df["dies_out"] & (df["table"] == "B.2")  # no cycle predicted, the loop oscillates
    b1 = un & df["dies_out"] & (df["table"] == "B.1") & (df["system_gain"] == 25.0)
    df.loc[b2, "amplitude_pred"] = np.nan
    df.loc[b1, "sim_state"] = "dies out"  # a cycle predicted, the loop dies out
    s = limit_cycle_statements(record(df))["time_domain_unscaled"]
    assert s.endswith(
        'The simulated loop oscillates at 4 of the 5 rows marked "oscillations die out" and has '
        "not settled at 0 (harmonic balance predicts an oscillation at 4)."
    )
    # nor is a row that has not settled, even where no cycle is predicted
    df = frame.copy()
    df.loc[un & df["dies_out"] & (df["table"] == "B.2"), "amplitude_pred"] = np.nan
    s = limit_cycle_statements(record(df))["time_domain_unscaled"]
    assert s.endswith("and has not settled at 1 (harmonic balance predicts an oscillation at 4).")


def test_confirmed_and_not_confirmed(attrs, frame):
    s = limit_cycle_statements(attrs)
    assert s["confirmed"] == (
        "Tables 5.1 and 5.2 confirm the exponent of frequency in the system gain (all 4 "
        "blocks); the sign of the source impedance's effect on the frequency at equal gain (all 5 "
        "gains); the sign of its effect on the amplitude (all 5 gains)."
    )
    assert s["not_confirmed"] == (
        "They do not confirm the exponent of amplitude in the system gain (it holds in 3 of 4 "
        "blocks); the unscaled frequency level (it holds in 0 of 4 blocks); the unscaled "
        "amplitude level (it holds in 1 of 4 blocks); one pair of scales for every block, held "
        "out (it holds in 1 of 4 blocks); the critical gains, unscaled, inside the measured "
        "brackets (it holds in 2 of 4 blocks)."
    )
    # one block more inside its bracket is not enough; all four is a confirmation
    df = frame.copy()
    for t in SPEC:
        sel = (df["setting"] == "unscaled") & (df["table"] == t)
        df.loc[sel, "critical_gain_pred"] = max(SPEC[t][3]) * (1.5 if t != "B.1" else 0.5)
    three = limit_cycle_statements(record(df))
    assert "inside the measured brackets (it holds in 3 of 4 blocks)" in three["not_confirmed"]
    df.loc[(df["setting"] == "unscaled") & (df["table"] == "B.1"), "critical_gain_pred"] = 60.0
    four = limit_cycle_statements(record(df))
    assert (
        "the critical gains, unscaled, inside the measured brackets (all 4 blocks)"
        in (four["confirmed"])
    )


def test_finding_sentence(attrs):
    s = limit_cycle_statements(attrs)
    u, h = attrs["agreement"]["unscaled"]["all"], attrs["agreement"]["held_out"]["all"]
    cg, dead = attrs["critical_gains"], attrs["dies_out_rows"]
    pos = [c["predicted"]["unscaled"]["position"] for c in cg]
    osc = sum(d["settings"]["unscaled"]["predicted_to_oscillate"] for d in dead)
    assert s["finding"] == (
        "Limit cycles (Tables 5.1, 5.2): unscaled, harmonic balance puts the frequency at "
        f"{u['median_omega_ratio']:.2f} and the amplitude at {u['median_amplitude_ratio']:.2f} "
        f"of the measured (medians over {u['rows_predicted']} rows); with the scales fitted to "
        f"three blocks and used on the fourth, at {h['median_omega_ratio']:.2f} and "
        f"{h['median_amplitude_ratio']:.2f}; the unscaled critical gain lies below the measured "
        f"die-out bracket in {pos.count('below')}, inside it in {pos.count('inside')} and above "
        f"it in {pos.count('above')} of the 4 blocks, and {osc} of the {len(dead)} rows marked "
        '"oscillations die out" are predicted to oscillate.'
    )
    assert pos == ["below", "below", "inside", "inside"]


# ------------------------------------------------------------------ scales held out
class _LeadingSaturation:
    """A saturating element leading by a fixed angle: a nonlinearity without a fit."""

    def __init__(self, level=0.5, lead_deg=40.0):
        self.level, self.lead = level, np.deg2rad(lead_deg)

    def predict(self, amplitude, frequency, source_impedance=0.0):
        A = np.asarray(amplitude, float)
        r = np.minimum(self.level / A, 1.0)
        N = (2 / np.pi) * (np.arcsin(r) + r * np.sqrt(1 - r * r))
        return N * np.exp(1j * self.lead) * np.ones_like(np.asarray(frequency, float))


def _tables():
    t = pd.concat([datasets.load("table_5_1"), datasets.load("table_5_2")], ignore_index=True)
    t["source_impedance_ohm"] = t["source_impedance_ohm"].astype(float)
    return t[np.isfinite(t["omega_rad_s"]) & np.isfinite(t["amplitude_v"]) & ~t["dies_out"]]


def test_held_out_scales_never_see_their_block():
    """Changing one block's measured rows moves every other block's held-out scales, never its
    own; the held-out scales are those fitted to the other blocks' rows alone."""
    fits = {key: _LeadingSaturation(0.3 + 0.1 * i) for i, key in enumerate(THESIS_BLOCKS)}
    rows = _tables()
    before = held_out_scales(rows, fits)
    changed = rows.copy()
    b1 = (changed["core"] == "permalloy") & (changed["source_impedance_ohm"] == 0.0)
    changed.loc[b1, "omega_rad_s"] *= 1.3
    changed.loc[b1, "amplitude_v"] *= 0.7
    after = held_out_scales(changed, fits)
    assert after["B.1"] == before["B.1"]
    for t in ("B.3", "B.2", "B.5"):
        assert after[t]["alpha"] != pytest.approx(before[t]["alpha"], rel=1e-6)
    others = rows[~b1]
    assert before["B.1"]["alpha"] == estimate_thesis_scales(others, fits)["alpha"]
    assert sorted(before["B.1"]["fitted_on"]) == ["B.2", "B.3", "B.5"]
    assert before["B.1"]["n_rows"] == len(others)
    # in-sample per block: each block's own rows
    per = per_block_scales(rows, fits)
    assert per["B.1"] == estimate_thesis_scales(rows[b1], fits)


# ------------------------------------------------------------------ the simulated loop's verdicts
class _Measured:
    def __init__(self, frame):
        self.frame = frame

    def measure(self):
        return self.frame


@pytest.mark.parametrize(
    "oscillating, drift, state",
    [
        (True, 0.0, "oscillates"),
        (True, comparison.SIM_DRIFT_TOL * (1 - 1e-9), "oscillates"),
        (True, -comparison.SIM_DRIFT_TOL * (1 + 1e-9), "unsettled"),
        (True, comparison.SIM_DRIFT_TOL * (1 + 1e-9), "unsettled"),
        (False, 0.0, "dies out"),
    ],
)
def test_simulated_state_at_the_drift_tolerance(monkeypatch, oscillating, drift, state):
    seen = {}

    def fake_simulation(plant, element, gains, **kw):
        seen.update(kw)
        n = len(gains)
        return _Measured(
            pd.DataFrame(
                {
                    "oscillating": [oscillating] * n,
                    "drift": [drift] * n,
                    "amplitude_h1": [1.5] * n,
                    "amplitude": [1.6] * n,
                    "omega": [7.0] * n,
                }
            )
        )

    monkeypatch.setattr(comparison, "simulate_loop", fake_simulation)
    monkeypatch.setattr(comparison.CoreElement, "from_fit", classmethod(lambda cls, f, rs: None))
    block = pd.DataFrame(
        {
            "alpha": [2.0, 2.0],
            "beta": [0.5, 0.5],
            "system_gain": [100.0, 200.0],
            "amplitude_pred": [1.0, np.nan],
            "omega_pred": [6.0, np.nan],
            "amplitude_v": [1.2, 0.8],
            "omega_rad_s": [12.0, 11.0],
        }
    )
    out = comparison._simulate_block(block, None, 0.0, critical_omega=4.0)
    assert list(out["sim_state"]) == [state, state]
    settled = state == "oscillates"
    assert np.isfinite(out["amplitude_sim"]).all() == settled
    if settled:
        assert list(out["amplitude_sim"]) == [1.5, 1.5] and list(out["omega_sim"]) == [7.0, 7.0]
    # started on the predicted cycle, else the measured amplitude at the critical frequency
    assert list(seen["initial_output"]) == [1.0, 0.8]
    assert list(seen["initial_omega"]) == [6.0, 4.0]
    assert seen["time_scale"] == 2.0


# ------------------------------------------------------------------ the rows' own critical gains
def _scalar_balance(D, plant=lambda s: 1 / ((1 + s) * (1 + 0.25 * s) * (1 + 1.1 * s))):
    """A root finder on the thesis plant's phase, row by row (not the tabulated interpolation)."""

    def lag(w):
        return math.atan(w) + math.atan(0.25 * w) + math.atan(1.1 * w)

    w = brentq(lambda w: lag(w) - math.pi - np.angle(D), 1e-3, 1e3, xtol=1e-14, rtol=1e-14)
    return w, 1 / (abs(D) * abs(plant(1j * w)))


def test_row_balance_gains_match_a_root_finder():
    D = np.array([0.99, 0.95 * np.exp(0.3j), 0.2 * np.exp(1.2j), 0.5 * np.exp(-0.1j)])
    omega, gain = row_balance_gains(D, THESIS_PLANT)
    for k, d in enumerate(D):
        w, g = _scalar_balance(d)
        assert omega[k] == pytest.approx(w, rel=1e-6) and gain[k] == pytest.approx(g, rel=1e-6)
    # a lead above 90 degrees asks a phase beyond the plant's -270: no loop closes
    assert np.isnan(row_balance_gains(np.array([np.exp(1.7j)]), THESIS_PLANT)[1][0])
    with pytest.raises(ValueError, match="monotonically"):
        row_balance_gains(D, "K*(s^2+0.1*s+4)/((s+1)^4)")


def test_data_implied_critical_gains_of_a_printed_table():
    """Table B.3's rows: the smallest balance gain per frequency, recomputed row by row."""
    data = resolve_data("B.3")
    got = data_implied_critical_gains(data, THESIS_PLANT)
    freqs = sorted(set(data.frequency))
    assert [r["frequency_hz"] for r in got["by_frequency"]] == freqs
    for r in got["by_frequency"]:
        at = np.flatnonzero(data.frequency == r["frequency_hz"])
        gains = [_scalar_balance(data.measured[i])[1] for i in at]
        j = at[int(np.argmin(gains))]
        assert r["critical_gain"] == pytest.approx(min(gains), rel=1e-6)
        assert r["input_v"] == data.amplitude[j]
    lowest, highest = got["by_frequency"][0], got["by_frequency"][-1]
    assert got["lowest_frequency_hz"] == freqs[0] == 3.0
    assert got["critical_gain"] == lowest["critical_gain"]
    assert got["rise"] == pytest.approx(lowest["critical_gain"] / highest["critical_gain"])
    # the 600-ohm rows' gains rise as the frequency falls (40 at 3 c/s, 16 at 10 c/s)
    assert 35 < got["critical_gain"] < 45 and 2.0 < got["rise"] < 3.0


def test_rows_imply_sentence(attrs):
    """Recomputed from the record: each table's implied gain at its lowest frequency, the
    die-out gain and their ratio, the rise over frequency and where the critical points lie."""
    implied = {
        t: {"critical_gain": 10.0 + i, "lowest_frequency_hz": 3.0, "rise": 1.0 + i / 10}
        for i, t in enumerate(SPEC)
    }
    s = limit_cycle_statements({**attrs, "data_implied": implied})
    cg = attrs["critical_gains"]
    rows = "; ".join(
        f"{c['table']} {implied[c['table']]['critical_gain']:.0f} (at 3 c/s; "
        f"{c['measured_dies_out_at']:.0f} died out, "
        f"{c['measured_dies_out_at'] / implied[c['table']]['critical_gain']:.1f} times higher)"
        for c in cg
    )
    omega = [c["predicted"]["unscaled"]["critical_omega_rad_s"] for c in cg]
    below = sum(w / (2 * math.pi) < 3.0 for w in omega)
    assert below == 4  # 3.2-4.5 rad/s: 0.5-0.72 c/s
    assert s["rows_imply"] == (
        "With no law fitted, each Appendix B row taken as the core's describing function where "
        "it balances the printed plant closes the loop at a gain; the smallest at each table's "
        f"lowest measured frequency: {rows}. From the highest measured frequency to the lowest "
        "these gains change by a factor "
        + ", ".join(f"{c['table']} {implied[c['table']]['rise']:.2f}" for c in cg)
        + f". The unscaled critical points lie at {min(omega):.2g}-{max(omega):.2g} rad/s "
        f"({min(omega) / (2 * math.pi):.2g}-{max(omega) / (2 * math.pi):.2g} c/s), below every "
        f"measured frequency in {below} of the 4 blocks: there the critical gain rests on the "
        "law's describing function below the rows, an extrapolation no row measures."
    )
    # a record without the rows' gains (an earlier report) has no such sentence
    assert "rows_imply" not in limit_cycle_statements(attrs)
