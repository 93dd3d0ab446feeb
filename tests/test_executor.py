"""The report's executor: serial, local processes and a Dask cluster give the same keyed results."""

from __future__ import annotations

import json
import operator
import os
import time
from dataclasses import replace

import pandas as pd
import pytest
from tiny_settings import TINY

import fitdf.executor as executor
from fitdf import cli
from fitdf.errors import OptionError
from fitdf.executor import Executor, RemoteTraceback
from fitdf.report.build import generate_report

distributed = pytest.importorskip("distributed")

#: Jobs of the standard library only: a Dask worker imports them by name (no test module).
#: The first is the slowest, so in a pool they finish in another order than submitted.
JOBS = {
    ("slow",): (time.sleep, (0.5,)),
    ("pow", 2): (pow, (2, 10)),
    ("add",): (operator.add, ("a", "b")),
    ("pow", 3): (pow, (3, 3)),
}
EXPECTED = {("slow",): None, ("pow", 2): 1024, ("add",): "ab", ("pow", 3): 27}

#: A report small enough to run twice in a test: the tiny report of the other report tests
#: on one block, one start and no limit cycles or `winding` refits; every kind of job
#: (fits, MCMC, CV, cross-impedance, figures) still runs.
SMALL = replace(
    TINY,
    blocks=("B.1",),
    n_starts=1,
    n_steps=50,
    max_steps=50,
    limit_cycles=False,
    approximate_chain=None,
)


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as c:
        yield c


@pytest.fixture(params=["serial", "processes", "dask"])
def where(request):
    """Executor arguments of each way to run."""
    if request.param == "dask":
        return {"scheduler": request.getfixturevalue("cluster").scheduler_address}
    return {"workers": 1 if request.param == "serial" else 2}


def test_results_keyed_and_in_job_order(where):
    with Executor(**where) as ex:
        out = ex.run(JOBS, "jobs")
        again = ex.run({("neg",): (operator.neg, (4,))}, "more jobs")  # the pool is reused
    assert out == EXPECTED and list(out) == list(JOBS)
    assert again == {("neg",): -4}
    assert set(ex.seconds) == {"slow", "pow 2", "add", "pow 3", "neg"}
    assert ex.seconds["slow"] >= 0.5 and all(s >= 0 for s in ex.seconds.values())
    assert ex.workers == (1 if where.get("workers") == 1 else 2)


def test_a_failing_job_raises_its_error_and_stops_the_rest(where):
    """The job's own exception; local workers are terminated, the running job not awaited."""
    local = where.get("workers") == 2
    jobs = {
        ("bad",): (operator.truediv, (1, 0)),
        ("long",): (time.sleep, (60 if local else 0.1,)),
    }
    start = time.perf_counter()
    with pytest.raises(ZeroDivisionError) as info, Executor(**where) as ex:
        procs = [p for p, _ in ex._procs]
        ex.run(jobs, "jobs")
    print(f"stopped in {time.perf_counter() - start:.2f} s")
    if local:
        assert time.perf_counter() - start < 30  # the workers' start-up; not the 60 s job
        assert len(procs) == 2 and not any(p.is_alive() for p in procs)
        assert isinstance(info.value.__cause__, RemoteTraceback)
        assert "truediv" in str(info.value.__cause__) or "division" in str(info.value.__cause__)


def test_a_dead_worker_is_an_error_not_a_hang():
    with pytest.raises(RuntimeError, match="died running job"), Executor(workers=2) as ex:
        ex.run({("exit",): (os._exit, (3,))}, "jobs")


def test_a_scheduler_without_dask_is_a_user_error(monkeypatch):
    monkeypatch.setattr(executor, "find_spec", lambda name: None)
    with pytest.raises(OptionError, match=r"fitdf\[dask\]"), Executor(scheduler="tcp://x:8786"):
        pass


@pytest.mark.slow
def test_a_report_on_a_cluster_gives_the_serial_numbers(tmp_path, cluster):
    serial = generate_report(tmp_path / "serial", progress=False, settings=SMALL)
    on_cluster = generate_report(
        tmp_path / "cluster",
        progress=False,
        settings=replace(SMALL, scheduler=cluster.scheduler_address),
    )
    ra, rb = (json.loads((p / "results.json").read_text()) for p in (serial, on_cluster))
    assert rb["timing"]["workers"] == 2 and set(rb["timing"]["jobs_s"]) == set(
        ra["timing"]["jobs_s"]
    )
    assert "scheduler" not in rb["settings"] and "workers" not in rb["settings"]
    assert {k: v for k, v in ra.items() if k != "timing"} == {
        k: v for k, v in rb.items() if k != "timing"
    }
    figures = sorted(p.relative_to(serial).as_posix() for p in serial.rglob("*.png"))
    assert figures == sorted(
        p.relative_to(on_cluster).as_posix() for p in on_cluster.rglob("*.png")
    )
    assert "figures/B_1_fit.png" in figures  # drawn on a worker, written into the report


def test_report_scheduler_option_and_environment(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("FITDF_SCHEDULER", "tcp://envhost:8786")
    assert cli.build_parser().parse_args(["report"]).scheduler == "tcp://envhost:8786"
    given = cli.build_parser().parse_args(["report", "--scheduler", "tcp://h:1"])
    assert given.scheduler == "tcp://h:1"
    monkeypatch.delenv("FITDF_SCHEDULER")
    assert cli.build_parser().parse_args(["report"]).scheduler is None

    monkeypatch.setattr(executor, "find_spec", lambda name: None)  # Dask not installed
    out = tmp_path / "rep"
    assert cli.main(["report", "--out", str(out), "--quiet", "--scheduler", "tcp://h:1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "fitdf[dask]" in err[0], err
    assert list(tmp_path.iterdir()) == []  # no report, no temporary folder


@pytest.mark.slow  # 19 s on 2 cores (the CV folds); jobs on workers are checked by default above
def test_fits_on_workers_give_the_serial_numbers():
    # fitdf fit --workers 2: the fits and the cross-validation folds run in worker processes
    # and must give exactly the numbers of one process (the CLI's default is 2 workers)
    from fitdf.inference.ranking import compare_fits

    kw = dict(models=["constant_width", "proportional_width"], n_starts=1, seed=3)
    serial = compare_fits("B.1", **kw)
    with Executor(workers=2) as ex:
        pooled = compare_fits("B.1", runner=ex.run, **kw)
    pd.testing.assert_frame_equal(pooled.table, serial.table, check_exact=True)
    assert [r.model for r in pooled.results] == kw["models"]
    assert all(p.values == s.values for p, s in zip(pooled.results, serial.results))
    assert "cv_rms_complex" in serial.table and serial.table["cv_rms_complex"].notna().all()


class _ArgumentsLost(Exception):
    """Like lmfit's MinimizerException (1.3.4): ``Exception.__init__`` without the message,
    so unpickling calls the class without arguments. (Defined here: importing Dask
    distributed makes lmfit's own exceptions picklable, tblib's pickling support.)"""

    def __init__(self, msg):
        super().__init__()
        self.msg = msg

    def __str__(self):
        return self.msg


def test_an_error_that_does_not_unpickle_comes_back_named():
    """A worker's exception must survive the pipe: the report's least squares died of a
    TypeError about ``MinimizerException.__init__`` in the parent instead of the error."""
    import pickle

    exc = _ArgumentsLost("boom")
    with pytest.raises(TypeError):
        pickle.loads(pickle.dumps(exc))
    back = pickle.loads(pickle.dumps(executor._portable(exc)))
    assert isinstance(back, RuntimeError)
    assert str(back) == f"{__name__}._ArgumentsLost: boom"
    plain = ZeroDivisionError("division by zero")
    assert executor._portable(plain) is plain
