"""The JSON that scripts read checks against the schemas in ``schemas/``.

Every ``--json`` output of the command line (run as a user runs it: a subprocess of the
installed package) and the report's ``results.json`` (the tiny report of conftest.py) must
validate against its JSON Schema (draft 2020-12). The schemas themselves must be valid,
self-contained (every ``$ref`` resolves), document every top-level key, and not be
vacuous: dropping a required key, or giving a new optional key the wrong shape, fails.
"""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

import fitdf.report.sections as sections
from fitdf.report.upgrade import read_results

REPO = Path(__file__).resolve().parents[1]
SCHEMAS = REPO / "schemas"
COMMITTED = REPO / "reports" / "results.json"
PLANT = "K/((1+s)(1+0.25s)(1+1.1s))"

#: A user's own measurements (no core geometry: no material constants, no Appendix A check).
USER_CSV = "input_v,frequency_hz,df_reported,phase_lead_deg,source_impedance_ohm\n" + "".join(
    f"{v},{f},{d},{ph},600\n"
    for f in (5.0, 10.0)
    for v, d, ph in ((0.2, 0.5, 30), (0.5, 0.7, 15), (1.0, 0.8, 8), (2.0, 0.6, 20), (3.0, 0.45, 35))
)

#: (case id, schema file, command line after ``fitdf``); ``{csv}`` is the user CSV above,
#: ``{dir}`` the folder holding it (and nothing else). The fits run on the CLI's default pool
#: of workers (the least squares and the MCMC, and one pool for a batch), except the plain
#: least-squares fit of B.1: in the CLI's own process (``--workers 1``, the same output
#: without a pool's start-up of seconds).
COMMANDS = [
    ("datasets", "fitdf-datasets.schema.json", ["datasets", "--json"]),
    ("audit-B.1", "fitdf-audit.schema.json", ["audit", "B.1", "--json"]),
    ("audit-csv", "fitdf-audit.schema.json", ["audit", "{csv}", "--json"]),
    ("models", "fitdf-models.schema.json", ["models", "--json"]),
    ("models-law", "fitdf-models.schema.json", ["models", "preisach", "--json"]),
    (
        "fit-B.1",
        "fitdf-fit.schema.json",
        ["fit", "B.1", "--models", "constant_width", "--no-cv", "--json", "--workers", "1"],
    ),
    (
        "fit-csv-mcmc",
        "fitdf-fit.schema.json",
        [
            "fit",
            "{csv}",
            "--models",
            "constant_width",
            "--method",
            "mcmc",
            "--steps",
            "50",
            "--max-steps",
            "50",
            "--no-cv",
            "--json",
        ],
    ),
    (
        "fit-batch",
        "fitdf-fit-batch.schema.json",
        [
            "fit",
            "{dir}",
            "{csv}",
            "--models",
            "constant_width",
            "--chain",
            "winding",
            "--no-cv",
            "--json",
        ],
    ),
    (
        "limit-cycle",
        "fitdf-limit-cycle.schema.json",
        [
            "limit-cycle",
            "B.1",
            "--plant",
            PLANT,
            "--gain",
            "150",  # a gain with a cycle: the schema's intersection fields are checked
            "--model",
            "constant_width",
            "--json",
        ],
    ),
]


def load_schema(name: str) -> dict:
    return json.loads((SCHEMAS / name).read_text(encoding="utf-8"))


def validator(name: str) -> Draft202012Validator:
    return Draft202012Validator(load_schema(name))


def errors(name: str, instance) -> list[str]:
    return [
        f"{'/'.join(map(str, e.absolute_path)) or '(top)'}: {e.message[:300]}"
        for e in validator(name).iter_errors(instance)
    ]


# ------------------------------------------------------------------ the schemas themselves
SCHEMA_FILES = [
    "fitdf-datasets.schema.json",
    "fitdf-audit.schema.json",
    "fitdf-models.schema.json",
    "fitdf-fit.schema.json",
    "fitdf-fit-batch.schema.json",
    "fitdf-limit-cycle.schema.json",
    "results.schema.json",
]


def _refs(node):
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "$ref":
                yield value
            else:
                yield from _refs(value)
    elif isinstance(node, list):
        for value in node:
            yield from _refs(value)


def test_schema_folder_holds_exactly_the_documented_files():
    assert sorted(p.name for p in SCHEMAS.glob("*.json")) == sorted(SCHEMA_FILES)


@pytest.mark.parametrize("name", SCHEMA_FILES)
def test_schema_is_valid_draft_2020_12_and_self_contained(name):
    schema = load_schema(name)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    Draft202012Validator.check_schema(schema)
    # check_schema does not follow $ref: every reference must point into this file's $defs
    for ref in set(_refs(schema)):
        assert ref.startswith("#/$defs/"), f"{name}: {ref} is not a local definition"
        assert ref.removeprefix("#/$defs/") in schema["$defs"], f"{name}: dangling {ref}"
    # every top-level key is documented, required keys exist, nothing undocumented sneaks in
    assert schema["type"] == "object" and schema["additionalProperties"] is False
    assert schema["required"] and set(schema["required"]) <= set(schema["properties"])
    for key, prop in schema["properties"].items():
        assert prop.get("description"), f"{name}: top-level key {key!r} has no description"


def test_shared_definitions_agree_across_files():
    """A definition used by several files (ranking row, fit parameters, ...) is the same everywhere."""
    seen: dict[str, tuple[str, dict]] = {}
    for name in SCHEMA_FILES:
        for key, definition in load_schema(name).get("$defs", {}).items():
            if key in seen:
                assert definition == seen[key][1], f"$defs/{key} differs: {seen[key][0]} vs {name}"
            else:
                seen[key] = (name, definition)


# ------------------------------------------------------------------ the command line
def _run(args: list[str]) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore", "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, "-m", "fitdf.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
        cwd=REPO,
    )


#: The commands that fit with a pool of workers, MCMC or the limit-cycle search (tens of
#: seconds each on a 2-core machine): their schema checks run with the slow tests.
SLOW_CASES = {"fit-csv-mcmc", "fit-batch", "limit-cycle"}


def _case(case, *rest):
    """A parameter set of the cases below, marked slow for :data:`SLOW_CASES`."""
    return pytest.param(case, *rest, marks=pytest.mark.slow if case in SLOW_CASES else ())


def _cases_wanted(request) -> set[str]:
    """The cases of COMMANDS the selected tests of this module read (``fit-B.1`` always)."""
    wanted = {"fit-B.1"}
    for item in request.session.items:
        params = getattr(getattr(item, "callspec", None), "params", {})
        if item.module is request.module and "case" in params:
            wanted.add(params["case"])
    return wanted


@pytest.fixture(scope="module")
def cli_outputs(request, tmp_path_factory) -> dict:
    """The commands of COMMANDS the selected tests read, two at a time (each is mostly
    start-up and one small fit)."""
    csv = tmp_path_factory.mktemp("csv") / "mycore.csv"
    csv.write_text(USER_CSV)
    wanted = _cases_wanted(request)
    argv = {
        case: [a.replace("{csv}", str(csv)).replace("{dir}", str(csv.parent)) for a in args]
        for case, _, args in COMMANDS
        if case in wanted
    }
    with ThreadPoolExecutor(max_workers=2) as pool:
        done = dict(zip(argv, pool.map(_run, argv.values())))
    return done


@pytest.mark.parametrize(("case", "schema"), [_case(c, s) for c, s, _ in COMMANDS])
def test_cli_json_matches_schema(cli_outputs, case, schema):
    proc = cli_outputs[case]
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    assert errors(schema, out) == []
    if (
        case == "fit-B.1"
    ):  # a thesis core: the material constants and the Appendix A check are there
        assert "material" in out["fits"][0] and out["fits"][0]["appendix_a_check"]
    if case == "fit-csv-mcmc":  # the emcee branch (its diagnostics) was exercised
        assert {f["method"] for f in out["fits"]} == {"mcmc"}
        assert "steps_over_tau" in out["fits"][0]["diagnostics"]
    if case == "audit-csv":
        assert out["rows"] == 10
    if case == "fit-batch":  # the folder's one CSV, then the same file named directly
        assert [f["data"] for f in out["files"]] == [r["data"] for r in out["summary"]]
        assert len(out["files"]) == 2 and out["files"][0]["data"].endswith("mycore.csv")
    if case == "models-law":  # the law asked for, and every chain
        assert [m["name"] for m in out["models"]] == ["preisach"]
        assert {c["name"] for c in out["chains"]} >= {"direct", "winding", "voltage"}
    if case == "limit-cycle":  # an ordinary plant: nothing to warn about
        assert out["warnings"] == []


def _drop(obj: dict, path: tuple):
    obj = copy.deepcopy(obj)
    node = obj
    for key in path[:-1]:
        node = node[key]
    del node[path[-1]]
    return obj


@pytest.mark.parametrize(
    ("case", "schema", "path"),
    [
        _case("datasets", "fitdf-datasets.schema.json", ("appendix_b",)),
        _case("datasets", "fitdf-datasets.schema.json", ("appendix_b", 0, "frequency_hz")),
        _case("audit-B.1", "fitdf-audit.schema.json", ("findings",)),
        _case("audit-B.1", "fitdf-audit.schema.json", ("flagged", 0, "exclude_default")),
        _case("models", "fitdf-models.schema.json", ("models", 0, "parameters")),
        _case("fit-B.1", "fitdf-fit.schema.json", ("ranking",)),
        _case("fit-B.1", "fitdf-fit.schema.json", ("ranking", 0, "rms_complex")),
        _case("fit-B.1", "fitdf-fit.schema.json", ("fits", 0, "parameters", 0, "value")),
        _case("fit-B.1", "fitdf-fit.schema.json", ("fits", 0, "appendix_a_check", 0, "inside")),
        _case("fit-csv-mcmc", "fitdf-fit.schema.json", ("fits", 0, "diagnostics")),
        _case("fit-batch", "fitdf-fit-batch.schema.json", ("summary", 0, "aicc")),
        _case("fit-batch", "fitdf-fit-batch.schema.json", ("files", 0, "ranking")),
        _case("fit-batch", "fitdf-fit-batch.schema.json", ("files", 1, "fits", 0, "parameters")),
        _case("limit-cycle", "fitdf-limit-cycle.schema.json", ("critical_gain",)),
        _case("limit-cycle", "fitdf-limit-cycle.schema.json", ("warnings",)),
        _case("limit-cycle", "fitdf-limit-cycle.schema.json", ("intersections", 0, "amplitude")),
    ],
)
def test_a_missing_required_key_fails(cli_outputs, case, schema, path):
    out = json.loads(cli_outputs[case].stdout)
    assert errors(schema, out) == []
    broken = _drop(out, path)
    assert errors(schema, broken), f"{schema} accepts the output without {'/'.join(map(str, path))}"


def test_batch_schema_holds_the_single_fit_schema():
    """Each dataset of a batch is exactly a ``fitdf fit DATA --json`` output: the same schema."""
    single, batch = load_schema("fitdf-fit.schema.json"), load_schema("fitdf-fit-batch.schema.json")
    per_file = batch["$defs"]["fit_output"]
    for key in ("properties", "required", "additionalProperties"):
        assert per_file[key] == single[key], key
    assert set(single["$defs"]) <= set(batch["$defs"])


def test_fit_schema_checks_the_new_keys_when_present(cli_outputs):
    out = json.loads(cli_outputs["fit-B.1"].stdout)
    fit = out["fits"][0]
    # optional: a fit without material constants (a user's CSV) is valid
    for key in ("material", "appendix_a_check"):
        assert errors("fitdf-fit.schema.json", _drop(out, ("fits", 0, key))) == []
    # new chains and model names are accepted, unknown chains are not
    ok = copy.deepcopy(out)
    ok["fits"][0].update(chain="voltage", model="preisach")
    ok["ranking"][0].update(chain="direct", model="jiles_atherton")
    assert errors("fitdf-fit.schema.json", ok) == []
    bad_chain = copy.deepcopy(out)
    bad_chain["fits"][0]["chain"] = "magnetic"
    assert errors("fitdf-fit.schema.json", bad_chain)
    # but when present they must have their shape
    for broken in (
        {**fit, "material": [1, 2]},
        {**fit, "appendix_a_check": {"quantity": "mu"}},
        {**fit, "appendix_a_check": [{**fit["appendix_a_check"][0], "inside": "yes"}]},
        {**fit, "appendix_a_check": [{**fit["appendix_a_check"][0], "fitted": "12"}]},
    ):
        assert errors("fitdf-fit.schema.json", {**out, "fits": [broken]}), broken
    # and an undocumented top-level key is refused (rename = remove + add)
    assert errors("fitdf-fit.schema.json", {**out, "fit": out["fits"]})


# ------------------------------------------------------------------ the report's results.json
@pytest.fixture(scope="module")
def report_results(tiny_report) -> dict:
    """results.json of the tiny report (conftest.py): least squares, MCMC, cross-validation,
    a joint block, a cross-impedance prediction and the limit-cycle comparison."""
    return json.loads((tiny_report / "results.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def switched_off(report_results) -> dict:
    """The same results with the limit-cycle section a run with ``limit_cycles=False`` writes
    (fitdf.report.build takes it from ``sections.limit_cycles_switched_off``)."""
    return {**report_results, "limit_cycles": sections.limit_cycles_switched_off()}


def test_results_json_matches_schema(report_results, switched_off):
    assert errors("results.schema.json", report_results) == []
    block = report_results["blocks"]["B.1"]
    assert block["fits_posterior"] and block["cv"]  # the MCMC and CV parts were exercised
    assert report_results["limit_cycles"]["rows"]  # and the limit-cycle comparison
    assert errors("results.schema.json", switched_off) == []
    assert switched_off["limit_cycles"]["available"] is False


def test_results_schema_is_not_vacuous(report_results, switched_off):
    r = report_results
    model = r["settings"]["models"][0]
    for results, path in (
        (r, ("blocks", "B.1", "ranking_lsq", 0, "aicc")),
        (r, ("blocks", "B.1", "order_lsq")),
        (r, ("blocks", "B.1", "fits_lsq", model, "parameters")),
        (r, ("blocks", "B.1", "fits_posterior", model, "diagnostics")),
        (switched_off, ("limit_cycles", "reason")),
        (r, ("settings", "models")),
        (r, ("findings",)),
        (r, ("claims",)),
        (r, ("claims", "conclusion")),
        (r, ("claims", "conclusion", 0, "fields")),
        (r, ("run",)),
        (r, ("physics", "precision")),
        (r, ("physics", "precision", "B.1", "rounding_rms_complex")),
        (r, ("physics", "catalogue")),
        (r, ("timing", "total_s")),
    ):
        assert errors("results.schema.json", _drop(results, path)), path
    fit = r["blocks"]["B.1"]["fits_lsq"][model]
    with_new = {**fit, "material": {"model": model, "coercive_force_oe": 0.1}}
    with_new["appendix_a_check"] = [
        {
            "quantity": "coercive_force_Hc",
            "fitted": None,
            "low": 0.02,
            "high": 0.25,
            "unit": "oersted",
            "inside": False,
        }
    ]
    good = copy.deepcopy(r)
    good["blocks"]["B.1"]["fits_lsq"][model] = with_new
    assert errors("results.schema.json", good) == []
    bad = copy.deepcopy(good)
    del bad["blocks"]["B.1"]["fits_lsq"][model]["appendix_a_check"][0]["unit"]
    assert errors("results.schema.json", bad)


def test_committed_results_json_matches_schema_if_current(report_results):
    if not COMMITTED.exists():
        pytest.skip("no committed reports/results.json")
    committed = read_results(COMMITTED)
    # (the small-signal study is added to a report after its run: fitdf.report.small_signal_study)
    if set(committed) - {"small_signal_evidence"} != set(report_results):
        pytest.skip(
            "reports/results.json predates the current structure "
            f"(top-level keys {sorted(set(committed) ^ set(report_results))} differ); regenerate it"
        )
    assert errors("results.schema.json", committed) == []


def test_switched_on_limit_cycle_section_shapes(report_results):
    """The three shapes of the limit-cycle section: switched off, failed, done."""
    base = copy.deepcopy(report_results)
    failed = {"available": True, "error": "RuntimeError: x", "models_offered": ["constant_width"]}
    done = {
        "available": True,
        "models_offered": ["constant_width"],
        "rows": [],
        "columns": [],
        "attrs": {"alpha": 1.0},
        "figure": None,
    }
    for section, ok in (
        (failed, True),
        (done, True),
        ({"available": True, "models_offered": []}, False),
        ({"available": False}, False),
    ):
        base["limit_cycles"] = section
        assert (errors("results.schema.json", base) == []) is ok, section
    # a record of the comparison by settings: its rows name their scales, its attrs carry the
    # summaries its sentences are made from
    lc = report_results["limit_cycles"]
    assert lc["rows"][0]["setting"] == "unscaled" and lc["attrs"]["statements"]
    for path in (
        ("limit_cycles", "rows", 0, "alpha"),
        ("limit_cycles", "attrs", "agreement"),
        ("limit_cycles", "attrs", "critical_gains"),
        ("limit_cycles", "attrs", "scales", "held_out"),
    ):
        assert errors("results.schema.json", _drop(report_results, path)), path
