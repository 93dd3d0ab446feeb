"""The rules of the row audit: the analysis and the checks (1)-(5).

:func:`_analyse` runs the checks (1)-(6) of :mod:`fitdf.data.audit` on a frame (the rows
under audit and the thresholds are in :mod:`fitdf.data.audit_rows`, check (6) in
:mod:`fitdf.data.audit_order`) and
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

from fitdf.data.audit_order import (
    _REVERSAL_COLUMNS,
    FLAT_RANGE,
    INPUT_REVERSED_COLUMNS,
    MIN_NEIGHBOURS,
    MIN_OVERLAP,
    REVERSAL_MARGIN,
    REVERSAL_RATIO,
    REVERSAL_RATIO_HIGHEST,
    REVERSIBLE,
    _check_reversals,
)
from fitdf.data.audit_rows import (
    _AUDIT_COLUMNS,
    _BLOCK,
    _FACTOR_WINDOW,
    MAG_NOISE,
    MAG_SPIKE,
    PHASE_SPIKE,
    STEP_OUTLIER,
    _columns,
    _Rows,
)
from fitdf.data.datasets import DECISION_COLUMN

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
#: The note a row of a column a documented decision takes reversed carries (after its name).
_DECISION_REASON = "taken in reverse order within its block by a documented decision of the dataset"
#: The column naming, per fitted row, the columns a row policy took in reverse order.
APPLIED_COLUMN = "reversed_applied"


# ------------------------------------------------------------------ the analysis
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
