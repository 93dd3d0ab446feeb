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
the same column of the other frequencies at the same flux (its rates on a corpus are in
docs/method/audit.rst).

The audit informs; it changes nothing. A row policy (:func:`select_rows`) decides which rows
a fit uses and in which order: by default (``trusted``) the values as printed, except a
column a documented decision of the dataset takes reversed (the bundled Table B.5's 10 c/s
phase, :func:`fitdf.data.datasets.decisions`); a column check (6) flags is taken reversed
only under the ``reordered`` policy, when the user asks.

The rules are in :mod:`fitdf.data.audit_rules` (checks 1-5), :mod:`fitdf.data.audit_order`
(check 6) and :mod:`fitdf.data.audit_rows` (the rows under audit, the thresholds).
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from fitdf.data.audit_order import REVERSAL_MARGIN, REVERSAL_RATIO
from fitdf.data.audit_rows import _AUDIT_COLUMNS, _REVERSED_REASON, MAG_SPIKE, PHASE_SPIKE, _columns
from fitdf.data.audit_rules import (
    _DECISION_REASON,
    APPLIED_COLUMN,
    _analyse,
    _order_only,
    _pending,
    _reversed_rows,
)
from fitdf.data.datasets import DECISION_COLUMN
from fitdf.errors import OptionError

__all__ = [
    "audit",
    "block_factors",
    "reversals",
    "select_rows",
    "policy_name",
    "order_notes",
    "decisions",
    "findings",
    "POLICIES",
    "DEFAULT_POLICY",
    "MAG_SPIKE",
    "PHASE_SPIKE",
]

#: Row policies of :func:`select_rows` (datasets/README.md); the first is the default.
POLICIES = ("trusted", "reordered", "as_printed", "all", "strict")
#: The policy a fit uses unless told otherwise.
DEFAULT_POLICY = POLICIES[0]
#: Other names a policy answers to: ``default`` is the default policy, whatever it is.
POLICY_ALIASES = {"default": DEFAULT_POLICY}


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
        ``exclude_default`` (the default policy, ``trusted``, drops the row: computed on
        the values it fits), ``df_recomputed`` (factor the block follows x output / input),
        ``df_tolerance`` (printed precision of that comparison), ``reversed_columns``
        (comma-joined columns of the row's block that check 6 flags as printed in reverse
        order, which only the ``reordered`` policy takes reversed; empty for most rows) and
        ``exclude_as_printed`` (the ``as_printed`` policy drops the row).

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
        reversed input column explains). ``axis``: "saturation" (input over the block's
        saturation input) or "flux" (input over frequency: the table marks no saturation
        row); ``neighbours``: blocks compared with; ``points``: the block's points their
        prediction covers; ``misfit_printed`` / ``misfit_reversed``: RMS distance, in the
        column's unit, to the column the neighbours predict at the same flux
        (interpolated in log frequency), ``ratio`` = printed / reversed; ``rho_printed`` /
        ``rho_reversed``: median Spearman rank correlation with the neighbours' curves,
        ``gain`` = reversed - printed; ``reversed``: flagged; ``verdict``: "reversed",
        "as printed", or why it "cannot judge".
    """
    return _order_only(df)


def policy_name(policy: str) -> str:
    """The policy ``policy`` names (an alias resolved); a one-line OptionError otherwise."""
    name = POLICY_ALIASES.get(policy, policy)
    if name not in POLICIES:
        raise OptionError(
            f"unknown row policy {policy!r}; choose one of {', '.join(POLICIES)} "
            f"({DEFAULT_POLICY} is the default)"
        )
    return name


def select_rows(df: pd.DataFrame, policy: str = DEFAULT_POLICY) -> pd.DataFrame:
    """Rows a fit uses under a policy (documented in datasets/README.md).

    ``"trusted"`` (the default; ``"default"`` names it too): rows whose amplitude,
    magnitude and phase the audit trusts, repeats of duplicates dropped, every value as
    printed except the columns a documented decision of the dataset takes in reverse order
    within their block (:data:`~fitdf.data.datasets.DECISION_COLUMN`: the bundled Table
    B.5's 10 c/s phase), which are taken reversed; ``"reordered"``: the same, with the
    columns check (6) flags also taken reversed (the repair, applied when asked);
    ``"as_printed"``: the same rows with every value as printed; ``"all"``: every row with a
    DF and a phase, as printed; ``"strict"``: only rows the audit left unflagged, as printed.
    A reversed column keeps its printed values in ``<column>_printed``, and
    ``reversed_applied`` names it. ``df`` may be audited already (its flags are then used),
    or selected already by the same policy (it is then returned as it is).
    """
    policy = policy_name(policy)
    frame = df if all(c in df for c in _AUDIT_COLUMNS) else audit(df)
    decided = frame.get(DECISION_COLUMN, pd.Series("", index=frame.index)).fillna("").astype(str)
    spec = {
        "trusted": decided.to_numpy(object),
        "reordered": np.array(
            [
                ",".join(dict.fromkeys([*_columns(d), *_columns(f)]))
                for d, f in zip(decided, frame["reversed_columns"].fillna(""))
            ],
            dtype=object,
        ),
    }.get(policy, np.full(len(frame), "", dtype=object))
    applied = frame.get(APPLIED_COLUMN, pd.Series("", index=frame.index)).fillna("").astype(str)
    extra = [a for a, s in zip(applied, spec) if set(_columns(a)) - set(_columns(s))]
    if extra:
        raise OptionError(
            f"these rows hold {extra[0]} reversed already (selected by another row policy); "
            f"select the '{policy}' rows from the data as loaded"
        )
    pending = _pending(frame, spec)
    fitted = _reversed_rows(frame, pending) if pending.astype(bool).any() else frame
    keep = {
        "all": np.ones(len(frame), bool),
        "trusted": ~fitted["exclude_default"].to_numpy(bool),
        "reordered": ~fitted["exclude_default"].to_numpy(bool),
        "as_printed": ~frame["exclude_as_printed"].to_numpy(bool),
        "strict": (frame["flag"] == "ok").to_numpy(),
    }[policy]
    return fitted[
        fitted["df_reported"].notna().to_numpy()
        & fitted["phase_lead_deg"].notna().to_numpy()
        & keep
    ]


def order_notes(rows: pd.DataFrame, label: str = "data") -> list[str]:
    """One line per block of ``rows`` (selected by a policy) about its column order.

    A column taken in reverse order (by a documented decision or the ``reordered`` policy)
    is said, and so is a column check (6) flags that is fitted as printed, with the option
    that would fit it reversed: the lines ``fitdf fit`` prints as warnings.
    """
    out = []
    keys = [k for k in ("table", "source_impedance_ohm", "frequency_hz") if k in rows]
    get = lambda c: rows.get(c, pd.Series("", index=rows.index)).fillna("").astype(str)  # noqa: E731
    frame = rows.assign(_flagged=get("reversed_columns"), _applied=get(APPLIED_COLUMN))
    frame = frame.assign(_decided=get(DECISION_COLUMN))
    for key, g in frame.groupby(keys, sort=False):
        key = dict(zip(keys, key if isinstance(key, tuple) else (key,)))
        table = str(key.get("table", ""))
        where = f"{label}{f' {table}' if table not in label else ''} f={key['frequency_hz']:g} c/s"
        applied, decided = _columns(g["_applied"].iloc[0]), _columns(g["_decided"].iloc[0])
        for c in applied:
            why = (
                "by a documented decision of the dataset; --policy as_printed fits it as printed"
                if c in decided
                else "by the 'reordered' policy, as asked"
            )
            out.append(f"{where}: {c} is fitted in reverse order within its block ({why})")
        for c in _columns(g["_flagged"].iloc[0]):
            if c not in applied:
                out.append(
                    f"{where}: the audit reads {c} as printed in reverse order within its block "
                    "(the audit's findings give the evidence); it is fitted as printed, "
                    "--policy reordered fits it reversed"
                )
    return out


def decisions(df: pd.DataFrame) -> pd.DataFrame:
    """The documented decisions on ``df``'s blocks, with what the column-order rule says.

    One row per (block, decided column): the block's keys, ``column``, ``rows``,
    ``printed`` and ``fitted`` (the column's values in printed order, as printed and as the
    default policy fits them), and, from :func:`reversals`, ``verdict`` (the rule's on the
    printed column), ``misfit_printed``, ``misfit_reversed``, ``rho_printed``,
    ``rho_reversed`` and ``neighbours``.
    """
    cols = [
        "table",
        "source_impedance_ohm",
        "frequency_hz",
        "column",
        "rows",
        "printed",
        "fitted",
        "verdict",
        "neighbours",
        "misfit_printed",
        "misfit_reversed",
        "rho_printed",
        "rho_reversed",
    ]
    if DECISION_COLUMN not in df or not df[DECISION_COLUMN].fillna("").astype(bool).any():
        return pd.DataFrame(columns=cols)
    rows, _, order = _analyse(df)
    return _decision_records(rows, order)[cols] if len(rows) else pd.DataFrame(columns=cols)


def _decision_records(rows: pd.DataFrame, order: pd.DataFrame) -> pd.DataFrame:
    out = []
    keys = ["table", "source_impedance_ohm", "frequency_hz"]
    decided = rows[rows[DECISION_COLUMN].fillna("").astype(bool)]
    for key, g in decided.groupby(keys, sort=False):
        if "row_in_block" in g:
            g = g.sort_values("row_in_block", kind="stable")
        for c in _columns(g[DECISION_COLUMN].iloc[0]):
            v = g[c].to_numpy(float).tolist()
            rec = {**dict(zip(keys, key)), "column": c, "rows": len(g), "printed": v}
            rec["fitted"] = v[::-1]
            judged = order[
                (order["table"] == key[0])
                & (order["source_impedance_ohm"] == key[1])
                & (order["frequency_hz"] == key[2])
                & (order["column"] == c)
            ]
            j = judged.iloc[0] if len(judged) else {}
            for k in ("verdict", "neighbours", "misfit_printed", "misfit_reversed"):
                rec[k] = j.get(k, np.nan) if len(judged) else np.nan
            for k in ("rho_printed", "rho_reversed"):
                rec[k] = j.get(k, np.nan) if len(judged) else np.nan
            out.append(rec)
    return pd.DataFrame(out)


def findings(df: pd.DataFrame) -> list[str]:
    """Human sentences for the report: factors, shifts, decisions, column order, every
    suspect row, policy counts."""
    rows, blocks, order = _analyse(df)
    out = _factor_sentences(blocks)
    for _, b in blocks[blocks["shift_power"] != 0].iterrows():
        out.append(
            f"{b['table']} f={b['frequency_hz']:g} c/s rows {b['shift_rows']}: {b['shift_column']} printed "
            f"10^{b['shift_power']:+d} times its value (a power-of-ten shift); the rows are "
            "consistent once it is undone."
        )
    out += _decision_sentences(rows, order)
    out += _order_sentences(order, rows)
    for label, r in rows[rows["flag"] == "suspect"].iterrows():
        reasons = [  # a reversed or decided column is said once for its block, above
            x
            for x in r["reasons"].split("; ")
            if _REVERSED_REASON not in x and _DECISION_REASON not in x
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
    decided = rows.get(DECISION_COLUMN, pd.Series("", index=rows.index)).fillna("").astype(bool)
    flagged = rows["reversed_columns"].fillna("").astype(bool)
    n_dec, n_rev = int(decided.sum()), int((flagged & ~decided).sum())
    how = (
        f" (with the {n_dec} rows of the column(s) a documented decision takes reversed in "
        "reversed order)"
        if n_dec
        else ""
    )
    how_re = f" (with {n_rev} more rows of flagged column(s) reversed)" if n_rev else ""
    out.append(
        f"Row policies on these {len(rows)} rows: 'trusted' (the default) keeps "
        f"{keep['trusted']}{how}, 'reordered' keeps {keep['reordered']}{how_re}, 'as_printed' "
        f"keeps {keep['as_printed']}, 'all' keeps {keep['all']}, 'strict' keeps "
        f"{keep['strict']}; {int((rows['flag'] == 'suspect').sum())} rows are suspect, "
        f"{int((rows['flag'] == 'note').sum())} carry a note."
    )
    return out


def _lines(g: pd.DataFrame) -> str:
    """``(thesis.txt lines 1955-1977)`` from the ``source`` cells of a block, if any."""
    found = [re.fullmatch(r"(.*) line (\d+)", str(s)) for s in g.get("source", [])]
    if not found or not all(found) or len({m[1] for m in found}) != 1:
        return ""
    lines = [int(m[2]) for m in found]
    return f", {found[0][1]} lines {min(lines)}-{max(lines)}"


def _values(v) -> str:
    return ", ".join(f"{x:g}" for x in v)


def _decision_sentences(rows: pd.DataFrame, order: pd.DataFrame) -> list[str]:
    """Each documented decision, said as one: what is taken reversed, and what stays."""
    if DECISION_COLUMN not in rows:
        return []
    out = []
    for _, d in _decision_records(rows, order).iterrows():
        out.append(
            f"{d['table']} f={d['frequency_hz']:g} c/s {d['column']} ({d['rows']} rows): taken in "
            "reverse order within its block by a documented decision of the dataset "
            f"({DECISION_COLUMN}; for the bundled tables fitdf.datasets.DECISIONS, with the "
            "evidence in datasets/README.md), not by a rule at run time. The cells stay as "
            "printed; the default policy 'trusted' fits the column reversed and says so in "
            f"each row's reasons, 'as_printed' fits it as printed. Printed {_values(d['printed'])}; "
            f"fitted {_values(d['fitted'])}."
        )
    return out


_AXIS = {
    "saturation": "at the same input over saturation input",
    "flux": "at the same input over frequency (flux; the table marks no saturation row)",
}


def _order_sentences(order: pd.DataFrame, rows: pd.DataFrame) -> list[str]:
    """The column-order check (6): a summary, then each reversed column with its evidence."""
    tested = order[order["column"] != "input_v"]
    if tested.empty:
        return []
    judged = tested[~tested["verdict"].str.startswith("cannot")]
    flagged = order[order["reversed"].astype(bool) & ~order["verdict"].str.startswith("reads")]
    others = judged[~judged["reversed"].astype(bool)]
    which = ", ".join(
        f"{b['table']} f={b['frequency_hz']:g} c/s {b['column']}" for _, b in flagged.iterrows()
    )
    summary = (
        f"Column order: {len(judged)} of the {len(tested)} (block, column) pairs could be judged "
        f"({len(tested) - len(judged)} are too flat, or have fewer than 2 comparable neighbouring "
        f"frequencies); {len(flagged) or 'none'} read{'s' * (len(flagged) == 1)} in reverse "
        f"order{f' ({which})' if which else ''}"
    )
    if len(others):
        top = others.loc[others["ratio"].idxmax()]
        summary += (
            f"; of the others, the printed column lies at most {top['ratio']:.2f} times as far "
            "from the column its neighbours predict as reversed "
            f"({top['table']} f={top['frequency_hz']:g} c/s {top['column']}; flagged from "
            f"{REVERSAL_RATIO:g} times)"
        )
    out = [summary + "."]
    decided = rows.get(DECISION_COLUMN, pd.Series("", index=rows.index)).fillna("").astype(str)
    for _, b in flagged.iterrows():
        block = order[
            (order["table"] == b["table"])
            & (order["source_impedance_ohm"] == b["source_impedance_ohm"])
            & (order["frequency_hz"] == b["frequency_hz"])
        ]
        g = rows[
            (rows.get("table", "data") == b["table"])
            & (rows["source_impedance_ohm"] == b["source_impedance_ohm"])
            & (rows["frequency_hz"] == b["frequency_hz"])
        ]
        if "row_in_block" in g:
            g = g.sort_values("row_in_block", kind="stable")
        v = g[b["column"]].to_numpy(float)
        head = f"{b['table']} f={b['frequency_hz']:g} c/s {b['column']} ({len(g)} rows{_lines(g)})"
        if b["column"] == "input_v":
            cols = block[block["verdict"].str.startswith("reads")]
            evidence = (
                "every other column reads reversed against it ("
                + ", ".join(
                    f"{c['column']}: {c['misfit_printed']:.3g} from the column its "
                    f"{c['neighbours']:g} neighbouring frequency blocks predict as printed, "
                    f"{c['misfit_reversed']:.3g} reversed"
                    for _, c in cols.iterrows()
                )
                + "), and none reads better as printed"
            )
        else:
            unit = {"phase_lead_deg": " deg", "h1_output_v": " V"}.get(b["column"], "")
            margin = REVERSAL_MARGIN[b["column"]]
            evidence = (
                f"{_AXIS[b['axis']]}, its RMS distance to the column its {b['neighbours']:g} "
                f"neighbouring frequency blocks predict is {b['misfit_printed']:.3g}{unit} as "
                f"printed and {b['misfit_reversed']:.3g}{unit} reversed ({b['ratio']:.1f} times "
                f"nearer reversed; flagged from {REVERSAL_RATIO:g} times"
                + (f" and {margin:g}{unit} nearer" if margin else "")
                + f"), and its median rank correlation with them is {b['rho_printed']:+.2f} "
                f"printed, {b['rho_reversed']:+.2f} reversed"
            )
        is_decided = b["column"] in _columns(decided[g.index[0]] if len(g) else "")
        tail = (
            "A documented decision of the dataset takes it reversed (said above), so the "
            "default policy 'trusted' fits it reversed by that decision; 'as_printed' fits it "
            "as printed."
            if is_decided
            else "It is fitted as printed by default ('trusted'); the 'reordered' policy "
            "(fitdf fit --policy reordered) fits it reversed."
        )
        out.append(
            f"{head} reads in reverse order: {evidence}; printed {_values(v)}, reversed "
            f"{_values(v[::-1])}. {tail}"
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
