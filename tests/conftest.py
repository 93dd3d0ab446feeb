"""One tiny report for the three test files that read it, built once per run.

test_report.py, test_report_browser.py and test_json_schemas.py all check a freshly
generated report (its files, its page in a browser, its results.json against the schema).
The ``tiny_report`` fixture builds it once per process, and under pytest-xdist
(``--dist loadfile``, pyproject.toml) the three files are one work unit, so they run in the
same process and the report is built once per run.
"""

from __future__ import annotations

from pathlib import Path

import pytest

#: Test files run in one pytest-xdist process (they share the session fixture ``tiny_report``).
TINY_REPORT_FILES = ("test_report.py", "test_report_browser.py", "test_json_schemas.py")


@pytest.fixture(scope="session")
def tiny_report(tmp_path_factory) -> Path:
    """Folder of a report generated with :data:`tiny_settings.TINY` (seed 0); read-only."""
    from tiny_settings import TINY

    from fitdf.report.build import generate_report

    out = tmp_path_factory.mktemp("tiny") / "report"
    generate_report(out, seed=0, progress=False, settings=TINY)
    return out


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile``, with the files of :data:`TINY_REPORT_FILES` as one work unit."""
    if config.getoption("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class Scheduler(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            scope = super()._split_scope(nodeid)
            return "tiny report files" if Path(scope).name in TINY_REPORT_FILES else scope

    return Scheduler(config, log)
