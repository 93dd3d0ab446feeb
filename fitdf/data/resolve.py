"""The rows a fit uses, from whatever names them: a dataset or core name, a CSV path, a
DataFrame or a :class:`~fitdf.data.fitdata.FitData`.

In the data layer so that the command line reads and checks every file it is given before
it imports the fitting stack (a bad file fails in a second, not after five of imports).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from fitdf.data import audit, datasets
from fitdf.data.fitdata import FitData
from fitdf.errors import DataError, OptionError

__all__ = ["resolve_data"]


def resolve_data(
    data, policy: str = audit.DEFAULT_POLICY, source_impedance=None, label: str | None = None
) -> FitData:
    """Rows to fit from a dataset name, core name, CSV path, DataFrame or FitData.

    The audit's row ``policy`` (one of :data:`fitdf.data.audit.POLICIES`: "trusted", the
    default, which "default" also names, "reordered", "as_printed", "all" or "strict", see
    datasets/README.md) decides which rows are used and in which order: no policy but
    "reordered" reverses a column the audit reads as printed in reverse order, and
    "trusted" and "reordered" apply the documented decisions of the bundled data (the
    reversed 10 c/s phase of Table B.5); ``source_impedance`` (ohm) keeps only those rows.
    """
    if isinstance(data, FitData):
        return data
    if isinstance(data, (str, Path)):
        frame = datasets.load(data)
        label = label or (Path(data).name if Path(str(data)).suffix else str(data))
    elif isinstance(data, pd.DataFrame):
        frame = data
        label = label or "data"
    else:
        raise OptionError(
            f"cannot fit data of type {type(data).__name__}; give a dataset name, path or DataFrame"
        )
    if source_impedance is not None:
        if "source_impedance_ohm" not in frame:
            raise OptionError(
                "--source-impedance given but the data have no source_impedance_ohm column"
            )
        available = sorted(frame["source_impedance_ohm"].unique().tolist())
        frame = frame[frame["source_impedance_ohm"] == float(source_impedance)]
        if frame.empty:
            raise OptionError(
                f"{label}: no rows at source impedance {source_impedance:g} ohm "
                f"(available: {', '.join(f'{a:g}' for a in available)})"
            )
        label = f"{label} @ {float(source_impedance):g} ohm"
    policy = audit.policy_name(policy)
    selected = audit.select_rows(audit.audit(frame), policy)
    if selected.empty:
        raise DataError(f"{label}: no rows left after the '{policy}' row policy")
    return FitData.from_frame(selected, label)
