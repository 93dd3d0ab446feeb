"""The settings of the tiny report that test_report.py, test_report_browser.py and
test_json_schemas.py read (built once per run: the ``tiny_report`` fixture, conftest.py)."""

from __future__ import annotations

from pathlib import Path

from fitdf.report.build import ReportSettings, job_cache

#: A report small enough for unit tests; every section and every kind of figure is still
#: produced: two blocks (one of them joint over two source impedances), least squares, a
#: short MCMC chain (corner figures), cross-validation, a cross-impedance prediction, the
#: limit-cycle comparison (Tables 5.1/5.2) and the thesis graphs.
TINY = ReportSettings(
    models=("proportional_width",),
    blocks=("B.1", "permalloy-joint"),
    n_starts=2,
    mcmc_top=1,
    # short chains: the tests read what the report holds, not the posterior (15 steps, not
    # 30: 11 s less of the suite's 75 s report on 2 cores)
    n_steps=15,
    max_steps=15,
    extend_steps=None,
    closed_form_step_factor=1,  # proportional_width is in closed form: keep the chain short
    n_walkers=16,
    cv_top=1,
    cross_top=1,
    cross=(("permalloy", 0.0, 600.0, "B.1", "B.3"),),
    # one refit with rate-dependent losses per block (the physics section), not cross-validated
    dynamic_top=1,
    dynamic_cv=False,
    workers=1,
)


def tiny_job_cache(report: Path):
    """The job cache of the tiny report in ``report`` (conftest.py's ``tiny_report``): the
    sibling folder ``job-cache``."""
    return job_cache(Path(report).parent / "job-cache", TINY, 0)
