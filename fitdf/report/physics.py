"""The report's "What the data say" section: the physics the laws leave out, as records.

:func:`physics_record` gathers, from the report's own fits and the bundled tables:

* the tables' **printed precision** on each block's rows (:func:`precision_record`): the RMS
  complex residual that rounding to the printed digits alone would give, and the readings
  the tables repeat, against which the best law's residual is read;
* the **catalogue ranges**: the best joint fits' material constants against Appendix A
  (:data:`CATALOGUE_CONSTANTS`), inside at the nominal stacking factor, for some stacking
  factor of the range, or not;
* the **reversed column** (Table B.5, 10 c/s phase), taken reversed by a documented decision of
  the bundled data (:data:`fitdf.data.datasets.DECISIONS`), with what the audit's column-order
  rule finds: the affected blocks' best laws fitted with the column as printed beside the
  default policy's fits, which apply the decision;
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

The best law of a block is :func:`fitdf.report.criteria.best_law` (the lowest AICc).
Everything is computed from the fits and tables handed in; nothing is typed by hand.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf._json import clean
from fitdf.data import audit, datasets
from fitdf.data.resolve import resolve_data
from fitdf.report.criteria import best_law
from fitdf.report.supermalloy import supermalloy_record

__all__ = [
    "physics_record",
    "precision_record",
    "repeated_readings",
    "reversal_record",
    "rate_dependent_record",
    "CATALOGUE_CONSTANTS",
]

#: The material constants of Permalloy's and Deltamax's best joint fits set beside their
#: Appendix A catalogue ranges.
CATALOGUE_CONSTANTS = ("peak_flux_density_Bp", "residual_induction_Br", "coercive_force_Hc")


def _best(rec: dict) -> dict | None:
    """The ranking row of the block's best law (:func:`~fitdf.report.criteria.best_law`)."""
    rows = rec.get("ranking_lsq") or []
    law = best_law([r["model"] for r in rows], [r["aicc"] for r in rows])
    return next((r for r in rows if r["model"] == law), None)


def _steps(frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Each row's printed step of ``|DF|`` and of the phase lead (degrees).

    ``|DF|``: ``10**-decimals``, a cell printed with fewer decimals than its block's usual
    (the most common of its table and frequency) read at the usual, as a dropped trailing
    zero (``0.95`` among ``0.955`` and ``0.942``; ``1`` among ``0.99``). The lead: 0.5 for a
    cell printed with a half, else 1 (the tables print whole and half degrees)."""
    keys = [frame[c] for c in ("table", "frequency_hz") if c in frame]
    decimals = pd.to_numeric(frame["df_reported_decimals"], errors="coerce").fillna(0)
    usual = decimals.groupby(keys).transform(lambda d: d.mode().max())
    decimals = np.maximum(decimals.to_numpy(float), usual.to_numpy(float))
    lead = frame["phase_lead_deg"].to_numpy(float)
    return 10.0**-decimals, np.where(lead % 1 != 0, 0.5, 1.0)


def precision_record(data: str) -> dict:
    """The printed precision of the rows a block's fits use (``data``: its dataset name, the
    default row policy).

    Rounding a value to a step ``q`` leaves an error uniform on ``+-q/2``, of variance
    ``q**2 / 12``; on the complex DF ``D = |D| e^(j lead)`` the magnitude's and the phase's
    add, ``q_m**2 / 12 + (|D| q_lead)**2 / 12`` (lead in radians). Their mean over the rows,
    square-rooted, is the RMS complex residual that rounding alone would give a law that
    describes the core exactly: the floor of the report's ``rms_complex``.
    """
    rows = resolve_data(data, "default").rows
    q_mag, q_lead = _steps(rows)
    df = rows["df_reported"].to_numpy(float)
    var = q_mag**2 / 12 + (df * np.deg2rad(q_lead)) ** 2 / 12
    return {
        "rows": len(rows),
        "df_step": [float(q_mag.min()), float(q_mag.max())],
        "phase_step_deg": [float(q_lead.min()), float(q_lead.max())],
        "rounding_rms_complex": float(np.sqrt(np.mean(var))),
        "rounding_rms_magnitude": float(np.sqrt(np.mean(q_mag**2 / 12))),
        "rounding_rms_phase_deg": float(np.sqrt(np.mean(q_lead**2 / 12))),
        "repeats": repeated_readings(datasets.load(data)),
    }


def repeated_readings(frame: pd.DataFrame) -> list[dict]:
    """The readings a table prints more than once: the same core, source impedance, frequency
    and input (in one table, or in two whose blocks overlap), each with its printed values,
    whether they are identical (a repeated print, not a second reading), and the spread of
    the complex readings (the RMS of their deviations from their mean, with ``n - 1``; of the
    magnitudes alone where a phase is missing)."""
    keys = [c for c in ("core", "source_impedance_ohm", "frequency_hz", "input_v") if c in frame]
    out = []
    for key, g in frame.groupby(keys, dropna=False):
        if len(g) < 2:
            continue
        df = g["df_reported"].to_numpy(float)
        lead = g["phase_lead_deg"].to_numpy(float)
        values = df * np.exp(1j * np.deg2rad(lead)) if np.isfinite(lead).all() else df
        out.append(
            {
                **dict(zip(keys, key)),
                "tables": sorted(g["table"].astype(str).unique()) if "table" in g else [],
                "n": len(g),
                "df_reported": df.tolist(),
                "phase_lead_deg": lead.tolist(),
                "identical": bool(
                    np.all(df == df[0]) and np.array_equal(lead, np.full_like(lead, lead[0]), True)
                ),
                "spread": float(
                    np.sqrt(np.sum(np.abs(values - values.mean()) ** 2) / (len(g) - 1))
                ),
                "spread_of": "complex" if np.iscomplexobj(values) else "magnitude",
            }
        )
    return out


def _catalogue(blocks: dict) -> list[dict]:
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
            if c["quantity"] not in CATALOGUE_CONSTANTS:
                continue
            out.append(
                {
                    "block": key,
                    "core": rec["core"],
                    "quantity": c["quantity"],
                    "law": best["model"],
                    "value": c["fitted"],
                    "range": [c["low"], c["high"]],
                    "value_range": [c.get("fitted_low"), c.get("fitted_high")],
                    "unit": c["unit"],
                    "inside": bool(c["inside"]),
                    "inside_for_some_stacking_factor": bool(c.get("inside_range", c["inside"])),
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


def physics_record(
    results: dict,
    *,
    audit_findings: list[str],
    printed: dict,
    dynamic: dict,
    static_cv: dict,
    supermalloy: tuple,
) -> dict:
    """The section's record (JSON-ready): the printed precision of each block, the catalogue
    ranges of the joint fits' constants, the reversed column, the iron fraction and series
    resistance of the joint fits, the rate-dependent loss, Supermalloy's permeability at
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
            "precision": {key: precision_record(rec["data"]) for key, rec in blocks.items()},
            "catalogue": _catalogue(blocks),
            "reversal": reversal,
            "joint": joint,
            "rate_dependent": rate_dependent_record(blocks, dynamic, static_cv),
            "supermalloy": supermalloy_record(*supermalloy),
            "jiles_atherton": ja,
        }
    )
