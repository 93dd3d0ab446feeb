"""What the report says, in order: :func:`build_document` and the report-wide sections.

The title, the summary figure (:mod:`fitdf.plots.summary`), the settings, contents,
findings and summary table, then one section per block
(:mod:`fitdf.report.block_outline`), the cross-impedance prediction, the limit
cycles, the audit, the thesis's curves and the models -- as a list of document blocks
(:mod:`fitdf.report.document`) that :mod:`fitdf.report.render` renders.
:func:`nav_links` names the main sections for the HTML navigation bar.
"""

from __future__ import annotations

from fitdf.inference.convergence import MAX_LOG_EVIDENCE_ERROR, MIN_EFFECTIVE
from fitdf.inference.cross_impedance import PRIOR_NODES
from fitdf.plots.summary import CAPTION as SUMMARY_CAPTION
from fitdf.report.block_outline import _block_blocks
from fitdf.report.claims import text
from fitdf.report.conclusion import UNDETERMINED
from fitdf.report.costs import phase_labels
from fitdf.report.document import (
    DETAILS,
    IMG,
    TABLE,
    UL,
    H,
    P,
    _records_table,
    box_factors,
    law,
    law_names,
    number_word,
    slug,
)
from fitdf.report.limit_outline import LIMIT as _LIMIT
from fitdf.report.limit_outline import limit_blocks as _limit_blocks
from fitdf.report.overview import regenerate_claims
from fitdf.report.physics_outline import PHYSICS, physics_blocks
from fitdf.report.small_signal_outline import study_blocks
from fitdf.report.upgrade import upgrade
from fitdf.report.words import report_words

__all__ = ["build_document", "nav_links"]

TITLE = "fitdf comparison report: describing-function models of three magnetic cores"
_CROSS = "Cross-impedance prediction"
_AUDIT = "Audit of the printed tables (Appendix B)"
_THESIS = "The thesis's computed curves (Graphs 4.1-4.7)"
_SMALL = "Small signals: a DC-bias hypothesis"

#: What the cross-impedance figures show.
CROSS_CAPTION = (
    "Top two rows: the training table, measured (black dots) and fitted (solid lines); bottom "
    "two rows: the other impedance's table, measured, and the curves predicted from the "
    "training fit with only that table's gain refitted (dashed); one colour per law, as in "
    "the legend; a frequency measured at one impedance only leaves its panels at the other "
    "blank."
)


def _more_starts(models, n_starts) -> str:
    """`` (24 for `cubic_hc`)``: the laws whose ``start_multiple`` gives them more starts."""
    more = [
        f"{n_starts * m['start_multiple']} for `{m['name']}`"
        for m in models
        if m.get("start_multiple", 1) > 1
    ]
    return f" ({', '.join(more)}, whose chi-square has kinks)" if more else ""


def _networks(n: int) -> str:
    """``1`` -> "one network", ``4`` -> "4 networks" (nautilus's emulators per bound)."""
    return "one network" if n == 1 else f"{n} networks"


def _machine_text(machine) -> str:
    """Where the numbers were computed (``fitdf.machine``)."""
    if not machine:
        return "computed on a machine this report did not record"
    libs = ", ".join(f"{k} {v}" for k, v in machine["libraries"].items() if v)
    return (
        f"computed on {machine['cpu']} ({machine['architecture']}, numba target "
        f"`{machine['llvm_cpu']}`), Python {machine['python']}, {libs}"
    )


def _settings_text(res, words=None) -> list:
    """The settings list; its last line says how to regenerate the report (the
    ``report.regenerate`` claim of ``words``, :func:`~fitdf.report.words.report_words`)."""
    regenerate = (words or {}).get("claims", {}).get("regenerate") or regenerate_claims(res)
    s, t = res["settings"], res["timing"]
    sampled = "posterior" in s["methods"] and s["posterior_top"] != 0
    if not sampled:
        posteriors = "no posterior sampling"
    elif s.get("sampler") == "nested":
        posteriors = _nested_text(s)
    else:
        posteriors = _mcmc_text(s)
    cv = _cv_text(s)
    return [
        UL(
            [
                f"fitdf {res['fitdf_version']}, seed {res['seed']}"
                + (
                    " (**quick** configuration)"
                    if res.get("quick") or (res.get("run") or {}).get("run") == "quick"
                    else ""
                ),
                f"laws: {', '.join(law(law_names(res), m) for m in s['models'])}; measurement "
                f"chain `{s.get('chain', 'winding')}`"
                + (
                    f" (every law also fitted through `{s['approximate_chain']}` for comparison)"
                    if s.get("approximate_chain")
                    else ""
                ),
                f"least squares with {s['n_starts']} starts for every model and block"
                + _more_starts(res.get("models", []), s["n_starts"])
                + f"; {posteriors}; {cv}",
                _run_time_text(s, t),
                _machine_text(t.get("machine")),
                text(regenerate),
            ]
        )
    ]


def _mcmc_text(s) -> str:
    """The settings' MCMC posteriors (``s``: ``results.json``'s settings)."""
    return (
        "MCMC (emcee: a discarded pilot, then independent chains) for the best {top} "
        "least-squares models of each block{skip}: {w} walkers in the pilot, at least {n} "
        "production steps, extended until converged up to {mx}{ext}{cf}".format(
            top="all" if s["posterior_top"] is None else s["posterior_top"],
            skip=(
                " (not sampled: " + ", ".join(f"`{m}`" for m in s["posterior_skip"]) + ")"
                if s.get("posterior_skip")
                else ""
            ),
            w="2 d + 2 (d sampled dimensions)" if s["n_walkers"] is None else s["n_walkers"],
            n=s["n_steps"],
            mx=s.get("max_steps") or s["n_steps"],
            ext=(
                f" ({s['extend_steps']} for a chain that mixes but is short of R-hat or ESS)"
                if s.get("extend_steps")
                else ""
            ),
            cf=(
                f"; {s['closed_form_step_factor']} times as many for the laws in closed form "
                "(cheaper per step)"
                if s.get("closed_form_step_factor", 1) != 1
                else ""
            ),
        )
    )


def _nested_text(s) -> str:
    """The settings' nested-sampling posteriors (``s``: ``results.json``'s settings)."""
    where = s.get("posterior_blocks")
    return (
        "posteriors and their Bayesian evidence by nested sampling (nautilus, {live} live "
        "points, {nets} per bound, up to {mx:,} likelihood evaluations; converged at {eff} effective draws and "
        "an evidence error of at most {err}) for the best {top} least-squares models of "
        "{where}{below}{sens}".format(
            live=s["nested_live"],
            nets=_networks(s.get("nested_networks", 4)),
            mx=s["nested_max_evaluations"],
            eff=MIN_EFFECTIVE,
            err=MAX_LOG_EVIDENCE_ERROR,
            top="all" if s["posterior_top"] is None else s["posterior_top"],
            where="each block" if not where else ", ".join(where),
            below=(
                " (the runners-up only where their AICc is within "
                f"{s['posterior_runner_up_below']:g} of the best's)"
                if s.get("posterior_runner_up_below") is not None
                else ""
            ),
            sens=(
                f"; the evidence again with the prior box {box_factors()} for the best "
                f"{s['sensitivity_top']} of each block"
                if s.get("sensitivity_top")
                else ""
            ),
        )
    )


def _cv_text(s) -> str:
    """The settings' cross-validation (``s``: ``results.json``'s settings)."""
    if s["cv_top"] == 0:
        return "no cross-validation"
    return (
        f"leave-one-frequency-out cross-validation for the best {s['cv_top'] if s['cv_top'] is not None else 'all'} "
        "models ("
        + (
            "each fold polished from the block's optimum"
            if s["cv_starts"] is None
            else f"{s['cv_starts']} starts per fold"
        )
        + ")"
    )


def _run_time_text(settings: dict, t: dict) -> str:
    """The run time, in all and per phase (named as the run named them)."""
    labels = phase_labels(settings)
    seconds = [
        t.get("least_squares_s", 0),
        t.get("second_phase_s", 0),
        t.get("figures_s", 0),
    ]
    phases = "; ".join(
        f"{label} {s:.0f} s" for label, s in zip(labels, seconds) if label != "nothing more"
    )
    return (
        f"run time {t.get('total_s', 0):.0f} s with {t.get('workers', 1)} worker process(es) "
        f"({phases})" + _reused_text(t)
    )


def _reused_text(timing: dict) -> str:
    """What the run took from the job cache (empty for a report computed afresh)."""
    reused = timing.get("reused_jobs") or []
    if not reused:
        return ""
    return (
        f"; {len(reused)} of {len(timing.get('jobs_s', {}))} jobs taken from the job cache, "
        "computed by an earlier run of the same settings, seed, code and machine"
    )


def _summary_table(res, words):
    """One row per block: each criterion's best law, from the ``summary.block`` claims."""
    names = law_names(res)
    rows = [c["values"] for c in words["claims"]["summary"]]
    posterior = any(r.get("evidence_best") or r.get("loo_best") for r in rows)
    head = [
        "block",
        "data",
        "best by AICc (least squares)",
        "RMS complex",
        "runner-up by AICc",
        "dAICc",
    ] + (["best by the evidence", "best by LOO-IC"] if posterior else [])
    return TABLE(
        head,
        [
            [
                f"[{r['block']}](#{slug(r['title'])})",
                r["title"],
                law(names, r["aicc_best"]),
                r["rms"],
                law(names, r.get("second")),
                r.get("d_aicc"),
            ]
            + (
                [
                    law(names, r["evidence_best"]) or "not sampled",
                    law(names, r["loo_best"]) or "not sampled",
                ]
                if posterior
                else []
            )
            for r in rows
        ],
    )


def _spread(row) -> str:
    """The prediction RMS over the series-resistance prior's nodes, ``low-high at r1..r3 ohm``."""
    nodes = row.get("r_series_nodes") or []
    if len(nodes) < 2:
        return "held at " + (f"{nodes[0]:.0f} ohm" if nodes else "n/a")
    return (
        f"{row['predict_rms_complex_min']:.3f}-{row['predict_rms_complex_max']:.3f} "
        f"(r_series {nodes[0]:.0f}-{nodes[-1]:.0f} ohm)"
    )


def _cross_blocks(res):
    out = [
        H(2, _CROSS),
        P(
            "Each core fitted at one source impedance predicts its data at the other: the core's parameters "
            "come from the training fit; only the target table's calibration gain is refitted (the tables use "
            "different DF factors, see the audit). Data at one impedance do not determine the series resistance "
            "(winding, source and leads: it trades against the core's current scale), and the prediction "
            "depends on it, so it is averaged over the resistance's prior: the prediction RMS is that of the "
            "prior-weighted mean prediction, and its spread the RMS at the prior's "
            f"{number_word(len(PRIOR_NODES))} quadrature nodes "
            f"(median and median x/÷ e^({max(PRIOR_NODES):.2f} sigma))."
        ),
    ]
    if not res["cross_impedance"]:
        return out + [P("Not computed in this configuration.")]
    names = law_names(res)
    for d in res["cross_impedance"]:
        out.append(
            H(
                3,
                f"{d['core'].capitalize()}: fitted at {d['train_ohm']:g} ohm ({d['train_block']}), "
                f"predicting {d['test_ohm']:g} ohm ({d['test_block']})",
            )
        )
        out.append(
            _records_table(
                [
                    {**row, "model": law(names, row["model"]), "spread": _spread(row)}
                    for row in d["rows"]
                ],
                [
                    ("model", "law"),
                    ("train_rms_complex", "training RMS complex"),
                    ("predict_rms_complex", "prediction RMS complex"),
                    ("spread", "over the resistance prior"),
                    ("predict_rms_magnitude", "prediction RMS |DF|"),
                    ("predict_rms_phase_deg", "prediction RMS phase (deg)"),
                    ("calibration_gain", "refitted gain"),
                    ("n_test", "rows predicted"),
                ],
            )
        )
        if d.get("figure"):
            out += [
                IMG(
                    d["figure"],
                    f"cross-impedance {d['core']} {d['train_ohm']:g} to {d['test_ohm']:g} ohm",
                ),
                P(CROSS_CAPTION),
            ]
    return out


def _small_signal_blocks(res):
    records = res.get("small_signal") or []
    out = [
        H(2, _SMALL),
        P(
            "The smallest inputs of the 600 ohm tables imply large loss angles with no frequency trend. The thesis "
            "mentions bias turns against a DC voltage in the analyser (Photo 2), so the core may sit in a biased or "
            "remanent state. In the Preisach law minor loops between the same extremes are congruent, so remanence "
            "cannot change the DF; a DC bias current can. Each block's Preisach fit is given the bias (one per "
            "table, and a free one per row) that fits its smallest-input rows best, through the sinusoidal-current "
            "relation (its error against the exact chain at zero bias is shown)."
        ),
    ]
    if not records:
        return out + [P("Not computed in this configuration (no Preisach fit of a 600 ohm block).")]
    for rec in records:
        out.append(H(3, f"{rec['block']}: {rec['verdict']}"))
        out.append(
            _records_table(
                rec["rows"],
                [
                    ("frequency_hz", "f (c/s)"),
                    ("input_v", "input (V)"),
                    ("peak_current_a", "peak current (A)"),
                    ("measured_magnitude", "measured abs(DF)"),
                    ("measured_lead_deg", "measured lead (deg)"),
                    ("unbiased_error", "error, no bias"),
                    ("common_bias_error", "error, one bias"),
                    ("best_bias_error", "error, bias per row"),
                    ("best_bias_over_i_c", "best bias / i_c"),
                    ("implied_loss_angle_deg", "loss angle implied (deg)"),
                    ("max_loss_angle_any_bias_deg", "largest loss angle any bias gives (deg)"),
                    ("approximation_error", "sinusoidal-current error"),
                ],
            )
        )
    return out


def _audit_blocks(res):
    a = res["audit"]
    return [
        H(2, _AUDIT),
        _records_table(
            a["tables"],
            [
                ("table", "table"),
                ("core", "core"),
                ("source_impedance_ohm", "source (ohm)"),
                ("rows", "rows"),
                ("flagged", "flagged"),
                ("excluded_by_default", "excluded by default"),
            ],
        ),
        P(
            "DF factor per block (what the printed DF column follows, against the table's footnote):"
        ),
        _records_table(
            a["block_factors"],
            [(k, k) for k in (a["block_factors"][0] if a["block_factors"] else {})],
        ),
        DETAILS(f"All {len(a['findings'])} audit findings", [UL(a["findings"])]),
    ]


def _thesis_blocks(res):
    out = [
        H(2, _THESIS),
        P(
            "Redrawn from fitdf's models with the thesis's k = 1, c = 5 (`fitdf.plots.thesis_graphs`)."
        ),
    ]
    for g in res["thesis_graphs"]:
        out += [P(f"**Graph {g['graph']}** -- {g['title']}"), IMG(g["path"], f"Graph {g['graph']}")]
    return out


def _model_blocks(res):
    return [
        H(2, "Models"),
        TABLE(
            ["model", "law", "thesis equations", "parameters", "N depends on f"],
            [
                [
                    f"`{m['name']}`",
                    m["title"],
                    m["equations"],
                    ", ".join(p["name"] for p in m["parameters"]),
                    m["frequency_dependent"],
                ]
                for m in res["models"]
            ],
        ),
    ]


def _overview_blocks(res) -> list:
    """The summary figure and its caption (nothing when the record has none)."""
    path = res.get("summary_figure")
    if not path:
        return []
    return [
        IMG(path, "summary: residual of every law on every block; constants against Appendix A"),
        P(f"{SUMMARY_CAPTION} {UNDETERMINED}."),
    ]


def nav_links(res: dict) -> list[tuple[str, str]]:
    """``(label, anchor)`` of the report's main sections, short enough for one bar.

    The anchors are the slugs of the document's own headings (first occurrence), so each
    resolves in the HTML (and on a code-hosting site).
    """
    links = [("Overview", slug(TITLE)), ("Findings", "findings"), ("Summary", "summary")]
    links += [
        ("+".join(b.get("tables") or [b["key"]]), slug(b["title"])) for b in res["blocks"].values()
    ]
    links += [("Physics", slug(PHYSICS))] if res.get("physics") else []
    return links + [
        ("Cross-impedance", slug(_CROSS)),
        ("Small signals", slug(_SMALL)),
        ("Limit cycles", slug(_LIMIT)),
        ("Audit", slug(_AUDIT)),
        ("Thesis graphs", slug(_THESIS)),
        ("Models", "models"),
    ]


def build_document(res: dict) -> list:
    """The report as a list of blocks (see the module docstring); ``res`` of an earlier
    schema is read as the current one (:func:`fitdf.report.upgrade.upgrade`)."""
    res = upgrade(res)
    blocks = [res["blocks"][k] for k in res["blocks"]]
    toc = ["[Findings](#findings)", "[Summary](#summary)"]
    toc += [f"[{b['title']}](#{slug(b['title'])})" for b in blocks]
    toc += [
        *([f"[{PHYSICS}](#{slug(PHYSICS)})"] if res.get("physics") else []),
        "[Cross-impedance prediction](#cross-impedance-prediction)",
        f"[{_SMALL}](#{slug(_SMALL)})",
        "[Limit cycles (Tables 5.1, 5.2)](#limit-cycles-tables-51-52)",
        "[Audit of the printed tables](#audit-of-the-printed-tables-appendix-b)",
        "[The thesis's computed curves](#the-thesiss-computed-curves-graphs-41-47)",
        "[Models](#models)",
    ]
    words = report_words(res)
    doc = [
        H(1, TITLE),
        P(text(words["claims"]["intro"])),
        *_overview_blocks(res),
        *_settings_text(res, words),
        H(2, "Contents"),
        UL(toc),
        H(2, "Findings"),
        P(text(words["claims"]["conclusion"])),
        P("In detail (every statement is generated from the numbers below):"),
        UL(words["findings"]),
        H(2, "Summary"),
        P(
            "Each block's best law by each criterion, each by its own numbers: AICc of the "
            "least-squares fits (every law)"
            + (
                ", the Bayesian evidence and LOO-IC of the posteriors (the laws sampled)."
                if any(b["ranking_posterior"] for b in blocks)
                else "; no posterior was sampled."
            )
        ),
        _summary_table(res, words),
    ]
    names = law_names(res)
    for b in blocks:
        doc += _block_blocks(b, names)
    doc += (
        physics_blocks(res, words)
        + _cross_blocks(res)
        + _small_signal_blocks(res)
        + study_blocks(res, words)
        + _limit_blocks(res)
        + _audit_blocks(res)
        + _thesis_blocks(res)
        + _model_blocks(res)
    )
    return doc
