"""The printed precision of a reading: half a unit in the last digit Appendix B prints.

A reading is the DF and the phase lead a fit uses; each is known to half a unit in its
last printed digit. The DF's digits are read as the audit reads them (a DF printed without
decimals, ``1``, at its column's usual decimals in the block; :mod:`fitdf.data.audit_rules`).
The output column is not used to narrow them: where it is printed to more digits it does not
always agree with the DF (Table B.4, 30 c/s, 1 V: output 0.975, DF 0.97), and the DF is
what is fitted. The phase, which Appendix B prints to whole degrees, is read at the last
digit of its value.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf.data.audit_rows import _Rows
from fitdf.data.audit_rules import _resolutions

__all__ = ["reading_resolution"]


def reading_resolution(frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """``(DF half-unit, phase half-unit in degrees)`` of every row of ``frame``.

    ``frame``: rows of the Appendix B schema (:func:`fitdf.datasets.load`, or the rows a fit
    used, ``FitData.rows``); the printed decimals of ``df_reported`` are taken from its
    ``df_reported_decimals`` column where present, else from the value's shortest form.

    Examples
    --------
    >>> from fitdf import datasets
    >>> df, phase = reading_resolution(datasets.load("B.4"))
    >>> float(df[0]), float(phase[0])  # 0.4 at 66 deg
    (0.05, 0.5)
    """
    df = np.asarray(_resolutions(_Rows(frame))["df_reported"], float)
    phase = frame["phase_lead_deg"].to_numpy(float)
    digits = np.array(
        [
            len(np.format_float_positional(p, trim="-").partition(".")[2]) if np.isfinite(p) else 0
            for p in phase
        ],
        float,
    )
    return df, 0.5 * 10.0**-digits
