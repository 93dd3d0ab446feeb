"""The numbers the documents state are the code's.

The Sphinx pages write a threshold, a prior's constant or a default through the ``:value:``
role (docs/_ext/fitdf_values.py), so the build writes the code's value: every such
reference must name a value. The Markdown documents (README.md, benchmarks/README.md,
datasets/README.md) and the few numbers the pages keep as text cannot be generated: each is
read here and compared with its source in the code, the committed report or the
benchmarks' measurements, so a changed constant fails here until the text follows.
"""

from __future__ import annotations

import inspect
import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

import fitdf_values  # noqa: E402  (docs/_ext: the role without Sphinx)


def text(path) -> str:
    """The document at ``path`` (relative to the repository), its whitespace runs as one space."""
    return " ".join((REPO / path).read_text(encoding="utf-8").split())


def number(value) -> str:
    """A constant as the documents write it: ``2`` for 2.0, ``0.3``, ``400``."""
    return f"{value:g}"


def section(markdown: str, heading: str) -> str:
    """The text of the ``## heading`` section of a Markdown file (to the next ``## ``)."""
    body = markdown.split(f"## {heading}", 1)[1]
    return body.split("\n## ", 1)[0]


def seconds(figure: str) -> tuple[float, float]:
    """A stated time (``41 s``, ``3 min 30 s``, ``69 min``, ``4156 s (69 min)``) in seconds,
    and half the unit of its last figure (what rounding to it allows)."""
    m = re.match(r"\s*(?:(\d+) h)?\s*(?:(\d+) min)?\s*(?:([\d.]+) s)?", figure)
    h, mins, s = (float(g) if g else 0.0 for g in m.groups())
    if not any(m.groups()):
        raise ValueError(f"no time in {figure!r}")
    total = 3600 * h + 60 * mins + s
    if m.group(3):
        half = (
            5.0
            if (m.group(2) and s % 10 == 0)
            else 0.5 * 10 ** -len((m.group(3).split(".") + [""])[1])
        )
    else:
        half = 30.0
    return total, half


# ------------------------------------------------------------------ the :value: role
def test_the_value_role_writes_the_codes_constants():
    from fitdf.data.cores import MATERIAL_LIMITS, STACKING_FACTOR_RANGE
    from fitdf.inference import nested

    assert fitdf_values.render("fitdf.inference.nested.MIN_EFFECTIVE") == str(nested.MIN_EFFECTIVE)
    assert fitdf_values.render("fitdf.inference.nested.MAX_LOG_EVIDENCE_ERROR") == number(
        nested.MAX_LOG_EVIDENCE_ERROR
    )
    assert fitdf_values.render("fitdf.data.cores.STACKING_FACTOR_RANGE[1]:.2f") == (
        f"{STACKING_FACTOR_RANGE[1]:.2f}"
    )
    default = inspect.signature(nested.fit_nested).parameters["max_evaluations"].default
    assert fitdf_values.render("fitdf.inference.nested.fit_nested(max_evaluations):,") == (
        f"{default:,}"
    )
    assert fitdf_values.render("fitdf.data.cores.MATERIAL_LIMITS[inductance][3]:short") == "3e6"
    assert MATERIAL_LIMITS["inductance"][3] == 3e6
    assert fitdf_values.render("fitdf.data.cores.MATERIAL_LIMITS[current][1]:short") == "1e-3"
    assert fitdf_values.render("fitdf.data.cores.MATERIAL_LIMITS[flux_linkage][3]:short") == "2.5"
    assert fitdf_values.render("fitdf.limit_cycle_tables.summary.LEVEL_CONFIDENCE:.0%") == "95 %"


@pytest.mark.parametrize(
    "target",
    [
        "fitdf.inference.nested.NO_SUCH_CONSTANT",
        "fitdf.no_such_module.X",
        "fitdf.inference.nested.fit_nested(no_such_parameter)",
        "fitdf.inference.nested.fit_nested(problem)",  # a parameter without a default
        "fitdf.data.cores.STACKING_FACTOR_RANGE[2]",
        "fitdf.data.cores.MATERIAL_LIMITS[no_such_quantity]",
        "not a reference",
    ],
)
def test_the_value_role_refuses_a_name_that_names_no_value(target):
    with pytest.raises(ValueError):
        fitdf_values.render(target)


def test_every_value_the_pages_write_names_a_value_of_the_code():
    """Every ``:value:`` of docs/ resolves (a renamed or moved constant fails here, as it
    fails the ``-W`` build), and the pages write the rules' thresholds through it."""
    refs = []
    for page in sorted(DOCS.rglob("*.rst")):
        refs += [(page, r) for r in re.findall(r":value:`([^`]+)`", page.read_text("utf-8"))]
    for page, ref in refs:
        assert fitdf_values.render(ref), (page, ref)
    written = {ref.split(":")[0] for _, ref in refs}
    for constant in (
        "fitdf.inference.convergence.MIN_EFFECTIVE",
        "fitdf.inference.convergence.MAX_LOG_EVIDENCE_ERROR",
        "fitdf.inference.nested.fit_nested(max_evaluations)",
        "fitdf.inference.nested.DEFAULT_LIVE",
        "fitdf.inference.convergence.RHAT_MAX",
        "fitdf.inference.convergence.MIN_ESS",
        "fitdf.inference.convergence.MIN_STEPS_OVER_TAU",
        "fitdf.inference.selection.TIE_AICC",
        "fitdf.inference.selection.TIE_TWO_LN_B",
        "fitdf.inference.selection.TIE_LOO_SE",
        "fitdf.inference.selection.ROWS_RULE",
        "fitdf.inference.evidence.MISSED_BY_ERRORS",
        "fitdf.chains.series_resistance.SOURCE_AND_LEADS_OHM",
        "fitdf.chains.series_resistance.R_SERIES_PRIOR_SIGMA",
        "fitdf.data.cores.STACKING_FACTOR_RANGE[0]",
        "fitdf.data.cores.STACKING_FACTOR",
        "fitdf.jobcache.STALE_DAYS",
    ):
        assert constant in written, constant


# ------------------------------------------------------------------ README.md
def test_the_readme_states_the_rows_laws_rule_and_tie_of_the_code():
    import fitdf.models
    from fitdf.data.resolve import resolve_data
    from fitdf.inference.selection import ROWS_RULE, TIE_AICC

    readme = text("README.md")
    laws, rows = map(
        int,
        re.search(
            r"`fitdf fit permalloy --method lsq` \| (\d+) laws on (\d+) rows", readme
        ).groups(),
    )
    assert laws == len(fitdf.models.MODELS)
    assert rows == resolve_data("permalloy").n  # the rows the default row policy fits
    assert f"(AICc within {number(TIE_AICC)})" in readme
    assert ROWS_RULE in readme


def test_the_readme_names_the_job_cache_the_code_uses(monkeypatch, tmp_path):
    from fitdf.jobcache import default_cache_folder

    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    folder = "~/" + default_cache_folder().relative_to(tmp_path).as_posix()
    assert f"kept in `{folder}`" in text("README.md")


def test_the_readme_builds_the_docs_as_ci_does():
    """The README's docs command treats warnings as errors, as .ci/run's build does."""
    command = re.search(r"python -m sphinx ([^`]*)`", text("README.md")).group(1).split()
    ci = re.search(r"^python -m sphinx (.*)$", (REPO / ".ci" / "run").read_text(), re.M)
    ci_flags = {w for w in ci.group(1).split() if w.startswith("-") and w != "-q"}
    assert ci_flags == {"-W", "--keep-going", "-b"} and ci_flags <= set(command)
    assert command[-2:] == ["docs", "docs/_build/html"]


def _command_times() -> dict:
    """benchmarks/README.md's measured commands: ``{command: wall figure}``."""
    bench = (REPO / "benchmarks" / "README.md").read_text(encoding="utf-8")
    rows = re.findall(
        r"^\| `[\w-]+` \| [^`|]*`([^`]+)`[^|]* \| ([^|]+) \| [^|]+ \|$",
        section(bench, "`bench_commands.py`: the user's commands"),
        flags=re.M,
    )
    return {cmd: wall for cmd, wall in rows}


def test_the_readmes_times_are_the_benchmarks_measurements():
    """A time is measured once (benchmarks/README.md, bench_commands.py); the README's table
    states it rounded."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    table = re.findall(
        r"^\| `((?:fitdf|python) [^`]+)` \| [^|]+ \| ([^|]+) \|$", section(readme, "Set up"), re.M
    )
    measured = _command_times()
    assert len(table) == 5 and len(measured) >= 6
    for command, figure in table:
        assert command in measured, command
        stated, half = seconds(figure)
        if figure.strip().endswith("planned"):  # not measured yet: the report's own plan
            wall = _planned_seconds(command)
        else:
            wall, _ = seconds(measured[command])
        assert abs(stated - wall) <= half + 1e-9, (command, figure, measured[command])


def _planned_seconds(command: str) -> float:
    """What ``fitdf report`` plans for a run at the committed machine's speed on 2 workers
    (fitdf.report.costs), the run named by its command."""
    from fitdf.report import costs
    from fitdf.report.build import printed_blocks
    from fitdf.report.settings import RUNS, ReportSettings

    run = {f"fitdf report {option}".strip(): name for name, option in RUNS.items()}[command]
    settings = ReportSettings.for_run(quick=run == "quick", full=run == "full")
    models, blocks = settings.model_list(), settings.block_list()
    keys = [b.key for b in blocks]
    folds = dict.fromkeys(keys, 4)  # folds do not change the plan's seconds
    phases, _ = costs.plan(
        settings,
        models,
        keys,
        [(b, m) for b in keys for m in models],
        folds,
        costs.phase_labels(settings),
        [b.key for b in printed_blocks(blocks)],
    )
    return costs.estimate(phases, 2)


def test_the_full_reports_time_is_the_committed_reports_own():
    """``fitdf report --full`` makes the committed report: its time in the benchmarks and
    the README is the one its results.json records."""
    results = json.loads((REPO / "reports" / "results.json").read_text(encoding="utf-8"))
    total = results["timing"]["total_s"]
    wall, half = seconds(_command_times()["fitdf report --full"])
    assert abs(wall - total) <= half
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    figure = re.search(r"^\| `fitdf report --full` \| [^|]+ \| ([^|]+) \|$", readme, re.M)
    stated, half = seconds(figure.group(1))
    assert abs(stated - total) <= half


# ------------------------------------------------------------------ benchmarks/README.md
def test_the_benchmarks_state_the_samplers_rules_and_settings():
    from fitdf.inference import mcmc, nested
    from fitdf.report.settings import ReportSettings

    bench = text("benchmarks/README.md")
    assert (
        f"until fitdf's convergence rule ({nested.MIN_EFFECTIVE} effective draws, Kish, and a "
        f"log-evidence error of at most {number(nested.MAX_LOG_EVIDENCE_ERROR)})" in bench
    )
    words = {1: "one", 2: "two", 4: "four"}
    assert (
        f"**The choice: nautilus, {nested.DEFAULT_LIVE} live points, "
        f"{words[nested.DEFAULT_NETWORKS]} network per bound**" in bench
    )
    assert f"**The batch: {nested.DEFAULT_BATCH} points a call**" in bench
    cap = re.search(r"stopped at the ([\d,]+) cap", bench) or re.search(
        r"stopped at ([\d,]+)\)", bench
    )
    default = inspect.signature(nested.fit_nested).parameters["max_evaluations"].default
    assert int(cap.group(1).replace(",", "")) == default
    # the emcee report's rule and limits (its settings, ReportSettings' own)
    s = ReportSettings()
    factor = {3: "three"}[s.closed_form_step_factor]
    assert (
        f"R-hat < {number(mcmc.RHAT_MAX)}, bulk ESS >= {mcmc.MIN_ESS}, "
        f"{mcmc.MIN_STEPS_OVER_TAU} autocorrelation times; {s.max_steps} steps, "
        f"{s.extend_steps} for a chain on course, {factor} times both for the laws in closed "
        "form" in bench
    )


def test_the_benchmarks_count_the_rows_and_laws_they_time():
    import fitdf.models
    from fitdf.data.resolve import resolve_data

    bench = text("benchmarks/README.md")
    assert (
        f"`fitdf fit permalloy --method lsq` ({len(fitdf.models.MODELS)} laws, cross-validated"
        in bench
    )
    assert f"on the {resolve_data('permalloy').n} rows of Tables B.1 + B.3" in bench
    assert f"Table B.4's {resolve_data('B.4').n} rows" in bench


# ------------------------------------------------------------------ datasets/README.md
def test_the_datasets_readme_states_the_audits_thresholds():
    from fitdf.data import audit_rules as r

    readme = text("datasets/README.md")
    for phrase in (
        f"(a step > {number(r.STEP_OUTLIER)}x the block's median step)",
        f"a DF off its curve (by > {number(r.MAG_NOISE)}, ~3 sigma)",
        f"comes within {number(r.MAG_SPIKE)} (DF) or {number(r.PHASE_SPIKE)} degrees",
        f"reversed it is {number(r.REVERSAL_RATIO)} times nearer its prediction than printed "
        f"({number(r.REVERSAL_RATIO_HIGHEST)} times at the table's highest frequency",
        f"half the spike thresholds of (5) ({number(r.REVERSAL_MARGIN['phase_lead_deg'])} deg, "
        f"{number(r.REVERSAL_MARGIN['df_reported'])} in DF",
        f"(at least {r.MIN_OVERLAP} points each)",
        f"At least {r.MIN_NEIGHBOURS} comparable neighbours are needed",
        f"a column spanning at most {number(r.FLAT_RANGE['phase_lead_deg'])} deg "
        f"({number(r.FLAT_RANGE['df_reported'])} in DF), "
        f"{number(r.FLAT_RANGE['phase_lead_deg'] / r.PHASE_SPIKE)}x the spike thresholds",
        f"when {r.INPUT_REVERSED_COLUMNS} or more columns of a block are flagged",
    ):
        assert phrase in readme, phrase


@pytest.mark.parametrize("path", ["datasets/README.md", "docs/method/audit.rst"])
def test_the_row_policies_keep_the_rows_the_documents_count(path):
    import fitdf.datasets
    from fitdf.data.audit import DEFAULT_POLICY, POLICIES, select_rows

    rows = fitdf.datasets.load("appendix_b")
    kept = {p: len(select_rows(rows, p)) for p in POLICIES}
    doc = (REPO / path).read_text(encoding="utf-8")
    if path.endswith(".md"):
        assert (
            f"`POLICIES = {POLICIES!r}`".replace("'", '"') in doc and DEFAULT_POLICY == POLICIES[0]
        )
        stated = dict(re.findall(r'^\| `"(\w+)"`(?: \(default\))? \| [^|]+ \| (\d+)', doc, re.M))
    else:
        table = doc.split("The row policies", 1)[1]
        stated = {
            row.split("``")[0]: re.findall(r"\n     - (\d+)", row)[-1]
            for row in table.split("   * - ``")[1:]
        }
    assert {p: int(n) for p, n in stated.items()} == kept


# ------------------------------------------------------------------ numbers the pages keep
def test_the_kass_raftery_scale_the_pages_state_is_the_rankings():
    """docs/method/ranking.rst and the user guide state the scale's steps on ``2 ln B``."""
    from fitdf.inference.ranking import bayes_factor_scale
    from fitdf.inference.selection import TIE_TWO_LN_B

    for path in ("docs/method/ranking.rst", "docs/user-guide/report.rst"):
        doc = text(path)
        steps = re.search(
            r"from there to (\d+)\W+positive\W+(\d+)-(\d+)\W+strong\W+above (\d+)", doc
        )
        assert steps, path
        six, six_again, ten, ten_again = map(float, steps.groups())
        assert six == six_again and ten == ten_again
        for two_ln_b, verdict in (
            (TIE_TWO_LN_B - 0.01, "not worth more than a bare mention"),
            (TIE_TWO_LN_B + 0.01, "positive"),
            (six - 0.01, "positive"),
            (six + 0.01, "strong"),
            (ten - 0.01, "strong"),
            (ten + 0.01, "very strong"),
        ):
            assert bayes_factor_scale(two_ln_b / 2) == verdict, (path, two_ln_b)


def test_the_noise_priors_the_inference_page_states_are_the_codes():
    from fitdf.inference.noise import NOISE_BOUNDS, NOISE_RANGES

    # the page writes the four bounds from the code, and the samplers' box is those bounds
    page = text("docs/method/inference.rst")
    for i in range(2):
        for j in range(2):
            assert f":value:`fitdf.inference.noise.NOISE_RANGES[{i}][{j}]`" in page
    assert np.allclose(10.0**NOISE_BOUNDS, NOISE_RANGES, rtol=1e-12)


def test_the_command_line_defaults_the_inference_page_states_are_the_parsers():
    from fitdf.cli import build_parser

    args = build_parser().parse_args(["fit", "B.1"])
    doc = text("docs/method/inference.rst")
    assert f"(``fitdf fit --steps``, default {args.steps})" in doc
    assert f"(``fitdf fit --max-steps``, default {args.max_steps})" in doc


def test_the_reports_posterior_counts_the_pages_state_are_its_settings():
    from fitdf.report.settings import BLOCKS, CORE_BLOCKS, ReportSettings

    default, full = ReportSettings.for_run(), ReportSettings.for_run(full=True)
    top = default.posterior_top
    full_top = full.posterior_top
    blocks = default.posterior_blocks
    assert tuple(blocks) == tuple(CORE_BLOCKS) and full.posterior_blocks is None
    words = {1: "one", 2: "two", 3: "three", 4: "four", 6: "six"}
    cluster = text("docs/user-guide/cluster.rst")
    assert top == 2 and default.posterior_runner_up_below is not None
    assert f"``fitdf report`` samples {words[len(CORE_BLOCKS)]} posteriors, the best" in cluster
    # the runners-up within the gap on the committed report's fits, as the plan takes them
    from fitdf.report.costs import planned_posteriors

    planned = [len(planned_posteriors(default, default.model_list(), b)) for b in CORE_BLOCKS]
    assert (
        f"(on the committed report's fits, {words[sum(planned) - len(planned)]}: "
        f"{words[sum(planned)]} in all)"
    ) in cluster
    assert f"``fitdf report --full`` samples {full_top * len(BLOCKS)}," in cluster
    guide = text("docs/user-guide/report.rst")
    assert (
        f"``fitdf report --full`` samples the {words[full_top]} best laws of every block and "
        "measures how the evidence depends on the prior (the box halved and doubled) for the "
        f"{words[full.sensitivity_top]} best" in guide
    )
    assert "of the best law of each core" in guide and "and of its runner-up only" in guide
    readme = text("README.md")
    assert (
        "posteriors and Bayesian evidence of the best law of each core (and of its runner-up "
        "where AICc leaves the order open)" in readme
    )
    assert f"posteriors and evidence of the best {words[full_top]} laws of every table" in readme


def test_five_rows_rank_laws_of_up_to_eight_parameters_and_three_rank_none(tmp_path):
    """docs/user-guide/own-core.rst's example of the rows rule, on the README's rows."""
    from fitdf.inference.ranking import rankable_laws
    from fitdf.inference.selection import rows_needed

    words = {"three": 3, "five": 5}
    five, most, three = re.search(
        r"so (\w+) rows rank laws of up to (\d+) parameters, and a file of (\w+) rows ranks none",
        text("docs/user-guide/own-core.rst"),
    ).groups()
    five, most, three = words[five], int(most), words[three]
    assert rows_needed(most) <= five < rows_needed(most + 1)
    csv = re.search(r"```csv\n(.*?)```", (REPO / "README.md").read_text(), re.S).group(1)
    path = tmp_path / "three.csv"
    path.write_text("\n".join(csv.splitlines()[: 1 + three]) + "\n")
    ok, not_ranked = rankable_laws(str(path))
    assert ok == [] and not_ranked


def test_the_benchmarks_state_the_least_squares_screen_and_starts():
    from fitdf.inference.lsq import fit_lsq
    from fitdf.models.cubic_hc import CubicHc

    defaults = inspect.signature(fit_lsq).parameters
    screen, starts = defaults["n_screen"].default, defaults["n_starts"].default
    assert (
        f"Least squares screens {screen} points and polishes {starts} starts per law "
        f"({starts * CubicHc.start_multiple} for cubic_hc" in text("benchmarks/README.md")
    )


def test_the_cubic_laws_bounds_and_starts_the_laws_page_states_are_its_own():
    from fitdf.models import get_model

    law = get_model("cubic_hc")
    upper = {p.name: p.bounds[1] for p in law.params}
    stated = re.search(
        r"The bounds add ``bend`` :math:`\\le ([\d.]+)`, ``h0_ratio`` :math:`\\le ([\d.]+)` and "
        r":math:`m_1 \\le ([\d.]+)`",
        text("docs/method/laws.rst"),
    )
    assert [float(g) for g in stated.groups()] == [upper["bend"], upper["h0_ratio"], upper["m1"]]
    words = {2: "twice", 3: "three times", 4: "four times"}
    assert f"least squares uses {words[law.start_multiple]} the usual number of starts" in text(
        "docs/method/laws.rst"
    )


def _walk(node, key):
    """Every value under ``key`` in a JSON tree."""
    if isinstance(node, dict):
        for k, v in node.items():
            if k == key:
                yield v
            yield from _walk(v, key)
    elif isinstance(node, list):
        for v in node:
            yield from _walk(v, key)


def test_the_benchmarks_account_of_the_committed_report_is_its_results():
    """benchmarks/README.md's figures of ``fitdf report --full`` (the committed report) are
    the ones its results.json records: phases, job-seconds, the posteriors' share, range and
    evaluations, the least-squares stage and the longest job."""
    results = json.loads((REPO / "reports" / "results.json").read_text(encoding="utf-8"))
    timing, jobs = results["timing"], results["timing"]["jobs_s"]
    bench = text("benchmarks/README.md")
    full = bench.split("**`fitdf report --full`**", 1)[1].split("**Known limits.**")[0]
    phases = re.search(r"least squares (\d+) s, second phase (\d+) s, figures (\d+) s", full)
    (second,) = [
        v
        for k, v in timing.items()
        if k.endswith("_s") and k not in ("least_squares_s", "figures_s", "total_s", "jobs_s")
    ]
    assert [int(g) for g in phases.groups()] == [
        round(timing["least_squares_s"]),
        round(second),
        round(timing["figures_s"]),
    ]
    posterior = {k: v for k, v in jobs.items() if k.split()[0] in ("nested", "posterior")}
    m = re.search(
        r"Job-seconds (\d+), of which nested sampling is (\d+) \((\d+) %: (\d+)-(\d+) s a job; "
        r"([\d,]+)-([\d,]+) evaluations a posterior\)",
        full,
    )
    evaluations = [  # the posteriors' own runs, not their prior boxes'
        f["diagnostics"]["n_likelihood_evaluations"]
        for block in results["blocks"].values()
        for f in (block.get("fits_posterior") or {}).values()
    ]
    assert [int(g.replace(",", "")) for g in m.groups()] == [
        round(sum(jobs.values())),
        round(sum(posterior.values())),
        round(100 * sum(posterior.values()) / sum(jobs.values())),
        round(min(posterior.values())),
        round(max(posterior.values())),
        min(evaluations),
        max(evaluations),
    ]
    sampled = [d for d in _walk(results["blocks"], "diagnostics") if "log_evidence" in d]
    converged = sum(bool(d["converged"]) for d in sampled)
    assert f"All {len(sampled)} posteriors converge" in full and converged == len(sampled)
    longest = max(jobs.values())
    m = re.search(r"\((\d+) s\), so the critical path on a cluster is about (\d+) minutes", full)
    assert [int(g) for g in m.groups()] == [
        round(longest),
        round((timing["least_squares_s"] + longest) / 60),
    ]
    blocks = set(results["blocks"])
    fits = [v for k, v in jobs.items() if k.split()[0] in blocks and len(k.split()) == 2]
    audits = [v for k, v in jobs.items() if k.split()[0] == "block"]
    m = re.search(
        r"this stage is (\d+) job-s \(the (\d+) fits (\d+), block audits and tables (\d+)\)", bench
    )
    assert [int(g) for g in m.groups()] == [
        round(sum(fits) + sum(audits)),
        len(fits),
        round(sum(fits)),
        round(sum(audits)),
    ]
    share = round(100 * sum(posterior.values()) / sum(jobs.values()))
    assert f"68 % of the default report's work and {share} % of `--full`'s" in bench


def test_the_changelogs_unreleased_section_is_the_net_change():
    """Unreleased states what differs from the last release, grouped Added/Changed/Fixed,
    not the intermediate states that led there ("was 52 min", "(was 1000 and four)")."""
    changelog = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    unreleased = changelog.split("## [Unreleased]", 1)[1].split("\n## [", 1)[0]
    headings = re.findall(r"^### (.+)$", unreleased, flags=re.M)
    assert headings and set(headings) <= {"Added", "Changed", "Fixed", "Removed"}
    flat = " ".join(unreleased.split())
    for history in (r"\(was\b", r"\bwas \d", r"\bnow\b", r"\bno longer\b", r"\bbefore that\b"):
        assert not re.search(history, flat), history


def test_the_least_squares_page_states_the_starts_study():
    """docs/method/inference.rst's account of how often the later least-squares starts
    change the optimum is benchmarks/lsq_starts.json's, recomputed by the benchmark's own
    functions."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "lsq_starts", REPO / "benchmarks" / "lsq_starts.py"
    )
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    records = json.loads((REPO / "benchmarks" / "lsq_starts.json").read_text())["records"]
    page = text("docs/method/inference.rst")
    exact = [bench.exact(r) for r in records]
    n = [len(r["starts"]) for r in records]
    assert f"polishes every start of the report's {len(records)} least-squares fits" in page
    first, last = sum(k == 1 for k in exact), sum(k == m for k, m in zip(exact, n))
    assert f"The first start is the best in {first} fits and the last in {last};" in page
    latest = {}
    for r, k, m in zip(records, exact, n):
        if k > latest.get(r["model"], (0,))[0]:
            latest[r["model"]] = (k, m, r["block"])
    assert all(k > 1 for k, _, _ in latest.values())  # "every law has a block ..."
    last_of_six = sum(k == m == 6 for k, m, _ in latest.values())
    assert f"start 6 of 6 for {last_of_six} laws" in page
    k, m, block = latest["cubic_hc"]
    assert f"start {k} of {m} for ``cubic_hc`` on Table {block}" in page
    total = sum(bench.cpu(r, len(r["starts"])) for r in records)
    after = sum(bench.cpu(r, len(r["starts"])) - bench.cpu(r, k) for r, k in zip(records, exact))
    assert f"best cost {after:.0f} of the {total:.0f} CPU seconds" in page
    worst, least_saved = 0.0, np.inf
    for n_agree, window in bench.RULES:
        stops = [bench.agree_stop(r, n_agree, window) for r in records]
        rises = [
            r["prefixes"][s - 1]["aicc"] - r["prefixes"][-1]["aicc"]
            for r, s, k in zip(records, stops, exact)
            if s < k
        ]
        saved = sum(
            bench.cpu(r, len(r["starts"])) - bench.cpu(r, s) for r, s in zip(records, stops)
        )
        if rises:
            worst = max(worst, *rises)
        else:  # a stop that changes no fit
            least_saved = min(least_saved, saved)
    assert (
        f"changes a fit, by up to {worst:.0f} in AICc (``cubic_hc``), or saves {least_saved:.0f} s"
        in page
    )
    b2 = next(r for r in records if (r["block"], r["model"]) == ("B.2", "jiles_atherton"))
    objective = [p["objective"] for p in b2["prefixes"]]
    assert bench.exact(b2) == 6 and len(set(np.round(objective[:5], 9))) == 1
    assert f"the sixth {objective[4] - objective[5]:.2f} lower in the penalised" in page
    starts = [s for r in records for s in r["starts"]]
    merged = [s for s in starts if s["merged"]]
    assert (
        f"the {len(merged)} of {len(starts)} starts that merge into a basin found before take "
        f"{sum(s['cpu_s'] for s in merged):.0f} s" in page
    )
