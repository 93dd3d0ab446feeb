"""The report's "What the data say" section, as document blocks (:mod:`fitdf.report.document`).

Renders :func:`fitdf.report.physics.physics_record`: the aims met or not, the reversed column
both ways, the iron fraction and series resistance the joint fits imply, the rate-dependent
loss beside the static laws and Supermalloy's small-signal permeability, Jiles-Atherton's
mean field.
"""

from __future__ import annotations

from fitdf.report.document import TABLE, H, P, fmt, law, law_names
from fitdf.report.physics import FALL_TOLERANCE

__all__ = ["physics_blocks", "PHYSICS"]

PHYSICS = "What the data say: the physics the laws leave out"


def _aims(aims: list, names: dict) -> list:
    rows = []
    for a in aims:
        if "target" in a:
            value = fmt(a["value"], 3)
            if a.get("as_printed"):
                value += f" (as printed: {fmt(a['as_printed']['value'], 3)})"
            if a.get("spread") and None not in a["spread"]:
                value += f" (over the resistance prior {fmt(a['spread'][0], 3)}-{fmt(a['spread'][1], 3)})"
            target = f"<= {fmt(a['target'], 3)}"
        else:
            value = f"{fmt(a['value'], 3)} {a['unit']}"
            low, high = a["value_range"]
            if low is not None and low != high:
                value += f" ({fmt(low, 3)}-{fmt(high, 3)} over the stacking factor)"
            hi = "" if a["range"][1] is None else fmt(a["range"][1], 3)
            target = f"{fmt(a['range'][0], 3)}-{hi} {a['unit']}"
        met = "met" if a["met"] else "not met"
        if not a["met"] and a.get("inside_for_some_stacking_factor"):
            met += " at 0.85; inside for a stacking factor of the range"
        if a.get("determined"):
            met += f" (determined {a['determined']})"
        rows.append([a["aim"], law(names, a.get("law")), value, target, met])
    return [TABLE(["aim", "law", "value", "aim's bound", "verdict"], rows)]


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


def _fall(f: dict | None, names: dict) -> list:
    if not f:
        return []
    lo, hi = f["frequencies_hz"]
    ev = f["evidence"]
    q = "; ".join(
        f"{k} c/s: {', '.join(fmt(v, 2) for v in vals)}"
        for k, vals in ev["q_smallest_rows"].items()
    )
    verdict = (
        f"reproduces it within {FALL_TOLERANCE:.0%}"
        if f.get("reproduced")
        else f"does not reproduce it within {FALL_TOLERANCE:.0%}"
    )
    text = (
        f"Supermalloy's small-signal permeability (Table B.4's smallest input at {lo:g} and {hi:g} c/s, "
        f"inverted through the circuit of Fig 5.10 with the fit's own series resistance and gain) falls "
        f"{fmt(f['fall_measured'], 3)}x in the data ({fmt(f['measured'][0], 3)} -> {fmt(f['measured'][1], 3)}); "
        f"the static fit {law(names, f['static_model'])} gives {fmt(f['fall_static'], 3)}x"
    )
    if "fall_dynamic" in f:
        text += (
            f", its refit with rate-dependent losses {fmt(f['fall_dynamic'], 3)}x: it {verdict}."
        )
    else:
        text += "."
    why = (
        f" What the data say of the fall: the quality factor of the two smallest readings is {q} "
        "(a fall resting on the smallest reading alone if only it is nearly lossless), and the "
        f"flux amplitude at the {lo:g} c/s row is {fmt(ev['flux_vs'][0], 3)} V s against "
        f"{fmt(ev['flux_vs'][1], 3)} V s at {hi:g} c/s: part of the fall is the smaller amplitude, "
        "which a rate-independent law already follows, and a loss that grows with frequency has to "
        "keep the low-frequency permeability while taking the high-frequency one down."
    )
    return [P(text + why)]


def _ja(ja: list) -> list:
    at = [j for j in ja if j.get("at_limit")]
    if not at:
        return []
    where = ", ".join(j["block"] for j in at)
    return [
        P(
            f"Jiles-Atherton's mean-field ratio zeta sits at its physical limit 1 on {where}: the "
            "anhysteretic curve's initial susceptibility diverges there, and the data determine only a "
            f"lower bound on it. {at[0]['warning'][0] if at[0]['warning'] else ''}"
        )
    ]


def physics_blocks(res: dict) -> list:
    """The section (nothing when the record has none)."""
    ph = res.get("physics")
    if not ph:
        return []
    names = law_names(res)
    met = sum(a["met"] for a in ph["aims"])
    return [
        H(2, PHYSICS),
        P(
            f"The aims on what the laws reach, {met} of {len(ph['aims'])} met (best law, least squares, the "
            "exact `voltage` chain, the default row policy; cross-impedance averaged over the series "
            "resistance's prior; the material constants of each core's best joint fit)."
        ),
        *_aims(ph["aims"], names),
        H(3, "A column printed in reverse order"),
        *_reversal(ph.get("reversal") or {}, names),
        H(3, "Iron fraction and series resistance"),
        *_joint(ph.get("joint") or [], names),
        H(3, "Rate-dependent loss"),
        *_rate_dependent(ph.get("rate_dependent") or {}, names),
        *_fall(ph.get("supermalloy_fall"), names),
        *_ja(ph.get("jiles_atherton") or []),
    ]
