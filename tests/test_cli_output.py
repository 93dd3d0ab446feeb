"""What the command line shows a terminal: every command's output and help within 100
columns, a reader that goes away (``| head -1``) ending the command normally, output paths
refused before any work, law names in any case with a suggestion, and errors that say what
they saw in the user's units.

The cheap cases run :func:`fitdf.cli.main` in this process (``run_here``); the closed pipe
needs a process of its own.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import pandas as pd
import pytest
from test_cli import CHECKOUT, FITDF, assert_user_error, run_here

import fitdf.loop.fitted
from fitdf.data.cores import CoreGeometry
from fitdf.errors import OptionError
from fitdf.inference import convergence, ranking, selection
from fitdf.inference.presentation import checks_text, ranking_text
from fitdf.models import get_model, law_name

WIDTH = 100
#: Cheap fits: one law through the winding chain in this process, no cross-validation.
FAST = ("--models", "constant_width", "--chain", "winding", "--no-cv", "--workers", "1")
FAST_CYCLE = ("--model", "constant_width", "--chain", "winding", "--no-cache")
PLANT = "K/((1+s)(1+0.25s)(1+1.1s))"


def widest(text: str) -> int:
    return max(map(len, text.splitlines()), default=0)


@pytest.fixture
def user_csv(tmp_path):
    """A user's CSV with an output column but no footnote factor."""
    path = tmp_path / "mycore.csv"
    rows = ["input_v,frequency_hz,df_reported,phase_lead_deg,h1_output_v"]
    rows += ["0.2,5,0.5,30,0.1", "0.5,5,0.7,15,0.35", "1.0,5,0.8,8,0.8", "2,5,0.6,20,1.2"]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    "command",
    [
        (),
        ("datasets",),
        ("audit",),
        ("models",),
        ("fit",),
        ("report",),
        ("limit-cycle",),
    ],
)
def test_every_help_fits_in_100_columns_on_a_wide_terminal(command, monkeypatch):
    monkeypatch.setenv("COLUMNS", "300")  # (argparse would fill the terminal's width)
    p = run_here(*command, "--help")
    assert p.returncode == 0 and "usage:" in p.stdout
    assert widest(p.stdout) <= WIDTH, max(p.stdout.splitlines(), key=len)


@pytest.mark.parametrize(
    "command",
    [
        ("datasets",),
        ("audit",),
        ("audit", "B.1"),
        ("audit", "B.5"),
        ("models",),
        ("models", "jiles_atherton"),
        ("fit", "B.3", *FAST),
        ("limit-cycle", "B.1", "--plant", PLANT, "--gain", "100", "500", *FAST_CYCLE),
    ],
)
def test_every_command_prints_within_100_columns_and_wide_prints_more(command):
    p = run_here(*command, "--quiet")
    assert p.returncode == 0, p.stderr
    assert widest(p.stdout) <= WIDTH, max(p.stdout.splitlines(), key=len)
    assert len(p.stdout.splitlines()) > 3  # (it printed something)
    if command[0] in ("datasets", "audit"):  # their tables' own columns, a row per line
        assert widest(run_here(*command, "--wide").stdout) > WIDTH


def test_the_audit_of_a_users_csv_prints_only_what_applies(user_csv):
    """No footnote factor in a user's CSV: no factor table of empty cells (the finding says
    what the rows follow); the thesis's tables keep theirs, shift columns only where a column
    is shifted."""
    p = run_here("audit", str(user_csv))
    assert p.returncode == 0, p.stderr
    assert "DF factor per block" not in p.stdout
    assert "NaN" not in p.stdout and "None" not in p.stdout
    assert "no footnote factor; the data follow DF = 1.000 x output / input" in p.stdout
    b1 = run_here("audit", "B.1").stdout
    assert "DF factor per block" in b1 and "shift 10^" in b1  # (B.1's h1 column at 3 c/s)
    b3 = run_here("audit", "B.3").stdout
    assert "DF factor per block" in b3 and "shift 10^" not in b3


# ------------------------------------------------------------------ a closed pipe
def _terminal_env() -> dict:
    """The environment of a user's shell: stdout buffered as Python buffers a pipe (without
    PYTHONUNBUFFERED, a short output waits in the buffer for the interpreter's last flush),
    the checkout's package first."""
    path = os.pathsep.join(filter(None, (CHECKOUT, os.environ.get("PYTHONPATH"))))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return {**env, "PYTHONWARNINGS": "ignore", "PYTHONPATH": path}


def _with_reader_gone(*args, timeout=300):
    """``fitdf ARGS`` writing into a pipe whose reader has already gone (the end of
    ``| head -1``, without the race: every write meets a closed pipe)."""
    read, write = os.pipe()
    os.close(read)
    env = _terminal_env()
    try:
        proc = subprocess.run(
            [FITDF, *args],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            timeout=timeout,
            env=env,
        )
    finally:
        os.close(write)
    return proc


@pytest.mark.parametrize(
    "args",
    [
        ("audit", "B.5"),
        ("datasets",),
        ("models",),
        ("fit", "--help"),
        ("--version",),  # (a short text: left in the buffer for the last flush)
        ("fit", "B.3", *FAST, "--quiet"),
    ],
)
def test_a_closed_pipe_is_a_normal_exit(args):
    proc = _with_reader_gone(*args)
    assert proc.returncode == 0, proc.stderr
    assert "internal error" not in proc.stderr and "Exception ignored" not in proc.stderr
    assert "BrokenPipe" not in proc.stderr


def test_head_dash_1_prints_the_first_line_and_exits_0():
    """As a user types it."""
    shell = f"set -o pipefail; '{FITDF}' audit B.5 | head -1"
    proc = subprocess.run(
        ["bash", "-c", shell], capture_output=True, text=True, timeout=300, env=_terminal_env()
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "92 rows, 22 flagged, 3 excluded by default\n"
    assert proc.stderr == ""


# ------------------------------------------------------------------ output paths first
def _no_fitting(*args, **kw):
    raise AssertionError("fitted before the output path was checked")


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="no /proc file system here")
@pytest.mark.parametrize(
    "plot, fragments",
    [
        ("/proc/fitdf-loci.png", ["--plot", "write in /proc"]),  # root or not
        ("{tmp}/no/such/folder/loci.png", ["--plot", "does not exist"]),
        ("{tmp}/loci.xyz", ["--plot", ".xyz", "png"]),  # a format matplotlib cannot write
        ("{tmp}", ["--plot", "is a folder"]),
    ],
)
def test_an_unwritable_plot_is_refused_before_any_fit(plot, fragments, tmp_path, monkeypatch):
    monkeypatch.setattr(fitdf.loop.fitted, "fitted_limit_cycles", _no_fitting)
    monkeypatch.setattr(fitdf.loop.fitted, "fit", _no_fitting)
    args = ("limit-cycle", "B.1", "--plant", PLANT, "--plot", plot.format(tmp=tmp_path))
    assert_user_error(run_here(*args), *fragments)


def test_a_writable_plot_passes_the_check_and_reaches_the_fits(tmp_path, monkeypatch):
    """(The control: with the same stand-in, a good path gets as far as fitting.)"""
    monkeypatch.setattr(fitdf.loop.fitted, "fitted_limit_cycles", _no_fitting)
    p = run_here("limit-cycle", "B.1", "--plant", PLANT, "--plot", str(tmp_path / "loci.svg"))
    assert p.returncode == 1 and "fitted before the output path" in p.stderr
    assert not (tmp_path / "loci.svg").exists()


# ------------------------------------------------------------------ law names
@pytest.mark.parametrize("given", ["Preisach", "PREISACH", "preisach", " preisach"])
def test_law_names_are_case_insensitive(given):
    assert law_name(given) == "preisach" and get_model(given).name == "preisach"


def test_the_command_line_takes_a_law_in_any_case(monkeypatch):
    def stop(data, models=None, **kw):
        raise OptionError(f"would fit {models}")

    monkeypatch.setattr(ranking, "compare_fits", stop)
    p = run_here(
        "fit", "B.3", "--models", "Constant_Width", "RAYLEIGH", "--no-cache", "--workers", "1"
    )
    assert_user_error(p, "would fit ['constant_width', 'rayleigh']")
    shown = run_here("models", "Jiles_Atherton")
    assert shown.returncode == 0 and shown.stdout.startswith("jiles_atherton:")


@pytest.mark.parametrize(
    "args, option",
    [
        (("fit", "B.3", "--models", "preisack"), "--models"),
        (("fit", "B.3", "--models", "rayleigh", "Preisak"), "--models"),
        (("models", "preisack"), "LAW"),
        (("limit-cycle", "B.1", "--plant", PLANT, "--model", "PreiSack"), "--model"),
    ],
)
def test_a_misspelt_law_gets_a_suggestion(args, option):
    assert_user_error(
        run_here(*args), option, "unknown law", "(did you mean 'preisach'?)", "rayleigh"
    )


def test_a_law_unlike_any_gets_the_list_without_a_guess():
    p = run_here("fit", "B.3", "--models", "zzz")
    assert_user_error(p, "unknown law 'zzz'", "known laws: constant_width")
    assert "did you mean" not in p.stderr


# ------------------------------------------------------------------ what the errors saw
def test_od_below_id_is_said_in_the_users_units():
    p = run_here("fit", "B.1", "--geometry", "turns=10,od=1in,id=30mm,height=5mm")
    assert_user_error(p, "od=1in must be larger than id=30mm")
    with pytest.raises(OptionError, match="outside 20 mm, inside 30 mm, height 5 mm"):
        CoreGeometry.from_dimensions(10, 0.020, 0.030, 0.005)


@pytest.mark.parametrize(
    "cell, said",
    [
        ("n/a", "the cell reads 'n/a', a missing value"),
        ("--", "the cell reads '--', a missing value"),
        ("", "the cell is empty"),
    ],
)
def test_a_missing_value_is_named_as_what_it_is(cell, said, tmp_path):
    path = tmp_path / "core.csv"
    path.write_text(
        f"input_v,frequency_hz,df_reported,phase_lead_deg\n0.2,5,0.5,30\n0.5,5,{cell},15\n"
    )
    assert_user_error(run_here("fit", str(path)), "core.csv", "row 2", "df_reported", said)


def test_the_python_module_entry_points_still_run():
    """``python -m fitdf.cli`` (the tests' own subprocesses use it) and ``python -m fitdf``."""
    for module in ("fitdf.cli", "fitdf"):
        proc = subprocess.run(
            [sys.executable, "-m", module, "--version"], capture_output=True, text=True, timeout=120
        )
        assert proc.returncode == 0 and proc.stdout.startswith("fitdf "), proc.stderr


# ------------------------------------------------------------------ the job cache
def test_limit_cycle_keeps_its_fits_as_fit_does(tmp_path):
    """The second call reads the fit from the cache (the same numbers, to the bit), and says
    so on stderr within 100 columns; --no-cache computes it again and says nothing."""
    args = ("limit-cycle", "B.1", "--plant", PLANT, "--gain", "100", "500")
    args += ("--model", "constant_width", "--chain", "winding", "--quiet", "--json")
    first = run_here(*args, "--cache", str(tmp_path))
    again = run_here(*args, "--cache", str(tmp_path))
    assert first.returncode == again.returncode == 0, first.stderr
    assert first.stdout == again.stdout  # (JSON: every number)
    assert first.stderr == again.stderr == ""  # (--quiet: no note)
    loud = run_here(*args[:-2], "--json", "--cache", str(tmp_path))
    note = " ".join(loud.stderr.split())
    assert "fitdf limit-cycle: 1 of 1 fits read from" in note and str(tmp_path) in note
    assert max(map(len, loud.stderr.splitlines())) <= WIDTH
    fresh = run_here(*args[:-2], "--json", "--no-cache")
    assert fresh.stderr == "" and fresh.stdout == first.stdout


# ------------------------------------------------------------------ rules rendered once
def test_the_rules_the_text_states_are_rendered_from_their_constants():
    """The tie rules and the convergence rules, as the ranking's legend, the posterior checks
    and ``fit --help`` state them, are the thresholds that apply them."""
    assert selection.TIE_RULES == {
        "lsq": f"AICc within {selection.TIE_AICC:g}",
        "mcmc": f"elpd_loo within {selection.TIE_LOO_SE:g} standard errors of the difference",
        "nested": f"2 ln B < {selection.TIE_TWO_LN_B:g} (a Bayes factor below "
        f"{math.exp(selection.TIE_TWO_LN_B / 2):.3g})",
    }
    assert convergence.CONVERGED == {
        "nested": f">= {convergence.MIN_EFFECTIVE} effective draws, evidence error <= "
        f"{convergence.MAX_LOG_EVIDENCE_ERROR:g}",
        "mcmc": f"{convergence.MIN_STEPS_OVER_TAU} autocorrelation times, R-hat < "
        f"{convergence.RHAT_MAX:g}, bulk ESS >= {convergence.MIN_ESS}",
    }
    table = pd.DataFrame(
        [
            {"rank": 1, "model": "a", "chain": "voltage", "method": m, "n_params": 3}
            for m in ("lsq", "nested")
        ]
    )
    legend = " ".join(ranking_text(table).split())
    assert f"least squares: {selection.TIE_RULES['lsq']}" in legend
    assert f"nested sampling: {selection.TIE_RULES['nested']}" in legend

    class Fit:  # the fields checks_text reads
        model, chain, method = "a", "voltage", "nested"
        diagnostics = {
            "converged": True,
            "log_evidence": -12.345,
            "log_evidence_error": 0.123,
            "n_effective": 512.0,
            "n_likelihood_evaluations": 40000.0,
        }

    text = checks_text([Fit()])
    assert f"(converged: {convergence.CONVERGED['nested']}):" in " ".join(text.split())
    assert text.splitlines()[-1].split() == [
        "a",
        "voltage",
        "yes",
        "-12.35",
        "+-",
        "0.12",
        "512",
        "40000",
    ]
    helped = " ".join(run_here("fit", "--help").stdout.split())
    assert convergence.CONVERGED["mcmc"] in helped
