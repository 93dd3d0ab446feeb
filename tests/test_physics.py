"""The report's "What the data say" records (fitdf.report.physics): the tables' printed
precision, the catalogue ranges, the reversed column both ways and the rate-dependent rows,
checked against numbers computed here (Supermalloy at matched flux:
test_supermalloy_report.py)."""

from __future__ import annotations

import csv
import math
from collections import Counter
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from fitdf.data.datasets import data_dir
from fitdf.report.claims import claim
from fitdf.report.physics import (
    physics_record,
    precision_record,
    repeated_readings,
    reversal_record,
)


def _block(core, rms: dict, check=None, data="B.1", aicc=None):
    aicc = aicc or {m: 100 * v for m, v in rms.items()}
    ranking = sorted(
        ({"model": m, "rms_complex": v, "aicc": aicc[m], "n_params": 5} for m, v in rms.items()),
        key=lambda r: r["rms_complex"],
    )
    fits = {m: {"chain": "voltage", "parameters": [], "warnings": []} for m in rms}
    if check:
        fits[min(aicc, key=aicc.get)]["appendix_a_check"] = check
    return {"core": core, "data": data, "ranking_lsq": ranking, "fits_lsq": fits}


def test_the_rounding_of_the_printed_digits_from_the_printed_cells():
    """Table B.1's rows (all fitted) read from the CSV's text: each |DF| cell's step is
    10^-decimals, at least its frequency block's most common; each lead's 1 degree, or 0.5
    where a half is printed; the RMS complex residual of rounding alone is
    sqrt(mean(q_m^2/12 + (|D| q_lead)^2/12))."""
    with open(data_dir() / "appendix_b.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["table"] == "B.1"]
    places = [len(r["df_reported"].split(".")[1]) if "." in r["df_reported"] else 0 for r in rows]
    usual = {}
    for fr in {r["frequency_hz"] for r in rows}:
        counts = Counter(p for p, r in zip(places, rows) if r["frequency_hz"] == fr)
        top = max(counts.values())
        usual[fr] = max(p for p, n in counts.items() if n == top)
    var = []
    for p, r in zip(places, rows):
        q_m = 10.0 ** -max(p, usual[r["frequency_hz"]])
        q_lead = 0.5 if float(r["phase_lead_deg"]) % 1 else 1.0
        var.append(q_m**2 / 12 + (float(r["df_reported"]) * math.radians(q_lead)) ** 2 / 12)
    got = precision_record("B.1")
    assert got["rows"] == len(rows) == 37
    assert got["rounding_rms_complex"] == pytest.approx(math.sqrt(np.mean(var)), rel=1e-12)
    assert got["df_step"] == [0.001, 0.01] and got["phase_step_deg"] == [0.5, 1.0]
    assert got["repeats"] == []
    # B.1 10 c/s prints 0.95 among 0.955 and 0.942: read at three decimals
    assert (
        usual["10"] == 3
        and places[rows.index(next(r for r in rows if r["df_reported"] == "0.95"))] == 2
    )


def test_repeated_readings_are_found_and_their_spread_measured():
    """Table B.2 prints its 3 c/s, 0.6 V row twice alike (a repeated print); readings that
    differ give the spread of a reading about their mean."""
    (dup,) = precision_record("B.2")["repeats"]
    assert (dup["frequency_hz"], dup["input_v"], dup["n"]) == (3.0, 0.6, 2)
    assert dup["identical"] and dup["spread"] == 0.0 and dup["spread_of"] == "magnitude"
    frame = pd.DataFrame(
        {
            "table": ["T", "T", "T", "T"],
            "core": ["c"] * 4,
            "source_impedance_ohm": [0.0] * 4,
            "frequency_hz": [3.0, 3.0, 3.0, 6.0],
            "input_v": [0.5, 0.5, 0.5, 0.5],
            "df_reported": [0.90, 0.92, 0.91, 0.5],
            "phase_lead_deg": [2.0, 4.0, 3.0, 1.0],
        }
    )
    (rep,) = repeated_readings(frame)
    z = np.array([0.90, 0.92, 0.91]) * np.exp(1j * np.radians([2.0, 4.0, 3.0]))
    spread = math.sqrt(sum(abs(z - z.mean()) ** 2) / 2)
    assert rep["n"] == 3 and not rep["identical"] and rep["spread"] == pytest.approx(spread)


def test_the_catalogue_ranges_and_the_precision_of_each_block():
    bp = {
        "quantity": "peak_flux_density_Bp",
        "fitted": 5000.0,
        "low": 6500.0,
        "high": 8000.0,
        "unit": "gauss",
        "inside": False,
        "fitted_low": 4722.0,
        "fitted_high": 8500.0,
        "inside_range": True,
        "determined": "by the data up to the iron fraction",
    }
    results = {
        "blocks": {
            "B.1": _block("permalloy", {"preisach": 0.0249, "rayleigh": 0.05}),
            "B.5": _block("deltamax", {"preisach": 0.041}, data="B.5"),
            # the lowest RMS (rayleigh) is not the best law: AICc prefers preisach
            "permalloy-joint": _block(
                "permalloy",
                {"preisach": 0.039, "rayleigh": 0.038},
                [bp],
                data="permalloy",
                aicc={"preisach": 10.0, "rayleigh": 30.0},
            ),
        },
        "cross_impedance": [],
    }
    printed = {
        ("B.5", "preisach"): SimpleNamespace(
            metrics={"rms_complex": 0.08, "aicc": 9.0, "n_points": 92}
        )
    }
    record = physics_record(
        results,
        audit_findings=["B.5 f=10 c/s phase_lead_deg reads in reverse order", "other"],
        printed=printed,
        dynamic={},
        static_cv={},
        supermalloy=(None, None),
    )
    assert "aims" not in record
    assert set(record["precision"]) == {"B.1", "B.5", "permalloy-joint"}
    assert record["precision"]["B.5"] == precision_record("B.5")
    (b,) = record["catalogue"]
    assert b["law"] == "preisach" and b["quantity"] == "peak_flux_density_Bp"
    assert not b["inside"] and b["inside_for_some_stacking_factor"] and b["unit"] == "gauss"
    assert record["joint"][0]["law"] == "preisach"
    assert record["reversal"]["finding"] == ["B.5 f=10 c/s phase_lead_deg reads in reverse order"]
    assert record["reversal"]["blocks"]["B.5"]["default"]["preisach"]["rms_complex"] == 0.041
    # the sentences: each block's best law against its rounding
    results["physics"] = record
    results["models"] = []
    row = claim("physics.precision_block", results, block="B.5")["values"]
    rounding = precision_record("B.5")["rounding_rms_complex"]
    assert row["rms"] == 0.041 and row["ratio"] == pytest.approx(0.041 / rounding)
    said = claim("physics.precision", results)
    ratios = [0.0249 / record["precision"]["B.1"]["rounding_rms_complex"], 0.041 / rounding]
    ratios.append(0.039 / record["precision"]["permalloy-joint"]["rounding_rms_complex"])
    assert said["values"]["low"] == pytest.approx(min(ratios))
    assert said["values"]["high"] == pytest.approx(max(ratios))
    assert said["text"].startswith(
        f"Against the tables' printed precision: the best law's RMS complex residual is "
        f"{min(ratios):.1f}-{max(ratios):.1f} times the"
    )
    assert "reaches the rounding" not in said["text"]
    assert "The tables repeat no reading, so the tables give no spread" in said["text"]
    # a law at the rounding is said to reach it
    results["blocks"]["B.5"]["ranking_lsq"][0]["rms_complex"] = rounding
    assert "; on B.5 it reaches the rounding." in claim("physics.precision", results)["text"]
    cat = claim("physics.catalogue", results)["text"]
    assert cat.startswith("0 of the 1 catalogue constants (peak flux density B_p of each")
    assert "and 1 for some stacking factor of 0.5-0.9." in cat


def test_reversal_record_skips_fits_of_blocks_not_in_the_report():
    fit = SimpleNamespace(metrics={"rms_complex": 0.1, "aicc": 1.0, "n_points": 3})
    assert reversal_record([], {}, {("B.5", "preisach"): fit})["blocks"] == {}
