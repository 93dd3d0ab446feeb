"""The generated comparison report.

``build`` runs the fits and writes the files, ``costs`` and ``progress`` say how long a run
takes and how far it is; ``sections`` turns results into JSON-ready records and figures,
``findings`` writes the generated conclusion and statements; ``document``,
``outline`` and ``block_outline`` lay the report out as blocks; ``render`` writes them as
Markdown and self-contained HTML.
"""

from fitdf.report.build import BLOCKS, Block, ReportSettings, generate_report

__all__ = ["BLOCKS", "Block", "ReportSettings", "generate_report"]
