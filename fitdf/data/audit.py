"""Row-level audit of Appendix B (or a user's CSV): which printed cells can be trusted.

Every flag is computed, none typed by hand; datasets/README.md gives the method, its
calibration, the findings on the thesis data and the fitting row policies. In short:
(1) missing phases, zero outputs (phase undefined) and duplicates; (2) inputs out of
their block's increasing order; (3) ``df_reported`` recomputed as ``factor * h1 / input``
(footnotes of Tables B.1-B.5) at printed precision, with the factor each block actually
follows and power-of-ten shifted columns detected; (4) for a remaining inconsistent row,
the neighbours decide whether the input, the DF or only the output cell is wrong;
(5) spikes of magnitude or phase against their own curve, tuned not to flag the genuine
saturation knees; (6) columns printed in reverse order within their block, judged against
the same column of the other frequencies (on the input axis divided by each block's
saturation input) and, for the input column, against the inputs output and DF imply.

The rules (rows under audit, checks, thresholds) are in :mod:`fitdf.data.audit_rules`.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from fitdf.data.audit_rules import (
    _AUDIT_COLUMNS,
    _REVERSED_REASON,
    MAG_SPIKE,
    PHASE_SPIKE,
    REVERSAL_GAIN,
    _analyse,
    _reversed_rows,
)
from fitdf.errors import OptionError

__all__ = [
    "audit",
    "block_factors",
    "reversals",
    "select_rows",
    "findings",
    "POLICIES",
    "MAG_SPIKE",
    "PHASE_SPIKE",
]

#: Row policies of :func:`select_rows` (datasets/README.md); the first is the default.
POLICIES = ("default", "as_printed", "all", "strict")


# ------------------------------------------------------------------ public API
def audit(df: pd.DataFrame) -> pd.DataFrame:
    """Flag every row of an Appendix B schema frame.

    Parameters
    ----------
    df : pandas.DataFrame
        From :func:`fitdf.datasets.load` (bundled or user CSV); needs ``input_v``,
        ``df_reported``, ``phase_lead_deg`` and ``frequency_hz``. Checks needing other
        columns (``h1_output_v`` for the DF recomputation) run only when they are present.

    Returns
    -------
    pandas.DataFrame
        The input rows (same index) plus ``flag`` ("ok", "note" or "suspect"), ``reasons``
        ("; "-joined, empty when ok), ``amplitude_trusted``, ``magnitude_trusted``,
        ``phase_trusted``, ``h1_trusted`` (checks 1-5 on the printed cells),
        ``exclude_default`` (the default fitting policy drops the row), ``df_recomputed``
        (factor the block follows x output / input), ``df_tolerance`` (printed precision
        of that comparison), ``reversed_columns`` (comma-joined columns of the row's block
        that check 6 finds printed in reverse order, which the default policy takes
        reversed; empty for most rows) and ``exclude_as_printed`` (the ``as_printed``
        policy drops the row).

    Examples
    --------
    >>> from fitdf import datasets
    >>> a = audit(datasets.load("B.3"))
    >>> a.loc[a["input_v"] == 0.01, ["flag", "amplitude_trusted"]].values.tolist()
    [['suspect', False]]
    """
    return _analyse(df)[0]


def block_factors(df: pd.DataFrame) -> pd.DataFrame:
    """The DF factor each (table, source impedance, frequency) block follows vs the footnote's.

    Columns: ``factor_printed``, ``factor_data`` (robust median of ``df * input / h1``
    after undoing a shift), ``rows_with_output``, ``rows_printed_ok`` / ``rows_data_ok``
    (rows consistent with each factor at printed precision), ``follows_printed``, and
    ``shift_power`` (a shifted column is printed ``10**shift_power`` times its value; 0 if
    none), ``shift_column``, ``shift_rows`` (``row_in_block`` range).
    """
    return _analyse(df)[1]


def reversals(df: pd.DataFrame) -> pd.DataFrame:
    """The column-order check (6) of every (block, column): printed versus reversed.

    Parameters
    ----------
    df : pandas.DataFrame
        As for :func:`audit`.

    Returns
    -------
    pandas.DataFrame
        One row per block and tested column (``phase_lead_deg``, ``df_reported``,
        ``h1_output_v``; an ``input_v`` row is added for a block whose flagged columns a
        reversed input column explains). ``neighbours``: blocks compared with;
        ``rho_printed`` / ``rho_reversed``: median Spearman rank correlation with their curves
        on the input axis divided by each block's saturation input, ``gain`` = reversed -
        printed; ``misfit_printed`` / ``misfit_reversed``: RMS distance to the neighbours'
        median curve, in the column's unit; ``extreme_printed`` / ``extreme_reversed``: rows
        from the saturation row (else the DF peak) to the phase minimum or DF maximum;
        ``reversed``: flagged; ``verdict``: "reversed", "as printed", or why it "cannot
        judge".
    """
    return _analyse(df)[2]


def select_rows(df: pd.DataFrame, policy: str = "default") -> pd.DataFrame:
    """Rows a fit uses under a policy (documented in datasets/README.md).

    ``"default"``: the columns check (6) finds printed in reverse order taken reversed
    within their block (``<column>_printed`` keeps the printed values, ``reversed_columns``
    names them), then rows whose amplitude, magnitude or phase cannot be trusted and
    repeated duplicates dropped; ``"as_printed"``: the same without the reversals;
    ``"all"``: every row with a DF and a phase, as printed; ``"strict"``: only rows the
    audit left unflagged, as printed. ``df`` may be audited already (its flags are then
    used).
    """
    if policy not in POLICIES:
        raise OptionError(f"unknown row policy {policy!r}; choose one of {', '.join(POLICIES)}")
    frame = df if all(c in df for c in _AUDIT_COLUMNS) else audit(df)
    fitted = frame
    if policy == "default" and frame["reversed_columns"].fillna("").astype(bool).any():
        fitted = _reversed_rows(frame)
    keep = {
        "all": np.ones(len(frame), bool),
        "default": ~frame["exclude_default"].to_numpy(bool),
        "as_printed": ~frame["exclude_as_printed"].to_numpy(bool),
        "strict": (frame["flag"] == "ok").to_numpy(),
    }[policy]
    return fitted[
        fitted["df_reported"].notna().to_numpy()
        & fitted["phase_lead_deg"].notna().to_numpy()
        & keep
    ]


def findings(df: pd.DataFrame) -> list[str]:
    """Human sentences for the report: factors, shifts, column order, every suspect row,
    policy counts."""
    rows, blocks, order = _analyse(df)
    out = _factor_sentences(blocks)
    for _, b in blocks[blocks["shift_power"] != 0].iterrows():
        out.append(
            f"{b['table']} f={b['frequency_hz']:g} c/s rows {b['shift_rows']}: {b['shift_column']} printed "
            f"10^{b['shift_power']:+d} times its value (a power-of-ten shift); the rows are "
            "consistent once it is undone."
        )
    out += _order_sentences(order, rows)
    for label, r in rows[rows["flag"] == "suspect"].iterrows():
        reasons = [  # a reversed column is said once for its block, above
            x for x in r["reasons"].split("; ") if _REVERSED_REASON not in x
        ]
        if not reasons:
            continue
        where = f" ({r['source']})" if isinstance(r.get("source"), str) and r.get("source") else ""
        out.append(
            f"{r.get('table', 'data')} f={r['frequency_hz']:g} c/s row {r.get('row_in_block', label)} "
            f"(input {r['input_v']:g} V){where}: {'; '.join(reasons)}."
        )
    zero = rows[rows["df_reported"] == 0]
    if len(zero):
        cells = ", ".join(
            f"{r.get('table', 'data')} {r['frequency_hz']:g} c/s {r['input_v']:g} V"
            for _, r in zero.iterrows()
        )
        out.append(
            f"{len(zero)} rows have zero output ({cells}): magnitude 0 is kept, the printed phase of a zero "
            "signal is meaningless (phase untrusted)."
        )
    keep = {p: len(select_rows(rows, p)) for p in POLICIES}
    n_rev = int(rows["reversed_columns"].astype(bool).sum())
    how = f" (with the {n_rev} rows of the reversed column(s) in reversed order)" if n_rev else ""
    out.append(
        f"Row policies on these {len(rows)} rows: 'all' keeps {keep['all']}, 'default' keeps "
        f"{keep['default']}{how}, 'as_printed' keeps {keep['as_printed']}, 'strict' keeps "
        f"{keep['strict']}; {int((rows['flag'] == 'suspect').sum())} rows "
        f"are suspect, {int((rows['flag'] == 'note').sum())} carry a note."
    )
    return out


def _lines(g: pd.DataFrame) -> str:
    """``(thesis.txt lines 1955-1977)`` from the ``source`` cells of a block, if any."""
    found = [re.fullmatch(r"(.*) line (\d+)", str(s)) for s in g.get("source", [])]
    if not found or not all(found) or len({m[1] for m in found}) != 1:
        return ""
    lines = [int(m[2]) for m in found]
    return f", {found[0][1]} lines {min(lines)}-{max(lines)}"


def _where(extreme: float, anchor: str) -> str:
    """``"2 rows after the saturation row"`` for an offset of +2 rows from ``anchor``."""
    if extreme == 0:
        return f"at the {anchor}"
    side = "after" if extreme > 0 else "before"
    return f"{abs(extreme):g} row{'s' * (abs(extreme) != 1)} {side} the {anchor}"


def _order_sentences(order: pd.DataFrame, rows: pd.DataFrame) -> list[str]:
    """The column-order check (6): a summary, then each reversed column with its evidence."""
    tested = order[order["column"] != "input_v"]
    if tested.empty:
        return []
    judged = tested[~tested["verdict"].str.startswith("cannot")]
    flagged = order[order["reversed"].astype(bool) & ~order["verdict"].str.startswith("reads")]
    others = judged[~judged["reversed"].astype(bool)]
    best = others["gain"].max() if len(others) else np.nan
    which = ", ".join(
        f"{b['table']} f={b['frequency_hz']:g} c/s {b['column']}" for _, b in flagged.iterrows()
    )
    out = [
        f"Column order: {len(judged)} of the {len(tested)} (block, column) pairs could be judged "
        f"({len(tested) - len(judged)} are too flat, or have fewer than 2 comparable neighbouring "
        f"frequencies); {len(flagged) or 'none'} read{'s' * (len(flagged) == 1)} better in reverse "
        f"order{f' ({which})' if which else ''}"
        + (
            f"; for every other, reversing changes its rank correlation by at most {best:+.2f} "
            f"(threshold {REVERSAL_GAIN:+.1f})."
            if np.isfinite(best)
            else "."
        )
    ]
    for _, b in flagged.iterrows():
        block = order[
            (order["table"] == b["table"])
            & (order["source_impedance_ohm"] == b["source_impedance_ohm"])
            & (order["frequency_hz"] == b["frequency_hz"])
        ]
        g = rows[
            (rows.get("table", "data") == b["table"])
            & (rows["frequency_hz"] == b["frequency_hz"])
            & (rows["reversed_columns"] != "")
        ]
        if "row_in_block" in g:
            g = g.sort_values("row_in_block", kind="stable")
        v = g[b["column"]].to_numpy(float)
        head = f"{b['table']} f={b['frequency_hz']:g} c/s {b['column']} ({len(g)} rows{_lines(g)})"
        if b["column"] == "input_v":
            cols = block[block["verdict"].str.startswith("reads")]
            gain = cols["gain"].min()
            evidence = (
                "every other column reads reversed against it ("
                + ", ".join(
                    f"{c['column']}: median rank correlation with {c['neighbours']:g} neighbouring "
                    f"frequency blocks {c['rho_printed']:+.2f} as printed, {c['rho_reversed']:+.2f} "
                    "reversed"
                    for _, c in cols.iterrows()
                )
                + "), and none reads better as printed"
            )
        else:
            gain = b["gain"]
            unit = {"phase_lead_deg": " deg", "h1_output_v": " V"}.get(b["column"], "")
            anchor = "saturation row" if g.get("saturation", pd.Series(False)).any() else "DF peak"
            what = "minimum" if b["column"] == "phase_lead_deg" else "maximum"
            evidence = (
                f"against {b['neighbours']:g} neighbouring frequency blocks, on the input "
                f"axis divided by each block's saturation input, its median rank correlation is "
                f"{b['rho_printed']:+.2f} as printed and {b['rho_reversed']:+.2f} reversed, its "
                f"RMS distance to their median curve {b['misfit_printed']:.3g}{unit} printed and "
                f"{b['misfit_reversed']:.3g}{unit} reversed"
            )
            if np.isfinite(b["extreme_printed"]):
                evidence += (
                    f", and its {what} sits {_where(b['extreme_printed'], anchor)} as printed, "
                    f"{_where(b['extreme_reversed'], anchor)} reversed"
                )
        rest = f" while no other column gains more than {best:+.2f}" if np.isfinite(best) else ""
        out.append(
            f"{head} reads in reverse order: {evidence}; printed "
            f"{', '.join(f'{x:g}' for x in v)}, reversed {', '.join(f'{x:g}' for x in v[::-1])}. "
            f"The 'default' policy fits it reversed, since its gain ({gain:+.2f}) is past the "
            f"threshold{rest}; 'as_printed' fits it as printed."
        )
    return out


def _factor_sentences(blocks: pd.DataFrame) -> list[str]:
    out = []
    for table, g in blocks.groupby("table", sort=False):
        known = g[g["factor_data"].notna()]
        if known.empty:
            continue
        printed, data = g["factor_printed"].iloc[0], np.median(known["factor_data"])
        off = known[~known["follows_printed"].fillna(True).astype(bool)]
        spread = f"{known['factor_data'].min():.3f}-{known['factor_data'].max():.3f}"
        if np.isnan(printed):
            out.append(
                f"{table}: no footnote factor; the data follow DF = {data:.3f} x output / input "
                f"(blocks {spread})."
            )
        elif off.empty:
            out.append(
                f"{table}: the footnote factor {printed:.4g} is followed by all {len(known)} frequency blocks "
                f"(data {spread})."
            )
        else:
            which = "all" if len(off) == len(known) else f"{len(off)} of {len(known)}"
            freqs = ", ".join(f"{f:g}" for f in off["frequency_hz"])
            out.append(
                f"{table}: the footnote factor {printed:.4g} fits {int(off['rows_printed_ok'].sum())} of "
                f"{int(off['rows_with_output'].sum())} rows in {which} frequency blocks ({freqs} c/s); the data "
                f"follow {data:.3f} (blocks {spread}), i.e. {data / printed:.3f} x the footnote."
            )
    return out
