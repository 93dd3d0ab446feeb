"""The report's "What the data say" records (fitdf.report.physics): the aims, the reversed column
both ways, the rate-dependent rows, and Supermalloy's small-signal permeability, checked against
numbers computed here."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

import fitdf
from fitdf.report.physics import (
    CROSS_AIMS,
    FALL_TOLERANCE,
    RMS_AIMS,
    physics_record,
    reversal_record,
    supermalloy_fall,
)


def _block(core, rms: dict, check=None):
    ranking = sorted(
        ({"model": m, "rms_complex": v, "aicc": 100 * v, "n_params": 5} for m, v in rms.items()),
        key=lambda r: r["rms_complex"],
    )
    fits = {m: {"chain": "voltage", "parameters": [], "warnings": []} for m in rms}
    if check:
        fits[ranking[0]["model"]]["appendix_a_check"] = check
    return {"core": core, "ranking_lsq": ranking, "fits_lsq": fits}


def test_aims_say_met_or_not_with_the_number():
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
            "B.5": _block("deltamax", {"preisach": 0.041}),
            "permalloy-joint": _block("permalloy", {"preisach": 0.039}, [bp]),
        },
        "cross_impedance": [
            {
                "core": "permalloy",
                "train_ohm": 0.0,
                "test_ohm": 600.0,
                "rows": [
                    {
                        "model": "preisach",
                        "predict_rms_complex": 0.09,
                        "predict_rms_complex_min": 0.08,
                        "predict_rms_complex_max": 0.2,
                    }
                ],
            }
        ],
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
    aims = {a["aim"]: a for a in record["aims"]}
    assert aims["best law on B.1"]["met"] and aims["best law on B.1"]["target"] == RMS_AIMS["B.1"]
    assert not aims["best law on B.5"]["met"] and aims["best law on B.5"]["value"] == 0.041
    assert aims["best law on B.5"]["as_printed"] == {"law": "preisach", "value": 0.08}
    assert aims["best law on permalloy-joint"]["met"]  # 0.039 <= 0.04
    cross = aims["permalloy 0 -> 600 ohm"]
    assert cross["target"] == CROSS_AIMS[("permalloy", 0.0, 600.0)] and not cross["met"]
    assert cross["spread"] == [0.08, 0.2]
    b = aims["permalloy peak_flux_density_Bp inside Appendix A"]
    assert not b["met"] and b["inside_for_some_stacking_factor"] and b["unit"] == "gauss"
    assert record["reversal"]["finding"] == ["B.5 f=10 c/s phase_lead_deg reads in reverse order"]
    assert record["reversal"]["blocks"]["B.5"]["default"]["preisach"]["rms_complex"] == 0.041


def test_reversal_record_skips_fits_of_blocks_not_in_the_report():
    fit = SimpleNamespace(metrics={"rms_complex": 0.1, "aicc": 1.0, "n_points": 3})
    assert reversal_record([], {}, {("B.5", "preisach"): fit})["blocks"] == {}


@pytest.fixture(scope="module")
def supermalloy():
    """Table B.4 fitted with Rayleigh's law (cheap) through the exact chain, and refitted with
    rate-dependent losses from it."""
    static = fitdf.fit("B.4", "rayleigh", method="lsq", n_starts=2)
    dynamic = fitdf.fit("B.4", "rayleigh", chain="dynamic", method="lsq", n_starts=2)
    return static, dynamic


def _mu_by_hand(fit, row):
    """Series relative permeability of one measured row, through Fig 5.10 by hand."""
    d, v = fit.problem.data, fit.values
    g = fit.problem.geometry
    gain = v.get("gain", v.get("gain[B.4]"))
    R = d.source_impedance[row] + v["r_series"]
    D = d.measured[row]
    Z = R * D / (gain - D)
    L = Z / (2j * math.pi * d.frequency[row])
    mu = L * g.l_e / (4e-7 * math.pi * g.turns**2 * g.a_e)
    return mu.real, mu.real / -mu.imag


def test_supermalloy_fall_against_the_circuit_by_hand(supermalloy):
    static, dynamic = supermalloy
    f = supermalloy_fall(static, dynamic)
    d = static.problem.data
    freqs = np.unique(d.frequency)
    rows = [
        int(np.flatnonzero(d.frequency == fr)[np.argmin(d.amplitude[d.frequency == fr])])
        for fr in (freqs[0], freqs[-1])
    ]
    (mu_lo, q_lo), (mu_hi, _) = (_mu_by_hand(static, r) for r in rows)
    assert f["frequencies_hz"] == [3.0, 50.0]
    assert f["measured"] == pytest.approx([mu_lo, mu_hi], rel=1e-9)
    assert f["q_measured"][0] == pytest.approx(q_lo, rel=1e-9)
    assert f["fall_measured"] == pytest.approx(mu_lo / mu_hi, rel=1e-9)
    measured_dyn = f["dynamic_measured"][0] / f["dynamic_measured"][1]
    assert f["reproduced"] == (abs(f["fall_dynamic"] / measured_dyn - 1) <= FALL_TOLERANCE)
    # the evidence: the flux of a reading is its EMF over omega
    ev = f["evidence"]
    gain = static.values.get("gain", static.values.get("gain[B.4]"))
    flux = abs(d.measured[rows[0]] * d.amplitude[rows[0]] / gain) / (2 * math.pi * 3.0)
    assert ev["flux_vs"][0] == pytest.approx(flux, rel=1e-12)
    assert set(ev["q_smallest_rows"]) == {"3", "6"}
