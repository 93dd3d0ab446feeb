"""The report's limit-cycle section (Tables 5.1, 5.2), as document blocks (:mod:`fitdf.report.document`).

Renders the ``limit_cycles`` record of :func:`fitdf.report.sections.limit_cycle_section`:
the comparison's own sentences first (:func:`fitdf.limit_cycle_tables.limit_cycle_statements`, stored
in the record), then the figure, the unscaled prediction row by row, the agreement per
setting and block, the scales (per block in-sample, held out, joint in-sample), the critical
gains against the measured brackets, the trends, and the held-out rows.
"""

from __future__ import annotations

from fitdf.report.document import DETAILS, IMG, TABLE, UL, H, P, _records_table, fmt, law, law_names

__all__ = ["LIMIT", "limit_blocks"]

LIMIT = "Limit cycles (Tables 5.1, 5.2)"

#: Words for the settings of the scales in the section's tables.
SETTING_LABELS = {
    "unscaled": "unscaled (alpha = beta = 1)",
    "held_out": "held out (scales fitted to the other three blocks)",
    "given": "scales as given",
}

_ROW_COLUMNS = [
    ("table", "table"),
    ("system_gain", "system gain"),
    ("dies_out", "dies out (printed)"),
    ("amplitude_v", "amplitude measured (V)"),
    ("amplitude_pred", "amplitude predicted"),
    ("amplitude_sim", "amplitude simulated"),
    ("amplitude_ratio", "predicted / measured"),
    ("omega_rad_s", "omega measured (rad/s)"),
    ("omega_pred", "omega predicted"),
    ("omega_sim", "omega simulated"),
    ("omega_ratio", "predicted / measured"),
    ("sim_state", "simulated loop"),
    ("extrapolated", "outside the fitted data"),
]


def _intro(lc, res) -> str:
    laws = (
        ", ".join(law(law_names(res), m) for m in lc["models_offered"])
        if lc.get("models_offered")
        else "all laws"
    )
    return (
        "The thesis's analog-computer loop (Fig 5.12, plant "
        f"`{(lc.get('attrs') or {}).get('plant', '')}`) predicted by harmonic balance from the "
        "fits of the matching Appendix B tables (`fitdf.limit_cycle_tables.thesis_limit_cycle_comparison`; "
        f"per block the lowest-AICc law among {laws}) against the measured Tables 5.1 and 5.2. "
        "The thesis prints neither the computer's time scale nor what its system gain "
        "multiplies: *unscaled* takes both as 1 and fits nothing to the tables; *held out* "
        "fits a time scale alpha (the plant run as G(s/alpha)) and a gain scale beta to three "
        "blocks and predicts the fourth. The loop is also simulated in time with the same "
        "fitted cores, started on the predicted cycle: harmonic balance against the "
        "simulation is the describing-function approximation, the simulation against the "
        "table is the rest (the law, the loop's assumptions, the scales)."
    )


def _agreement_table(attrs) -> list:
    rows = []
    for setting, per in attrs.get("agreement", {}).items():
        for block, a in per.items():
            td = (attrs.get("time_domain") or {}).get(setting, {}).get(block, {})
            rows.append(
                [
                    SETTING_LABELS.get(setting, setting),
                    block,
                    f"{a['rows_predicted']} of {a['rows_oscillating']}",
                    a["median_amplitude_ratio"],
                    a["rms_log_amplitude_ratio"],
                    a["amplitude_level_consistent"],
                    a["median_omega_ratio"],
                    a["rms_log_omega_ratio"],
                    a["omega_level_consistent"],
                    td.get("rms_log_amplitude_hb_over_sim"),
                    td.get("rms_log_omega_hb_over_sim"),
                ]
            )
    return [
        TABLE(
            [
                "setting",
                "block",
                "rows predicted",
                "amplitude: median predicted / measured",
                "RMS log ratio",
                "level within the rows' scatter (95 %)",
                "omega: median predicted / measured",
                "RMS log ratio",
                "level within the rows' scatter (95 %)",
                "harmonic balance vs simulated: RMS log ratio, amplitude",
                "omega",
            ],
            rows,
        )
    ]


def _scales_table(sc) -> list:
    rows = [
        [f"{t} alone (in-sample)", s["alpha"], s["beta"], s["rms_phase_deg"], s["n_rows"]]
        for t, s in sc["per_block"].items()
    ]
    rows += [
        [
            f"for {t}: fitted to {', '.join(s['fitted_on'])} (held out)",
            s["alpha"],
            s["beta"],
            s["rms_phase_deg"],
            s["n_rows"],
        ]
        for t, s in sc["held_out"].items()
    ]
    j = sc["joint"]
    rows.append(["all blocks (in-sample)", j["alpha"], j["beta"], j["rms_phase_deg"], j["n_rows"]])
    if sc.get("given"):
        rows.append(["given", sc["given"]["alpha"], sc["given"]["beta"], None, None])
    return [
        TABLE(
            [
                "scales fitted to",
                "time scale alpha",
                "gain scale beta",
                "RMS phase left (deg, on the rows fitted)",
                "rows",
            ],
            rows,
        )
    ]


def _critical_table(attrs) -> list:
    cg = attrs.get("critical_gains") or []
    settings = list(cg[0]["predicted"]) if cg else []
    header = ["block", "largest gain that died out", "smallest gain that oscillated"]
    for s in settings:
        header += [f"predicted, {SETTING_LABELS.get(s, s)}", "position"]
    rows = []
    for c in cg:
        row = [c["table"], c["measured_dies_out_at"], c["measured_lowest_oscillating"]]
        for s in settings:
            p = c["predicted"][s]
            row += [p["critical_gain"], p["position"]]
        rows.append(row)
    dead = [
        [d["table"], d["system_gain"]]
        + [
            f"{fmt(v['predicted_to_oscillate'])}"
            + (f"; simulated: {v['sim_state']}" if v.get("sim_state") else "")
            for v in d["settings"].values()
        ]
        for d in attrs.get("dies_out_rows") or []
    ]
    dead_header = ["row marked dies out", "system gain"] + [
        f"predicted to oscillate, {SETTING_LABELS.get(s, s)}" for s in settings
    ]
    return [TABLE(header, rows), TABLE(dead_header, dead)]


def _trend_table(attrs) -> list:
    rows = []
    for setting, per in (attrs.get("trends") or {}).items():
        for block, t in per.items():
            row = [SETTING_LABELS.get(setting, setting), block, t["rows"]]
            for q in ("amplitude", "omega"):
                lo, hi = t[q]["measured_slope_interval"]
                row += [
                    f"{fmt(t[q]['measured_slope'], 3)} ({fmt(lo, 3)} to {fmt(hi, 3)})",
                    t[q]["predicted_slope"],
                    t[q]["consistent"],
                ]
            rows.append(row)
    return [
        TABLE(
            [
                "setting",
                "block",
                "rows",
                "amplitude exponent in gain, measured (95 %)",
                "predicted",
                "inside",
                "omega exponent in gain, measured (95 %)",
                "predicted",
                "inside",
            ],
            rows,
        )
    ]


def limit_blocks(res) -> list:
    """The section's blocks from ``res["limit_cycles"]`` (switched off, failed, or done)."""
    lc = res["limit_cycles"]
    out = [H(2, LIMIT)]
    if not lc.get("available"):
        return out + [P(lc.get("reason", "Not available."))]
    if lc.get("error"):
        return out + [P(f"The limit-cycle comparison failed in this run: `{lc['error']}`.")]
    attrs = lc.get("attrs") or {}
    if "statements" not in attrs:  # a record made before the comparison had settings
        return out + [
            P(
                "This record of the comparison predates its unscaled and held-out settings "
                "(its scales were fitted to the rows it was judged on); regenerate the report."
            )
        ]
    out.append(P(_intro(lc, res)))
    out.append(UL([v for k, v in attrs["statements"].items() if k != "finding"]))
    if lc.get("figure"):
        out.append(IMG(lc["figure"], "limit cycles, predicted against measured"))
    rows = lc.get("rows") or []
    names = law_names(res)
    rows = [{**r, "model": law(names, r["model"])} if r.get("model") else r for r in rows]
    models = sorted({(r["table"], r["model"]) for r in rows})
    if models:
        out.append(P("Laws used: " + "; ".join(f"{t}: {m}" for t, m in models) + "."))
    out.append(H(3, "The unscaled prediction, row by row"))
    out.append(_records_table([r for r in rows if r["setting"] == "unscaled"], _ROW_COLUMNS))
    out.append(H(3, "Agreement per block"))
    out += _agreement_table(attrs)
    if attrs.get("scales"):
        out.append(H(3, "The computer's scales"))
        out += _scales_table(attrs["scales"])
    out.append(H(3, "Critical gains"))
    out += _critical_table(attrs)
    out.append(H(3, "Trends with the system gain"))
    out += _trend_table(attrs)
    for setting in [s for s in SETTING_LABELS if s != "unscaled"]:
        mine = [r for r in rows if r["setting"] == setting]
        if mine:
            cols = _ROW_COLUMNS[:1] + [("alpha", "alpha"), ("beta", "beta")] + _ROW_COLUMNS[1:]
            out.append(
                DETAILS(
                    f"The prediction row by row, {SETTING_LABELS[setting]}",
                    [_records_table(mine, cols)],
                )
            )
    return out
