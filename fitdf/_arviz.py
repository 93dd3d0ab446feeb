"""ArviZ, imported without its once-a-day notice about its own coming refactor.

ArviZ 0.x warns (a multi-line ``FutureWarning``, on import, once a day) that its 1.0 will
change its interface. That concerns fitdf's maintainers, not a user's result, so only
that warning is silenced, only while ArviZ is imported; every other warning of ArviZ
still shows. fitdf is tested with ArviZ 0.x and pins ``arviz<1`` (pyproject.toml).

:func:`walkers_as_chains` silences ArviZ's log line about the shape of an array with more
chains than draws, while fitdf hands it one: fitdf makes its walkers ArviZ's chains, and a
chain stopped early and thinned can leave fewer draws per walker than ArviZ's heuristic
expects (the report's constant_width on B.2: 8 walkers of one draw). Its diagnostics
already say so; the line reached the terminal in the middle of the progress output.
"""

from __future__ import annotations

import contextlib
import logging
import warnings

#: The notice (message start; ArviZ 0.23 begins it with a newline).
REFACTOR_NOTICE = r"\s*ArviZ is undergoing a major refactor"

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message=REFACTOR_NOTICE, category=FutureWarning)
    import arviz as az

__all__ = ["az", "REFACTOR_NOTICE", "walkers_as_chains"]

#: The start of ArviZ's log line about an array's shape (``arviz.stats.stats_utils``).
SHAPE_NOTICE = "Shape validation failed"


class _DropShapeNotice(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(SHAPE_NOTICE)


@contextlib.contextmanager
def walkers_as_chains():
    """Within: ArviZ's logger drops its shape notice (module docstring); nothing else."""
    # ArviZ 0.x logs through its own ``Logger("arviz")`` instance, ``arviz._log``, which
    # is not the one ``logging.getLogger("arviz")`` returns
    logger = getattr(az, "_log", None) or logging.getLogger("arviz")
    drop = _DropShapeNotice()
    logger.addFilter(drop)
    try:
        yield
    finally:
        logger.removeFilter(drop)
