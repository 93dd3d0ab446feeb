"""The generated comparison report: build (run the fits), sections (records), render (Markdown, HTML)."""

from fitdf.report.build import BLOCKS, Block, ReportSettings, generate_report

__all__ = ["BLOCKS", "Block", "ReportSettings", "generate_report"]
