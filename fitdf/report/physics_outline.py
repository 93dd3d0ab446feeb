"""The report's "What the data say" section, as document blocks (:mod:`fitdf.report.document`).

Renders :func:`fitdf.report.physics.physics_record` and the claims of
:mod:`fitdf.report.physics_claims`: the best laws' residuals against the tables' printed
precision, the joint fits' constants against their catalogue ranges, the reversed column
both ways, the iron fraction and series resistance the joint fits imply, the rate-dependent
loss beside the static laws, Jiles-Atherton's mean field, and Supermalloy's series
permeability at matched flux.
"""

from __future__ import annotations

from fitdf.data.cores import STACKING_FACTOR
from fitdf.report.claims import text
from fitdf.report.document import IMG, TABLE, H, P, fmt, law, law_names
from fitdf.report.physics_claims import physics_claims
from fitdf.report.supermalloy import supermalloy_sentences

__all__ = ["physics_blocks", "PHYSICS"]

PHYSICS = "What the data say: the physics the laws leave out"


def _range(low, high) -> str:
    """``low-high``, or one number when they are equal."""
    return fmt(low) if low == high else f"{fmt(low)}-{fmt(high)}"


def _precision(claims: dict, names: dict) -> list:
    """The best laws' residuals against the tables' printed precision: the sentence, then a
    row per block and per cross-impedance direction (the claims' values)."""
    out = [P(text(claims["precision"]))] if claims["precision"] else []
    rows = [c["values"] for c in claims["precision_blocks"]]
    if rows:
        out.append(
            TABLE(
                [
                    "block",
                    "best law (AICc)",
                    "RMS complex",
                    "rounding alone",
                    "ratio",
                    "|DF| printed to",
                    "lead printed to (deg)",
                ],
                [
                    [
                        r["block"],
                        law(names, r["law"]),
                        r["rms"],
                        r["rounding"],
                        r["ratio"],
                        _range(r["df_low"], r["df_high"]),
                        _range(r["lead_low"], r["lead_high"]),
                    ]
                    for r in rows
                ],
            )
        )
    cross = [c["values"] for c in claims["precision_cross"]]
    if cross:
        out.append(
            TABLE(
                [
                    "prediction",
                    "law",
                    "RMS complex",
                    "the target's own best fit",
                    "ratio",
                    "target's rounding",
                    "ratio",
                ],
                [
                    [
                        f"{r['core']} {fmt(r['train'])} -> {fmt(r['test'])} ohm",
                        law(names, r["law"]),
                        r["rms"],
                        f"{fmt(r['own'])} ({law(names, r['own_law'])})",
                        r["ratio_own"],
                        r["rounding"],
                        r["ratio_rounding"],
                    ]
                    for r in cross
                ],
            )
        )
    return out


def _catalogue(catalogue: list, claims: dict, names: dict) -> list:
    """The joint fits' constants against their Appendix A ranges."""
    if not catalogue:
        return []
    rows = []
    for c in catalogue:
        value = f"{fmt(c['value'], 3)} {c['unit']}"
        low, high = c["value_range"]
        if low is not None and low != high:
            value += f" ({fmt(low, 3)}-{fmt(high, 3)} over the stacking factor)"
        hi = "" if c["range"][1] is None else fmt(c["range"][1], 3)
        verdict = "inside" if c["inside"] else "outside"
        if not c["inside"] and c.get("inside_for_some_stacking_factor"):
            verdict += f" at {STACKING_FACTOR:g}; inside for a stacking factor of the range"
        if c.get("determined"):
            verdict += f" (determined {c['determined']})"
        rows.append(
            [
                f"{c['core']} {c['quantity']}",
                law(names, c.get("law")),
                value,
                f"{fmt(c['range'][0], 3)}-{hi} {c['unit']}",
                verdict,
            ]
        )
    return [
        P(text(claims["catalogue"])),
        TABLE(["constant", "law", "fitted", "Appendix A", "against the range"], rows),
    ]


def _decision_text(d: dict) -> str:
    """One documented decision of the bundled data, said as one (its record's fields)."""
    values = lambda v: ", ".join(fmt(x, 3) for x in v)  # noqa: E731
    return (
        f"Table {d['table']} at {fmt(d['frequency_hz'], 3)} c/s ({fmt(d['source_impedance_ohm'], 3)} "
        f"ohm): the bundled data take the {d['column']} column ({d['rows']} rows) in reverse "
        'order, a documented decision of the dataset (datasets/README.md, "Decisions"), not a '
        "rule applied when the report runs. The cells stay as printed in appendix_b.csv; the "
        "default row policy fits the column reversed and says so row by row, and "
        "`--policy as_printed` fits it as printed (the table below). "
        f"Printed: {values(d['printed'])}; fitted: {values(d['fitted'])}."
    )


def _reversal(rev: dict, names: dict) -> list:
    decisions = rev.get("decisions") or []
    text = [_decision_text(d) for d in decisions]
    text += [
        f"The audit's column-order rule does not flag the {d['column']} column of {d['table']} at "
        f"{fmt(d['frequency_hz'], 3)} c/s ({d['verdict']}); the decision rests on the evidence "
        "in datasets/README.md."
        for d in decisions
        if d.get("verdict") != "reversed"
    ]
    if rev.get("finding"):
        text.append(
            "The audit's column-order rule, which on a user's file only flags a column and fits "
            "it as printed, reads it so too: " + " ".join(rev["finding"])
        )
    out = [
        P(
            " ".join(text)
            or "The audit finds no column printed in reverse order, and the data "
            "take none reversed."
        )
    ]
    rows = []
    for key, e in (rev.get("blocks") or {}).items():
        for law_name, d in e["default"].items():
            p = e["as_printed"].get(law_name) or {}
            rows.append(
                [
                    key,
                    law(names, law_name),
                    d["rms_complex"],
                    p.get("rms_complex"),
                    d["aicc"],
                    p.get("aicc"),
                ]
            )
    if rows:
        out.append(
            TABLE(
                [
                    "block",
                    "law",
                    "RMS, reversed (decision; default)",
                    "RMS, as printed",
                    "AICc, reversed (decision)",
                    "AICc, as printed",
                ],
                rows,
            )
        )
    return out


def _joint(joint: list, names: dict) -> list:
    rows = []
    for j in joint:
        sf = j.get("implied_stacking_factor") or {}
        implied = (
            f"{fmt(sf['low'], 2)}-{fmt(sf['high'], 2)} "
            f"({'within' if sf['consistent'] else 'outside'} {fmt(sf['range'][0], 2)}-{fmt(sf['range'][1], 2)})"
            if sf
            else "n/a"
        )
        lo, hi = j.get("r_series_interval") or (None, None)
        rows.append(
            [
                j["block"],
                law(names, j["law"]),
                implied,
                f"{fmt(j.get('r_series'), 3)} ({fmt(lo, 3)}-{fmt(hi, 3)})",
            ]
        )
    return [
        P(
            "The iron fraction of each core's section, from its best joint fit's peak flux and "
            "Appendix A's peak flux density B_p (the describing function determines the flux, not "
            "the section), and the series resistance of the circuit (winding, source and leads) "
            "that the joint fit of both source impedances determines, with its 68 % interval."
        ),
        TABLE(["block", "law", "implied stacking factor", "series resistance (ohm)"], rows),
    ]


def _k(row, name) -> str | None:
    """A loss coefficient in material units, "none" where the fit left it at its box's bottom."""
    value = row.get(f"k_{name[2:]}")
    if value is None:
        return None
    return f"<= {fmt(value, 2)} (none)" if name in (row.get("at_lower") or []) else fmt(value, 3)


def _rate_dependent(rd: dict, names: dict) -> list:
    out = [
        P(
            "Each block's best laws refitted with "
            "rate-dependent losses: Bertotti's classical eddy-current field k_cl dB/dt and excess "
            "field k_ex |dB/dt|^(1/2) on top of the law's loop, through the exact circuit (the "
            "`dynamic` chain), ranked by AICc beside the static fits; cv: leave-one-frequency-out "
            "cross-validation RMS where computed. k_cl in S m (sigma d^2 / 12), k_ex in "
            "A/m (T/s)^(-1/2); 'none': at the bottom of its box, the data find no such loss."
        )
    ]
    for key, rows in rd.items():
        dynamic_laws = {r["model"] for r in rows if "delta_aicc" in r}
        static = [r for r in rows if "delta_aicc" not in r]
        # the static fits of the refitted laws and the three best by AICc; every dynamic fit
        shown = {id(r) for r in static[:3]} | {id(r) for r in static if r["model"] in dynamic_laws}
        table = [
            [
                law(names, r["model"]),
                r["chain"],
                r["n_params"],
                r["rms_complex"],
                r["aicc"],
                r.get("delta_aicc"),
                r.get("cv_rms_complex"),
                _k(r, "c_cl"),
                _k(r, "c_ex"),
            ]
            for r in rows
            if id(r) in shown or "delta_aicc" in r
        ]
        out += [
            H(3, f"Rate-dependent loss on {key}"),
            TABLE(
                [
                    "law",
                    "chain",
                    "parameters",
                    "RMS complex",
                    "AICc",
                    "AICc - static",
                    "cv RMS",
                    "k_cl",
                    "k_ex",
                ],
                table,
            ),
        ]
    return out


def _supermalloy(rec: dict | None, names: dict) -> list:
    """Supermalloy at matched flux: the figure, what it finds (:mod:`fitdf.report.supermalloy`),
    and its numbers per frequency and per flux level."""
    if not rec:
        return []
    said = supermalloy_sentences(rec, lambda m: law(names, m))
    dyn = "dynamic" in rec["fits"]

    def k(x):  # a permeability in thousands
        return "n/a" if x is None else f"{x / 1e3:.3g}k"

    def pct(x):
        return "n/a" if x is None else f"{100 * x:.3g} %"

    small = [
        [
            r["frequency_hz"],
            fmt(1e3 * r["flux_vs"], 3),
            f"{k(r['mu'])} ({k(r['mu_lo'])}-{k(r['mu_hi'])})",
            f"{fmt(r['q'], 3)} ({fmt(r['q_lo'], 3)}-{fmt(r['q_hi'], 3) if r['q_hi'] is not None else 'inf'})",
            k(r["mu_static"]),
            k(r.get("mu_dynamic")),
            f"{fmt(r['rise'], 3)} ({fmt(r['rise_lo'], 3)}-{fmt(r['rise_hi'], 3)})",
            fmt(r["rise_static"], 3),
            fmt(r.get("rise_dynamic"), 3),
        ]
        for r in sorted(rec["small_flux"], key=lambda r: r["frequency_hz"])
    ]
    levels = [
        [
            fmt(1e3 * r["level_vs"], 3),
            ", ".join(f"{f:g}" for f in r["frequencies_hz"]),
            f"{k(r['mu_min'])}-{k(r['mu_max'])} ({fmt(r['ratio'], 3)}x)",
            "n/a"
            if r["slope_lo"] is None
            else f"{r['slope']:.3f} ({r['slope_lo']:.3f} to {r['slope_hi']:.3f})",
            pct(r["scatter"]),
            pct(r["precision"]),
            f"{r['slope_static']:.3f}" if r["slope_static"] is not None else "n/a",
            f"{r['slope_dynamic']:.3f}" if dyn and r.get("slope_dynamic") is not None else "n/a",
        ]
        for r in rec["frequency"]
    ]
    common = fmt(1e3 * rec["common_vs"], 3)
    out = [H(3, "Supermalloy's permeability at matched flux")]
    if rec.get("figure"):
        out.append(IMG(rec["figure"], "Supermalloy: series permeability and Q against flux"))
    out += [
        P(said["matched"]),
        P(said["small_flux"]),
        P(said["quality"]),
        TABLE(
            [
                "c/s",
                "smallest flux (mV s)",
                "mu' rows (printed precision)",
                "Q rows",
                "mu' static law",
                "mu' dynamic refit",
                f"rise of mu' to {common} mV s: rows",
                "static law",
                "dynamic refit",
            ],
            small,
        ),
        TABLE(
            [
                "flux level (mV s)",
                "c/s",
                "mu' rows (max/min)",
                "power-law slope s (95 %)",
                "scatter",
                "printed precision",
                "s static law",
                "s dynamic refit",
            ],
            levels,
        ),
    ]
    return out


def physics_blocks(res: dict, words=None) -> list:
    """The section (nothing when the record has none); ``words``: the report's
    (:func:`fitdf.report.words.report_words`), whose physics claims it shows."""
    ph = res.get("physics")
    if not ph:
        return []
    names = law_names(res)
    claims = (words or {}).get("claims", {}).get("physics") or physics_claims(res)
    return [
        H(2, PHYSICS),
        P(
            "What the laws reach, read against what the tables can show: the best law's RMS "
            "complex residual (least squares, the exact `voltage` chain, the default row "
            "policy) beside the RMS that rounding to the printed digits alone gives, and the "
            "cross-impedance predictions (averaged over the series resistance's prior) beside "
            "the target table's own best fit."
        ),
        *_precision(claims, names),
        H(3, "Material constants against the catalogue"),
        *_catalogue(ph.get("catalogue") or [], claims, names),
        H(3, "A column printed in reverse order"),
        *_reversal(ph.get("reversal") or {}, names),
        H(3, "Iron fraction and series resistance"),
        *_joint(ph.get("joint") or [], names),
        H(3, "Rate-dependent loss"),
        *_rate_dependent(ph.get("rate_dependent") or {}, names),
        *([P(text(claims["jiles_atherton"]))] if claims["jiles_atherton"] else []),
        *_supermalloy(ph.get("supermalloy"), names),
    ]
