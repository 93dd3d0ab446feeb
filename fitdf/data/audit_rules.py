"""The rules of the row audit: the rows under audit, the checks and their thresholds.

:func:`_analyse` runs the checks (1)-(6) of :mod:`fitdf.data.audit` on a frame and
returns the flagged rows, the DF factor of each block and the column-order verdict of
each (block, column); :func:`_reversed_rows` audits the values the ``default`` policy fits
(the columns check (6) finds printed in reverse order taken reversed). The public
functions there (``audit``, ``block_factors``, ``reversals``, ``select_rows``,
``findings``) read their output.
"""

from __future__ import annotations

from bisect import bisect_left
from itertools import groupby

import numpy as np
import pandas as pd

from fitdf.errors import DataError

__all__ = [
    "MAG_SPIKE",
    "PHASE_SPIKE",
    "MAG_NOISE",
    "STEP_OUTLIER",
    "REVERSIBLE",
    "REVERSAL_GAIN",
    "REVERSAL_FIT",
    "FLAT_RANGE",
    "MIN_OVERLAP",
    "MIN_NEIGHBOURS",
    "EXTREME_ROWS",
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
# blocks (the other frequencies of its table and source impedance) on the normalised input
# axis u = log(input / reference input), the reference being the block's saturation (``**``)
# row, else the middle of its DF peak; the statistic is Spearman's rank correlation with each
# neighbour's curve (linearly interpolated in u, over the block's points it covers), its
# median over the neighbours is the block's score, printed and with the column reversed.
# Calibration on the 21 bundled blocks: 57 of the 63 (block, column) pairs can be judged; the
# printed columns score 0.36-1.00 but one, B.5 10 c/s phase (-0.08); reversing a column
# raises the score by at most +0.02 except there (+0.99, to +0.91). The gain threshold sits
# midway; the fit threshold below every genuine printed score. Reversing one of the other 56
# judged columns in a copy is caught 41 times; the misses read nearly alike either way
# (|gain| < 0.5: a phase minimum or DF peak in mid-block).
#: Columns tested for a reversed order (the input column is the axis: see _check_reversals).
REVERSIBLE = ("phase_lead_deg", "df_reported", "h1_output_v")
#: The median rank correlation must rise by this much when the column is reversed ...
REVERSAL_GAIN = 0.5
#: ... and reach this, for the column to be flagged as printed in reverse order.
REVERSAL_FIT = 0.3
#: A column spanning less has no shape to compare (1.25x the spike thresholds: no feature
#: larger than one slipped digit); h1_output_v only needs to vary.
FLAT_RANGE = {"phase_lead_deg": 1.25 * PHASE_SPIKE, "df_reported": 1.25 * MAG_SPIKE}
#: Points of a block a neighbour's curve must cover to be compared with it.
MIN_OVERLAP = 4
#: Comparable neighbours needed to judge: with one, either block could be the reversed one.
MIN_NEIGHBOURS = 2
#: Rows the phase minimum (DF maximum) may sit from the saturation row in a genuine column
#: (every judged thesis column but one: B.5 10 c/s phase, 2); a reversal that would move it
#: farther than this and than printed is vetoed.
EXTREME_ROWS = 1

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
_REVERSAL_SCORES = (
    "rho_printed",
    "rho_reversed",
    "gain",
    "misfit_printed",
    "misfit_reversed",
    "extreme_printed",
    "extreme_reversed",
)
_REVERSAL_COLUMNS = [*_BLOCK, "column", "neighbours", *_REVERSAL_SCORES, "reversed", "verdict"]


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

    def blocks(self):  # row positions of each block, in printed order
        for b in np.unique(self.block):
            idx = np.flatnonzero(self.block == b)
            yield idx[np.argsort(self.order[idx], kind="stable")]

    def mark(self, i, text, *, untrust=(), suspect=True):  # one reason; "note" when not suspect
        self.reasons[i].append(text)
        for k in untrust:
            self.trust[k][i] = False
        self.suspect[i] |= suspect


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
    if r.reversed.astype(bool).any():  # the default policy fits the reversed values
        out["exclude_default"] = _reversed_rows(out)["exclude_default"].to_numpy(bool)
    return out, blocks, order


def _reversed_rows(audited: pd.DataFrame) -> pd.DataFrame:
    """Audit (checks 1-5) of the values the ``default`` policy fits.

    Each row's ``reversed_columns`` are taken in reverse printed order (``row_in_block``)
    within its block, with their printed-digit counts; ``<column>_printed`` keeps the printed
    values, ``reversed_columns`` says which were reversed, and each such row gets a note.
    ``exclude_default`` is computed on these values; ``exclude_as_printed`` is copied from
    ``audited`` (the printed rows' audit).
    """
    spec = audited["reversed_columns"].fillna("").astype(str).to_numpy()
    frame = audited.drop(columns=[c for c in _AUDIT_COLUMNS if c in audited])
    r = _Rows(frame)
    values = {}
    for name in dict.fromkeys(c for s in spec if s for c in s.split(",")):
        if f"{name}_printed" in frame:  # these rows hold the reversed values already
            continue
        for c in (name, f"{name}_decimals"):
            if c in frame:
                values[c] = frame[c].to_numpy(copy=True)
        frame[f"{name}_printed"] = frame[name]
    for idx in r.blocks():
        for name in spec[idx[0]].split(",") if spec[idx[0]] else ():
            for c in (name, f"{name}_decimals"):
                if c in values:
                    values[c][idx] = frame[c].to_numpy()[idx][::-1]
    if not values:  # nothing left to reverse: ``audited`` holds the fitted values already
        return audited.copy()
    for c, v in values.items():
        frame[c] = pd.Series(v, index=frame.index).astype(frame[c].dtype)
    out = _analyse(frame, judge_order=False)[0]
    for i in np.flatnonzero(spec.astype(bool)):
        note = "; ".join(
            f"{c} taken in reverse order within its block (printed "
            f"{frame[f'{c}_printed'].iloc[i]:g})"
            for c in spec[i].split(",")
        )
        out.iloc[i, out.columns.get_loc("reasons")] = "; ".join(
            x for x in (out["reasons"].iloc[i], note) if x
        )
        if out["flag"].iloc[i] == "ok":
            out.iloc[i, out.columns.get_loc("flag")] = "note"
    out["reversed_columns"] = spec
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
    values, inverse, counts = np.unique(x, return_inverse=True, return_counts=True)
    return (np.cumsum(counts) - (counts - 1) / 2.0)[inverse.ravel()]


def _rank_corr(y, z) -> float:
    """Spearman's rank correlation (average ranks for ties); NaN when a side is constant."""
    ry, rz = _ranks(y), _ranks(z)
    ry, rz = ry - ry.mean(), rz - rz.mean()
    norm = np.sqrt((ry @ ry) * (rz @ rz))
    return float(ry @ rz / norm) if norm > 0 else np.nan


def _column_median(zs) -> np.ndarray:
    """Median of each column of ``zs`` over its finite values (each column has one)."""
    k = np.isfinite(zs).sum(axis=0)
    s = np.sort(zs, axis=0)  # NaN sorts last
    cols = np.arange(zs.shape[1])
    return (s[(k - 1) // 2, cols] + s[k // 2, cols]) / 2.0


def _reference(r: _Rows, idx, d) -> int | None:
    """Position in ``idx`` of the block's saturation row, else of the middle of its DF peak."""
    base = (r.a[idx] > 0) & r.trust["amplitude"][idx] & ~r.dup_extra[idx]
    sat = np.flatnonzero(base & r.sat[idx])
    if sat.size:
        return int(sat[0])
    ok = np.flatnonzero(base & np.isfinite(d))
    if not ok.size:
        return None
    top = ok[d[ok] == d[ok].max()]
    return int(top[len(top) // 2])


def _curve(r: _Rows, idx, name, y, d):
    """A block's column on the normalised axis: ``(u, y, positions, reference position)``.

    ``u = log(input / reference input)`` at the rows whose ``y`` enters the comparison
    (amplitude trusted, not a repeat, finite; for the phase, a non-zero output); ``d`` is
    the DF the reference is taken from. None without a reference.
    """
    ref = _reference(r, idx, d)
    if ref is None:
        return None
    ok = r.trust["amplitude"][idx] & ~r.dup_extra[idx] & np.isfinite(y) & (r.a[idx] > 0)
    if name == "phase_lead_deg":
        ok &= r.d[idx] > 0
    return np.log(r.a[idx][ok] / r.a[idx[ref]]), y[ok], np.flatnonzero(ok), ref


def _extreme_offset(name, curve, has_sat) -> float:
    """Rows from the reference row to the phase minimum (DF maximum, when the block has a
    saturation row); a run of equal extremes counts whole. NaN for other columns."""
    _, y, pos, ref = curve
    if name == "phase_lead_deg":
        ext = pos[y == y.min()]
    elif name == "df_reported" and has_sat:
        ext = pos[y == y.max()]
    else:
        return np.nan
    if ext.min() <= ref <= ext.max():
        return 0.0
    return float(ext.min() - ref if ext.min() > ref else ext.max() - ref)


def _score(curve, neighbours):
    """Median rank correlation with the neighbours' curves, how many compared, and the RMS
    distance to their median curve (in the column's unit) over the points they cover."""
    u, y = curve[0], curve[1]
    rhos, zs = [], []
    for nu, ny in neighbours:
        inside = (u >= nu.min()) & (u <= nu.max())
        if inside.sum() < MIN_OVERLAP:
            continue
        o = np.argsort(nu, kind="stable")
        z = np.full(len(u), np.nan)
        z[inside] = np.interp(u[inside], nu[o], ny[o])
        rho = _rank_corr(y[inside], z[inside])
        if np.isfinite(rho):
            rhos.append(rho)
            zs.append(z)
    if not rhos:
        return np.nan, 0, np.nan
    zs = np.vstack(zs)
    covered = np.isfinite(zs).any(axis=0)
    mid = _column_median(zs[:, covered])
    return float(np.median(rhos)), len(rhos), float(np.sqrt(np.mean((y[covered] - mid) ** 2)))


def _judge(r: _Rows, idx, name, same, kin) -> dict:
    """Check (6) for one (block, column): a record of :func:`_check_reversals`.

    ``same`` are the ``(u, y)`` curves of the other blocks of its table and source impedance,
    ``kin`` those of the same core's other tables (used when ``same`` gives too few).
    """
    rec = dict(r.keys.iloc[idx[0]], column=name, neighbours=0, reversed=False)
    rec.update(dict.fromkeys(_REVERSAL_SCORES, np.nan))
    y = r.column[name][idx]
    hyp = {  # the DF peak a block without saturation row is referred to moves with the DF
        False: _curve(r, idx, name, y, r.d[idx]),
        True: _curve(r, idx, name, y[::-1], y[::-1] if name == "df_reported" else r.d[idx]),
    }
    if hyp[False] is None or hyp[True] is None or len(hyp[False][1]) < MIN_OVERLAP:
        return {**rec, "verdict": f"cannot judge: fewer than {MIN_OVERLAP} usable rows"}
    span, flat = float(np.ptp(hyp[False][1])), FLAT_RANGE.get(name, 0.0)
    if span <= flat:
        return {**rec, "verdict": f"cannot judge: its values span only {span:.3g} (<= {flat:g})"}
    scores = {rev: _score(hyp[rev], same) for rev in (False, True)}
    if min(s[1] for s in scores.values()) < MIN_NEIGHBOURS and kin:
        scores = {rev: _score(hyp[rev], same + kin) for rev in (False, True)}
    n = rec["neighbours"] = min(s[1] for s in scores.values())
    if n < MIN_NEIGHBOURS:
        return {
            **rec,
            "verdict": f"cannot judge: {n} comparable neighbour(s), {MIN_NEIGHBOURS} needed",
        }
    ext = {rev: _extreme_offset(name, hyp[rev], bool(r.sat[idx].any())) for rev in (False, True)}
    rec.update(
        rho_printed=scores[False][0],
        rho_reversed=scores[True][0],
        gain=scores[True][0] - scores[False][0],
        misfit_printed=scores[False][2],
        misfit_reversed=scores[True][2],
        extreme_printed=ext[False],
        extreme_reversed=ext[True],
    )
    flagged = bool(
        rec["gain"] >= REVERSAL_GAIN
        and rec["rho_reversed"] >= REVERSAL_FIT
        and not abs(ext[True]) > max(abs(ext[False]), EXTREME_ROWS)  # NaN: no veto
    )
    return {**rec, "reversed": flagged, "verdict": "reversed" if flagged else "as printed"}


def _check_reversals(r: _Rows) -> pd.DataFrame:
    """Check (6): columns printed in reverse order within their block.

    Every column of :data:`REVERSIBLE` of every block is compared, printed and reversed, with
    the same column of its neighbouring blocks (module comment above :data:`REVERSIBLE`).
    The input column is the axis of those comparisons, not a tested column: an input column
    printed reversed would leave every other column reversed against it, so two or more
    flagged columns of one block, with no judged column of it reading better as printed
    (gain <= -REVERSAL_GAIN), are reported and reversed as its input column. The flagged
    rows are marked suspect without losing trust: the policies decide which order a fit
    uses (``default`` the reversed, ``as_printed`` the printed one).
    """
    blocks = list(r.blocks())
    group = [tuple(r.keys.iloc[idx[0]][["table", "source_impedance_ohm"]]) for idx in blocks]
    core = [r.core[idx[0]] for idx in blocks]
    records = []
    for name in REVERSIBLE:
        if not r.present[name]:
            continue
        curves = [_curve(r, idx, name, r.column[name][idx], r.d[idx]) for idx in blocks]
        curves = [c[:2] if c is not None and len(c[0]) >= 2 else None for c in curves]
        for b, idx in enumerate(blocks):
            others = [j for j in range(len(blocks)) if j != b and curves[j] is not None]
            same = [curves[j] for j in others if group[j] == group[b]]
            kin = [
                curves[j] for j in others if group[j] != group[b] and core[b] and core[j] == core[b]
            ]
            records.append((b, _judge(r, idx, name, same, kin)))
    for b, idx in enumerate(blocks):
        mine = [rec for j, rec in records if j == b]
        flagged = [rec["column"] for rec in mine if rec["reversed"]]
        if not flagged:
            continue
        if len(flagged) >= 2 and not any(rec["gain"] <= -REVERSAL_GAIN for rec in mine):
            for rec in mine:
                if rec["reversed"]:
                    rec["verdict"] = "reads reversed because the input column is"
            records.append(
                (
                    b,
                    {
                        **{k: mine[0][k] for k in _BLOCK},
                        "column": "input_v",
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
                fitted = f"the default policy fits {r.frame[name].iloc[j]:g}"
                where = f"printed in row {r.order[j]:g}"
                r.mark(i, f"{name} {_REVERSED_REASON}, see findings): {fitted}, {where}")
    order = {c: k for k, c in enumerate((*REVERSIBLE, "input_v"))}
    records.sort(key=lambda x: (x[0], order[x[1]["column"]]))
    return pd.DataFrame([rec for _, rec in records], columns=_REVERSAL_COLUMNS)
