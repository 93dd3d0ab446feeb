"""The report's "Findings": the detailed statements after the conclusion, each a claim of
:mod:`fitdf.report.claims` made from named fields of ``results.json``.

Per block: the best law (:func:`fitdf.report.criteria.best_law`, the lowest AICc) with its
margin and residual; what the posteriors' criteria (the evidence, LOO-IC) say, each by its
own numbers; why the runner-up has no posterior where its AICc gap was too wide to sample it
(:func:`fitdf.report.settings.posterior_laws`); where the criteria disagree; the hardest rows. Then where all laws fail, the
posteriors' convergence, the cross-impedance predictions, the small-signal test, the joint
fits and the physics section's sentences (:mod:`fitdf.report.physics_claims`).
:func:`findings` lists the statements as paragraphs of claims, or as plain sentences for the
few still written without one (the audit's, the limit cycles', Supermalloy's).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.inference.convergence import (
    MAX_LOG_EVIDENCE_ERROR,
    MIN_EFFECTIVE,
    MIN_ESS,
    MIN_STEPS_OVER_TAU,
    RHAT_MAX,
)
from fitdf.inference.evidence import MISSED_BY_ERRORS
from fitdf.inference.small_signal import verdict
from fitdf.report.audit_claims import audit_findings
from fitdf.report.claims import paragraph, rule, say, span
from fitdf.report.conclusion import LSQ, error_percent
from fitdf.report.criteria import AICC_TIE, LOO_TIE_SE, best_by, best_law, known
from fitdf.report.settings import EVIDENCE_SHORTFALL

__all__ = ["findings", "block_claims"]

_BLOCK = {
    "models": "blocks/{block}/ranking_lsq/*/model",
    "aicc": "blocks/{block}/ranking_lsq/*/aicc",
}
_BLOCK_POST = {
    "post_models": "blocks/{block}/ranking_posterior/*/model",
    "log_evidence": "blocks/{block}/ranking_posterior/*/log_evidence",
    "looic": "blocks/{block}/ranking_posterior/*/looic",
}


def _at(models, values, model):
    return values[models.index(model)]


# ------------------------------------------------------------------ per block
@rule(
    "block.best",
    title="blocks/{block}/title",
    rms="blocks/{block}/ranking_lsq/*/rms_complex",
    n_params="blocks/{block}/ranking_lsq/*/n_params",
    df="blocks/{block}/fits_lsq/*/rows/df_measured",
    **_BLOCK,
)
def _best(title, rms, n_params, df, models, aicc, block):
    best = best_law(models or [], aicc or [])
    if best is None:
        return None
    values = {
        "title": title,
        "best": best,
        "k": _at(models, n_params, best),
        "rms": _at(models, rms, best),
        "pct": error_percent(_at(models, rms, best), df[best]),
    }
    template = (
        "**{title}**: the best law by AICc is {best:law} ({k} parameters; RMS complex residual "
        "{rms:.4f}, {pct:.1f} % of the DF)"
    )
    others = [i for i in known(aicc) if models[i] != best]
    if others:
        second = min(others, key=lambda i: aicc[i])
        values.update(
            second=models[second],
            d_aicc=aicc[second] - _at(models, aicc, best),
            rms2=rms[second],
            tie=AICC_TIE,
        )
        template += "; the runner-up {second:law} has an AICc higher by {d_aicc:.1f}" + (
            " (within {tie:g}: a tie)" if values["d_aicc"] < AICC_TIE else ""
        )
        template += " and RMS {rms2:.4f}"
    template += "."
    low = best_by(models, rms)
    if low is not None and low != best:
        values.update(low=low, rms_low=_at(models, rms, low), k_low=_at(models, n_params, low))
        template += " The smallest RMS complex residual is {low:law}'s ({rms_low:.4f}, {k_low} "
        template += (
            "parameters): AICc charges it for its parameters."
            if values["k_low"] > values["k"]
            else "parameters): AICc weighs magnitude and phase by the tables' precision, not "
            "the complex residual."
        )
    return say(template, **values)


_LOO_NUMBERS = {
    "elpd_diff": "blocks/{block}/ranking_posterior/*/elpd_loo_diff",
    "elpd_dse": "blocks/{block}/ranking_posterior/*/elpd_loo_dse",
}


@rule("block.posteriors", **_BLOCK, **_BLOCK_POST, **_LOO_NUMBERS)
def _posteriors(models, aicc, post_models, log_evidence, looic, elpd_diff, elpd_dse, block):
    """What the evidence and LOO-IC say of the best law, each by its own numbers."""
    best = best_law(models or [], aicc or [])
    if best is None or not post_models:
        return None
    values = {"best": best, "n": len(post_models), "loo_se": LOO_TIE_SE}
    sentences = []
    ev = best_by(post_models, log_evidence, larger=True)
    if ev is not None:
        if ev == best:
            sentences.append(
                "The evidence agrees ({n} law sampled)."
                if len(post_models) == 1
                else "The evidence agrees ({n} laws sampled)."
            )
        else:
            values["ev"] = ev
            if best in post_models and known([_at(post_models, log_evidence, best)]):
                values["ln_b"] = _at(post_models, log_evidence, ev) - _at(
                    post_models, log_evidence, best
                )
                sentences.append(
                    "Of the {n} laws sampled, the evidence prefers {ev:law} (ln B {ln_b:.1f} "
                    "over {best:law})."
                )
            else:
                sentences.append(
                    "Of the {n} laws sampled, which do not include {best:law}, the evidence "
                    "prefers {ev:law}."
                )
    loo = best_by(post_models, looic)
    if loo is not None:
        if loo == best:
            sentences.append("LOO-IC agrees.")
        elif best in post_models and known([_at(post_models, elpd_diff, best)]):
            values.update(
                loo=loo,
                loo_diff=_at(post_models, elpd_diff, best),
                loo_dse=_at(post_models, elpd_dse, best) or 0.0,
            )
            tie = abs(values["loo_diff"]) < LOO_TIE_SE * values["loo_dse"]
            sentences.append(
                "LOO-IC prefers {loo:law} (elpd ahead by {loo_diff:.1f} +- {loo_dse:.1f}"
                + (", less than {loo_se:g} standard errors: a tie)." if tie else ").")
            )
        else:
            values["loo"] = loo
            sentences.append("LOO-IC prefers {loo:law}, among the laws sampled.")
    return say(" ".join(sentences), **values) if sentences else None


@rule(
    "block.runner_up",
    below="settings/posterior_runner_up_below",
    top="settings/posterior_top",
    skip="settings/posterior_skip",
    **_BLOCK,
    **_BLOCK_POST,
)
def _runner_up(below, top, skip, models, aicc, post_models, log_evidence, looic, block):
    """Why a block's runner-up has no posterior: its AICc gap is at or above the settings'
    threshold (:data:`~fitdf.report.settings.RUNNER_UP_AICC_GAP`), and a reversal by the
    evidence would need a shortfall of half that gap, against the most measured
    (:data:`~fitdf.report.settings.EVIDENCE_SHORTFALL`)."""
    if below is None or not post_models or (top is not None and top < 2):
        return None
    ranked = sorted(
        (i for i in known(aicc or []) if models[i] not in (skip or [])), key=lambda i: aicc[i]
    )
    if len(ranked) < 2 or models[ranked[0]] not in post_models:
        return None
    best, second = ranked[0], ranked[1]
    gap = aicc[second] - aicc[best]
    if models[second] in post_models or gap < below:
        return None
    return say(
        "The runner-up {second:law} has no posterior: its AICc is {d_aicc:.1f} above "
        "{best:law}'s, not below {below:g} (the gap under which a runner-up is sampled too); "
        "to reverse that order the evidence's log Bayes factor would have to fall {need:.1f} "
        "short of half the AICc gap, {times:.1f} times the most it fell short between any two "
        "laws the committed `fitdf report --full` sampled ({shortfall:.2f}).",
        second=models[second],
        best=models[best],
        d_aicc=gap,
        below=below,
        need=gap / 2,
        times=gap / 2 / EVIDENCE_SHORTFALL,
        shortfall=EVIDENCE_SHORTFALL,
    )


@rule(
    "block.disagreement",
    cv="blocks/{block}/ranking_lsq/*/cv_rms_complex",
    **_BLOCK,
    **_BLOCK_POST,
)
def _disagreement(cv, models, aicc, post_models, log_evidence, looic, block):
    """Where the criteria rank the sampled laws differently, in one sentence."""
    if not post_models:
        return None
    sampled = [m for m in post_models if m in (models or [])]
    own = [models.index(m) for m in sampled]
    picks = {}
    for name, ms, vs, larger in (
        ("AICc", sampled, [aicc[i] for i in own], False),
        ("cross-validation", sampled, [cv[i] for i in own], False),
        ("LOO-IC", post_models, looic, False),
        ("the evidence", post_models, log_evidence, True),
    ):
        if len(known(vs)) >= 2:
            picks[name] = best_by(ms, vs, larger)
    if len(set(picks.values())) < 2:
        return None
    values = {"n": len(post_models)}
    parts = []
    for i, (name, m) in enumerate(picks.items()):
        parts.append(f"{name} prefers {{pick_{i}:law}}")
        values[f"pick_{i}"] = m
    return say("The criteria disagree on the {n} laws sampled: " + "; ".join(parts) + ".", **values)


@rule(
    "block.hardest",
    where="blocks/{block}/where_models_fail/frequency_blocks/0",
    row="blocks/{block}/where_models_fail/rows/0",
)
def _hardest(where, row, block):
    if not where or not row:
        return None
    lead = row.get("phase_lead_measured_deg")
    return say(
        "Hardest: {f:g} c/s at {ohm:g} ohm (the smallest RMS there {law:law}'s, {rms:.3f}); "
        "every law misses {table} {row_f:g} c/s, {v:g} V (|DF| {df:.3g}"
        + (", lead {lead:.3g} deg" if lead is not None else "")
        + ") by at least {miss:.3f}.",
        f=where["frequency_hz"],
        ohm=where["source_impedance_ohm"],
        law=where["best_model"],
        rms=where["best_rms_complex"],
        table=row["table"],
        row_f=row["frequency_hz"],
        v=row["input_v"],
        df=row["df_measured"],
        lead=lead,
        miss=row["smallest_complex_residual"],
    )


def block_claims(results: dict, key: str) -> list[dict]:
    """One block's statement: best law and margin, the posteriors (and why the runner-up has
    none, where its AICc gap left it unsampled), disagreement, hardest rows."""
    return paragraph(
        results,
        *(
            (f"block.{kind}", {"block": key})
            for kind in ("best", "posteriors", "runner_up", "disagreement", "hardest")
        ),
    )


# ------------------------------------------------------------------ across blocks
@rule(
    "findings.failures",
    tables="blocks/*/tables",
    worst="blocks/*/where_models_fail/rows",
    inputs="blocks/*/fits_lsq/*/rows/input_v",
    leads="blocks/*/fits_lsq/*/rows/phase_lead_measured_deg",
)
def _failures(tables, worst, inputs, leads):
    """Where all laws fail, across the single-table blocks: amplitude and lead of the worst rows."""
    rows, every_v, every_lead, per_table = [], [], [], 0
    for k, t in tables.items():
        if len(t or []) != 1 or not inputs.get(k):
            continue
        rows += worst[k] or []
        per_table = max(per_table, len(worst[k] or []))
        first = next(iter(inputs[k]))
        every_v += inputs[k][first]
        every_lead += leads[k][first]
    if not rows:
        return None

    def median(xs):
        return float(np.nanmedian([np.nan if x is None else x for x in xs]))

    values = {
        "n": len(rows),
        "per_table": per_table,
        "worst_v": median([w["input_v"] for w in rows]),
        "all_v": median(every_v),
        "worst_lead": median([w["phase_lead_measured_deg"] for w in rows]),
        "all_lead": median(every_lead),
    }
    template = (
        "Where all laws fail: the {n} rows that every law misses most ({per_table} per table) "
        "have a median input of {worst_v:.3g} V (all rows: {all_v:.3g} V) and a median phase "
        "lead of {worst_lead:.3g} deg (all rows: {all_lead:.3g} deg)"
    )
    if values["worst_v"] < 0.5 * values["all_v"]:
        template += " -- they sit at the small-signal end of the tables"
        if values["worst_lead"] > 1.5 * values["all_lead"]:
            template += ", where the measured lead is large"
    return say(template + ".", **values)


_DIAGNOSTICS = "blocks/*/fits_posterior/*/diagnostics/"


@rule(
    "findings.posteriors",
    method="blocks/*/fits_posterior/*/method",
    converged=_DIAGNOSTICS + "converged",
    evaluations=_DIAGNOSTICS + "n_likelihood_evaluations",
    evidence_error=_DIAGNOSTICS + "log_evidence_error",
    steps_over_tau=_DIAGNOSTICS + "steps_over_tau",
    rhat_max=_DIAGNOSTICS + "rhat_max",
    steps_needed=_DIAGNOSTICS + "steps_needed",
    box_factor=_DIAGNOSTICS + "prior_sensitivity/boxes/*/factor",
    box_consistent=_DIAGNOSTICS + "prior_sensitivity/boxes/*/consistent",
)
def _posterior_statement(
    method,
    converged,
    evaluations,
    evidence_error,
    steps_over_tau,
    rhat_max,
    steps_needed,
    box_factor,
    box_consistent,
):
    """The posteriors' convergence statistics, and the widened prior boxes that missed."""
    fits = [(k, m) for k, laws in method.items() for m in (laws or {})]

    def of(field, kind):
        return [field[k][m] for k, m in fits if (method[k][m] or "mcmc") == kind]

    if of(converged, "nested"):
        wide = [
            consistent
            for k, m in fits
            for f, consistent in zip(box_factor[k][m] or [], box_consistent[k][m] or [])
            if f is not None and f > 1
        ]
        return _nested_statement(
            of(converged, "nested"), of(evaluations, "nested"), of(evidence_error, "nested"), wide
        )
    if not of(converged, "mcmc"):
        return None
    return _mcmc_statement(
        of(converged, "mcmc"),
        of(steps_over_tau, "mcmc"),
        of(rhat_max, "mcmc"),
        of(steps_needed, "mcmc"),
    )


def _nested_statement(nested, evaluations, evidence_error, wide):
    """:func:`_posterior_statement` of nested sampling: each posterior's ``converged``,
    likelihood evaluations and evidence error, and each widened box's ``consistent``."""
    values = {
        "n_conv": sum(bool(c) for c in nested),
        "n": len(nested),
        "eff": MIN_EFFECTIVE,
        "max_err": MAX_LOG_EVIDENCE_ERROR,
        "ev_low": min(evaluations),
        "ev_high": max(evaluations),
        "err_low": min(evidence_error),
        "err_high": max(evidence_error),
    }
    template = (
        "Nested sampling: {n_conv} of {n} posteriors meet the convergence rule ({eff} "
        "effective draws, evidence error <= {max_err:g}), in "
        + span(values["ev_low"], values["ev_high"], ",.0f", "ev_low", "ev_high")
        + " likelihood evaluations; evidence errors "
        + span(values["err_low"], values["err_high"], ".2f", "err_low", "err_high")
        + "."
    )
    if wide:
        values.update(
            n_strat=sum(c is not None for c in wide),
            n_missed=sum(c is False for c in wide),
            n_old=sum(c is None for c in wide),
            by=MISSED_BY_ERRORS,
        )
        template += _widened_template(values)
    return say(template, **values)


def _widened_template(values) -> str:
    """The sentences on the widened prior boxes (``n_strat``, ``n_missed``, ``n_old``)."""
    template = ""
    if values["n_missed"]:
        template += (
            " With the prior box widened, {n_missed} of {n_strat} runs missed the "
            "posterior the prior's box holds (their own evidence more than {by:g} errors "
            "below the exact part inside it): not converged, their evidence the "
            "stratified estimate, a lower bound."
        )
    elif values["n_strat"] == 1:
        template += (
            " With the prior box widened, the one run did not miss the posterior the "
            "prior's box holds."
        )
    elif values["n_strat"]:
        template += (
            " With the prior box widened, none of the {n_strat} runs missed the "
            "posterior the prior's box holds."
        )
    if values["n_old"]:
        template += (
            " {n_old} of the widened boxes hold no stratified estimate (a record "
            "from before it): their evidence is not a result."
        )
    return template


def _mcmc_statement(chains, ratio, rhat, steps_needed):
    """:func:`_posterior_statement` of MCMC: each chain's ``converged``, steps over tau,
    max R-hat and ``steps_needed``."""
    values = {
        "n_conv": sum(bool(c) for c in chains),
        "n": len(chains),
        "taus": MIN_STEPS_OVER_TAU,
        "rhat": RHAT_MAX,
        "ess": MIN_ESS,
        "ratio_low": min(ratio),
        "ratio_high": max(ratio),
        "rhat_low": min(rhat),
        "rhat_high": max(rhat),
        "n_early": sum(bool(s) for s in steps_needed),
    }
    return say(
        "MCMC: {n_conv} of {n} chains meet the convergence rule ({taus} autocorrelation times, "
        "R-hat < {rhat:g}, bulk ESS >= {ess}); steps/tau {ratio_low:.0f}-{ratio_high:.0f}, max "
        "R-hat {rhat_low:.3f}-{rhat_high:.3f}"
        + (
            "; {n_early} stopped early: at their autocorrelation times they need more steps "
            "than the limit"
            if values["n_early"]
            else ""
        )
        + ".",
        **values,
    )


@rule(
    "findings.cross",
    direction="cross_impedance/{index}",
    own_rms="blocks/*/ranking_lsq/*/rms_complex",
    **LSQ,
)
def _cross(direction, own_rms, models, aicc, index):
    if not direction or not direction.get("rows"):
        return None
    r = direction["rows"][0]
    test = direction["test_block"]
    values = {
        "core": direction["core"],
        "train": direction["train_ohm"],
        "train_block": direction["train_block"],
        "law": r["model"],
        "test": direction["test_ohm"],
        "test_block": test,
        "rms": r["predict_rms_complex"],
        "train_rms": r["train_rms_complex"],
    }
    template = (
        "Cross-impedance, {core}: fitted at {train:g} ohm ({train_block}), {law:law} predicts "
        "the {test:g} ohm data ({test_block}) best with RMS complex residual {rms:.3f} averaged "
        "over the series resistance's prior"
    )
    low, high = r.get("predict_rms_complex_min"), r.get("predict_rms_complex_max")
    if low is not None and high is not None and low != high:
        template += " ({low:.3f}-{high:.3f} across it)"
        values.update(low=low, high=high)
    template += " (training residual {train_rms:.3f}"
    own = best_law(models.get(test) or [], aicc.get(test) or [])
    if own is not None:
        values.update(own=own, own_rms=_at(models[test], own_rms[test], own))
        template += "; the best law fitted to {test_block} itself, {own:law}, reaches {own_rms:.3f}"
    return say(template + ").", **values)


#: The columns of a small-signal scan its verdict reads.
_SCAN_COLUMNS = [
    "unbiased_error",
    "common_bias_error",
    "best_bias_error",
    "implied_loss_angle_deg",
    "max_loss_angle_any_bias_deg",
]


@rule(
    "findings.small_signal",
    record="small_signal/{index}",
)
def _small_signal(record, index):
    """The DC-bias test's verdict, made again from its rows
    (:func:`fitdf.inference.small_signal.verdict`)."""
    if not record or not record.get("rows"):
        return None
    return say(
        "Small signals, {block} ({law:law}): {verdict}.",
        block=record["block"],
        law=record["model"],
        verdict=verdict(pd.DataFrame(record["rows"])[_SCAN_COLUMNS].astype(float)),
    )


@rule(
    "findings.joint",
    tables="blocks/{block}/tables",
    rms="blocks/*/ranking_lsq/*/rms_complex",
    **LSQ,
)
def _joint(tables, rms, models, aicc, block):
    """One parameter set for both impedances against the separate tables' best fits."""
    if not tables or len(tables) < 2 or not models.get(block):
        return None
    j = best_law(models[block], aicc[block])
    sep = [t for t in tables if best_law(models.get(t) or [], aicc.get(t) or [])]
    if j is None or not sep:
        return None
    values = {"block": block, "law": j, "rms": _at(models[block], rms[block], j)}
    parts = []
    for i, t in enumerate(sep):
        w = best_law(models[t], aicc[t])
        parts.append(f"{{sep_{i}}} {{sep_rms_{i}:.3f}}")
        values[f"sep_{i}"], values[f"sep_rms_{i}"] = t, _at(models[t], rms[t], w)
    return say(
        "One parameter set for both impedances ({block}): the best law by AICc, {law:law}, "
        "has RMS {rms:.3f}, against the separate tables' best by AICc (" + ", ".join(parts) + ").",
        **values,
    )


def findings(results: dict, physics=()) -> list:
    """The statements after the conclusion, in order: each a list of claims (one paragraph,
    a law named in full at its first mention), or a plain sentence where none is made yet.
    ``physics``: the physics section's statements
    (:func:`fitdf.report.physics_claims.physics_findings`), placed before the audit's."""
    out = [block_claims(results, key) for key in results["blocks"]]
    out += [paragraph(results, (kind, {})) for kind in ("findings.failures", "findings.posteriors")]
    out += [
        paragraph(results, ("findings.cross", {"index": i}))
        for i in range(len(results.get("cross_impedance") or []))
    ]
    out += [
        paragraph(results, ("findings.small_signal", {"index": i}))
        for i in range(len(results.get("small_signal") or []))
    ]
    out += [
        paragraph(results, ("findings.joint", {"block": key}))
        for key, rec in results["blocks"].items()
        if len(rec.get("tables") or []) > 1
    ]
    out += list(physics)
    out += audit_findings(results)
    out.append(_limit_finding(results.get("limit_cycles", {})))
    return [p for p in out if p]


# ------------------------------------------------------------------ not yet claims
def _limit_finding(lc) -> str | None:
    """The limit-cycle comparison's own one-line finding (``attrs.statements.finding``, made
    by :func:`fitdf.limit_cycle_tables.limit_cycle_statements` from the record's fields)."""
    return ((lc.get("attrs") or {}).get("statements") or {}).get("finding")
