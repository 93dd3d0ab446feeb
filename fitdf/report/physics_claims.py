"""The physics section's sentences, each a claim of :mod:`fitdf.report.claims` on the fields of
``results.json`` (``physics``, built by :mod:`fitdf.report.physics`).

The best law's residual against the tables' printed precision, per block
(``physics.precision_block``), per cross-impedance direction (``physics.precision_cross``) and
in one sentence (``physics.precision``); the joint fits' constants against their catalogue
ranges; the rate-dependent refits that lower AICc; Jiles-Atherton's mean field at its limit.
"""

from __future__ import annotations

from fitdf.data.cores import STACKING_FACTOR, STACKING_FACTOR_RANGE
from fitdf.models import get_model
from fitdf.report.claims import paragraph, rule, say, span
from fitdf.report.conclusion import LSQ, QUANTITY_NAMES
from fitdf.report.criteria import AICC_TIE, best_law
from fitdf.report.supermalloy import supermalloy_sentences

__all__ = ["physics_findings", "physics_claims", "precision_rows"]

_RMS = {"rms": "blocks/*/ranking_lsq/*/rms_complex", **LSQ}


def _best_rms(models, aicc, rms, key):
    """``(law, RMS complex)`` of block ``key``'s best law, or ``(None, None)``."""
    law = best_law(models.get(key) or [], aicc.get(key) or [])
    return (law, rms[key][models[key].index(law)]) if law else (None, None)


# ------------------------------------------------------------------ the printed precision
@rule("physics.precision_block", precision="physics/precision/{block}", **_RMS)
def _precision_block(precision, models, aicc, rms, block):
    """One block's best residual against the RMS of rounding to the printed digits."""
    law, value = _best_rms(models, aicc, rms, block)
    if law is None or not precision:
        return None
    rounding = precision["rounding_rms_complex"]
    return say(
        "{block}: the best law by AICc, {law:law}, has an RMS complex residual of {rms:.4f}, "
        "{ratio:.1f} times the {rounding:.4f} that rounding to the printed digits alone gives "
        "(|DF| printed to "
        + span(precision["df_step"][0], precision["df_step"][1], "g", "df_low", "df_high")
        + ", the lead to "
        + span(
            precision["phase_step_deg"][0],
            precision["phase_step_deg"][1],
            "g",
            "lead_low",
            "lead_high",
        )
        + " deg).",
        block=block,
        law=law,
        rms=value,
        rounding=rounding,
        ratio=value / rounding,
        df_low=precision["df_step"][0],
        df_high=precision["df_step"][1],
        lead_low=precision["phase_step_deg"][0],
        lead_high=precision["phase_step_deg"][1],
    )


@rule(
    "physics.precision_cross",
    direction="cross_impedance/{index}",
    rounding="physics/precision/*/rounding_rms_complex",
    **_RMS,
)
def _precision_cross(direction, rounding, models, aicc, rms, index):
    """A cross-impedance prediction against the target table's own best fit and its rounding."""
    if not direction or not direction.get("rows"):
        return None
    r, test = direction["rows"][0], direction["test_block"]
    own_law, own = _best_rms(models, aicc, rms, test)
    if own_law is None or (rounding or {}).get(test) is None:
        return None
    return say(
        "{core} {train:g} -> {test:g} ohm: {law:law} predicts {test_block} with an RMS complex "
        "residual of {rms:.3f} (averaged over the series resistance's prior), {ratio_own:.1f} "
        "times the best fit to {test_block} itself ({own_law:law}, {own:.4f}) and "
        "{ratio_rounding:.0f} times its rounding ({rounding:.4f}).",
        core=direction["core"].capitalize(),
        train=direction["train_ohm"],
        test=direction["test_ohm"],
        law=r["model"],
        test_block=test,
        rms=r["predict_rms_complex"],
        own_law=own_law,
        own=own,
        ratio_own=r["predict_rms_complex"] / own,
        rounding=rounding[test],
        ratio_rounding=r["predict_rms_complex"] / rounding[test],
    )


@rule(
    "physics.precision",
    rounding="physics/precision/*/rounding_rms_complex",
    repeats="physics/precision/*/repeats",
    **_RMS,
)
def _precision(rounding, repeats, models, aicc, rms):
    """The best laws' residuals against the printed precision, and the repeated readings."""
    ratios = {}
    for key, r in (rounding or {}).items():
        law, value = _best_rms(models, aicc, rms, key)
        if law is not None and r:
            ratios[key] = (value / r, r)
    if not ratios:
        return None
    values = {
        "low": min(q for q, _ in ratios.values()),
        "high": max(q for q, _ in ratios.values()),
        "r_low": min(r for _, r in ratios.values()),
        "r_high": max(r for _, r in ratios.values()),
        "n": len(ratios),
    }
    template = (
        "Against the tables' printed precision: the best law's RMS complex residual is "
        + span(values["low"], values["high"], ".1f", "low", "high")
        + " times the "
        + span(values["r_low"], values["r_high"], ".4f", "r_low", "r_high")
        + " that rounding to the printed digits alone gives, on "
        + ("the {n} block" if len(ratios) == 1 else "the {n} blocks")
    )
    reached = [k for k, (q, _) in ratios.items() if q <= 1]
    if reached:
        template += "; on {reached:and} it reaches the rounding"
        values["reached"] = reached
    template += "."
    seen = {}
    for rows in (repeats or {}).values():
        for rep in rows or []:
            key = (rep.get("core"), rep.get("source_impedance_ohm"), rep["frequency_hz"])
            seen[key + (rep["input_v"],)] = rep
    differ = [r for r in seen.values() if not r["identical"]]
    alike = [r for r in seen.values() if r["identical"]]
    no_spread = "so the tables give no spread of repeated readings to set beside the residuals."
    if differ:
        values.update(
            n_rep=len(differ),
            s_low=min(r["spread"] for r in differ),
            s_high=max(r["spread"] for r in differ),
        )
        template += (
            " The {n_rep} readings the tables repeat differ by an RMS of "
            + span(values["s_low"], values["s_high"], ".3f", "s_low", "s_high")
            + " about their means: the scatter of a reading."
        )
    elif not alike:
        template += " The tables repeat no reading, " + no_spread
    if alike:
        values.update(
            n_alike=len(alike),
            alike=[
                f"{', '.join(r['tables'])} {r['frequency_hz']:g} c/s {r['input_v']:g} V"
                for r in alike
            ],
        )
        template += (
            " The tables print one reading more than once with the same numbers "
            "({alike:and}): a repeated print, not a second reading"
            if len(alike) == 1
            else " The tables print {n_alike} readings more than once with the same numbers "
            "({alike:and}): repeated prints, not second readings"
        ) + (", " + no_spread if not differ else ".")
    return say(template, **values)


def precision_rows(results: dict) -> tuple[list, list]:
    """The claims of the precision tables: one per block, one per cross-impedance direction."""
    blocks = [
        c
        for key in (results.get("physics") or {}).get("precision") or {}
        for c in paragraph(results, ("physics.precision_block", {"block": key}))
    ]
    cross = [
        c
        for i in range(len(results.get("cross_impedance") or []))
        for c in paragraph(results, ("physics.precision_cross", {"index": i}))
    ]
    return blocks, cross


# ------------------------------------------------------------------ the catalogue ranges
@rule(
    "physics.catalogue",
    inside="physics/catalogue/*/inside",
    inside_some="physics/catalogue/*/inside_for_some_stacking_factor",
    quantity="physics/catalogue/*/quantity",
)
def _catalogue(inside, inside_some, quantity):
    if not inside:
        return None
    names = list(dict.fromkeys(QUANTITY_NAMES.get(q, q) for q in quantity))
    return say(
        "{n_in} of the {n} catalogue constants ({names:and} of each core's best joint fit) lie "
        "inside their Appendix A range at the nominal stacking factor {sf:g}, and {n_some} for "
        "some stacking factor of {sf_low:g}-{sf_high:g}.",
        n_in=sum(bool(i) for i in inside),
        n=len(inside),
        names=names,
        sf=STACKING_FACTOR,
        n_some=sum(bool(i) for i in inside_some),
        sf_low=STACKING_FACTOR_RANGE[0],
        sf_high=STACKING_FACTOR_RANGE[1],
    )


# ------------------------------------------------------------------ rate-dependent losses
@rule(
    "physics.rate_dependent",
    models="physics/rate_dependent/*/*/model",
    delta="physics/rate_dependent/*/*/delta_aicc",
)
def _rate_dependent(models, delta):
    """The dynamic refits that lower AICc by the tie margin or more."""
    if not models:
        return None
    better = [
        (key, m, d)
        for key in models
        for m, d in zip(models[key] or [], delta[key] or [])
        if d is not None and d <= -AICC_TIE
    ]
    values = {"tie": AICC_TIE}
    parts = []
    for i, (key, m, d) in enumerate(better):
        parts.append(f"{{block_{i}}} ({{law_{i}:code}}, AICc {{d_{i}:+.1f}})")
        values.update({f"block_{i}": key, f"law_{i}": m, f"d_{i}": d})
    return say(
        "Rate-dependent losses (the dynamic chain) lower AICc by {tie:g} or more on "
        + (", ".join(parts) if parts else "no block")
        + ".",
        **values,
    )


#: Jiles-Atherton's mean-field ratio at its physical limit (the top of its ``limits``).
_ZETA_LIMIT = next(p for p in get_model("jiles_atherton").params if p.name == "zeta").limits[1]


@rule(
    "physics.jiles_atherton",
    block="physics/jiles_atherton/*/block",
    at_limit="physics/jiles_atherton/*/at_limit",
    warning="physics/jiles_atherton/*/warning",
)
def _ja(block, at_limit, warning):
    at = [i for i, a in enumerate(at_limit or []) if a]
    if not at:
        return None
    first = (warning[at[0]] or [""])[0]
    return say(
        "Jiles-Atherton's mean-field ratio zeta sits at its physical limit {limit:g} on "
        "{blocks:and}: the anhysteretic curve's initial susceptibility diverges there, and the "
        "data determine only a lower bound on it." + (" {warning}" if first else ""),
        limit=_ZETA_LIMIT,
        blocks=[block[i] for i in at],
        warning=first,
    )


# ------------------------------------------------------------------ the section's statements
def physics_claims(results: dict) -> dict:
    """The physics section's claims by part: ``precision`` (a paragraph), ``precision_blocks``
    and ``precision_cross`` (the tables' rows), ``catalogue``, ``jiles_atherton``."""
    blocks, cross = precision_rows(results)
    return {
        "precision": paragraph(results, ("physics.precision", {})),
        "precision_blocks": blocks,
        "precision_cross": cross,
        "catalogue": paragraph(results, ("physics.catalogue", {})),
        "jiles_atherton": paragraph(results, ("physics.jiles_atherton", {})),
    }


def physics_findings(results: dict) -> list:
    """The physics section in the Findings: the residuals against the printed precision, the
    rate-dependent loss, Supermalloy's small-signal permeability."""
    if not results.get("physics"):
        return []
    out = [
        paragraph(results, ("physics.precision", {})),
        paragraph(results, ("physics.rate_dependent", {})),
    ]
    fall = _supermalloy_finding(results["physics"].get("supermalloy"))
    return [p for p in out if p] + ([fall] if fall else [])


def _supermalloy_finding(rec) -> str | None:
    """Supermalloy at matched flux, the Findings' bullet (:mod:`fitdf.report.supermalloy`)."""
    return supermalloy_sentences(rec)["finding"] if rec else None
