"""One block's section of the report as document blocks.

Data and audit flags, the DF and critical-loci figures, the rankings, the residuals,
the parameter tables and the MCMC diagnostics of one block of ``results.json``
(:func:`_block_blocks`, called by :func:`fitdf.report.outline.build_document`).
"""

from __future__ import annotations

from fitdf.inference.convergence import (
    MAX_LOG_EVIDENCE_ERROR,
    MIN_EFFECTIVE,
    MIN_ESS,
    MIN_STEPS_OVER_TAU,
    RHAT_MAX,
)
from fitdf.inference.ranking import KASS_RAFTERY
from fitdf.inference.selection import TIE_AICC
from fitdf.plots.posterior import LEVELS as CORNER_LEVELS
from fitdf.report.conclusion import OUTSIDE
from fitdf.report.criteria import best_by
from fitdf.report.document import (
    DETAILS,
    IMG,
    TABLE,
    UL,
    H,
    P,
    _records_table,
    box_factors,
    fmt,
    law,
    number_word,
)
from fitdf.report.settings import ReportSettings

__all__ = ["RANK_COLS", "FIT_CAPTION", "LOCI_CAPTION", "RESIDUALS_CAPTION", "CORNER_CAPTION"]

#: What each of a block's figures shows (every mark of the figure named).
FIT_CAPTION = (
    "Measured |DF| (upper panel of each pair) and phase lead (lower) against input amplitude, "
    "one column per frequency and, for a joint fit, a pair of rows per source impedance: black "
    "dots are the rows fitted, grey crosses the rows the audit excluded, and each law's "
    "least-squares curve is a line of its own colour (as in the legend); the shaded bands, when "
    "a posterior was sampled, are the best law's posterior band of the curve (68 %, darker, and 95 %)."
)
LOCI_CAPTION = (
    "-1/DF in the Nyquist plane, one panel per source impedance: dots are the measured rows and "
    "lines the curves of the best two laws over the measured amplitude range (solid: the best, "
    "dashed: the runner-up), one colour per frequency; the arrow on the best law's curve points "
    "the way the amplitude grows. The measured DF leads, so the loci lie in the second quadrant; "
    "rows with |DF| below 0.15 lie beyond the axes."
)
RESIDUALS_CAPTION = (
    "Fit minus measured |DF| (top) and phase lead (bottom) against input amplitude, one column "
    "per law (the best ones, with their RMS residuals above): one colour per frequency, circles "
    "for the first source impedance and squares for the second (a joint fit), thin lines "
    "joining the rows of one frequency; the grey line is zero."
)
CORNER_CAPTION = (
    "The posterior of the best law's parameters (log10 of those sampled in log): on the "
    "diagonal the histogram of each parameter with dashed lines at its 16th, 50th and 84th "
    "percentiles (its title: the median, plus and minus the distance to them); below it the "
    "draws of each pair, contours enclosing "
    + ", ".join(f"{100 * lv:.0f}" for lv in CORNER_LEVELS[:-1])
    + f" and {100 * CORNER_LEVELS[-1]:.0f} % of them; blue lines and "
    "squares: the least-squares optimum."
)

RANK_COLS = [
    ("rank", "rank"),
    ("model", "law"),
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
    ("indistinguishable_from", f"indistinguishable from (AICc < {TIE_AICC:g} / LOO)"),
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


#: How each method's fits are named, and the criterion that picks the best of them:
#: (column of the ranking, larger is better, its name).
_METHODS = {
    "lsq": ("least squares", "aicc", False, "AICc"),
    "nested": ("nested sampling", "log_evidence", True, "the evidence"),
    "mcmc": ("MCMC", "looic", False, "LOO-IC"),
}


def _param_blocks(rec, names):
    """Each fit's parameters: of each method the best by its criterion first (AICc for least
    squares, the evidence for nested sampling, LOO-IC for MCMC), the others folded."""
    out = []
    for fits, ranking in (
        (rec["fits_lsq"], rec["ranking_lsq"]),
        (rec["fits_posterior"], rec["ranking_posterior"]),
    ):
        if not fits:
            continue
        kind = next(iter(fits.values())).get("method", "lsq")
        method, column, larger, criterion = _METHODS.get(kind, _METHODS["lsq"])
        rows = [r for r in ranking if r["model"] in fits]
        best = best_by([r["model"] for r in rows], [r.get(column) for r in rows], larger)
        order = sorted(fits, key=lambda m: m != best)
        for model in order:
            fit = fits[model]
            body = [_param_table(fit), *_material_blocks(fit)]
            if fit["warnings"]:
                body.append(UL([f"warning: {w}" for w in fit["warnings"]]))
            if model == best:
                out += [P(f"**{law(names, model)}** ({method}, the best by {criterion}):")] + body
            else:
                out.append(DETAILS(f"{law(names, model)} ({method})", body))
    return out


#: The posterior ranking's columns when nested sampling gave the posteriors.
EVIDENCE_COLS = [
    ("rank", "rank"),
    ("model", "law"),
    ("n_params", "parameters"),
    ("rms_complex", "RMS complex"),
    ("log_evidence", "ln evidence"),
    ("log_evidence_error", "+-"),
    ("log_bayes_factor_next", "ln B over the next"),
    ("bayes_factor_verdict", "verdict"),
    ("aicc", "AICc"),
    ("looic", "LOO-IC"),
    ("indistinguishable_from", "ties"),
]


def _posterior_blocks(rec, names):
    """The posteriors' diagnostics, by sampler; an unconverged one is listed, not drawn."""
    if not rec["fits_posterior"]:
        return [
            P(
                "No posterior sampled on this block: this run samples the blocks its settings "
                "name (above); `fitdf report --full` samples the best "
                f"{number_word(ReportSettings.for_run(full=True).posterior_top)} laws of every block."
            )
        ]
    nested = {m: f for m, f in rec["fits_posterior"].items() if f.get("method") == "nested"}
    out = _nested_blocks(rec, nested, names) if nested else []
    if len(nested) < len(rec["fits_posterior"]):
        out += _mcmc_blocks(rec, names)
    elif rec["figures"].get("corner"):
        out += [
            IMG(rec["figures"]["corner"], f"corner plot of {rec['order_lsq'][0]} on {rec['key']}"),
            P(CORNER_CAPTION),
        ]
    return out


#: How a prior box's evidence was estimated (``prior_sensitivity``'s ``estimate``).
_HOW_ESTIMATED = {
    "restricted": "the posterior's draws inside it",
    "sampled": "sampled",
    "widened": "the prior's box exact, sampled outside it",
}


def _missed_bound(box):
    """The lower bound on a wider box's ``ln Z`` that its own run fell below (it missed the
    posterior the prior's box holds: ``consistent`` false), or None
    (:func:`fitdf.inference.evidence.widened_log_evidence`)."""
    if box["factor"] <= 1 or box.get("consistent", True):
        return None
    return box["lower_bound"]


def _nested_blocks(rec, fits, names):
    rows, unconverged, sensitivity, missed = [], [], [], []
    for model, fit in fits.items():
        d = fit["diagnostics"]
        rows.append(
            [
                law(names, model),
                d.get("n_likelihood_evaluations"),
                d.get("n_effective"),
                f"{fmt(d.get('log_evidence'), 5)} +- {fmt(d.get('log_evidence_error'), 2)}",
                d.get("converged"),
            ]
        )
        if not d.get("converged"):
            unconverged.append(_unconverged_nested(law(names, model), d))
        boxes, misses = _sensitivity_rows(law(names, model), d)
        sensitivity += boxes
        missed += misses
    out = [
        TABLE(["law", "evaluations", "effective draws", "ln evidence", "converged"], rows),
        P(
            f"Nested sampling (nautilus): converged means at least {MIN_EFFECTIVE} effective draws "
            f"(Kish) and an evidence error of at most {MAX_LOG_EVIDENCE_ERROR:g}. The prior decides the evidence: each parameter's is "
            "uniform on its box in the fitted coordinate (log-uniform for a log-scaled parameter; "
            "the boxes are the material limits of soft magnetic alloys with the core's geometry), "
            "the series resistance's log-normal, and the two noise scales are integrated out under "
            "log-uniform priors; the best law's prior, in physical units:"
        ),
        *_prior_table(next(iter(fits.values())).get("prior") or {}),
    ]
    if unconverged:
        out.append(P("Not converged: " + "; ".join(unconverged) + "."))
    if sensitivity:
        out += [
            P(
                "How the evidence depends on the prior: the evidence with every parameter's box "
                f"{box_factors(where=True)}; a shift of "
                "-d ln(factor) is the Occam factor of d parameters the data determine. A box inside "
                "the prior's needs no new sampling: its evidence is the posterior's share inside it "
                "times the ratio of the two priors' densities there. A wider box holds the prior's, "
                "whose part of its evidence is exact and a lower bound:"
            ),
            TABLE(["law", "box width", "ln evidence", "shift", "how", "converged"], sensitivity),
        ]
        if missed:
            out.append(P("Missed: " + "; ".join(missed) + "."))
    return out


def _unconverged_nested(name, d) -> str:
    """Why the posterior of the law ``name`` (diagnostics ``d``) is not drawn."""
    return (
        f"{name}: {fmt(d.get('n_effective'), 3)} effective draws "
        f"({MIN_EFFECTIVE} needed) and an evidence error of "
        f"{fmt(d.get('log_evidence_error'), 2)} ({MAX_LOG_EVIDENCE_ERROR:g} at "
        f"most) after {fmt(d.get('n_likelihood_evaluations'), 6)} evaluations, the "
        "report's limit: its band, corner plot and intervals are not drawn as results"
    )


def _sensitivity_rows(name, d) -> tuple[list, list]:
    """The prior-sensitivity table's rows of the law ``name`` (diagnostics ``d``), and the
    sentences on its wider boxes whose run missed the posterior."""
    rows, missed = [], []
    for box in (d.get("prior_sensitivity") or {}).get("boxes") or []:
        bound = _missed_bound(box)
        if bound is not None:
            run = box.get("sampled_log_evidence", box["log_evidence"])
            missed.append(
                f"{name}, box width {fmt(box['factor'])}: its run's ln evidence "
                f"{fmt(run, 5)} is below {fmt(bound, 5)}, the least the box allows (the "
                "prior's own evidence over the volume ratio): the run missed the posterior, "
                "and the evidence shown is the stratified estimate, exact inside the prior's "
                "box and a lower bound"
            )
        rows.append(
            [
                name,
                box["factor"],
                f"{fmt(box['log_evidence'], 5)} +- {fmt(box['log_evidence_error'], 2)}",
                box["shift"]
                if box.get("shift_error") is None
                else f"{fmt(box['shift'], 3)} +- {fmt(box['shift_error'], 2)}",
                _HOW_ESTIMATED.get(box.get("estimate", "sampled")),
                bool(box.get("converged")),
            ]
        )
    return rows, missed


def _prior_table(prior) -> list:
    """A law's prior in physical units, as a table (none without a prior)."""
    if not prior:
        return []
    return [
        TABLE(
            ["parameter", "prior", "low", "high", "unit"],
            [
                [
                    name,
                    p.get("distribution")
                    + (
                        f" (median {fmt(p['median'], 3)}, x/÷ e^{fmt(p['sigma_ln'], 2)})"
                        if "median" in p
                        else ""
                    ),
                    *(p.get("bounds") or (None, None)),
                    p.get("unit"),
                ]
                for name, p in prior.items()
            ],
        )
    ]


def _mcmc_blocks(rec, names):
    if not any(f.get("method") == "mcmc" for f in rec["fits_posterior"].values()):
        return [P("No MCMC in this configuration.")]
    rows = []
    for model, fit in rec["fits_posterior"].items():
        if fit.get("method") != "mcmc":
            continue
        d = fit["diagnostics"]
        rows.append(
            [
                law(names, model),
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
                "law",
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
            f"Converged means at least {MIN_STEPS_OVER_TAU} autocorrelation times, R-hat < "
            f"{RHAT_MAX:g} and bulk ESS >= {MIN_ESS} for every parameter (a pilot is discarded; "
            "production is extended until converged, up to the report's step limit, and stopped "
            f"early once {MIN_STEPS_OVER_TAU} autocorrelation times exceed that limit: "
            "'steps needed' is then the length it would take). Read the posterior bands of an "
            "unconverged chain as rough."
        ),
    ]
    if rec["figures"].get("corner"):
        out += [
            IMG(rec["figures"]["corner"], f"corner plot of {rec['order_lsq'][0]} on {rec['key']}"),
            P(CORNER_CAPTION),
        ]
    return out


def _chain_blocks(rec, names):
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
                "model": law(names, b["model"]),
                "mu_i": f"{fmt(ce.get('initial_permeability'), 3)} / {fmt(ca.get('initial_permeability'), 3)}",
                "hc": f"{fmt(ce.get('coercive_force_oe'), 3)} / {fmt(ca.get('coercive_force_oe'), 3)}",
                "bp": f"{fmt(ce.get('peak_flux_density_gauss'), 3)} / "
                f"{fmt(ca.get('peak_flux_density_gauss'), 3)}",
                "rw": f"{fmt(ce.get('series_resistance_ohm'), 3)} / "
                f"{fmt(ca.get('series_resistance_ohm'), 3)}",
            }
        )
    return [
        H(
            3,
            f"Exact circuit ({cc['exact_chain']}) against its approximation ({cc['approximate_chain']})",
        ),
        P(
            f"Every law is also fitted through the `{cc['approximate_chain']}` chain. Ranking there "
            "(code names, as in the ranking above; RMS complex residual): "
            + ", ".join(
                f"`{m}` ({fmt(cc['rms_approximate'][m], 3)})" for m in cc["order_approximate"]
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
                ("model", "law"),
                ("rms_exact", "RMS exact"),
                ("rms_approximate", "RMS approx. (refit)"),
                ("prediction_gap_rms", "gap RMS"),
                ("prediction_gap_max", "gap max"),
                ("phase_gap_max_deg", "phase gap max (deg)"),
                ("mu_i", "mu_i exact / approx."),
                ("hc", "H_c (Oe)"),
                ("bp", "B_p (G)"),
                ("rw", "r_series (ohm)"),
            ],
        ),
    ]


def _kass_raftery_scale() -> str:
    """The Kass-Raftery scale in words, from its bounds (``below 2 not worth more than a bare
    mention, 2-6 positive, 6-10 strong, above 10 very strong``)."""
    parts, low = [], None
    for bound, label in KASS_RAFTERY:
        parts.append(f"below {bound:g} {label}" if low is None else f"{low:g}-{bound:g} {label}")
        low = bound
    return ", ".join(parts + [f"above {low:g} very strong"])


def _named(records, names, *keys):
    """``records`` with the laws under ``keys`` named by :func:`~fitdf.report.document.law`."""
    return [{**r, **{k: law(names, r.get(k)) for k in keys}} for r in records]


def _posterior_ranking(rec, names) -> list:
    """The posterior ranking, with what orders it (none without posteriors)."""
    if not rec["ranking_posterior"]:
        return []
    nested = any(f.get("method") == "nested" for f in rec["fits_posterior"].values())
    return [
        P(
            "Posteriors (nested sampling: highest-posterior draws), ordered by the Bayesian "
            "evidence; ln B is the Bayes factor over the next law, with its verdict on the "
            f"Kass-Raftery scale (2 ln B: {_kass_raftery_scale()}):"
            if nested
            else "MCMC (highest-posterior draws; fitted noise scales), ordered by LOO-IC:"
        ),
        _records_table(
            _named(rec["ranking_posterior"], names, "model"),
            EVIDENCE_COLS if nested else RANK_COLS,
        ),
    ]


def _residual_blocks(rec, names) -> list:
    """The residual figure and the rows and frequency blocks that every law misses."""
    wf = rec["where_models_fail"]
    return [
        H(3, "Residuals of the top models"),
        IMG(rec["figures"]["residuals"], f"residuals on {rec['key']}"),
        P(RESIDUALS_CAPTION),
        P("Rows that every law misses (smallest complex residual over all laws):"),
        _records_table(
            _named(wf["rows"], names, "closest_model"),
            [
                ("table", "table"),
                ("source_impedance_ohm", "source (ohm)"),
                ("frequency_hz", "f (c/s)"),
                ("input_v", "input (V)"),
                ("df_measured", "|DF|"),
                ("phase_lead_measured_deg", "lead (deg)"),
                ("smallest_complex_residual", "smallest residual"),
                ("closest_model", "closest law"),
                ("largest_complex_residual", "largest residual"),
            ],
        ),
        DETAILS(
            "RMS complex residual per frequency block (best and worst law)",
            [
                _records_table(
                    _named(wf["frequency_blocks"], names, "best_model", "worst_model"),
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
    ]


def _block_blocks(rec, names):
    """One block's section; ``names``: :func:`~fitdf.report.document.law_names` of the record."""
    f = rec["figures"]
    out = [
        H(2, rec["title"]),
        H(3, "Data"),
        *_data_blocks(rec),
        H(3, "Describing function against input amplitude"),
        IMG(f["fit"], f"DF fits on {rec['key']}"),
        P(FIT_CAPTION),
        H(3, "Critical loci"),
        IMG(f["loci"], f"critical loci on {rec['key']}"),
        P(LOCI_CAPTION),
        H(3, "Ranking"),
        P(
            "Least squares, ordered by AICc (the first row is the best law); rms_complex is the "
            "RMS of |fit - measured|:"
        ),
        _records_table(_named(rec["ranking_lsq"], names, "model"), RANK_COLS),
        *_posterior_ranking(rec, names),
        *_residual_blocks(rec, names),
        *_chain_blocks(rec, names),
        H(3, "Parameters"),
        P(
            "Each fit's parameters, then its loop's material constants against Appendix A: "
            f"**no** in the last column means that {OUTSIDE}. Which constants the data do not "
            "determine: see the note under the summary figure."
        ),
        *_param_blocks(rec, names),
        H(3, "Posteriors"),
        *_posterior_blocks(rec, names),
    ]
    return out
