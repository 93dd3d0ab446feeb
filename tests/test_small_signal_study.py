"""The small-signal study (fitdf.report.small_signal_study): its sentences made from its
record, and the study run end to end on a copy of the committed report at a tiny sampler
budget (slow)."""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from fitdf.report import small_signal_study as study
from fitdf.report.claims import claim, literal_numbers, recompute
from fitdf.report.render import render_markdown
from fitdf.report.small_signal_claims import MOVED_FACTOR, small_signal_claims
from fitdf.report.upgrade import read_results
from fitdf.report.words import every_claim, report_words

COMMITTED = Path(__file__).resolve().parents[1] / "reports"


def _run(lnz, err=0.05, converged=True, rms=0.05, params=None, noise=None):
    return {
        "log_evidence": lnz,
        "log_evidence_error": err,
        "n_effective": 400.0,
        "n_likelihood_evaluations": 40000,
        "converged": converged,
        "rms_complex": rms,
        "parameters": params or {"a": [0.9, 1.0, 1.1], "b": [1.0, 2.0, 3.0]},
        "noise": noise or {"s_m": [0.01, 0.02, 0.03], "s_p_deg": [1.0, 2.0, 3.0]},
        "warnings": [],
    }


def _worst(f, v, report_miss, miss, distance):
    return {
        "table": "B.2",
        "source_impedance_ohm": 0.0,
        "frequency_hz": f,
        "input_v": v,
        "df_measured": 0.3,
        "lead_measured_deg": 20.0,
        "report_miss": report_miss,
        "report_law": "preisach",
        "miss": miss,
        "passive_distance": distance,
    }


def _record():
    reading = _run(
        115.4,
        rms=0.056,
        params={"a": [0.9, 1.05, 1.1], "b": [0.1, 0.5, 0.9]},
        noise={
            "s_m": [0.01, 0.016, 0.02],
            "s_p_deg": [0.3, 0.43, 0.5],
            "r_m": [7e-4, 1.1e-3, 1.8e-3],
            "r_p": [1e-3, 1.3e-3, 1.6e-3],
        },
    )
    return {
        "settings": {},
        "noise": [
            {
                "block": "B.2",
                "law": "preisach",
                "lsq_rms_complex": 0.0485,
                "runs": {
                    "constant": _run(81.8, rms=0.049),
                    "reading": reading,
                    "student": _run(90.0),
                },
            },
            {
                "block": "B.5",
                "law": "preisach",
                "lsq_rms_complex": 0.033,
                "runs": {
                    "constant": _run(101.4),
                    "reading": _run(
                        138.2,
                        noise={
                            **reading["noise"],
                            "r_m": [0.03, 0.0352, 0.04],
                            "r_p": [0.03, 0.0325, 0.035],
                        },
                    ),
                },
            },
        ],
        "low_field": [
            {
                "block": "B.2",
                "law": "preisach_rayleigh",
                "base": "preisach",
                "n_points": 30,
                "lsq": {
                    "aicc": 141.6,
                    "rms_complex": 0.0441,
                    "n_params": 10,
                    "cv_rms_complex": 0.069,
                },
                "base_lsq": {
                    "aicc": 142.8,
                    "rms_complex": 0.0483,
                    "n_params": 8,
                    "cv_rms_complex": 0.079,
                },
                "posterior": _run(92.05, rms=0.047),
                "worst_rows": [
                    _worst(3.0, 0.2, 0.10, 0.08, 0.0),
                    _worst(6.0, 0.1, 0.18, 0.17, 0.05),
                ],
                "base_posterior": {
                    "log_evidence": 83.43,
                    "log_evidence_error": 0.04,
                    "rms_complex": 0.073,
                },
            },
            {
                "block": "B.3",
                "law": "preisach_rayleigh",
                "base": "preisach",
                "n_points": 30,
                "lsq": {
                    "aicc": 183.1,
                    "rms_complex": 0.0519,
                    "n_params": 10,
                    "cv_rms_complex": 0.130,
                },
                "base_lsq": {
                    "aicc": 179.8,
                    "rms_complex": 0.0527,
                    "n_params": 8,
                    "cv_rms_complex": 0.083,
                },
                "posterior": _run(60.0, rms=0.06),
                "base_posterior": {
                    "log_evidence": 62.5,
                    "log_evidence_error": 0.05,
                    "rms_complex": 0.07,
                },
            },
        ],
    }


@pytest.fixture(scope="module")
def results():
    res = copy.deepcopy(read_results(COMMITTED))
    res["small_signal_evidence"] = _record()
    return res


def test_the_noise_laws_are_ranked_by_their_evidence(results):
    said = claim("small_signal.noise", results, index=0)
    v = said["values"]
    assert v["order"] == ["reading", "student", "constant"]
    # the Bayes factors over constant scales, from the runs' own evidences and errors
    assert v["lnb_0"] == pytest.approx(115.4 - 81.8) and v["n_0"] == "reading"
    assert v["lnb_1"] == pytest.approx(90.0 - 81.8) and v["n_1"] == "student"
    assert v["err_0"] == pytest.approx(np.hypot(0.05, 0.05))
    assert "reading by ln B = 33.6 ± 0.1; student by ln B = 8.2 ± 0.1" in said["text"]
    # b's median 2.0 -> 0.5 moves by 4 (> MOVED_FACTOR); a's 1.0 -> 1.05 does not
    assert v["moved"] == ["b"] and v["factor"] == MOVED_FACTOR
    assert "1.1 mV and 1.3 mV of output" in said["text"]
    assert literal_numbers(said["template"]) == []


def test_an_unconverged_noise_run_withholds_the_evidence(results):
    res = copy.deepcopy(results)
    res["small_signal_evidence"]["noise"][0]["runs"]["student"]["converged"] = False
    said = claim("small_signal.noise", res, index=0)["text"]
    assert "not stated" in said and "student" in said and "ln B" not in said


def test_the_low_field_law_is_set_beside_the_law_it_extends(results):
    better = claim("small_signal.low_field", results, index=0)
    assert better["values"]["winner"] == "preisach_rayleigh"
    assert better["values"]["lnb"] == pytest.approx(92.05 - 83.43)
    assert "ln B = 8.6 ± 0.06 (very strong)" in better["text"]  # 2 ln B = 17.2, above 10
    worse = claim("small_signal.low_field", results, index=1)
    assert worse["values"]["winner"] == "preisach"
    assert worse["values"]["lnb"] == pytest.approx(2.5)
    summary = claim("small_signal.summary", results)["text"]
    assert "has more evidence than" in summary and "on 1 of 2 tables (B.2)" in summary
    assert "the reading noise law has the highest evidence on B.2" in summary


def test_the_reading_laws_resolutions_are_compared_across_source_impedance(results):
    """One core's tables at two source impedances (Deltamax: B.2 at 0 ohm, B.5 at 600)."""
    said = claim("small_signal.resolutions", results)
    v = said["values"]
    assert (v["core_0"], v["lo_0"], v["hi_0"], v["lo_ohm_0"], v["hi_ohm_0"]) == (
        "Deltamax",
        "B.2",
        "B.5",
        0.0,
        600.0,
    )
    assert v["ratio_m_0"] == pytest.approx(0.0352 / 1.1e-3)
    assert v["ratio_p_0"] == pytest.approx(0.0325 / 1.3e-3)
    assert (
        "Deltamax at 600 ohm (B.5) needs resolutions of 35.2 and 32.5 mV of output, 32 and 25 "
        "times its 0 ohm table B.2's (1.1 and 1.3 mV)" in said["text"]
    )
    other = copy.deepcopy(results)  # two cores, one impedance each: nothing to compare
    other["small_signal_evidence"]["noise"][1]["block"] = "B.3"
    assert claim("small_signal.resolutions", other) is None


def test_the_worst_rows_are_pooled_and_the_farthest_outside_the_disc_named(results):
    said = claim("small_signal.worst_rows", results)
    v = said["values"]
    assert v["n"] == 2 and v["blocks"] == ["B.2"]
    assert v["old"] == pytest.approx(np.sqrt((0.10**2 + 0.18**2) / 2))
    assert v["new"] == pytest.approx(np.sqrt((0.08**2 + 0.17**2) / 2))
    assert v["n_out"] == 1 and v["floor"] == pytest.approx(0.05 / np.sqrt(2))
    assert (
        "farthest B.2 at 6 c/s and 0.1 V, by 0.050, which `preisach_rayleigh` misses by 0.170"
        in said["text"]
    )


def test_readings_of_passive_cores_lie_in_the_disc():
    """Every law's prediction through the exact circuit, at random parameters of its box, at 0
    and 600 ohm, lies in the disc of passive readings (to the chain's own accuracy, 1e-6);
    the printed B.3 6 c/s 0.1 V reading does not."""
    from fitdf.inference.api import resolve_data, resolve_geometry
    from fitdf.inference.problem import FitProblem
    from fitdf.inference.small_signal import passive_distance

    rng = np.random.default_rng(1)
    for block in ("B.1", "B.3"):
        fd = resolve_data(block)
        for law in ("constant_width", "rayleigh", "preisach", "jiles_atherton"):
            p = FitProblem(fd, law, "voltage", None, None, resolve_geometry("auto", fd))
            box = np.asarray(p.internal_bounds())
            x = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((8, box.shape[0]))
            pred = p.predict(x)
            gain = p.full_natural(x)["gain"][..., None]
            d = passive_distance(np.abs(pred), np.degrees(np.angle(pred)), gain)
            assert d.max() < 1e-5, (block, law)
    assert passive_distance(0.32, 82.0, 1.0) == pytest.approx(0.0548, abs=2e-4)
    assert passive_distance(0.5, 45.0, 1.0) == 0.0


def test_every_study_claim_is_made_again_and_the_section_renders(results):
    words = report_words(results)
    made = list(every_claim(words["claims"]["small_signal"]))
    assert len(made) == 6
    for c in made:
        assert recompute(c, results) == c
    res = {**results, **words}
    md = render_markdown(res)
    assert "The noise of the readings and the low-field law, by the evidence" in md
    for c in made:
        assert c["text"] in md
    assert words["findings"].count(claim("small_signal.summary", results)["text"]) == 1


def test_a_report_without_the_study_says_how_to_add_it():
    res = read_results(COMMITTED)
    res = {k: v for k, v in res.items() if k != "small_signal_evidence"}
    assert small_signal_claims(res) == {
        "noise": [],
        "low_field": [],
        "resolutions": [],
        "worst_rows": [],
    }
    assert "python -m fitdf.report.small_signal_study REPORT` adds it" in render_markdown(
        {**res, **report_words(res)}
    )


def test_an_unknown_block_is_one_line_and_exit_2(tmp_path, capsys):
    shutil.copytree(COMMITTED, tmp_path / "r")
    before = (tmp_path / "r" / "results.json").read_bytes()
    assert study.main([str(tmp_path / "r"), "--noise-blocks", "B.9", "--no-cache"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "B.9" in err
    assert (tmp_path / "r" / "results.json").read_bytes() == before


@pytest.mark.slow
def test_the_study_runs_on_a_report_and_states_its_own_numbers(tmp_path):
    """The study end to end on a copy of the committed report, at a tiny sampler budget: the
    record holds every run, the claims are made from it and rendered, nothing else changes."""
    folder = tmp_path / "r"
    shutil.copytree(COMMITTED, folder)
    res = json.loads((folder / "results.json").read_text())
    res["settings"].update(
        nested_live=60, nested_networks=1, nested_max_evaluations=1200, n_starts=1
    )
    (folder / "results.json").write_text(json.dumps(res))
    small = study.StudySettings(("B.2",), ("constant", "reading"), ("B.2",))
    record = study.add_study(folder, small, workers=2, progress=False, cache=False)
    after = read_results(folder)
    assert after["small_signal_evidence"] == json.loads(json.dumps(record))
    assert set(record["noise"][0]["runs"]) == {"constant", "reading"}
    assert record["low_field"][0]["base_posterior"]["log_evidence"] == pytest.approx(
        next(r for r in res["blocks"]["B.2"]["ranking_posterior"] if r["model"] == "preisach")[
            "log_evidence"
        ]
    )
    assert after["blocks"] == res["blocks"]
    words = report_words(after)
    assert {"claims": after["claims"], "findings": after["findings"]} == words
    for c in every_claim(words["claims"]["small_signal"]):
        assert c["text"] in (folder / "README.md").read_text()
