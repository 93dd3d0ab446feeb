"""What the chain benchmarks share: a report block by its key, fitted by least squares as
the report fits it (``bench_chain.py``, ``bench_overhead.py``, ``surrogate_check.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fitdf.report.jobs import job_lsq
from fitdf.report.settings import BLOCKS, ReportSettings


def report_lsq(block_key: str, law: str, seed: int, settings: ReportSettings):
    """The report's least-squares job for ``law`` on the block ``block_key`` (a command-line
    error naming the blocks when there is no such block)."""
    blocks = {b.key: b for b in BLOCKS}
    if block_key not in blocks:
        raise SystemExit(f"unknown block {block_key!r}; choose from {', '.join(blocks)}")
    return job_lsq(blocks[block_key].data, law, seed, settings.n_starts, settings.chain)
