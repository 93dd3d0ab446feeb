"""Kept jobs: a finished job is not computed again, a stopped run keeps what it finished,
and a report taken from its kept jobs is the report computed afresh."""

from __future__ import annotations

import contextlib
import io
import operator
import os
import pickle
import shutil
import time
from pathlib import Path

import pytest
from synthetic import synthetic_frame

from fitdf import cli
from fitdf.executor import Executor
from fitdf.jobcache import STALE_DAYS, JobCache, default_cache_folder, files_digest


def _counted(log, value):
    """A job that leaves a line in ``log`` each time it really runs (in any process)."""
    with open(log, "a") as f:
        f.write(f"{value}\n")
    return value * 2


def _runs(log) -> list[str]:
    return Path(log).read_text().split() if Path(log).exists() else []


def test_an_entry_is_found_under_its_job_and_salt_only(tmp_path):
    cache = JobCache(tmp_path, salt="code 1")
    d = cache.digest(pow, ("mcmc", "B.1", 0.0))
    assert d is not None and len(d) == 64
    assert cache.get(d) == (False, None)
    assert cache.put(d, (1024, 0.5))
    assert cache.get(d) == (True, (1024, 0.5)) and (cache.hits, cache.written) == (1, 1)
    # another key (to the last digit of a number), another function, another salt: another entry
    assert cache.digest(pow, ("mcmc", "B.1", 0.0)) == d
    assert cache.digest(pow, ("mcmc", "B.1", 5e-324)) != d
    assert cache.digest(pow, ("mcmc", "B.2", 0.0)) != d
    assert cache.digest(operator.mul, ("mcmc", "B.1", 0.0)) != d
    other = JobCache(tmp_path, salt="code 2")
    key = ("mcmc", "B.1", 0.0)
    assert other.digest(pow, key) != d and other.get(other.digest(pow, key))[0] is False
    # written whole, by rename: no temporary file is left
    assert [p.name for p in tmp_path.rglob("*") if p.is_file()] == [f"{d}.pkl"]


def test_what_cannot_be_kept_is_a_miss_not_an_error(tmp_path):
    cache = JobCache(tmp_path, salt="s")
    assert cache.digest(lambda: 0, ("a",)) is None  # no name to import it by
    assert cache.put(None, 1) is False and cache.get(None) == (False, None)
    d = cache.digest(pow, (2, 3))
    assert cache.put(d, lambda: 0) is False  # a result that does not pickle
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]
    path = cache.folder / d[:2] / f"{d}.pkl"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(8)[:-3])  # damaged (a disk that filled up, say)
    assert cache.get(d) == (False, None) and not path.exists()
    locked = JobCache(tmp_path / "file", salt="s")
    (tmp_path / "file").write_text("not a folder")
    assert locked.put(locked.digest(pow, (2, 3)), 8) is False


def test_other_salts_folders_are_removed_once_stale(tmp_path):
    old, recent = JobCache(tmp_path, "old code"), JobCache(tmp_path, "recent code")
    for cache in (old, recent):
        assert cache.put(cache.digest(pow, (2, 3)), 8)
    week = time.time() - (STALE_DAYS + 1) * 86400.0
    os.utime(old.folder, (week, week))
    JobCache(tmp_path, "current code")
    assert not old.folder.exists() and recent.folder.exists()
    assert JobCache(tmp_path, "recent code").get(recent.digest(pow, (2, 3))) == (True, 8)
    os.utime(recent.folder, (week, week))  # its own folder is never removed, stale or not
    assert JobCache(tmp_path, "recent code").get(recent.digest(pow, (2, 3))) == (True, 8)


def test_files_digest_follows_the_code_and_data_not_the_compiled_files(tmp_path):
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    (tmp_path / "data.csv").write_text("a,b\n1,2\n")
    first = files_digest(tmp_path)
    (tmp_path / "pkg" / "a.nbi").write_bytes(b"compiled")
    assert files_digest(tmp_path) == first
    (tmp_path / "data.csv").write_text("a,b\n1,3\n")
    assert files_digest(tmp_path) != first


def test_default_folder_is_the_users_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache_folder() == tmp_path / "fitdf" / "jobs"


@pytest.mark.parametrize("workers", [1, 2])
def test_a_kept_job_is_not_run_again(tmp_path, workers):
    log = tmp_path / "runs.log"
    jobs = {(k,): (_counted, (str(log), k)) for k in (1, 2, 3)}
    with Executor(workers, cache=JobCache(tmp_path / "c", "s")) as ex:
        assert ex.run(jobs, "first") == {(1,): 2, (2,): 4, (3,): 6}
    assert sorted(_runs(log)) == ["1", "2", "3"] and ex.reused == []
    jobs[(4,)] = (_counted, (str(log), 4))
    with Executor(workers, cache=JobCache(tmp_path / "c", "s")) as again:
        assert again.run(jobs, "again") == {(1,): 2, (2,): 4, (3,): 6, (4,): 8}
    assert sorted(_runs(log)) == ["1", "2", "3", "4"]  # only the new job ran
    assert again.reused == ["1", "2", "3"] and set(again.seconds) == {"1", "2", "3", "4"}
    assert again.cache.hits == 3 and again.cache.written == 1


def test_a_run_that_stops_keeps_the_jobs_it_finished(tmp_path):
    log = tmp_path / "runs.log"
    jobs = {("a",): (_counted, (str(log), 1)), ("bad",): (operator.truediv, (1, 0))}
    cache = JobCache(tmp_path / "c", "s")
    with pytest.raises(ZeroDivisionError), Executor(1, cache=cache) as ex:
        ex.run(jobs, "stops")
    assert cache.written == 1
    jobs[("bad",)] = (operator.truediv, (1, 2))
    with Executor(1, cache=JobCache(tmp_path / "c", "s")) as ex:
        assert ex.run(jobs, "resumed") == {("a",): 2, ("bad",): 0.5}
    assert _runs(log) == ["1"] and ex.reused == ["a"]


def test_the_stop_message_says_what_was_kept(tmp_path):
    args = cli.build_parser().parse_args(["report", "--out", str(tmp_path / "r")])
    assert cli._stopped_message(args, KeyboardInterrupt()) == (
        f"fitdf: interrupted; no report written to {tmp_path / 'r'}/"
    )
    args.job_caches = [JobCache(tmp_path / "c", "s")]
    args.job_caches[0].written, args.job_caches[0].hits = 3, 2
    assert cli._stopped_message(args, cli.Terminated()) == (
        f"fitdf: terminated; no report written to {tmp_path / 'r'}/; 5 finished jobs kept in "
        f"{tmp_path / 'c'}, the same command goes on from them"
    )


def test_a_stopped_fit_says_what_was_kept(tmp_path):
    args = cli.build_parser().parse_args(["fit", "B.3"])
    assert cli._stopped_message(args, KeyboardInterrupt()) == (
        "fitdf: interrupted; no results printed"
    )
    args.job_caches = [JobCache(tmp_path / "c", "rows 1"), JobCache(tmp_path / "c", "rows 2")]
    args.job_caches[0].written, args.job_caches[1].hits = 3, 1  # a batch: two files' caches
    assert cli._stopped_message(args, KeyboardInterrupt()) == (
        f"fitdf: interrupted; no results printed; 4 finished fits kept in {tmp_path / 'c'}, "
        "the same command goes on from them"
    )


@pytest.mark.parametrize("command", [["report", "--out", "OUT"], ["fit", "B.3"]])
def test_cache_options(tmp_path, monkeypatch, capsys, command):
    monkeypatch.setenv("FITDF_CACHE_DIR", str(tmp_path / "env"))
    parse = cli.build_parser().parse_args
    assert parse(command).cache == str(tmp_path / "env")
    assert parse([*command, "--cache", "x"]).cache == "x"
    assert parse([*command, "--no-cache"]).no_cache
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    out = tmp_path / "out"
    command = [str(out) if word == "OUT" else word for word in command]
    for argv, words in (
        (["--cache", str(a_file)], "--cache"),
        (["--cache", ""], "--cache: empty path"),
        (["--cache", "x", "--no-cache"], "not allowed with"),
    ):
        code = cli.main([*command, "--quiet", *argv])
        captured = capsys.readouterr()
        assert code == 2 and not out.exists() and not captured.out, argv
        assert words in captured.err and len(captured.err.strip().splitlines()) == 1, captured


def _fit(csv, cache, *more):
    """``fitdf fit`` of one cheap law on ``csv`` in this process, its fits kept in ``cache``
    (None: ``--no-cache``): ``(exit code, JSON, stderr)``."""
    argv = ["fit", str(csv), "--models", "constant_width", "--chain", "winding", "--no-cv"]
    argv += ["--workers", "1", "--json"]
    argv += ["--no-cache"] if cache is None else ["--cache", str(cache)]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main([*argv, *more])
    return code, out.getvalue(), err.getvalue()


def test_a_fit_asked_again_is_read_not_computed_unless_its_rows_changed(tmp_path, monkeypatch):
    import fitdf.inference.ranking as ranking

    csv = tmp_path / "core.csv"
    frame = synthetic_frame(
        "constant_width",
        {"k": 60.0, "b": 2e-4, "c": 0.04, "r_series": 100.0, "gain": 0.95},
        chain="winding",
        frequencies=(3.0, 10.0),
        amplitudes=[0.2, 0.5, 1.0, 2.0, 3.0, 4.0],
    )
    frame.to_csv(csv, index=False)
    cache = tmp_path / "kept"
    code, first, err = _fit(csv, cache)
    assert code == 0 and "read from" not in err, err
    fitted = []  # the fits that really run from here on
    real_fit = ranking.fit
    monkeypatch.setattr(ranking, "fit", lambda *a, **k: fitted.append(a[1]) or real_fit(*a, **k))
    code, again, err = _fit(csv, cache)
    assert code == 0 and again == first and fitted == []  # the same JSON, to the last digit
    assert f"1 of 1 fits read from {cache}" in " ".join(err.split())  # (wrapped)
    # one cell of the user's file changed: its own entry, computed
    frame.loc[3, "df_reported"] += 1e-3
    frame.to_csv(csv, index=False)
    code, changed, err = _fit(csv, cache)
    assert code == 0 and changed != first and fitted == ["constant_width"]
    assert "read from" not in err and len(list(cache.iterdir())) == 2
    # another seed is another entry; --no-cache neither reads nor writes
    assert _fit(csv, cache, "--seed", "3")[0] == 0 and len(fitted) == 2
    shutil.rmtree(cache)
    monkeypatch.setenv("FITDF_CACHE_DIR", str(cache))
    code, uncached, _ = _fit(csv, None)
    assert code == 0 and uncached == changed and len(fitted) == 3 and not cache.exists()


def test_a_reports_cache_is_its_settings_seed_and_clusters_own(tmp_path):
    from dataclasses import replace

    from fitdf.report.build import job_cache
    from fitdf.report.settings import ReportSettings

    base = ReportSettings.for_run()
    folder = job_cache(tmp_path, base, 0).folder
    assert job_cache(tmp_path, base, 0).folder == folder
    assert job_cache(tmp_path, replace(base, workers=7), 0).folder == folder  # same numbers
    for other, seed in (
        (base, 1),
        (ReportSettings.for_run(quick=True), 0),
        (replace(base, n_starts=5), 0),
        (replace(base, scheduler="tcp://h:8786"), 0),  # its workers' CPUs, not this one's
    ):
        assert job_cache(tmp_path, other, seed).folder != folder, (other, seed)
