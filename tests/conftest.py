"""One tiny report for the four test files that read it, built once per run; the kernels compiled first.

test_report.py, test_report_browser.py, test_json_schemas.py and test_claims.py all check a freshly
generated report (its files, its page in a browser, its results.json against the schema).
The ``tiny_report`` fixture builds it once per process, and under pytest-xdist
(``--dist loadfile``, pyproject.toml) the four files are one work unit, so they run in the
same process and the report is built once per run.

On a fresh install the numba kernels are compiled once, before the test processes start
(``pytest_configure``), and every test process keeps ``fitdf report``'s finished jobs in a
folder of its own (``FITDF_CACHE_DIR``), never in the user's cache.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest


def _numba_cache_is_cold() -> bool:
    """No compiled kernel of fitdf on disk yet (a fresh install or checkout)."""
    import importlib.util
    import os

    folder = os.environ.get("NUMBA_CACHE_DIR")
    root = Path(folder) if folder else Path(importlib.util.find_spec("fitdf").origin).parent
    return not any(root.rglob("*.nbi"))


#: Compiled in a second process while the first compiles the other laws' kernels (and the
#: chains', which both need): Jiles-Atherton's take ~10 s of all of them.
_COMPILED_APART = ("jiles_atherton",)


def _compile_the_kernels(laws=None, *, skip=()) -> None:
    """Every law (or those of ``laws``, except ``skip``) through every chain once, on a few
    rows: numba compiles each kernel and writes it to its cache (``cache=True``)."""
    from fitdf.inference.api import resolve_data
    from fitdf.inference.problem import FitProblem
    from fitdf.models import model_names

    rows = resolve_data("B.1", "default", None)
    for chain in ("voltage", "winding", "direct"):
        for law in laws or model_names():
            if law not in skip:
                problem = FitProblem(rows, law, chain)
                problem.objective_residuals(problem.start_internal())


#: The job cache folder this process made for ``fitdf report`` (:func:`pytest_configure`).
_JOB_CACHE = []


def pytest_configure(config):
    """A job cache folder of this process's own for ``fitdf report`` (the command line's
    default is the user's cache, which a test must neither read nor fill); then, on a fresh
    install, compile the numba kernels once before the test processes start:
    otherwise both pytest-xdist workers, and the command-line and pool processes the tests
    start before a kernel's cache is written, each compile it (~25 s a process, measured).
    Two processes share the work (numba writes a cache file whole, by rename, so the
    kernels both compile are safe): ~13 s instead of ~22 s on two cores."""
    _JOB_CACHE.append(tempfile.mkdtemp(prefix="fitdf-test-jobs-"))
    os.environ["FITDF_CACHE_DIR"] = _JOB_CACHE[-1]
    if hasattr(config, "workerinput") or not _numba_cache_is_cold():
        return
    apart = subprocess.Popen(
        [
            sys.executable,
            "-c",
            f"import conftest; conftest._compile_the_kernels({_COMPILED_APART})",
        ],
        cwd=Path(__file__).parent,
    )
    try:
        _compile_the_kernels(skip=_COMPILED_APART)
    finally:
        if apart.wait() != 0:
            # (not fatal: the tests then compile what is missing themselves)
            print(f"conftest: compiling {_COMPILED_APART} apart failed (exit {apart.returncode})")


def pytest_unconfigure(config):
    for folder in _JOB_CACHE:
        shutil.rmtree(folder, ignore_errors=True)


#: Test files run in one pytest-xdist process (they share the session fixture ``tiny_report``).
TINY_REPORT_FILES = (
    "test_report.py",
    "test_report_browser.py",
    "test_json_schemas.py",
    "test_claims.py",
)


@pytest.fixture(scope="session")
def tiny_report(tmp_path_factory) -> Path:
    """Folder of a report generated with :data:`tiny_settings.TINY` (seed 0); read-only.
    Its finished jobs are kept in the sibling folder ``job-cache`` (:func:`tiny_job_cache`)."""
    from tiny_settings import TINY, tiny_job_cache

    from fitdf.report.build import generate_report

    out = tmp_path_factory.mktemp("tiny") / "report"
    generate_report(out, seed=0, progress=False, settings=TINY, cache=tiny_job_cache(out))
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
