"""The rows under audit and the thresholds of the audit's checks (:mod:`fitdf.data.audit`).

:class:`_Rows` holds the arrays of a frame under audit and the flags the checks accumulate;
the checks (1)-(5) are in :mod:`fitdf.data.audit_rules`, the column order (6) in
:mod:`fitdf.data.audit_order`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.data.datasets import DECIDABLE_COLUMNS, DECISION_COLUMN
from fitdf.errors import DataError

__all__ = ["MAG_SPIKE", "PHASE_SPIKE", "MAG_NOISE", "STEP_OUTLIER"]

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
#: The reason a row of a reversed column carries (after the column's name).
_REVERSED_REASON = "printed in reverse order within its block (column-order check"


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
