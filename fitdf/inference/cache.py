"""The job cache of a comparison (``fitdf fit``): its fits kept under what they are made from.

:func:`~fitdf.inference.ranking.compare_fits` runs one job per law x chain x method (with
its cross-validation folds), keyed by position, law, chain and method; the job's arguments
are the rows, the seed and the keywords of :func:`fitdf.fit`. The salt of
:func:`comparison_cache` names all of them, the rows by their content
(:meth:`~fitdf.data.fitdata.FitData.digest`: a user's CSV edited in one cell is another
salt), beside what every number depends on (:func:`fitdf.jobcache.run_salt`: machine,
libraries, fitdf's source and bundled data). So a batch of files stopped midway goes on from
the fits it finished, and a fit asked for again is read, to the bit, not computed.
"""

from __future__ import annotations

from pathlib import Path

from fitdf.data.datasets import data_dir
from fitdf.data.fitdata import FitData
from fitdf.jobcache import JobCache, default_cache_folder, run_salt

__all__ = ["comparison_cache"]

#: Libraries a fit's result depends on beyond the machine record's numerical stack (ArviZ's
#: diagnostics decide when a chain stops; pandas builds the tables).
_LIBRARIES = ("pandas", "arviz", "xarray", "llvmlite")


def comparison_cache(
    folder, data: FitData, *, seed: int, cross_validation: bool, scheduler=None, **fit_kw
) -> JobCache:
    """The job cache of :func:`~fitdf.inference.ranking.compare_fits` on ``data``.

    Parameters
    ----------
    folder : str, Path or None
        Root of the cache (None: :func:`fitdf.jobcache.default_cache_folder`).
    data : FitData
        The rows fitted (resolved: the row policy and source impedance applied).
    seed, cross_validation :
        As given to ``compare_fits``.
    scheduler : str or None
        The Dask scheduler the fits run on (its workers compute on their own CPUs).
    **fit_kw :
        The other keywords ``compare_fits`` passes to :func:`fitdf.fit` (steps, geometry...).
    """
    parts = {
        "rows": data.digest(),
        "seed": int(seed),
        "cross_validation": bool(cross_validation),
        "fit": {k: repr(v) for k, v in sorted(fit_kw.items())},
        "scheduler": scheduler,
    }
    folders = (Path(__file__).resolve().parents[1], Path(str(data_dir())))
    root = default_cache_folder() if folder is None else folder
    return JobCache(root, run_salt(parts, folders, _LIBRARIES))
