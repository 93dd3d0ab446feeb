"""The row-level audit of the printed tables (or of your CSV), as ``fitdf.audit``.

``import fitdf.audit`` and ``fitdf.audit`` (after ``import fitdf``) give the same functions
as :mod:`fitdf.data.audit`, where they and the rules are documented.
"""

from fitdf.data.audit import (
    MAG_SPIKE,
    PHASE_SPIKE,
    POLICIES,
    audit,
    block_factors,
    findings,
    reversals,
    select_rows,
)

__all__ = [
    "audit",
    "block_factors",
    "select_rows",
    "findings",
    "reversals",
    "POLICIES",
    "MAG_SPIKE",
    "PHASE_SPIKE",
]
