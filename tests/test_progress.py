"""The report's progress display (fitdf.report.progress, fitdf.report.costs): the time left is
weighted by each job's expected cost and calibrated by what has been measured, on a fake clock;
the phases name only what a run computes."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path

import pytest

from fitdf.executor import Executor
from fitdf.report import costs, refresh_costs
from fitdf.report.build import printed_blocks
from fitdf.report.costs import phase_labels
from fitdf.report.progress import Phase, RunProgress, duration_text, schedule_length
from fitdf.report.settings import CORE_BLOCKS, RUNNER_UP_AICC_GAP, ReportSettings
from fitdf.report.upgrade import read_results

COMMITTED = Path(__file__).resolve().parents[1] / "reports" / "results.json"


class Clock:
    """A clock the test moves by hand."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


#: Expected seconds of fake jobs, by key (``small0``, ``small1``, ...: 1 s each): kind "chain"
#: for the chain, "fit" for the others.
COST = {"a": 10.0, "b": 10.0, "c": 4.0, "chain": 100.0}


def _cost(key):
    return 1.0 if key.startswith("small") else COST[key]


def _kind(key):
    return "chain" if key == "chain" else "fit"


def _display(phases, workers=2, clock=None, **kw):
    return RunProgress(phases, _cost, workers, kind=_kind, clock=clock or Clock(), **kw)


def test_schedule_is_the_greedy_one():
    assert schedule_length([], 2) == 0.0
    assert schedule_length([10.0, 10.0, 4.0], 2) == 14.0  # the 4 s job waits for a worker
    assert schedule_length([10.0, 10.0, 4.0], 1) == 24.0
    assert schedule_length([4.0], 2, busy=[6.0, 1.0]) == 6.0  # the worker free at 1 s takes it
    assert schedule_length([], 2, busy=[3.0, 2.0, 5.0]) == 5.0  # more running than workers


def test_time_left_follows_the_expected_costs_and_the_measured_ones():
    clock = Clock()
    planned = Phase("chains", (("chain", 100.0),))
    fits = Phase("fits", (("fit", 10.0), ("fit", 10.0), ("fit", 4.0)))
    p = _display([fits, planned], clock=clock, enabled=False)
    # before anything runs: the plan at the reference machine's speed, 10 + 10 then 4, then 100
    assert p.remaining() == 114.0 and p.ratio() is None
    assert p.basis() == "at the reference machine's speed"
    p.begin("fits", ["a", "b", "c"])
    p.started("a"), p.started("b")
    clock.now = 5.0
    assert p.remaining() == 5.0 + 4.0 + 100.0
    # "a" took twice its expected time: every fit, and the chain no fit calibrates, is
    # expected to take twice as long (b has run 20 s of its 20)
    clock.now = 20.0
    p.finished("a", 20.0)
    p.started("c")
    assert p.ratio("fit") == 2.0 and p.ratio("chain") == 2.0
    # b is due (a twentieth of its 20 s is still counted), c needs 8 s; then the chain 200 s
    assert p.remaining() == pytest.approx(8.0 + 200.0)
    clock.now = 28.0
    p.finished("c", 8.0)
    p.finished("b", 28.0)  # 28 s for 10 expected: fits now run at 56 / 24 of the committed times
    assert p.ratio("fit") == pytest.approx(56.0 / 24.0)
    p.begin("chains", ["chain"])
    p.started("chain")
    clock.now = 128.0  # the chain runs at the fits' ratio until it finishes: 233 s expected
    assert p.remaining() == pytest.approx(100.0 * 56.0 / 24.0 - 100.0)
    p.finished("chain", 150.0)  # then its own kind calibrates it
    assert p.ratio("chain") == 1.5 and p.ratio("fit") == pytest.approx(56.0 / 24.0)
    assert p.remaining() == 0.0
    p.close()


def test_progress_is_weighted_by_cost_not_by_count():
    clock = Clock()
    p = _display([Phase("all")], workers=1, clock=clock, enabled=False)
    p.begin("all", [f"small{i}" for i in range(9)] + ["chain"])
    for i in range(9):
        p.started(f"small{i}")
        clock.now += 1.0
        p.finished(f"small{i}", 1.0)
    # nine jobs of ten done, but 9 of 109 expected seconds
    assert p.fraction_done() == pytest.approx(9.0 / 109.0)
    assert p.label() == "1/1 all: 9/10 jobs" and p.remaining() == pytest.approx(100.0)
    p.started("chain")
    clock.now += 50.0  # half way through the chain: half of it counts as done
    assert p.fraction_done() == pytest.approx(59.0 / 109.0)
    p.close()


def test_jobs_from_the_cache_are_done_but_not_measured():
    p = _display([Phase("fits")], enabled=False)
    p.begin("fits", ["a", "b", "c"], cached=["a", "b"])
    assert p.ratio() is None and p.remaining() == 4.0
    assert p.fraction_done() == pytest.approx(20.0 / 24.0)
    assert p.label() == "1/1 fits: 2/3 jobs"


def test_the_display_names_the_phase_and_the_basis_of_its_estimate():
    out, clock = io.StringIO(), Clock()
    phases = [Phase("least squares", (("fit", 10.0),)), Phase("figures", (("fit", 4.0),))]
    with _display(phases, clock=clock, file=out, refresh_s=0, width=200) as p:
        p.begin("least squares", ["a"])
        p.started("a")
        clock.now = 30.0
        p.finished("a", 30.0)
        p.begin("figures", ["c"])
        p.started("c")
    text = out.getvalue()
    assert text.startswith(
        "\r  0%|                | 00:00 elapsed, about 14 s left | 1/2 least squares: 0/1 jobs | "
        "at the reference machine's speed"
    )
    assert "2/2 figures: 0/1 jobs" in text
    # after the fit took 3 times its expected 10 s: the 4 s figure job is expected at 12 s
    words = " ".join(text.split())  # (a phase's last line is wrapped)
    assert "1/2 least squares: 1/1 jobs done in 30 s; the rest: about 12 s" in words
    assert "this machine: 3.00 x the committed job times, from 1 job" in words


def test_the_display_fits_its_width_and_wraps_nothing():
    """Every line of the display (the bar as each redraw leaves it, and each phase's last
    line) within its width: a longer bar wraps, and every redraw leaves a line behind. The
    basis of the estimate leaves the bar when the bar has no room for it."""
    for width in (100, 60):
        out, clock = io.StringIO(), Clock()
        phases = [Phase("least squares", (("fit", 10.0),)), Phase("figures", (("fit", 4.0),))]
        with _display(phases, clock=clock, file=out, refresh_s=0, width=width) as p:
            p.begin("least squares", ["a"])
            p.started("a")
            clock.now = 30.0
            p.finished("a", 30.0)
            p.begin("figures", ["c"])
            p.started("c")
        lines = [part for line in out.getvalue().split("\n") for part in line.split("\r")]
        assert max(map(len, lines)) < width, max(lines, key=len)
        # (at 100 columns the phase and its jobs fit; a narrower bar is cut, never wrapped)
        assert ("| 1/2 least squares: 0/1 jobs" in out.getvalue()) == (width == 100)
        basis = "this machine: 3.00 x the committed job times"
        assert basis in " ".join(out.getvalue().split())  # (in the phase's last line)
        bars = [line for line in lines if "elapsed, about" in line]
        assert bars and all(basis not in line for line in bars)  # (no room in the bar)


def test_a_run_stopped_early_is_not_reported_done():
    out, clock = io.StringIO(), Clock()
    with pytest.raises(KeyboardInterrupt):
        with _display([Phase("fits")], clock=clock, file=out, refresh_s=0) as p:
            p.begin("fits", ["a", "b"])
            p.started("a")
            clock.now = 3.0
            raise KeyboardInterrupt
    last = out.getvalue().split("\r")[-1]
    assert "1/1 fits: 0/2 jobs | stopped" in last and "done" not in out.getvalue()


def test_no_progress_prints_nothing(capsys):
    p = RunProgress([Phase("fits")], _cost, 2, enabled=False)
    p.begin("fits", ["a"])
    p.started("a")
    p.finished("a", 1.0)
    p.close()
    assert capsys.readouterr() == ("", "")


class _Recorder:
    """A display that writes down what the executor tells it."""

    def __init__(self):
        self.calls = []

    def begin(self, desc, keys, cached):
        self.calls.append(("begin", desc, tuple(keys), tuple(cached)))

    def started(self, key):
        self.calls.append(("started", key))

    def finished(self, key, seconds):
        self.calls.append(("finished", key))


@pytest.mark.parametrize("workers", [1, 2])
def test_the_executor_tells_its_display_every_job(workers):
    jobs = {("a",): (pow, (2, 3)), ("b",): (pow, (3, 2)), ("c",): (abs, (-1,))}
    with Executor(workers=workers) as ex:
        ex.display = _Recorder()
        assert ex.run(jobs, "phase") == {("a",): 8, ("b",): 9, ("c",): 1}
    calls = ex.display.calls
    assert calls[0] == ("begin", "phase", (("a",), ("b",), ("c",)), ())
    for key in jobs:  # each job started once, then finished once
        assert calls.count(("started", key)) == 1 and calls.count(("finished", key)) == 1
        assert calls.index(("started", key)) < calls.index(("finished", key))


# ------------------------------------------------------------------ the report's plan


def _plan(settings):
    models, blocks = settings.model_list(), [b.key for b in settings.block_list()]
    lsq = [(b, m) for b in blocks for m in models]
    folds = dict.fromkeys(blocks, 4)
    printed = [b.key for b in printed_blocks(settings.block_list())]
    return costs.plan(settings, models, blocks, lsq, folds, phase_labels(settings), printed)


def test_a_quick_run_names_no_mcmc():
    quick = ReportSettings.for_run(quick=True)
    labels = phase_labels(quick)
    assert labels == (
        "least squares",
        "rate-dependent refits, cross-impedance, limit cycles",
        "figures",
    )
    phases, what = _plan(quick)
    assert [p.label for p in phases] == list(labels)
    text = " ".join(labels) + " ".join(what)
    assert "MCMC" not in text and "nested" not in text and "cross-validation" not in text
    full = phase_labels(ReportSettings.for_run(full=True, compare_chain="winding"))
    assert full[1] == (
        "nested sampling, cross-validation, winding refits, rate-dependent refits, "
        "cross-impedance, limit cycles"
    )
    emcee = replace(ReportSettings.for_run(), sampler="emcee")
    assert phase_labels(emcee)[1].startswith("MCMC, ")
    bare = ReportSettings(
        posterior_top=0,
        cv_top=0,
        cross=(),
        limit_cycles=False,
        approximate_chain=None,
        dynamic_chain=None,
        printed_top=0,
    )
    phases, _ = _plan(bare)
    assert [p.label for p in phases] == ["least squares", "figures"]  # no empty second phase


def test_the_committed_run_is_planned_as_it_ran():
    """At the committed machine's speed the plan of the command that made the committed report
    takes about what that report took: its own jobs, on its 2 workers."""
    assert costs.COMMITTED_RUN["command"] == "fitdf report --full"
    settings = ReportSettings.for_run(full=True)
    phases, what = _plan(settings)
    # (the second phase: 21 posteriors, 14 cross-validations, 14 rate-dependent refits, 4
    # fits to the rows as printed, 8 cross-impedance predictions and the limit cycles)
    assert [len(p.planned) for p in phases] == [56, 62, 12]
    assert what[:3] == [
        "56 least-squares fits (8 laws on 7 blocks)",
        "21 posteriors and evidence (nested sampling), 14 evidences again with the prior box "
        "halved and doubled",
        "14 cross-validations (56 leave-one-frequency-out folds)",
    ]
    assert what[-1] == "up to 41 figures"
    total = costs.estimate(phases, 2)
    assert total == pytest.approx(costs.COMMITTED_RUN["total_s"], rel=0.03)
    assert not costs.rough(settings) and costs.rough(ReportSettings.for_run(quick=True))
    line = costs.start_line(what, total, 2)
    took = duration_text(costs.COMMITTED_RUN["total_s"])
    assert f"About {duration_text(total)} with 2 workers" in line
    assert f"{took} for `fitdf report --full`" in line
    assert "first jobs finish" in line
    # the default run, from the same jobs: the best law of each core, and the runner-up where
    # the committed report's AICc gap is below the threshold
    settings = ReportSettings.for_run()
    default, what = _plan(settings)
    fits = read_results(COMMITTED)["blocks"] if COMMITTED.exists() else None
    sampled = {}
    for key in CORE_BLOCKS:
        aicc = costs.COMMITTED_AICC[key]
        if fits is not None:  # the table is the committed report's ranking
            assert aicc == {r["model"]: r["aicc"] for r in fits[key]["ranking_lsq"]}
        best, second = list(aicc)[:2]
        sampled[key] = [best] + [second] * (aicc[second] - aicc[best] < RUNNER_UP_AICC_GAP)
    n = sum(map(len, sampled.values()))
    assert what[1].startswith(f"{n} posteriors and evidence (nested sampling; a runner-up's")
    # its second phase: the --full run's less those posteriors, cross-validations and refits
    assert [len(p.planned) for p in default] == [56, 62 - 21 + n, 12]
    nested = sorted(s for k, s in default[1].planned if k == "nested")
    assert nested == sorted(costs._SECONDS[f"nested {b} {m}"] for b in sampled for m in sampled[b])
    # with every runner-up sampled (no threshold), as the default run was planned before
    every, _ = _plan(replace(settings, posterior_runner_up_below=None))
    assert [len(p.planned) for p in every] == [56, 62 - 21 + 2 * len(CORE_BLOCKS), 12]
    assert costs.estimate(default, 2) < costs.estimate(every, 2)


def test_expected_seconds_of_jobs_the_table_lacks():
    # a job of the committed report: its own time; another law: its kind's mean on the block
    b4 = [s for k, s in costs._SECONDS.items() if k.startswith("nested B.4 ")]
    assert len(b4) == 3 and "nested B.4 preisach" in costs._SECONDS
    assert (
        costs.expected_seconds(("nested", "B.4", "preisach"))
        == costs._SECONDS["nested B.4 preisach"]
    )
    assert costs.expected_seconds(("nested", "B.4", "rayleigh")) == pytest.approx(sum(b4) / 3)
    assert costs.unknown_laws("nested", "B.4", 3) == [
        ("nested", s) for s in sorted(b4, reverse=True)
    ]  # longest first
    # a kind the committed report did not run: a multiple of the block's least-squares fits
    lsq_b5 = [s for k, s in costs._SECONDS.items() if k.startswith("B.5 ")]
    assert costs.expected_seconds(("mcmc", "B.5", "preisach")) == pytest.approx(
        costs._DERIVED["mcmc"] * sum(lsq_b5) / len(lsq_b5)
    )
    assert costs.job_kind(("cross", "permalloy", 0.0, 600.0)) == "figures"
    assert costs.job_kind(("cross", "permalloy", 0.0, 600.0, "preisach")) == "cross"
    assert costs.job_kind(("B.1", "preisach")) == "lsq"


def test_durations_read_as_a_person_would_say_them():
    assert [duration_text(s) for s in (42, 600, 7028, 25_000)] == [
        "42 s",
        "10 min",
        "1 h 57 min",
        "6 h 57 min",
    ]


@pytest.mark.skipif(not COMMITTED.exists(), reason="no committed reports/results.json")
def test_the_cost_table_is_the_committed_reports():
    """The package's committed_costs.json is the committed report's costs (read through the
    schema upgrade); after the report is regenerated, this says to refresh it."""
    committed = costs.cost_record(read_results(COMMITTED), known=costs.COMMITTED_RUN)
    if committed["run"]["total_s"] != costs.COMMITTED_RUN["total_s"]:
        pytest.skip(
            "reports/results.json was regenerated: refresh fitdf/report/committed_costs.json "
            "with `python -m fitdf.report.refresh_costs reports`"
        )
    assert committed == costs.COMMITTED
    assert set(costs.COMMITTED_SETTINGS) == set(costs.COST_SETTINGS)


def test_a_posterior_with_its_prior_sensitivity_is_planned_with_its_box():
    """``--full``: the best two laws of each block also sample the box doubled in the same job
    (the halved box comes from the posterior's draws), so each of those jobs is planned as
    its posterior and its box, each at the committed report's seconds; the third alone."""
    full = ReportSettings.for_run(full=True)
    phases, _ = _plan(full)
    nested = sorted((s for _, s in phases[1].planned if _ == "nested"), reverse=True)
    assert len(nested) == 21
    aicc = costs.COMMITTED_AICC["B.4"]
    laws = sorted(aicc, key=aicc.get)[:3]
    keys = [f"nested B.4 {m}" for m in laws]
    planned_b4 = [costs.expected_seconds(k) + costs._SENSITIVITY_SECONDS[k] for k in keys[:2]]
    planned_b4.append(costs.expected_seconds(keys[2]))
    assert keys[2] not in costs._SENSITIVITY_SECONDS
    for s in planned_b4:
        assert any(abs(s - n) < 1e-9 for n in nested), (s, nested)


def _costed(fits_key="fits_posterior", **more) -> dict:
    """A results record of four jobs, three of them posteriors on B.3, one with its prior's
    box restricted from its draws and sampled, one with two boxes sampled (a record from
    before restriction: no ``estimate``)."""

    def job(boxes):
        return {"diagnostics": {"prior_sensitivity": {"boxes": boxes}}}

    return {
        "settings": {"n_starts": 6, "sampler": "nested", "chain": "voltage"},
        "run": {"run": "full", "command": "fitdf report --full"},
        "timing": {"jobs_s": {"nested B.3 preisach": 300.0, "nested B.3 cubic_hc": 300.0,
                              "nested B.3 rayleigh": 300.0, "B.3 preisach": 10.004},
                   "total_s": 1234.6, "workers": 2, "machine": {"cpu": "Some CPU"}},
        "blocks": {"B.3": {fits_key: {
            "preisach": job([{"estimate": "restricted"}, {"estimate": "sampled"}]),
            "cubic_hc": job([{}, {}]),
            "rayleigh": {"diagnostics": {}},
        }}},
        **more,
    }  # fmt: skip


def test_the_cost_table_counts_the_runs_a_posterior_job_sampled():
    """A posterior job with its prior's sensitivity enters the table at its seconds over the
    runs it sampled: a box restricted from its draws is no run; a box without ``estimate``
    (a record from before restriction) was sampled."""
    record = costs.cost_record(_costed())
    assert record["jobs_s"] == {
        "nested B.3 preisach": 150.0,
        "nested B.3 cubic_hc": 100.0,
        "nested B.3 rayleigh": 300.0,
        "B.3 preisach": 10.0,
    }
    assert record["run"] == {
        "cpu": "Some CPU",
        "cores": None,  # a record from before timing.cores
        "workers": 2,
        "total_s": 1235,
        "command": "fitdf report --full",
    }
    assert record["settings"]["n_starts"] == 6 and record["settings"]["nested_live"] is None
    assert set(record["settings"]) == set(costs.COST_SETTINGS)
    # a record of the earlier schema (fits_mcmc) costs the same
    assert costs.cost_record(_costed("fits_mcmc")) == record
    known = {"cores": 8, "command": "fitdf report"}
    assert costs.cost_record(_costed(), known=known)["run"]["cores"] == 8  # only what it lacks
    assert costs.cost_record(_costed(), known=known)["run"]["command"] == "fitdf report --full"


def test_a_posterior_job_is_split_from_its_boxes_by_their_recorded_seconds(monkeypatch):
    """Boxes that record their runs' seconds: the table holds the posterior's seconds (the
    job's less its boxes') and the boxes' beside it, so a run without the prior's sensitivity
    is planned at the posterior's alone and one with it at the whole job; a posterior the
    table lacks gets the table's ratio of box to posterior seconds."""
    results = _costed()
    boxes = results["blocks"]["B.3"]["fits_posterior"]["preisach"]["diagnostics"]
    boxes["prior_sensitivity"]["boxes"][1]["seconds"] = 240.0  # the doubled box missed: long
    record = costs.cost_record(results)
    assert record["jobs_s"]["nested B.3 preisach"] == 60.0
    assert record["sensitivity_s"] == {"nested B.3 preisach": 240.0}
    # the others are as before: no seconds recorded, the job shared among its runs
    assert record["jobs_s"]["nested B.3 cubic_hc"] == 100.0
    monkeypatch.setattr(costs, "_SECONDS", {k: float(v) for k, v in record["jobs_s"].items()})
    monkeypatch.setattr(costs, "_SENSITIVITY_SECONDS", record["sensitivity_s"])
    assert costs._box_seconds("nested B.3 preisach", 60.0) == 240.0
    assert costs._box_seconds("nested B.5 preisach", 50.0) == 200.0  # the ratio, 4
    monkeypatch.setattr(costs, "_SENSITIVITY_SECONDS", {})
    assert costs._box_seconds(None, 50.0) == 50.0 * len(costs.SAMPLED_FACTORS)


def test_the_refresh_command_writes_the_file_the_estimates_read(tmp_path, monkeypatch, capsys):
    """``python -m fitdf.report.refresh_costs REPORT`` writes the record of REPORT's results.json,
    which is what the package reads as the committed costs."""
    results = _costed(timing=dict(_costed()["timing"], cores=4))
    (tmp_path / "results.json").write_text(json.dumps(results))
    out = tmp_path / "committed_costs.json"
    assert refresh_costs.main([str(tmp_path), "--out", str(out)]) == 0
    written = json.loads(out.read_text())
    assert written == costs.cost_record(results) and written["run"]["cores"] == 4
    assert "4 jobs of `fitdf report --full`, 1235 s on 2 workers" in capsys.readouterr().out
    # the package's own file has that shape, and its jobs are the table the estimates read
    assert set(costs.COMMITTED) == {"run", "settings", "jobs_s", "sensitivity_s", "aicc"}
    assert costs.COMMITTED_AICC is costs.COMMITTED["aicc"]
    assert (
        costs.expected_seconds(("nested", "B.4", "preisach"))
        == costs.COMMITTED["jobs_s"]["nested B.4 preisach"]
    )
