"""The audit's statements in the Findings, as claims (:mod:`fitdf.report.claims`) on the
``audit`` record of ``results.json``:

* ``audit.counts``: how many rows of the printed tables the audit flags and how many the
  default row policy leaves out;
* ``audit.factor``: for a table whose printed footnote factor (DF = factor x output / input)
  its rows do not follow, or that prints none, the factor the data follow (the median over
  its frequency blocks) and the blocks' spread. A table whose blocks all follow the footnote
  says nothing here (the audit section lists it).

The numbers are those of the audit's record (``tables``, ``block_factors``), which
:mod:`fitdf.data.audit` computes from the bundled tables.
"""

from __future__ import annotations

import math

import numpy as np

from fitdf.report.claims import paragraph, rule, say, span

__all__ = ["audit_findings"]


@rule(
    "audit.counts",
    flagged="audit/tables/*/flagged",
    excluded="audit/tables/*/excluded_by_default",
    rows="audit/tables/*/rows",
)
def _counts(flagged, excluded, rows):
    if not rows:
        return None
    return say(
        "The audit of the printed tables flags {n_flag} of {n_rows} rows and excludes {n_excl} "
        "by default (see the audit section for every row and reason).",
        n_flag=int(sum(flagged)),
        n_rows=int(sum(rows)),
        n_excl=int(sum(excluded)),
    )


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


@rule(
    "audit.factor",
    tables="audit/block_factors/*/table",
    frequency="audit/block_factors/*/frequency_hz",
    printed="audit/block_factors/*/factor_printed",
    data="audit/block_factors/*/factor_data",
    follows="audit/block_factors/*/follows_printed",
    rows_ok="audit/block_factors/*/rows_printed_ok",
    rows_out="audit/block_factors/*/rows_with_output",
)
def _factor(tables, frequency, printed, data, follows, rows_ok, rows_out, table):
    mine = [i for i, t in enumerate(tables or []) if t == table]
    known = [i for i in mine if _finite(data[i])]
    if not known:
        return None
    values = {
        "table": table,
        "data": float(np.median([data[i] for i in known])),
        "low": min(data[i] for i in known),
        "high": max(data[i] for i in known),
    }
    spread = span(values["low"], values["high"], ".3f", "low", "high")
    footnote = printed[mine[0]]
    if not _finite(footnote):
        return say(
            "{table}: no footnote factor; the data follow DF = {data:.3f} x output / input "
            "(blocks " + spread + ").",
            **values,
        )
    # A block with no verdict (None) counts as following, as the audit's own sentence has it.
    off = [i for i in known if follows[i] is False]
    if not off:
        return None
    freqs = {f"f{j}": frequency[i] for j, i in enumerate(off)}
    which = "all" if len(off) == len(known) else "{n_off} of {n_known}"
    values.update(
        printed=footnote,
        ok=int(sum(rows_ok[i] for i in off)),
        n=int(sum(rows_out[i] for i in off)),
        n_off=len(off),
        n_known=len(known),
        ratio=values["data"] / footnote,
        **freqs,
    )
    return say(
        "{table}: the footnote factor {printed:.4g} fits {ok} of {n} rows in "
        + which
        + " frequency blocks ("
        + ", ".join("{" + k + ":g}" for k in freqs)
        + " c/s); the data follow {data:.3f} (blocks "
        + spread
        + "), i.e. {ratio:.3f} x the footnote.",
        **values,
    )


def audit_findings(results: dict) -> list:
    """The audit's statements of the Findings: the counts, then one per table whose rows do
    not follow its printed footnote factor."""
    audit = results.get("audit") or {}
    if not audit.get("tables"):
        return []
    tables = list(dict.fromkeys(b["table"] for b in audit.get("block_factors") or []))
    out = [paragraph(results, ("audit.counts", {}))]
    out += [paragraph(results, ("audit.factor", {"table": t})) for t in tables]
    return [p for p in out if p]
