"""The report's "What the data say" section: the physics the laws leave out, as records.

:func:`physics_record` gathers, from the report's own fits:

* the **aims** on the best law's residual of each block and of each cross-impedance
  direction, and on the best fits' material constants, each stated as met or not with its
  number (:data:`RMS_AIMS`, :data:`CROSS_AIMS`);
* the **reversed column** the audit finds (Table B.5, 10 c/s phase): the affected blocks'
  best laws fitted with the column as printed beside the default, reversed, policy;
* the **iron fraction** each core's best joint fit implies with Appendix A's ``B_p``
  (:func:`fitdf.inference.material.implied_stacking_factor`), and the **series resistance**
  the joint fits find against its prior;
* the **rate-dependent loss** (the ``dynamic`` chain): each block's best laws refitted with
  Bertotti's dynamic fields, ranked beside the static fits by AICc and cross-validation, and
  their coefficients in material units;
* **Supermalloy's series permeability** (Table B.4) and Q compared at matched flux amplitude,
  rows against the static law and its rate-dependent refit
  (:func:`fitdf.report.supermalloy.supermalloy_record`);
* the **Jiles-Atherton** fits whose mean field sits at its limit.

Everything is computed from the fits handed in; nothing is typed by hand.
"""

from __future__ import annotations

import numpy as np

from fitdf._json import clean
from fitdf.report.supermalloy import supermalloy_record

__all__ = [
    "physics_record",
    "reversal_record",
    "rate_dependent_record",
    "RMS_AIMS",
    "CROSS_AIMS",
]

#: Aims on the best law's RMS complex residual (least squares, ``voltage`` chain) per block.
RMS_AIMS = {
    "B.1": 0.025,
    "B.2": 0.045,
    "B.3": 0.045,
    "B.4": 0.045,
    "B.5": 0.04,
    "permalloy-joint": 0.04,
    "deltamax-joint": 0.055,
}
#: Aims on the best cross-impedance prediction, by (core, training ohm, test ohm).
CROSS_AIMS = {
    ("permalloy", 0.0, 600.0): 0.085,
    ("permalloy", 600.0, 0.0): 0.05,
    ("deltamax", 0.0, 600.0): 0.08,
    ("deltamax", 600.0, 0.0): 0.08,
}
#: Material constants whose agreement with Appendix A is an aim (Permalloy's and Deltamax's).
CONSTANT_AIMS = ("peak_flux_density_Bp", "residual_induction_Br", "coercive_force_Hc")


def _best(rec: dict) -> dict | None:
    rows = rec.get("ranking_lsq") or []
    return rows[0] if rows else None


def _rms_aims(blocks: dict, reversal: dict) -> list[dict]:
    out = []
    for key, target in RMS_AIMS.items():
        rec = blocks.get(key)
        best = _best(rec) if rec else None
        if best is None:
            continue
        row = {
            "aim": f"best law on {key}",
            "target": target,
            "value": best["rms_complex"],
            "law": best["model"],
            "met": bool(best["rms_complex"] <= target),
        }
        printed = (reversal.get("blocks") or {}).get(key, {}).get("as_printed") or {}
        if printed:
            law, value = min(printed.items(), key=lambda kv: kv[1]["rms_complex"])
            row["as_printed"] = {"law": law, "value": value["rms_complex"]}
        out.append(row)
    return out


def _cross_aims(cross: list) -> list[dict]:
    out = []
    for d in cross:
        target = CROSS_AIMS.get((d["core"], float(d["train_ohm"]), float(d["test_ohm"])))
        if target is None or not d["rows"]:
            continue
        r = d["rows"][0]
        out.append(
            {
                "aim": f"{d['core']} {d['train_ohm']:g} -> {d['test_ohm']:g} ohm",
                "target": target,
                "value": r["predict_rms_complex"],
                "law": r["model"],
                "met": bool(r["predict_rms_complex"] <= target),
                "spread": [r.get("predict_rms_complex_min"), r.get("predict_rms_complex_max")],
            }
        )
    return out


def _constant_aims(blocks: dict) -> list[dict]:
    """Permalloy's and Deltamax's best joint fits' B_p, B_r and H_c against Appendix A: inside at
    the nominal stacking factor, inside for some stacking factor of the range, or not."""
    out = []
    for key in ("permalloy-joint", "deltamax-joint"):
        rec = blocks.get(key)
        best = _best(rec) if rec else None
        if best is None:
            continue
        fit = rec["fits_lsq"].get(best["model"]) or {}
        for c in fit.get("appendix_a_check") or []:
            if c["quantity"] not in CONSTANT_AIMS:
                continue
            met = bool(c["inside"])
            out.append(
                {
                    "aim": f"{rec['core']} {c['quantity']} inside Appendix A",
                    "law": best["model"],
                    "value": c["fitted"],
                    "range": [c["low"], c["high"]],
                    "value_range": [c.get("fitted_low"), c.get("fitted_high")],
                    "unit": c["unit"],
                    "met": met,
                    "inside_for_some_stacking_factor": bool(c.get("inside_range", met)),
                    "determined": c.get("determined"),
                }
            )
    return out


def reversal_record(findings: list[str], blocks: dict, printed: dict) -> dict:
    """The reversed column and the affected blocks' best laws fitted both ways.

    ``printed``: ``{(block key, law): FitResult}`` of the fits with the ``as_printed``
    policy; the default policy's are the blocks' own fits."""
    out = {"finding": [f for f in findings if "reverse" in f], "blocks": {}}
    for (key, law), r in printed.items():
        rec = blocks.get(key)
        if rec is None or law not in rec["fits_lsq"]:
            continue
        mine = next(row for row in rec["ranking_lsq"] if row["model"] == law)
        entry = out["blocks"].setdefault(key, {"default": {}, "as_printed": {}})
        entry["default"][law] = {"rms_complex": mine["rms_complex"], "aicc": mine["aicc"]}
        entry["as_printed"][law] = {
            "rms_complex": r.metrics["rms_complex"],
            "aicc": r.metrics["aicc"],
            "n_points": r.metrics["n_points"],
        }
    return out


def _coefficients(fit) -> dict:
    """The dynamic fit's loss coefficients, in winding and in material units, and whether each
    sits at the bottom of its box (``at_lower``: the data find no such loss)."""
    out = {"at_lower": []}
    specs = {s.name: s for s in fit.problem.specs}
    g = fit.problem.geometry
    for name, quantity in (("c_cl", "conductance"), ("c_ex", "current_per_root_voltage")):
        value = fit.values.get(name)
        out[name] = value
        if value is None:
            continue
        if g is not None:
            out[f"k_{name[2:]}"] = value / g.winding_scale(quantity)
        if name in specs and value <= specs[name].bounds[0] * 1.01:
            out["at_lower"].append(name)
    return out


def rate_dependent_record(blocks: dict, dynamic: dict, static_cv: dict) -> dict:
    """Each block's refits through the ``dynamic`` chain beside its static fits.

    ``dynamic``: ``{(block key, law): (dynamic FitResult, its cross-validation)}``;
    ``static_cv``: ``{(block key, law): cross-validation}`` of the static fits. Returns, per
    block, the static ranking's rows and the dynamic rows in one list ordered by AICc, each
    ``{model, chain, n_params, rms_complex, aicc, cv_rms_complex}`` (dynamic rows with their
    coefficients), and ``delta_aicc`` of each dynamic fit against its static one.
    """
    out = {}
    for key, rec in blocks.items():
        laws = [law for (k, law) in dynamic if k == key]
        if not laws:
            continue
        rows = []
        for row in rec["ranking_lsq"]:
            cv = static_cv.get((key, row["model"])) or {}
            rows.append(
                {
                    "model": row["model"],
                    "chain": rec["fits_lsq"][row["model"]]["chain"],
                    "n_params": row["n_params"],
                    "rms_complex": row["rms_complex"],
                    "aicc": row["aicc"],
                    "cv_rms_complex": cv.get("cv_rms_complex", row.get("cv_rms_complex")),
                }
            )
        static = {r["model"]: r for r in rows}
        for law in laws:
            fit, cv = dynamic[(key, law)]
            rows.append(
                {
                    "model": law,
                    "chain": fit.chain,
                    "n_params": fit.metrics["n_params"],
                    "rms_complex": fit.metrics["rms_complex"],
                    "aicc": fit.metrics["aicc"],
                    "cv_rms_complex": (cv or {}).get("cv_rms_complex"),
                    "delta_aicc": fit.metrics["aicc"] - static[law]["aicc"],
                    **_coefficients(fit),
                }
            )
        rows.sort(key=lambda r: np.inf if r["aicc"] is None else r["aicc"])
        out[key] = rows
    return out


def physics_record(
    results: dict,
    *,
    audit_findings: list[str],
    printed: dict,
    dynamic: dict,
    static_cv: dict,
    supermalloy: tuple,
) -> dict:
    """The section's record (JSON-ready): the aims, the reversed column, the iron fraction and
    series resistance of the joint fits, the rate-dependent loss, Supermalloy's permeability at
    matched flux, Jiles-Atherton's mean field.

    ``supermalloy``: ``(static FitResult, dynamic FitResult or None)`` of Table B.4's best law.
    """
    blocks = results["blocks"]
    reversal = reversal_record(audit_findings, blocks, printed)
    joint = []
    for key in ("permalloy-joint", "deltamax-joint"):
        rec = blocks.get(key)
        best = _best(rec) if rec else None
        if best is None:
            continue
        fit = rec["fits_lsq"][best["model"]]
        material = fit.get("material") or {}
        params = {p["parameter"]: p for p in fit.get("parameters") or []}
        r = params.get("r_series") or {}
        joint.append(
            {
                "block": key,
                "core": rec["core"],
                "law": best["model"],
                "implied_stacking_factor": material.get("implied_stacking_factor"),
                "r_series": r.get("value"),
                "r_series_interval": [r.get("p16"), r.get("p84")],
            }
        )
    ja = []
    for key, rec in blocks.items():
        fit = rec["fits_lsq"].get("jiles_atherton")
        if not fit:
            continue
        zeta = next((p["value"] for p in fit["parameters"] if p["parameter"] == "zeta"), None)
        limit = [w for w in fit.get("warnings") or [] if w.startswith("zeta")]
        ja.append({"block": key, "zeta": zeta, "at_limit": bool(limit), "warning": limit[:1]})
    return clean(
        {
            "aims": _rms_aims(blocks, reversal)
            + _cross_aims(results.get("cross_impedance") or [])
            + _constant_aims(blocks),
            "reversal": reversal,
            "joint": joint,
            "rate_dependent": rate_dependent_record(blocks, dynamic, static_cv),
            "supermalloy": supermalloy_record(*supermalloy),
            "jiles_atherton": ja,
        }
    )
