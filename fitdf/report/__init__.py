"""The generated comparison report.

``build`` runs the fits and writes the files, ``costs`` and ``progress`` say how long a run
takes and how far it is; ``sections`` and ``physics`` turn results into JSON-ready records
and figures; every sentence the report generates is a claim (``claims``: a named rule on
named fields of ``results.json``), by the criteria of ``criteria``, gathered by ``words``
from ``overview``, ``conclusion``, ``findings`` and ``physics_claims``; ``document``,
``outline``, ``block_outline`` and ``physics_outline`` lay the report out as blocks;
``render`` writes them as Markdown and self-contained HTML.
"""

from fitdf.report.build import BLOCKS, Block, ReportSettings, generate_report

__all__ = ["BLOCKS", "Block", "ReportSettings", "generate_report"]
