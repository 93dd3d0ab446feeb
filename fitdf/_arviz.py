"""ArviZ, imported without its once-a-day notice about its own coming refactor.

ArviZ 0.x warns (a multi-line ``FutureWarning``, on import, once a day) that its 1.0 will
change its interface. That concerns fitdf's maintainers, not a user's result, so only
that warning is silenced, only while ArviZ is imported; every other warning of ArviZ
still shows. fitdf is tested with ArviZ 0.x and pins ``arviz<1`` (pyproject.toml).
"""

from __future__ import annotations

import warnings

#: The notice (message start; ArviZ 0.23 begins it with a newline).
REFACTOR_NOTICE = r"\s*ArviZ is undergoing a major refactor"

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message=REFACTOR_NOTICE, category=FutureWarning)
    import arviz as az

__all__ = ["az", "REFACTOR_NOTICE"]
