"""The report's "What the data say" records (fitdf.report.physics): the aims, the reversed column
both ways and the rate-dependent rows, checked against numbers computed here (Supermalloy at
matched flux: test_supermalloy_report.py)."""

from __future__ import annotations

from types import SimpleNamespace

from fitdf.report.physics import (
    CROSS_AIMS,
    RMS_AIMS,
    physics_record,
    reversal_record,
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
