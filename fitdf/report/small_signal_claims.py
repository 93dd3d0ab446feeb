"""The small-signal study's sentences (:mod:`fitdf.report.small_signal_study`), each a claim
made again by the tests from the fields of ``small_signal_evidence`` it reads
(:mod:`fitdf.report.claims`).

``small_signal.noise`` (one per block of the noise study): the noise laws in the order of
their evidence, the Bayes factors over constant scales, the RMS of each posterior's point
estimate, the reading law's resolutions, and the law's parameters the noise law moves.
``small_signal.resolutions``: the reading law's resolutions on one core's tables at two
source impedances. ``small_signal.low_field`` (one per block of the low-field study): the
low-field law against the law it extends by AICc, cross-validation and the evidence.
``small_signal.worst_rows``: the rows every law misses most, with the low-field law and
against the readings a passive core gives. ``small_signal.summary``: the noise laws' and the
low-field law's verdicts in one sentence, for the Findings.
"""

from __future__ import annotations

import numpy as np

from fitdf.inference.ranking import bayes_factor_scale, log_bayes_factor
from fitdf.report.claims import paragraph, rule, say

__all__ = ["MOVED_FACTOR", "small_signal_claims", "small_signal_findings"]

#: A parameter "moves" between two noise laws when its posterior median changes by more than
#: this factor (either way): well beyond the 68 % intervals of the determined parameters
#: (``lambda_s``, ``gain`` and ``r_series`` within a few per cent), within those of the
#: undetermined ones.
MOVED_FACTOR = 1.5


def _moved(base: dict, other: dict) -> list[str]:
    """The parameters whose posterior median differs by more than :data:`MOVED_FACTOR`."""
    out = []
    for name, (_, m0, _) in base["parameters"].items():
        m1 = other["parameters"][name][1]
        if m0 > 0 and m1 > 0 and max(m0 / m1, m1 / m0) > MOVED_FACTOR:
            out.append(name)
    return out


@rule("small_signal.noise", record="small_signal_evidence/noise/{index}")
def _noise(record, index):
    """One block's noise laws ranked by the evidence."""
    if not record:
        return None
    runs = record["runs"]
    unconverged = [n for n, r in runs.items() if not r["converged"]]
    if unconverged:
        return say(
            "Table {block}: the noise laws' evidence is not stated, since the posterior under "
            "{unconverged:and} did not converge.",
            block=record["block"],
            unconverged=unconverged,
        )
    order = sorted(runs, key=lambda n: -runs[n]["log_evidence"])
    values = {"block": record["block"], "law": record["law"], "order": order}
    template = (
        "Table {block}, {law:law} under each fitted noise law: the evidence ranks them {order:and}"
    )
    if "constant" in runs:
        parts = []
        for i, n in enumerate(x for x in order if x != "constant"):
            lnb, err = log_bayes_factor(runs[n], runs["constant"])
            values.update({f"n_{i}": n, f"lnb_{i}": lnb, f"err_{i}": err})
            parts.append(f"{{n_{i}}} by ln B = {{lnb_{i}:.1f}} ± {{err_{i}:.1f}}")
        template += " (over constant scales: " + "; ".join(parts) + ")"
    best = order[0]
    values.update(
        best=best,
        rms_best=runs[best]["rms_complex"],
        lsq=record["lsq_rms_complex"],
    )
    template += (
        ". The posterior's point estimate under {best} has RMS {rms_best:.3f} (least squares at "
        "the printed scales: {lsq:.3f})"
    )
    if best != "constant" and "constant" in runs:
        moved = _moved(runs["constant"], runs[best])
        values.update(rms_const=runs["constant"]["rms_complex"], factor=MOVED_FACTOR)
        template += ", under constant scales {rms_const:.3f}"
        if moved:
            values["moved"] = moved
            template += (
                "; between the two, the posterior medians of {moved:and} move by more than a "
                "factor {factor:g}"
            )
        else:
            template += "; between the two, no parameter's median moves by a factor {factor:g}"
    if "reading" in runs:
        noise = runs["reading"]["noise"]
        values.update(r_m=noise["r_m"][1] * 1e3, r_p=noise["r_p"][1] * 1e3)
        template += (
            ". The reading law's resolutions (posterior medians) are {r_m:.1f} mV and "
            "{r_p:.1f} mV of output"
        )
    return say(template + ".", **values)


@rule("small_signal.low_field", record="small_signal_evidence/low_field/{index}")
def _low_field(record, index):
    """One block's low-field law against the law it extends."""
    if not record:
        return None
    post, base = record["posterior"], record["base_posterior"]
    values = {
        "block": record["block"],
        "law": record["law"],
        "base": record["base"],
        "aicc": record["lsq"]["aicc"],
        "base_aicc": record["base_lsq"]["aicc"],
        "cv": record["lsq"]["cv_rms_complex"],
        "base_cv": record["base_lsq"]["cv_rms_complex"],
    }
    template = (
        "Table {block}: {law:law} against {base:law}, AICc {aicc:.1f} against {base_aicc:.1f}, "
        "held-out RMS {cv:.3f} against {base_cv:.3f}"
    )
    if not post["converged"]:
        return say(
            template + "; its posterior did not converge, so no evidence is stated.", **values
        )
    lnb, err = log_bayes_factor(post, base)
    winner, loser = (record["law"], record["base"]) if lnb >= 0 else (record["base"], record["law"])
    values.update(
        lnb=abs(lnb),
        err=err,
        winner=winner,
        loser=loser,
        scale=bayes_factor_scale(lnb),
        rms=post["rms_complex"],
        base_rms=base["rms_complex"],
    )
    template += (
        "; the evidence favours {winner:code} over {loser:code} by ln B = {lnb:.1f} ± {err:.2f} "
        "({scale}), and the posteriors' point estimates have RMS {rms:.3f} against {base_rms:.3f}."
    )
    return say(template, **values)


@rule(
    "small_signal.resolutions",
    noise="small_signal_evidence/noise",
    ohm="blocks/*/source_impedance_ohm",
    core="blocks/*/core",
)
def _resolutions(noise, ohm, core):
    """The reading law's resolutions on one core's tables at its lowest and highest source
    impedance: an analyser's resolution does not depend on the source impedance."""
    by_core = {}
    for rec in noise or []:
        k, run = rec["block"], rec["runs"].get("reading")
        if run and run["converged"] and len(ohm.get(k) or []) == 1:  # a single table
            by_core.setdefault(core[k], []).append((ohm[k][0], k, run["noise"]))
    parts, values = [], {}
    for name, tables in by_core.items():
        (lo_ohm, lo, lo_r), (hi_ohm, hi, hi_r) = min(tables), max(tables)
        if lo_ohm == hi_ohm:
            continue
        i = len(parts)
        values.update(
            {
                f"core_{i}": name.capitalize(),
                f"hi_ohm_{i}": hi_ohm,
                f"hi_{i}": hi,
                f"lo_ohm_{i}": lo_ohm,
                f"lo_{i}": lo,
                f"hi_m_{i}": hi_r["r_m"][1] * 1e3,
                f"hi_p_{i}": hi_r["r_p"][1] * 1e3,
                f"lo_m_{i}": lo_r["r_m"][1] * 1e3,
                f"lo_p_{i}": lo_r["r_p"][1] * 1e3,
                f"ratio_m_{i}": hi_r["r_m"][1] / lo_r["r_m"][1],
                f"ratio_p_{i}": hi_r["r_p"][1] / lo_r["r_p"][1],
            }
        )
        parts.append(
            f"{{core_{i}}} at {{hi_ohm_{i}:g}} ohm ({{hi_{i}}}) needs resolutions of "
            f"{{hi_m_{i}:.1f}} and {{hi_p_{i}:.1f}} mV of output, {{ratio_m_{i}:.0f}} and "
            f"{{ratio_p_{i}:.0f}} times its {{lo_ohm_{i}:g}} ohm table {{lo_{i}}}'s "
            f"({{lo_m_{i}:.1f}} and {{lo_p_{i}:.1f}} mV)"
        )
    if not parts:
        return None
    return say(
        "Under the reading law, "
        + "; ".join(parts)
        + ". One analyser read both tables, and its resolution does not depend on the source "
        "impedance; the tables' near-repeated readings agree far more closely than that (the "
        "measurement-noise page of the docs). Behind the source resistance the reading law "
        "takes up the law's miss at small signals as much as the tables' reading error.",
        **values,
    )


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@rule("small_signal.worst_rows", low="small_signal_evidence/low_field")
def _worst_rows(low):
    """The rows every law misses most, with the low-field law, and how far outside the readings
    a passive core can give they lie."""
    rows = [r for rec in low or [] for r in rec.get("worst_rows") or []]
    if not rows:
        return None
    old = [r["report_miss"] for r in rows]
    new = [r["miss"] for r in rows]
    dist = [r["passive_distance"] for r in rows]
    far = max(rows, key=lambda r: r["passive_distance"])
    counts = {len(rec["worst_rows"]) for rec in low if rec.get("worst_rows")}
    values = {
        "n": len(rows),
        "per": max(counts),
        "blocks": [rec["block"] for rec in low if rec.get("worst_rows")],
        "law": low[0]["law"],
        "old": _rms(old),
        "new": _rms(new),
        "ratio": _rms(new) / _rms(old),
        "n_out": sum(d > 0 for d in dist),
        "lie": "lies" if sum(d > 0 for d in dist) == 1 else "lie",
        "floor": _rms(dist),
    }
    template = (
        "The rows every law of the report misses most ({n}: the worst {per} of each of "
        "{blocks:and}) have RMS miss {old:.3f} by each row's closest law and {new:.3f} by "
        "{law:law} ({ratio:.2f} of it); {n_out} of them {lie} outside the readings a passive "
        "core gives behind the fitted circuit "
        "(RMS distance over the {n}: {floor:.3f})"
    )
    if far["passive_distance"] > 0:
        values.update(
            far_table=far["table"],
            far_f=far["frequency_hz"],
            far_v=far["input_v"],
            far_d=far["passive_distance"],
            far_miss=far["miss"],
        )
        template += (
            ", farthest {far_table} at {far_f:g} c/s and {far_v:g} V, by {far_d:.3f}, which "
            "{law:code} misses by {far_miss:.3f} (no passive core behind that circuit comes closer)"
        )
    return say(template + ".", **values)


@rule(
    "small_signal.summary",
    noise="small_signal_evidence/noise",
    low="small_signal_evidence/low_field",
)
def _summary(noise, low):
    """Both parts of the study in one sentence: where each noise law wins, where the low-field
    law wins."""
    if not noise and not low:
        return None
    parts, values = [], {}
    if noise:
        wins = {}
        for rec in noise:
            runs = rec["runs"]
            if all(r["converged"] for r in runs.values()):
                best = max(runs, key=lambda n: runs[n]["log_evidence"])
                wins.setdefault(best, []).append(rec["block"])
        for i, (n, blocks) in enumerate(sorted(wins.items())):
            values.update({f"noise_{i}": n, f"noise_blocks_{i}": blocks})
            parts.append(
                f"the {{noise_{i}}} noise law has the highest evidence on {{noise_blocks_{i}:and}}"
            )
    if low:
        done = [r for r in low if r["posterior"]["converged"]]
        better = [
            r["block"] for r in done if log_bayes_factor(r["posterior"], r["base_posterior"])[0] > 0
        ]
        values.update(law=low[0]["law"], base=low[0]["base"], n_better=len(better), n=len(done))
        part = "{law:law} has more evidence than {base:law} on {n_better} of {n} tables"
        if better:
            values["better"] = better
            part += " ({better:and})"
        parts.append(part)
    return say("Small-signal study: " + "; ".join(parts) + ".", **values)


def small_signal_claims(results: dict) -> dict:
    """The study's claims by part, each one paragraph (a law named in full once): ``noise``
    and ``low_field`` (a sentence per block), ``resolutions`` and ``worst_rows``."""
    rec = results.get("small_signal_evidence") or {}
    return {
        "noise": paragraph(
            results,
            *[("small_signal.noise", {"index": i}) for i in range(len(rec.get("noise") or []))],
        ),
        "low_field": paragraph(
            results,
            *[
                ("small_signal.low_field", {"index": i})
                for i in range(len(rec.get("low_field") or []))
            ],
        ),
        "resolutions": paragraph(results, ("small_signal.resolutions", {})),
        "worst_rows": paragraph(results, ("small_signal.worst_rows", {})),
    }


def small_signal_findings(results: dict) -> list:
    """The study in the Findings: one statement, or none without a study."""
    if not results.get("small_signal_evidence"):
        return []
    p = paragraph(results, ("small_signal.summary", {}))
    return [p] if p else []
