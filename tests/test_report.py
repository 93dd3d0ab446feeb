"""The generated report: files, self-containedness, results.json, atomic writes, determinism."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from tiny_settings import TINY

import fitdf.report.block_outline as block_outline
import fitdf.report.outline as outline
import fitdf.report.render as render
import fitdf.report.sections as sections
from fitdf.limit_cycle_tables import limit_cycle_statements
from fitdf.machine import machine_record, same_machine
from fitdf.plots.summary import CAPTION, constant_rows, plot_summary, residual_grid
from fitdf.report import costs
from fitdf.report.build import generate_report
from fitdf.report.settings import BLOCKS, ReportSettings
from fitdf.report.upgrade import SCHEMA_VERSION, read_results

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
COMMITTED = REPO / "reports" / "results.json"

#: Smaller still: fits of one block, no MCMC (atomic-write tests).
MINI = ReportSettings(
    models=("proportional_width",),
    blocks=("B.1",),
    n_starts=1,
    posterior_top=0,
    cv_top=0,
    cross=(),
    limit_cycles=False,
    workers=1,
    # the cheap chain and no refit through another: what is tested is the folder's swap
    chain="winding",
    approximate_chain=None,
)


_PNG = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360000002000100e5270ad60000000049454e44ae426082"
)


@pytest.fixture
def stub_figures(monkeypatch):
    """Replace the (slow) figures by 1-pixel PNGs: for tests about the numbers and the file handling."""

    def make_figures(kind, payload, figdir):
        names = {"thesis": ["thesis_4_1"], "cross": ["cross"]}.get(
            kind, ["fit", "loci", "residuals", "corner"]
        )
        paths = {}
        for n in names:
            name = f"{payload['block'].key if kind == 'block' else kind}_{n}.png"
            (figdir / name).write_bytes(_PNG)
            paths[n] = f"figures/{name}"
        if kind == "thesis":
            return [{"graph": "4.1", "path": paths["thesis_4_1"], "title": "stub"}]
        return paths["cross"] if kind == "cross" else paths

    monkeypatch.setattr(sections, "make_figures", make_figures)


def _strip_timing(results: dict) -> dict:
    return {k: v for k, v in results.items() if k != "timing"}


# ``tiny_report``: the report of TINY (conftest.py): every section, the real modules.
@pytest.fixture(scope="module")
def tiny_results(tiny_report):
    return json.loads((tiny_report / "results.json").read_text())


def test_report_records_the_machine_it_ran_on(tiny_report, tiny_results):
    machine = tiny_results["timing"]["machine"]
    assert machine == machine_record()
    assert machine["cpu"] and machine["llvm_cpu"] and machine["libraries"]["numpy"]
    text = (tiny_report / "README.md").read_text()
    assert (
        f"computed on {machine['cpu']}" in text and f"numpy {machine['libraries']['numpy']}" in text
    )
    assert same_machine(machine, dict(machine))
    other = {**machine, "libraries": {**machine["libraries"], "numpy": "0.0"}}
    assert not same_machine(machine, other) and not same_machine(None, machine)


def test_report_writes_every_file(tiny_report, tiny_results):
    for name in ("README.md", "index.html", "results.json"):
        assert (tiny_report / name).stat().st_size > 1000
    # the cost of each job, as the package's committed_costs.json holds the committed run's
    written = json.loads((tiny_report / "costs.json").read_text())
    assert written == costs.cost_record(tiny_results)
    assert set(written["jobs_s"]) == set(tiny_results["timing"]["jobs_s"])
    assert written["run"]["cores"] == os.cpu_count() == tiny_results["timing"]["cores"]
    assert tiny_results["schema_version"] == SCHEMA_VERSION
    figures = {
        p.relative_to(tiny_report).as_posix() for p in (tiny_report / "figures").rglob("*.png")
    }
    for key in TINY.blocks:
        for kind in ("fit", "loci", "residuals", "corner"):
            assert tiny_results["blocks"][key]["figures"][kind] in figures
    assert tiny_results["cross_impedance"][0]["figure"] in figures
    assert len([f for f in figures if f.startswith("figures/thesis/")]) == 7
    # Markdown links every figure relatively, and only existing ones
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", (tiny_report / "README.md").read_text())
    assert (
        links
        and set(links) <= figures
        and not any(link.startswith(("/", "http")) for link in links)
    )
    assert not list(tiny_report.parent.glob(".report.*")), "temporary directories left behind"


def test_a_report_from_its_kept_jobs_is_the_report_computed(tiny_report, tmp_path):
    """The tiny report again, from the jobs its first build kept: every job is taken from the
    cache, in a fresh interpreter whose string hashing differs (a key must not depend on
    it), and every number, figure and page is the same."""
    first = json.loads((tiny_report / "results.json").read_text())
    assert first["timing"]["reused_jobs"] == []
    out = tmp_path / "again"
    code = (
        "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]);"
        "from tiny_settings import TINY, tiny_job_cache;"
        "from fitdf.report.build import generate_report;"
        "c = tiny_job_cache(Path(sys.argv[2]));"
        "generate_report(sys.argv[3], seed=0, progress=False, settings=TINY, cache=c);"
        "print(c.hits, c.written)"
    )
    env = {**os.environ, "PYTHONHASHSEED": "4242", "PYTHONWARNINGS": "ignore"}
    done = subprocess.run(
        [sys.executable, "-c", code, str(TESTS), str(tiny_report), str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    again = json.loads((out / "results.json").read_text())
    jobs = set(first["timing"]["jobs_s"])
    assert set(again["timing"]["reused_jobs"]) == jobs and len(jobs) >= 10
    assert done.stdout.split() == [str(len(jobs)), "0"]
    assert again["timing"]["jobs_s"] == first["timing"]["jobs_s"]  # the times they took
    assert _strip_timing(again) == _strip_timing(first)
    said = f"{len(jobs)} of {len(jobs)} jobs taken from the job cache"
    assert said in (out / "README.md").read_text()
    assert "taken from the job cache" not in (tiny_report / "README.md").read_text()
    figures = sorted(p.relative_to(tiny_report).as_posix() for p in tiny_report.rglob("*.png"))
    assert figures == sorted(p.relative_to(out).as_posix() for p in out.rglob("*.png"))
    for name in figures:  # the summary figure is drawn again; the jobs' come from the cache
        if name != "figures/summary.png":
            assert (tiny_report / name).read_bytes() == (out / name).read_bytes(), name
    assert TINY.workers == 1  # (the first build ran its jobs in-process, this one as well)


def test_html_is_self_contained(tiny_report):
    page = (tiny_report / "index.html").read_text()
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page, re.I)
    assert "http://" not in page and "https://" not in page
    assert "<script" not in page.lower() and "<link" not in page.lower()
    imgs = re.findall(r'<img src="([^"]+)"', page)
    assert imgs and all(src.startswith("data:image/png;base64,") for src in imgs)
    md_images = (tiny_report / "README.md").read_text().count("![")
    assert len(imgs) == md_images
    assert page.count("<table") >= 10


def _image_links(markdown: str) -> list[str]:
    return re.findall(r"!\[[^\]]*\]\(([^)]+)\)", markdown)


def test_report_opens_with_the_summary_figure(tiny_report, tiny_results):
    path = tiny_results["summary_figure"]
    assert path == "figures/summary.png" and (tiny_report / path).stat().st_size > 10_000
    md = (tiny_report / "README.md").read_text()
    assert _image_links(md)[0] == path  # the first figure, right after the title and intro
    assert md.index(path) < md.index("## Contents") and CAPTION in md
    page = (tiny_report / "index.html").read_text()
    assert re.search(r'<img src="[^"]*" alt="([^"]*)"', page).group(1).startswith("summary")
    # the figure draws the record's residuals and marks each block's best law
    grid = residual_grid(tiny_results)
    assert grid.blocks == list(TINY.blocks)
    for j, key in enumerate(grid.blocks):
        ranking = tiny_results["blocks"][key]["ranking_lsq"]
        for row in ranking:
            assert grid.rms[grid.laws.index(row["model"]), j] == row["rms_complex"]
        assert grid.laws[grid.best[j]] == min(ranking, key=lambda r: r["aicc"])["model"]
    fig = plot_summary(tiny_results)
    np.testing.assert_array_equal(np.asarray(fig.axes[0].images[0].get_array()), grid.rms)
    rows = constant_rows(tiny_results)  # the fits' Appendix A checks are on the right
    assert rows and {r["core"] for r in rows} == {"permalloy"}
    assert len(fig.axes) == 2 + len({r["quantity"] for r in rows})
    # the top-level README shows the figure the report writes
    top = (REPO / "README.md").read_text(encoding="utf-8")
    assert _image_links(top)[0] == f"reports/{path}"


def test_html_nav_bar_links_resolve(tiny_report):
    page = (tiny_report / "index.html").read_text()
    nav = re.search(r'<nav class="sections"[^>]*>(.*?)</nav>', page, re.S)
    assert nav and page.index("<nav") < page.index("<h1")
    ids = set(re.findall(r'\sid="([^"]+)"', page))
    targets = re.findall(r'href="#([^"]+)"', nav.group(1))
    assert targets and set(targets) <= ids, set(targets) - ids
    labels = re.findall(r">([^<]+)</a>", nav.group(1))
    for label in ("Overview", "Summary", "B.1", "B.1+B.3", "Cross-impedance", "Limit cycles"):
        assert label in labels, label
    assert {"Audit", "Thesis graphs"} <= set(labels)
    assert set(re.findall(r'href="#([^"]+)"', page)) <= ids  # every in-page link resolves
    assert re.search(r"nav\.sections\{position:sticky;top:0", page)


def test_results_json_holds_rankings_and_settings(tiny_results):
    r = tiny_results
    assert (
        r["seed"] == 0 and r["fitdf_version"] and r["settings"]["models"] == ["proportional_width"]
    )
    assert r["timing"]["total_s"] > 0
    for key in TINY.blocks:
        rec = r["blocks"][key]
        assert rec["order_lsq"] == ["proportional_width"]
        row = rec["ranking_lsq"][0]
        for metric in (
            "rms_complex",
            "rms_magnitude",
            "rms_phase_deg",
            "redchi",
            "aicc",
            "bic",
            "cv_rms_complex",
        ):
            assert isinstance(row[metric], float), (key, metric)
        assert rec["ranking_posterior"][0]["looic"] is not None
        assert rec["ranking_posterior"][0]["log_evidence"] is not None
        post = rec["fits_posterior"]["proportional_width"]
        assert post["method"] == "nested"
        diag = post["diagnostics"]
        assert {
            "log_evidence",
            "log_evidence_error",
            "n_effective",
            "n_likelihood_evaluations",
            "converged",
        } <= set(diag)
        assert diag["n_likelihood_evaluations"] <= TINY.nested_max_evaluations
        # the prior, which decides the evidence, in physical units
        assert post["prior"]["r_series"]["distribution"].startswith("log-normal")
        assert post["prior"]["k"]["unit"] == "H" and len(post["prior"]["k"]["bounds"]) == 2
        assert rec["fits_lsq"]["proportional_width"]["parameters"]
        assert rec["data_summary"]["rows_used"] == len(
            rec["fits_lsq"]["proportional_width"]["rows"]["input_v"]
        )
    assert r["blocks"]["permalloy-joint"]["source_impedance_ohm"] == [0.0, 600.0]
    assert r["cross_impedance"][0]["rows"][0]["predict_rms_complex"] > 0
    lc = r["limit_cycles"]  # the real comparison (fitdf.limit_cycle_tables), on the tiny settings
    assert lc["available"] and "error" not in lc and lc["figure"]
    assert len(lc["rows"]) == 2 * 38 and {row["table"] for row in lc["rows"]} == {
        "B.1",
        "B.2",
        "B.3",
        "B.5",
    }
    assert {row["setting"] for row in lc["rows"]} == {"unscaled", "held_out"}
    assert all(0.1 < s["alpha"] < 100 for s in lc["attrs"]["scales"]["held_out"].values())
    assert r["findings"] and any("the best law by AICc is" in f for f in r["findings"])
    assert r["audit"]["tables"] and r["audit"]["findings"]


def test_markdown_sections(tiny_report, tiny_results):
    md = (tiny_report / "README.md").read_text()
    for heading in (
        "## Findings",
        "## Summary",
        "### Ranking",
        "### Parameters",
        "### Posteriors",
        "## Cross-impedance prediction",
        "## Limit cycles (Tables 5.1, 5.2)",
        "## Audit of the printed tables (Appendix B)",
        "## The thesis's computed curves (Graphs 4.1-4.7)",
    ):
        assert heading in md, heading
    assert f"seed {tiny_results['seed']}" in md and "run time" in md
    # every table row has as many cells as its header
    for block in re.findall(r"((?:^\|.*\|\n)+)", md, re.M):
        lines = block.strip().splitlines()
        width = len(re.split(r"(?<!\\)\|", lines[0]))
        assert all(len(re.split(r"(?<!\\)\|", ln)) == width for ln in lines), lines[0]
    # contents links resolve to headings (GitHub anchors)
    anchors = {render.slug(h) for h in re.findall(r"^#+ (.*)$", md, re.M)}
    for target in re.findall(r"\]\(#([^)]+)\)", md):
        assert target in anchors, target


def test_limit_cycle_sentences_are_made_from_the_record(tiny_results, tiny_report):
    """Every sentence of the limit-cycle section, recomputed from the fields of results.json,
    is the one the record holds and the report prints; the findings carry its finding."""
    lc = tiny_results["limit_cycles"]
    statements = lc["attrs"]["statements"]
    assert limit_cycle_statements(lc["attrs"]) == statements
    assert {"finding", "unscaled", "held_out", "critical", "confirmed", "not_confirmed"} <= set(
        statements
    )
    assert "time_domain_unscaled" in statements  # the report simulates the loop
    # the unscaled medians, recomputed from the rows themselves
    rows = [r for r in lc["rows"] if r["setting"] == "unscaled" and not r["dies_out"]]
    rows = [r for r in rows if r["amplitude_v"] is not None and r["omega_rad_s"] is not None]
    ratios = [r["omega_pred"] / r["omega_rad_s"] for r in rows if r["omega_pred"] is not None]
    median = f"puts the frequency at {np.median(ratios):.2f} of the measured one"
    assert median in statements["unscaled"]
    assert statements["finding"] in tiny_results["findings"]
    md = (tiny_report / "README.md").read_text()
    for name, text in statements.items():
        if name != "finding":
            assert text in md, name


def test_limit_cycle_section_switched_off_or_failing(monkeypatch, tmp_path):
    blocks = outline._limit_blocks({"limit_cycles": sections.limit_cycles_switched_off()})
    assert "switched off" in render._md(blocks)[2]

    def boom(**kwargs):
        raise RuntimeError("no convergence")

    monkeypatch.setattr(sections, "thesis_limit_cycle_comparison", boom)
    rec = sections.limit_cycle_section(0, ["constant_width"], 1, None, tmp_path)
    assert rec == {
        "available": True,
        "error": "RuntimeError: no convergence",
        "models_offered": ["constant_width"],
    }


def test_failed_run_leaves_the_old_report_intact(tmp_path, monkeypatch, stub_figures):
    out = tmp_path / "reports"
    out.mkdir()
    (out / "README.md").write_text("old report\n")
    (out / "figures").mkdir()
    (out / "figures" / "old.png").write_bytes(b"old")

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    real_render_html = render.render_html
    monkeypatch.setattr(
        render, "render_html", boom
    )  # fails after the fits, figures and results.json
    with pytest.raises(RuntimeError, match="disk full"):
        generate_report(out, progress=False, settings=MINI)
    assert (out / "README.md").read_text() == "old report\n"
    assert sorted(p.name for p in out.rglob("*")) == ["README.md", "figures", "old.png"]
    assert [p.name for p in tmp_path.iterdir()] == ["reports"]  # no temporary directory left

    monkeypatch.setattr(render, "render_html", real_render_html)
    generate_report(out, progress=False, settings=MINI)  # a good run replaces it whole
    assert not (out / "figures" / "old.png").exists()
    assert "fitdf comparison report" in (out / "README.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reports"]


def test_interrupted_swap_restores_the_old_report(tmp_path, monkeypatch):
    import fitdf.report.output as report

    out = tmp_path / "reports"
    out.mkdir()
    (out / "README.md").write_text("old report\n")
    new = tmp_path / "new"
    new.mkdir()
    real_replace = report.os.replace

    def flaky_replace(src, dst):
        if Path(src) == new:
            raise OSError("interrupted")
        return real_replace(src, dst)

    monkeypatch.setattr(report.os, "replace", flaky_replace)
    with pytest.raises(OSError):
        report.swap_in(new, out)
    assert (out / "README.md").read_text() == "old report\n"


@pytest.mark.slow  # 28 s: two reports; a fit and a chain repeat with a seed by default (test_fitting, test_mcmc)
def test_same_seed_same_numbers(tmp_path, stub_figures):
    # every random stage (the starts, the pilot rounds and chain, the CV folds), short:
    # the same seed must give the same numbers whatever the length of the chain (not
    # extended: past max_steps the report's default went on for ~8 s a run)
    settings = ReportSettings(
        models=("proportional_width",),
        blocks=("B.1",),
        n_starts=2,
        posterior_top=1,
        n_steps=20,
        max_steps=20,
        extend_steps=None,
        closed_form_step_factor=1,
        n_walkers=16,
        cv_top=1,
        cv_starts=1,
        cross=(),
        limit_cycles=False,
        workers=1,
    )
    a = generate_report(tmp_path / "a", seed=3, progress=False, settings=settings)
    b = generate_report(tmp_path / "b", seed=3, progress=False, settings=settings)
    ra, rb = (json.loads((p / "results.json").read_text()) for p in (a, b))
    assert _strip_timing(ra) == _strip_timing(rb)
    assert (a / "README.md").read_text().split("## Contents")[1] == (
        b / "README.md"
    ).read_text().split("## Contents")[1]


def test_quick_settings_keep_the_ranking_configuration():
    full, quick = ReportSettings.for_run(), ReportSettings.for_run(quick=True)
    assert quick.methods == ("lsq",) and quick.posterior_top == 0
    assert (quick.models, quick.blocks, quick.n_starts) == (full.models, full.blocks, full.n_starts)
    assert ReportSettings.for_run(methods=("lsq",)).posterior_top == 0
    for methods in (("posterior",), ("lsq", "mcmc")):  # least squares first; no sampler's name
        with pytest.raises(Exception, match="methods"):
            ReportSettings.for_run(methods=methods)


def test_closed_form_laws_get_longer_chains():
    s = ReportSettings.for_run()
    factor = s.closed_form_step_factor
    assert factor > 1
    assert s.step_limits("cubic_hc") == (factor * s.max_steps, factor * s.extend_steps)
    assert s.step_limits("constant_width") == (factor * s.max_steps, factor * s.extend_steps)
    # the laws integrated numerically or stepped keep the common limits
    for law in ("preisach", "rayleigh", "jiles_atherton"):
        assert s.step_limits(law) == (s.max_steps, s.extend_steps)
    no_extension = ReportSettings(extend_steps=None)
    assert no_extension.step_limits("cubic_hc") == (factor * s.max_steps, None)


@pytest.mark.slow
def test_pool_gives_the_serial_numbers(tmp_path):
    from dataclasses import replace

    settings = replace(TINY, blocks=("B.1", "B.3"), limit_cycles=False)
    serial = generate_report(tmp_path / "serial", progress=False, settings=settings)
    pooled = generate_report(
        tmp_path / "pooled", progress=False, settings=replace(settings, workers=2)
    )
    ra, rb = (json.loads((p / "results.json").read_text()) for p in (serial, pooled))
    assert _strip_timing(ra) == _strip_timing(rb)


def _committed_matching_the_code() -> dict:
    """The committed results.json, or a skip naming why it cannot be compared with this code."""
    committed = read_results(COMMITTED)
    settings = ReportSettings.for_run()
    made_with = (committed["settings"].get("chain", "winding"), committed["settings"]["models"])
    if made_with != (settings.chain, settings.model_list()):
        pytest.skip(
            f"reports/results.json was generated with chain {made_with[0]!r} and models "
            f"{made_with[1]}; this code fits {settings.model_list()} through {settings.chain!r}: "
            "regenerate it with `fitdf report`"
        )
    return committed


def _orders_agree(order_a, order_b, rms: dict, rtol=1e-6, aicc: dict | None = None) -> bool:
    """Same model order, except that models whose RMS residuals agree to ``rtol`` may swap,
    and, given ``aicc``, models the report itself calls indistinguishable (AICc within 2)."""
    if sorted(order_a) != sorted(order_b):
        return False
    for a, b in zip(order_a, order_b):
        if a == b or np.isclose(rms[a], rms[b], rtol=rtol, atol=0):
            continue
        if aicc is None or abs(aicc[a] - aicc[b]) >= 2:
            return False
    return True


def test_orders_agree_allows_only_ties_to_swap():
    rms = {"a": 1.0, "b": 1.0 + 1e-9, "c": 2.0}
    assert _orders_agree(["a", "b", "c"], ["b", "a", "c"], rms)
    assert not _orders_agree(["a", "c", "b"], ["a", "b", "c"], rms)
    assert not _orders_agree(["a", "b"], ["a", "c"], rms)
    assert _orders_agree(["a", "c", "b"], ["a", "b", "c"], rms, aicc={"a": 0, "b": 5, "c": 6.9})
    assert not _orders_agree(["a", "c", "b"], ["a", "b", "c"], rms, aicc={"a": 0, "b": 5, "c": 7})


@pytest.mark.slow
@pytest.mark.skipif(not COMMITTED.exists(), reason="no committed reports/results.json")
def test_quick_run_reproduces_the_committed_rankings(tmp_path):
    committed = _committed_matching_the_code()
    out = generate_report(tmp_path / "quick", seed=committed["seed"], quick=True, progress=False)
    fresh = json.loads((out / "results.json").read_text())
    assert set(fresh["blocks"]) == set(committed["blocks"]) == {b.key for b in BLOCKS}
    here = same_machine(committed["timing"].get("machine"), fresh["timing"]["machine"])
    for key, rec in committed["blocks"].items():
        rows = fresh["blocks"][key]["ranking_lsq"]
        rms = {row["model"]: row["rms_complex"] for row in rows}
        aicc = None if here else {row["model"]: row["aicc"] for row in rows}
        assert _orders_agree(fresh["blocks"][key]["order_lsq"], rec["order_lsq"], rms, aicc=aicc), (
            key
        )


@pytest.mark.slow
@pytest.mark.skipif(not COMMITTED.exists(), reason="no committed reports/results.json")
def test_quick_run_reproduces_committed_rankings_of_two_tables(tmp_path):
    """The fast (CI) version of the check above: the quick configuration on two tables.

    On the machine that made the committed report (same CPU, same libraries:
    ``timing.machine``) every RMS residual is reproduced to 1e-6. On another CPU NumPy's SIMD
    kernels and numba's code round a few last bits differently and the optimiser stops
    elsewhere in flat valleys: the same order and every model's AICc within 2 of the committed
    one, the report's own rule for fits the data cannot tell apart. (AMD EPYC against the
    committed report's machine: RMS up to 1.7e-3 relative, AICc up to 2.0, cubic_hc on B.4
    finding a slightly better basin.)"""
    from dataclasses import replace

    committed = _committed_matching_the_code()
    settings = replace(
        ReportSettings.for_run(quick=True),
        blocks=("B.1", "B.4"),
        limit_cycles=False,
        cross=(),
        workers=2,
    )
    out = generate_report(
        tmp_path / "quick2", seed=committed["seed"], progress=False, settings=settings
    )
    fresh = json.loads((out / "results.json").read_text())
    assert fresh["timing"]["machine"] == machine_record()
    here = same_machine(committed["timing"].get("machine"), fresh["timing"]["machine"])
    assert set(fresh["blocks"]) == {"B.1", "B.4"}
    for key, rec in fresh["blocks"].items():
        rows = {row["model"]: row for row in rec["ranking_lsq"]}
        before = {row["model"]: row for row in committed["blocks"][key]["ranking_lsq"]}
        assert rows.keys() == before.keys(), key
        rms = {m: row["rms_complex"] for m, row in rows.items()}
        aicc = None if here else {m: row["aicc"] for m, row in rows.items()}
        assert _orders_agree(
            rec["order_lsq"], committed["blocks"][key]["order_lsq"], rms, aicc=aicc
        ), key
        for model, row in rows.items():
            if here:  # same numbers, not just the same order
                assert row["rms_complex"] == pytest.approx(
                    before[model]["rms_complex"], rel=1e-6
                ), (key, model)
            else:
                assert abs(row["aicc"] - before[model]["aicc"]) < 2, (key, model)
                assert row["rms_complex"] == pytest.approx(
                    before[model]["rms_complex"], rel=5e-3
                ), (key, model)


def test_approximate_chain_refit_starts_at_the_exact_optimum():
    from fitdf.inference.api import fit
    from fitdf.inference.lsq import fit_lsq
    from fitdf.inference.problem import FitProblem
    from fitdf.report.jobs import job_approx

    exact = fit("B.1", "constant_width", n_starts=1)
    approx = job_approx(exact, 0, "winding")
    assert approx.chain == "winding" and approx.problem.names == exact.problem.names
    assert approx.info["n_starts"] == 2  # the exact optimum and the screen's best point
    p = exact.problem
    alone = fit_lsq(
        FitProblem(p.data, p.model, "winding", p.noise, p.fixed, p.geometry),
        seed=0,
        starts=exact.internal,
    )
    # (polished in a batch of two starts, not alone: on some CPUs the batch's rounding moves
    # where the optimiser stops by ~2e-9 relative, AMD EPYC here; a polish from any other
    # start ends elsewhere by far more)
    assert approx.info["starts_chi2"][0] == pytest.approx(alone.info["starts_chi2"][0], rel=1e-7)
    assert approx.metrics["chi2"] <= alone.metrics["chi2"] * (1 + 1e-7)
    # --quick: the exact optimum only, which is that polish exactly
    assert ReportSettings.for_run(quick=True).approximate_screen == 0
    assert ReportSettings.for_run().approximate_screen == 1
    nearest = job_approx(exact, 0, "winding", 0)
    assert nearest.info["n_starts"] == 1
    assert nearest.metrics["chi2"] == alone.metrics["chi2"]


def test_settings_line_states_the_posteriors_and_cv_that_ran():
    # the committed report's own settings: nested sampling with its live points, evaluation
    # limit and rule, on the core blocks; folds polished from the optimum (cv_starts None)
    settings = read_results(COMMITTED)["settings"]
    (kind, items), *_ = outline._settings_text(
        {"settings": settings, "timing": {}, "fitdf_version": "x", "seed": 0}
    )
    line = next(i for i in items if i.startswith("least squares"))
    assert "None" not in line
    assert settings["sampler"] == "nested"
    assert (
        f"by nested sampling (nautilus, {settings['nested_live']} live points, "
        f"{outline._networks(settings.get('nested_networks', 4))} per bound, up to "
        f"{settings['nested_max_evaluations']:,} likelihood evaluations; converged at 400 "
        "effective draws and an evidence error of at most 0.3) for the best "
        f"{settings['posterior_top']} least-squares models of "
        + (", ".join(settings["posterior_blocks"] or ()) or "each block")
    ) in line
    if settings.get("sensitivity_top"):
        assert (
            "the evidence again with the prior box halved and doubled for the best "
            f"{settings['sensitivity_top']} of each block"
        ) in line
    # the default run's: the posteriors on the core blocks
    default = {**settings, "posterior_blocks": ["B.4", "permalloy-joint"], "sensitivity_top": 0}
    (_, items), *_ = outline._settings_text(
        {"settings": default, "timing": {}, "fitdf_version": "x", "seed": 0}
    )
    line = next(i for i in items if i.startswith("least squares"))
    assert "least-squares models of B.4, permalloy-joint;" in line and "halved" not in line
    assert "each fold polished from the block's optimum" in line
    # a report sampled by emcee: its step limits
    emcee = {**settings, "sampler": "emcee"}
    (_, items), *_ = outline._settings_text(
        {"settings": emcee, "timing": {}, "fitdf_version": "x", "seed": 0}
    )
    line = next(i for i in items if i.startswith("least squares"))
    assert (
        f"up to {settings['max_steps']}" in line
        and f"{settings['extend_steps']} for a chain" in line
    )
    assert (
        f"; {settings['closed_form_step_factor']} times as many for the laws in closed form" in line
    )
    quick = {**settings, "methods": ["lsq"], "cv_starts": 2, "extend_steps": None}
    (_, items), *_ = outline._settings_text(
        {"settings": quick, "timing": {}, "fitdf_version": "x", "seed": 0}
    )
    line = next(i for i in items if i.startswith("least squares"))
    assert "no posterior sampling" in line and "2 starts per fold" in line


def test_settings_line_names_the_laws_with_more_starts():
    settings = read_results(COMMITTED)["settings"]
    models = [{"name": "cubic_hc", "start_multiple": 4}, {"name": "rayleigh", "start_multiple": 1}]
    res = {"settings": settings, "timing": {}, "fitdf_version": "x", "seed": 0, "models": models}
    (_, items), *_ = outline._settings_text(res)
    line = next(i for i in items if i.startswith("least squares"))
    n = settings["n_starts"]
    assert f"{n} starts for every model and block ({4 * n} for `cubic_hc`" in line
    assert "rayleigh" not in line
    (_, items), *_ = outline._settings_text({**res, "models": models[1:]})
    assert "(" not in next(i for i in items if i.startswith("least squares")).split(";")[0]


# ------------------------------------------------------------------ what the report says


def _findings_section(md: str) -> tuple[str, list[str]]:
    """The conclusion (the section's first paragraph) and the statements of "Findings"."""
    body = md.split("## Findings\n\n", 1)[1].split("\n## ", 1)[0]
    paragraphs = body.split("\n\n")
    return paragraphs[0], [ln[2:] for ln in body.splitlines() if ln.startswith("- ")]


def _sentences(text: str) -> list[str]:
    return [s for s in re.split(r"(?<=[.])\s+(?=[A-Z0-9`])", text.strip()) if s]


#: Words of a development history, not of a report (a "pass" of work, an issue number).
_HISTORY = re.compile(r"\bpass(es|ed)?\b|#\d+|\bissues?\b|\bitem \d|\bPR\b", re.I)


def _lowest(rows, column, larger=False):
    """The model of ``rows`` with the lowest (``larger``: highest) known ``column``."""
    known = [r for r in rows if r.get(column) is not None]
    pick = max if larger else min
    return pick(known, key=lambda r: r[column])["model"] if known else None


@pytest.mark.skipif(not COMMITTED.exists(), reason="no committed reports/results.json")
def test_findings_open_with_a_conclusion_from_the_numbers():
    """The committed report re-rendered from its results.json (no refit): "Findings" opens
    with a short conclusion whose every number comes from the record, each criterion it
    names answered by that criterion's numbers (computed here from the rankings)."""
    res = read_results(COMMITTED)
    md = render.render_markdown(res)
    text, statements = _findings_section(md)
    assert 3 <= len(_sentences(text)) <= 6, _sentences(text)
    names = {m["name"]: f"{m['title']} `{m['name']}`" for m in res["models"]}
    blocks = res["blocks"].values()
    # which law to use: each block's lowest AICc, named as a person would
    best = {rec["key"]: _lowest(rec["ranking_lsq"], "aicc") for rec in blocks}
    if len(set(best.values())) == 1:
        (w,) = set(best.values())
        assert text.startswith(f"Use {names[w]} for all 3 cores: it has the lowest AICc")
    # the error to expect: the best law's RMS complex residual over the RMS measured |DF|
    for rec in blocks:
        row = next(r for r in rec["ranking_lsq"] if r["model"] == best[rec["key"]])
        df = np.asarray(rec["fits_lsq"][row["model"]]["rows"]["df_measured"], float)
        pct = 100 * row["rms_complex"] / np.sqrt(np.mean(df**2))
        assert f"{pct:.1f} %" in text, (rec["key"], pct)
    # what the data cannot decide: each criterion's ties by its own numbers
    ties = next(s for s in _sentences(text) if s.startswith("By AICc"))
    for rec in blocks:
        post = rec["ranking_posterior"]
        loo_best = _lowest(post, "looic")
        for r in post:
            d, se = r.get("elpd_loo_diff"), r.get("elpd_loo_dse")
            if r["model"] != loo_best and d is not None and abs(d) < 2 * se:
                assert f"`{r['model']}` on {rec['key']} (elpd apart by {d:.1f}" in ties
        ev_best = _lowest(post, "log_evidence", larger=True)
        top = max((r["log_evidence"] for r in post if r.get("log_evidence")), default=None)
        for r in post:
            if r["model"] != ev_best and r.get("log_evidence") is not None:
                if 2 * (top - r["log_evidence"]) < 2:
                    assert f"`{r['model']}` on" in ties.split("; by LOO-IC")[0]
    chains = [
        f["diagnostics"]["converged"] for rec in blocks for f in rec["fits_posterior"].values()
    ]
    if all(chains):
        assert f"All {len(chains)} posteriors converged." in text
    else:
        assert f"{chains.count(False)} of {len(chains)} posteriors did not converge" in text
    checks = [c for rec in blocks for c in rec["fits_lsq"][best[rec["key"]]]["appendix_a_check"]]
    outside = sum(not c["inside"] for c in checks)
    assert f"{outside} of the {len(checks)} material constants of the best fits lie outside" in text
    assert "trade against the series resistance" in text and "iron fraction" in text
    # the statements below do not repeat the winners' list, and name laws by title and code
    assert not any(s.startswith("Best model per block") for s in statements)
    first = res["blocks"]["B.1"]
    assert statements[0].startswith(
        f"**{first['title']}**: the best law by AICc is {names[best['B.1']]}"
    )
    assert not _HISTORY.search(text + " ".join(statements))


def test_the_tiny_report_concludes_and_names_its_law(tiny_report, tiny_results):
    md = (tiny_report / "README.md").read_text()
    text, statements = _findings_section(md)
    title = tiny_results["models"][0]["title"]
    label = f"{title} `proportional_width`"
    assert text.startswith(f"Only {label} was fitted here, to Permalloy")
    assert 3 <= len(_sentences(text)) <= 6
    assert "All 2 posteriors converged." in text  # nested sampling meets its rule here
    # laws named by title and code name in the tables and headings too
    assert f"| {label} |" in md  # the summary and ranking tables
    assert f"**{label}** (least squares, the best by AICc):" in md
    assert f"**{label}** (nested sampling, the best by the evidence):" in md
    # every caption and statement is about the results, not about how the code was made
    assert not _HISTORY.search(md)
    for caption in (
        CAPTION,
        outline.CROSS_CAPTION,
        block_outline.FIT_CAPTION,
        block_outline.LOCI_CAPTION,
        block_outline.RESIDUALS_CAPTION,
        block_outline.CORNER_CAPTION,
    ):
        assert md.count(caption) >= 1, caption


def test_the_plan_of_a_run_counts_the_jobs_and_figures_it_made(tiny_report, tiny_results):
    """What the opening lines announce and the progress display plans is what the run did:
    as many jobs of each kind, as many figures."""
    models, blocks = TINY.model_list(), [b.key for b in TINY.block_list()]
    lsq = [(b, m) for b in blocks for m in models]
    phases, what = costs.plan(TINY, models, blocks, lsq, {}, costs.phase_labels(TINY))
    planned = Counter(kind for p in phases for kind, _ in p.planned)
    ran = Counter(costs.job_kind(k) for k in tiny_results["timing"]["jobs_s"])
    assert planned == ran and ran["nested"] == 2 and ran["figures"] == 4
    pngs = list((tiny_report / "figures").rglob("*.png"))
    assert what[-1] == f"up to {len(pngs)} figures"  # every block's best law was sampled


def test_a_wider_box_whose_run_missed_the_posterior_is_flagged_not_reported():
    """The sensitivity table marks a doubled box whose own run fell below the least evidence
    the box allows, as ``prior_sensitivity`` states it (``consistent``), and shows it as not
    converged; the evidence shown is the stratified one."""

    def fit(boxes, n_params=4):
        return {
            "diagnostics": {
                "n_likelihood_evaluations": 1000,
                "n_effective": 500.0,
                "log_evidence": 100.0,
                "log_evidence_error": 0.04,
                "converged": True,
                "prior_sensitivity": {"boxes": boxes},
            },
            "metrics": {"n_params": n_params},
        }

    def text(fits):
        return json.dumps(block_outline._nested_blocks({}, fits, {}))

    good = {"factor": 2.0, "log_evidence": 97.5, "log_evidence_error": 0.05, "shift": -2.5,
            "shift_error": 0.05, "converged": True, "estimate": "widened", "consistent": True,
            "lower_bound": 97.23, "sampled_log_evidence": 97.4}  # fmt: skip
    missed = {**good, "log_evidence": 97.23, "shift": -2.77, "consistent": False,
              "converged": False, "sampled_log_evidence": 80.0}  # fmt: skip
    assert "Missed" not in text({"a": fit([good])})
    out = text({"a": fit([missed])})
    assert "Missed: `a`, box width 2: its run's ln evidence 80" in out and "97.23" in out
    assert "the stratified estimate" in out
    table = block_outline._nested_blocks({}, {"a": fit([missed])}, {})
    (rows,) = [b[2] for b in table if b[0] == "table" and b[1][0] == "law" and "box width" in b[1]]
    assert rows[0][-1] == "no"  # not converged
    halved = {"factor": 0.5, "log_evidence": 102.0, "log_evidence_error": 0.05, "shift": 2.0,
              "converged": True, "estimate": "restricted"}  # fmt: skip
    assert "Missed" not in text({"a": fit([halved])})


def test_each_run_of_the_command_is_named_with_its_seed():
    """A report says the command that makes it again: the run of ``fitdf report`` whose
    settings it has, with ``--compare-chain`` and the seed when not the default; none for
    settings no option gives."""
    from dataclasses import replace

    from fitdf.report.settings import run_record

    for quick, full, command in (
        (True, False, "fitdf report --quick"),
        (False, False, "fitdf report"),
        (False, True, "fitdf report --full"),
    ):
        settings = ReportSettings.for_run(quick, full=full)
        assert run_record(settings, 0)["command"] == command
        assert run_record(settings, 7)["command"] == command + " --seed 7"
        # workers and the scheduler change no number: the same run
        assert run_record(replace(settings, workers=1), 0)["command"] == command
    chain = ReportSettings.for_run(full=True, compare_chain="winding")
    assert run_record(chain, 3) == {
        "run": "full",
        "command": "fitdf report --full --compare-chain winding --seed 3",
    }
    assert run_record(TINY, 0) == {"run": None, "command": None}
    assert run_record(replace(ReportSettings.for_run(), n_starts=7), 0)["command"] is None
    assert run_record(ReportSettings.for_run(methods=("lsq",)), 0)["command"] is None


def test_a_report_describes_the_methods_it_ran(tiny_report, tiny_results):
    """The opening says which methods ran: posteriors only when some were sampled, and by
    which sampler; a report made by settings of its own says so where it says how to
    regenerate it."""
    from fitdf.report.claims import claim

    md = (tiny_report / "README.md").read_text()
    intro = md.split("\n\n")[1]
    n_post = sum(len(b["fits_posterior"]) for b in tiny_results["blocks"].values())
    assert n_post == 2
    assert "by least squares, with the posteriors of 2 of the fits by nested sampling" in intro
    assert "predict across source impedance" in intro and "limit cycles" in intro
    assert "Generated by `fitdf.report.generate_report` with settings of its own" in intro
    assert "made with settings of its own (`settings` in `results.json`)" in md
    assert "regenerate with `fitdf report`" not in md
    # a quick report: no posterior, so no word of one; its command
    quick = {
        **tiny_results,
        "run": {"run": "quick", "command": "fitdf report --quick"},
        "blocks": {k: {**b, "fits_posterior": {}} for k, b in tiny_results["blocks"].items()},
        "cross_impedance": [],
        "limit_cycles": {"available": False},
    }
    said = claim("report.intro", quick)["text"]
    assert "posterior" not in said and "sampling" not in said and "predict" not in said
    assert said.endswith(
        "by least squares, ranked. Generated by `fitdf report --quick`; do not edit."
    )
    again = claim("report.regenerate", quick)["text"]
    assert again.startswith("regenerate with `fitdf report --quick` (same seed")
