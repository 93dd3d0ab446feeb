"""The report's "What the data say" section, as document blocks (:mod:`fitdf.report.document`).

Renders :func:`fitdf.report.physics.physics_record`: the aims met or not, the reversed column
both ways, the iron fraction and series resistance the joint fits imply, the rate-dependent
loss beside the static laws, Jiles-Atherton's mean field, and Supermalloy's series
permeability at matched flux.
"""

from __future__ import annotations

from fitdf.report.document import IMG, TABLE, H, P, fmt, law, law_names
from fitdf.report.supermalloy import supermalloy_sentences

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


def _reversal(rev: dict, names: dict) -> list:
    out = [P(" ".join(rev.get("finding") or ["The audit finds no column printed in reverse."]))]
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
                    "RMS, reversed (default)",
                    "RMS, as printed",
                    "AICc, reversed",
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
        *_ja(ph.get("jiles_atherton") or []),
        *_supermalloy(ph.get("supermalloy"), names),
    ]
