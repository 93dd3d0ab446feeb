"""The ``fitdf`` command line: a thin layer that parses options and calls the library.

Every user mistake (unknown core, missing file, bad CSV, unknown model, impossible
option or option value) is one line on stderr and exit code 2; an internal failure says so
and where to look (``--debug`` shows the traceback).

Start-up stays light: this module imports only the standard library and ``fitdf.errors``
at the top, so ``fitdf --version`` and every ``--help`` answer without loading numpy,
pandas, matplotlib or the fitting stack. Each subcommand handler (``cmd_*``) imports what
it needs when it runs -- the only function-level imports the package allows
(tests/test_architecture.py). The choices the parser offers are therefore written out
here; tests/test_cli_fast.py checks them against the library.
"""

from __future__ import annotations

import _thread
import argparse
import contextlib
import functools
import json
import os
import re
import signal
import sys
import tempfile
import textwrap
import threading
import traceback
from pathlib import Path

from fitdf import __version__
from fitdf.errors import FitdfError, OptionError

EXIT_USAGE = 2
EXIT_INTERNAL = 1

#: Measurement chains (``fitdf.chains.chain_names()``) and the default chain
#: (``fitdf.inference.api.DEFAULT_CHAIN``).
CHAIN_CHOICES = ("direct", "winding", "voltage", "dynamic")
DEFAULT_CHAIN = "voltage"
#: ``fitdf.inference.ranking.METHOD_CHOICES`` and ``RANK_COLUMNS``.
METHOD_CHOICES = ("lsq", "mcmc", "nested", "both")
#: How the text names a fit's method.
METHOD_NAMES = {"lsq": "least squares", "mcmc": "MCMC", "nested": "nested sampling"}
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
#: Row policies (``fitdf.data.audit.POLICIES``; the first is the default) and the other
#: names they answer to (``fitdf.data.audit.POLICY_ALIASES``).
POLICY_CHOICES = ("trusted", "reordered", "as_printed", "all", "strict")
POLICY_ALIASES = {"default": POLICY_CHOICES[0]}
#: How a dimensionless unit is printed (``fitdf.params.DIMENSIONLESS``).
DIMENSIONLESS_UNIT = "-"
#: numpy's legacy ``RandomState`` (the MCMC's walkers) takes seeds below 2**32.
MAX_SEED = 2**32 - 1


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit code 2)."""

    def error(self, message):
        raise _UsageError(f"{self.prog}: {message}")


class _UsageError(Exception):
    pass


#: Characters that end a line for ``str.splitlines`` (and for many terminals).
_LINE_BREAKS = re.compile("[\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029]")


def one_line(message: str) -> str:
    """``message`` on one line: line breaks a user typed into a value are shown escaped."""
    return _LINE_BREAKS.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), message)


def _emit_json(obj):
    """Print ``obj`` (already through :func:`fitdf._json.clean`) as strict JSON."""
    json.dump(obj, sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


# ------------------------------------------------------------------ option values
# argparse ``type=`` functions: a bad value is argparse's one-line usage error (exit 2)
# naming the option ("argument --seed: ..."). Numbers are ASCII decimals only, as the CSV
# loader reads them (float() would also take "nan", "1_0" and non-ASCII digits).
_INT = r"[+-]?[0-9]+"
_FLOAT = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
MAX_STEPS = 1_000_000  #: longest MCMC chain (per walker) the command line accepts
SEED_HELP = f"seed of every random choice, 0..{MAX_SEED} (default 0)"


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
        # permissions are not the only reason (a read-only or virtual file system such as
        # /proc, a full disk): make and remove a folder where the command will write
        os.rmdir(tempfile.mkdtemp(prefix=".fitdf-probe-", dir=base))
    except OptionError:
        raise
    except (OSError, ValueError) as exc:  # name too long, NUL byte, unreadable parent, ...
        reason = getattr(exc, "strerror", None) or exc
        raise OptionError(f"{option} {path!r}: not a folder fitdf can write ({reason})") from None
    return target


def check_output_file(option: str, path: str) -> Path:
    """A file the command can write: not a folder, in an existing writable folder."""
    if not str(path).strip():
        raise OptionError(f"{option}: empty path")
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
    except OptionError:
        raise
    except (OSError, ValueError) as exc:
        raise OptionError(f"{option} {path!r}: not a usable file name ({exc})") from None
    return target


# ------------------------------------------------------------------ commands
def cmd_datasets(args):
    from fitdf._json import clean
    from fitdf.data import datasets

    table = datasets.summary()
    if args.json:
        _emit_json(
            clean({"datasets": datasets.names(), "appendix_b": table.to_dict(orient="records")})
        )
        return 0
    print("Bundled datasets: " + ", ".join(datasets.names()))
    print("\nAppendix B rows per table and frequency:")
    print(table.to_string(index=False))
    return 0


def cmd_audit(args):
    import pandas as pd

    from fitdf._json import clean
    from fitdf.data import audit, datasets

    frame = audit.audit(datasets.load(args.data))
    flagged = frame[frame["flag"] != "ok"]
    factors = audit.block_factors(frame) if "h1_output_v" in frame else None
    if args.json:
        _emit_json(
            clean(
                {
                    "rows": len(frame),
                    "flagged": flagged.to_dict(orient="records"),
                    "block_factors": None if factors is None else factors.to_dict(orient="records"),
                    "findings": audit.findings(frame),
                }
            )
        )
        return 0
    cols = [
        c
        for c in (
            "table",
            "frequency_hz",
            "row_in_block",
            "input_v",
            "h1_output_v",
            "phase_lead_deg",
            "df_reported",
            "flag",
            "exclude_default",
            "reasons",
        )
        if c in frame
    ]
    print(
        f"{len(frame)} rows, {len(flagged)} flagged, {int(frame['exclude_default'].sum())} excluded by default\n"
    )
    notes = audit.order_notes(audit.select_rows(frame), str(args.data))
    for line in notes:  # what the default fit does with the column order, before the detail
        print(f"Column order: {line}.")
    if notes:
        print()
    if factors is not None:
        print("DF factor per block (printed vs followed by the data):")
        print(factors.to_string(index=False), "\n")
    if not flagged.empty:
        with pd.option_context("display.max_colwidth", 200, "display.width", 250):
            print(flagged[cols].to_string(index=False))
    for line in audit.findings(frame):
        print("- " + line)
    return 0


#: Longest line of the commands' text (``fitdf fit --wide`` prints every column regardless).
TEXT_WIDTH = 100
#: The ranking's columns with ``--wide`` (those with a value in some row).
WIDE_COLUMNS = (
    "rank",
    "model",
    "chain",
    "method",
    "n_params",
    "rms_complex",
    "rms_magnitude",
    "rms_phase_deg",
    "redchi",
    "aicc",
    "bic",
    "looic",
    "cv_rms_complex",
    "log_evidence",
    "log_evidence_error",
    "log_bayes_factor_next",
    "bayes_factor_verdict",
    "indistinguishable_from",
)
#: The ranking's columns by default: ``chain`` and ``method`` only when they differ between
#: rows, ``cv_rms_complex`` when it was computed, the ``--rank-by`` column when it is none of
#: these, then ``ties``.
BRIEF_COLUMNS = (
    "rank",
    "model",
    "chain",
    "method",
    "n_params",
    "rms_complex",
    "aicc",
    "cv_rms_complex",
    "log_evidence",
)
#: What each column of the ranking means (the legend under the default table).
COLUMN_MEANINGS = {
    "n_params": "parameters fitted",
    "rms_complex": "RMS of |predicted - measured| complex DF (V/V)",
    "rms_magnitude": "RMS of |predicted| - |measured| (V/V)",
    "rms_phase_deg": "RMS phase error (degree)",
    "redchi": "reduced chi-square",
    "aicc": "Akaike's information criterion corrected for few rows (lower is better)",
    "bic": "Bayesian information criterion (lower is better)",
    "looic": "PSIS leave-one-out information criterion (MCMC; lower is better)",
    "waic": "widely applicable information criterion (MCMC; lower is better)",
    "cv_rms_complex": "rms_complex of each frequency predicted from a fit to the others",
    "log_evidence": "ln of the Bayesian evidence (nested sampling; higher is better)",
    "log_bayes_factor_next": "ln B over the next law by evidence",
}


def cmd_models(args):
    from fitdf._json import clean
    from fitdf.chains import CHAINS
    from fitdf.models import MODELS

    if args.law is not None and args.law not in MODELS:
        raise OptionError(f"unknown law {args.law!r}; known: {', '.join(MODELS)}")
    laws = [MODELS[args.law]] if args.law is not None else list(MODELS.values())
    if args.json:
        _emit_json(
            clean(
                {
                    "models": [m.describe() for m in laws],
                    "chains": [
                        {"name": c.name, "title": c.title, "parameters": [p.name for p in c.params]}
                        for c in CHAINS.values()
                    ],
                }
            )
        )
        return 0
    if args.law is not None:
        print(_law_text(laws[0], CHAINS.values()))
        return 0
    for m in laws:
        print(
            f"{m.name}: {m.title} ({m.equations})"
            + ("  [N depends on frequency]" if m.frequency_dependent else "")
        )
        for p in m.params:
            print(
                f"    {p.name:<11s} {p.unit_label:<8s} bounds [{p.bounds[0]:g}, {p.bounds[1]:g}]  "
                f"{p.description}" + (f" ({p.equation})" if p.equation else "")
            )
    print("\nMeasurement chains:")
    for c in CHAINS.values():
        print(f"{c.name}: {c.title}; parameters: {', '.join(p.name for p in c.params) or 'none'}")
    print("\n'fitdf models LAW' explains one law, its parameters and the chains' parameters.")
    return 0


def _params_text(params, indent: str = "  ") -> list[str]:
    """Lines of declared parameters: name, unit, bounds, scale and thesis equation, then an
    indented line of what each means (wrapped at :data:`TEXT_WIDTH`)."""
    rows = [
        [
            p.name,
            p.unit_label,
            f"{p.bounds[0]:g} .. {p.bounds[1]:g}",
            "log" if p.log else "linear",
            p.equation or "-",
        ]
        for p in params
    ]
    headers = ["parameter", "unit", "bounds", "scale", "thesis / source"]
    table = _table_text(headers, rows, left=headers)
    lines = [indent + table[0]]
    for p, line in zip(params, table[1:]):
        line = indent + line
        lines.append(line if len(line) <= TEXT_WIDTH else line[: TEXT_WIDTH - 3] + "...")
        lines += textwrap.wrap(
            p.description or "(no description)",
            TEXT_WIDTH,
            initial_indent=indent + "    ",
            subsequent_indent=indent + "    ",
        )
    return lines


def _law_text(law, chains) -> str:
    """``fitdf models LAW``: the law's title and equations, its parameters, the chains'."""
    lines = textwrap.wrap(f"{law.name}: {law.title}", TEXT_WIDTH, subsequent_indent="  ")
    lines += textwrap.wrap(
        f"thesis equations: {law.equations}",
        TEXT_WIDTH,
        initial_indent="  ",
        subsequent_indent="    ",
    )
    lines.append(
        "  N depends on the frequency as well as the amplitude"
        if law.frequency_dependent
        else "  N depends on the amplitude only (rate-independent loop)"
    )
    lines += ["", "Parameters of the law (the core's flux linkage against winding current):"]
    lines += _params_text(law.params)
    lines += [
        "",
        "Measurement chains (fitdf fit --chain; their parameters are fitted with the law's):",
    ]
    for k, c in enumerate(chains):
        default = " (default)" if c.name == DEFAULT_CHAIN else ""
        lines += [""] if k else []
        lines += textwrap.wrap(
            f"{c.name}{default}: {c.title}", TEXT_WIDTH, subsequent_indent="    "
        )
        lines += _params_text(c.params, indent="    ") if c.params else ["    no parameters"]
    note = (
        f"unit {DIMENSIONLESS_UNIT}: dimensionless; scale log: the fits work with log10 of the "
        "value. Bounds are the default box (the prior support); with a core's geometry a fit "
        "narrows them to the material's physical limits."
    )
    lines += ["", *textwrap.wrap(note, TEXT_WIDTH)]
    return "\n".join(lines)


def _cell(value) -> str:
    """A table cell: floats in four significant digits, NaN as ``n/a``."""
    if isinstance(value, float):
        return "n/a" if value != value else f"{value:.4g}"
    return str(value)


def _ranks_text(ranks) -> str:
    """Sorted ranks, runs shortened: ``[2, 3, 4, 7]`` -> ``"2-4,7"``."""
    runs, out = [], []
    for r in sorted(set(ranks)):
        if runs and r == runs[-1][1] + 1:
            runs[-1][1] = r
        else:
            runs.append([r, r])
    for lo, hi in runs:
        out.append(str(lo) if lo == hi else f"{lo},{hi}" if hi == lo + 1 else f"{lo}-{hi}")
    return ",".join(out)


def _tie_ranks(table) -> list[str]:
    """Per row of a ranking, the ranks of the rows it cannot be told apart from (its
    ``indistinguishable_from``: models of the same method), e.g. ``"2-4,7"``."""
    rank_of = {
        (row["model"], row["chain"], row["method"]): int(row["rank"]) for _, row in table.iterrows()
    }
    out = []
    for _, row in table.iterrows():
        names = [n for n in str(row.get("indistinguishable_from") or "").split(", ") if n]
        ranks = [rank_of.get((*n.rsplit("/", 1), row["method"])) for n in names]
        out.append(_ranks_text(r for r in ranks if r is not None))
    return out


def _table_text(headers, rows, left=(), sep="  ") -> list[str]:
    """Lines of a plain table: ``headers`` over ``rows`` (lists of str), columns named in
    ``left`` aligned left, the others right."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(headers)]
    return [
        sep.join(
            c.ljust(w) if h in left else c.rjust(w) for c, w, h in zip(line, widths, headers)
        ).rstrip()
        for line in (headers, *rows)
    ]


def _ranking_text(table, rank_by: str = "aicc", wide: bool = False) -> str:
    """The ranking as text: every column with ``wide``, else the columns a reader needs
    first, no line longer than :data:`TEXT_WIDTH`, and a legend of those columns."""
    if wide:
        cols = [c for c in WIDE_COLUMNS if c in table and not table[c].isna().all()]
        return table[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}")
    cols = [
        c
        for c in BRIEF_COLUMNS
        if c in table
        and not table[c].isna().all()
        and (c not in ("chain", "method") or table[c].nunique() > 1)
    ]
    if rank_by in table and rank_by not in cols:
        cols.append(rank_by)
    rows = [[_cell(row[c]) for c in cols] for _, row in table.iterrows()]
    ties = _tie_ranks(table)
    headers = [*cols, "ties"]
    left = ("model", "chain", "method", "ties")
    lines = _table_text(headers, [[*r, t] for r, t in zip(rows, ties)], left)
    if max(map(len, lines)) > TEXT_WIDTH:  # several chains and methods: closer columns
        lines = _table_text(headers, [[*r, t] for r, t in zip(rows, ties)], left, sep=" ")
    if max(map(len, lines)) > TEXT_WIDTH:  # a long list of ties: cut, --wide has them all
        room = TEXT_WIDTH - 1 - max(map(len, _table_text(cols, rows, left, sep=" ")))
        room = max(room, len("ties"))
        ties = [t if len(t) <= room else t[: room - 3] + "..." for t in ties]
        lines = _table_text(headers, [[*r, t] for r, t in zip(rows, ties)], left, sep=" ")
    methods = set(table["method"])
    tie_rule = {
        "lsq": "AICc within 2",
        "mcmc": "elpd_loo within twice its standard error",
        "nested": "a Bayes factor below e (2 ln B < 2)",
    }
    rule = "; ".join(f"{METHOD_NAMES[m]}: {tie_rule[m]}" for m in sorted(methods))
    legend = [f"{c}: {COLUMN_MEANINGS[c]}" for c in cols if c in COLUMN_MEANINGS]
    legend.append(f"ties: the ranks this row cannot be told apart from ({rule})")
    legend.append("--wide prints every column")
    text = "; ".join(legend) + "."
    return "\n".join([*lines, "", *textwrap.wrap(text, TEXT_WIDTH)])


def _check_models(models, known) -> None:
    unknown = [m for m in models if m not in known]
    if unknown:
        raise OptionError(f"unknown model(s) {', '.join(unknown)}; known: {', '.join(known)}")


def _is_folder(item: str, bundled) -> bool:
    """``item`` names a folder (not a bundled name; "" would be the current folder: not one)."""
    if not item.strip() or item in bundled:
        return False
    try:
        return Path(item).is_dir()
    except (OSError, ValueError):  # name too long, NUL byte: the loader names the problem
        return False


def fit_sources(items, bundled) -> tuple[list[str], bool]:
    """The datasets ``fitdf fit`` ranks: names and CSV paths as given, folders as their ``*.csv``.

    Returns the list and whether it is a batch (several items, or a folder).
    """
    sources, batch = [], len(items) > 1
    for item in items:
        if not _is_folder(item, bundled):
            sources.append(item)
            continue
        try:
            found = sorted(
                str(p) for p in Path(item).iterdir() if p.suffix.lower() == ".csv" and p.is_file()
            )
        except OSError as exc:
            reason = exc.strerror or exc
            raise OptionError(f"{item}: the folder cannot be read ({reason})") from None
        if not found:
            raise OptionError(f"{item}: the folder holds no *.csv files")
        sources += found
        batch = True
    return sources, batch


def cmd_fit(args):
    from fitdf.data import datasets
    from fitdf.data.audit import order_notes
    from fitdf.data.cores import parse_geometry
    from fitdf.data.resolve import resolve_data
    from fitdf.models import model_names

    models = args.models or model_names()
    _check_models(models, model_names())
    geometry = parse_geometry(args.geometry) if args.geometry else "auto"
    sources, batch = fit_sources(args.data, {*datasets.names(), "appendix_b"})
    # every dataset is read and checked before the first fit, and before the fitting stack
    # is imported (~5 s): a bad file fails at once, naming file, row and column
    rows = [resolve_data(src, args.policy, args.source_impedance) for src in sources]
    for line in order_warnings(sources, rows, order_notes):
        print(line, file=sys.stderr)
    return cmd_fit_checked(args, models, geometry, sources, batch, rows)


def order_warnings(sources, rows, notes) -> list[str]:
    """``fitdf fit``'s warnings on the column order of each dataset (``notes``:
    :func:`fitdf.data.audit.order_notes`): a column taken in reverse order, or one the audit
    flags that is fitted as printed and the option that would reverse it (the audit informs;
    the user decides)."""
    return [
        f"fitdf fit: warning: {line}"
        for src, fd in zip(sources, rows)
        for line in notes(fd.rows, str(src))
    ]


def cmd_fit_checked(args, models, geometry, sources, batch, rows):
    """The fits of ``fitdf fit`` once :func:`cmd_fit` has read and checked every dataset
    (``rows``): a handler of its own so that the fitting stack it imports (~5 s) is imported
    only for data that can be fitted."""
    from fitdf._json import clean
    from fitdf.executor import Executor
    from fitdf.inference.cache import comparison_cache
    from fitdf.inference.posterior_data import write_posteriors
    from fitdf.inference.ranking import compare_fits

    per_fit = len(models) * len(args.chain) * (2 if args.method == "both" else 1)
    records, summary = [], []
    show = not args.quiet and not args.json
    fit_kw = dict(n_steps=args.steps, max_steps=args.max_steps, geometry=geometry)
    # kept on ``args``: after Ctrl-C, the one line says what the caches kept
    args.job_caches = []
    with Executor(workers=args.workers, scheduler=args.scheduler, progress=show) as executor:
        for src, fd in zip(sources, rows):
            if not args.no_cache:
                executor.cache = comparison_cache(
                    args.cache,
                    fd,
                    seed=args.seed,
                    cross_validation=not args.no_cv,
                    scheduler=args.scheduler,
                    **fit_kw,
                )
                args.job_caches.append(executor.cache)
            comparison = compare_fits(
                fd,
                models=models,
                chains=tuple(args.chain),
                method=args.method,
                seed=args.seed,
                rank_by=args.rank_by,
                cross_validation=not args.no_cv,
                runner=executor.run,
                **fit_kw,
            )
            record = {
                "data": str(src),
                "seed": args.seed,
                "rank_by": args.rank_by,
                "ranking": comparison.table.to_dict(orient="records"),
                "selection": comparison.selection.to_dict(),
                "fits": [r.to_dict() for r in comparison.results],
            }
            records.append(clean(record))
            summary.append(clean(_summary_row(src, comparison)))
            if args.posterior_out:
                for path in write_posteriors(comparison.results, args.posterior_out):
                    if not args.quiet:
                        print(f"fitdf fit: wrote {path}", file=sys.stderr)
            if not args.json:
                _print_fit(comparison, args, brief=batch)
    if executor.reused and not args.quiet:
        where = args.job_caches[0].root
        print(
            f"fitdf fit: {len(executor.reused)} of {per_fit * len(sources)} fits read from "
            f"{where}, kept by an earlier run of the same rows, options, code and machine "
            "(--no-cache computes them again)",
            file=sys.stderr,
        )
    if args.json:
        if batch:
            out = {"seed": args.seed, "rank_by": args.rank_by, "summary": summary}
            _emit_json({**out, "files": records})
        else:
            _emit_json(records[0])
    elif batch:
        print(f"\nSummary ({len(summary)} datasets, best: the lowest AICc of the laws ranked):")
        print(_summary_text(summary))
    return 0


def _summary_row(src, comparison) -> dict:
    """One dataset's line of the batch summary: its best model (the selection rule's) and how
    well it fits."""
    best = comparison.best
    return {
        "data": str(src),
        "best_model": best.model,
        "chain": best.chain,
        "method": best.method,
        "rms_complex": float(best.metrics["rms_complex"]),
        "aicc": float(best.metrics["aicc"]),
        "n_points": int(best.metrics["n_points"]),
    }


def _summary_text(rows) -> str:
    cols = ("data", "best_model", "chain", "method", "rms_complex", "aicc", "n_points")
    cells = [
        [
            "n/a" if r[c] is None else f"{r[c]:.4g}" if isinstance(r[c], float) else str(r[c])
            for c in cols
        ]
        for r in rows
    ]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]
    lines = [cols, *cells]
    return "\n".join(
        "  ".join(
            cell.ljust(w) if i < 4 else cell.rjust(w)
            for i, (cell, w) in enumerate(zip(line, widths))
        )
        for line in lines
    )


def _print_fit(comparison, args, *, brief: bool) -> None:
    """The ranking; for a single dataset also the best fit, its material and MCMC checks.

    Every line fits in :data:`TEXT_WIDTH` columns unless ``--wide``.
    """
    table, results, best = comparison.table, comparison.results, comparison.best
    wide = getattr(args, "wide", False)
    if brief:
        print()
    how = []  # what every row shares (the default table leaves those columns out)
    if table["chain"].nunique() == 1:
        how.append(f"{table['chain'].iloc[0]} chain")
    if table["method"].nunique() == 1:
        how.append(METHOD_NAMES.get(table["method"].iloc[0], table["method"].iloc[0]))
    print(
        f"Ranking on {results[0].label} ({results[0].metrics['n_points']} rows, "
        f"{', '.join([*how, f'seed {args.seed}'])}), ordered by {args.rank_by}:"
    )
    print(_ranking_text(table, args.rank_by, wide=wide))
    print()
    print(_selection_text(comparison.selection))
    if not brief:
        print("\nBest model:")
        print(best.summary())
        print(_material_text(best))
    nested = [r for r in results if r.method == "nested"]
    if nested:
        print(
            "\nNested-sampling checks (converged: >= 400 effective draws, evidence error <= 0.3):"
        )
        rows = []
        for r in nested:
            d = r.diagnostics
            rows.append(
                [
                    r.model,
                    r.chain,
                    "yes" if d["converged"] else "NO",
                    f"{d['log_evidence']:.2f} +- {d['log_evidence_error']:.2f}",
                    f"{d['n_effective']:.0f}",
                    f"{d['n_likelihood_evaluations']:.0f}",
                ]
            )
        headers = ["model", "chain", "converged", "ln evidence", "eff. draws", "evaluations"]
        for line in _table_text(headers, rows, left=("model", "chain", "converged")):
            print("  " + line)
    mcmc = [r for r in results if r.method == "mcmc"]
    if mcmc:
        print("\nMCMC checks (converged: 50 autocorrelation times, R-hat < 1.01, bulk ESS >= 400):")
        rows = []
        for r in mcmc:
            d = r.diagnostics
            rows.append(
                [
                    r.model,
                    r.chain,
                    "yes" if d["converged"] else "NO",
                    f"{d['steps_over_tau']:.0f}",
                    f"{max(d['rhat'].values()):.3f}",
                    f"{min(d['ess_bulk'].values()):.0f}",
                    f"{d['acceptance_mean']:.2f}",
                ]
            )
        headers = ["model", "chain", "converged", "steps/tau", "max R-hat", "min ESS", "acceptance"]
        for line in _table_text(headers, rows, left=("model", "chain", "converged")):
            print("  " + line)


#: ``fitdf.inference.selection.ROWS_RULE`` (this module imports no fitting code at its top).
ROWS_RULE = "AICc needs two numbers a row, at least the parameters plus two"


def _selection_text(selection) -> str:
    """What the selection rule calls best, the criteria that disagree, the laws not ranked:
    each a wrapped line of :class:`~fitdf.inference.selection.Selection`'s sentences."""
    lines = textwrap.wrap(selection.sentence, TEXT_WIDTH)
    if selection.disagreement:
        lines += textwrap.wrap(selection.disagreement, TEXT_WIDTH)
    if selection.not_ranked:
        laws = ", ".join(f"{r['model']} ({r['n_params']} parameters)" for r in selection.not_ranked)
        n = selection.not_ranked[0]["n_points"]
        text = f"Not fitted or ranked, {n} rows being too few ({ROWS_RULE}): {laws}."
        lines += textwrap.wrap(text, TEXT_WIDTH)
    return "\n".join(lines)


def _material_text(result) -> str:
    """The best fit's material constants beside the Appendix A ranges (when there is a
    geometry), and the caveat when they rest on parameters the data do not determine."""
    if result.material is None:
        return "  (no core geometry: material constants not computed; see --geometry)"
    caveat = result.material.get("caveat")
    text = _material_lines(result)
    if caveat:
        wrapped = textwrap.wrap(
            f"caveat: {caveat}", TEXT_WIDTH, initial_indent="  ", subsequent_indent="    "
        )
        text += "\n" + "\n".join(wrapped)
    return text


def _material_lines(result) -> str:
    """The constants, against the Appendix A ranges where the core has them."""
    check = result.material.get("appendix_a_check")
    if not check:
        c = result.material["constants"]
        return (
            f"  material: mu_i {c['initial_permeability']:.4g}, "
            f"mu_max {c['maximum_permeability']:.4g}, H_c {c['coercive_force_oe']:.3g} Oe,\n"
            f"    B_p {c['peak_flux_density_gauss']:.4g} G, B_r/B_p {c['squareness']:.3g} "
            "(no catalogue ranges for this core)"
        )
    lines = ["  material constants vs Appendix A:"]
    for row in check:
        high = "" if row["high"] is None else f"{row['high']:.4g}"
        fitted = "n/a" if row["fitted"] is None else f"{row['fitted']:.4g}"
        mark = "inside" if row["inside"] else "OUTSIDE"
        lines.append(
            f"    {row['quantity']:<24s} {fitted:>10s} {row['unit'] or '-':<13s} "
            f"range {row['low']:.4g}..{high:<8s} {mark}"
        )
    return "\n".join(lines)


def cmd_report(args):
    from fitdf.report.build import ReportSettings, generate_report, job_cache

    settings = ReportSettings.for_run(
        args.quick, full=args.full, scheduler=args.scheduler, compare_chain=args.compare_chain
    )
    cache = None if args.no_cache else job_cache(args.cache, settings, args.seed)
    # kept on ``args``: after Ctrl-C, the one line says what the cache kept
    args.job_caches = [] if cache is None else [cache]
    try:
        out = generate_report(
            out_dir=args.out,
            seed=args.seed,
            quick=args.quick,
            progress=not args.quiet,
            settings=settings,
            cache=cache,
        )
    except OSError as exc:
        # the folder passed the checks before the run, and writing it failed after (a full
        # disk, the folder removed meanwhile): the user's to fix, the previous report kept
        parent = str(Path(args.out).expanduser().resolve().parent)
        if exc.filename is None or not str(exc.filename).startswith(parent):
            raise
        raise OptionError(
            f"--out {args.out}: the report could not be written ({exc.strerror})"
        ) from None
    print(f"report written to {out}/ (README.md, index.html, results.json, figures/)")
    return 0


def cmd_limit_cycle(args):
    from fitdf._json import clean
    from fitdf.loop.fitted import fitted_limit_cycles
    from fitdf.models import model_names
    from fitdf.plots.limit_cycles import plot_nyquist

    if args.model is not None:
        _check_models([args.model], model_names())
    found = fitted_limit_cycles(
        args.data,
        args.plant,
        args.gain,
        args.source_impedance,
        model=args.model,
        chain=args.chain,
        seed=args.seed,
        time_scale=args.time_scale,
    )
    if args.plot is not None:
        try:
            plot_nyquist(found.response).savefig(args.plot)
        except (
            OSError,
            ValueError,
        ) as exc:  # unwritable path or unknown image format: the user's to fix
            raise OptionError(f"cannot write the figure to {args.plot}: {exc}") from exc
    result = found.to_dict()
    if args.json:
        _emit_json(clean(result))
        return 0
    print(format_limit_cycle_table(result))
    if args.plot:
        print(f"Nyquist-plane figure written to {args.plot}")
    return 0


#: The legend under ``fitdf limit-cycle``'s table (:mod:`fitdf.loop.harmonic` for Loeb's
#: criterion).
LIMIT_CYCLE_LEGEND = (
    "gain: the loop gain K; amplitude: peak of the sinusoid at the core's input (the plant's "
    "output); omega, f: its frequency; stable: whether a slightly larger cycle decays back to it "
    "(yes: the loop settles into this cycle) or grows away (no), by Loeb's criterion; loeb: that "
    "criterion's value, the sine of the angle at which the plant locus G(jw) crosses the critical "
    "locus -1/N(A, w), from -1 to 1: above 0 stable, below 0 unstable, near 0 a fragile verdict."
)


def format_limit_cycle_table(result: dict) -> str:
    """Plain-text table of a :class:`~fitdf.loop.fitted.FittedLimitCycles` record (``to_dict``)."""
    lines = textwrap.wrap(
        f"Limit cycles of {result['plant']} with the {result['model']} core "
        f"({result['chain']} chain) fitted to {result['data']} at "
        f"{result['source_impedance_ohm']:g} ohm",
        TEXT_WIDTH,
        subsequent_indent="  ",
    )
    lines += [
        f"amplitudes searched {result['amplitude_range'][0]:.3g}..{result['amplitude_range'][1]:.3g} V, "
        f"omega {result['omega_range'][0]:.3g}..{result['omega_range'][1]:.3g} rad/s",
        "",
        f"{'gain':>10s} {'amplitude V':>12s} {'omega rad/s':>12s} {'f Hz':>8s} {'stable':>7s} {'loeb':>7s}",
    ]
    by_gain = {}
    for c in result["intersections"]:
        by_gain.setdefault(c["gain"], []).append(c)
    for g in result["gains"]:
        cycles = by_gain.get(g, [])
        if not cycles:
            lines.append(f"{g:>10.4g} {'none':>12s}")
        for c in cycles:
            lines.append(
                f"{g:>10.4g} {c['amplitude']:>12.4g} {c['omega_rad_s']:>12.4g} {c['frequency_hz']:>8.3g} "
                f"{'yes' if c['stable'] else 'no':>7s} {c['loeb']:>7.2f}"
            )
    lines += ["", *textwrap.wrap(LIMIT_CYCLE_LEGEND, TEXT_WIDTH)]
    crit = result.get("critical_gain")
    point = result.get("critical_point", {})
    lines.append("")
    if crit is None:
        lines.append("No gain gives a limit cycle in the amplitude range searched.")
    else:
        where = " (at the edge of the amplitude range)" if point.get("at_boundary") else ""
        unstable = any("unstable in open loop" in w for w in result.get("warnings", ()))
        below = (
            "No periodic solution below gain"  # an unstable plant may diverge instead
            if unstable
            else "Oscillations die out below gain"
        )
        lines += textwrap.wrap(
            f"{below} {crit:.4g}; the first cycle appears at "
            f"A = {point.get('amplitude'):.3g} V, omega = {point.get('omega'):.3g} rad/s{where}.",
            TEXT_WIDTH,
        )
    lines += [f"Warning: {w}." for w in result.get("warnings", ())]
    return "\n".join(lines)


# ------------------------------------------------------------------ parser
def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="fitdf",
        description="Fit, rank and use describing-function models of hysteretic elements.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  fitdf datasets\n  fitdf audit B.1\n  fitdf fit permalloy --method both\n"
        "  fitdf report",
    )
    p.add_argument("--version", action="version", version=f"fitdf {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    def add(name, func, help, examples, notes="", json=True):
        sp = sub.add_parser(
            name,
            help=help,
            description=help,
            formatter_class=argparse.RawDescriptionHelpFormatter,
            epilog="examples:\n" + "\n".join(f"  {e}" for e in examples) + notes,
        )
        sp.set_defaults(func=func)
        if json:
            sp.add_argument(
                "--json", action="store_true", help="print JSON on stdout instead of text"
            )
        sp.add_argument("--quiet", action="store_true", help="no progress bars")
        return sp

    add(
        "datasets",
        cmd_datasets,
        "list the bundled datasets with row counts per frequency",
        ["fitdf datasets", "fitdf datasets --json"],
    )
    sp = add(
        "audit",
        cmd_audit,
        "audit the printed tables row by row and show the flagged rows",
        ["fitdf audit", "fitdf audit B.1", "fitdf audit my_core.csv --json"],
    )
    sp.add_argument(
        "data",
        nargs="?",
        default="appendix_b",
        help="dataset, core or CSV path (default: all of Appendix B)",
    )
    sp = add(
        "models",
        cmd_models,
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
    sp = add(
        "fit",
        cmd_fit,
        "fit every model to a core and print the ranking",
        [
            "fitdf fit permalloy",
            "fitdf fit B.3 --method both --steps 2000",
            "fitdf fit deltamax --source-impedance 600 --models constant_width rayleigh --json",
            "fitdf fit core1.csv core2.csv --method lsq   # a summary table after the rankings",
            "fitdf fit measurements/ --json               # every *.csv of the folder",
        ],
        notes="\n\nCSV file: columns input_v (V peak), frequency_hz (Hz), df_reported (|DF|, V/V), "
        "phase_lead_deg\n(degree, output leads input), optional source_impedance_ohm (ohm, default 0); "
        "datasets/README.md",
    )
    sp.add_argument(
        "data",
        nargs="+",
        help="core name (permalloy, deltamax, supermalloy), table (B.1..B.5), CSV file (format "
        "below) or a folder of CSV files; several (or a folder) are ranked one by one, then "
        "summarised",
    )
    sp.add_argument(
        "--wide",
        action="store_true",
        help="print every column of the ranking (default: the main ones, in 100 columns)",
    )
    sp.add_argument(
        "--method",
        choices=METHOD_CHOICES,
        default="lsq",
        help="lsq: least squares (default); nested: the posterior and its evidence by nested "
        "sampling (nautilus); mcmc: the posterior by emcee; both: lsq and nested",
    )
    sp.add_argument("--models", nargs="+", metavar="MODEL", help="models to fit (default: all)")
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
        "--source-impedance",
        type=number_value(0.0, what="source impedance"),
        default=None,
        metavar="OHM",
        help="only rows at this source impedance (default: all, fitted jointly)",
    )
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
        help="extend the chain up to this many steps until it has converged "
        "(50 autocorrelation times, R-hat < 1.01, bulk ESS >= 400; default 5000); a chain "
        "whose 50 autocorrelation times exceed it stops early",
    )
    sp.add_argument(
        "--rank-by",
        default="aicc",
        choices=RANK_CHOICES,
        help="the column that orders the ranking (default aicc); whatever the order, the best "
        "law is the one with the lowest AICc among the laws the rows can rank (two numbers a "
        "row, at least the parameters plus two): docs/method/ranking.rst",
    )
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
    sp.add_argument(
        "--workers",
        type=count_value(1, 64, "workers"),
        default=min(2, os.cpu_count() or 1),
        help="local worker processes for the fits (default: 2, or 1 on one CPU; 1 runs in "
        "this process; the numbers are the same)",
    )
    sp.add_argument(
        "--scheduler",
        default=os.environ.get("FITDF_SCHEDULER") or None,
        metavar="ADDRESS",
        help="run the fits on this Dask cluster (default: FITDF_SCHEDULER, else local)",
    )
    sp.add_argument(
        "--posterior-out",
        default=None,
        metavar="FOLDER",
        help="write each posterior (--method nested, mcmc or both) to FOLDER as an ArviZ "
        "netCDF file, <data>_<law>_<chain>_<method>.nc: draws in physical units, pointwise "
        "log-likelihood, evidence and prior",
    )
    _add_cache_options(sp, "the rows' contents, options, seed")

    sp = add(
        "report",
        cmd_report,
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
        "--out", default="reports", metavar="DIR", help="output folder (default: reports)"
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
    sp.add_argument(
        "--scheduler",
        default=os.environ.get("FITDF_SCHEDULER") or None,
        metavar="ADDRESS",
        help="run the fits on this Dask cluster, e.g. tcp://host:8786 (default: the "
        "FITDF_SCHEDULER environment variable, else local processes; needs fitdf[dask])",
    )
    _add_cache_options(sp, "the settings, seed")

    sp = add(
        "limit-cycle",
        cmd_limit_cycle,
        "predict limit cycles of a loop closed around a fitted core",
        [
            'fitdf limit-cycle permalloy --plant "K/((1+s)(1+0.25s)(1+1.1s))" --gain 500 1000 2500 '
            "--source-impedance 600",
            'fitdf limit-cycle deltamax --plant "10/(s*(s+1)*(s+2))" --gain 1 --json',
            'fitdf limit-cycle B.3 --plant "K/((1+s)(1+0.25s)(1+1.1s))" --gain 1000 --plot loci.png',
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
    sp.add_argument(
        "--source-impedance",
        type=number_value(0.0, what="source impedance"),
        default=None,
        metavar="OHM",
        help="rows and DF at this source impedance (default: the data's only one)",
    )
    sp.add_argument(
        "--model", default=None, help="model to use (default: the lowest AICc of all models)"
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
        help="write the Nyquist-plane figure: the loci framed where they meet (the cycles, "
        "else the first cycle at the critical gain), beside a panel of the whole loci",
    )
    return p


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


def _validate(args):
    """Checks before anything is imported or computed (each value alone passed its ``type=``).

    Output paths are checked here, not when the output is written after minutes of fitting.
    """
    if args.command == "report":
        check_output_folder("--out", args.out, replaced=True)
    if getattr(args, "cache", None) is not None and not args.no_cache:
        check_output_folder("--cache", args.cache)
    if getattr(args, "plot", None) is not None:
        check_output_file("--plot", args.plot)
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


EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports it
EXIT_TERMINATED = 143  # 128 + SIGTERM


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that it is cleaned up like Ctrl-C (a report's
    workers stopped, its temporary folder removed, the previous report kept)."""


def _raise_terminated(signum, frame):
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a second SIGTERM ends the process at once
    raise Terminated


def _interrupt_main_soon(signum: int) -> None:
    """Signal ``signum`` to the main thread from a timer thread 0.1 s from now."""
    timer = threading.Timer(0.1, _thread.interrupt_main, args=(signum,))
    timer.daemon = True
    timer.start()


def _raise_swallowed_stop_again(unraisable, fallback=sys.__unraisablehook__) -> None:
    """``sys.unraisablehook`` while a command runs: a Ctrl-C or SIGTERM whose exception was
    raised inside a C callback is printed and dropped by ctypes ("Exception ignored on calling
    ctypes callback function": llvmlite's object-cache callback while numba compiles a
    kernel, as on a first run), and the command would run on. The signal is given to the main
    thread again a moment later, from another thread: raised from here, its exception would be
    dropped with this hook's. Anything else goes to ``fallback``, the hook there before."""
    exc = unraisable.exc_value
    if isinstance(exc, Terminated):
        signal.signal(signal.SIGTERM, _raise_terminated)  # the first one had reset it
        signum = signal.SIGTERM
    elif isinstance(exc, KeyboardInterrupt):
        signum = signal.SIGINT
    else:
        fallback(unraisable)
        return
    while True:
        try:
            _interrupt_main_soon(signum)
            return
        except (KeyboardInterrupt, Terminated):  # it came while still in here: once more
            continue


@contextlib.contextmanager
def stop_signals():
    """Ctrl-C and SIGTERM stop a command by an exception :func:`main` catches: SIGTERM raises
    :class:`Terminated` in the main thread, and a stop swallowed by a C callback is raised
    again (:func:`_raise_swallowed_stop_again`). Both restored on the way out; outside the
    main thread (no signal handlers there) only the hook is set."""
    hook = sys.unraisablehook
    try:
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    except ValueError:
        previous = False
    sys.unraisablehook = functools.partial(_raise_swallowed_stop_again, fallback=hook)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        if previous is not False:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _stopped_message(args, exc: BaseException) -> str:
    """The one line after Ctrl-C or SIGTERM: what was kept."""
    what = "terminated" if isinstance(exc, Terminated) else "interrupted"
    caches = getattr(args, "job_caches", [])  # (set once a command's caches are open)
    kept = sum(c.hits + c.written for c in caches)
    resume = (
        f"; {kept} finished {'job' if args.command == 'report' else 'fit'}"
        f"{'s' if kept != 1 else ''} kept in {caches[0].root}, the same command goes on from them"
        if kept
        else ""
    )
    if args.command == "report":
        out = str(args.out).rstrip("/") or str(args.out)
        if Path(args.out).is_dir():  # the report is written atomically: still the old one
            return f"fitdf: {what}; {out}/ left as it was{resume}"
        return f"fitdf: {what}; no report written to {out}/{resume}"
    if args.command == "fit":
        return f"fitdf: {what}; no results printed{resume}"
    return f"fitdf: {what}"


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except _UsageError as exc:
        print(one_line(str(exc)), file=sys.stderr)
        return EXIT_USAGE
    if not getattr(args, "command", None):
        parser.print_help()
        return EXIT_USAGE
    try:
        with stop_signals():
            _validate(args)
            return args.func(args)
    except FitdfError as exc:
        print(one_line(f"fitdf {args.command}: error: {exc}"), file=sys.stderr)
        return EXIT_USAGE
    except (KeyboardInterrupt, Terminated) as exc:
        print(_stopped_message(args, exc), file=sys.stderr)
        return EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED
    except Exception as exc:  # an internal failure, not the user's
        if args.debug:
            traceback.print_exc()
        print(
            f"fitdf {args.command}: internal error: {type(exc).__name__}: {exc} "
            "(rerun with --debug for the traceback and report it)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
