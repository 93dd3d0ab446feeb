"""The thesis's measured data as validated tables, and the reader of users' CSV files.

Bundled data (``datasets/`` in a checkout, ``fitdf._bundled`` once installed):

* ``appendix_b.csv`` -- every row of Tables B.1-B.5 (Appendix B) as printed, one row per
  measurement; ``"B.1"`` .. ``"B.5"`` select one table, ``"permalloy"``, ``"deltamax"``
  and ``"supermalloy"`` every Appendix B row of one core;
* ``table_5_1`` / ``table_5_2`` (limit cycles, section V.6), ``table_3_1`` (eq 3.12
  constants), ``appendix_a`` (core data), ``eq_4_11`` (K-S magnet steel ``H_c(H_m)``);
* :data:`DECISIONS` -- the documented decisions about the printed tables (:func:`decisions`).
  One so far: Table B.5's 10 c/s phase column is printed in reverse order, and the bundled
  data take it reversed (the evidence is in ``datasets/README.md``, "Decisions"). The cells
  of ``appendix_b.csv`` stay as printed; :func:`load` names the decided columns of each row
  in ``reversed_by_decision``, the default row policy (``trusted``,
  :func:`fitdf.data.audit.select_rows`) applies the decision and says so in each row's
  reasons, and the ``as_printed`` policy fits the column as printed.

A user's CSV in the Appendix B schema goes through the same validation; any problem
raises :class:`~fitdf.errors.DataError` with one line naming file, row, line and column.
Column meanings and units are in ``datasets/README.md``.
"""

from __future__ import annotations

import csv
import difflib
import io
import os
import re
from functools import cache, lru_cache
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from fitdf.errors import DataError

__all__ = [
    "names",
    "load",
    "decisions",
    "DECISIONS",
    "DECISION_COLUMN",
    "summary",
    "data_dir",
    "APPENDIX_B_COLUMNS",
    "REQUIRED_COLUMNS",
    "TABLES",
    "CORES",
]

#: Column order of ``appendix_b.csv`` (the Appendix B schema).
APPENDIX_B_COLUMNS = (
    "table",
    "graph",
    "core",
    "core_part",
    "source_impedance_ohm",
    "frequency_hz",
    "row_in_block",
    "input_v",
    "h1_output_v",
    "phase_lead_deg",
    "df_reported",
    "saturation",
    "df_factor_printed",
    "source",
)
#: Column :func:`load` adds to the bundled Appendix B rows (and reads from a user's CSV): the
#: columns of the row's block a documented decision takes in reverse order, comma-joined.
DECISION_COLUMN = "reversed_by_decision"
#: Columns a documented decision may reverse within their block.
DECIDABLE_COLUMNS = ("phase_lead_deg", "df_reported", "h1_output_v", "input_v")
#: The documented decisions about the bundled tables: ``(table, source impedance (ohm),
#: frequency (Hz), column, decision, evidence)``; "reversed" takes the column in reverse
#: printed order within its block. datasets/README.md ("Decisions") gives the evidence in full.
DECISIONS = (
    (
        "B.5",
        600.0,
        10.0,
        "phase_lead_deg",
        "reversed",
        "printed, it falls from 44 deg to 0 two rows past the ** row and rises to 41; reversed, "
        "its minimum sits at the ** row and its values match the other Deltamax frequencies "
        "at the same inputs, while its DF and output columns agree with them as printed",
    ),
)
#: Columns a user's CSV must have.
REQUIRED_COLUMNS = ("input_v", "df_reported", "phase_lead_deg", "frequency_hz")
#: Columns whose printed number of decimals :func:`load` records (as ``<column>_decimals``)
#: so that :mod:`fitdf.data.audit` can compare cells at the precision the table prints.
DECIMAL_COLUMNS = ("input_v", "h1_output_v", "df_reported")
TABLES = ("B.1", "B.2", "B.3", "B.4", "B.5")
CORES = ("permalloy", "deltamax", "supermalloy")
_OTHER = ("table_5_1", "table_5_2", "table_3_1", "appendix_a", "eq_4_11")
_OTHER_DTYPES = {
    "table_5_1": {
        "core": str,
        "source_impedance_ohm": float,
        "system_gain": float,
        "amplitude_v": float,
        "frequency_hz": float,
        "omega_rad_s": float,
        "dies_out": bool,
        "source": str,
    },
    "table_3_1": {
        "material": str,
        "a1": float,
        "hc_inf": float,
        "hm_for_095": float,
        "source": str,
    },
    "appendix_a": {
        "core": str,
        "core_part": str,
        "quantity": str,
        "label_printed": str,
        "value_printed": str,
        "value_min": float,
        "value_max": float,
        "unit": str,
        "note": str,
        "source": str,
    },
    "eq_4_11": {
        "piece": int,
        "hm_min": float,
        "hm_max": float,
        "constant": float,
        "linear": float,
        "cubic": float,
        "source": str,
    },
}
_OTHER_DTYPES["table_5_2"] = _OTHER_DTYPES["table_5_1"]

_FLOAT_COLUMNS = (
    "source_impedance_ohm",
    "frequency_hz",
    "input_v",
    "h1_output_v",
    "phase_lead_deg",
    "df_reported",
    "df_factor_printed",
)
_TEXT_COLUMNS = ("table", "graph", "core", "core_part", "source")
# ASCII only: float() also accepts "1_000", "inf" and non-ASCII digits, none of which a table prints.
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_MISSING = {"", "--", "- -", "nan", "na", "n/a"}
_TRUE = {"true", "yes", "1", "**", "t", "y"}
_FALSE = {"false", "no", "0", "", "f", "n"}


def data_dir():
    """Folder holding the bundled CSV files.

    The installed package ``fitdf._bundled`` when it is importable (a wheel), else the
    ``datasets/`` folder next to the ``fitdf/`` package (a source checkout).
    """
    try:
        folder = resources.files("fitdf._bundled")
        if folder.joinpath("appendix_b.csv").is_file():
            return folder
    except ModuleNotFoundError:  # not installed: running from a checkout
        pass
    return Path(__file__).resolve().parents[2] / "datasets"


def names() -> list[str]:
    """Names :func:`load` accepts besides a path: tables, other datasets, then cores."""
    return [*TABLES, *_OTHER, *CORES]


def load(name_or_path) -> pd.DataFrame:
    """A validated dataset as a DataFrame.

    Parameters
    ----------
    name_or_path : str or os.PathLike
        A bundled name (see :func:`names`), ``"appendix_b"`` (all Tables B.1-B.5), a core
        name, or the path of a CSV file in the Appendix B schema (at least ``input_v``,
        ``df_reported``, ``phase_lead_deg`` and ``frequency_hz``; see datasets/README.md).

    Returns
    -------
    pandas.DataFrame
        Appendix B schema frames have the columns of :data:`APPENDIX_B_COLUMNS` (float
        numbers, bool ``saturation``, str text), then ``<column>_decimals`` (nullable int:
        decimals printed in that cell) for :data:`DECIMAL_COLUMNS`, then any extra columns
        of a user's file (as text). The bundled rows end with :data:`DECISION_COLUMN`: the
        columns of the row's block that a documented decision (:func:`decisions`) takes in
        reverse order, ``""`` for most rows; the cells themselves are as printed.

    Raises
    ------
    DataError
        Unknown name, missing file, directory, or a file that is not a valid CSV in the
        schema; the message is one line naming file, row, line and column.

    Examples
    --------
    >>> b1 = load("B.1")
    >>> len(b1), b1["frequency_hz"].unique().tolist()
    (37, [3.0, 6.0, 10.0, 20.0])
    """
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise DataError(f"expected a dataset name or a CSV path, got {type(name_or_path).__name__}")
    key = os.fspath(name_or_path)
    if isinstance(name_or_path, str):
        if key in TABLES:
            return _subset("table", key)
        if key in CORES:
            return _subset("core", key)
        if key == "appendix_b":
            return _bundled_appendix_b().copy()
        if key in _OTHER:
            return _bundled_other(key).copy()
    path = Path(key)
    try:
        exists = path.exists()
    except OSError as exc:  # a name too long for the file system, ...
        shown = key if len(key) <= 80 else key[:77] + "..."
        raise DataError(f"{shown}: not a usable file name ({exc.strerror or exc})") from None
    if not exists:
        looks_like_path = key.lower().endswith((".csv", ".txt")) or os.sep in key or "/" in key
        if looks_like_path:
            raise DataError(f"{key}: file not found (nor a bundled dataset: {', '.join(names())})")
        raise DataError(
            f"unknown dataset {key!r} (neither a bundled name nor an existing file); "
            f"bundled datasets: {', '.join([*names(), 'appendix_b'])}"
        )
    return read_csv(path)


def read_csv(path) -> pd.DataFrame:
    """Read and validate a user's CSV file in the Appendix B schema (see :func:`load`)."""
    path = Path(path)
    label = str(path)
    if path.is_dir():
        raise DataError(f"{label}: is a directory, not a CSV file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataError(f"{label}: cannot be read ({exc.strerror or exc})") from None
    return _parse(raw, label, stem=path.stem, bundled=False)


def summary() -> pd.DataFrame:
    """Row counts of the bundled Appendix B data, one row per table and frequency."""
    b = _bundled_appendix_b()
    keys = ["table", "graph", "core", "source_impedance_ohm", "frequency_hz"]
    out = b.groupby(keys, sort=False).agg(
        rows=("input_v", "size"),
        saturation_rows=("saturation", "sum"),
        missing_phase=("phase_lead_deg", lambda s: int(s.isna().sum())),
        input_min_v=("input_v", "min"),
        input_max_v=("input_v", "max"),
    )
    return out.reset_index()


# ------------------------------------------------------------------ bundled data
def _read_bundled_bytes(filename: str) -> bytes:
    try:
        return data_dir().joinpath(filename).read_bytes()
    except OSError as exc:  # a broken installation, not a user error, but still a data problem
        raise DataError(f"bundled dataset {filename} cannot be read ({exc})") from None


@lru_cache(maxsize=1)
def _bundled_appendix_b() -> pd.DataFrame:
    frame = _parse(
        _read_bundled_bytes("appendix_b.csv"), "appendix_b.csv", stem="appendix_b", bundled=True
    )
    frame[DECISION_COLUMN] = ""
    keys = ["table", "source_impedance_ohm", "frequency_hz"]
    for d in decisions().itertuples(index=False):
        rows = (frame[keys] == (d.table, d.source_impedance_ohm, d.frequency_hz)).all(axis=1)
        assert rows.any() and d.column in DECIDABLE_COLUMNS and d.decision == "reversed", d
        old = frame.loc[rows, DECISION_COLUMN]
        frame.loc[rows, DECISION_COLUMN] = (old + "," + d.column).str.strip(",")
    return frame


def decisions() -> pd.DataFrame:
    """The documented decisions about the bundled tables (:data:`DECISIONS`) as a frame.

    One row per decision: ``table``, ``source_impedance_ohm``, ``frequency_hz`` (the block),
    ``column``, ``decision`` (``"reversed"``: the column is taken in reverse printed order
    within its block) and ``evidence``. ``datasets/README.md`` ("Decisions") gives the
    evidence in full. :func:`load` marks the rows of a decided block in
    :data:`DECISION_COLUMN`; the printed cells are never changed.

    Examples
    --------
    >>> decisions()[["table", "frequency_hz", "column", "decision"]].values.tolist()
    [['B.5', 10.0, 'phase_lead_deg', 'reversed']]
    """
    columns = ["table", "source_impedance_ohm", "frequency_hz", "column", "decision", "evidence"]
    return pd.DataFrame(list(DECISIONS), columns=columns)


def _subset(column: str, value: str) -> pd.DataFrame:
    b = _bundled_appendix_b()
    return b[b[column] == value].reset_index(drop=True)


@cache
def _bundled_other(name: str) -> pd.DataFrame:
    dtypes = _OTHER_DTYPES[name]
    text = _read_bundled_bytes(f"{name}.csv").decode("utf-8")
    frame = pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False)
    for col, kind in dtypes.items():
        cells = frame[col].str.strip()
        if kind is float:
            frame[col] = pd.to_numeric(cells.replace("", np.nan)).astype(float)
        elif kind is int:
            frame[col] = cells.astype(int)
        elif kind is bool:
            frame[col] = cells.str.lower().map({"true": True, "false": False}).astype(bool)
    return frame


# ------------------------------------------------------------------ parsing
def _fail(label, problem, row=None, line=None, column=None):
    where = []
    if row is not None:
        where.append(f"row {row}" + (f" (line {line})" if line is not None else ""))
    if column is not None:
        where.append(f"column {column!r}")
    text = f"{label}: " + (", ".join(where) + ": " if where else "") + problem
    raise DataError(" ".join(text.split()))  # one line whatever the cell held


def _show(cell: str) -> str:
    return repr(cell if len(cell) <= 30 else cell[:27] + "...")


def _records(raw: bytes, label: str):
    """Header and ``(line, fields)`` data records of a CSV file; errors for non-CSV content."""
    if not raw.strip():
        _fail(label, "the file is empty")
    nul = raw.find(b"\0")
    if nul >= 0:
        _fail(label, f"binary content (NUL byte at offset {nul}); not a CSV text file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        _fail(
            label, f"not UTF-8 text (undecodable byte at offset {exc.start}); not a CSV text file"
        )
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    records = []
    try:
        for fields in reader:
            if any(f.strip() for f in fields):
                records.append((reader.line_num, fields))
    except csv.Error as exc:
        _fail(label, f"not valid CSV at line {reader.line_num + 1}: {exc}")
    if not records:
        _fail(label, "the file is empty (no header)")
    header_line, header = records[0]
    names_ = [h.strip().lower() for h in header]
    if len(names_) == 1:
        for sep, word in ((";", "semicolon"), ("\t", "tab"), ("|", "pipe")):
            if sep in header[0]:
                _fail(
                    label,
                    f"line {header_line}: the header looks {word}-separated; fitdf reads comma-separated "
                    "CSV",
                )
    for i, n in enumerate(names_):
        if not n:
            _fail(label, f"line {header_line}: header column {i + 1} has no name")
        if names_.index(n) != i:
            _fail(label, f"line {header_line}: column {n!r} appears twice in the header")
    data = records[1:]
    if not data:
        _fail(label, "no data rows below the header")
    for r, (line, fields) in enumerate(data, start=1):
        if len(fields) != len(names_):
            _fail(
                label,
                f"{len(fields)} fields but the header has {len(names_)} (ragged rows; check the "
                "delimiter and quoting)",
                row=r,
                line=line,
            )
    return names_, data


def _check_columns(names_, label, bundled):
    known = {*APPENDIX_B_COLUMNS, DECISION_COLUMN}
    if bundled:
        missing = [c for c in APPENDIX_B_COLUMNS if c not in names_]
        if missing:
            _fail(label, f"missing columns {missing}")
        return
    unknown = [n for n in names_ if n not in known]
    for n in unknown:
        close = difflib.get_close_matches(n, sorted(known - set(names_)), n=1, cutoff=0.75)
        if close:
            _fail(label, f"unknown column {n!r}; did you mean {close[0]!r}?", column=n)
    for req in REQUIRED_COLUMNS:
        if req not in names_:
            close = difflib.get_close_matches(req, unknown, n=1, cutoff=0.6)
            hint = f" (is {close[0]!r} a misspelling?)" if close else ""
            _fail(
                label,
                f"missing required column{hint}; required: {', '.join(REQUIRED_COLUMNS)}",
                column=req,
            )


def _decimals(cell: str) -> int:
    mantissa, _, exponent = cell.lower().partition("e")
    places = len(mantissa.partition(".")[2]) - int(exponent or 0)
    return min(max(places, 0), 99)  # clamped: "1e-99999" must not overflow the Int64 column


def _parse(raw: bytes, label: str, *, stem: str, bundled: bool) -> pd.DataFrame:
    names_, data = _records(raw, label)
    _check_columns(names_, label, bundled)
    cols = {n: [f[i].strip() for _, f in data] for i, n in enumerate(names_)}
    lines = [line for line, _ in data]
    out = {}
    decimals = {}
    for col in _FLOAT_COLUMNS:
        if col not in cols:
            continue
        values = np.full(len(data), np.nan)
        places = [pd.NA] * len(data)
        for r, cell in enumerate(cols[col]):
            if cell.lower() in _MISSING:
                continue
            if not _NUMBER.fullmatch(cell):
                _fail(label, f"{_show(cell)} is not a number", r + 1, lines[r], col)
            values[r] = float(cell)
            if not np.isfinite(values[r]):
                _fail(label, f"{_show(cell)} is not a finite number", r + 1, lines[r], col)
            places[r] = _decimals(cell)
        out[col] = values
        if col in DECIMAL_COLUMNS:
            decimals[f"{col}_decimals"] = pd.array(places, dtype="Int64")
    n = len(data)
    _check_values(out, lines, label, bundled, cols)
    frame = pd.DataFrame(index=pd.RangeIndex(n))
    text_default = {"table": stem, "core": stem, "graph": "", "core_part": "", "source": None}
    for col in APPENDIX_B_COLUMNS:
        if col in out:
            frame[col] = out[col]
        elif col in _TEXT_COLUMNS:
            frame[col] = (
                cols[col]
                if col in cols
                else (
                    [f"{Path(label).name} line {line}" for line in lines]
                    if col == "source"
                    else [text_default[col]] * n
                )
            )
        elif col == "saturation":
            frame[col] = _bools(cols.get(col), lines, label)
        elif col == "row_in_block":
            frame[col] = _row_in_block(cols.get(col), frame, lines, label)
        else:  # an absent optional number: impedance 0 ohm, no output amplitude, no footnote factor
            frame[col] = 0.0 if col == "source_impedance_ohm" else np.nan
    for col in ("input_v", "h1_output_v", "df_reported"):
        name = f"{col}_decimals"
        frame[name] = decimals.get(name, pd.array([pd.NA] * n, dtype="Int64"))
    for col in names_:
        if col not in frame:
            frame[col] = cols[col]
    if not bundled:
        _check_duplicates(frame, lines, label)
    return frame


def _check_values(out, lines, label, bundled, cells):
    required = ["input_v", "frequency_hz", "df_reported"] + ([] if bundled else ["phase_lead_deg"])
    for col in required + ["source_impedance_ohm"]:
        if col in out and np.isnan(out[col]).any():
            r = int(np.flatnonzero(np.isnan(out[col]))[0])
            cell = cells[col][r]
            what = "is empty" if not cell else f"reads {_show(cell)}, a missing value"
            _fail(label, f"value required but the cell {what}", r + 1, lines[r], col)
    rules = (
        ("input_v", lambda v: v > 0, "amplitude must be positive"),
        ("frequency_hz", lambda v: v > 0, "frequency must be positive"),
        ("h1_output_v", lambda v: v >= 0, "output amplitude must not be negative"),
        ("df_reported", lambda v: v >= 0, "describing-function magnitude must not be negative"),
        (
            "phase_lead_deg",
            lambda v: (v > -180) & (v <= 180),
            "phase must lie in (-180, 180] degrees",
        ),
        ("source_impedance_ohm", lambda v: v >= 0, "source impedance must not be negative"),
        ("df_factor_printed", lambda v: v > 0, "DF factor must be positive"),
    )
    for col, ok, problem in rules:
        if col not in out:
            continue
        v = out[col]
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~np.isnan(v) & ~ok(v))
        if bad.size:
            r = int(bad[0])
            _fail(label, f"{problem} (got {v[r]:g})", r + 1, lines[r], col)


def _bools(cells, lines, label):
    if cells is None:
        return np.zeros(len(lines), dtype=bool)
    values = []
    for r, cell in enumerate(cells):
        low = cell.lower()
        if low not in _TRUE | _FALSE:
            _fail(label, f"{_show(cell)} is not true/false", r + 1, lines[r], "saturation")
        values.append(low in _TRUE)
    return np.array(values, dtype=bool)


def _row_in_block(cells, frame, lines, label):
    if cells is not None:
        values = []
        for r, cell in enumerate(cells):
            if not re.fullmatch(r"\d{1,9}", cell, re.ASCII) or int(cell) < 1:
                _fail(
                    label,
                    f"{_show(cell)} is not a positive integer",
                    r + 1,
                    lines[r],
                    "row_in_block",
                )
            values.append(int(cell))
        return np.array(values, dtype=np.int64)
    keys = frame[["table", "source_impedance_ohm", "frequency_hz"]]
    return (keys.groupby(list(keys.columns), sort=False).cumcount() + 1).to_numpy(np.int64)


def _check_duplicates(frame, lines, label):
    key = [
        "table",
        "frequency_hz",
        "input_v",
        "df_reported",
        "phase_lead_deg",
        "source_impedance_ohm",
    ]
    dup = frame.duplicated(key, keep="first").to_numpy()
    if dup.any():
        r = int(np.flatnonzero(dup)[0])
        first = int(np.flatnonzero((frame[key] == frame.loc[r, key]).all(axis=1).to_numpy())[0])
        _fail(
            label,
            f"duplicates row {first + 1} (line {lines[first]}): same table, frequency, input, DF, phase "
            "and source impedance",
            r + 1,
            lines[r],
            "input_v",
        )
