"""Render the comparison report from ``results.json`` (and the figure files) as Markdown and HTML.

Both renderings come from one document model -- a list of blocks (headings,
paragraphs, lists, tables, images, collapsible details) built by
:func:`build_document` -- so they always say the same thing:

* :func:`render_markdown` -- ``README.md``: pipe tables, relative image links
  (``figures/...``), ``<details>`` for the long parameter tables; renders on a
  code-hosting site.
* :func:`render_html` -- ``index.html``: one self-contained file, the PNG figures
  embedded as base64 ``data:`` URIs, inline CSS, no scripts and no external resources.

Re-render an existing report without refitting::

    import json, pathlib
    from fitdf.report.render import render_html
    out = pathlib.Path("reports")
    html = render_html(json.loads((out / "results.json").read_text()), out)
"""

from __future__ import annotations

import base64
import html
import json
import re
from pathlib import Path

__all__ = ["build_document", "render_markdown", "render_html", "slug", "fmt"]

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


# ------------------------------------------------------------------ formatting
def fmt(v, digits=4) -> str:
    """A cell: numbers to ``digits`` significant digits, None as 'n/a', booleans yes/no."""
    if v is None:
        return "n/a"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
            return f"{v:.{digits - 1}e}"
        return f"{v:.{digits}g}"
    return str(v)


def slug(text: str) -> str:
    """GitHub's heading anchor: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", text.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


# ------------------------------------------------------------------ document model
def H(level, text):
    return ("h", level, text)


def P(text):
    return ("p", text)


def UL(items):
    return ("ul", list(items))


def TABLE(header, rows):
    return ("table", list(header), [[fmt(c) for c in r] for r in rows])


def IMG(path, alt):
    return ("img", path, alt)


def DETAILS(summary, blocks):
    return ("details", summary, list(blocks))


def _records_table(records, cols):
    if not records:
        return P("(none)")
    cols = [(k, label) for k, label in cols if any(r.get(k) not in (None, "") for r in records)]
    return TABLE([label for _, label in cols], [[r.get(k) for k, _ in cols] for r in records])


def _settings_text(res) -> list:
    s, t = res["settings"], res["timing"]
    mcmc = (
        "MCMC (emcee, DE moves) for the best {top} least-squares models of each block: {w} walkers x {n} steps".format(
            top="all" if s["mcmc_top"] is None else s["mcmc_top"], w=s["n_walkers"], n=s["n_steps"]
        )
        if "mcmc" in s["methods"] and s["mcmc_top"] != 0
        else "no MCMC"
    )
    cv = (
        f"leave-one-frequency-out cross-validation for the best {s['cv_top'] if s['cv_top'] is not None else 'all'} "
        f"models ({s['cv_starts']} starts per fold)"
        if s["cv_top"] != 0
        else "no cross-validation"
    )
    return [
        UL(
            [
                f"fitdf {res['fitdf_version']}, seed {res['seed']}"
                + (" (**quick** configuration)" if res.get("quick") else ""),
                f"models: {', '.join('`' + m + '`' for m in s['models'])}; measurement chain `winding`",
                f"least squares with {s['n_starts']} starts for every model and block; {mcmc}; {cv}",
                f"run time {t.get('total_s', 0):.0f} s with {t.get('workers', 1)} worker process(es) "
                f"(least squares {t.get('least_squares_s', 0):.0f} s, MCMC/CV/cross-impedance/limit cycles "
                f"{t.get('mcmc_cv_cross_limit_s', 0):.0f} s, figures {t.get('figures_s', 0):.0f} s)",
                "regenerate with `fitdf report` (same seed, same numbers); every number is in `results.json`",
            ]
        )
    ]


def _summary_table(res):
    rows = []
    for rec in res["blocks"].values():
        r = rec["ranking_lsq"]
        if not r:
            continue
        m = rec["ranking_mcmc"][0]["model"] if rec["ranking_mcmc"] else None
        rows.append(
            [
                f"[{rec['key']}](#{slug(rec['title'])})",
                rec["title"],
                r[0]["model"],
                r[0]["rms_complex"],
                r[1]["model"] if len(r) > 1 else None,
                r[1]["rms_complex"] if len(r) > 1 else None,
                m,
            ]
        )
    return TABLE(
        [
            "block",
            "data",
            "best (lsq)",
            "RMS complex",
            "runner-up",
            "RMS complex",
            "best by LOO-IC (MCMC)",
        ],
        rows,
    )


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


def _param_blocks(rec):
    out = []
    for method, fits in (("least squares", rec["fits_lsq"]), ("MCMC", rec["fits_mcmc"])):
        for i, (model, fit) in enumerate(fits.items()):
            body = [_param_table(fit)]
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
            ],
            rows,
        ),
        P(
            "Converged means at least 50 autocorrelation times and R-hat < 1.05 for every parameter; the chains "
            "are short by design (run time), so read unconverged posteriors as rough."
        ),
    ]
    if rec["figures"].get("corner"):
        out.append(
            IMG(rec["figures"]["corner"], f"corner plot of {rec['order_lsq'][0]} on {rec['key']}")
        )
    return out


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
        H(3, "Parameters"),
        *_param_blocks(rec),
        H(3, "MCMC diagnostics"),
        *_mcmc_blocks(rec),
    ]
    return out


def _cross_blocks(res):
    out = [
        H(2, "Cross-impedance prediction"),
        P(
            "Each core fitted at one source impedance predicts its data at the other: the core's parameters and "
            "the winding resistance come from the training fit; only the target table's calibration gain is "
            "refitted (the tables use different DF factors, see the audit)."
        ),
    ]
    if not res["cross_impedance"]:
        return out + [P("Not computed in this configuration.")]
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
                d["rows"],
                [
                    ("model", "model"),
                    ("train_rms_complex", "training RMS complex"),
                    ("predict_rms_complex", "prediction RMS complex"),
                    ("predict_rms_magnitude", "prediction RMS |DF|"),
                    ("predict_rms_phase_deg", "prediction RMS phase (deg)"),
                    ("calibration_gain", "refitted gain"),
                    ("n_test", "rows predicted"),
                ],
            )
        )
        if d.get("figure"):
            out.append(
                IMG(
                    d["figure"],
                    f"cross-impedance {d['core']} {d['train_ohm']:g} to {d['test_ohm']:g} ohm",
                )
            )
    return out


def _limit_blocks(res):
    lc = res["limit_cycles"]
    out = [H(2, "Limit cycles (Tables 5.1, 5.2)")]
    if not lc.get("available"):
        return out + [P(lc.get("reason", "Not available."))]
    if lc.get("error"):
        return out + [P(f"The limit-cycle comparison failed in this run: `{lc['error']}`.")]
    out.append(
        P(
            "Limit cycles of the thesis's analog-computer loop predicted by harmonic balance from the fits "
            "(`fitdf.thesis.thesis_limit_cycle_comparison`; per block the lowest-AICc model among "
            + ", ".join(f"`{m}`" for m in (lc.get("models_offered") or ["all models"]))
            + ") against the measured Tables 5.1 and 5.2."
        )
    )
    if lc.get("figure"):
        out.append(IMG(lc["figure"], "limit cycles, predicted against measured"))
    rows = lc.get("rows") or []
    if rows:
        cols = [(c, c) for c in lc.get("columns", rows[0].keys())]
        out.append(_records_table(rows, cols))
    attrs = lc.get("attrs") or {}
    scalars = {k: v for k, v in attrs.items() if not isinstance(v, (dict, list))}
    if scalars:
        out.append(UL([f"{k}: {fmt(v)}" for k, v in scalars.items()]))
    for k, v in attrs.items():
        if isinstance(v, dict) and v and all(isinstance(x, dict) for x in v.values()):
            keys = list(
                dict.fromkeys(
                    c for x in v.values() for c in x if not isinstance(x[c], (dict, list))
                )
            )
            out.append(
                DETAILS(
                    f"{k}",
                    [
                        TABLE(
                            [k] + keys, [[name] + [x.get(c) for c in keys] for name, x in v.items()]
                        )
                    ],
                )
            )
        elif isinstance(v, (dict, list)) and v:
            out.append(DETAILS(f"{k}", [("code", json.dumps(v, indent=1))]))
    return out


def _audit_blocks(res):
    a = res["audit"]
    return [
        H(2, "Audit of the printed tables (Appendix B)"),
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
        H(2, "The thesis's computed curves (Graphs 4.1-4.7)"),
        P("Redrawn from fitdf's models with the thesis's k = 1, c = 5 (`fitdf.plots.thesis`)."),
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


def build_document(res: dict) -> list:
    """The report as a list of blocks (see the module docstring)."""
    blocks = [res["blocks"][k] for k in res["blocks"]]
    toc = ["[Findings](#findings)", "[Summary](#summary)"]
    toc += [f"[{b['title']}](#{slug(b['title'])})" for b in blocks]
    toc += [
        "[Cross-impedance prediction](#cross-impedance-prediction)",
        "[Limit cycles (Tables 5.1, 5.2)](#limit-cycles-tables-51-52)",
        "[Audit of the printed tables](#audit-of-the-printed-tables-appendix-b)",
        "[The thesis's computed curves](#the-thesiss-computed-curves-graphs-41-47)",
        "[Models](#models)",
    ]
    doc = [
        H(1, "fitdf comparison report: describing-function models of three magnetic cores"),
        P(
            "Every candidate hysteresis law, seen through the winding measurement chain, fitted to the measured "
            "describing functions of Appendix B (thesis Chapter V) by least squares and MCMC, ranked, and used to "
            "predict across source impedance and to predict limit cycles. Generated by `fitdf report`; do not edit."
        ),
        *_settings_text(res),
        H(2, "Contents"),
        UL(toc),
        H(2, "Findings"),
        P("Generated from the numbers below."),
        UL(res["findings"]),
        H(2, "Summary"),
        _summary_table(res),
    ]
    for b in blocks:
        doc += _block_blocks(b)
    doc += (
        _cross_blocks(res)
        + _limit_blocks(res)
        + _audit_blocks(res)
        + _thesis_blocks(res)
        + _model_blocks(res)
    )
    return doc


# ------------------------------------------------------------------ Markdown
def _md_cell(text: str) -> str:
    return str(text).replace("\n", " ").replace("|", "\\|")


def _md(blocks) -> list[str]:
    out = []
    for b in blocks:
        kind = b[0]
        if kind == "h":
            out += ["#" * b[1] + " " + b[2], ""]
        elif kind == "p":
            out += [b[1], ""]
        elif kind == "ul":
            out += [f"- {item}" for item in b[1]] + [""]
        elif kind == "table":
            out.append("| " + " | ".join(_md_cell(h) for h in b[1]) + " |")
            out.append("|" + "|".join("---" for _ in b[1]) + "|")
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b[2]]
            out.append("")
        elif kind == "img":
            out += [f"![{b[2]}]({b[1]})", ""]
        elif kind == "details":
            out += (
                ["<details>", f"<summary>{html.escape(b[1])}</summary>", ""]
                + _md(b[2])
                + ["</details>", ""]
            )
        elif kind == "code":
            out += ["```", b[1], "```", ""]
    return out


def render_markdown(res: dict) -> str:
    """README.md text (figures linked relatively as ``figures/...``)."""
    return "\n".join(_md(build_document(res))).rstrip() + "\n"


# ------------------------------------------------------------------ HTML
_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;max-width:1300px;margin:0 auto;
padding:1.5em;color:#1f2328;line-height:1.45}
h1{font-size:1.7em;border-bottom:1px solid #d0d7de;padding-bottom:.3em}
h2{font-size:1.35em;border-bottom:1px solid #d0d7de;padding-bottom:.25em;margin-top:2em}
h3{font-size:1.1em;margin-top:1.4em}
table{border-collapse:collapse;margin:.6em 0;font-size:.85em;display:block;overflow-x:auto}
th,td{border:1px solid #d0d7de;padding:3px 7px;text-align:left;vertical-align:top}
th{background:#f6f8fa}tr:nth-child(even) td{background:#fbfbfc}
code{background:#f2f3f5;padding:.1em .3em;border-radius:4px;font-size:.92em}
img{max-width:100%;height:auto;border:1px solid #eee;margin:.4em 0}
details{margin:.5em 0}summary{cursor:pointer;color:#0b57d0}
pre{background:#f6f8fa;padding:.7em;overflow-x:auto;font-size:.8em}
"""


def _inline(text: str) -> str:
    t = html.escape(str(text), quote=False)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    t = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", t)
    return re.sub(r"\[([^\]]+)\]\((#[^)\s]+)\)", r'<a href="\2">\1</a>', t)


def _data_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _html(blocks, root: Path, ids: dict) -> list[str]:
    out = []
    for b in blocks:
        kind = b[0]
        if kind == "h":
            base = slug(b[2])
            n = ids.get(base, 0)
            ids[base] = n + 1
            hid = base if n == 0 else f"{base}-{n}"
            out.append(f'<h{b[1]} id="{hid}">{_inline(b[2])}</h{b[1]}>')
        elif kind == "p":
            out.append(f"<p>{_inline(b[1])}</p>")
        elif kind == "ul":
            out.append("<ul>" + "".join(f"<li>{_inline(i)}</li>" for i in b[1]) + "</ul>")
        elif kind == "table":
            head = "".join(f"<th>{_inline(h)}</th>" for h in b[1])
            body = "".join(
                "<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in row) + "</tr>" for row in b[2]
            )
            out.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
        elif kind == "img":
            out.append(f'<img src="{_data_uri(root / b[1])}" alt="{html.escape(b[2])}">')
        elif kind == "details":
            out.append(
                f"<details><summary>{_inline(b[1])}</summary>"
                + "".join(_html(b[2], root, ids))
                + "</details>"
            )
        elif kind == "code":
            out.append(f"<pre>{html.escape(b[1])}</pre>")
    return out


def render_html(res: dict, root) -> str:
    """index.html text: self-contained, figures read from ``root / 'figures/...'`` and embedded."""
    body = "\n".join(_html(build_document(res), Path(root), {}))
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        "<title>fitdf comparison report</title>\n"
        f"<style>{_CSS}</style>\n</head>\n<body>\n{body}\n</body>\n</html>\n"
    )
