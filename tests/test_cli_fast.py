"""``fitdf --version`` and every ``--help`` load no numerical stack (they answer at once).

The command line imports what a subcommand needs only when that subcommand runs
(fitdf/cli.py). These tests check *which modules are imported*, not a time, so they do not
depend on the machine's load. The parser's choices (and the words of the selection rule),
written out in fitdf/cli_parser.py for that reason, must stay those of the library. And
ArviZ's refactor notice, not about the user's result, never reaches the terminal
(fitdf/_arviz.py).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from matplotlib.backend_bases import FigureCanvasBase

from fitdf import cli_parser
from fitdf.chains import chain_names
from fitdf.inference.api import DEFAULT_CHAIN
from fitdf.inference.ranking import METHOD_CHOICES, RANK_COLUMNS
from fitdf.inference.selection import ROWS_RULE
from fitdf.params import DIMENSIONLESS

HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "numba", "lmfit", "emcee", "arviz", "control")
SUBCOMMANDS = ("datasets", "audit", "models", "fit", "report", "limit-cycle")

#: Runs in a fresh interpreter: ``python -m fitdf`` for each argv, then the modules loaded.
PROBE = textwrap.dedent(
    """
    import contextlib, io, json, runpy, sys
    codes = []
    for argv in json.loads(sys.argv[1]):
        sys.argv = ["fitdf", *argv]
        out = io.StringIO()
        try:
            with contextlib.redirect_stdout(out):
                runpy.run_module("fitdf", run_name="__main__", alter_sys=True)
        except SystemExit as exc:
            codes.append([exc.code, out.getvalue()[:40]])
    print(json.dumps({"codes": codes, "modules": sorted(sys.modules)}))
    """
)


def _probe(argvs: list[list[str]]) -> dict:
    run = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(argvs)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout)


#: The modules the command line loads before a subcommand runs: standard library only.
LIGHT = {
    "fitdf",
    "fitdf.__main__",
    "fitdf.cli",
    "fitdf.cli_parser",
    "fitdf.errors",
    "fitdf.stop_signals",
    "fitdf.inference",
    "fitdf.inference.convergence",
}


def test_version_and_help_import_no_numerical_stack():
    argvs = [["--version"], ["--help"], *([c, "--help"] for c in SUBCOMMANDS)]
    found = _probe(argvs)
    assert [c for c, _ in found["codes"]] == [0] * len(argvs)
    assert found["codes"][0][1].startswith("fitdf ")  # --version answered
    heavy = sorted(m for m in found["modules"] if m.split(".")[0] in HEAVY)
    assert not heavy, f"--version/--help imported {heavy}"
    own = [m for m in found["modules"] if m.startswith("fitdf")]
    assert set(own) <= LIGHT, own


def test_a_bad_option_value_fails_before_the_numerical_stack_loads():
    found = _probe([["fit", "B.3", "--seed", "-1"], ["report", "--seed", "x"]])
    assert [c for c, _ in found["codes"]] == [2, 2]
    assert not [m for m in found["modules"] if m.split(".")[0] in HEAVY]


#: What ``fitdf fit`` imports only once every file it is given has been read and checked.
FITTING_STACK = ("lmfit", "emcee", "arviz", "matplotlib", "fitdf.inference", "fitdf.report")


def test_bad_data_fail_before_the_fitting_stack_loads(tmp_path):
    """A bad file, a missing one, a folder with a bad file: one-line errors (exit 2) from the
    data layer alone, not after ~5 s of importing the fitting stack (``cmd_fit_checked``)."""
    bad = tmp_path / "cores" / "zz_bad.csv"
    bad.parent.mkdir()
    bad.write_text("input_v,frequency_hz,df_reported,phase_lead_deg\n0.5,10,abc,3\n")
    found = _probe(
        [["fit", str(bad)], ["fit", str(tmp_path / "nope.csv")], ["fit", str(bad.parent)]]
    )
    assert [c for c, _ in found["codes"]] == [2, 2, 2]
    loaded = [m for m in found["modules"] if m.startswith(FITTING_STACK) and m not in LIGHT]
    assert not loaded, loaded
    assert (
        "fitdf.data.resolve" in found["modules"]
    )  # (the data were read: the probe is not vacuous)


def test_a_least_squares_fit_and_a_limit_cycle_load_neither_arviz_nor_the_report():
    """ArviZ (1-3 s to import) is for MCMC, LOO and corner plots only, the report's stack for
    the report: ``fitdf fit --method lsq`` and ``fitdf limit-cycle`` import neither
    (``fitdf._arviz.arviz``, ``fitdf.plots.posterior._corner``, ``fitdf.executor``)."""
    fast = ["--chain", "winding", "--quiet"]
    fit = ["fit", "B.1", "--models", "constant_width", "--method", "lsq", "--no-cv", *fast]
    cycle = ["limit-cycle", "B.1", "--plant", "K/((1+s)(1+0.25s)(1+1.1s))", "--gain", "100", *fast]
    found = _probe([fit, [*cycle, "--model", "constant_width"]])
    assert [c for c, _ in found["codes"]] == [0, 0]
    # (it fitted and drew: the probe is not vacuous)
    assert {"fitdf.inference.lsq", "fitdf.loop.fitted", "fitdf.plots"} <= set(found["modules"])
    loaded = [m for m in found["modules"] if m.startswith(("arviz", "corner", "fitdf.report"))]
    assert not loaded, loaded


def test_python_dash_m_fitdf_prints_the_version():
    run = subprocess.run(
        [sys.executable, "-m", "fitdf", "--version"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0 and run.stdout.startswith("fitdf "), run.stderr


def test_parser_choices_are_the_librarys():
    assert cli_parser.DIMENSIONLESS_UNIT == DIMENSIONLESS
    assert sorted(cli_parser.CHAIN_CHOICES) == sorted(chain_names())
    assert cli_parser.DEFAULT_CHAIN == DEFAULT_CHAIN
    assert tuple(cli_parser.METHOD_CHOICES) == tuple(METHOD_CHOICES)
    assert tuple(cli_parser.RANK_CHOICES) == tuple(RANK_COLUMNS)
    assert cli_parser.ROWS_RULE == ROWS_RULE
    formats = FigureCanvasBase.get_supported_filetypes()
    assert sorted(cli_parser.PLOT_FORMATS) == sorted(formats)


def test_largest_seed_is_numpys():
    np.random.RandomState(cli_parser.MAX_SEED)
    np.random.default_rng(cli_parser.MAX_SEED)
    with pytest.raises(ValueError):
        np.random.RandomState(cli_parser.MAX_SEED + 1)


def test_arvizs_refactor_notice_is_filtered_and_nothing_else(tmp_path):
    """ArviZ warns once a day on import (a stamp in the user's cache): a fresh cache shows it.

    Both ways fitdf imports ArviZ stay quiet: on first use (``fitdf._arviz.arviz``, the
    MCMC diagnostics) and through ``corner`` (the corner plots)."""
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache"), "PYTHONWARNINGS": "always"}

    def stderr_of(code: str) -> str:
        shutil.rmtree(tmp_path / "cache", ignore_errors=True)  # fresh: the notice is due
        run = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env
        )
        assert run.returncode == 0, run.stderr[-2000:]
        return run.stderr

    assert "ArviZ is undergoing a major refactor" in stderr_of("import arviz")  # the control
    for imports in (
        "import fitdf.inference.mcmc as m; m.arviz()",
        "import fitdf.plots.posterior as p; p._corner()",
    ):
        quiet = stderr_of(f"import warnings; warnings.warn('still shown', UserWarning); {imports}")
        assert "ArviZ is undergoing" not in quiet and "still shown" in quiet, (imports, quiet)
