"""The bundled datasets and an audit as text: what ``fitdf datasets`` and ``fitdf audit`` print.

Within :data:`~fitdf._text.TEXT_WIDTH` columns unless ``wide`` (then every column of the
tables, as pandas prints them). Numbers are printed as read (``:g``), not rounded further.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf._text import TEXT_WIDTH, close_table_lines, table_lines, wrap
from fitdf.data import audit

__all__ = ["datasets_text", "audit_text"]


def _num(value, fmt: str = "g") -> str:
    return "" if value is None or pd.isna(value) else format(float(value), fmt)


def _value(value, fmt: str = "g") -> str:
    """A cell: yes/no for a flag, a number in ``fmt`` (empty for a missing one), else text."""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return _num(value, fmt)
    return str(value)


def datasets_text(names, table: pd.DataFrame, wide: bool = False, width=TEXT_WIDTH) -> str:
    """The bundled datasets and the Appendix B rows per table and frequency
    (:func:`fitdf.data.datasets.summary`)."""
    lines = wrap("Bundled datasets: " + ", ".join(names), width, "", "  ")
    lines += ["", "Appendix B rows per table and frequency:"]
    if wide:
        return "\n".join([*lines, table.to_string(index=False)])
    headers = ["table", "graph", "core", "source ohm", "f Hz", "rows", "saturated", "no phase"]
    headers.append("input V")
    rows = [
        [
            str(r["table"]),
            str(r["graph"]),
            str(r["core"]),
            _num(r["source_impedance_ohm"]),
            _num(r["frequency_hz"]),
            str(r["rows"]),
            str(r["saturation_rows"]),
            str(r["missing_phase"]),
            f"{r['input_min_v']:g}..{r['input_max_v']:g}",
        ]
        for _, r in table.iterrows()
    ]
    lines += table_lines(headers, rows, left=("table", "graph", "core"))
    legend = (
        "source ohm: the source impedance; saturated: rows the thesis marks as saturation; "
        "no phase: rows printed without a phase; input V: the input amplitudes (peak). "
        "--wide prints the table's own columns."
    )
    return "\n".join([*lines, "", *wrap(legend, width)])


#: Columns of a flagged row (as the audit names them, and as the text heads them).
_ROW_COLUMNS = {
    "table": "table",
    "frequency_hz": "f Hz",
    "row_in_block": "row",
    "input_v": "input V",
    "h1_output_v": "h1 V",
    "phase_lead_deg": "phase deg",
    "df_reported": "DF",
    "flag": "flag",
    "exclude_default": "excluded",
}
#: Columns of the DF-factor table, for the blocks whose table prints a factor.
_FACTOR_COLUMNS = {
    "table": "table",
    "source_impedance_ohm": "source ohm",
    "frequency_hz": "f Hz",
    "factor_printed": "printed",
    "factor_data": "data",
    "rows_with_output": "outputs",
    "rows_printed_ok": "ok printed",
    "rows_data_ok": "ok data",
    "follows_printed": "follows",
    "shift_power": "shift 10^",
    "shift_column": "column",
    "shift_rows": "rows",
}
#: The legend under the DF-factor table.
_FACTOR_LEGEND = (
    "printed: the footnote's factor; data: the factor the rows follow; outputs: rows with an "
    "output reading; ok printed, ok data: rows consistent with each factor at printed "
    "precision; follows: the rows follow the printed factor"
)
_SHIFT_LEGEND = "; shift 10^, column, rows: a column printed 10^shift times its value"


def _factor_lines(factors: pd.DataFrame, wide: bool, width: int) -> list[str]:
    """The DF factor each block follows beside its printed footnote factor: only blocks with a
    printed factor (a user's CSV has none), the shift columns only when a column is shifted."""
    printed = factors[factors["factor_printed"].notna()]
    if printed.empty:
        return []
    head = "DF factor per block (printed vs followed by the data):"
    if wide:
        return [head, printed.to_string(index=False), ""]
    cols = [c for c in _FACTOR_COLUMNS if c in printed]
    if not (printed.get("shift_power", pd.Series(dtype=int)) != 0).any():
        cols = [c for c in cols if not c.startswith("shift")]
    rows = [[_value(r[c], ".6g") for c in cols] for _, r in printed.iterrows()]
    headers = [_FACTOR_COLUMNS[c] for c in cols]
    lines = close_table_lines(headers, rows, ("table", "column", "rows"), width)
    shifted = "shift_power" in cols
    legend = wrap(_FACTOR_LEGEND + (_SHIFT_LEGEND if shifted else "") + ".", width)
    return [head, *lines, *legend, ""]


def _flagged_lines(flagged: pd.DataFrame, wide: bool, width: int) -> list[str]:
    """The flagged rows: a line of values each, its reasons wrapped beneath (``wide``: the
    audit's own columns, a row per line)."""
    if flagged.empty:
        return []
    cols = [c for c in _ROW_COLUMNS if c in flagged]
    if wide:
        with pd.option_context("display.max_colwidth", 200, "display.width", 250):
            return [flagged[[*cols, "reasons"]].to_string(index=False)]
    rows = [[_value(r[c]) for c in cols] for _, r in flagged.iterrows()]
    headers = [_ROW_COLUMNS[c] for c in cols]
    table = table_lines(headers, rows, left=("table", "flag", "excluded"))
    lines = [table[0]]
    for line, (_, r) in zip(table[1:], flagged.iterrows()):
        lines.append(line)
        lines += wrap(str(r.get("reasons") or ""), width, "    ")
    return lines


def audit_text(frame: pd.DataFrame, label: str, wide: bool = False, width=TEXT_WIDTH) -> str:
    """An audit (:func:`fitdf.data.audit.audit` of the rows of ``label``): the counts, what the
    default fit does with the column order, the DF factor of each block whose table prints
    one, the flagged rows with their reasons, then the findings."""
    flagged = frame[frame["flag"] != "ok"]
    excluded = int(frame["exclude_default"].sum())
    lines = [f"{len(frame)} rows, {len(flagged)} flagged, {excluded} excluded by default", ""]
    notes = audit.order_notes(audit.select_rows(frame), label)
    for note in notes:  # what the default fit does with the column order, before the detail
        lines += wrap(f"Column order: {note}.", width, "", "  ")
    lines += [""] if notes else []
    if "h1_output_v" in frame:
        lines += _factor_lines(audit.block_factors(frame), wide, width)
    lines += _flagged_lines(flagged, wide, width)
    for finding in audit.findings(frame):
        lines += [f"- {finding}"] if wide else wrap(f"- {finding}", width, "", "  ")
    return "\n".join(lines)
