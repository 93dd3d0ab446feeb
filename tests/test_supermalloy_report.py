"""The report's Supermalloy paragraphs and Findings bullet (fitdf.report.supermalloy): every
number and every word recomputed here from the record's fields (as results.json keeps them)."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from scipy import stats
from supermalloy_fits import DYNAMIC, STATIC, near_optimum

from fitdf.report.physics_claims import physics_findings
from fitdf.report.physics_outline import _supermalloy
from fitdf.report.supermalloy import (
    FIGURE,
    RISE_WORDS,
    sentence_fields,
    supermalloy_figure,
    supermalloy_record,
    supermalloy_sentences,
)


@pytest.fixture(scope="module")
def record():
    rec = supermalloy_record(near_optimum("voltage", STATIC), near_optimum("dynamic", DYNAMIC))
    return json.loads(json.dumps(rec, allow_nan=False))  # as results.json keeps it


def _k(x):
    return f"{x / 1e3:.3g}k"


def _s(x):
    return f"{x:.3f}"


def _mv(x):
    return f"{1e3 * x:.3g}"


def _and(items):
    items = list(items)
    return ", ".join(items[:-1]) + " and " + items[-1] if len(items) > 1 else items[0]


def test_matched_flux_sentence_is_recomputed_from_the_level_rows(record):
    text = supermalloy_sentences(record)["matched"]
    static = record["fits"]["static"]
    assert f"R_source + r_series = {static['r_total_ohm']:.4g} ohm" in text
    assert f"gain {static['gain']:.4g} of the static fit, `{static['model']}`)" in text
    common = record["common_vs"]
    rows = sorted(
        (r for r in record["levels"] if r["level_vs"] == common), key=lambda r: r["frequency_hz"]
    )
    f = np.array([r["frequency_hz"] for r in rows])
    mu = np.array([r["mu"] for r in rows])
    # the common level is the largest of the frequencies' smallest fluxes
    smallest = [r["flux_vs"] for r in record["small_flux"]]
    assert common == max(smallest) and len(rows) == len(smallest)
    assert f"At {_mv(common)} mV s, the smallest flux all {len(rows)} frequencies reach" in text
    assert f"mu' {_and(_k(m) for m in mu)} at {_and(f'{x:g}' for x in f)} c/s" in text
    assert f"{mu.max() / mu.min():.3g}x between the largest and the smallest" in text
    steps = np.diff(mu)
    word = (
        "falling with frequency"
        if (steps < 0).all()
        else "rising with frequency"
        if (steps > 0).all()
        else "not monotone in frequency"
    )
    assert f", {word}, {mu[0] / mu[-1]:.3g}x from {f[0]:g} to {f[-1]:g} c/s" in text
    slope, icpt = np.polyfit(np.log(f), np.log(mu), 1)
    resid = np.log(mu) - (icpt + slope * np.log(f))
    se = math.sqrt(np.sum(resid**2) / (f.size - 2) / np.sum((np.log(f) - np.log(f).mean()) ** 2))
    half = stats.t.ppf(0.975, f.size - 2) * se
    assert f"s = {slope:.3f} (95 % interval {slope - half:.3f} to {slope + half:.3f})" in text
    assert f"scatter {100 * math.sqrt(np.mean(resid**2)):.3g} % (RMS)" in text
    level = next(r for r in record["frequency"] if r["level_vs"] == common)
    assert f"the printed precision of the readings {100 * level['precision']:.3g} %" in text
    # every level three or more frequencies reach, and which laws' slopes its interval holds
    levels = [r for r in record["frequency"] if r["n_frequencies"] >= 3]
    assert f"At the {len(levels)} flux levels three or more frequencies reach" in text
    assert f"({_and(_mv(r['level_vs']) for r in levels)} mV s)" in text
    assert f"s = {_and(_s(r['slope']) for r in levels)};" in text
    for law in ("static", "dynamic"):
        held = sum(r["slope_lo"] <= r["slope_" + law] <= r["slope_hi"] for r in levels)
        slopes = _and(_s(r["slope_" + law]) for r in levels)
        assert f"({slopes}) at {held} of {len(levels)}" in text


def test_small_flux_sentence_is_recomputed_from_the_levels(record):
    text = supermalloy_sentences(record)["small_flux"]
    at = {(r["level_vs"], r["frequency_hz"]): r for r in record["levels"]}
    common = record["common_vs"]
    deep = min(record["small_flux"], key=lambda r: r["flux_vs"])
    f = deep["frequency_hz"]
    own, top = at[(deep["flux_vs"], f)], at[(common, f)]
    rise = top["mu"] / own["mu"]
    rise_static = top["mu_static"] / own["mu_static"]
    rise_dynamic = top["mu_dynamic"] / own["mu_dynamic"]
    steeper = deep["rise_lo"] > max(rise_static, rise_dynamic)
    shallower = deep["rise_hi"] < min(rise_static, rise_dynamic)
    key = "steeper" if steeper else "shallower" if shallower else "alike"
    assert text.startswith(RISE_WORDS[key][0] + ": ")
    assert (
        f"from {_mv(deep['flux_vs'])} to {_mv(common)} mV s at {f:g} c/s the rows' mu' rises "
        f"{rise:.3g}x ({deep['rise_lo']:.3g}-{deep['rise_hi']:.3g} at printed precision), the "
        f"static law's {rise_static:.3g}x, its refit with rate-dependent losses "
        f"{rise_dynamic:.3g}x." in text
    )
    over = own["mu"] / own["mu_static"]
    scatter = next(r for r in record["frequency"] if r["level_vs"] == common)["scatter"]
    assert (
        f"the rows give {_k(own['mu'])} against the static law's {_k(own['mu_static'])}, "
        f"{over:.3g} times it, a deviation of {abs(math.log(over)) / scatter:.3g} times" in text
    )
    small = sorted(record["small_flux"], key=lambda r: r["frequency_hz"])
    ratios = [at[(r["flux_vs"], r["frequency_hz"])] for r in small]
    over = _and(f"{r['mu'] / r['mu_static']:.3g}" for r in ratios)
    assert f"rows over the static law are {over}" in text
    # levels only two frequencies reach: the lower frequency's mu' over the higher's
    for r in record["frequency"]:
        if r["n_frequencies"] == 2:
            lo, hi = r["frequencies_hz"]
            ratio = at[(r["level_vs"], lo)]["mu"] / at[(r["level_vs"], hi)]["mu"]
            assert (
                f"at {_mv(r['level_vs'])} mV s the {lo:g} c/s rows give {ratio:.3g} times" in text
            )


def test_quality_sentence_gives_every_smallest_reading_its_range(record):
    text = supermalloy_sentences(record)["quality"]
    for r in record["small_flux"]:
        q = r["mu"] / next(
            x["mu"] / x["q"]
            for x in record["levels"]
            if x["frequency_hz"] == r["frequency_hz"] and x["own"]
        )
        assert q == pytest.approx(r["q"], rel=1e-12)
        # a range without an upper end (a draw at or beyond lossless) is said as "above"
        part = (
            f"{q:.3g} (above {r['q_lo']:.3g})"
            if r["q_hi"] is None
            else f"{q:.3g} ({r['q_lo']:.3g}-{r['q_hi']:.3g})"
        )
        assert part in text
    assert "66" not in text or "above" in text  # the 3 c/s reading's Q is only bounded below


def test_finding_bullet_is_recomputed(record):
    said = supermalloy_sentences(record)
    text = said["finding"]
    c = next(r for r in record["frequency"] if r["level_vs"] == record["common_vs"])
    deep = min(record["small_flux"], key=lambda r: r["flux_vs"])
    f = c["frequencies_hz"]
    assert text.startswith("Supermalloy (Table B.4, `preisach`) at matched flux: at ")
    assert f"mu' differs {c['ratio']:.3g}x over {f[0]:g}-{f[-1]:g} c/s" in text
    assert f"power law f^{c['slope']:.3f}, 95 % interval {c['slope_lo']:.3f} to" in text
    assert (
        f"({deep['frequency_hz']:g} c/s, {_mv(deep['flux_vs'])} to {_mv(deep['common_vs'])} mV s: "
        f"rows {deep['rise']:.3g}x, static law {deep['rise_static']:.3g}x, refit with "
        f"rate-dependent losses {deep['rise_dynamic']:.3g}x)." in text
    )
    # the same words as the paragraph's
    key = next(k for k, (long, _) in RISE_WORDS.items() if said["small_flux"].startswith(long))
    assert RISE_WORDS[key][1] in text


def test_words_turn_at_their_boundaries(record):
    """The rows' rise exactly at a law's is not "steeper"; one ulp above all of them is; the
    same for "shallower"; a falling mu' at the common level is said so."""
    rec = copy.deepcopy(record)
    deep = min(rec["small_flux"], key=lambda r: r["flux_vs"])
    top = max(deep["rise_static"], deep["rise_dynamic"])
    bottom = min(deep["rise_static"], deep["rise_dynamic"])
    deep["rise_lo"], deep["rise_hi"] = top, top * 1.5
    assert supermalloy_sentences(rec)["small_flux"].startswith(RISE_WORDS["alike"][0])
    deep["rise_lo"] = float(np.nextafter(top, np.inf))
    assert supermalloy_sentences(rec)["small_flux"].startswith(RISE_WORDS["steeper"][0])
    deep["rise_lo"], deep["rise_hi"] = bottom * 0.5, bottom
    assert supermalloy_sentences(rec)["small_flux"].startswith(RISE_WORDS["alike"][0])
    deep["rise_hi"] = float(np.nextafter(bottom, -np.inf))
    assert supermalloy_sentences(rec)["small_flux"].startswith(RISE_WORDS["shallower"][0])
    at = [r for r in rec["levels"] if r["level_vs"] == rec["common_vs"]]
    for i, r in enumerate(sorted(at, key=lambda r: r["frequency_hz"])):
        r["mu"] = 3e4 - i
    assert "falling with frequency" in supermalloy_sentences(rec)["matched"]
    # "rises with the flux amplitude" only if every frequency's mu' rises to the common level
    assert ") rises with the flux amplitude" in supermalloy_sentences(rec)["matched"]
    below = next(r for r in rec["small_flux"] if r["flux_vs"] < rec["common_vs"])
    below["rise"] = 1.0
    assert ") changes with the flux amplitude" in supermalloy_sentences(rec)["matched"]
    # the levels whose interval holds a law's slope are counted from their own verdicts
    levels = [r for r in rec["frequency"] if r["n_frequencies"] >= 3]
    held = sum(bool(r["contains_static"]) for r in levels)
    levels[0]["contains_static"] = not levels[0]["contains_static"]
    held += 1 if levels[0]["contains_static"] else -1
    assert f"at {held} of {len(levels)}" in supermalloy_sentences(rec)["matched"]
    # the small-flux sentence speaks of the frequency that reaches the smallest flux
    fields = sentence_fields(rec)
    assert fields["deepest"]["flux_vs"] == min(r["flux_vs"] for r in rec["small_flux"])
    other = next(r for r in rec["small_flux"] if r is not fields["deepest"])
    other["flux_vs"] = 0.5 * fields["deepest"]["flux_vs"]
    assert sentence_fields(rec)["deepest"] is other
    # without a refit the dynamic clauses go
    rec.pop("curves")
    rec["fits"].pop("dynamic")
    said = supermalloy_sentences(rec)
    assert all("rate-dependent" not in t for t in said.values())


def test_section_and_findings_carry_the_sentences(record, tmp_path):
    said = supermalloy_sentences(record)
    rec = {**record, "figure": supermalloy_figure(record, tmp_path)}
    assert rec["figure"] == f"figures/{FIGURE}" and (tmp_path / FIGURE).stat().st_size > 10_000
    blocks = _supermalloy(rec, {})
    paragraphs = [b[1] for b in blocks if b[0] == "p"]
    assert paragraphs == [said["matched"], said["small_flux"], said["quality"]]
    assert ("img", rec["figure"], "Supermalloy: series permeability and Q against flux") in blocks
    results = {"blocks": {}, "physics": {"rate_dependent": {}, "supermalloy": record}}
    assert physics_findings(results)[-1] == said["finding"]
    assert _supermalloy(None, {}) == [] and supermalloy_record(None, None) is None
