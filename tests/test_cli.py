"""The command line as a user drives it: subprocesses of the installed console script.

The user-error cases run :func:`fitdf.cli.main` in this process instead (``run_here``): the
one-line message and the exit code are main's, the console script only passes the code
on (which the subprocess tests check), and an interpreter start-up per case cost ~3 s.
"""

import contextlib
import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from synthetic import synthetic_frame

FITDF = shutil.which("fitdf") or os.path.join(os.path.dirname(sys.executable), "fitdf")
#: The checkout these tests import (the console script itself puts its own folder first).
CHECKOUT = str(Path(__file__).resolve().parent.parent)


def run(*args, timeout=600):
    """The installed console script, importing the checkout's package like every other test:
    on a fresh install the checkout's numba kernels are compiled before the tests start
    (conftest.py), the installed copy's would be compiled again here (~25 s)."""
    path = os.pathsep.join(filter(None, (CHECKOUT, os.environ.get("PYTHONPATH"))))
    env = {**os.environ, "PYTHONWARNINGS": "ignore", "PYTHONPATH": path}
    return subprocess.run([FITDF, *args], capture_output=True, text=True, timeout=timeout, env=env)


def run_here(*args):
    """:func:`fitdf.cli.main` on ``args`` in this process, as ``run`` would report it
    (``--help`` included: argparse ends it by ``SystemExit``)."""
    from fitdf.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:
            code = exc.code
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def assert_user_error(proc, *fragments):
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr  # one line, never a traceback
    assert "Traceback" not in proc.stderr
    for f in fragments:
        assert f in lines[0], lines[0]


def test_version_and_help():
    v = run("--version")
    assert v.returncode == 0 and v.stdout.startswith("fitdf ")
    h = run("--help")
    assert h.returncode == 0
    for cmd in ("datasets", "audit", "models", "fit", "report", "limit-cycle"):
        assert cmd in h.stdout
        sub = run(cmd, "--help")
        assert sub.returncode == 0 and "examples:" in sub.stdout, cmd


def test_no_command_prints_help_and_exits_2():
    p = run()
    assert p.returncode == 2 and "usage" in p.stdout


def test_datasets_lists_every_table_with_counts():
    p = run("datasets")
    assert p.returncode == 0, p.stderr
    for t in ("B.1", "B.2", "B.3", "B.4", "B.5", "table_5_1", "table_5_2"):
        assert t in p.stdout
    j = json.loads(run("datasets", "--json").stdout)
    assert sum(r["rows"] for r in j["appendix_b"]) == 264


def test_audit_shows_flagged_rows_and_findings():
    p = run("audit", "B.1")
    assert p.returncode == 0, p.stderr
    assert "power-of-ten" in p.stdout
    assert "3.3" in p.stdout  # the DF factor the B.1 data follow
    j = json.loads(run("audit", "--json").stdout)
    assert j["rows"] == 264 and len(j["flagged"]) > 10 and j["findings"]


def test_models_lists_every_model_with_equations():
    p = run("models")
    assert p.returncode == 0, p.stderr
    for m in (
        "constant_width",
        "proportional_width",
        "proportional_width_fig42",
        "cubic_hc",
        "rayleigh",
        "frequency_hc",
        "winding",
        "direct",
    ):
        assert m in p.stdout
    assert "eq" in p.stdout
    j = json.loads(run("models", "--json").stdout)
    assert {m["name"] for m in j["models"]} >= {"rayleigh", "cubic_hc"}


#: The fits in the CLI's own process (--workers 1; the same numbers, test_executor.py): a
#: pool's start-up costs more than these small fits. The CLI's default pool of workers runs
#: the fits of test_json_schemas.py (one dataset, and a batch) and test_interrupt.py.
ONE_PROCESS = ("--workers", "1")


#: The longest line ``fitdf fit`` prints by default (``--wide``: every column).
WIDTH = 100


def assert_fits_in_100_columns(text: str) -> None:
    long = [line for line in text.splitlines() if len(line) > WIDTH]
    assert not long, "\n".join(long)


def parameter_lines(text: str) -> dict:
    """``{name: (value line, meaning)}`` of the best model's parameters in ``fitdf fit``'s
    text: a line of name, value, unit and interval, then indented lines of what it means."""
    lines = text.split("Best model:")[1].splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["parameter", "value"])
    out, name = {}, None
    for line in lines[head + 1 :]:
        if line.startswith("      ") and name is not None:  # (a meaning may wrap)
            out[name] = (out[name][0], f"{out[name][1]} {line.strip()}".strip())
        elif line.startswith("  ") and not line.startswith(("   ", "  (", "  warning:")):
            name = line.split()[0]
            out[name] = (line, "")
        else:
            break
    return out


def test_fit_prints_ranking_and_json():
    fit_b3 = ("fit", "B.3", "--models", "constant_width", "proportional_width")
    fit_b3 += ("proportional_width_fig42", "--chain", "winding", "--no-cv", *ONE_PROCESS)
    # through the cheap winding chain (12 s less a run on 2 cores; neither the text nor the
    # JSON depends on the chain): the default chain's JSON is test_json_schemas.py's fit-B.1
    p = run(*fit_b3, "--quiet")
    assert p.returncode == 0, p.stderr
    assert "Ranking on B.3 (36 rows, winding chain, least squares, seed 0)" in p.stdout
    assert_fits_in_100_columns(p.stdout)
    ranking = p.stdout.split("\n\n")[0].splitlines()[1:]
    assert ranking[0].split() == ["rank", "model", "n_params", "rms_complex", "aicc", "ties"]
    rows = {r.split()[1]: r.split() for r in ranking[1:]}
    # the two proportional-width laws cannot be told apart (AICc within 2): each names the other
    pw, fig42 = rows["proportional_width"], rows["proportional_width_fig42"]
    assert pw[-1] == fig42[0] and fig42[-1] == pw[0]
    words = " ".join(p.stdout.split())  # (the legend is wrapped)
    assert "ties: the ranks this row cannot be told apart from" in words
    assert "(least squares: AICc within 2)" in words and "--wide prints every column" in words
    # the best model's parameters: unit (- for a pure number) and what each means
    params = parameter_lines(p.stdout)
    assert set(params) >= {"k", "c", "r_series", "gain"}
    units = {name: line.split()[2] for name, (line, _) in params.items()}
    assert units["k"] == "H" and units["r_series"] == "ohm" and units["gain"] == "-"
    assert "calibration gain" in params["gain"][1] and "series resistance" in params["r_series"][1]
    assert "(unit -: dimensionless)" in p.stdout
    wide = run(*fit_b3, "--quiet", "--wide")
    assert wide.returncode == 0, wide.stderr
    header = wide.stdout.splitlines()[1].split()
    assert {"chain", "method", "rms_phase_deg", "bic", "indistinguishable_from"} <= set(header)
    assert "proportional_width_fig42/winding" in wide.stdout
    j = json.loads(run_here(*fit_b3, "--json").stdout)  # (in this process: ~4 s of start-up less)
    assert [r["rank"] for r in j["ranking"]] == [1, 2, 3]
    assert {f["model"] for f in j["fits"]} == {
        "constant_width",
        "proportional_width",
        "proportional_width_fig42",
    }
    for f in j["fits"]:
        assert f["metrics"]["rms_complex"] > 0 and f["parameters"]


@pytest.mark.slow  # about a minute of nested sampling on 2 cores
def test_fit_by_nested_sampling_prints_its_checks_and_json():
    """``--method nested``: the ranking by evidence, the nested-sampling checks and the JSON
    with the evidence, its error and the prior, valid against the fit schema."""
    args = ("fit", "B.1", "--models", "rayleigh", "constant_width", "--chain", "winding")
    args += ("--method", "nested", "--no-cv", "--rank-by", "log_evidence", *ONE_PROCESS)
    p = run(*args, "--quiet")
    assert p.returncode == 0, p.stderr
    assert "nested sampling" in p.stdout and "log_evidence" in p.stdout
    assert_fits_in_100_columns(p.stdout)
    checks = p.stdout.split("Nested-sampling checks")[1].splitlines()
    assert "converged: >= 400 effective draws, evidence error <= 0.3" in checks[0]
    rows = {line.split()[0]: line.split() for line in checks[2:4]}
    assert set(rows) == {"rayleigh", "constant_width"}
    j = json.loads(run_here(*args, "--json").stdout)
    from jsonschema import Draft202012Validator

    schema = json.loads((Path(CHECKOUT) / "schemas" / "fitdf-fit.schema.json").read_text())
    assert not list(Draft202012Validator(schema).iter_errors(j))
    evidence = [r["log_evidence"] for r in j["ranking"]]
    assert evidence == sorted(evidence, reverse=True)  # ranked by the evidence
    for f in j["fits"]:
        d = f["diagnostics"]
        assert f["method"] == "nested" and d["converged"], d
        assert d["n_effective"] >= 400 and d["log_evidence_error"] <= 0.3
        assert f["info"]["prior"]["r_series"]["distribution"].startswith("log-normal")
        shown = rows[f["model"]]
        assert (
            shown[3] == f"{d['log_evidence']:.2f}" and shown[5] == f"{d['log_evidence_error']:.2f}"
        )
    top = j["ranking"][0]
    assert top["log_bayes_factor_next"] == pytest.approx(evidence[0] - evidence[1])
    assert top["bayes_factor_verdict"]


@pytest.mark.slow  # 30 s of fitting on 2 cores (the cheaper test above runs by default)
def test_the_default_fit_output_fits_in_100_columns(tmp_path):
    """``fitdf fit B.3 --method lsq --no-cv`` as a user types it: every line within 100
    columns, every parameter of the best law with its unit and meaning."""
    p = run("fit", "B.3", "--method", "lsq", "--no-cv", "--cache", str(tmp_path))
    assert p.returncode == 0, p.stderr
    assert_fits_in_100_columns(p.stdout)
    params = parameter_lines(p.stdout)
    assert {"i_c", "l_rev", "f_rev"} <= set(params)  # (the best law on B.3: the Preisach model)
    for name, (line, meaning) in params.items():
        assert line.split()[2] != "1", line  # a pure number's unit is "-"
        assert len(meaning.split()) >= 3, (name, meaning)
    assert "coercive-current" in params["i_c"][1]
    assert "reversible" in params["l_rev"][1] and "reversible" in params["f_rev"][1]


def test_the_default_ranking_stays_within_100_columns():
    """Three chains and both methods, long lists of ties: the columns that vary are shown,
    the table stays within 100 columns, a cut list of ties says so."""
    import pandas as pd

    from fitdf.inference.presentation import ranking_text

    models = ["proportional_width_fig42", "jiles_atherton", "preisach", "cubic_hc"]
    rows = []
    for model in models:
        for chain in ("direct", "winding", "voltage"):
            for method in ("lsq", "mcmc"):
                rows.append(
                    {
                        "model": model,
                        "chain": chain,
                        "method": method,
                        "n_params": 9,
                        "rms_complex": 0.123456,
                        "aicc": -1234.5678,
                        "cv_rms_complex": 0.2345678,
                        "looic": 1234.5,
                        "bic": 1.0,
                    }
                )
    table = pd.DataFrame(rows)
    table.insert(0, "rank", range(1, len(table) + 1))
    every = [f"{r['model']}/{r['chain']}" for r in rows]
    table["indistinguishable_from"] = [
        ", ".join(n for n in every[::2] if n != f"{r['model']}/{r['chain']}") for r in rows
    ]
    text = ranking_text(table, "looic")
    assert_fits_in_100_columns(text)
    header = text.splitlines()[0].split()
    assert header == [
        "rank",
        "model",
        "chain",
        "method",
        "n_params",
        "rms_complex",
        "aicc",
        "cv_rms_complex",
        "looic",
        "ties",
    ]
    assert "..." in text
    assert "least squares: AICc within 2; MCMC: elpd_loo" in " ".join(text.split())
    wide = ranking_text(table, "looic", wide=True)
    assert "indistinguishable_from" in wide and max(map(len, wide.splitlines())) > WIDTH


def test_models_explains_one_law():
    p = run_here("models", "preisach")
    assert p.returncode == 0, p.stderr
    assert_fits_in_100_columns(p.stdout)
    text = p.stdout
    assert text.startswith("preisach: Preisach model")
    assert "thesis equations:" in text and "eqs 3.1, 3.7" in text
    lines = text.splitlines()
    for name, unit, bounds in (("i_c", "A", "1e-07 .. 0.1"), ("l_rev", "H", "0.01 .. 10000")):
        (row,) = [line for line in lines if line.split()[:1] == [name]]
        assert row.split()[1] == unit and bounds in row
        meaning = lines[lines.index(row) + 1]
        assert meaning.startswith("      ") and len(meaning.split()) > 3
    assert [line for line in lines if line.split()[:2] == ["f_rev", "-"]]  # dimensionless
    for chain in ("direct:", "winding:", "voltage (default):"):
        assert any(line.startswith(chain) for line in lines), chain
    assert [line for line in lines if line.split()[:2] == ["r_series", "ohm"]]
    listing = run_here("models")
    assert listing.returncode == 0 and "jiles_atherton:" in listing.stdout
    assert "fitdf models LAW" in listing.stdout


def test_models_of_an_unknown_law_is_a_user_error():
    p = run_here("models", "bogus")
    assert_user_error(p, "unknown law 'bogus'", "preisach", "constant_width")


def test_report_has_no_json_option():
    """The report's machine-readable output is its results.json; it prints no JSON."""
    assert_user_error(run_here("report", "--json"), "--json")
    h = run_here("report", "--help")
    assert "--json" not in h.stdout and "results.json" in h.stdout


def test_fit_help_points_to_the_csv_format():
    h = run_here("fit", "--help")
    for column in ("input_v", "frequency_hz", "df_reported", "phase_lead_deg"):
        assert column in h.stdout
    assert "source_impedance_ohm" in h.stdout and "datasets/README.md" in h.stdout


@pytest.mark.parametrize(
    "args, fragments",
    [
        (("fit", "nosuchcore"), ["nosuchcore"]),
        (("fit", "missing_dir/file.csv"), ["file.csv"]),
        (("fit", "B.3", "--models", "bogus"), ["--models", "unknown law", "bogus"]),
        (("fit", "B.3", "--chain", "bogus"), ["bogus"]),
        (("fit", "B.3", "--method", "magic"), ["magic"]),
        (("fit", "B.3", "--steps", "10"), ["--steps"]),
        (("fit", "B.3", "--rank-by", "looic"), ["looic", "mcmc"]),
        (("fit", "B.3", "--rank-by", "log_evidence"), ["log_evidence", "nested"]),
        (("report", "--quick", "--full"), ["--full", "--quick"]),
        (("fit", "B.3", "--source-impedance", "50"), ["50"]),
        (("fit", "B.3", "--seed", "abc"), ["abc"]),
        (("audit", "nosuch.csv"), ["nosuch.csv"]),
        (("bogus-command",), ["bogus-command"]),
    ],
)
def test_user_errors_are_one_line_and_exit_2(args, fragments):
    assert_user_error(run_here(*args), *fragments)


def test_bad_csv_is_a_user_error(tmp_path):
    bad = tmp_path / "core.csv"
    bad.write_text("input_v,frequency_hz,df_reported,phase_lead_deg\n0.5,10,abc,3\n")
    assert_user_error(run("fit", str(bad)), "core.csv", "df_reported")  # the console script
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    assert_user_error(run_here("audit", str(empty)), "empty.csv")


def test_user_csv_fits(tmp_path):
    good = tmp_path / "mycore.csv"
    rows = ["input_v,frequency_hz,df_reported,phase_lead_deg,source_impedance_ohm"]
    for f in (5.0, 10.0):
        for v, d, ph in (
            (0.2, 0.5, 30),
            (0.5, 0.7, 15),
            (1.0, 0.8, 8),
            (2.0, 0.6, 20),
            (3.0, 0.45, 35),
        ):
            rows.append(f"{v},{f},{d},{ph},600")
    good.write_text("\n".join(rows) + "\n")
    p = run("fit", str(good), "--models", "constant_width", "--no-cv", "--quiet", *ONE_PROCESS)
    assert p.returncode == 0, p.stderr
    assert "mycore.csv" in p.stdout


@pytest.mark.slow  # 24 s on 2 cores; test_limit_cycle_warns_of_an_unstable_plant runs the command by default
def test_limit_cycle_command_prints_table_json_and_plot(tmp_path):
    plant = "K/((1+s)(1+0.25s)(1+1.1s))"
    p = run(
        "limit-cycle",
        "B.1",
        "--plant",
        plant,
        "--gain",
        "100",
        "500",
        "--model",
        "proportional_width",
    )
    assert p.returncode == 0, p.stderr
    assert "100" in p.stdout and "500" in p.stdout
    png = tmp_path / "loci.png"
    j = run(
        "limit-cycle",
        "B.1",
        "--plant",
        plant,
        "--gain",
        "500",
        "--model",
        "proportional_width",
        "--json",
        "--plot",
        str(png),
    )
    assert j.returncode == 0, j.stderr
    data = json.loads(j.stdout)
    assert data and png.exists() and png.stat().st_size > 1000


@pytest.mark.parametrize(
    "args, fragments",
    [
        (("limit-cycle", "B.1", "--plant", "K/((1+s)(1+0.25s"), ["plant"]),
        (("limit-cycle", "B.1", "--plant", "__import__('os')"), ["plant"]),
        (("limit-cycle", "permalloy", "--plant", "K/(1+s)"), ["source impedance"]),
        (("limit-cycle", "B.1", "--plant", "K/(1+s)", "--model", "bogus"), ["bogus"]),
        (("limit-cycle", "B.1", "--plant", "K/(1+s)", "--time-scale", "0"), ["--time-scale"]),
        (("limit-cycle", "B.1"), ["--plant"]),
    ],
)
def test_limit_cycle_user_errors(args, fragments):
    assert_user_error(run_here(*args), *fragments)


# ------------------------------------------------------------------ batch fitting
def _write_cores(folder, n=2):
    """``n`` small synthetic cores (constant-width law, winding chain) as CSV files."""
    folder.mkdir(exist_ok=True)
    paths = []
    for i in range(n):
        truth = {"k": 60.0 + 30.0 * i, "b": 2e-4, "c": 0.04, "r_series": 100.0, "gain": 0.95}
        frame = synthetic_frame(
            "constant_width",
            truth,
            chain="winding",
            seed=i,
            frequencies=(3.0, 10.0),
            amplitudes=[0.2, 0.5, 1.0, 2.0, 3.0, 4.0],
        )
        path = folder / f"core{i}.csv"
        frame.to_csv(path, index=False)
        paths.append(path)
    return paths


FAST_FIT = (
    "--method",
    "lsq",
    "--chain",
    "winding",
    "--models",
    "constant_width",
    "--no-cv",
    *ONE_PROCESS,
)


@pytest.mark.slow  # 15 s; a batch is checked before fitting by default (test_fit_batch_checks_every_file_before_fitting)
def test_fit_batch_ranks_each_file_then_summarises(tmp_path):
    a, b = _write_cores(tmp_path / "cores")
    (tmp_path / "cores" / "notes.txt").write_text("not a CSV: ignored\n")
    p = run("fit", str(tmp_path / "cores"), *FAST_FIT, "--quiet", "--wide")
    assert p.returncode == 0, p.stderr
    assert p.stdout.count("Ranking on") == 2
    summary = p.stdout.split("Summary (2 datasets")[1].splitlines()[1:]
    assert summary[0].split()[:3] == ["data", "best_model", "chain"]
    assert [line.split()[0] for line in summary[1:3]] == [str(a), str(b)]  # sorted, full path
    narrow = run("fit", str(tmp_path / "cores"), *FAST_FIT, "--quiet")  # (from the cache)
    assert_fits_in_100_columns(narrow.stdout)
    cut = narrow.stdout.split("Summary (2 datasets")[1].splitlines()[2:4]
    paths = [line.split()[0] for line in cut]
    assert all(
        p == str(f) or (p.startswith("...") and str(f).endswith(p[3:]))
        for p, f in zip(paths, (a, b))
    )
    assert all(line.split()[1] == "constant_width" for line in summary[1:3])
    j = run("fit", str(b), str(a), *FAST_FIT, "--json")
    assert j.returncode == 0, j.stderr
    out = json.loads(j.stdout)
    assert [f["data"] for f in out["files"]] == [str(b), str(a)]  # as given
    for row, f in zip(out["summary"], out["files"]):
        assert row["best_model"] == f["ranking"][0]["model"] == "constant_width"
        assert row["rms_complex"] == f["ranking"][0]["rms_complex"] and row["n_points"] == 12


def test_fit_batch_checks_every_file_before_fitting(tmp_path):
    (good,) = _write_cores(tmp_path / "cores", n=1)
    bad = tmp_path / "cores" / "zz_bad.csv"
    bad.write_text("input_v,frequency_hz,df_reported,phase_lead_deg\n0.5,10,abc,3\n")
    p = run("fit", str(tmp_path / "cores"), *FAST_FIT)
    assert_user_error(p, "zz_bad.csv", "df_reported")  # file and column named
    assert p.stdout == ""  # nothing fitted: the bad file was found first
    assert_user_error(run("fit", str(good), str(tmp_path / "nope.csv"), *FAST_FIT), "nope.csv")
    empty = tmp_path / "empty_folder"
    empty.mkdir()
    assert_user_error(run("fit", str(empty)), "no *.csv")


# ------------------------------------------------------------------ clean edges
@pytest.mark.parametrize(
    "args, fragments",
    [
        (("fit", "B.3", "--seed", "-1"), ["--seed", "-1"]),
        (("fit", "B.3", "--seed", str(2**32)), ["--seed"]),
        (("fit", "B.3", "--steps", "1e3"), ["--steps"]),
        (("fit", "B.3", "--source-impedance", "nan"), ["--source-impedance"]),
        (("fit", "B.3", "--geometry", "x" * 5000), ["geometry"]),
        (("fit", "y" * 5000), ["not a usable file name"]),
        (("report", "--seed", "-3"), ["--seed"]),
        (("limit-cycle", "B.1", "--plant", "K/(1+s)", "--gain", "-1"), ["--gain"]),
        (("limit-cycle", "B.1", "--plant", "K/(1+s)", "--gain", "inf"), ["--gain"]),
        (("datasets", "\n"), ["unrecognized"]),  # a line break in a value stays on one line
    ],
)
def test_bad_option_values_are_one_line_and_exit_2(args, fragments):
    assert_user_error(run_here(*args), *fragments)


def test_report_out_must_be_a_usable_folder(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    assert_user_error(run("report", "--quick", "--out", str(a_file)), "--out", "not a folder")
    assert_user_error(run("report", "--quick", "--out", str(a_file / "sub")), "--out", "a_file")
    keep = tmp_path / "mine"
    keep.mkdir()
    (keep / "thesis.tex").write_text("precious")
    assert_user_error(run("report", "--quick", "--out", str(keep)), "not a fitdf report")
    assert (keep / "thesis.tex").read_text() == "precious"
    if os.geteuid() != 0:  # root writes anywhere
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        try:
            assert_user_error(run("report", "--out", str(locked / "r")), "--out", "permission")
        finally:
            locked.chmod(0o700)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc file system here")
def test_report_out_that_cannot_be_written_whatever_the_reason(tmp_path, monkeypatch):
    """Permissions pass but the folder cannot be made (a virtual file system, root or not):
    one line and exit 2 before anything runs; and a write that fails after the run the same."""
    assert_user_error(run_here("report", "--out", "/proc/fitdf-report"), "--out", "/proc")
    import fitdf.report.build as build

    def full_disk(out_dir, **kw):
        raise OSError(28, "No space left on device", str(Path(out_dir).resolve() / "x.png"))

    monkeypatch.setattr(build, "generate_report", full_disk)
    out = tmp_path / "r"
    assert_user_error(run_here("report", "--out", str(out), "--no-cache"), "--out", "No space")


def test_limit_cycle_warns_of_an_unstable_plant(tmp_path):
    args = ("limit-cycle", "B.3", "--plant", "K/(s-1)", "--gain", "10")
    fast = ("--model", "constant_width", "--chain", "winding")
    p = run(*args, *fast)
    assert p.returncode == 0, p.stderr
    assert "Warning: the plant is unstable in open loop" in p.stdout
    assert "does not mean the loop is stable" in " ".join(p.stdout.split())  # (wrapped)
    assert_fits_in_100_columns(p.stdout)
    j = json.loads(run_here(*args, *fast, "--json").stdout)  # (in this process)
    assert len(j["warnings"]) == 1 and "unstable" in j["warnings"][0]
