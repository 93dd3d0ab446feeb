"""The report's conclusion: a few sentences on which law to use for which core, the error to
expect from it, and what the data cannot decide.

Each sentence is a rule of :mod:`fitdf.report.claims` on the fields of ``results.json``;
the best law of a block is :func:`fitdf.report.criteria.best_law` (the lowest AICc), and a
sentence naming another criterion (the evidence, LOO-IC) is made from that criterion's own
numbers (:mod:`fitdf.report.criteria`).
"""

from __future__ import annotations

import math

import numpy as np

from fitdf.data.cores import STACKING_FACTOR, STACKING_FACTOR_RANGE
from fitdf.inference.material import RESISTANCE_PRIOR_SIGMAS
from fitdf.report.claims import paragraph, rule, say
from fitdf.report.criteria import (
    AICC_TIE,
    BARE_MENTION,
    LOO_TIE_SE,
    aicc_ties,
    best_by,
    best_law,
    evidence_ties,
    loo_ties,
)

__all__ = [
    "conclusion_claims",
    "error_percent",
    "QUANTITY_NAMES",
    "OUTSIDE",
    "UNDETERMINED",
    "LSQ",
    "POSTERIOR",
]

#: The Appendix A quantities in words.
QUANTITY_NAMES = {
    "initial_permeability": "initial permeability",
    "maximum_permeability": "maximum permeability",
    "coercive_force_Hc": "coercive force",
    "peak_flux_density_Bp": "peak flux density B_p",
    "residual_induction_Br": "residual induction B_r",
    "squareness_Br_over_Bp": "squareness B_r/B_p",
    "series_resistance": "series resistance",
}

#: What "outside" means for a material constant of a fit.
OUTSIDE = (
    "the fitted constant lies outside the Appendix A catalogue range of the core's material, "
    f"at the nominal stacking factor {STACKING_FACTOR:g} (for the series resistance: outside "
    f"the central {100 * math.erf(RESISTANCE_PRIOR_SIGMAS / math.sqrt(2)):.0f} % of its prior, the winding's Appendix A estimate plus a typical source and "
    "leads)"
)

#: What the describing function leaves open about the material constants (from
#: :mod:`fitdf.data.cores` and :mod:`fitdf.inference.material`), for the report's text.
UNDETERMINED = (
    "The describing function does not determine the iron fraction of the core's section (the "
    "stacking factor, which the thesis does not print): inductions and permeabilities scale as "
    "its inverse, so they are also given over the range of tape-wound cores, "
    f"{STACKING_FACTOR_RANGE[0]:g}-{STACKING_FACTOR_RANGE[1]:g}. At one source impedance the data "
    "fix a core only up to a current scale that trades against the series resistance, so there "
    "the permeabilities and the coercive force rest on the resistance's prior; the joint fits of "
    "0 and 600 ohm determine them. B_p and B_r are the tip and remanence of the largest loop the "
    "tables reach, not of the catalogue's unprinted test conditions"
)

#: The same, in short, for the conclusion.
_UNDETERMINED_SHORT = (
    "the describing function does not determine all of them: inductions and permeabilities "
    "carry the unprinted iron fraction of the section, and at one source impedance the "
    "permeabilities and the coercive force trade against the series resistance"
)

#: The fields of every block's least-squares ranking and posterior ranking the rules read.
LSQ = {
    "models": "blocks/*/ranking_lsq/*/model",
    "aicc": "blocks/*/ranking_lsq/*/aicc",
}
POSTERIOR = {
    "post_models": "blocks/*/ranking_posterior/*/model",
    "log_evidence": "blocks/*/ranking_posterior/*/log_evidence",
    "looic": "blocks/*/ranking_posterior/*/looic",
}


def _listed(items) -> str:
    items = list(items)
    return ", ".join(items[:-1]) + f" and {items[-1]}" if len(items) > 1 else "".join(items)


def _bests(models: dict, aicc: dict) -> dict:
    """Block -> its best law (:func:`~fitdf.report.criteria.best_law`), fitted blocks only."""
    out = {k: best_law(models[k] or [], aicc.get(k) or []) for k in models}
    return {k: m for k, m in out.items() if m is not None}


def error_percent(rms: float, df_measured) -> float:
    """An RMS complex residual as a percentage of the RMS measured ``|DF|`` of the rows fitted."""
    df = np.asarray([np.nan if d is None else d for d in df_measured], float)
    return 100.0 * rms / float(np.sqrt(np.nanmean(df**2)))


def _how_many(n: int, noun: str) -> str:
    """``the block``, ``both blocks``, ``all 5 blocks`` (a template with the field ``n``)."""
    return {1: f"the {noun}", 2: f"both {noun}s"}.get(n, f"all {{n}} {noun}s")


# ------------------------------------------------------------------ which law to use
@rule("conclusion.use", core="blocks/*/core", tables="blocks/*/tables", **LSQ, **POSTERIOR)
def _use(core, tables, models, aicc, post_models, log_evidence, looic):
    best = _bests(models, aicc)
    if not best:
        return say("No block was fitted.")
    cores = list(dict.fromkeys(core[k].capitalize() for k in best))
    fitted = sorted({m for k in best for m in models[k]})
    if len(fitted) == 1:
        return say(
            "Only {law:law} was fitted here, to {cores:and}: this report ranks no laws.",
            law=fitted[0],
            cores=cores,
        )
    winners = list(dict.fromkeys(best.values()))
    if len(winners) > 1:
        parts, values = [], {}
        for i, c in enumerate(cores):
            by_law = {}
            for k, w in best.items():
                if core[k].capitalize() == c:
                    by_law.setdefault(w, []).append(k)
            laws = []
            for j, (w, ks) in enumerate(by_law.items()):
                laws.append(f"{{law_{i}_{j}:law}} (on {{blocks_{i}_{j}:and}})")
                values[f"law_{i}_{j}"], values[f"blocks_{i}_{j}"] = w, ks
            parts.append(f"{{core_{i}}}: " + "; ".join(laws))
            values[f"core_{i}"] = c
        return say(
            "The law with the lowest AICc (least squares) depends on the core. "
            + ". ".join(parts)
            + ".",
            **values,
        )
    (w,) = winners
    joint = any(len(tables[k] or []) > 1 for k in best)
    single = any(len(tables[k] or []) == 1 for k in best)
    template = (
        "Use {law:law} for "
        + ("all {n_cores} cores" if len(cores) > 1 else "{cores:and}")
        + ": it has the lowest AICc (least squares) on "
        + _how_many(len(best), "block")
        + (" (each table alone and each core's tables jointly)" if joint and single else "")
    )
    values = {"law": w, "n_cores": len(cores), "cores": cores, "n": len(best)}
    for name, values_by_block, larger in (
        ("the evidence", log_evidence, True),
        ("LOO-IC", looic, False),
    ):
        picked = {
            k: best_by(post_models.get(k) or [], values_by_block.get(k) or [], larger) for k in best
        }
        picked = {k: m for k, m in picked.items() if m is not None}
        if not picked:
            continue
        key = "ev" if larger else "loo"
        agree = [k for k, m in picked.items() if m == w]
        if len(agree) == len(picked):
            template += f"; {name} agrees on " + (
                "the {n_" + key + "} block sampled"
                if len(picked) == 1
                else "the {n_" + key + "} blocks sampled"
            )
            values[f"n_{key}"] = len(picked)
        else:
            others = {}
            for k, m in picked.items():
                if m != w:
                    others.setdefault(m, []).append(k)
            clauses = []
            for j, (m, ks) in enumerate(others.items()):
                clauses.append(f"{{{key}_law_{j}:law}} on {{{key}_blocks_{j}:and}}")
                values[f"{key}_law_{j}"], values[f"{key}_blocks_{j}"] = m, ks
            template += f"; {name} prefers " + ", ".join(clauses)
    return say(template + ".", **values)


# ------------------------------------------------------------------ the error to expect
@rule(
    "conclusion.error",
    core="blocks/*/core",
    ohms="blocks/*/source_impedance_ohm",
    rms="blocks/*/ranking_lsq/*/rms_complex",
    df="blocks/*/fits_lsq/*/rows/df_measured",
    **LSQ,
)
def _error(core, ohms, rms, df, models, aicc):
    best = _bests(models, aicc)
    if not best:
        return None
    single, joint = [], []
    for k, w in best.items():
        pct = error_percent(rms[k][models[k].index(w)], df[k][w])
        (joint if len(ohms[k]) > 1 else single).append((k, pct))
    every = [p for _, p in single + joint]
    values = {"low": min(every), "high": max(every)}
    template = "Expect an RMS complex residual of " + (
        "{low:.1f}-{high:.1f} %" if len(every) > 1 else "{low:.1f} %"
    )
    template += " of the measured |DF| from the best law (lowest AICc)"
    by_core = {}
    for i, (k, pct) in enumerate(single):
        by_core.setdefault(core[k].capitalize(), []).append(
            f"{{pct_{i}:.1f}} % at {{ohm_{i}:g}} ohm"
        )
        values[f"pct_{i}"], values[f"ohm_{i}"] = pct, ohms[k][0]
    if by_core:
        template += ": " + "; ".join(f"{c} {_listed(v)}" for c, v in by_core.items())
    if joint:
        parts = []
        for i, (k, pct) in enumerate(joint):
            parts.append(f"{{joint_{i}:.1f}} % ({core[k].capitalize()})")
            values[f"joint_{i}"] = pct
        template += "; one parameter set for both impedances: " + _listed(parts)
    return say(template + ".", **values)


# ------------------------------------------------------------------ what the data cannot tell
_LOO = {
    "elpd_diff": "blocks/*/ranking_posterior/*/elpd_loo_diff",
    "elpd_dse": "blocks/*/ranking_posterior/*/elpd_loo_dse",
}


def _grouped(pairs) -> dict:
    """``{(best, other): [(block, numbers...)]}`` from ``[(block, best, other, *numbers)]``."""
    out = {}
    for block, best, other, *numbers in pairs:
        out.setdefault((best, other), []).append((block, *numbers))
    return out


@rule("conclusion.ties", **LSQ, **POSTERIOR, **_LOO)
def _ties(models, aicc, post_models, log_evidence, looic, elpd_diff, elpd_dse):
    """One clause per criterion, each by its own rule (:mod:`fitdf.report.criteria`)."""
    best = _bests(models, aicc)
    if len({m for k in best for m in models[k]}) < 2:
        return None
    # (Kass and Raftery's scale is on 2 ln B: the sentence states the bound on ln B)
    values = {"aicc_tie": AICC_TIE, "bare": BARE_MENTION / 2, "loo_se": LOO_TIE_SE}
    clauses = [
        _aicc_clause(models, aicc, best, values),
        _evidence_clause(post_models, log_evidence, best, values),
        _loo_clause(post_models, looic, elpd_diff, elpd_dse, best, values),
    ]
    text = "; ".join(c for c in clauses if c)
    return say(text[0].upper() + text[1:] + ".", **values)


def _aicc_clause(models, aicc, best, values) -> str:
    """The AICc ties' clause of :func:`_ties` (its fields added to ``values``)."""
    pairs = [(k, best[k], m, d) for k in best for m, d in aicc_ties(models[k], aicc[k])]
    if not pairs:
        return "by AICc no other law comes within {aicc_tie:g} of the best on any block"
    parts = []
    for i, ((a, b), where) in enumerate(_grouped(pairs).items()):
        parts.append(f"{{a_best_{i}:law}} from {{a_other_{i}:law}} on {{a_blocks_{i}:and}}")
        values.update({f"a_best_{i}": a, f"a_other_{i}": b, f"a_blocks_{i}": [w[0] for w in where]})
    return "by AICc (within {aicc_tie:g}) the data cannot tell " + "; nor ".join(parts)


def _evidence_clause(post_models, log_evidence, best, values) -> str | None:
    """The evidence ties' clause of :func:`_ties`, None where no block was sampled."""
    sampled = {
        k: best_by(post_models.get(k) or [], log_evidence.get(k) or [], larger=True) for k in best
    }
    sampled = {k: m for k, m in sampled.items() if m is not None}
    if not sampled:
        return None
    pairs = [
        (k, sampled[k], m, two)
        for k in sampled
        for m, two in evidence_ties(post_models[k], log_evidence[k])
    ]
    values["n_ev"] = len(sampled)
    if not pairs:
        return (
            "by the evidence every Bayes factor to the best on the {n_ev} "
            + ("block" if len(sampled) == 1 else "blocks")
            + " sampled is worth more than a bare mention (ln B at least {bare:g})"
        )
    parts = []
    for i, ((a, b), where) in enumerate(_grouped(pairs).items()):
        parts.append(f"{{e_best_{i}:law}} from {{e_other_{i}:law}} on {{e_blocks_{i}:and}}")
        values.update({f"e_best_{i}": a, f"e_other_{i}": b, f"e_blocks_{i}": [w[0] for w in where]})
    return (
        "by the evidence (a Bayes factor B with ln B below {bare:g}, not worth more "
        "than a bare mention) it cannot tell " + "; nor ".join(parts)
    )


def _loo_clause(post_models, looic, elpd_diff, elpd_dse, best, values) -> str | None:
    """The LOO-IC ties' clause of :func:`_ties`, None where no block has a LOO-IC."""
    loo_best = {k: best_by(post_models.get(k) or [], looic.get(k) or []) for k in best}
    loo_best = {k: m for k, m in loo_best.items() if m is not None}
    if not loo_best:
        return None
    pairs = [
        (k, loo_best[k], m, d, se)
        for k in loo_best
        for m, d, se in loo_ties(post_models[k], looic[k], elpd_diff[k], elpd_dse[k])
    ]
    if not pairs:
        return "by LOO-IC no other law's elpd comes within {loo_se:g} standard errors of the best's"
    parts = []
    for i, (k, a, b, d, se) in enumerate(pairs):
        parts.append(
            f"{{l_best_{i}:law}} from {{l_other_{i}:law}} on {{l_block_{i}}} "
            f"(elpd apart by {{l_diff_{i}:.1f}} +- {{l_se_{i}:.1f}})"
        )
        values.update(
            {
                f"l_best_{i}": a,
                f"l_other_{i}": b,
                f"l_block_{i}": k,
                f"l_diff_{i}": d,
                f"l_se_{i}": se,
            }
        )
    return (
        "by LOO-IC (an elpd difference below {loo_se:g} standard errors) it cannot "
        "tell " + "; nor ".join(parts)
    )


# ------------------------------------------------------------------ posteriors and constants
@rule("conclusion.chains", converged="blocks/*/fits_posterior/*/diagnostics/converged")
def _chains(converged):
    fits = [(k, m, c) for k, laws in converged.items() for m, c in (laws or {}).items()]
    if not fits:
        return say(
            "No posterior was sampled in this configuration: the ranking rests on least squares."
        )
    bad = {}
    for k, m, c in fits:
        if not c:
            bad.setdefault(m, []).append(k)
    if not bad:
        return say("All {n} posteriors converged.", n=len(fits))
    parts, values = [], {"n_bad": sum(map(len, bad.values())), "n": len(fits)}
    for i, (m, ks) in enumerate(bad.items()):
        parts.append(f"{{law_{i}:law}} on {{blocks_{i}:and}}")
        values[f"law_{i}"], values[f"blocks_{i}"] = m, ks
    return say(
        "{n_bad} of {n} posteriors did not converge within the report's limit ("
        + "; ".join(parts)
        + "): they are listed, not drawn as results.",
        **values,
    )


@rule(
    "conclusion.constants",
    check="blocks/*/fits_lsq/*/appendix_a_check",
    initial="blocks/*/fits_lsq/*/material/initial_converged",
    **LSQ,
)
def _constants(check, initial, models, aicc):
    best = _bests(models, aicc)
    checks, open_mu = [], []
    for k, w in best.items():
        checks += (check.get(k) or {}).get(w) or []
        if (initial.get(k) or {}).get(w) is False:
            open_mu.append(k)
    if not checks:
        return None
    outside = {}
    for c in checks:
        if not c["inside"]:
            outside[c["quantity"]] = outside.get(c["quantity"], 0) + 1
    most = sorted(outside.items(), key=lambda qn: -qn[1])[:2]
    values = {"n_out": sum(outside.values()), "n": len(checks)}
    template = (
        "{n_out} of the {n} material constants of the best fits lie outside the Appendix A "
        "catalogue ranges"
    )
    if most:
        template += ", most often the " + _listed(
            f"{{q_{i}}} ({{q_n_{i}}})" for i in range(len(most))
        )
        for i, (q, n) in enumerate(most):
            values[f"q_{i}"], values[f"q_n_{i}"] = QUANTITY_NAMES.get(q, q), n
    template += "; " + _UNDETERMINED_SHORT
    if open_mu:
        template += (
            ", and on {open_mu:and} the best fit's small-signal inductance still changes "
            "at a millionth of the largest current, so its initial permeability is not determined"
        )
        values["open_mu"] = open_mu
    return say(template + ".", **values)


def conclusion_claims(results: dict) -> list[dict]:
    """The conclusion's claims, one paragraph (see the module docstring)."""
    kinds = ("use", "error", "ties", "chains", "constants")
    if not any(rec.get("ranking_lsq") for rec in results["blocks"].values()):
        kinds = ("use",)
    return paragraph(results, *((f"conclusion.{k}", {}) for k in kinds))
