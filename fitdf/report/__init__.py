"""The generated comparison report.

``build`` runs the fits and writes the files; ``sections`` turns results into JSON-ready
records and figures, ``findings`` writes the generated sentences; ``document``,
``outline`` and ``block_outline`` lay the report out as blocks; ``render`` writes them as
Markdown and self-contained HTML.
"""

from fitdf.report.build import BLOCKS, Block, ReportSettings, generate_report

__all__ = ["BLOCKS", "Block", "ReportSettings", "generate_report"]
