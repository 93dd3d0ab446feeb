"""Fits and rankings as text: what :meth:`Comparison.text`, :meth:`FitResult.text` and a
material record's :meth:`MaterialRecord.text` print (the ``fitdf fit`` output).

Every line fits in :data:`~fitdf._text.TEXT_WIDTH` columns unless ``wide``. The rules a
text states are rendered from the constants that apply them: the ties from
:data:`fitdf.inference.selection.TIE_RULES`, the posteriors' convergence from
:data:`fitdf.inference.convergence.CONVERGED`.
"""

from __future__ import annotations

import pandas as pd

from fitdf._text import TEXT_WIDTH, cell, cut, table_lines, wrap
from fitdf.inference.convergence import CONVERGED
from fitdf.inference.selection import TIE_RULES

__all__ = [
    "METHOD_NAMES",
    "WIDE_COLUMNS",
    "BRIEF_COLUMNS",
    "COLUMN_MEANINGS",
    "MaterialRecord",
    "ranking_text",
    "tie_ranks",
    "checks_text",
    "comparison_text",
    "fit_text",
    "material_text",
    "summary_record",
    "summary_text",
]

#: How the text names a fit's method.
METHOD_NAMES = {"lsq": "least squares", "mcmc": "MCMC", "nested": "nested sampling"}
#: The ranking's columns with ``wide`` (those with a value in some row).
WIDE_COLUMNS = (
    "rank",
    "model",
    "chain",
    "method",
    "n_params",
    "rms_complex",
    "rms_magnitude",
    "rms_phase_deg",
    "redchi",
    "aicc",
    "bic",
    "looic",
    "cv_rms_complex",
    "log_evidence",
    "log_evidence_error",
    "log_bayes_factor_next",
    "bayes_factor_verdict",
    "indistinguishable_from",
)
#: The ranking's columns by default: ``chain`` and ``method`` only when they differ between
#: rows, ``cv_rms_complex`` when it was computed, the ``rank_by`` column when it is none of
#: these, then ``ties``.
BRIEF_COLUMNS = (
    "rank",
    "model",
    "chain",
    "method",
    "n_params",
    "rms_complex",
    "aicc",
    "cv_rms_complex",
    "log_evidence",
)
#: What each column of the ranking means (the legend under the default table).
COLUMN_MEANINGS = {
    "n_params": "parameters fitted",
    "rms_complex": "RMS of |predicted - measured| complex DF (V/V)",
    "rms_magnitude": "RMS of |predicted| - |measured| (V/V)",
    "rms_phase_deg": "RMS phase error (degree)",
    "redchi": "reduced chi-square",
    "aicc": "Akaike's information criterion corrected for few rows (lower is better)",
    "bic": "Bayesian information criterion (lower is better)",
    "looic": "PSIS leave-one-out information criterion (MCMC; lower is better)",
    "waic": "widely applicable information criterion (MCMC; lower is better)",
    "cv_rms_complex": "rms_complex of each frequency predicted from a fit to the others",
    "log_evidence": "ln of the Bayesian evidence (nested sampling; higher is better)",
    "log_bayes_factor_next": "ln B over the next law by evidence",
}


# ------------------------------------------------------------------ the ranking
def _ranks_text(ranks) -> str:
    """Sorted ranks, runs shortened: ``[2, 3, 4, 7]`` -> ``"2-4,7"``."""
    runs, out = [], []
    for r in sorted(set(ranks)):
        if runs and r == runs[-1][1] + 1:
            runs[-1][1] = r
        else:
            runs.append([r, r])
    for lo, hi in runs:
        out.append(str(lo) if lo == hi else f"{lo},{hi}" if hi == lo + 1 else f"{lo}-{hi}")
    return ",".join(out)


def tie_ranks(table: pd.DataFrame) -> list[str]:
    """Per row of a ranking, the ranks of the rows it cannot be told apart from (its
    ``indistinguishable_from``: models of the same method), e.g. ``"2-4,7"``."""
    rank_of = {
        (row["model"], row["chain"], row["method"]): int(row["rank"]) for _, row in table.iterrows()
    }
    out = []
    for _, row in table.iterrows():
        names = [n for n in str(row.get("indistinguishable_from") or "").split(", ") if n]
        ranks = [rank_of.get((*n.rsplit("/", 1), row["method"])) for n in names]
        out.append(_ranks_text(r for r in ranks if r is not None))
    return out


def _brief_columns(table: pd.DataFrame, rank_by: str) -> list[str]:
    cols = [
        c
        for c in BRIEF_COLUMNS
        if c in table
        and not table[c].isna().all()
        and (c not in ("chain", "method") or table[c].nunique() > 1)
    ]
    if rank_by in table and rank_by not in cols:
        cols.append(rank_by)
    return cols


def ranking_text(
    table: pd.DataFrame, rank_by: str = "aicc", wide: bool = False, width: int = TEXT_WIDTH
) -> str:
    """The ranking as text: every column with ``wide``, else the columns a reader needs
    first, no line longer than ``width``, and a legend of those columns."""
    if wide:
        cols = [c for c in WIDE_COLUMNS if c in table and not table[c].isna().all()]
        return table[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}")
    cols = _brief_columns(table, rank_by)
    rows = [[cell(row[c]) for c in cols] for _, row in table.iterrows()]
    ties = tie_ranks(table)
    headers = [*cols, "ties"]
    left = ("model", "chain", "method", "ties")
    lines = table_lines(headers, [[*r, t] for r, t in zip(rows, ties)], left)
    if max(map(len, lines)) > width:  # several chains and methods: closer columns
        lines = table_lines(headers, [[*r, t] for r, t in zip(rows, ties)], left, sep=" ")
    if max(map(len, lines)) > width:  # a long list of ties: cut, ``wide`` has them all
        room = width - 1 - max(map(len, table_lines(cols, rows, left, sep=" ")))
        ties = [cut(t, max(room, len("ties"))) for t in ties]
        lines = table_lines(headers, [[*r, t] for r, t in zip(rows, ties)], left, sep=" ")
    rule = "; ".join(f"{METHOD_NAMES[m]}: {TIE_RULES[m]}" for m in sorted(set(table["method"])))
    legend = [f"{c}: {COLUMN_MEANINGS[c]}" for c in cols if c in COLUMN_MEANINGS]
    legend.append(f"ties: the ranks this row cannot be told apart from ({rule})")
    legend.append("--wide prints every column")
    return "\n".join([*lines, "", *wrap("; ".join(legend) + ".", width)])


# ------------------------------------------------------------------ posterior checks
def _nested_row(r) -> list[str]:
    d = r.diagnostics
    return [
        f"{d['log_evidence']:.2f} +- {d['log_evidence_error']:.2f}",
        f"{d['n_effective']:.0f}",
        f"{d['n_likelihood_evaluations']:.0f}",
    ]


def _mcmc_row(r) -> list[str]:
    d = r.diagnostics
    return [
        f"{d['steps_over_tau']:.0f}",
        f"{max(d['rhat'].values()):.3f}",
        f"{min(d['ess_bulk'].values()):.0f}",
        f"{d['acceptance_mean']:.2f}",
    ]


#: Per method: the title of its checks, its columns beyond model/chain/converged, its row.
_CHECKS = {
    "nested": ("Nested-sampling checks", ("ln evidence", "eff. draws", "evaluations"), _nested_row),
    "mcmc": ("MCMC checks", ("steps/tau", "max R-hat", "min ESS", "acceptance"), _mcmc_row),
}


def checks_text(results, width: int = TEXT_WIDTH) -> str:
    """The convergence checks of the posteriors among ``results``, a table per method under
    the rule that calls one converged (:data:`CONVERGED`); "" when there are none."""
    blocks = []
    for method, (title, columns, row_of) in _CHECKS.items():
        found = [r for r in results if r.method == method]
        if not found:
            continue
        rows = [
            [r.model, r.chain, "yes" if r.diagnostics["converged"] else "NO", *row_of(r)]
            for r in found
        ]
        headers = ["model", "chain", "converged", *columns]
        lines = wrap(f"{title} (converged: {CONVERGED[method]}):", width)
        lines += ["  " + line for line in table_lines(headers, rows, headers[:3])]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


# ------------------------------------------------------------------ a fit and its material
class MaterialRecord(dict):
    """A fit's material record (:func:`fitdf.inference.material.material_record`): a plain
    JSON-ready dict that also presents itself (:meth:`text`, :meth:`table`)."""

    def text(self, width: int = TEXT_WIDTH) -> str:
        return material_text(self, width)

    def table(self) -> pd.DataFrame:
        """The Appendix A check, one row per quantity; without catalogue ranges, the
        constants (``quantity``, ``fitted``)."""
        check = self.get("appendix_a_check")
        if check:
            return pd.DataFrame(check)
        items = self.get("constants", {}).items()
        return pd.DataFrame([{"quantity": k, "fitted": v} for k, v in items])


def _material_lines(record) -> list[str]:
    """The constants, against the Appendix A ranges where the core has them."""
    check = record.get("appendix_a_check")
    if not check:
        c = record["constants"]
        return [
            f"  material: mu_i {c['initial_permeability']:.4g}, "
            f"mu_max {c['maximum_permeability']:.4g}, H_c {c['coercive_force_oe']:.3g} Oe,",
            f"    B_p {c['peak_flux_density_gauss']:.4g} G, B_r/B_p {c['squareness']:.3g} "
            "(no catalogue ranges for this core)",
        ]
    lines = ["  material constants vs Appendix A:"]
    for row in check:
        high = "" if row["high"] is None else f"{row['high']:.4g}"
        mark = "inside" if row["inside"] else "OUTSIDE"
        lines.append(
            f"    {row['quantity']:<24s} {cell(row['fitted']):>10s} {row['unit'] or '-':<13s} "
            f"range {row['low']:.4g}..{high:<8s} {mark}"
        )
    return lines


def material_text(record, width: int = TEXT_WIDTH) -> str:
    """A fit's material constants beside the Appendix A ranges (when there is a geometry),
    and the caveat when they rest on parameters the data do not determine."""
    if record is None:
        return "  (no core geometry: material constants not computed; see --geometry)"
    lines = _material_lines(record)
    if record.get("caveat"):
        lines += wrap(f"caveat: {record['caveat']}", width, "  ", "    ")
    return "\n".join(lines)


def fit_text(result, width: int = TEXT_WIDTH) -> str:
    """A fit as text (:meth:`FitResult.summary`), its material constants, and for a
    posterior its convergence check."""
    parts = [result.summary(width), material_text(result.material, width)]
    checks = checks_text([result], width) if getattr(result, "diagnostics", None) else ""
    return "\n".join(parts + ([checks] if checks else []))


# ------------------------------------------------------------------ a comparison
def _header(comparison) -> str:
    """``Ranking on B.3 (36 rows, winding chain, least squares, seed 0), ordered by aicc:``,
    naming what every row shares (the default table leaves those columns out)."""
    table, first = comparison.table, comparison.results[0]
    how = []
    if table["chain"].nunique() == 1:
        how.append(f"{table['chain'].iloc[0]} chain")
    if table["method"].nunique() == 1:
        how.append(METHOD_NAMES.get(table["method"].iloc[0], table["method"].iloc[0]))
    seed = first.info.get("seed")
    how += [] if seed is None else [f"seed {seed}"]
    return (
        f"Ranking on {first.label} ({first.metrics['n_points']} rows, {', '.join(how)}), "
        f"ordered by {comparison.rank_by}:"
    )


def comparison_text(comparison, wide: bool = False, brief: bool = False, width=TEXT_WIDTH) -> str:
    """A comparison as ``fitdf fit`` prints it: the ranking and its legend, what the
    selection rule calls best, then (unless ``brief``) the best fit and its material, and
    the posteriors' convergence checks."""
    parts = [
        "\n".join(wrap(_header(comparison), width, "", "  ")),
        ranking_text(comparison.table, comparison.rank_by, wide, width),
        "",
        comparison.selection.text(width),
    ]
    if not brief:
        best = comparison.best
        parts += ["", "Best model:", best.summary(width), material_text(best.material, width)]
    checks = checks_text(comparison.results, width)
    parts += ["", checks] if checks else []
    return "\n".join(parts)


def summary_record(comparison, data) -> dict:
    """One dataset's line of a batch summary: its best law (the selection rule's) and how
    well it fits."""
    best = comparison.best
    return {
        "data": str(data),
        "best_model": best.model,
        "chain": best.chain,
        "method": best.method,
        "rms_complex": float(best.metrics["rms_complex"]),
        "aicc": float(best.metrics["aicc"]),
        "n_points": int(best.metrics["n_points"]),
    }


#: The columns of :func:`summary_text`; the first four aligned left.
SUMMARY_COLUMNS = ("data", "best_model", "chain", "method", "rms_complex", "aicc", "n_points")


def summary_text(rows, wide: bool = False, width: int = TEXT_WIDTH) -> str:
    """The batch summary of :func:`summary_record` rows as a table; unless ``wide``, a long
    ``data`` path is cut from the left (``...``) to keep the table within ``width``."""
    cells = [[cell(r[c]) for c in SUMMARY_COLUMNS] for r in rows]
    lines = table_lines(SUMMARY_COLUMNS, cells, left=SUMMARY_COLUMNS[:4])
    over = 0 if wide else max(map(len, lines)) - width
    if over > 0:
        room = max(len("data"), max(len(c[0]) for c in cells) - over)
        for c in cells:
            c[0] = c[0] if len(c[0]) <= room else "..." + c[0][-(room - 3) :]
        lines = table_lines(SUMMARY_COLUMNS, cells, left=SUMMARY_COLUMNS[:4])
    return "\n".join(lines)
