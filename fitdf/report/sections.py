"""The report's sections as JSON-ready records, and its figures.

Helpers of :mod:`fitdf.report`: they turn fit results into plain dicts (what
``results.json`` holds and :mod:`fitdf.report.render` renders) and draw and save each
block's figures (run inside the report's worker processes). The report's sentences are
claims of :mod:`fitdf.report.words`.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

from fitdf._json import clean
from fitdf.data import audit, datasets
from fitdf.inference.api import resolve_data
from fitdf.inference.problem import FitProblem
from fitdf.inference.ranking import ranking_table
from fitdf.inference.selection import best_result, select
from fitdf.inference.small_signal import small_signal_scan, verdict
from fitdf.limit_cycle_tables import thesis_limit_cycle_comparison
from fitdf.models import get_model
from fitdf.plots import (
    plot_corner,
    plot_critical_loci,
    plot_cross_impedance,
    plot_fit,
    plot_residuals,
    save_thesis_graphs,
)
from fitdf.plots.limit_cycles import plot_thesis_comparison
from fitdf.plots.summary import plot_summary
from fitdf.plots.thesis_graphs import THESIS_GRAPHS

__all__ = [
    "block_record",
    "block_payload",
    "make_figures",
    "summary_figure",
    "cross_record",
    "small_signal_record",
    "audit_record",
    "limit_cycle_section",
    "limit_cycles_switched_off",
    "model_descriptions",
    "aicc_winners",
    "clean",
]


def aicc_winners(lsq: dict, models, keys) -> list[str]:
    """The best model of each block in ``keys`` by the selection rule (the lowest AICc:
    :func:`fitdf.inference.selection.best_result`); blocks not fitted are skipped."""
    out = set()
    for k in keys:
        fits = [lsq[(k, m)] for m in models if (k, m) in lsq]
        if fits:
            out.add(best_result(fits).model)
    return sorted(out)


def model_descriptions(models) -> list[dict]:
    return clean([get_model(m).describe() for m in models])


def _slug(key: str) -> str:
    return key.replace(".", "_").replace(" ", "_")


# ------------------------------------------------------------------ data and audit
def _audited(name: str) -> pd.DataFrame:
    return audit.audit(datasets.load(name))


def _data_summary(block, lsq0) -> dict:
    frame = _audited(block.data)
    used = lsq0.residuals.groupby(["source_impedance_ohm", "frequency_hz"]).size()
    per_f = []
    for (rs, f), g in frame.groupby(["source_impedance_ohm", "frequency_hz"]):
        per_f.append(
            {
                "table": ", ".join(sorted(g["table"].astype(str).unique())),
                "source_impedance_ohm": rs,
                "frequency_hz": f,
                "rows_printed": len(g),
                "rows_used": int(used.get((rs, f), 0)),
                "rows_flagged": int((g["flag"] != "ok").sum()),
                "rows_excluded": int(g["exclude_default"].sum()),
                "input_min_v": g["input_v"].min(),
                "input_max_v": g["input_v"].max(),
            }
        )
    cols = [
        "table",
        "source_impedance_ohm",
        "frequency_hz",
        "row_in_block",
        "input_v",
        "df_reported",
        "phase_lead_deg",
        "flag",
        "exclude_default",
        "reasons",
    ]
    flagged = frame[frame["flag"] != "ok"][[c for c in cols if c in frame]]
    return {
        "rows_printed": len(frame),
        "rows_used": len(lsq0.residuals),
        "per_frequency": per_f,
        "flagged_rows": flagged.to_dict(orient="records"),
        "audit_findings": audit.findings(frame),
    }


def _excluded_rows(name: str) -> pd.DataFrame:
    frame = _audited(name)
    cols = ["input_v", "frequency_hz", "source_impedance_ohm", "df_reported", "phase_lead_deg"]
    return frame[frame["exclude_default"]][cols].reset_index(drop=True)


def audit_record() -> dict:
    """Appendix B as a whole: per-table counts, DF factor per block, the audit's sentences."""
    frame = _audited("appendix_b")
    tables = []
    for t, g in frame.groupby("table"):
        tables.append(
            {
                "table": t,
                "core": g["core"].iloc[0],
                "source_impedance_ohm": g["source_impedance_ohm"].iloc[0],
                "rows": len(g),
                "flagged": int((g["flag"] != "ok").sum()),
                "excluded_by_default": int(g["exclude_default"].sum()),
            }
        )
    factors = audit.block_factors(frame)
    return clean(
        {
            "tables": tables,
            "block_factors": factors.to_dict(orient="records"),
            "findings": audit.findings(frame),
        }
    )


# ------------------------------------------------------------------ fits
_INFO_KEYS = ("seed", "n_screen", "n_starts", "best_start", "n_agree", "nfev", "success")
_DIAG_KEYS = (
    "n_steps",
    "n_walkers",
    "burn",
    "thin",
    "n_draws",
    "steps_over_tau",
    "acceptance_mean",
    "acceptance_min",
    "converged",
    "pareto_k_max",
    "n_pareto_k_bad",
    "looic",
    "looic_se",
    "waic",
    "waic_se",
    "p_loo",
    "tau",
    "rhat",
    "ess_bulk",
    "sigma_magnitude_interval",
    "sigma_phase_deg_interval",
    "max_steps",
    "extend_steps",
    "steps_needed",
    "pilot_rounds",
    # nested sampling's
    "log_evidence",
    "log_evidence_error",
    "n_effective",
    "n_likelihood_evaluations",
    "sampler",
    "prior_sensitivity",
)


def _residual_columns(r) -> dict:
    cols = [
        "table",
        "source_impedance_ohm",
        "frequency_hz",
        "input_v",
        "df_measured",
        "phase_lead_measured_deg",
        "df_predicted",
        "phase_lead_predicted_deg",
        "magnitude_residual",
        "phase_residual_deg",
        "complex_residual",
    ]
    res = r.residuals
    return {c: res[c].tolist() for c in cols if c in res}


def fit_record(r) -> dict:
    rec = {
        "model": r.model,
        "chain": r.chain,
        "method": r.method,
        "label": r.label,
        "parameters": r.parameter_table().to_dict(orient="records"),
        "metrics": dict(r.metrics),
        "warnings": list(r.warnings),
        "info": {k: r.info[k] for k in _INFO_KEYS if k in r.info},
        "rows": _residual_columns(r),
    }
    if r.material is not None:
        rec["material"] = r.material["constants"]
        if r.material.get("appendix_a_check") is not None:
            rec["appendix_a_check"] = r.material["appendix_a_check"]
    if r.method == "mcmc":
        d = r.diagnostics
        rec["diagnostics"] = {k: d[k] for k in _DIAG_KEYS if k in d}
        rec["diagnostics"]["tau_max"] = max(d["tau"].values())
        rec["diagnostics"]["rhat_max"] = max(d["rhat"].values())
        rec["diagnostics"]["ess_bulk_min"] = min(d["ess_bulk"].values())
    elif r.method == "nested":
        d = r.diagnostics
        rec["diagnostics"] = {k: d[k] for k in _DIAG_KEYS if k in d}
        if "prior" in r.info:  # the prior decides the evidence: stated in physical units
            rec["prior"] = r.info["prior"]
    return rec


def _posterior_rank(results) -> str:
    """How posteriors are ranked: by the evidence when nested sampling gave every one, else
    by PSIS-LOO."""
    return "log_evidence" if all(r.method == "nested" for r in results) else "looic"


def _ranking(results, cv=None, rank_by="aicc") -> list[dict]:
    cv_idx = {i: cv[r.model] for i, r in enumerate(results) if cv and r.model in cv}
    table = ranking_table(results, rank_by=rank_by, cv=cv_idx or None)
    return table.to_dict(orient="records")


def _where_models_fail(lsq_ranked, n=5) -> dict:
    """Rows and frequency blocks that even the best model at that spot misses most."""
    res0 = lsq_ranked[0].residuals
    stack = np.column_stack([r.residuals["complex_residual"].to_numpy(float) for r in lsq_ranked])
    best = np.nanmin(stack, axis=1)
    which = np.nanargmin(stack, axis=1)
    order = np.argsort(-best, kind="stable")[:n]
    rows = []
    for i in order:
        rows.append(
            {
                "table": res0["table"].iloc[i] if "table" in res0 else "",
                "source_impedance_ohm": res0["source_impedance_ohm"].iloc[i],
                "frequency_hz": res0["frequency_hz"].iloc[i],
                "input_v": res0["input_v"].iloc[i],
                "df_measured": res0["df_measured"].iloc[i],
                "phase_lead_measured_deg": res0["phase_lead_measured_deg"].iloc[i],
                "smallest_complex_residual": best[i],
                "closest_model": lsq_ranked[which[i]].model,
                "largest_complex_residual": float(np.nanmax(stack[i])),
            }
        )
    blocks = []
    for (rs, f), idx in res0.groupby(["source_impedance_ohm", "frequency_hz"]).groups.items():
        rms = np.sqrt(np.nanmean(stack[np.asarray(idx)] ** 2, axis=0))
        k = int(np.nanargmin(rms))
        blocks.append(
            {
                "source_impedance_ohm": rs,
                "frequency_hz": f,
                "n": len(idx),
                "best_model": lsq_ranked[k].model,
                "best_rms_complex": float(rms[k]),
                "worst_model": lsq_ranked[int(np.nanargmax(rms))].model,
                "worst_rms_complex": float(np.nanmax(rms)),
            }
        )
    blocks.sort(key=lambda b: -b["best_rms_complex"])
    return {"rows": rows, "frequency_blocks": blocks}


def block_record(
    block, lsq_ranked, posterior_by_model, cv_by_model, figures, chain_comparison=None
) -> dict:
    """Everything the report shows about one block (JSON-ready). The posteriors, by either
    sampler, are ``fits_posterior`` (each with its ``method``) and ranked in
    ``ranking_posterior``."""
    posteriors = [posterior_by_model[r.model] for r in lsq_ranked if r.model in posterior_by_model]
    d = lsq_ranked[0].problem.data
    rec = {
        "key": block.key,
        "title": block.title,
        "core": block.core,
        "data": block.data,
        "tables": d.groups,
        "source_impedance_ohm": sorted(set(d.source_impedance.tolist())),
        "data_summary": _data_summary(block, lsq_ranked[0]),
        "ranking_lsq": _ranking(lsq_ranked, cv_by_model),
        "ranking_posterior": _ranking(posteriors, rank_by=_posterior_rank(posteriors))
        if posteriors
        else [],
        "fits_lsq": {r.model: fit_record(r) for r in lsq_ranked},
        "fits_posterior": {r.model: fit_record(r) for r in posteriors},
        "cv": {m: {k: v for k, v in c.items()} for m, c in cv_by_model.items()},
        "where_models_fail": _where_models_fail(lsq_ranked),
        "figures": figures,
        "chain_comparison": chain_comparison,
    }
    rec["order_lsq"] = [row["model"] for row in rec["ranking_lsq"]]
    rec["order_posterior"] = [row["model"] for row in rec["ranking_posterior"]]
    # the best law, its ties, and what cross-validation, the evidence and LOO pick
    rec["selection"] = select(rec["ranking_lsq"] + rec["ranking_posterior"]).to_dict()
    return clean(rec)


#: Material constants shown side by side for the two chains.
_COMPARED_CONSTANTS = (
    "initial_permeability",
    "coercive_force_oe",
    "peak_flux_density_gauss",
    "squareness",
    "series_resistance_ohm",
)


def _constants(result) -> dict:
    if result is None or result.material is None:
        return {}
    c = result.material["constants"]
    return {k: c.get(k) for k in _COMPARED_CONSTANTS}


def _prediction_gap(result, chain) -> dict:
    """The exact fit's parameters seen through ``chain``: how far that chain's DF is from it."""
    p = result.problem
    other = FitProblem(p.data, p.model, chain, p.noise, p.fixed, p.geometry)
    exact, approx = p.predict(result.internal), other.predict(result.internal)
    gap = np.abs(approx - exact)
    phase = np.abs(np.angle(approx / np.where(exact == 0, 1.0, exact), deg=True))
    return {
        "prediction_gap_rms": float(np.sqrt(np.mean(gap**2))),
        "prediction_gap_max": float(np.max(gap)),
        "phase_gap_max_deg": float(np.nanmax(np.where(exact == 0, np.nan, phase)))
        if np.any(exact != 0)
        else float("nan"),
    }


def chain_comparison(exact_ranked, approx_results, top=3) -> dict | None:
    """The exact chain against an approximate one on one block (JSON-ready), or None.

    ``order_*`` are the two rankings (by AICc); for the ``top`` models of the
    exact ranking, ``best`` gives both residuals, how far the approximate chain's DF is
    from the exact one at the exact fit's parameters (the approximation's own error), and
    the fitted material constants on each chain.
    """
    if not approx_results:
        return None
    by_model = {r.model: r for r in approx_results}
    approx_table = ranking_table(list(approx_results))
    rows = []
    for r in exact_ranked[:top]:
        a = by_model.get(r.model)
        rows.append(
            {
                "model": r.model,
                "rms_exact": r.metrics["rms_complex"],
                "rms_approximate": None if a is None else a.metrics["rms_complex"],
                **_prediction_gap(r, approx_results[0].chain),
                "constants_exact": _constants(r),
                "constants_approximate": _constants(a),
            }
        )
    return clean(
        {
            "exact_chain": exact_ranked[0].chain,
            "approximate_chain": approx_results[0].chain,
            "order_exact": [r.model for r in exact_ranked],
            "order_approximate": list(approx_table["model"]),
            "rms_approximate": dict(zip(approx_table["model"], approx_table["rms_complex"])),
            "best": rows,
        }
    )


#: Blocks of the small-signal hypothesis test: the 600 ohm tables, where the reading
#: depends on the core's complex inductance (at 0 ohm it is nearly the gain).
SMALL_SIGNAL_BLOCKS = ("B.3", "B.5", "B.4")


def small_signal_record(lsq: dict) -> list[dict]:
    """The DC-bias hypothesis on each 600 ohm block's Preisach fit (JSON-ready; empty
    when the report has no Preisach fit of such a block): rows and verdict of
    :func:`fitdf.inference.small_signal.small_signal_scan`."""
    out = []
    for key in SMALL_SIGNAL_BLOCKS:
        r = lsq.get((key, "preisach"))
        if r is None:
            continue
        scan = small_signal_scan(r)
        rows = scan.drop(columns=["measured", "fitted", "sinusoidal_unbiased"]).assign(
            measured_magnitude=np.abs(scan["measured"]),
            measured_lead_deg=np.angle(scan["measured"], deg=True),
            fitted_magnitude=np.abs(scan["fitted"]),
            fitted_lead_deg=np.angle(scan["fitted"], deg=True),
        )
        out.append(
            {
                "block": key,
                "model": "preisach",
                "rms_complex": r.metrics["rms_complex"],
                "verdict": verdict(scan),
                "rows": rows.to_dict(orient="records"),
            }
        )
    return clean(out)


def cross_record(directions, cross: dict, figures: dict) -> list[dict]:
    out = []
    for core, train, test, train_key, test_key in directions:
        rows = [
            row
            for (c, tr, te, _), recs in cross.items()
            if (c, tr, te) == (core, train, test)
            for row in recs
        ]
        rows.sort(key=lambda r: (r["predict_rms_complex"], r["model"]))
        out.append(
            {
                "core": core,
                "train_ohm": train,
                "test_ohm": test,
                "train_block": train_key,
                "test_block": test_key,
                "rows": rows,
                "figure": figures.get(("cross", core, train, test)),
            }
        )
    return clean(out)


# ------------------------------------------------------------------ figures (run in workers)
def block_payload(block, lsq_ranked, posteriors, settings) -> dict:
    return {
        "block": block,
        "lsq": lsq_ranked,
        "posteriors": posteriors,
        "plot_top": settings.plot_top,
        "excluded": _excluded_rows(block.data),
    }


def _save(fig, figdir: Path, name: str, palette: bool = True) -> str:
    """Write ``fig`` as a 256-colour palette PNG (a third of the size; line plots lose nothing
    visible), or as full RGB when ``palette`` is False (colour gradients, which a palette bands)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    buf.seek(0)
    with Image.open(buf) as img:
        rgb = img.convert("RGB")
        out = rgb.quantize(256, method=Image.Quantize.FASTOCTREE) if palette else rgb
        out.save(figdir / name, optimize=True)
    return f"figures/{name}"


def make_figures(kind: str, payload, figdir: Path):
    """Draw and save one group of figures; returns relative paths."""
    if kind == "thesis":
        paths = save_thesis_graphs(figdir / "thesis")
        return [
            {
                "graph": n,
                "path": f"figures/thesis/{p.name}",
                "title": _thesis_title(THESIS_GRAPHS[n]),
            }
            for n, p in zip(THESIS_GRAPHS, paths)
        ]
    if kind == "cross":
        core, train, test, train_key, test_key = payload["direction"]
        fig = plot_cross_impedance(
            payload["train"], resolve_data(test_key), calibration_gains=payload["gains"]
        )
        return _save(fig, figdir, f"cross_{core}_{train:g}_to_{test:g}.png")
    b, lsq, post = payload["block"], payload["lsq"], payload["posteriors"]
    slug = _slug(b.key)
    # only a converged posterior is drawn as a result (its band and its corner plot)
    best_post = (
        post[0]
        if post and post[0].model == lsq[0].model and post[0].diagnostics.get("converged")
        else None
    )
    out = {
        "fit": _save(
            plot_fit(lsq, band=best_post or False, excluded=payload["excluded"]),
            figdir,
            f"{slug}_fit.png",
        ),
        "loci": _save(plot_critical_loci(lsq, top=2), figdir, f"{slug}_loci.png"),
        "residuals": _save(
            plot_residuals(lsq, top=payload["plot_top"]), figdir, f"{slug}_residuals.png"
        ),
    }
    if best_post is not None:
        out["corner"] = _save(plot_corner(best_post, truths=lsq[0]), figdir, f"{slug}_corner.png")
    return out


def summary_figure(results: dict, figdir: Path) -> str | None:
    """The report's opening figure (:func:`fitdf.plots.summary.plot_summary`) from the collected
    results; its relative path, or None (with a warning) when it cannot be drawn -- the rest
    of the report stands."""
    try:
        return _save(plot_summary(results), Path(figdir), "summary.png", palette=False)
    except Exception as exc:
        warnings.warn(f"summary figure not drawn: {type(exc).__name__}: {exc}", stacklevel=2)
        return None


def _thesis_title(fn) -> str:
    doc = (fn.__doc__ or "").strip().splitlines()
    return doc[0] if doc else fn.__name__


# ------------------------------------------------------------------ limit cycles
def limit_cycles_switched_off() -> dict:
    return {
        "available": False,
        "reason": "The limit-cycle comparison was switched off in these settings.",
    }


def limit_cycle_section(seed, models, n_starts, candidates, figdir) -> dict:
    """Tables 5.1/5.2 against the limit cycles predicted from the fits (:mod:`fitdf.limit_cycle_tables`):
    unscaled and with held-out scales, by harmonic balance and simulated in time.

    ``models`` are the lowest-AICc models of the blocks B.1, B.3, B.2, B.5; the
    comparison picks the lowest-AICc of them per block, which is the same choice as
    among all models, at a fraction of the cost. ``candidates`` (table name -> the
    report's least-squares fits of those models) are used instead of fitting again.
    The record's ``attrs`` hold the comparison's summaries and its sentences
    (``statements``).
    """
    try:
        df = thesis_limit_cycle_comparison(
            seed=seed, models=models, n_starts=n_starts, candidates=candidates, time_domain=True
        )
    except Exception as exc:  # the section reports the failure; the rest of the report stands
        return {
            "available": True,
            "error": f"{type(exc).__name__}: {exc}",
            "models_offered": models,
        }
    rec = {
        "available": True,
        "models_offered": models,
        "rows": clean(df.to_dict(orient="records")),
        "columns": list(df.columns),
        "attrs": clean(dict(df.attrs)),
        "figure": None,
    }
    try:
        rec["figure"] = _save(plot_thesis_comparison(df), Path(figdir), "limit_cycles.png")
    except Exception as exc:  # a figure that fails leaves its numbers in the report
        rec["figure_error"] = f"{type(exc).__name__}: {exc}"
    return rec
