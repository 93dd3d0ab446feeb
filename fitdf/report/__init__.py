"""The generated comparison report.

``settings`` says what a run computes, ``jobs`` are its jobs, ``build`` runs them and
assembles the record, ``output`` writes the folder atomically (and keeps a more complete
report from being replaced by a lesser run); ``upgrade`` reads a ``results.json`` of an
earlier schema; ``costs`` (from the committed run's ``committed_costs.json``) and
``progress`` say how long a run takes and how far it is; ``sections`` and ``physics`` turn
results into JSON-ready records and figures; every sentence the report generates is a claim (``claims``: a named rule on
named fields of ``results.json``), by the criteria of ``criteria``, gathered by ``words``
from ``overview``, ``conclusion``, ``findings`` and ``physics_claims``; ``document``,
``outline``, ``block_outline`` and ``physics_outline`` lay the report out as blocks;
``render`` writes them as Markdown and self-contained HTML.
"""

from fitdf.report.build import generate_report
from fitdf.report.settings import BLOCKS, Block, ReportSettings

__all__ = ["BLOCKS", "Block", "ReportSettings", "generate_report"]
