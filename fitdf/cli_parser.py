"""The parser of the ``fitdf`` command line: one builder per subcommand, and the option values
it accepts.

Standard library only (and the rule texts of :mod:`fitdf.inference.convergence`, which is),
so that ``fitdf --version`` and every ``--help`` answer without loading numpy, pandas or the
fitting stack. The choices the parser offers are therefore written out here;
tests/test_cli_fast.py checks them against the library. Help is formatted within 100
columns (fewer on a narrower terminal); the docs' command-line reference is rendered from
:func:`build_parser` (docs/_ext/fitdf_cli.py).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import tempfile
from pathlib import Path

from fitdf import __version__
from fitdf.errors import OptionError
from fitdf.inference.convergence import CONVERGED, MIN_STEPS_OVER_TAU

#: Measurement chains (``fitdf.chains.chain_names()``) and the default chain
#: (``fitdf.inference.api.DEFAULT_CHAIN``).
CHAIN_CHOICES = ("direct", "winding", "voltage", "dynamic")
DEFAULT_CHAIN = "voltage"
#: ``fitdf.inference.ranking.METHOD_CHOICES`` and ``RANK_COLUMNS``.
METHOD_CHOICES = ("lsq", "mcmc", "nested", "both")
RANK_CHOICES = (
    "rms_complex",
    "rms_magnitude",
    "rms_phase_deg",
    "redchi",
    "aicc",
    "bic",
    "looic",
    "waic",
    "cv_rms_complex",
    "n_params",
    "log_evidence",
)
#: Noise laws (``fitdf.inference.noise_models.NOISE_LAWS``; the first is the default) and
#: those MCMC takes (``fitdf.inference.api.MCMC_NOISE``).
NOISE_CHOICES = ("printed", "constant", "reading", "student", "reading-student")
MCMC_NOISE = ("printed", "constant")
#: Row policies (``fitdf.data.audit.POLICIES``; the first is the default) and the other
#: names they answer to (``fitdf.data.audit.POLICY_ALIASES``).
POLICY_CHOICES = ("trusted", "reordered", "as_printed", "all", "strict")
POLICY_ALIASES = {"default": POLICY_CHOICES[0]}
#: How a dimensionless unit is printed (``fitdf.params.DIMENSIONLESS``).
DIMENSIONLESS_UNIT = "-"
#: ``fitdf.inference.selection.ROWS_RULE``.
ROWS_RULE = "AICc needs two numbers a row, at least the parameters plus two"
#: The image formats ``--plot`` writes: matplotlib's ``savefig`` formats (by the file's suffix).
PLOT_FORMATS = (
    "avif",
    "eps",
    "gif",
    "jpeg",
    "jpg",
    "pdf",
    "pgf",
    "png",
    "ps",
    "raw",
    "rgba",
    "svg",
    "svgz",
    "tif",
    "tiff",
    "webp",
)
#: numpy's legacy ``RandomState`` (the MCMC's walkers) takes seeds below 2**32.
MAX_SEED = 2**32 - 1
MAX_STEPS = 1_000_000  #: longest MCMC chain (per walker) the command line accepts
SEED_HELP = f"seed of every random choice, 0..{MAX_SEED} (default 0)"
#: The widest help (``fitdf._text.TEXT_WIDTH``; a narrower terminal narrows it).
HELP_WIDTH = 100


class UsageError(Exception):
    """A command line argparse cannot parse (one line, exit code 2)."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit code 2)."""

    def error(self, message):
        raise UsageError(f"{self.prog}: {message}")


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Help within :data:`HELP_WIDTH` columns, or the terminal's width if narrower; the
    descriptions and examples as written (each line of them within 100 columns)."""

    def __init__(self, prog, **kw):
        kw.setdefault("width", min(shutil.get_terminal_size().columns - 2, HELP_WIDTH))
        super().__init__(prog, **kw)


# ------------------------------------------------------------------ option values
# argparse ``type=`` functions: a bad value is argparse's one-line usage error (exit 2)
# naming the option ("argument --seed: ..."). Numbers are ASCII decimals only, as the CSV
# loader reads them (float() would also take "nan", "1_0" and non-ASCII digits).
_INT = r"[+-]?[0-9]+"
_FLOAT = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"


def _parse_number(text: str, pattern: str, kind: str):
    if not re.fullmatch(pattern, text.strip(), flags=re.ASCII):
        raise argparse.ArgumentTypeError(f"expected {kind}, got {text!r}")
    try:
        value = int(text) if pattern is _INT else float(text)
    except (ValueError, OverflowError):  # e.g. more digits than Python converts
        raise argparse.ArgumentTypeError(f"expected {kind}, got {text[:40]!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite {kind}, got {text[:40]!r}")
    return value


def seed_value(text: str) -> int:
    """A seed: an integer 0..2**32-1 (numpy's ``RandomState`` limit)."""
    value = _parse_number(text, _INT, "an integer seed")
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"a seed is an integer from 0 to {MAX_SEED}, got {text}")
    return value


def policy_value(text: str) -> str:
    """A row policy's name (an alias resolved)."""
    name = POLICY_ALIASES.get(text, text)
    if name not in POLICY_CHOICES:
        raise argparse.ArgumentTypeError(
            f"unknown row policy {text[:40]!r}; choose one of {', '.join(POLICY_CHOICES)} "
            f"({POLICY_CHOICES[0]} is the default; reordered also takes the columns the audit "
            "reads as printed in reverse order reversed)"
        )
    return name


def count_value(low: int, high: int, what: str):
    """An integer ``low..high`` (steps, walkers, workers)."""

    def parse(text: str) -> int:
        value = _parse_number(text, _INT, f"an integer number of {what}")
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"the number of {what} must be from {low} to {high}, got {text}"
            )
        return value

    parse.__name__ = what  # argparse names the type in some messages
    return parse


def number_value(low: float = -float("inf"), *, strict: bool = False, what: str = "number"):
    """A finite float ``>= low`` (``> low`` when ``strict``)."""

    def parse(text: str) -> float:
        value = _parse_number(text, _FLOAT, f"a {what}")
        if value < low or (strict and value == low):
            bound = f"{'above' if strict else 'at least'} {low:g}"
            raise argparse.ArgumentTypeError(f"the {what} must be {bound}, got {text}")
        return value

    parse.__name__ = what
    return parse


# ------------------------------------------------------------------ output paths
def _probe(folder: Path) -> None:
    """Make and remove a folder in ``folder``: permissions are not the only reason a write
    fails (a read-only or virtual file system such as /proc, a full disk, root's access)."""
    os.rmdir(tempfile.mkdtemp(prefix=".fitdf-probe-", dir=folder))


def check_output_folder(option: str, path: str, *, replaced: bool = False) -> Path:
    """An output folder that can be created or written, named in a one-line error if not.

    ``replaced``: the command replaces the folder as a whole (``fitdf report``), so an
    existing folder must be empty or a previous report (holding ``results.json``).
    """
    if not str(path).strip():
        raise OptionError(f"{option}: empty path")
    try:
        target = Path(path).expanduser().resolve()
        if target.exists() and not target.is_dir():
            raise OptionError(f"{option} {path}: is a file, not a folder")
        if replaced and target.is_dir():
            if target == target.parent or target == Path.home().resolve():
                raise OptionError(f"{option} {path}: refusing to replace {target}")
            if any(target.iterdir()) and not (target / "results.json").is_file():
                raise OptionError(
                    f"{option} {path}: an existing folder that is not a fitdf report "
                    "(the report replaces its folder as a whole); choose a new or empty folder"
                )
        # the report writes beside the folder, then renames: the parent must be writable
        base = target.parent if replaced or not target.exists() else target
        while not base.exists():
            base = base.parent
        if not base.is_dir():
            raise OptionError(f"{option} {path}: {base} is a file, not a folder")
        if not os.access(base, os.W_OK | os.X_OK):
            raise OptionError(f"{option} {path}: no permission to write in {base}")
        _probe(base)
    except OptionError:
        raise
    except (OSError, ValueError) as exc:  # name too long, NUL byte, unreadable parent, ...
        reason = getattr(exc, "strerror", None) or exc
        raise OptionError(f"{option} {path!r}: not a folder fitdf can write ({reason})") from None
    return target


def check_output_file(option: str, path: str, formats=None) -> Path:
    """A file the command can write: not a folder, in an existing folder it can write in (made
    and removed there to be sure), and with ``formats``, a suffix among them (or none)."""
    if not str(path).strip():
        raise OptionError(f"{option}: empty path")
    suffix = Path(path).suffix.lower().lstrip(".")
    if formats is not None and suffix and suffix not in formats:
        raise OptionError(
            f"{option} {path}: cannot write a .{suffix} file; the suffix names the format, one "
            f"of {', '.join(formats)}"
        )
    folder = None
    try:
        target = Path(path).expanduser().resolve()
        if target.is_dir():
            raise OptionError(f"{option} {path}: is a folder, not a file")
        folder = target.parent
        if not folder.is_dir():
            what = "is a file" if folder.exists() else "does not exist"
            raise OptionError(f"{option} {path}: the folder {folder} {what}")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise OptionError(f"{option} {path}: no permission to write in {folder}")
        _probe(folder)
        if target.exists():
            open(target, "ab").close()  # (nothing written: the file stays as it is)
    except OptionError:
        raise
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or exc
        where = "not a file name fitdf can use" if folder is None else f"cannot write in {folder}"
        raise OptionError(f"{option} {path!r}: {where} ({reason})") from None
    return target


def validate(args) -> None:
    """Checks before anything is imported or computed (each value alone passed its ``type=``).

    Output paths are checked here, not when the output is written after minutes of fitting.
    """
    if args.command == "report":
        check_output_folder("--out", args.out, replaced=True)
    if getattr(args, "cache", None) is not None and not args.no_cache:
        check_output_folder("--cache", args.cache)
    if getattr(args, "plot", None) is not None:
        check_output_file("--plot", args.plot, PLOT_FORMATS)
    if getattr(args, "posterior_out", None) is not None:
        if args.method == "lsq":
            raise OptionError("--posterior-out needs a posterior: --method nested, mcmc or both")
        check_output_folder("--posterior-out", args.posterior_out)
    if getattr(args, "max_steps", None) is not None and args.max_steps < args.steps:
        raise OptionError("--max-steps must be at least --steps")
    if (
        getattr(args, "rank_by", None) in ("looic", "waic")
        and getattr(args, "method", "mcmc") == "lsq"
    ):
        raise OptionError(f"--rank-by {args.rank_by} needs --method nested, mcmc or both")
    if getattr(args, "rank_by", None) == "log_evidence" and args.method not in ("nested", "both"):
        raise OptionError("--rank-by log_evidence needs --method nested or both")
    if getattr(args, "noise", MCMC_NOISE[0]) not in MCMC_NOISE and args.method in ("mcmc", "both"):
        raise OptionError(f"--noise {args.noise} needs --method lsq or nested")


# ------------------------------------------------------------------ shared options
def _subcommand(sub, name, help, examples, notes="", json=True):
    """A subcommand with its examples (each line within 100 columns) and ``--json``,
    ``--quiet``."""
    sp = sub.add_parser(
        name,
        help=help,
        description=help,
        formatter_class=_Formatter,
        epilog="examples:\n" + "\n".join(f"  {e}" for e in examples) + notes,
    )
    if json:
        sp.add_argument("--json", action="store_true", help="print JSON on stdout instead of text")
    sp.add_argument("--quiet", action="store_true", help="no progress bars")
    return sp


def _add_wide(sp, what: str) -> None:
    sp.add_argument(
        "--wide",
        action="store_true",
        help=f"print every column of {what} (default: within 100 columns)",
    )


def _add_cache_options(sp, key: str) -> None:
    """``--cache DIR`` and ``--no-cache`` (:mod:`fitdf.jobcache`); ``key``: what the key covers
    besides code, data and machine."""
    kept = sp.add_mutually_exclusive_group()
    kept.add_argument(
        "--cache",
        default=os.environ.get("FITDF_CACHE_DIR") or None,
        metavar="DIR",
        help="keep finished fits here, so that a stopped or repeated run goes on from them "
        f"(default: FITDF_CACHE_DIR, else ~/.cache/fitdf/jobs; the key covers {key}, "
        "code, data and machine)",
    )
    kept.add_argument(
        "--no-cache", action="store_true", help="compute every fit, keep none (for timings)"
    )


def _add_scheduler(sp, help: str) -> None:
    sp.add_argument(
        "--scheduler",
        default=os.environ.get("FITDF_SCHEDULER") or None,
        metavar="ADDRESS",
        help=help,
    )


def _add_source_impedance(sp, help: str) -> None:
    sp.add_argument(
        "--source-impedance",
        type=number_value(0.0, what="source impedance"),
        default=None,
        metavar="OHM",
        help=help,
    )


# ------------------------------------------------------------------ subcommands
def _datasets_parser(sub) -> None:
    sp = _subcommand(
        sub,
        "datasets",
        "list the bundled datasets with row counts per frequency",
        ["fitdf datasets", "fitdf datasets --json"],
    )
    _add_wide(sp, "the table")


def _audit_parser(sub) -> None:
    sp = _subcommand(
        sub,
        "audit",
        "audit the printed tables row by row and show the flagged rows",
        ["fitdf audit", "fitdf audit B.1", "fitdf audit my_core.csv --json"],
    )
    sp.add_argument(
        "data",
        nargs="?",
        default="appendix_b",
        help="dataset, core or CSV path (default: all of Appendix B)",
    )
    _add_wide(sp, "the tables, a row per line")


def _models_parser(sub) -> None:
    sp = _subcommand(
        sub,
        "models",
        "list the candidate models (hysteresis laws), or explain one law",
        ["fitdf models", "fitdf models preisach", "fitdf models --json"],
    )
    sp.add_argument(
        "law",
        nargs="?",
        default=None,
        metavar="LAW",
        help="a law to explain: its equations, each parameter with unit, bounds and meaning, "
        "and the measurement chains' parameters (default: list every law)",
    )


#: ``fitdf fit --help``'s note on the CSV format (each line within 100 columns).
CSV_NOTE = (
    "\n\nCSV file: columns input_v (V peak), frequency_hz (Hz), df_reported (|DF|, V/V),\n"
    "phase_lead_deg (degree, output leads input), optional source_impedance_ohm (ohm, default 0);\n"
    "see datasets/README.md"
)


def _fit_parser(sub) -> None:
    sp = _subcommand(
        sub,
        "fit",
        "fit every model to a core and print the ranking",
        [
            "fitdf fit permalloy",
            "fitdf fit B.3 --method both --steps 2000",
            "fitdf fit deltamax --source-impedance 600 --models constant_width rayleigh --json",
            "fitdf fit core1.csv core2.csv --method lsq   # a summary table after the rankings",
            "fitdf fit measurements/ --json               # every *.csv of the folder",
        ],
        notes=CSV_NOTE,
    )
    sp.add_argument(
        "data",
        nargs="+",
        help="core name (permalloy, deltamax, supermalloy), table (B.1..B.5), CSV file (format "
        "below) or a folder of CSV files; several (or a folder) are ranked one by one, then "
        "summarised",
    )
    _fit_model_options(sp)
    _fit_data_options(sp)
    _fit_sampling_options(sp)
    _fit_run_options(sp)
    _fit_output_options(sp)


def _fit_model_options(sp) -> None:
    """What ``fitdf fit`` fits and how it ranks: method, laws, chains, geometry, order."""
    sp.add_argument(
        "--method",
        choices=METHOD_CHOICES,
        default="lsq",
        help="lsq: least squares (default); nested: the posterior and its evidence by nested "
        "sampling (nautilus); mcmc: the posterior by emcee; both: lsq and nested",
    )
    sp.add_argument(
        "--models",
        nargs="+",
        metavar="MODEL",
        help="laws to fit, in any case (default: all; fitdf models lists them)",
    )
    sp.add_argument(
        "--chain",
        nargs="+",
        default=[DEFAULT_CHAIN],
        choices=CHAIN_CHOICES,
        help=f"measurement chain(s) (default: {DEFAULT_CHAIN}; winding is its sinusoidal-current "
        "approximation)",
    )
    sp.add_argument(
        "--geometry",
        default=None,
        metavar="SPEC",
        help="the core's turns and dimensions for a user's CSV, e.g. "
        '"turns=1250,od=63.5mm,id=50.8mm,height=12.7mm[,stacking=0.85][,r_winding=54]" or a file '
        "of such lines (default: Appendix A for a thesis core, else none)",
    )
    sp.add_argument(
        "--noise",
        default=NOISE_CHOICES[0],
        choices=NOISE_CHOICES,
        help="measurement-noise law: printed (default) weighs the rows by the tables' printed "
        "precision; constant fits one magnitude and one phase scale; reading fits a floor and "
        "an output-reading resolution each, the errors growing as the input falls; student and "
        "reading-student the same with Student-t errors (those three: --method lsq or nested; "
        "docs/method/noise.rst)",
    )
    sp.add_argument(
        "--rank-by",
        default="aicc",
        choices=RANK_CHOICES,
        metavar="COLUMN",
        help="the column that orders the ranking: " + ", ".join(RANK_CHOICES) + " (default "
        "aicc); whatever the order, the best law is the one with the lowest AICc among the laws "
        f"the rows can rank ({ROWS_RULE}): docs/method/ranking.rst",
    )


def _fit_data_options(sp) -> None:
    """Which rows ``fitdf fit`` fits."""
    _add_source_impedance(sp, "only rows at this source impedance (default: all, fitted jointly)")
    sp.add_argument(
        "--policy",
        default=POLICY_CHOICES[0],
        type=policy_value,
        metavar="{" + ",".join(POLICY_CHOICES) + "}",
        help="which audited rows to use, in which order: 'trusted' (default; 'default' names it "
        "too) drops untrustworthy rows and keeps every value as printed, but for a column a "
        "documented decision of the bundled data takes reversed (Table B.5, 10 c/s phase); "
        "'reordered' also takes a column the audit reads as printed in reverse order reversed; "
        "'as_printed' the trusted rows with no column reversed; 'all' every row; 'strict' only "
        "unflagged rows (datasets/README.md)",
    )
    sp.add_argument(
        "--no-cv", action="store_true", help="skip the leave-one-frequency-out cross-validation"
    )


def _fit_sampling_options(sp) -> None:
    """The posteriors' seed and MCMC chain lengths."""
    sp.add_argument("--seed", type=seed_value, default=0, help=SEED_HELP)
    sp.add_argument(
        "--steps",
        type=count_value(50, MAX_STEPS, "steps"),
        default=300,
        help="minimum MCMC production steps per chain, after a pilot of 300-step rounds "
        "(default 300)",
    )
    sp.add_argument(
        "--max-steps",
        type=count_value(50, MAX_STEPS, "steps"),
        default=5000,
        help=f"extend the chain up to this many steps until it has converged "
        f"({CONVERGED['mcmc']}; default 5000); a chain whose {MIN_STEPS_OVER_TAU} "
        "autocorrelation times exceed it stops early",
    )


def _fit_run_options(sp) -> None:
    """Where ``fitdf fit`` runs its fits and keeps them."""
    sp.add_argument(
        "--workers",
        type=count_value(1, 64, "workers"),
        default=min(2, os.cpu_count() or 1),
        help="local worker processes for the fits (default: 2, or 1 on one CPU; 1 runs in "
        "this process; the numbers are the same)",
    )
    _add_scheduler(sp, "run the fits on this Dask cluster (default: FITDF_SCHEDULER, else local)")
    _add_cache_options(sp, "the rows' contents, options, seed")


def _fit_output_options(sp) -> None:
    """What ``fitdf fit`` prints or writes besides the ranking (``--json``, ``--quiet``): the
    width, and the posteriors as netCDF files (``--posterior-out``)."""
    _add_wide(sp, "the ranking and the summary")
    # (options that write files go here, their paths checked by ``validate`` before any work)
    sp.add_argument(
        "--posterior-out",
        default=None,
        metavar="FOLDER",
        help="write each posterior (--method nested, mcmc or both) to FOLDER as an ArviZ netCDF "
        "file, <data>_<law>_<chain>_<method>.nc: draws in physical units, pointwise "
        "log-likelihood, evidence and prior",
    )


def _report_parser(sub) -> None:
    sp = _subcommand(
        sub,
        "report",
        "fit every model to every core and write the comparison report",
        [
            "fitdf report",
            "fitdf report --quick",
            "fitdf report --full --out /tmp/full-report",
            "fitdf report --compare-chain winding --seed 3",
        ],
        notes="\n\nThe report prints no JSON: its machine-readable output is results.json in the\n"
        "output folder (schemas/results.schema.json), beside README.md, index.html and figures/.",
        json=False,
    )
    sp.add_argument(
        "--out",
        default="fitdf-report",
        metavar="DIR",
        help="output folder (default: fitdf-report in the current folder); a report already "
        "there is replaced only by a run that computes at least what it holds",
    )
    sp.add_argument(
        "--replace",
        action="store_true",
        help="replace the report in --out even when it holds more than this run computes "
        "(a --full report by a --quick run, say)",
    )
    sp.add_argument("--seed", type=seed_value, default=0, help=SEED_HELP)
    run = sp.add_mutually_exclusive_group()
    run.add_argument(
        "--quick",
        action="store_true",
        help="least squares only, no posteriors and no cross-validation: a fast look",
    )
    run.add_argument(
        "--full",
        action="store_true",
        help="the posteriors and evidences of the best three laws of every block, and the "
        "evidence's sensitivity to the prior (the default samples the best two laws of each core)",
    )
    sp.add_argument(
        "--compare-chain",
        choices=("winding",),
        default=None,
        metavar="CHAIN",
        help="also refit every law through this approximate chain (winding: the "
        "sinusoidal-current approximation) and show how far it moves the results",
    )
    _add_scheduler(
        sp,
        "run the fits on this Dask cluster, e.g. tcp://host:8786 (default: the "
        "FITDF_SCHEDULER environment variable, else local processes; needs fitdf[dask])",
    )
    _add_cache_options(sp, "the settings, seed")


#: The thesis's loop (Fig 5.18), the plant of ``fitdf limit-cycle``'s examples.
_THESIS_PLANT = '"K/((1+s)(1+0.25s)(1+1.1s))"'


def _limit_cycle_parser(sub) -> None:
    sp = _subcommand(
        sub,
        "limit-cycle",
        "predict limit cycles of a loop closed around a fitted core",
        [
            f"fitdf limit-cycle permalloy --plant {_THESIS_PLANT} --gain 500 1000 2500 \\\n"
            "      --source-impedance 600",
            'fitdf limit-cycle deltamax --plant "10/(s*(s+1)*(s+2))" --gain 1 --json',
            f"fitdf limit-cycle B.3 --plant {_THESIS_PLANT} --gain 1000 --plot loci.png",
        ],
    )
    sp.add_argument(
        "data", help="core name, table (B.1..B.5) or CSV path of the core's measured DF"
    )
    sp.add_argument(
        "--plant",
        required=True,
        help='transfer function in s, with K for the gain, e.g. "K/((1+s)(1+0.25s)(1+1.1s))"',
    )
    sp.add_argument(
        "--gain",
        type=number_value(0.0, strict=True, what="gain"),
        nargs="+",
        default=[1.0],
        metavar="K",
        help="loop gain(s) K",
    )
    _add_source_impedance(sp, "rows and DF at this source impedance (default: the data's only one)")
    sp.add_argument(
        "--model",
        default=None,
        help="law to use, in any case (default: the lowest AICc of all laws)",
    )
    sp.add_argument(
        "--time-scale",
        type=number_value(0.0, strict=True, what="time scale"),
        default=1.0,
        metavar="ALPHA",
        help="run the plant as G(s/ALPHA), e.g. for a time-scaled analog computer (default 1)",
    )
    sp.add_argument("--chain", default=DEFAULT_CHAIN, choices=CHAIN_CHOICES)
    sp.add_argument("--seed", type=seed_value, default=0, help=SEED_HELP)
    sp.add_argument(
        "--plot",
        default=None,
        metavar="FILE.png",
        help="write the Nyquist-plane figure (its format by the suffix: "
        + ", ".join(PLOT_FORMATS)
        + "): the loci framed where they meet (the cycles, else the first cycle at the "
        "critical gain), beside a panel of the whole loci",
    )
    _add_cache_options(sp, "the rows' contents, options, seed")


#: The subcommands, in the order ``fitdf --help`` lists them.
SUBCOMMANDS = {
    "datasets": _datasets_parser,
    "audit": _audit_parser,
    "models": _models_parser,
    "fit": _fit_parser,
    "report": _report_parser,
    "limit-cycle": _limit_cycle_parser,
}


def build_parser() -> argparse.ArgumentParser:
    """The ``fitdf`` parser; ``args.command`` names the subcommand."""
    p = _Parser(
        prog="fitdf",
        description="Fit, rank and use describing-function models of hysteretic elements.",
        formatter_class=_Formatter,
        epilog="examples:\n  fitdf datasets\n  fitdf audit B.1\n  fitdf fit permalloy --method both\n"
        "  fitdf report",
    )
    p.add_argument("--version", action="version", version=f"fitdf {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for builder in SUBCOMMANDS.values():
        builder(sub)
    return p
