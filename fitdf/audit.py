"""The row-level audit of the printed tables (or of your CSV), as ``fitdf.audit``.

``import fitdf.audit`` and ``fitdf.audit`` (after ``import fitdf``) give the same functions
as :mod:`fitdf.data.audit`, where they and the rules are documented.
"""

from fitdf.data.audit import (
    DEFAULT_POLICY,
    MAG_SPIKE,
    PHASE_SPIKE,
    POLICIES,
    audit,
    block_factors,
    decisions,
    findings,
    order_notes,
    policy_name,
    reversals,
    select_rows,
)

__all__ = [
    "audit",
    "block_factors",
    "select_rows",
    "findings",
    "reversals",
    "decisions",
    "order_notes",
    "policy_name",
    "POLICIES",
    "DEFAULT_POLICY",
    "MAG_SPIKE",
    "PHASE_SPIKE",
]
