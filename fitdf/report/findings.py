"""The report's "Findings": a short conclusion and the detailed statements, generated from the
numbers of ``results.json``.

:func:`conclusion` says in a few sentences which law to use for which core, the error to expect
from it, and what the data cannot decide (ties, unconverged chains, material constants
outside Appendix A and the ones the describing function does not determine);
:func:`findings` states per block the winners, margins, verdicts and failures, then the
cross-impedance, small-signal, audit and limit-cycle results. Both read the records that
:mod:`fitdf.report.sections` built; nothing in them is typed by hand.
"""

from __future__ import annotations

import math

import numpy as np

from fitdf.data.cores import STACKING_FACTOR, STACKING_FACTOR_RANGE
from fitdf.inference.nested import MAX_LOG_EVIDENCE_ERROR, MIN_EFFECTIVE
from fitdf.report.document import law, law_names

__all__ = [
    "findings",
    "conclusion",
    "error_percent",
    "QUANTITY_NAMES",
    "OUTSIDE",
    "UNDETERMINED",
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
    "the central 95 % of its prior, the winding's Appendix A estimate plus a typical source and "
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


class _Names:
    """Law names for one paragraph: the human name beside the code name at the first mention,
    the code name after it."""

    def __init__(self, results: dict):
        self.full, self.seen = law_names(results), set()

    def __call__(self, name) -> str:
        if name in self.seen:
            return f"`{name}`"
        self.seen.add(name)
        return law(self.full, name)


def _pct(a, b):
    return 100.0 * (b - a) / b if b else float("nan")


def _listed(items) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    items = list(items)
    return ", ".join(items[:-1]) + f" and {items[-1]}" if len(items) > 1 else "".join(items)


def _tied_with(cell) -> list[str]:
    """The laws of an ``indistinguishable_from`` cell (``"cubic_hc/voltage, rayleigh/voltage"``)."""
    return [t.split("/")[0].strip() for t in str(cell or "").split(",") if t.strip()]


def error_percent(rec: dict, model: str) -> float:
    """RMS complex residual of ``model``'s least-squares fit on a block as a percentage of the
    RMS measured ``|DF|`` of the rows it fitted."""
    fit = rec["fits_lsq"][model]
    df = np.asarray(fit["rows"]["df_measured"], float)
    rms = next(r["rms_complex"] for r in rec["ranking_lsq"] if r["model"] == model)
    return 100.0 * rms / float(np.sqrt(np.nanmean(df**2)))


# ------------------------------------------------------------------ the conclusion
def _use_sentence(blocks, names) -> str:
    """Which law to use for which core."""
    best = {k: rec["order_lsq"][0] for k, rec in blocks.items() if rec["order_lsq"]}
    cores = list(dict.fromkeys(blocks[k]["core"] for k in best))
    laws = set(best.values())
    fitted = {m for rec in blocks.values() for m in rec["order_lsq"]}
    if len(fitted) == 1:
        return (
            f"Only {names(next(iter(fitted)))} was fitted here, to "
            f"{_listed(c.capitalize() for c in cores)}: this report ranks no laws."
        )
    if len(laws) == 1:
        (w,) = laws
        also = []
        aicc = {
            min(rec["ranking_lsq"], key=lambda r: math.inf if r["aicc"] is None else r["aicc"])[
                "model"
            ]
            for rec in blocks.values()
            if rec["ranking_lsq"]
        }
        if aicc == {w}:
            also.append("AICc")
        loo = {rec["order_mcmc"][0] for rec in blocks.values() if rec.get("order_mcmc")}
        if loo == {w}:
            also.append(_posterior_criterion(blocks))
        n = f"all {len(cores)} cores" if len(cores) > 1 else cores[0].capitalize()
        return (
            f"Use {names(w)} for {n}: it has the smallest RMS complex residual on "
            + {1: "the block", 2: "both blocks"}.get(len(best), f"all {len(best)} blocks")
            + (" (each table alone and each core's tables jointly)" if len(best) > 1 else "")
            + (f" and the lowest {_listed(also)}" if also else "")
            + "."
        )
    parts = []
    for core in cores:
        by_law = {}
        for k, w in best.items():
            if blocks[k]["core"] == core:
                by_law.setdefault(w, []).append(k)
        parts.append(
            f"{core.capitalize()}: "
            + "; ".join(f"{names(w)} (best on {_listed(ks)})" for w, ks in by_law.items())
        )
    return "The law with the smallest RMS complex residual depends on the core. " + (
        ". ".join(parts) + "."
    )


def _error_sentence(blocks) -> str | None:
    """The error to expect from each block's best law, as a share of the DF."""
    single, joint = [], []
    for rec in blocks.values():
        if not rec["order_lsq"]:
            continue
        pct = error_percent(rec, rec["order_lsq"][0])
        ohms = "+".join(f"{o:g}" for o in rec["source_impedance_ohm"])
        (joint if len(rec["source_impedance_ohm"]) > 1 else single).append((rec, ohms, pct))
    if not single and not joint:
        return None
    every = [p for _, _, p in single + joint]
    by_core = {}
    for rec, ohms, pct in single:
        by_core.setdefault(rec["core"], []).append(f"{pct:.1f} % at {ohms} ohm")
    span = f"{min(every):.1f}-{max(every):.1f} %" if len(every) > 1 else f"{every[0]:.1f} %"
    text = f"Expect an RMS complex residual of {span} of the measured |DF|"
    if by_core:
        text += ": " + "; ".join(f"{c.capitalize()} {_listed(v)}" for c, v in by_core.items())
    if joint:
        text += "; one parameter set for both impedances: " + _listed(
            f"{p:.1f} % ({rec['core'].capitalize()})" for rec, _, p in joint
        )
    return text + "."


def _ties_sentence(blocks, names) -> str | None:
    """Where the best law cannot be told apart from another."""
    if len({m for rec in blocks.values() for m in rec["order_lsq"]}) < 2:
        return None
    aicc, loo = {}, {}
    for k, rec in blocks.items():
        for ranking, out in ((rec["ranking_lsq"], aicc), (rec.get("ranking_mcmc") or [], loo)):
            if ranking:
                for other in _tied_with(ranking[0].get("indistinguishable_from")):
                    out.setdefault((ranking[0]["model"], other), []).append(k)
    parts = [
        f"{names(a)} from {names(b)} on {_listed(ks)} (by AICc: within 2)"
        for (a, b), ks in aicc.items()
    ]
    by = (
        "by the evidence: a Bayes factor not worth more than a bare mention"
        if _posterior_criterion(blocks) == "the evidence"
        else "by LOO-IC: elpd apart by less than twice its standard error"
    )
    parts += [f"{names(a)} from {names(b)} on {_listed(ks)} ({by})" for (a, b), ks in loo.items()]
    if not parts:
        mcmc = any(r.get("ranking_mcmc") for r in blocks.values())
        return (
            "No other law comes within 2 of the best law's AICc on any block"
            + (" or within the uncertainty of its LOO-IC" if mcmc else "")
            + "."
        )
    return "The data cannot tell " + "; nor ".join(parts) + "."


def _posterior_criterion(blocks) -> str:
    """What ranks the posteriors: the evidence (nested sampling) or LOO-IC (MCMC)."""
    methods = {f.get("method") for rec in blocks.values() for f in rec["fits_mcmc"].values()}
    return "the evidence" if methods == {"nested"} else "LOO-IC"


def _chains_sentence(blocks, names) -> str:
    """How many posteriors converged; which not."""
    fits = [(k, m, f) for k, rec in blocks.items() for m, f in rec["fits_mcmc"].items()]
    if not fits:
        return "No posterior was sampled in this configuration: the ranking rests on least squares."
    bad = {}
    for k, m, f in fits:
        if not f["diagnostics"].get("converged"):
            bad.setdefault(m, []).append(k)
    if not bad:
        return f"All {len(fits)} posteriors converged."
    n_bad = sum(map(len, bad.values()))
    return (
        f"{n_bad} of {len(fits)} posteriors did not converge within the report's limit ("
        + "; ".join(f"{names(m)} on {_listed(ks)}" for m, ks in bad.items())
        + "): they are listed, not drawn as results."
    )


def _constants_sentence(blocks) -> str | None:
    """How many of the best fits' material constants lie outside Appendix A, and why some
    cannot be decided."""
    checks, open_mu = [], []
    for k, rec in blocks.items():
        if not rec["order_lsq"]:
            continue
        fit = rec["fits_lsq"][rec["order_lsq"][0]]
        checks += fit.get("appendix_a_check") or []
        if (fit.get("material") or {}).get("initial_converged") is False:
            open_mu.append(k)
    if not checks:
        return None
    outside = {}
    for c in checks:
        if not c["inside"]:
            outside[c["quantity"]] = outside.get(c["quantity"], 0) + 1
    most = sorted(outside.items(), key=lambda qn: -qn[1])[:2]
    text = (
        f"{sum(outside.values())} of the {len(checks)} material constants of the best fits lie "
        "outside the Appendix A catalogue ranges"
        + (
            ", most often the " + _listed(f"{QUANTITY_NAMES.get(q, q)} ({n})" for q, n in most)
            if most
            else ""
        )
        + "; "
        + _UNDETERMINED_SHORT
    )
    if open_mu:
        text += (
            f", and on {_listed(open_mu)} the best fit's small-signal inductance still changes "
            "at a millionth of the largest current, so its initial permeability is not determined"
        )
    return text + "."


def conclusion(results: dict) -> str:
    """A few plain sentences: the law to use per core, the error to expect, what the data
    cannot decide (see the module docstring)."""
    blocks = {k: r for k, r in results["blocks"].items() if r["order_lsq"]}
    if not blocks:
        return "No block was fitted."
    names = _Names(results)
    parts = [
        _use_sentence(blocks, names),
        _error_sentence(blocks),
        _ties_sentence(blocks, names),
        _chains_sentence(blocks, names),
        _constants_sentence(blocks),
    ]
    return " ".join(p for p in parts if p)


# ------------------------------------------------------------------ the detailed statements
def _block_finding(rec, results) -> str | None:
    """One sentence group per block: winner and margin, AICc and LOO verdicts, the hardest spot."""
    names = _Names(results)
    rank = rec["ranking_lsq"]
    if not rank:
        return None
    best = rank[0]
    text = (
        f"**{rec['title']}**: {names(best['model'])} fits best (RMS complex residual "
        f"{best['rms_complex']:.4f}, {error_percent(rec, best['model']):.1f} % of the DF"
    )
    if len(rank) > 1:
        second = rank[1]
        d_aicc = (second["aicc"] or 0.0) - (best["aicc"] or 0.0)
        text += (
            f"; {_pct(best['rms_complex'], second['rms_complex']):.0f}% below the runner-up "
            f"{names(second['model'])} at {second['rms_complex']:.4f}; "
            + (
                f"AICc lower by {d_aicc:.1f}"
                if d_aicc >= 0
                else f"but AICc higher by {-d_aicc:.1f}"
            )
        )
    text += ")."
    aicc_best = min(rank, key=lambda r: r["aicc"] if r["aicc"] is not None else math.inf)
    if aicc_best["model"] != best["model"]:
        text += f" AICc, which charges for parameters, prefers {names(aicc_best['model'])}."
    if rec["ranking_mcmc"]:
        m = rec["ranking_mcmc"][0]["model"]
        how = _posterior_criterion({rec["key"]: rec})
        text += (
            f" The posteriors ({how}) agree."
            if m == best["model"]
            else f" Of the {len(rec['ranking_mcmc'])} laws sampled, {how} prefers {names(m)}."
        )
        text += _disagreement(rec, names)
    fail = rec["where_models_fail"]
    if fail["frequency_blocks"] and fail["rows"]:
        fb, w = fail["frequency_blocks"][0], fail["rows"][0]
        text += (
            f" Hardest: {fb['frequency_hz']:g} c/s at {fb['source_impedance_ohm']:g} ohm (best "
            f"law there {names(fb['best_model'])}, RMS {fb['best_rms_complex']:.3f}); every "
            f"law misses {w['table']} {w['frequency_hz']:g} c/s, {w['input_v']:g} V (|DF| "
            f"{w['df_measured']:.3g}, lead {w['phase_lead_measured_deg']:.3g} deg) by at least "
            f"{w['smallest_complex_residual']:.3f}."
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
        f"Where all laws fail: the {len(worst)} rows that every law misses most ({per_table}"
        f" per table) have a median input of {wa:.3g} V (all rows: {aa:.3g} V) and a median "
        f"phase lead of {wl:.3g} deg (all rows: {al:.3g} deg)"
    )
    if wa < 0.5 * aa:
        text += " -- they sit at the small-signal end of the tables"
        text += ", where the measured lead is large" if wl > 1.5 * al else ""
    return text + "."


def _disagreement(rec, names) -> str:
    """Where the criteria rank the sampled laws differently: AICc, LOO-IC, the evidence and
    cross-validation, each on the laws it ranks."""
    sampled = [r["model"] for r in rec["ranking_mcmc"]]
    rows = {r["model"]: r for r in rec["ranking_lsq"] if r["model"] in sampled}
    post = {r["model"]: r for r in rec["ranking_mcmc"]}
    best = {}
    for name, values, better in (
        ("AICc", {m: rows[m].get("aicc") for m in rows}, min),
        ("cross-validation", {m: rows[m].get("cv_rms_complex") for m in rows}, min),
        ("LOO-IC", {m: post[m].get("looic") for m in post}, min),
        ("the evidence", {m: post[m].get("log_evidence") for m in post}, max),
    ):
        known = {m: v for m, v in values.items() if v is not None and math.isfinite(v)}
        if len(known) >= 2:
            best[name] = better(known, key=known.get)
    if len(set(best.values())) < 2:
        return ""
    return (
        " The criteria disagree on the laws sampled: "
        + "; ".join(f"{name} prefers {names(m)}" for name, m in best.items())
        + "."
    )


def _span(values, fmt: str) -> str:
    """``"a-b"`` of the smallest and largest of ``values`` in ``fmt``; one number if equal."""
    lo, hi = fmt.format(min(values)), fmt.format(max(values))
    return lo if lo == hi else f"{lo}-{hi}"


def _mcmc_finding(blocks) -> str | None:
    """The chains' convergence statistics (which chains did not converge: the conclusion)."""
    diags = [
        f["diagnostics"]
        for rec in blocks.values()
        for f in rec["fits_mcmc"].values()
        if f.get("method", "mcmc") == "mcmc"
    ]
    nested = [
        f["diagnostics"]
        for rec in blocks.values()
        for f in rec["fits_mcmc"].values()
        if f.get("method") == "nested"
    ]
    if nested:
        n_conv = sum(bool(d.get("converged")) for d in nested)
        ev = [d["n_likelihood_evaluations"] for d in nested]
        err = [d["log_evidence_error"] for d in nested]
        return (
            f"Nested sampling: {n_conv} of {len(nested)} posteriors meet the convergence rule "
            f"({MIN_EFFECTIVE} effective draws, evidence error <= {MAX_LOG_EVIDENCE_ERROR}), in "
            f"{_span(ev, '{:,.0f}')} likelihood evaluations; evidence errors "
            f"{_span(err, '{:.2f}')}."
        )
    if not diags:
        return None
    n_conv = sum(bool(d.get("converged")) for d in diags)
    ratio = [d["steps_over_tau"] for d in diags]
    rhat = [d["rhat_max"] for d in diags]
    n_given_up = sum(bool(d.get("steps_needed")) for d in diags)
    return (
        f"MCMC: {n_conv} of {len(diags)} chains meet the convergence rule (50 autocorrelation "
        f"times, R-hat < 1.01, bulk ESS >= 400); steps/tau {min(ratio):.0f}-{max(ratio):.0f}, "
        f"max R-hat {min(rhat):.3f}-{max(rhat):.3f}"
        + (
            f"; {n_given_up} stopped early: at their autocorrelation times they need more "
            "steps than the limit"
            if n_given_up
            else ""
        )
        + "."
    )


def _cross_findings(results) -> list[str]:
    out = []
    blocks = results["blocks"]
    for d in results.get("cross_impedance", []):
        names = _Names(results)
        if d["rows"]:
            r = d["rows"][0]
            own = blocks.get(d["test_block"], {}).get("ranking_lsq")
            own_text = (
                f"; a fit to {d['test_block']} itself reaches {own[0]['rms_complex']:.3f}"
                if own
                else ""
            )
            out.append(
                f"Cross-impedance, {d['core']}: fitted at {d['train_ohm']:g} ohm "
                f"({d['train_block']}), {names(r['model'])} predicts the {d['test_ohm']:g} "
                f"ohm data ({d['test_block']}) best with RMS complex residual "
                f"{r['predict_rms_complex']:.3f} averaged over the series resistance's prior"
                f"{_spread_text(r)} (training residual "
                f"{r['train_rms_complex']:.3f}{own_text})."
            )
    return out


def _spread_text(row) -> str:
    low, high = row.get("predict_rms_complex_min"), row.get("predict_rms_complex_max")
    if low is None or high is None or low == high:
        return ""
    return f" ({low:.3f}-{high:.3f} across it)"


def _joint_findings(results) -> list[str]:
    out, blocks = [], results["blocks"]
    for core, keys in (("permalloy", ("B.1", "B.3")), ("deltamax", ("B.2", "B.5"))):
        names = _Names(results)
        joint = blocks.get(f"{core}-joint")
        sep = [blocks[k] for k in keys if k in blocks and blocks[k]["ranking_lsq"]]
        if joint and joint["ranking_lsq"] and sep:
            j = joint["ranking_lsq"][0]
            parts = ", ".join(f"{s['key']} {s['ranking_lsq'][0]['rms_complex']:.3f}" for s in sep)
            out.append(
                f"One parameter set for both impedances ({joint['key']}): best "
                f"{names(j['model'])} with RMS {j['rms_complex']:.3f}, against the separate "
                f"fits' best ({parts})."
            )
    return out


def _audit_findings(audit) -> list[str]:
    if not audit.get("tables"):
        return []
    n_flag = sum(t["flagged"] for t in audit["tables"])
    n_excl = sum(t["excluded_by_default"] for t in audit["tables"])
    n_rows = sum(t["rows"] for t in audit["tables"])
    return [
        f"The audit of the printed tables flags {n_flag} of {n_rows} rows and excludes {n_excl} "
        "by default (see the audit section for every row and reason)."
    ] + [
        f
        for f in audit.get("findings", [])
        if "footnote factor" in f and "followed by all" not in f
    ]


def _limit_finding(lc) -> str | None:
    """The limit-cycle comparison's own one-line finding (``attrs.statements.finding``, made
    by :func:`fitdf.thesis.limit_cycle_statements` from the record's fields)."""
    return ((lc.get("attrs") or {}).get("statements") or {}).get("finding")


def findings(results: dict) -> list[str]:
    """The detailed statements that follow the conclusion (the report's "Findings" list)."""
    blocks = results["blocks"]
    out = [t for t in (_block_finding(rec, results) for rec in blocks.values()) if t]
    out += [t for t in (_failure_pattern(blocks), _mcmc_finding(blocks)) if t]
    out += _cross_findings(results)
    out += [
        f"Small signals, {rec['block']} ({_Names(results)(rec['model'])}): {rec['verdict']}."
        for rec in results.get("small_signal", [])
    ]
    out += _joint_findings(results)
    out += _physics_findings(results.get("physics"))
    out += _audit_findings(results.get("audit", {}))
    lc = _limit_finding(results.get("limit_cycles", {}))
    return out + ([lc] if lc else [])


def _physics_findings(ph) -> list[str]:
    """The physics section in one or two sentences: the aims not met, the rate-dependent loss."""
    if not ph:
        return []
    missed = [a["aim"] for a in ph["aims"] if not a["met"]]
    out = [
        f"Physics: {len(ph['aims']) - len(missed)} of {len(ph['aims'])} aims met"
        + (f"; not met: {', '.join(missed)}." if missed else ".")
    ]
    better = [
        f"{key} ({r['model']}, AICc {r['delta_aicc']:+.1f})"
        for key, rows in (ph.get("rate_dependent") or {}).items()
        for r in rows
        if r.get("delta_aicc") is not None and r["delta_aicc"] <= -2
    ]
    out.append(
        "Rate-dependent losses (the dynamic chain) improve the fit by more than 2 in AICc on "
        + (", ".join(better) if better else "no block")
        + "."
    )
    fall = ph.get("supermalloy_fall")
    if fall and "reproduced" in fall:
        out.append(
            f"Supermalloy's small-signal permeability falls {fall['fall_measured']:.2f}x from "
            f"{fall['frequencies_hz'][0]:g} to {fall['frequencies_hz'][1]:g} c/s; the refit with "
            f"rate-dependent losses gives {fall['fall_dynamic']:.2f}x"
            + (" (reproduced within 20 %)." if fall["reproduced"] else ", not within 20 %.")
        )
    return out
