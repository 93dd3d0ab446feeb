"""The rules of the row audit: the rows under audit, the checks and their thresholds.

:func:`_analyse` runs the checks (1)-(6) of :mod:`fitdf.data.audit` on a frame and
returns the flagged rows, the DF factor of each block and the column-order verdict of
each (block, column); :func:`_reversed_rows` audits the values a row policy fits (columns
taken in reverse order within their block: those a documented decision names under the
default policy, also those check (6) flags under ``reordered``). The public functions there
(``audit``, ``block_factors``, ``reversals``, ``select_rows``, ``findings``) read their
output.
"""

from __future__ import annotations

from bisect import bisect_left
from itertools import groupby

import numpy as np
import pandas as pd

from fitdf.data.datasets import DECIDABLE_COLUMNS, DECISION_COLUMN
from fitdf.errors import DataError

__all__ = [
    "MAG_SPIKE",
    "PHASE_SPIKE",
    "MAG_NOISE",
    "STEP_OUTLIER",
    "REVERSIBLE",
    "REVERSAL_RATIO",
    "REVERSAL_RATIO_HIGHEST",
    "REVERSAL_MARGIN",
    "FLAT_RANGE",
    "MIN_OVERLAP",
    "MIN_NEIGHBOURS",
    "INPUT_REVERSED_COLUMNS",
]

# Calibration on the 264 bundled rows (best-of-three leave-one-out residuals of the 220
# interior magnitude and 213 interior phase points, see _best_residual): the within-block
# scatter is 1.4826*MAD = 0.006 in DF and 0.46 deg in phase. The largest residuals of local
# extrema all sit at genuine saturation knees (a ``**`` row or its neighbour): 0.056
# (B.5 10 c/s 1.5 V), 0.050 (B.4 3 c/s 0.5 V) in DF; 4.7 deg (B.4 3 c/s 0.5 V), 4.5 deg
# (B.5 3 c/s 0.7 V) in phase; away from knees none exceeds 0.020 / 3.5 deg. The thresholds
# sit ~1.5x above every knee (> 10 sigma): no knee is flagged, a slipped digit
# (>= 0.1 in DF, >= 10 deg) is.
#: Magnitude spike threshold (DF units) of the smoothness test.
MAG_SPIKE = 0.08
#: Phase spike threshold (degrees) of the smoothness test.
PHASE_SPIKE = 8.0
#: ~3 sigma of the DF scatter: a DF this close to its curve is not blamed for an inconsistency.
MAG_NOISE = 0.02
#: A printed input whose log-step to a neighbour exceeds this multiple of the block's
#: median log-step is "off its sequence" (B.3 10 c/s: 0.01 -> 0.25 V is 14x the median).
STEP_OUTLIER = 4.0
#: Relative window (log10) around a block's median factor that counts as "following" it.
_FACTOR_WINDOW = 0.02

# Column order (check 6). A column is compared with the same column of its neighbouring
# blocks (the other frequencies of its table and source impedance) at the same flux: on the
# axis u = log(input / reference input), the reference being the block's saturation (``**``)
# input; a block without the mark takes its frequency times the median saturation input over
# frequency of the marked blocks, and a table without marks its frequency (Faraday's law: the
# peak flux of a sinusoidal drive is input / (2 pi f N), so equal input / frequency is equal
# flux; on the thesis tables the marked saturation inputs over frequency agree within a factor
# 1.6 per table). Two statistics, printed and with the column reversed: the RMS distance to
# the column predicted from the neighbours (at each point, interpolated in log frequency
# between the nearest lower and higher frequencies covering it, else the nearest one), and
# the median over the neighbours of Spearman's rank correlation with each neighbour's curve.
# Validated on the corpus of benchmarks/audit_order_corpus.py (rates in docs/method/audit.rst).
#: Columns tested for a reversed order (the input column is the axis: see _check_reversals).
REVERSIBLE = ("phase_lead_deg", "df_reported", "h1_output_v")
#: The printed column must lie this many times farther from its predicted curve than the
#: reversed one ...
REVERSAL_RATIO = 2.0
#: ... this many at the highest frequency of its table, whose prediction extrapolates from
#: lower frequencies while rate-dependent (eddy-current) loss grows with frequency and flux:
#: a genuine rise there must not read as a reversal ...
REVERSAL_RATIO_HIGHEST = 4.0
#: ... by at least this much in the column's unit (half the spike thresholds: ~9 times the
#: tables' within-block scatter), and reversing must raise the rank correlation, for the
#: column to be flagged as printed in reverse order.
REVERSAL_MARGIN = {
    "phase_lead_deg": PHASE_SPIKE / 2,
    "df_reported": MAG_SPIKE / 2,
    "h1_output_v": 0.0,
}
#: A column spanning less has no shape to compare (1.25x the spike thresholds: no feature
#: larger than one slipped digit); h1_output_v only needs to vary.
FLAT_RANGE = {"phase_lead_deg": 1.25 * PHASE_SPIKE, "df_reported": 1.25 * MAG_SPIKE}
#: Points of a block a neighbour's curve must cover to be compared with it.
MIN_OVERLAP = 4
#: Comparable neighbours needed to judge: with one, either block could be the reversed one.
MIN_NEIGHBOURS = 2
#: Columns a block must flag, with none reading better as printed, for its input column to
#: be the one printed reversed (every other column then reads reversed against it).
INPUT_REVERSED_COLUMNS = 2

_AUDIT_COLUMNS = (
    "flag",
    "reasons",
    "amplitude_trusted",
    "magnitude_trusted",
    "phase_trusted",
    "h1_trusted",
    "exclude_default",
    "df_recomputed",
    "df_tolerance",
    "reversed_columns",
    "exclude_as_printed",
)
_BLOCK = ["table", "source_impedance_ohm", "frequency_hz"]
_FACTOR_COLUMNS = [
    *_BLOCK,
    "factor_printed",
    "factor_data",
    "rows_with_output",
    "rows_printed_ok",
    "rows_data_ok",
    "follows_printed",
    "shift_power",
    "shift_column",
    "shift_rows",
]
#: The reason a row of a reversed column carries (after the column's name).
_REVERSED_REASON = "printed in reverse order within its block (column-order check"
#: The note a row of a column a documented decision takes reversed carries (after its name).
_DECISION_REASON = "taken in reverse order within its block by a documented decision of the dataset"
#: The column naming, per fitted row, the columns a row policy took in reverse order.
APPLIED_COLUMN = "reversed_applied"
_REVERSAL_SCORES = (
    "points",
    "misfit_printed",
    "misfit_reversed",
    "ratio",
    "rho_printed",
    "rho_reversed",
    "gain",
)
_REVERSAL_COLUMNS = [
    *_BLOCK,
    "column",
    "axis",
    "neighbours",
    *_REVERSAL_SCORES,
    "reversed",
    "verdict",
]


# ------------------------------------------------------------------ the analysis
class _Rows:
    """Arrays of the rows under audit plus the flags accumulated so far."""

    def __init__(self, df: pd.DataFrame):
        missing = [
            c for c in ("input_v", "df_reported", "phase_lead_deg", "frequency_hz") if c not in df
        ]
        if missing:
            raise DataError(f"audit needs the columns {missing}")
        self.frame = f = df.drop(columns=[c for c in _AUDIT_COLUMNS if c in df])
        n = len(f)
        col = lambda name, default: f[name].to_numpy(float) if name in f else np.full(n, default)  # noqa: E731
        self.a, self.d, self.p = (
            col("input_v", np.nan),
            col("df_reported", np.nan),
            col("phase_lead_deg", np.nan),
        )
        self.h, self.k_printed = col("h1_output_v", np.nan), col("df_factor_printed", np.nan)
        table = (
            f["table"].astype(str).to_numpy() if "table" in f else np.full(n, "data", dtype=object)
        )
        self.keys = pd.DataFrame(
            {
                "table": table,
                "source_impedance_ohm": col("source_impedance_ohm", 0.0),
                "frequency_hz": col("frequency_hz", np.nan),
            }
        )
        self.block = self.keys.groupby(_BLOCK, sort=False, dropna=False).ngroup().to_numpy()
        self.sat = (
            f["saturation"].astype("boolean").fillna(False).to_numpy(bool)
            if "saturation" in f
            else np.zeros(n, bool)
        )
        self.core = (
            f["core"].fillna("").astype(str).str.lower().to_numpy()
            if "core" in f
            else np.full(n, "", dtype=object)
        )
        self.column = {"phase_lead_deg": self.p, "df_reported": self.d, "h1_output_v": self.h}
        self.present = {c: bool(c in f and f[c].notna().any()) for c in self.column}
        self.order = col("row_in_block", 0.0) if "row_in_block" in f else np.arange(n, dtype=float)
        self.reasons = [[] for _ in range(n)]
        self.trust = {k: np.ones(n, bool) for k in ("amplitude", "magnitude", "phase", "h1")}
        self.suspect, self.dup_extra = np.zeros(n, bool), np.zeros(n, bool)
        self.d_exp, self.tol = np.full(n, np.nan), np.full(n, np.nan)
        self.reversed = np.full(n, "", dtype=object)  # columns check (6) finds reversed
        self.decided = _decided(f, self)  # columns a documented decision takes reversed

    def blocks(self):  # row positions of each block, in printed order
        for b in np.unique(self.block):
            idx = np.flatnonzero(self.block == b)
            yield idx[np.argsort(self.order[idx], kind="stable")]

    def mark(self, i, text, *, untrust=(), suspect=True):  # one reason; "note" when not suspect
        self.reasons[i].append(text)
        for k in untrust:
            self.trust[k][i] = False
        self.suspect[i] |= suspect


def _columns(spec) -> list[str]:
    """``"a,b"`` -> ``["a", "b"]``; empty or missing -> ``[]``."""
    return [c for c in str(spec).split(",") if c] if isinstance(spec, str) else []


def _decided(frame: pd.DataFrame, r: _Rows) -> np.ndarray:
    """The ``reversed_by_decision`` column, checked: reversible column names, one value a block."""
    if DECISION_COLUMN not in frame:
        return np.full(len(frame), "", dtype=object)
    spec = frame[DECISION_COLUMN].fillna("").astype(str).str.replace(" ", "").to_numpy(object)
    for idx in r.blocks():
        values = set(spec[idx])
        where = ", ".join(f"{k}={r.keys[k].iloc[idx[0]]}" for k in _BLOCK)
        if len(values) > 1:
            raise DataError(
                f"{DECISION_COLUMN}: its value differs within the block {where} "
                f"({', '.join(sorted(map(repr, values)))}); a decision names a block's columns"
            )
        bad = [c for c in _columns(spec[idx[0]]) if c not in DECIDABLE_COLUMNS]
        if bad:
            raise DataError(
                f"{DECISION_COLUMN}: {bad[0]!r} in the block {where} is not a column that can "
                f"be reversed ({', '.join(DECIDABLE_COLUMNS)})"
            )
    return spec


def _pending(frame: pd.DataFrame, spec) -> np.ndarray:
    """``spec`` (comma-joined columns per row) less the columns a row already holds reversed."""
    done = frame.get(APPLIED_COLUMN, pd.Series("", index=frame.index)).fillna("").astype(str)
    return np.array(
        [",".join(c for c in _columns(s) if c not in _columns(d)) for s, d in zip(spec, done)],
        dtype=object,
    )


def _analyse(df: pd.DataFrame, judge_order: bool = True):
    """Rows with their flags, DF factor per block, column-order verdicts (checks 1-6).

    ``judge_order=False`` skips check (6): the frame holds the values a policy fits.
    """
    r = _Rows(df)
    with np.errstate(divide="ignore", invalid="ignore"):  # user frames may hold zeros or NaN
        _check_cells(r)
        _check_order(r)
        # before (3)-(5): a reversed output or DF column would make them blame other cells
        order = _check_reversals(r) if judge_order else pd.DataFrame(columns=_REVERSAL_COLUMNS)
        blocks = _factor_analysis(r)
        _check_smoothness(r)
    pending = _pending(r.frame, r.decided)
    _mark_decisions(r, pending)
    out = r.frame.copy()
    out["flag"] = np.where(
        r.suspect, "suspect", np.where([bool(x) for x in r.reasons], "note", "ok")
    )
    out["reasons"] = ["; ".join(x) for x in r.reasons]
    for key in ("amplitude", "magnitude", "phase", "h1"):
        out[f"{key}_trusted"] = r.trust[key]
    excluded = ~(r.trust["amplitude"] & r.trust["magnitude"] & r.trust["phase"]) | r.dup_extra
    out["exclude_default"] = excluded
    out["df_recomputed"], out["df_tolerance"] = r.d_exp, r.tol
    out["reversed_columns"] = r.reversed
    out["exclude_as_printed"] = excluded
    if pending.astype(bool).any():  # the default policy fits the values the decision gives
        out["exclude_default"] = _reversed_rows(out, pending)["exclude_default"].to_numpy(bool)
    return out, blocks, order


def _order_only(df: pd.DataFrame) -> pd.DataFrame:
    """The column-order verdicts (check 6) alone: it reads only the trust checks 1 and 2 set."""
    r = _Rows(df)
    with np.errstate(divide="ignore", invalid="ignore"):
        _check_cells(r)
        _check_order(r)
        return _check_reversals(r)


def _mark_decisions(r: _Rows, pending):
    """A note on each row of a column a documented decision takes reversed."""
    for idx in r.blocks():
        n = len(idx)
        for name in _columns(pending[idx[0]]):
            for k, i in enumerate(idx):
                j = idx[n - 1 - k]
                r.mark(
                    i,
                    f"{name} {_DECISION_REASON} ({DECISION_COLUMN}): the default policy fits "
                    f"{r.frame[name].iloc[j]:g}, printed in row {r.order[j]:g}",
                    suspect=False,
                )


def _reversed_rows(audited: pd.DataFrame, spec) -> pd.DataFrame:
    """Audit (checks 1-5) of the values a policy fits: ``spec`` (comma-joined columns per row,
    the same within a block) taken in reverse printed order (``row_in_block``) within each
    block, with their printed-digit counts.

    ``<column>_printed`` keeps the printed values, :data:`APPLIED_COLUMN` names the columns a
    row holds reversed, and each such row gets a note; ``exclude_default`` is computed on these
    values, ``exclude_as_printed`` and ``reversed_columns`` are copied from ``audited``.
    """
    spec = np.asarray(spec, dtype=object)
    frame = audited.drop(columns=[c for c in _AUDIT_COLUMNS if c in audited])
    r = _Rows(frame)
    values = {}
    for name in dict.fromkeys(c for s in spec for c in _columns(s)):
        for c in (name, f"{name}_decimals"):
            if c in frame:
                values[c] = frame[c].to_numpy(copy=True)
        if f"{name}_printed" not in frame:
            frame[f"{name}_printed"] = frame[name]
    for idx in r.blocks():
        for name in _columns(spec[idx[0]]):
            for c in (name, f"{name}_decimals"):
                if c in values:
                    values[c][idx] = frame[c].to_numpy()[idx][::-1]
    for c, v in values.items():
        frame[c] = pd.Series(v, index=frame.index).astype(frame[c].dtype)
    before = frame.get(APPLIED_COLUMN, pd.Series("", index=frame.index)).fillna("").astype(str)
    frame[APPLIED_COLUMN] = [
        ",".join(dict.fromkeys([*_columns(b), *_columns(s)])) for b, s in zip(before, spec)
    ]
    out = _analyse(frame, judge_order=False)[0]
    decided = r.decided
    for i in np.flatnonzero(spec.astype(bool)):
        note = "; ".join(
            f"{c} taken in reverse order within its block "
            f"({'a documented decision of the dataset' if c in _columns(decided[i]) else 'the reordered policy'}; "
            f"printed {frame[f'{c}_printed'].iloc[i]:g})"
            for c in _columns(spec[i])
        )
        out.iloc[i, out.columns.get_loc("reasons")] = "; ".join(
            x for x in (out["reasons"].iloc[i], note) if x
        )
        if out["flag"].iloc[i] == "ok":
            out.iloc[i, out.columns.get_loc("flag")] = "note"
    out["reversed_columns"] = audited["reversed_columns"].to_numpy(object)
    out["exclude_as_printed"] = audited["exclude_as_printed"].to_numpy(bool)
    return out


# ------------------------------------------------------------------ checks
def _check_cells(r: _Rows):
    for i in np.flatnonzero(np.isnan(r.p)):
        r.mark(i, "phase_lead_deg missing (printed '--')", untrust=("phase",))
    for i in np.flatnonzero(np.isnan(r.d)):
        r.mark(i, "df_reported missing", untrust=("magnitude",))
    for i in np.flatnonzero(~(r.a > 0)):
        r.mark(i, "input_v missing or not positive", untrust=("amplitude",))
    for i in np.flatnonzero((r.d == 0) & ~np.isnan(r.p)):
        r.mark(
            i,
            f"zero output: its printed phase ({r.p[i]:g} deg) is undefined",
            untrust=("phase",),
            suspect=False,
        )
    key = pd.DataFrame({"b": r.block, "a": r.a, "d": r.d, "p": r.p})
    for _, g in key[key.duplicated(keep=False)].groupby(list(key.columns), dropna=False):
        pos = g.index.to_numpy()
        pos = pos[np.argsort(r.order[pos], kind="stable")]
        listed = ", ".join(f"{r.order[j]:g}" for j in pos)
        r.mark(pos[0], f"printed {len(pos)} times (rows {listed} of its block)", suspect=False)
        for j in pos[1:]:
            r.mark(j, f"duplicate of row {r.order[pos[0]]:g} (repeat excluded)")
            r.dup_extra[j] = True


def _lis(x) -> list[int]:
    """Positions of a longest strictly increasing subsequence (patience sorting)."""
    tails, tail_pos, prev, out = [], [], [-1] * len(x), []
    for i, v in enumerate(x):
        j = bisect_left(tails, v)
        tails[j : j + 1], tail_pos[j : j + 1], prev[i] = [v], [i], tail_pos[j - 1] if j else -1
    i = tail_pos[-1] if tail_pos else -1
    while i >= 0:
        out, i = [i, *out], prev[i]
    return out


def _check_order(r: _Rows):
    for idx in r.blocks():
        idx = idx[~r.dup_extra[idx] & np.isfinite(r.a[idx])]
        keep = set(_lis(r.a[idx]))
        if len(keep) < 0.75 * len(
            idx
        ):  # a block not printed in increasing order: order says nothing
            continue
        for j in sorted(set(range(len(idx))) - keep):
            r.mark(
                idx[j],
                f"input_v {r.a[idx[j]]:g} V out of its block's increasing order",
                untrust=("amplitude",),
            )


def _resolutions(r: _Rows) -> dict[str, np.ndarray]:
    """Half a unit in the last printed digit of input, output and DF.

    Inputs are generator settings, read at the finest decimals printed in their block
    (``0.2`` among ``0.35`` means 0.20); a DF or output printed without decimals (``1``)
    is read at its column's usual decimals in the block.
    """
    dec = {}
    for col, v in (("input_v", r.a), ("h1_output_v", r.h), ("df_reported", r.d)):
        name = f"{col}_decimals"
        given = (
            r.frame[name].to_numpy(float, na_value=np.nan)
            if name in r.frame
            else np.full(len(v), np.nan)
        )
        # without the printed text (a plain DataFrame) the shortest repr is the best guess
        inferred = [
            len(np.format_float_positional(x, trim="-").partition(".")[2])
            if np.isfinite(x)
            else np.nan
            for x in v
        ]
        dec[col] = np.where(np.isnan(given), np.asarray(inferred, float), given)
    for idx in r.blocks():
        if np.isfinite(dec["input_v"][idx]).any():
            dec["input_v"][idx] = np.nanmax(dec["input_v"][idx])
        for col in ("h1_output_v", "df_reported"):
            x = dec[col][idx]
            if (x > 0).any():
                dec[col][idx] = np.where(x == 0, np.floor(np.median(x[x > 0])), x)
    return {c: 0.5 * 10.0 ** -np.nan_to_num(v) for c, v in dec.items()}


def _runs(positions, s):
    """Maximal runs (>= 2 rows) of equal non-zero shift ``s`` over consecutive positions."""
    out, j = [], 0
    for value, group in groupby(s):
        m = len(list(group))
        out += [positions[j : j + m]] if value != 0 and m >= 2 else []
        j += m
    return out


def _shift_column(r, run, rest):
    """Which column a power-of-ten run shifted: the one off the rest of its table."""
    if rest.size == 0:
        return "h1_output_v"
    dev = lambda v: abs(np.log10(np.median(v[run]) / np.median(v[rest])))  # noqa: E731
    if dev(r.d) > 0.5 and dev(r.d) > dev(r.h / r.a):
        return "df_reported"
    return "input_v" if dev(r.a) > 0.5 else "h1_output_v"


def _factor_analysis(r: _Rows) -> pd.DataFrame:
    """Factor each block follows, shifted runs, and per-row recomputed DF (module doc, 3)."""
    n, usable = len(r.a), (r.h > 0) & (r.d > 0) & (r.a > 0)
    k = np.where(usable, r.d * r.a / r.h, np.nan)
    tables = r.keys["table"].to_numpy()
    k0 = {
        t: np.median(k[(tables == t) & usable])
        for t in np.unique(tables)
        if ((tables == t) & usable).any()
    }
    shift, runs = np.zeros(n, int), []
    for idx in r.blocks():
        u = idx[usable[idx]]
        if u.size:
            s = np.rint(np.log10(k[u] / k0[tables[u[0]]])).astype(int)
            runs += _runs(u, s)
    for run in runs:
        shift[run] = np.rint(np.log10(k[run[0]] / k0[tables[run[0]]]))
    res, kc, out = _resolutions(r), k / 10.0**shift, []
    for idx in r.blocks():
        t, u, printed = tables[idx[0]], idx[usable[idx]], r.k_printed[idx[0]]
        kb = k0.get(t, np.nan)
        if u.size >= 3:
            kb = np.median(kc[u])
            close = u[np.abs(np.log10(kc[u] / kb)) < _FACTOR_WINDOW]
            kb = np.median(kc[close]) if close.size else kb
        ok = {}
        for name, factor in (("printed", printed), ("data", kb)):
            K = factor * 10.0 ** shift[idx]
            d_exp = K * r.h[idx] / r.a[idx]
            tol = res["df_reported"][idx] + K * (
                res["h1_output_v"][idx] / r.a[idx] + r.h[idx] * res["input_v"][idx] / r.a[idx] ** 2
            )
            ok[name] = (np.abs(r.d[idx] - d_exp) <= tol * (1 + 1e-9), d_exp, tol, K)
        n_p, n_d = int(ok["printed"][0][usable[idx]].sum()), int(ok["data"][0][usable[idx]].sum())
        follows = bool(n_p >= max(1, 0.8 * n_d)) if np.isfinite(printed) else None
        good, d_exp, tol, K = ok["printed" if follows else "data"]
        r.d_exp[idx], r.tol[idx] = d_exp, tol
        block_runs = [run for run in runs if run[0] in idx]
        column, span, power = "", "", 0
        for run in block_runs:
            rest = np.flatnonzero((tables == t) & usable & (shift == 0))
            column = _shift_column(r, run, rest)
            span = f"{r.order[run[0]]:g}-{r.order[run[-1]]:g}"
            # k = df * input / h1, so a too-large output lowers k and a too-large input or DF raises it
            power = -shift[run[0]] if column == "h1_output_v" else shift[run[0]]
            untrust = {"df_reported": ("magnitude",), "input_v": ("amplitude",)}.get(
                column, ("h1",)
            )
            for i in run:
                r.mark(
                    i,
                    f"{column} printed 10^{power:+d} times its value (power-of-ten shift of rows {span})",
                    untrust=untrust,
                    suspect=column != "h1_output_v",
                )
        for j in np.flatnonzero(~good & np.isfinite(d_exp) & np.isfinite(r.d[idx])):
            _attribute(r, idx, idx[j], d_exp[j], tol[j], K[j])
        out.append(
            {
                "table": t,
                "source_impedance_ohm": r.keys["source_impedance_ohm"].iloc[idx[0]],
                "frequency_hz": r.keys["frequency_hz"].iloc[idx[0]],
                "factor_printed": printed,
                "factor_data": kb,
                "rows_with_output": int(u.size),
                "rows_printed_ok": n_p,
                "rows_data_ok": n_d,
                "follows_printed": follows,
                "shift_power": int(power),
                "shift_column": column,
                "shift_rows": span,
            }
        )
    return pd.DataFrame(out, columns=_FACTOR_COLUMNS)


def _best_residual(x, y, x0, y0) -> float:
    """Residual of ``(x0, y0)`` from the best of three local lines through its neighbours.

    The lines are the interpolation between the nearest neighbour on each side and the
    extrapolations of the two nearest on either side; taking the best keeps a genuine
    corner (a saturation knee) from counting as an outlier.
    """
    o = np.argsort(x, kind="stable")
    x, y, k = x[o], y[o], int(np.searchsorted(x[o], x0))
    preds = [
        y[i] + (y[j] - y[i]) * (x0 - x[i]) / (x[j] - x[i])
        for i, j in ((k - 1, k), (k - 2, k - 1), (k, k + 1))
        if 0 <= i < j < len(x) and x[j] != x[i]
    ]
    return float(min((y0 - p for p in preds), key=abs)) if preds else np.nan


def _attribute(r: _Rows, idx, i, d_exp, tol, K):
    """Say which cell of an inconsistent row is most likely wrong, from its neighbours.

    An input off its block's sequence that output and DF would put back in line: the
    amplitude; a DF off its curve while ``factor * h1 / input`` is on it: the magnitude;
    otherwise only ``h1_output_v`` (harmless: fits use ``df_reported``).
    """
    detail = f"df_reported {r.d[i]:g} but factor x h1/input = {d_exp:.3g} (tolerance {tol:.2g})"
    if not r.trust["amplitude"][i]:
        r.mark(i, detail)
        return
    a_imp = K * r.h[i] / r.d[i] if r.d[i] > 0 else np.nan
    if _off_sequence(r, idx, i, a_imp):
        r.mark(
            i,
            f"input_v {r.a[i]:g} V off its block's sequence: output and DF imply {a_imp:.3g} V ({detail})",
            untrust=("amplitude",),
        )
        return
    nb = idx[
        (idx != i)
        & r.trust["amplitude"][idx]
        & r.trust["magnitude"][idx]
        & ~r.dup_extra[idx]
        & np.isfinite(r.d[idx])
    ]
    x, x0 = np.log(r.a[nb]), np.log(r.a[i])
    res_d, res_alt = _best_residual(x, r.d[nb], x0, r.d[i]), _best_residual(x, r.d[nb], x0, d_exp)
    if np.isnan(res_d) or (abs(res_d) > MAG_NOISE and abs(res_alt) < abs(res_d)):
        r.mark(
            i,
            f"df_reported off its curve by {res_d:+.3f} while factor x h1/input is on it ({detail})",
            untrust=("magnitude",),
        )
    else:
        r.mark(
            i,
            f"h1_output_v inconsistent ({detail}); df_reported lies on its curve",
            untrust=("h1",),
        )


def _off_sequence(r: _Rows, idx, i, a_imp) -> bool:
    """True when input ``i`` leaves an outlying log-step that the implied ``a_imp`` closes."""
    seq = idx[(r.trust["amplitude"][idx] & ~r.dup_extra[idx]) | (idx == i)]
    steps = np.abs(np.diff(np.log(r.a[seq])))
    steps = steps[steps > 0]
    pos = int(np.flatnonzero(seq == i)[0])
    lo = r.a[seq[pos - 1]] if pos > 0 else np.nan
    hi = r.a[seq[pos + 1]] if pos + 1 < len(seq) else np.nan
    if len(seq) < 2 or not steps.size or not a_imp > 0 or a_imp <= lo or a_imp >= hi:
        return False
    gap = lambda a: np.nanmax(np.abs(np.log([a / lo, hi / a])))  # noqa: E731
    return bool(gap(r.a[i]) > STEP_OUTLIER * np.median(steps) and gap(a_imp) <= gap(r.a[i]) / 2)


def _check_smoothness(r: _Rows):
    """Flag local extrema of magnitude or phase that no local line explains (see MAG_SPIKE).

    The worst offender is removed before looking again, so one spike does not make its
    neighbours look like extrema too.
    """
    for idx in r.blocks():
        base = idx[r.trust["amplitude"][idx] & ~r.dup_extra[idx] & np.isfinite(r.d[idx])]
        base = base[np.argsort(r.a[base], kind="stable")]
        for y, key, col, thr in (
            (r.d, "magnitude", "df_reported", MAG_SPIKE),
            (r.p, "phase", "phase_lead_deg", PHASE_SPIKE),
        ):
            pts = base[np.isfinite(y[base]) & r.trust[key][base]]
            while len(pts) >= 3:
                worst, worst_res = None, thr
                for j in range(1, len(pts) - 1):
                    i, lo, hi = pts[j], y[pts[j - 1]], y[pts[j + 1]]
                    if min(lo, hi) <= y[i] <= max(lo, hi):
                        continue
                    others = np.delete(pts, j)
                    res = _best_residual(np.log(r.a[others]), y[others], np.log(r.a[i]), y[i])
                    if abs(res) > abs(worst_res):
                        worst, worst_res = j, res
                if worst is None:
                    break
                r.mark(
                    pts[worst],
                    f"{col} {y[pts[worst]]:g} breaks the smoothness of its curve (off by "
                    f"{worst_res:+.3g})",
                    untrust=(key,),
                )
                pts = np.delete(pts, worst)


# ------------------------------------------------------------------ column order (6)
def _ranks(x) -> np.ndarray:
    """Ranks 1..n of ``x``, ties sharing their average rank."""
    x = np.asarray(x, float)
    o = np.argsort(x, kind="stable")
    new = np.r_[True, x[o][1:] != x[o][:-1]]
    starts = np.flatnonzero(new)
    mean_rank = (starts + np.r_[starts[1:], len(x)] + 1) / 2.0
    out = np.empty(len(x))
    out[o] = mean_rank[np.cumsum(new) - 1]
    return out


def _rank_corr(y, z) -> float:
    """Spearman's rank correlation (average ranks for ties); NaN when a side is constant."""
    ry, rz = _ranks(y), _ranks(z)
    ry, rz = ry - ry.mean(), rz - rz.mean()
    norm = np.sqrt((ry @ ry) * (rz @ rz))
    return float(ry @ rz / norm) if norm > 0 else np.nan


def _references(r: _Rows, blocks, group) -> tuple[np.ndarray, list[str]]:
    """Each block's reference input (module comment above :data:`REVERSIBLE`) and its axis.

    The marked saturation input; for a block without the mark, its frequency times the median
    of (saturation input / frequency) over the marked blocks of its group; for a group without
    marks, its frequency ("flux": the axis is input / frequency).
    """
    freq = np.array([r.keys["frequency_hz"].iloc[idx[0]] for idx in blocks], float)
    sat = np.full(len(blocks), np.nan)
    for b, idx in enumerate(blocks):
        marked = idx[r.sat[idx] & (r.a[idx] > 0) & r.trust["amplitude"][idx]]
        if marked.size:
            sat[b] = r.a[marked[0]]
    ref, axis = freq.copy(), ["flux"] * len(blocks)
    for g in set(group):
        mine = [b for b in range(len(blocks)) if group[b] == g]
        ratio = [sat[b] / freq[b] for b in mine if np.isfinite(sat[b])]
        if ratio:
            for b in mine:
                ref[b] = sat[b] if np.isfinite(sat[b]) else freq[b] * np.median(ratio)
                axis[b] = "saturation"
    return ref, axis


def _curve(r: _Rows, idx, name, y, ref):
    """A block's column on the flux axis: ``(u, y)`` at the rows whose ``y`` enters the
    comparison (amplitude trusted, not a repeat, finite; for the phase, a non-zero output)."""
    ok = r.trust["amplitude"][idx] & ~r.dup_extra[idx] & np.isfinite(y) & (r.a[idx] > 0)
    if name == "phase_lead_deg":
        ok &= r.d[idx] > 0
    return np.log(r.a[idx][ok] / ref), y[ok]


def _covered(u, nu) -> np.ndarray:
    return (u >= nu.min()) & (u <= nu.max())


def _nanmean(z) -> np.ndarray:
    """Mean of each column of ``z`` over its finite values (NaN where none is)."""
    k = np.isfinite(z).sum(axis=0)
    total = np.where(np.isfinite(z), z, 0.0).sum(axis=0)
    return np.where(k > 0, total / np.maximum(k, 1), np.nan)


def _predict(u, f, neighbours) -> np.ndarray:
    """The column at ``u`` predicted from the neighbours' ``(frequency, u, y)`` curves.

    At each point the neighbours covering it are interpolated linearly in ``u`` (several at
    one frequency averaged); the prediction interpolates linearly in log frequency between
    the nearest lower and higher frequency, else takes the nearest one. NaN where none covers.
    """
    at = {}
    for nf, nu, ny in neighbours:
        o = np.argsort(nu, kind="stable")
        at.setdefault(nf, []).append(np.where(_covered(u, nu), np.interp(u, nu[o], ny[o]), np.nan))
    if not at:
        return np.full(len(u), np.nan)
    freqs = np.array(sorted(at))
    z = np.vstack([_nanmean(np.vstack(at[nf])) for nf in freqs])  # (frequency, point)
    have, rows = np.isfinite(z), np.arange(len(freqs))[:, None]
    lo = np.where(have & (freqs < f)[:, None], rows, -1).max(axis=0)
    hi = np.where(have & (freqs > f)[:, None], rows, len(freqs)).min(axis=0)
    same = np.where(have & (freqs == f)[:, None], rows, len(freqs)).min(axis=0)
    cols, last = np.arange(len(u)), len(freqs) - 1
    a, c = np.clip(lo, 0, None), np.clip(hi, None, last)
    z_lo, z_hi, lf = z[a, cols], z[c, cols], np.log(freqs)
    both = (lo >= 0) & (hi <= last)
    w = (np.log(f) - lf[a]) / np.where(both, lf[c] - lf[a], 1.0)
    out = np.where(both, z_lo + w * (z_hi - z_lo), np.where(lo >= 0, z_lo, z_hi))
    out = np.where((lo < 0) & (hi > last), np.nan, out)
    return np.where(same <= last, z[np.clip(same, None, last), cols], out)


def _score(curve, f, neighbours):
    """``(misfit, rho, neighbours compared, points)`` of one curve: the RMS distance to the
    column predicted from the comparable neighbours (those covering at least MIN_OVERLAP of
    its points), and the median of its rank correlations with their curves."""
    u, y = curve
    comparable = [c for c in neighbours if _covered(u, c[1]).sum() >= MIN_OVERLAP]
    rhos = []
    for _, nu, ny in comparable:
        inside = _covered(u, nu)
        o = np.argsort(nu, kind="stable")
        rho = _rank_corr(y[inside], np.interp(u[inside], nu[o], ny[o]))
        if np.isfinite(rho):
            rhos.append(rho)
    pred = _predict(u, f, comparable)
    ok = np.isfinite(pred)
    misfit = float(np.sqrt(np.mean((y[ok] - pred[ok]) ** 2))) if ok.sum() >= MIN_OVERLAP else np.nan
    return misfit, float(np.median(rhos)) if rhos else np.nan, len(comparable), int(ok.sum())


def _reads_reversed(name, misfit, other, rho, rho_other, ratio=REVERSAL_RATIO) -> bool:
    """The order with ``misfit``/``rho`` is told from the other one: ``ratio`` times nearer
    its predicted curve, by REVERSAL_MARGIN at least, and higher in rank correlation (a tie
    tells nothing: a monotone column against neighbours rising and falling alike)."""
    return bool(
        misfit * ratio <= other
        and other - misfit >= REVERSAL_MARGIN[name]
        and not rho <= rho_other  # NaN (a constant side) does not veto
    )


def _judge(r: _Rows, idx, name, ref, axis, same, kin, highest=False) -> dict:
    """Check (6) for one (block, column): a record of :func:`_check_reversals`.

    ``same`` are the ``(frequency, u, y)`` curves of the other blocks of its table and source
    impedance, ``kin`` those of the same core's other tables (used when ``same`` gives too
    few comparable ones); ``highest``: the block has its table's highest frequency.
    """
    rec = dict(r.keys.iloc[idx[0]], column=name, axis=axis, neighbours=0, reversed=False)
    rec.update(dict.fromkeys(_REVERSAL_SCORES, np.nan))
    f = rec["frequency_hz"]
    y = r.column[name][idx]
    hyp = {rev: _curve(r, idx, name, y[::-1] if rev else y, ref) for rev in (False, True)}
    if min(len(h[1]) for h in hyp.values()) < MIN_OVERLAP:
        return {**rec, "verdict": f"cannot judge: fewer than {MIN_OVERLAP} usable rows"}
    span, flat = float(np.ptp(hyp[False][1])), FLAT_RANGE.get(name, 0.0)
    if span <= flat:
        return {**rec, "verdict": f"cannot judge: its values span only {span:.3g} (<= {flat:g})"}
    scores = {rev: _score(hyp[rev], f, same) for rev in (False, True)}
    if min(s[2] for s in scores.values()) < MIN_NEIGHBOURS and kin:
        scores = {rev: _score(hyp[rev], f, same + kin) for rev in (False, True)}
    n = rec["neighbours"] = min(s[2] for s in scores.values())
    if n < MIN_NEIGHBOURS or not all(np.isfinite(s[0]) for s in scores.values()):
        return {
            **rec,
            "verdict": f"cannot judge: {n} comparable neighbour(s), {MIN_NEIGHBOURS} needed",
        }
    (mp, rp, _, pts), (mr, rr, _, _) = scores[False], scores[True]
    rec.update(
        points=pts,
        misfit_printed=mp,
        misfit_reversed=mr,
        ratio=mp / mr if mr > 0 else np.inf,
        rho_printed=rp,
        rho_reversed=rr,
        gain=rr - rp,
    )
    flagged = _reads_reversed(
        name, mr, mp, rr, rp, REVERSAL_RATIO_HIGHEST if highest else REVERSAL_RATIO
    )
    return {**rec, "reversed": flagged, "verdict": "reversed" if flagged else "as printed"}


def _check_reversals(r: _Rows) -> pd.DataFrame:
    """Check (6): columns printed in reverse order within their block.

    Every column of :data:`REVERSIBLE` of every block is compared, printed and reversed, with
    the same column of its neighbouring blocks at the same flux (module comment above
    :data:`REVERSIBLE`). The input column is the axis of those comparisons, not a tested
    column: an input column printed reversed would leave every other column reversed against
    it, so :data:`INPUT_REVERSED_COLUMNS` or more flagged columns of one block, with no judged
    column of it reading better as printed, are reported as its input column. The flagged rows
    are marked suspect without losing trust: the row policies decide the order a fit uses
    (``trusted`` and ``as_printed`` the printed one, ``reordered`` the reversed one).
    """
    blocks = list(r.blocks())
    group = [tuple(r.keys.iloc[idx[0]][["table", "source_impedance_ohm"]]) for idx in blocks]
    core = [r.core[idx[0]] for idx in blocks]
    freq = [float(r.keys["frequency_hz"].iloc[idx[0]]) for idx in blocks]
    ref, axis = _references(r, blocks, group)
    top = {g: max(f for f, h in zip(freq, group) if h == g) for g in group}
    records = []
    for name in REVERSIBLE:
        if not r.present[name]:
            continue
        curves = [
            (freq[b], *_curve(r, idx, name, r.column[name][idx], ref[b]))
            for b, idx in enumerate(blocks)
        ]
        curves = [c if len(c[1]) >= 2 else None for c in curves]
        for b, idx in enumerate(blocks):
            others = [j for j in range(len(blocks)) if j != b and curves[j] is not None]
            same = [curves[j] for j in others if group[j] == group[b]]
            kin = [
                curves[j] for j in others if group[j] != group[b] and core[b] and core[j] == core[b]
            ]
            records.append(
                (b, _judge(r, idx, name, ref[b], axis[b], same, kin, freq[b] == top[group[b]]))
            )
    for b, idx in enumerate(blocks):
        mine = [rec for j, rec in records if j == b]
        flagged = [rec["column"] for rec in mine if rec["reversed"]]
        if not flagged:
            continue
        printed_better = any(
            np.isfinite(rec["misfit_printed"])
            and _reads_reversed(
                rec["column"],
                rec["misfit_printed"],
                rec["misfit_reversed"],
                rec["rho_printed"],
                rec["rho_reversed"],
            )
            for rec in mine
        )
        if len(flagged) >= INPUT_REVERSED_COLUMNS and not printed_better:
            for rec in mine:
                if rec["reversed"]:
                    rec["verdict"] = "reads reversed because the input column is"
            records.append(
                (
                    b,
                    {
                        **{k: mine[0][k] for k in _BLOCK},
                        "column": "input_v",
                        "axis": axis[b],
                        "reversed": True,
                        "verdict": f"reversed: {', '.join(flagged)} read reversed against it",
                    },
                )
            )
            flagged = ["input_v"]
        r.reversed[idx] = ",".join(flagged)
        n = len(idx)
        for k, i in enumerate(idx):
            for name in flagged:
                j = idx[n - 1 - k]
                r.mark(
                    i,
                    f"{name} {_REVERSED_REASON}, see findings): reversed, this row would read "
                    f"{r.frame[name].iloc[j]:g}, printed in row {r.order[j]:g}",
                )
    order = {c: k for k, c in enumerate((*REVERSIBLE, "input_v"))}
    records.sort(key=lambda x: (x[0], order[x[1]["column"]]))
    return pd.DataFrame([rec for _, rec in records], columns=_REVERSAL_COLUMNS)
