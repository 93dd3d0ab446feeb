"""What the rows of the Tables 5.1/5.2 comparison say, summarised per setting and block.

Every function reads the long frame of :func:`fitdf.limit_cycle_tables.thesis_limit_cycle_comparison`
(one row per table row and *setting*: ``unscaled``, ``held_out``, optionally ``given``)
and returns plain dicts, the record the report and its sentences are made from.

Rules (each a textbook interval; the rows of a block are the sample):

* *Level* of a block: the log ratios ``ln(predicted / measured)`` of its oscillating rows;
  the level is *consistent* when the 95 % Student-t interval of their mean contains 0 -- the
  offset is within what the rows' scatter allows.
* *Trend* of a block: the least-squares slope of ``ln(measured)`` on ``ln(system gain)``
  (the exponent of amplitude or frequency in gain) and its 95 % t-interval (``n - 2`` degrees
  of freedom); the prediction is *consistent* when its slope on the same rows lies inside.
* *Order across source impedance*: at each system gain where both impedances of a core
  oscillated, the sign of ``ln(q_600 / q_0)`` measured and predicted.
* *Critical gain*: the measured bracket of a block is (largest gain that died out, smallest
  gain that oscillated); the predicted critical gain lies ``below``, ``inside`` or ``above``.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

__all__ = [
    "summarise",
    "LEVEL_CONFIDENCE",
    "QUANTITIES",
    "agreement",
    "trends",
    "impedance_order",
    "critical_gains",
    "dies_out_rows",
    "time_domain_summary",
]

#: Confidence of the level and trend intervals.
LEVEL_CONFIDENCE = 0.95
#: The two measured quantities: (name, measured column, predicted column, simulated column).
QUANTITIES = (
    ("amplitude", "amplitude_v", "amplitude_pred", "amplitude_sim"),
    ("omega", "omega_rad_s", "omega_pred", "omega_sim"),
)


def _oscillating(g):
    """Rows measured oscillating, with a finite amplitude and frequency."""
    return g[~g["dies_out"] & np.isfinite(g["amplitude_v"]) & np.isfinite(g["omega_rad_s"])]


def _blocks(df):
    """``(setting, [("all", rows), (table, rows), ...])`` in the frame's order."""
    for setting, s in df.groupby("setting", sort=False):
        yield setting, [("all", s)] + list(s.groupby("table", sort=False))


def _t(n_dof):
    return float(stats.t.ppf(0.5 + LEVEL_CONFIDENCE / 2, n_dof))


def _nan_list(x):
    return [float(v) for v in x]


def mean_interval(r) -> dict:
    """Mean of ``r`` and its two-sided t-interval at :data:`LEVEL_CONFIDENCE` (NaN below 2 values)."""
    r = np.asarray(r, float)
    n = r.size
    if n < 2:
        return {"mean": float(np.mean(r)) if n else float("nan"), "interval": [np.nan, np.nan]}
    m, half = float(np.mean(r)), _t(n - 1) * float(np.std(r, ddof=1)) / np.sqrt(n)
    return {"mean": m, "interval": [m - half, m + half]}


def slope_interval(x, y) -> dict:
    """Least-squares slope of ``y`` on ``x`` and its t-interval (``n - 2`` dof; NaN below 3 points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    n = x.size
    if n < 3 or np.ptp(x) == 0:
        return {"slope": float("nan"), "interval": [np.nan, np.nan]}
    xc = x - x.mean()
    sxx = float(xc @ xc)
    b = float(xc @ (y - y.mean())) / sxx
    resid = y - y.mean() - b * xc
    half = _t(n - 2) * np.sqrt(float(resid @ resid) / (n - 2) / sxx)
    return {"slope": b, "interval": [b - half, b + half]}


def _inside(value, interval) -> bool | None:
    lo, hi = interval
    if not (np.isfinite(value) and np.isfinite(lo) and np.isfinite(hi)):
        return None
    return bool(lo <= value <= hi)


def agreement(df) -> dict:
    """Per setting, for all rows and per block: how the prediction's level compares.

    ``rows_oscillating`` (measured), ``rows_predicted`` (of those, with a stable predicted
    cycle), ``rows_extrapolated`` (of those, the cycle outside the amplitudes or frequencies
    the fit saw) and per quantity ``median_<q>_ratio``, ``rms_log_<q>_ratio``, ``mean_log_<q>_ratio``,
    its interval ``log_<q>_ratio_interval`` and ``<q>_level_consistent`` (the interval holds 0;
    None where it cannot be formed).
    """
    out = {}
    for setting, groups in _blocks(df):
        out[setting] = {}
        for name, g in groups:
            live = _oscillating(g)
            ok = live[np.isfinite(live["amplitude_pred"]) & np.isfinite(live["omega_pred"])]
            rec = {
                "rows_oscillating": len(live),
                "rows_predicted": len(ok),
                "rows_extrapolated": int(ok["extrapolated"].astype(bool).sum()),
            }
            for q, meas, pred, _ in QUANTITIES:
                r = np.log(ok[pred].to_numpy(float) / ok[meas].to_numpy(float))
                mi = mean_interval(r)
                rec[f"median_{q}_ratio"] = float(np.exp(np.median(r))) if r.size else np.nan
                rec[f"rms_log_{q}_ratio"] = float(np.sqrt(np.mean(r**2))) if r.size else np.nan
                rec[f"mean_log_{q}_ratio"] = mi["mean"]
                rec[f"log_{q}_ratio_interval"] = _nan_list(mi["interval"])
                rec[f"{q}_level_consistent"] = _inside(0.0, mi["interval"])
            out[setting][name] = rec
    return out


def trends(df) -> dict:
    """Per setting and block: the exponent of amplitude and of frequency in the system gain,
    measured (with its interval) and predicted, both on the block's oscillating rows that have
    a predicted cycle (``rows``), and whether they agree (None below three rows)."""
    out = {}
    for setting, groups in _blocks(df):
        out[setting] = {}
        for name, g in groups[1:]:
            live = _oscillating(g)
            live = live[np.isfinite(live["amplitude_pred"]) & np.isfinite(live["omega_pred"])]
            rec = {"rows": len(live)}
            lk = np.log(live["system_gain"].to_numpy(float))
            for q, meas, pred, _ in QUANTITIES:
                m = slope_interval(lk, np.log(live[meas].to_numpy(float)))
                ps = slope_interval(lk, np.log(live[pred].to_numpy(float)))["slope"]
                rec[q] = {
                    "measured_slope": m["slope"],
                    "measured_slope_interval": _nan_list(m["interval"]),
                    "predicted_slope": ps,
                    "consistent": _inside(ps, m["interval"]),
                }
            out[setting][name] = rec
    return out


def impedance_order(df) -> dict:
    """Per setting: at each (core, system gain) measured oscillating at both source impedances,
    ``ln(q_600 / q_0)`` measured and predicted; ``pairs``, and per quantity how many pairs the
    prediction orders as measured (``<q>_agree``; a pair without a prediction does not agree)."""
    out = {}
    for setting, s in df.groupby("setting", sort=False):
        live = _oscillating(s)
        pairs = []
        for core, c in live.groupby("core", sort=False):
            by_r = {r: g.set_index("system_gain") for r, g in c.groupby("source_impedance_ohm")}
            if len(by_r) != 2:
                continue
            lo, hi = sorted(by_r)
            for k in sorted(set(by_r[lo].index) & set(by_r[hi].index)):
                rec = {"core": core, "system_gain": float(k), "impedances_ohm": [lo, hi]}
                for q, meas, pred, _ in QUANTITIES:
                    a, b = by_r[lo].loc[k], by_r[hi].loc[k]
                    rec[f"log_{q}_ratio_measured"] = float(np.log(b[meas] / a[meas]))
                    rec[f"log_{q}_ratio_predicted"] = float(np.log(b[pred] / a[pred]))
                pairs.append(rec)
        summary = {"pairs": len(pairs)}
        for q, *_ in QUANTITIES:
            summary[f"{q}_agree"] = sum(
                bool(
                    np.sign(p[f"log_{q}_ratio_measured"]) == np.sign(p[f"log_{q}_ratio_predicted"])
                )
                and np.isfinite(p[f"log_{q}_ratio_predicted"])
                for p in pairs
            )
        out[setting] = {**summary, "rows": pairs}
    return out


def _position(pred, lo, hi) -> str:
    if not np.isfinite(pred):
        return "none"
    if lo is not None and pred < lo:
        return "below"
    if hi is not None and pred > hi:
        return "above"
    return "inside"


def critical_gains(df) -> list:
    """Per block: the measured die-out bracket and, per setting, the predicted critical gain
    (system-gain units) and the angular frequency of its critical point, its position against the bracket and its ratio to the bracket's lower
    end (``die_out_over_predicted``: how far below the largest gain that died out)."""
    rows = []
    first = df[df["setting"] == df["setting"].iloc[0]]
    for table, g in first.groupby("table", sort=False):
        dead, live = g[g["dies_out"]], g[~g["dies_out"]]
        lo = float(dead["system_gain"].max()) if not dead.empty else None
        hi = float(live["system_gain"].min()) if not live.empty else None
        rec = {
            "table": table,
            "core": g["core"].iloc[0],
            "source_impedance_ohm": float(g["source_impedance_ohm"].iloc[0]),
            "measured_dies_out_at": lo,
            "measured_lowest_oscillating": hi,
            "predicted": {},
        }
        for setting, s in df[df["table"] == table].groupby("setting", sort=False):
            pred = float(s["critical_gain_pred"].iloc[0])
            rec["predicted"][setting] = {
                "critical_gain": pred,
                "critical_omega_rad_s": float(s["critical_omega_pred"].iloc[0])
                if "critical_omega_pred" in s
                else None,
                "position": _position(pred, lo, hi),
                "die_out_over_predicted": lo / pred if lo is not None and pred > 0 else np.nan,
            }
        rows.append(rec)
    return rows


def dies_out_rows(df) -> list:
    """Each row the thesis marks "oscillations die out": per setting whether harmonic balance
    predicts a stable cycle there (``predicted_to_oscillate``) and, when simulated, what the
    loop in time does (``sim_state``)."""
    out = []
    first = df[df["setting"] == df["setting"].iloc[0]]
    for _, row in first[first["dies_out"]].iterrows():
        rec = {"table": row["table"], "system_gain": float(row["system_gain"]), "settings": {}}
        same = df[
            df["dies_out"]
            & (df["table"] == row["table"])
            & (df["system_gain"] == row["system_gain"])
        ]
        for _, r in same.iterrows():
            rec["settings"][r["setting"]] = {
                "predicted_to_oscillate": bool(np.isfinite(r["amplitude_pred"])),
                "amplitude_pred": float(r["amplitude_pred"]),
                "sim_state": r.get("sim_state") if isinstance(r.get("sim_state"), str) else None,
            }
        out.append(rec)
    return out


def time_domain_summary(df) -> dict:
    """Per setting, all rows and per block: harmonic balance against the simulated loop (the
    describing-function approximation, ``rms_log_<q>_hb_over_sim``) and the simulated loop
    against the table (``rms_log_<q>_sim_over_measured``), on the rows measured oscillating
    whose simulation settled; the counts of simulated rows by state; and the die-out rows at
    which the simulated loop oscillates. Empty when the frame has no simulation."""
    if "sim_state" not in df:
        return {}
    out = {}
    for setting, groups in _blocks(df):
        out[setting] = {}
        for name, g in groups:
            live = _oscillating(g)
            both = live[
                (live["sim_state"] == "oscillates")
                & np.isfinite(live["amplitude_pred"])
                & np.isfinite(live["omega_pred"])
            ]
            rec = {
                "rows_oscillating": len(live),
                "rows_compared": len(both),
                "rows_simulated": int(g["sim_state"].notna().sum()),
                **{
                    f"rows_{state.replace(' ', '_')}": int((g["sim_state"] == state).sum())
                    for state in ("oscillates", "dies out", "unsettled")
                },
                "dies_out_rows": int(g["dies_out"].sum()),
                "dies_out_rows_sim_oscillates": int(
                    (g["dies_out"] & (g["sim_state"] == "oscillates")).sum()
                ),
            }
            for q, meas, pred, sim in QUANTITIES:
                hb = np.log(both[pred].to_numpy(float) / both[sim].to_numpy(float))
                sm = np.log(both[sim].to_numpy(float) / both[meas].to_numpy(float))
                rec[f"rms_log_{q}_hb_over_sim"] = (
                    float(np.sqrt(np.mean(hb**2))) if hb.size else np.nan
                )
                rec[f"rms_log_{q}_sim_over_measured"] = (
                    float(np.sqrt(np.mean(sm**2))) if sm.size else np.nan
                )
            out[setting][name] = rec
    return out


def summarise(df) -> dict:
    """Every summary of the frame by its record name: ``agreement``, ``trends``,
    ``impedance_order``, ``critical_gains``, ``dies_out_rows``, ``time_domain``."""
    return {
        "agreement": agreement(df),
        "trends": trends(df),
        "impedance_order": impedance_order(df),
        "critical_gains": critical_gains(df),
        "dies_out_rows": dies_out_rows(df),
        "time_domain": time_domain_summary(df),
    }
