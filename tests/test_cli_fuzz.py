"""Random option values never crash the command line: exit 0 or 2, one line, no traceback.

Every subcommand gets random values (text, unicode, empty strings, negative, huge and
non-finite numbers, missing and unreadable files, a file where a folder is expected) for
its options, through :func:`fitdf.cli.main` in this process (fast: no interpreter
start-up per call).

What is *not* thrown, so that no example starts a real computation (each would take
seconds to hours):

* ``fit`` and ``limit-cycle`` always get at least one dataset that fails to load (a
  missing file, an empty or malformed CSV, a folder without CSV files, a name that is no
  dataset); every other option is random. Valid data with valid options would fit.
* ``report`` always gets an ``--out`` that cannot be used (a file, a folder under a file,
  an empty path, a folder that is not a report); a usable ``--out`` would build a report.

The functions that would compute (``compare_fits``, the fits of ``limit-cycle``,
``generate_report``) are replaced by a guard during the test: an example reaching one
fails with the arguments, instead of running for minutes.
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import fitdf.inference.ranking
import fitdf.loop.fitted
import fitdf.report.build
from fitdf.cli import main
from fitdf.data.datasets import names

KNOWN = {*names(), "appendix_b"}

#: Values that broke, or could break, an option parser or a loader.
NASTY = [
    "",
    " ",
    "-1",
    "0",
    "-0",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e999",
    "1e-999",
    "4294967295",
    "4294967296",
    "99999999999999999999999999",
    "1_000",
    "0x10",
    "\u0663",  # ARABIC-INDIC DIGIT THREE: int() reads it
    "\uff11",  # FULLWIDTH DIGIT ONE
    "\u202e",
    "é",
    "💥",
    "a" * 5000,
    "a/" * 2000 + "x.csv",
    "--",
    "-",
    "=",
    "K",
    "s",
    "turns=1,od=1mm,id=2mm,height=1mm",
]

numbers = st.one_of(
    st.integers(-(10**30), 10**30).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)
junk = st.one_of(
    st.sampled_from(NASTY),
    numbers,
    st.text(max_size=20),
    st.text(alphabet=st.characters(codec="ascii"), max_size=12),
)


class WouldCompute(Exception):
    pass


def _guard(*args, **kwargs):
    raise WouldCompute(f"an example reached a computation: {args!r} {kwargs!r}")


@pytest.fixture(scope="module")
def bad_paths(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("fuzz")
    a_file = root / "a_file.txt"
    a_file.write_text("not a folder\n")
    empty = root / "empty.csv"
    empty.write_text("")
    bad = root / "bad.csv"
    bad.write_text("input_v,frequency_hz,df_reported,phase_lead_deg\n0.5,10,abc,3\n")
    binary = root / "binary.csv"
    binary.write_bytes(bytes(range(256)))
    no_csv = root / "no_csv"
    no_csv.mkdir()
    bad_dir = root / "bad_dir"
    bad_dir.mkdir()
    (bad_dir / "x.csv").write_text("input_v\n1\n")
    not_report = root / "not_a_report"
    not_report.mkdir()
    (not_report / "keep.txt").write_text("precious\n")
    return {
        "data": [
            str(root / "missing.csv"),
            str(root / "missing_dir" / "x.csv"),
            str(empty),
            str(bad),
            str(binary),
            str(no_csv),
            str(bad_dir),
            str(a_file),
        ],
        "out": ["", str(a_file), str(a_file / "sub"), str(not_report)],
        "file": str(a_file),
    }


def run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # --help and --version (argparse exits with 0)
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def check(argv: list[str]) -> None:
    with (
        mock.patch.object(fitdf.inference.ranking, "compare_fits", _guard),
        mock.patch.object(fitdf.loop.fitted, "fit", _guard),
        mock.patch.object(fitdf.report.build, "generate_report", _guard),
    ):
        code, out, err = run(argv)
    shown = f"argv={argv!r}\nexit {code}\nstdout: {out[-600:]}\nstderr: {err[-600:]}"
    assert "WouldCompute" not in err, shown
    assert code in (0, 2), shown
    for text in (out, err):
        # (the help text mentions "internal errors": look for the message itself)
        assert ": internal error:" not in text and "Traceback" not in text, shown
    if code == 2 and err:
        assert len(err.strip().splitlines()) == 1, shown  # one line


def _not_data(text: str) -> bool:
    """``text`` names no dataset and no existing file (so loading it fails)."""
    if text.strip() in KNOWN:
        return False
    try:
        return not Path(text).exists()
    except (OSError, ValueError):  # too long, NUL byte
        return True


def options(draw, table: dict) -> list[str]:
    """Some of the options in ``table`` (flag -> strategy of values, or None for a switch)."""
    chosen = draw(st.lists(st.sampled_from(sorted(table)), unique=True, max_size=len(table)))
    argv = []
    for flag in chosen:
        values = table[flag]
        if values is None:
            argv.append(flag)
        else:
            argv += [flag, *draw(st.lists(values, min_size=1, max_size=2))]
    return argv


def choice_or_junk(choices):
    """Mostly valid (so that later checks are reached too), sometimes junk."""
    valid = st.sampled_from(choices)
    return st.one_of(valid, valid, valid, junk)


COMMON = {"--json": None, "--quiet": None}
FIT = {
    **COMMON,
    "--method": choice_or_junk(["lsq", "mcmc", "both"]),
    "--models": choice_or_junk(["constant_width", "rayleigh"]),
    "--chain": choice_or_junk(["winding", "voltage", "direct"]),
    "--geometry": junk,
    "--source-impedance": choice_or_junk(["0", "600"]),
    "--seed": choice_or_junk(["0", "7"]),
    "--steps": choice_or_junk(["50", "100"]),
    "--max-steps": choice_or_junk(["50", "5000"]),
    "--rank-by": choice_or_junk(["aicc", "looic"]),
    "--policy": choice_or_junk(["all", "strict"]),
    "--no-cv": None,
    "--cache": junk,
    "--no-cache": None,
}
LIMIT_CYCLE = {
    **COMMON,
    "--gain": choice_or_junk(["1", "10"]),
    "--source-impedance": choice_or_junk(["0", "600"]),
    "--model": choice_or_junk(["constant_width"]),
    "--time-scale": choice_or_junk(["1", "2"]),
    "--chain": choice_or_junk(["winding"]),
    "--seed": choice_or_junk(["0", "7"]),
    "--plot": junk,
}
REPORT = {  # (no --json: the report prints none, results.json is its machine-readable output)
    "--quiet": None,
    "--seed": junk,
    "--quick": None,
    "--scheduler": junk,
    "--cache": junk,
    "--no-cache": None,
    "--replace": None,
}

#: FITDF_FUZZ_EXAMPLES=2000 for a longer search than the default suite's.
FUZZ = settings(
    max_examples=int(os.environ.get("FITDF_FUZZ_EXAMPLES", "40")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)


@FUZZ
@given(data=st.data())
def test_fit_random_options(bad_paths, data):
    good = data.draw(st.lists(st.sampled_from(["B.1", "B.3"]), max_size=1))
    bad = data.draw(
        st.lists(
            st.one_of(st.sampled_from(bad_paths["data"]), junk.filter(_not_data)),
            min_size=1,
            max_size=2,
        )
    )
    check(["fit", *good, *bad, *options(data.draw, FIT)])


@FUZZ
@given(data=st.data())
def test_limit_cycle_random_options(bad_paths, data):
    bad = data.draw(st.one_of(st.sampled_from(bad_paths["data"]), junk.filter(_not_data)))
    plant = data.draw(choice_or_junk(["K/(1+s)", "K/(s-1)", "K/((1+s", "s"]))
    check(["limit-cycle", bad, "--plant", plant, *options(data.draw, LIMIT_CYCLE)])


@FUZZ
@given(data=st.data())
def test_report_random_options(bad_paths, data):
    out = data.draw(st.sampled_from(bad_paths["out"]))
    check(["report", *options(data.draw, REPORT), "--out", out])


@FUZZ
@given(data=st.data())
def test_audit_datasets_models_random_options(bad_paths, data):
    command = data.draw(st.sampled_from(["audit", "datasets", "models"]))
    argv = [command]
    if command == "audit":
        argv.append(data.draw(st.one_of(st.sampled_from([*bad_paths["data"], "B.1"]), junk)))
    if command == "models":  # a law to explain, or none
        argv += data.draw(st.lists(choice_or_junk(["preisach", "cubic_hc"]), max_size=1))
    argv += data.draw(st.lists(st.one_of(st.sampled_from(["--json", "--quiet"]), junk), max_size=2))
    check(argv)


@settings(max_examples=30, deadline=None)
@given(argv=st.lists(junk, max_size=4))
def test_random_words_at_the_top_level(argv):
    """Any words at all (not naming a subcommand first): usage, help or version."""
    assume(not {"datasets", "audit", "models", "fit", "report", "limit-cycle"} & set(argv))
    check(argv)


def test_guard_catches_a_computation():
    """The guard is live: a valid fit reaches it (so the fuzz tests above would notice)."""
    with pytest.raises(AssertionError, match="reached a computation"):
        check(["fit", "B.1", "--models", "constant_width", "--quiet"])
