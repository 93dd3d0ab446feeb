"""Check (6) of the audit (:mod:`fitdf.data.audit`): columns printed in reverse order within
their block, judged against the same column of the other frequencies at the same flux.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.data.audit_rows import _BLOCK, _REVERSED_REASON, MAG_SPIKE, PHASE_SPIKE, _Rows

__all__ = [
    "REVERSIBLE",
    "REVERSAL_RATIO",
    "REVERSAL_RATIO_HIGHEST",
    "REVERSAL_MARGIN",
    "FLAT_RANGE",
    "MIN_OVERLAP",
    "MIN_NEIGHBOURS",
    "INPUT_REVERSED_COLUMNS",
]

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


def _mark_reversed(r: _Rows, b, idx, axis, records) -> None:
    """The verdict on block ``b`` (rows ``idx``) once its columns are judged (``records``):
    its flagged columns, or its input column when :data:`INPUT_REVERSED_COLUMNS` of them are
    flagged and none reads better as printed (a record added for it); each of its rows marked
    with the value it would read reversed."""
    mine = [rec for j, rec in records if j == b]
    flagged = [rec["column"] for rec in mine if rec["reversed"]]
    if not flagged:
        return
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
                    "axis": axis,
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
        _mark_reversed(r, b, idx, axis[b], records)
    order = {c: k for k, c in enumerate((*REVERSIBLE, "input_v"))}
    records.sort(key=lambda x: (x[0], order[x[1]["column"]]))
    return pd.DataFrame([rec for _, rec in records], columns=_REVERSAL_COLUMNS)
