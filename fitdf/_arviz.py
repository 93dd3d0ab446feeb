"""ArviZ, imported when first needed and without its once-a-day notice about its own refactor.

ArviZ takes 1-3 s to import (with its plotting modules; more than anything else a
least-squares fit imports) and only the MCMC diagnostics, the LOO comparisons and the corner
plots use it, so :func:`arviz` imports it on its first call (and
:mod:`fitdf.plots.posterior` imports ``corner``, which imports ArviZ, on the first corner
plot): ``fitdf fit --method lsq`` and ``fitdf limit-cycle`` never load it.

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

__all__ = ["arviz", "REFACTOR_NOTICE", "walkers_as_chains", "without_refactor_notice"]

#: The start of ArviZ's log line about an array's shape (``arviz.stats.stats_utils``).
SHAPE_NOTICE = "Shape validation failed"


@contextlib.contextmanager
def without_refactor_notice():
    """Within: ArviZ's refactor notice is ignored (for an import that may import ArviZ first)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=REFACTOR_NOTICE, category=FutureWarning)
        yield


def arviz():
    """The ``arviz`` module, imported on the first call without its refactor notice."""
    with without_refactor_notice():
        import arviz  # here, not at the top: the module docstring says why

    return arviz


class _DropShapeNotice(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(SHAPE_NOTICE)


@contextlib.contextmanager
def walkers_as_chains():
    """Within: ArviZ's logger drops its shape notice (module docstring); nothing else."""
    # ArviZ 0.x logs through its own ``Logger("arviz")`` instance, ``arviz._log``, which
    # is not the one ``logging.getLogger("arviz")`` returns
    logger = getattr(arviz(), "_log", None) or logging.getLogger("arviz")
    drop = _DropShapeNotice()
    logger.addFilter(drop)
    try:
        yield
    finally:
        logger.removeFilter(drop)
