"""Row-level audit of Appendix B (or a user's CSV): which printed cells can be trusted.

Every flag is computed, none typed by hand; datasets/README.md gives the method, its
calibration, the findings on the thesis data and the fitting row policy. In short:
(1) missing phases, zero outputs (phase undefined) and duplicates; (2) inputs out of
their block's increasing order; (3) ``df_reported`` recomputed as ``factor * h1 / input``
(footnotes of Tables B.1-B.5) at printed precision, with the factor each block actually
follows and power-of-ten shifted columns detected; (4) for a remaining inconsistent row,
the neighbours decide whether the input, the DF or only the output cell is wrong;
(5) spikes of magnitude or phase against their own curve, tuned not to flag the genuine
saturation knees.

The rules (rows under audit, checks, thresholds) are in :mod:`fitdf.data.audit_rules`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.data.audit_rules import _AUDIT_COLUMNS, MAG_SPIKE, PHASE_SPIKE, _analyse
from fitdf.errors import OptionError

__all__ = [
    "audit",
    "block_factors",
    "select_rows",
    "findings",
    "POLICIES",
    "MAG_SPIKE",
    "PHASE_SPIKE",
]

POLICIES = ("default", "all", "strict")


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
        ``phase_trusted``, ``h1_trusted``, ``exclude_default`` (the default fitting policy
        drops the row), ``df_recomputed`` (factor the block follows x output / input) and
        ``df_tolerance`` (printed precision of that comparison).

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


def select_rows(df: pd.DataFrame, policy: str = "default") -> pd.DataFrame:
    """Rows a fit uses under a policy (documented in datasets/README.md).

    ``"all"``: every row with a DF and a phase; ``"default"``: drops rows whose amplitude,
    magnitude or phase cannot be trusted and repeated duplicates; ``"strict"``: only rows
    the audit left unflagged. ``df`` may be audited already (its flags are then used).
    """
    if policy not in POLICIES:
        raise OptionError(f"unknown row policy {policy!r}; choose one of {', '.join(POLICIES)}")
    frame = df if all(c in df for c in _AUDIT_COLUMNS) else audit(df)
    keep = {"all": True, "default": ~frame["exclude_default"], "strict": frame["flag"] == "ok"}[
        policy
    ]
    return frame[frame["df_reported"].notna() & frame["phase_lead_deg"].notna() & keep]


def findings(df: pd.DataFrame) -> list[str]:
    """Human sentences for the report: factors, shifts, every suspect row, policy counts."""
    rows, blocks = _analyse(df)
    out = _factor_sentences(blocks)
    for _, b in blocks[blocks["shift_power"] != 0].iterrows():
        out.append(
            f"{b['table']} f={b['frequency_hz']:g} c/s rows {b['shift_rows']}: {b['shift_column']} printed "
            f"10^{b['shift_power']:+d} times its value (a power-of-ten shift); the rows are "
            "consistent once it is undone."
        )
    for label, r in rows[rows["flag"] == "suspect"].iterrows():
        where = f" ({r['source']})" if isinstance(r.get("source"), str) and r.get("source") else ""
        out.append(
            f"{r.get('table', 'data')} f={r['frequency_hz']:g} c/s row {r.get('row_in_block', label)} "
            f"(input {r['input_v']:g} V){where}: {r['reasons']}."
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
    out.append(
        f"Row policies on these {len(rows)} rows: 'all' keeps {keep['all']}, 'default' keeps "
        f"{keep['default']}, 'strict' keeps {keep['strict']}; {int((rows['flag'] == 'suspect').sum())} rows "
        f"are suspect, {int((rows['flag'] == 'note').sum())} carry a note."
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
