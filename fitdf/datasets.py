"""The bundled datasets and the reader of your own CSV files, as ``fitdf.datasets``.

``import fitdf.datasets`` and ``fitdf.datasets`` (after ``import fitdf``) give the same
functions as :mod:`fitdf.data.datasets`, where they are documented: :func:`names` lists the
bundled datasets, :func:`load` reads one (or a CSV in the Appendix B schema, validated).

Examples
--------
>>> import fitdf.datasets
>>> fitdf.datasets.load("B.1")["frequency_hz"].unique().tolist()
[3.0, 6.0, 10.0, 20.0]
"""

from fitdf.data.datasets import (
    APPENDIX_B_COLUMNS,
    CORES,
    DECISION_COLUMN,
    DECISIONS,
    REQUIRED_COLUMNS,
    TABLES,
    data_dir,
    decisions,
    load,
    names,
    summary,
)

__all__ = [
    "names",
    "load",
    "summary",
    "decisions",
    "data_dir",
    "DECISIONS",
    "DECISION_COLUMN",
    "APPENDIX_B_COLUMNS",
    "REQUIRED_COLUMNS",
    "TABLES",
    "CORES",
]
