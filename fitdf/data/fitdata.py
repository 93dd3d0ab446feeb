"""The rows a fit uses, as arrays: amplitude, frequency, source impedance, measured complex DF.

The measured describing function is ``DF * exp(j * phase_lead)`` (Appendix B): a lead is a
positive angle, the same sign convention as the models' ``N`` (a lag is negative).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from fitdf.errors import DataError

__all__ = ["FitData", "NoiseModel"]


@dataclass(frozen=True)
class NoiseModel:
    """Noise scales of the measured magnitude and phase (the tables' printed precision).

    Appendix B prints the DF to 2-3 decimals and the phase to whole (sometimes half)
    degrees, read off a transfer-function analyser; 0.01 in magnitude and 1 degree in
    phase are the defaults. ``floor`` keeps the tangential scale finite where DF = 0.
    """

    sigma_magnitude: float = 0.01
    sigma_phase_deg: float = 1.0
    floor: float = 0.01

    def to_dict(self):
        return {
            "sigma_magnitude": self.sigma_magnitude,
            "sigma_phase_deg": self.sigma_phase_deg,
            "floor": self.floor,
        }


@dataclass(frozen=True)
class FitData:
    """Arrays of the rows to fit, with the frame they came from (for provenance)."""

    amplitude: np.ndarray
    frequency: np.ndarray
    source_impedance: np.ndarray
    measured: np.ndarray
    group: np.ndarray  # table label per row, for per-table calibration gains
    rows: pd.DataFrame = field(repr=False)
    label: str = ""
    #: The core the rows were measured on (an Appendix A name) when they all share one.
    core: str | None = None

    @property
    def n(self) -> int:
        return int(self.amplitude.size)

    @property
    def groups(self) -> list[str]:
        return list(dict.fromkeys(self.group.tolist()))

    @classmethod
    def from_frame(cls, frame: pd.DataFrame, label: str = "") -> FitData:
        """Arrays from a validated dataset frame (rows already selected by the audit policy)."""
        need = ["input_v", "frequency_hz", "df_reported", "phase_lead_deg"]
        missing = [c for c in need if c not in frame.columns]
        if missing:
            raise DataError(f"{label or 'data'}: missing column(s) {', '.join(missing)}")
        frame = frame.dropna(subset=need).reset_index(drop=True)
        if frame.empty:
            raise DataError(f"{label or 'data'}: no rows left to fit after the row policy")
        rs = (
            frame["source_impedance_ohm"]
            if "source_impedance_ohm" in frame
            else pd.Series(0.0, index=frame.index)
        )
        group = (
            frame["table"].astype(str)
            if "table" in frame
            else pd.Series(label or "data", index=frame.index)
        )
        measured = frame["df_reported"].to_numpy(float) * np.exp(
            1j * np.deg2rad(frame["phase_lead_deg"].to_numpy(float))
        )
        return cls(
            amplitude=frame["input_v"].to_numpy(float),
            frequency=frame["frequency_hz"].to_numpy(float),
            source_impedance=rs.to_numpy(float),
            measured=measured,
            group=group.to_numpy(str),
            rows=frame,
            label=label,
            core=_single_core(frame),
        )

    def digest(self) -> str:
        """SHA-256 of everything a fit reads from these rows: the arrays, the table of each
        row, the label, the core and the whole frame (its columns, types and values). The
        same rows give the same digest in any process (a key of :mod:`fitdf.jobcache`)."""
        h = hashlib.sha256()
        for a in (self.amplitude, self.frequency, self.source_impedance, self.measured):
            h.update(np.ascontiguousarray(a).tobytes())
        frame = self.rows
        header = [self.label, str(self.core), *self.group.tolist(), *map(str, frame.columns)]
        header += [str(t) for t in frame.dtypes]
        h.update("\0".join(header).encode())
        # pandas' row hash has a fixed key: the same values hash alike in every process
        h.update(pd.util.hash_pandas_object(frame, index=True).to_numpy().tobytes())
        return h.hexdigest()

    def subset(self, mask) -> FitData:
        mask = np.asarray(mask, bool)
        return FitData(
            self.amplitude[mask],
            self.frequency[mask],
            self.source_impedance[mask],
            self.measured[mask],
            self.group[mask],
            self.rows[mask].reset_index(drop=True),
            self.label,
            self.core,
        )


def _single_core(frame: pd.DataFrame) -> str | None:
    """The value of the ``core`` column when every row has the same one, else None."""
    if "core" not in frame:
        return None
    cores = frame["core"].dropna().astype(str).str.lower().unique()
    return str(cores[0]) if len(cores) == 1 else None
