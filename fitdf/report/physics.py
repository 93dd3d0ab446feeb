"""The report's "What the data say" section: the physics the laws leave out, as records.

:func:`physics_record` gathers, from the report's own fits:

* the **aims** on the best law's residual of each block and of each cross-impedance
  direction, and on the best fits' material constants, each stated as met or not with its
  number (:data:`RMS_AIMS`, :data:`CROSS_AIMS`);
* the **reversed column** (Table B.5, 10 c/s phase), taken reversed by a documented decision of
  the bundled data (:data:`fitdf.data.datasets.DECISIONS`), with what the audit's column-order
  rule finds: the affected blocks' best laws fitted with the column as printed beside the
  default policy's fits, which apply the decision;
* the **iron fraction** each core's best joint fit implies with Appendix A's ``B_p``
  (:func:`fitdf.inference.material.implied_stacking_factor`), and the **series resistance**
  the joint fits find against its prior;
* the **rate-dependent loss** (the ``dynamic`` chain): each block's best laws refitted with
  Bertotti's dynamic fields, ranked beside the static fits by AICc and cross-validation, their
  coefficients in material units, and whether that reproduces Supermalloy's falling
  small-signal permeability (Table B.4, 3 and 50 c/s) within 20 %;
* the **Jiles-Atherton** fits whose mean field sits at its limit.

Everything is computed from the fits handed in; nothing is typed by hand.
"""

from __future__ import annotations

import numpy as np

from fitdf._json import clean
from fitdf.data import audit, datasets
from fitdf.inference.small_signal import series_permeability, small_signal_permeability

__all__ = [
    "physics_record",
    "reversal_record",
    "rate_dependent_record",
    "supermalloy_fall",
    "RMS_AIMS",
    "CROSS_AIMS",
    "FALL_TOLERANCE",
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
#: Relative tolerance on Supermalloy's small-signal permeability fall from 3 to 50 c/s.
FALL_TOLERANCE = 0.2


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


def reversal_record(findings: list[str], blocks: dict, printed: dict, decisions=None) -> dict:
    """The decided column, the audit's evidence, and the affected blocks' best laws fitted both
    ways.

    ``findings``: the audit's sentences (those giving the evidence of a column read in reverse
    order are kept); ``decisions``: records of :func:`fitdf.data.audit.decisions` (default: the
    bundled Appendix B's); ``printed``: ``{(block key, law): FitResult}`` of the fits with the
    ``as_printed`` policy; the default policy's (the decision applied) are the blocks' own
    fits."""
    if decisions is None:
        decisions = audit.decisions(datasets.load("appendix_b")).to_dict(orient="records")
    kept = [f for f in findings if " reads in reverse order" in f and not f.startswith("Column")]
    out = {"decisions": clean(list(decisions)), "finding": kept, "blocks": {}}
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


def _flux(df, v, gain, frequency):
    """Peak flux linkage (V s) of a reading: the EMF ``DF V / gain`` over ``w``."""
    return np.abs(np.asarray(df) * v / gain) / (2 * np.pi * np.asarray(frequency))


def supermalloy_fall(static, dynamic) -> dict | None:
    """Supermalloy's small-signal permeability at its lowest and highest frequency (Table B.4):
    measured and as the static and the dynamic fit predict, each inverted through the circuit
    of Fig 5.10 with the fit's own series resistance and gain, and whether the dynamic fit
    reproduces the measured fall within :data:`FALL_TOLERANCE`.

    Also what the data themselves say about the fall: the measured quality factor of the
    two smallest rows at the lowest frequency and of the smallest row at the next one (the
    fall rests on the smallest reading if only it is nearly lossless), and the flux
    amplitude of the two rows compared (a smaller flux at the higher frequency: part of the
    fall is amplitude, which a rate-independent law already has).
    """
    if static is None or static.problem.geometry is None:
        return None
    fits = {"static": static, "dynamic": dynamic}
    tables = {k: small_signal_permeability(r) for k, r in fits.items() if r is not None}
    t = tables["static"].sort_values("frequency_hz")
    lo, hi = t.iloc[0], t.iloc[-1]
    out = {
        "frequencies_hz": [float(lo["frequency_hz"]), float(hi["frequency_hz"])],
        "measured": [float(lo["mu_measured"]), float(hi["mu_measured"])],
        "q_measured": [float(lo["q_measured"]), float(hi["q_measured"])],
    }
    for name, table in tables.items():
        s = table.sort_values("frequency_hz")
        out[f"{name}_model"] = fits[name].model
        out[f"{name}_chain"] = fits[name].chain
        out[f"{name}_measured"] = [
            float(s.iloc[0]["mu_measured"]),
            float(s.iloc[-1]["mu_measured"]),
        ]
        out[name] = [float(s.iloc[0]["mu_fitted"]), float(s.iloc[-1]["mu_fitted"])]
    ratio = lambda pair: pair[0] / pair[1]  # noqa: E731
    out["fall_measured"] = ratio(out["measured"])
    out["fall_static"] = ratio(out["static"])
    if "dynamic" in out:
        out["fall_dynamic"] = ratio(out["dynamic"])
        measured = ratio(out["dynamic_measured"])
        out["reproduced"] = bool(abs(out["fall_dynamic"] / measured - 1) <= FALL_TOLERANCE)
    out["evidence"] = _fall_evidence(static)
    return out


def _fall_evidence(fit) -> dict:
    """The quality factors of the smallest readings and the flux amplitudes of the two rows."""
    p = fit.problem
    d = p.data
    f = np.asarray(d.frequency, float)
    v = np.asarray(d.amplitude, float)
    measured = np.asarray(d.measured)
    R = np.asarray(d.source_impedance, float) + fit.values.get("r_series", 0.0)
    gain = np.array(
        [fit.values.get(f"gain[{g}]", fit.values.get("gain", 1.0)) for g in np.asarray(d.group)]
    )
    freqs = np.unique(f)
    q = {}
    for fr in freqs[:2]:
        idx = np.flatnonzero(f == fr)[np.argsort(v[f == fr])][:2]
        mu = series_permeability(measured[idx], f[idx], R[idx], gain[idx], p.geometry)
        q[f"{fr:g}"] = [float(m.real / -m.imag) for m in mu]
    low = np.flatnonzero(f == freqs[0])[np.argmin(v[f == freqs[0]])]
    high = np.flatnonzero(f == freqs[-1])[np.argmin(v[f == freqs[-1]])]
    flux = _flux(measured[[low, high]], v[[low, high]], gain[[low, high]], f[[low, high]])
    return {"q_smallest_rows": q, "flux_vs": [float(flux[0]), float(flux[1])]}


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
    series resistance of the joint fits, the rate-dependent loss, Jiles-Atherton's mean field.

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
            "supermalloy_fall": supermalloy_fall(*supermalloy),
            "jiles_atherton": ja,
        }
    )
