"""One block's section of the report as document blocks.

Data and audit flags, the DF and critical-loci figures, the rankings, the residuals,
the parameter tables and the MCMC diagnostics of one block of ``results.json``
(:func:`_block_blocks`, called by :func:`fitdf.report.outline.build_document`).
"""

from __future__ import annotations

from fitdf.report.document import DETAILS, IMG, TABLE, UL, H, P, _records_table, fmt

__all__ = ["RANK_COLS"]

RANK_COLS = [
    ("rank", "rank"),
    ("model", "model"),
    ("n_params", "k"),
    ("n_points", "rows"),
    ("rms_complex", "RMS complex"),
    ("rms_magnitude", "RMS |DF|"),
    ("rms_phase_deg", "RMS phase (deg)"),
    ("redchi", "red. chi2"),
    ("aicc", "AICc"),
    ("delta_aicc", "dAICc"),
    ("aicc_weight", "AICc weight"),
    ("bic", "BIC"),
    ("looic", "LOO-IC"),
    ("looic_se", "LOO-IC se"),
    ("waic", "WAIC"),
    ("cv_rms_complex", "CV RMS complex"),
    ("indistinguishable_from", "indistinguishable from (AICc < 2 / LOO)"),
    ("warnings", "warnings"),
]


def _data_blocks(rec):
    ds = rec["data_summary"]
    out = [
        P(
            f"{ds['rows_printed']} printed rows, {ds['rows_used']} used by the fits (the audit's default row "
            f"policy). Flagged rows are listed below; excluded ones are grey crosses in the fit figure."
        )
    ]
    out.append(
        _records_table(
            ds["per_frequency"],
            [
                ("table", "table"),
                ("source_impedance_ohm", "source (ohm)"),
                ("frequency_hz", "f (c/s)"),
                ("rows_printed", "rows printed"),
                ("rows_used", "rows used"),
                ("rows_flagged", "flagged"),
                ("rows_excluded", "excluded"),
                ("input_min_v", "input min (V)"),
                ("input_max_v", "input max (V)"),
            ],
        )
    )
    if ds["flagged_rows"]:
        out.append(
            DETAILS(
                f"{len(ds['flagged_rows'])} rows flagged by the audit",
                [
                    _records_table(
                        ds["flagged_rows"],
                        [
                            ("table", "table"),
                            ("frequency_hz", "f (c/s)"),
                            ("row_in_block", "row"),
                            ("input_v", "input (V)"),
                            ("df_reported", "DF"),
                            ("phase_lead_deg", "lead (deg)"),
                            ("flag", "flag"),
                            ("exclude_default", "excluded"),
                            ("reasons", "reasons"),
                        ],
                    )
                ],
            )
        )
    if ds["audit_findings"]:
        out.append(DETAILS("What the audit found in these tables", [UL(ds["audit_findings"])]))
    return out


def _param_table(fit):
    rows = []
    for p in fit["parameters"]:
        rows.append(
            [
                p["parameter"],
                p["value"],
                p["stderr"],
                f"{fmt(p['p16'])} .. {fmt(p['p84'])}",
                f"{fmt(p['p2.5'])} .. {fmt(p['p97.5'])}",
                p["unit"],
                f"{fmt(p['lower'])} .. {fmt(p['upper'])}",
            ]
        )
    head = "posterior median" if fit["method"] == "mcmc" else "value"
    return TABLE(
        [
            "parameter",
            head,
            "std. error" if fit["method"] == "lsq" else "posterior sd",
            "68% interval",
            "95% interval",
            "unit",
            "bounds",
        ],
        rows,
    )


def _material_blocks(fit):
    """The fit as material constants beside the Appendix A ranges."""
    check = fit.get("appendix_a_check")
    if not check:
        return []
    rows = [
        [
            c["quantity"],
            c["fitted"],
            c["unit"],
            f"{fmt(c['low'])} .. {fmt(c['high']) if c['high'] is not None else '(no upper limit)'}",
            "yes" if c["inside"] else "**no**",
        ]
        for c in check
    ]
    return [TABLE(["material constant", "fitted", "unit", "Appendix A", "inside"], rows)]


def _param_blocks(rec):
    out = []
    for method, fits in (("least squares", rec["fits_lsq"]), ("MCMC", rec["fits_mcmc"])):
        for i, (model, fit) in enumerate(fits.items()):
            body = [_param_table(fit), *_material_blocks(fit)]
            if fit["warnings"]:
                body.append(UL([f"warning: {w}" for w in fit["warnings"]]))
            if i == 0:
                out += [P(f"**`{model}`** ({method}, best of this method):")] + body
            else:
                out.append(DETAILS(f"{model} ({method})", body))
    return out


def _mcmc_blocks(rec):
    if not rec["fits_mcmc"]:
        return [P("No MCMC in this configuration.")]
    rows = []
    for model, fit in rec["fits_mcmc"].items():
        d = fit["diagnostics"]
        rows.append(
            [
                model,
                f"{d['n_walkers']} x {d['n_steps']}",
                d["burn"],
                d["thin"],
                d["n_draws"],
                d["tau_max"],
                d["steps_over_tau"],
                d["rhat_max"],
                d["ess_bulk_min"],
                d["acceptance_mean"],
                d["pareto_k_max"],
                d["converged"],
                d.get("steps_needed") or "",
            ]
        )
    out = [
        TABLE(
            [
                "model",
                "walkers x steps",
                "burn-in",
                "thin",
                "draws",
                "max tau",
                "steps/tau",
                "max R-hat",
                "min ESS (bulk)",
                "acceptance",
                "max Pareto k",
                "converged",
                "steps needed",
            ],
            rows,
        ),
        P(
            "Converged means at least 50 autocorrelation times, R-hat < 1.01 and bulk ESS >= 400 for "
            "every parameter (a pilot is discarded; production is extended until converged, up to the "
            "report's step limit, and stopped early once 50 autocorrelation times exceed that limit: "
            "'steps needed' is then the length it would take). Read the posterior bands of an "
            "unconverged chain as rough."
        ),
    ]
    if rec["figures"].get("corner"):
        out.append(
            IMG(rec["figures"]["corner"], f"corner plot of {rec['order_lsq'][0]} on {rec['key']}")
        )
    return out


def _chain_blocks(rec):
    """The exact chain against its approximation: ranking, prediction gap, fitted constants."""
    cc = rec.get("chain_comparison")
    if not cc:
        return []
    same = cc["order_exact"] == cc["order_approximate"]
    rows = []
    for b in cc["best"]:
        ce, ca = b["constants_exact"], b["constants_approximate"]
        rows.append(
            {
                **b,
                "mu_i": f"{fmt(ce.get('initial_permeability'), 3)} / {fmt(ca.get('initial_permeability'), 3)}",
                "hc": f"{fmt(ce.get('coercive_force_oe'), 3)} / {fmt(ca.get('coercive_force_oe'), 3)}",
                "bp": f"{fmt(ce.get('peak_flux_density_gauss'), 3)} / "
                f"{fmt(ca.get('peak_flux_density_gauss'), 3)}",
                "rw": f"{fmt(ce.get('winding_resistance_ohm'), 3)} / "
                f"{fmt(ca.get('winding_resistance_ohm'), 3)}",
            }
        )
    return [
        H(
            3,
            f"Exact circuit ({cc['exact_chain']}) against its approximation ({cc['approximate_chain']})",
        ),
        P(
            f"Every law is also fitted through the `{cc['approximate_chain']}` chain. Ranking there: "
            + ", ".join(
                f"{m} ({fmt(cc['rms_approximate'][m], 3)})" for m in cc["order_approximate"]
            )
            + (
                " - the same order as the exact chain."
                if same
                else " - a different order from the exact chain."
            )
            + " The gap columns evaluate the approximation at the exact fit's parameters: its own "
            "error, to set against the differences between the laws."
        ),
        _records_table(
            rows,
            [
                ("model", "model"),
                ("rms_exact", "RMS exact"),
                ("rms_approximate", "RMS approx. (refit)"),
                ("prediction_gap_rms", "gap RMS"),
                ("prediction_gap_max", "gap max"),
                ("phase_gap_max_deg", "phase gap max (deg)"),
                ("mu_i", "mu_i exact / approx."),
                ("hc", "H_c (Oe)"),
                ("bp", "B_p (G)"),
                ("rw", "r_winding (ohm)"),
            ],
        ),
    ]


def _block_blocks(rec):
    f = rec["figures"]
    out = [
        H(2, rec["title"]),
        H(3, "Data"),
        *_data_blocks(rec),
        H(3, "Describing function against input amplitude"),
        P(
            "Measured |DF| and phase lead per frequency with every model's least-squares curve; the shaded band is "
            "the best model's posterior (68% and 95%) when MCMC ran."
        ),
        IMG(f["fit"], f"DF fits on {rec['key']}"),
        H(3, "Critical loci"),
        P("-1/DF in the Nyquist plane (second quadrant: the measured DF leads)."),
        IMG(f["loci"], f"critical loci on {rec['key']}"),
        H(3, "Ranking"),
        P("Least squares, ordered by RMS complex residual |fit - measured|:"),
        _records_table(rec["ranking_lsq"], RANK_COLS),
    ]
    if rec["ranking_mcmc"]:
        out += [
            P("MCMC (posterior medians; fitted noise scales), ordered by LOO-IC:"),
            _records_table(rec["ranking_mcmc"], RANK_COLS),
        ]
    wf = rec["where_models_fail"]
    out += [
        H(3, "Residuals of the top models"),
        IMG(f["residuals"], f"residuals on {rec['key']}"),
        P("Rows that every model misses (smallest complex residual over all models):"),
        _records_table(
            wf["rows"],
            [
                ("table", "table"),
                ("source_impedance_ohm", "source (ohm)"),
                ("frequency_hz", "f (c/s)"),
                ("input_v", "input (V)"),
                ("df_measured", "|DF|"),
                ("phase_lead_measured_deg", "lead (deg)"),
                ("smallest_complex_residual", "smallest residual"),
                ("closest_model", "closest model"),
                ("largest_complex_residual", "largest residual"),
            ],
        ),
        DETAILS(
            "RMS complex residual per frequency block (best and worst model)",
            [
                _records_table(
                    wf["frequency_blocks"],
                    [
                        ("source_impedance_ohm", "source (ohm)"),
                        ("frequency_hz", "f (c/s)"),
                        ("n", "rows"),
                        ("best_model", "best"),
                        ("best_rms_complex", "best RMS"),
                        ("worst_model", "worst"),
                        ("worst_rms_complex", "worst RMS"),
                    ],
                )
            ],
        ),
        *_chain_blocks(rec),
        H(3, "Parameters"),
        *_param_blocks(rec),
        H(3, "MCMC diagnostics"),
        *_mcmc_blocks(rec),
    ]
    return out
