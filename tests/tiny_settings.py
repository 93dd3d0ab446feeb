"""The settings of the tiny report that test_report.py, test_report_browser.py,
test_json_schemas.py and test_claims.py read (built once per run: the ``tiny_report`` fixture, conftest.py)."""

from __future__ import annotations

from pathlib import Path

from fitdf.report.build import job_cache
from fitdf.report.settings import ReportSettings

#: A report small enough for unit tests; every section and every kind of figure is still
#: produced: two blocks (one of them joint over two source impedances), least squares, a
#: posterior by nested sampling (corner figures), cross-validation, a cross-impedance
#: prediction, the limit-cycle comparison (Tables 5.1/5.2) and the thesis graphs.
TINY = ReportSettings(
    models=("proportional_width",),
    blocks=("B.1", "permalloy-joint"),
    n_starts=2,
    posterior_top=1,
    # nested sampling with fewer live points than a report's: the posterior of this 5- or
    # 6-parameter law converges in about 10,000 evaluations
    sampler="nested",
    nested_live=200,
    nested_max_evaluations=20_000,
    cv_top=1,
    cross_top=1,
    cross=(("permalloy", 0.0, 600.0, "B.1", "B.3"),),
    # one refit with rate-dependent losses per block (the physics section), not cross-validated
    dynamic_top=1,
    dynamic_cv=False,
    # the approximate chain's comparison (off by default in a report: asked for here)
    approximate_chain="winding",
    workers=1,
)


def tiny_job_cache(report: Path):
    """The job cache of the tiny report in ``report`` (conftest.py's ``tiny_report``): the
    sibling folder ``job-cache``."""
    return job_cache(Path(report).parent / "job-cache", TINY, 0)
