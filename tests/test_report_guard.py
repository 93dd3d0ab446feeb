"""A report is never replaced by a lesser run by surprise (fitdf.report.output.check_replace,
fitdf.report.settings.lost_by), and ``fitdf report`` writes into a folder of its own.

No test here fits anything: the run's computation is replaced by a sentinel that fails the
test if it is reached where the run should have been refused.
"""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

import fitdf.report.build as build
from fitdf import cli
from fitdf.report.output import LesserReport, check_replace
from fitdf.report.settings import ReportSettings, lost_by, run_record, settings_record

FULL, DEFAULT, QUICK = (
    ReportSettings.for_run(full=True),
    ReportSettings.for_run(),
    ReportSettings.for_run(quick=True),
)


def _record(settings: ReportSettings) -> dict:
    return settings_record(settings)


class Computed(BaseException):
    """The run got past its checks to the computation (not an ``Exception``: the command
    line would report it as an internal error)."""


@pytest.fixture
def no_computation(monkeypatch):
    def collect(*args, **kwargs):
        raise Computed

    monkeypatch.setattr(build, "collect", collect)


def _report_folder(tmp_path, settings: ReportSettings, *, v1=False):
    """A folder holding a report's results.json of ``settings`` (the keys of schema version 1
    with ``v1``) and a README."""
    out = tmp_path / "reports"
    out.mkdir()
    record = _record(settings)
    if v1:
        record["mcmc_top"] = record.pop("posterior_top")
        record["mcmc_skip"] = record.pop("posterior_skip")
        record["methods"] = ["mcmc" if m == "posterior" else m for m in record["methods"]]
    results = {"seed": 0, "settings": record, "run": run_record(settings, 0)}
    (out / "results.json").write_text(json.dumps(results))
    (out / "README.md").write_text("the committed report\n")
    return out


def test_the_runs_are_ordered_by_what_they_compute():
    full, default, quick = _record(FULL), _record(DEFAULT), _record(QUICK)
    assert lost_by(full, default) == ["posteriors"]  # the best two of each core, not three
    assert lost_by(full, quick) == [
        "posteriors",
        "cross-validations",
        "cross-impedance predictions",
        "fits to the rows as printed",
        "rate-dependent refits",
    ]
    assert lost_by(default, quick)[:2] == ["posteriors", "cross-validations"]
    for a, b in ((quick, default), (default, full), (quick, full), (full, full)):
        assert lost_by(a, b) == [], (a, b)
    # the approximate chain's refits are something a report holds
    winding = _record(ReportSettings.for_run(full=True, compare_chain="winding"))
    assert lost_by(winding, full) == ["winding refits"] and lost_by(full, winding) == []


def test_each_part_a_report_holds_is_counted_at_its_bound():
    base = replace(DEFAULT, posterior_blocks=None)
    record = _record(base)
    assert lost_by(record, record) == []
    for change, lost in (
        ({"posterior_top": 1}, "posteriors"),
        ({"methods": ("lsq",)}, "posteriors"),
        ({"posterior_blocks": ("B.1",)}, "posteriors"),
        ({"sampler": "emcee"}, "posteriors"),
        ({"cv_top": 1}, "cross-validations"),
        ({"cross_top": 1}, "cross-impedance predictions"),
        ({"cross": base.cross[:2]}, "cross-impedance predictions"),
        ({"printed_top": 1}, "fits to the rows as printed"),
        ({"limit_cycles": False}, "limit cycles"),
        ({"dynamic_top": 1}, "rate-dependent refits"),
        ({"dynamic_chain": None}, "rate-dependent refits"),
        ({"dynamic_cv": False}, "rate-dependent refits' cross-validations"),
        ({"models": ("preisach", "rayleigh")}, "laws"),
        ({"blocks": ("B.1",)}, "blocks"),
    ):
        said = lost_by(record, _record(replace(base, **change)))
        assert len(said) == 1 and said[0].startswith(lost), (change, said)
        # one more than the report holds, or all of them (None), loses nothing
    for more in ({"posterior_top": 3}, {"posterior_top": None}, {"cv_top": None}):
        assert lost_by(record, _record(replace(base, **more))) == [], more
    assert lost_by(_record(replace(base, posterior_top=0)), _record(QUICK))[0] != "posteriors"


def test_a_quick_run_into_a_full_report_refuses_before_any_fit(tmp_path, no_computation):
    out = _report_folder(tmp_path, FULL)
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(LesserReport) as refused:
        build.generate_report(out, quick=True, progress=False)
    said = str(refused.value)
    assert "\n" not in said
    assert said.startswith(f"{out} holds a report made by `fitdf report --full`;")
    assert (
        "`fitdf report --quick` would replace it without its posteriors, cross-validations" in said
    )
    assert said.endswith("write elsewhere (--out DIR) or replace it (--replace)")
    assert (out / "README.md").read_text() == "the committed report\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no temporary folder either
    # the default run too; asked to, or with at least as much, the run goes ahead
    with pytest.raises(
        LesserReport, match="`fitdf report` would replace it without its posteriors"
    ):
        build.generate_report(out, progress=False, settings=DEFAULT)
    for settings, asked in ((QUICK, True), (FULL, False)):
        with pytest.raises(Computed):
            build.generate_report(out, progress=False, settings=settings, replace=asked)


def test_a_report_holding_a_small_signal_study_is_not_replaced_by_surprise(
    tmp_path, no_computation
):
    """No run of fitdf report makes the study: even a --full run would lose it."""
    out = _report_folder(tmp_path, FULL)
    results = json.loads((out / "results.json").read_text())
    results["small_signal_evidence"] = {"settings": {}, "noise": [], "low_field": []}
    (out / "results.json").write_text(json.dumps(results))
    with pytest.raises(LesserReport) as refused:
        build.generate_report(out, progress=False, settings=FULL)
    said = str(refused.value)
    assert "`fitdf report --full` would replace it without its small-signal study" in said
    assert "\n" not in said and (out / "README.md").read_text() == "the committed report\n"
    with pytest.raises(Computed):  # asked to
        build.generate_report(out, progress=False, settings=FULL, replace=True)


def test_a_report_of_the_earlier_schema_is_guarded_too(tmp_path, no_computation):
    out = _report_folder(tmp_path, FULL, v1=True)
    with pytest.raises(LesserReport, match="without its posteriors"):
        check_replace(out, _record(DEFAULT), "fitdf report")
    # a folder whose results.json says nothing of its settings: nothing to lose by its words
    (out / "results.json").write_text('{"seed": 0}\n')
    check_replace(out, _record(QUICK), "fitdf report --quick")
    # settings of its own, over a --full report: what it lacks is named
    (out / "results.json").write_text(json.dumps({"settings": _record(FULL)}))
    tiny = replace(QUICK, models=("rayleigh",), blocks=("B.1",))
    with pytest.raises(LesserReport, match="made by settings of its own; these settings would"):
        (out / "results.json").write_text(json.dumps({"settings": _record(FULL), "run": {}}))
        check_replace(out, _record(tiny), None)


def test_the_command_line_refuses_in_one_line_and_says_where_a_report_goes(
    tmp_path, no_computation, capsys, monkeypatch
):
    out = _report_folder(tmp_path, FULL)
    code = cli.main(["report", "--quick", "--out", str(out), "--no-cache", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith("fitdf report: error: ") and "--replace" in err
    # with --replace the run goes on to the computation
    with pytest.raises(Computed):
        cli.main(["report", "--quick", "--out", str(out), "--no-cache", "--quiet", "--replace"])
    # by default a report goes into fitdf-report/ of the current folder, not a clone's reports/
    monkeypatch.chdir(tmp_path)
    assert cli.build_parser().parse_args(["report"]).out == build.DEFAULT_OUT == "fitdf-report"
    with pytest.raises(Computed):
        cli.main(["report", "--quick", "--no-cache", "--quiet"])
    assert (out / "README.md").read_text() == "the committed report\n"
