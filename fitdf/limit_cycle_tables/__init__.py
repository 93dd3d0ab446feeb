"""The thesis's own comparisons: the analog-computer limit cycles of Tables 5.1 and 5.2 (section V.6).

The loop of Fig 5.12 (error -> core -> amplidyne/generator plant -> output) was run on an
analog computer with the cores of Appendix B; Tables 5.1 (Permalloy) and 5.2 (Deltamax) list
the limit cycles seen at each system gain. :func:`thesis_limit_cycle_comparison` predicts them
by harmonic balance from the fits of the matching Appendix B tables -- first unscaled (the
plant and the system gain as printed), then with the computer's unprinted time and gain
scalings fitted to three blocks of the tables and judged on the fourth
(:mod:`fitdf.limit_cycle_tables.scales`) -- and optionally simulates the loop in time with the same
fitted cores. :mod:`fitdf.limit_cycle_tables.summary` condenses the rows per block (levels, trends,
critical gains); :func:`limit_cycle_statements` says in sentences, from those fields, what the
tables confirm and what they do not.
"""

from __future__ import annotations

from fitdf.limit_cycle_tables.comparison import thesis_limit_cycle_comparison
from fitdf.limit_cycle_tables.scales import (
    THESIS_BLOCKS,
    THESIS_PLANT,
    estimate_thesis_scales,
    held_out_scales,
    per_block_scales,
)
from fitdf.limit_cycle_tables.statements import limit_cycle_statements

__all__ = [
    "thesis_limit_cycle_comparison",
    "estimate_thesis_scales",
    "held_out_scales",
    "per_block_scales",
    "limit_cycle_statements",
    "THESIS_PLANT",
    "THESIS_BLOCKS",
]
