"""The report's "Findings": short sentences generated from the numbers of ``results.json``.

:func:`findings` reads the records that :mod:`fitdf.report.sections` built (blocks,
cross-impedance, audit, limit cycles) and states winners, margins, verdicts and
failures; nothing in it is typed by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["findings"]


def _pct(a, b):
    return 100.0 * (b - a) / b if b else float("nan")


def _block_finding(rec) -> str | None:
    """One sentence group per block: winner and margin, AICc and LOO verdicts, the hardest spot."""
    rank = rec["ranking_lsq"]
    if not rank:
        return None
    best = rank[0]
    text = f"**{rec['title']}**: `{best['model']}` fits best (RMS complex residual {best['rms_complex']:.4f}"
    if len(rank) > 1:
        second = rank[1]
        d_aicc = (second["aicc"] or 0.0) - (best["aicc"] or 0.0)
        text += (
            f", {_pct(best['rms_complex'], second['rms_complex']):.0f}% below the runner-up "
            f"`{second['model']}` at {second['rms_complex']:.4f}; "
            + (
                f"AICc lower by {d_aicc:.1f}"
                if d_aicc >= 0
                else f"but AICc higher by {-d_aicc:.1f}"
            )
        )
    text += ")."
    aicc_best = min(rank, key=lambda r: r["aicc"] if r["aicc"] is not None else math.inf)
    if aicc_best["model"] != best["model"]:
        text += f" AICc, which charges for parameters, prefers `{aicc_best['model']}`."
    if best.get("indistinguishable_from"):
        text += f" It cannot be told apart (AICc within 2) from {best['indistinguishable_from']}."
    if rec["ranking_mcmc"]:
        m = rec["ranking_mcmc"][0]["model"]
        text += (
            " MCMC (LOO-IC) agrees."
            if m == best["model"]
            else f" MCMC's LOO-IC prefers `{m}` of the {len(rec['ranking_mcmc'])} models sampled."
        )
    fail = rec["where_models_fail"]
    if fail["frequency_blocks"] and fail["rows"]:
        fb, w = fail["frequency_blocks"][0], fail["rows"][0]
        text += (
            f" Hardest: {fb['frequency_hz']:g} c/s at {fb['source_impedance_ohm']:g} ohm (best model there "
            f"`{fb['best_model']}`, RMS {fb['best_rms_complex']:.3f}); every model misses {w['table']} "
            f"{w['frequency_hz']:g} c/s, {w['input_v']:g} V (|DF| {w['df_measured']:.3g}, lead "
            f"{w['phase_lead_measured_deg']:.3g} deg) by at least {w['smallest_complex_residual']:.3f}."
        )
    return text


def _failure_pattern(blocks) -> str | None:
    """Where all models fail, across the single-table blocks: amplitude and lead of the worst rows."""
    worst, every, per_table = [], [], 0
    for rec in blocks.values():
        if len(rec["tables"]) != 1:
            continue
        worst += rec["where_models_fail"]["rows"]
        per_table = max(per_table, len(rec["where_models_fail"]["rows"]))
        rows = next(iter(rec["fits_lsq"].values()))["rows"]
        every += [
            {"input_v": a, "lead": p}
            for a, p in zip(rows["input_v"], rows["phase_lead_measured_deg"])
        ]
    if not worst:
        return None
    wa = float(np.median([w["input_v"] for w in worst]))
    aa = float(np.median([e["input_v"] for e in every]))
    wl = float(
        np.nanmedian(
            [
                np.nan if w["phase_lead_measured_deg"] is None else w["phase_lead_measured_deg"]
                for w in worst
            ]
        )
    )
    al = float(np.nanmedian([np.nan if e["lead"] is None else e["lead"] for e in every]))
    text = (
        f"Where all models fail: the {len(worst)} rows that every model misses most ({per_table}"
        f" per table) have a median input of {wa:.3g} V (all rows: {aa:.3g} V) and a median phase lead of "
        f"{wl:.3g} deg (all rows: {al:.3g} deg)"
    )
    if wa < 0.5 * aa:
        text += " -- they sit at the small-signal end of the tables"
        text += ", where the measured lead is large" if wl > 1.5 * al else ""
    return text + "."


def _mcmc_finding(blocks) -> str | None:
    diags = [f["diagnostics"] for rec in blocks.values() for f in rec["fits_mcmc"].values()]
    if not diags:
        return None
    n_conv = sum(bool(d.get("converged")) for d in diags)
    ratio = [d["steps_over_tau"] for d in diags]
    rhat = [d["rhat_max"] for d in diags]
    text = (
        f"MCMC: {n_conv} of {len(diags)} chains meet the convergence rule (50 autocorrelation times, "
        f"R-hat < 1.01, bulk ESS >= 400); steps/tau {min(ratio):.0f}-{max(ratio):.0f}, max R-hat "
        f"{min(rhat):.3f}-{max(rhat):.3f}"
    )
    bad = sorted(
        {
            f"{m} on {k}"
            for k, rec in blocks.items()
            for m, f in rec["fits_mcmc"].items()
            if not f["diagnostics"].get("converged")
        }
    )
    n_given_up = sum(bool(d.get("steps_needed")) for d in diags)
    given_up = (
        f" ({n_given_up} stopped early: at their autocorrelation times they need more steps "
        "than the limit)"
        if n_given_up
        else ""
    )
    return text + (
        f". Not converged within the report's step limit: {', '.join(bad)}{given_up}; read their "
        "posterior bands, corner plots and LOO-ICs as rough."
        if bad
        else "."
    )


def findings(results: dict) -> list[str]:
    """Short statements generated from the numbers (the report's "Findings")."""
    out = []
    blocks = results["blocks"]
    wins = {}
    for rec in blocks.values():
        if rec["order_lsq"]:
            wins.setdefault(rec["order_lsq"][0], []).append(rec["key"])
    if wins:
        out.append(
            "Best model per block (least squares, RMS complex residual): "
            + "; ".join(f"`{m}` on {', '.join(keys)}" for m, keys in wins.items())
            + "."
        )
    out += [t for t in (_block_finding(rec) for rec in blocks.values()) if t]
    out += [t for t in (_failure_pattern(blocks), _mcmc_finding(blocks)) if t]
    for d in results.get("cross_impedance", []):
        if d["rows"]:
            r = d["rows"][0]
            own = blocks.get(d["test_block"], {}).get("ranking_lsq")
            own_text = (
                f"; a fit to {d['test_block']} itself reaches {own[0]['rms_complex']:.3f}"
                if own
                else ""
            )
            out.append(
                f"Cross-impedance, {d['core']}: fitted at {d['train_ohm']:g} ohm ({d['train_block']}), "
                f"`{r['model']}` predicts the {d['test_ohm']:g} ohm data ({d['test_block']}) best with RMS "
                f"complex residual {r['predict_rms_complex']:.3f} (training residual "
                f"{r['train_rms_complex']:.3f}{own_text})."
            )
    for rec in results.get("small_signal", []):
        out.append(f"Small signals, {rec['block']} (`{rec['model']}`): {rec['verdict']}.")
    for core, keys in (("permalloy", ("B.1", "B.3")), ("deltamax", ("B.2", "B.5"))):
        joint = blocks.get(f"{core}-joint")
        sep = [blocks[k] for k in keys if k in blocks]
        if joint and joint["ranking_lsq"] and sep:
            j = joint["ranking_lsq"][0]
            parts = ", ".join(f"{s['key']} {s['ranking_lsq'][0]['rms_complex']:.3f}" for s in sep)
            out.append(
                f"One parameter set for both impedances ({joint['key']}): best `{j['model']}` with RMS "
                f"{j['rms_complex']:.3f}, against the separate fits' best ({parts})."
            )
    audit = results.get("audit", {})
    if audit.get("tables"):
        n_flag = sum(t["flagged"] for t in audit["tables"])
        n_excl = sum(t["excluded_by_default"] for t in audit["tables"])
        n_rows = sum(t["rows"] for t in audit["tables"])
        out.append(
            f"The audit of the printed tables flags {n_flag} of {n_rows} rows and excludes {n_excl} by default "
            "(see the audit section for every row and reason)."
        )
        out += [
            f
            for f in audit.get("findings", [])
            if "footnote factor" in f and "followed by all" not in f
        ]
    lc = results.get("limit_cycles", {})
    if lc.get("rows"):
        df = pd.DataFrame(lc["rows"])
        if {"amplitude_ratio", "omega_ratio"} <= set(df) and df["amplitude_ratio"].notna().any():
            out.append(
                f"Limit cycles (Tables 5.1, 5.2): predicted over measured amplitude has median "
                f"{df['amplitude_ratio'].median():.2f} (range {df['amplitude_ratio'].min():.2f}-"
                f"{df['amplitude_ratio'].max():.2f}) and predicted over measured frequency median "
                f"{df['omega_ratio'].median():.2f} over {int(df['amplitude_ratio'].notna().sum())} rows."
            )
    return out
