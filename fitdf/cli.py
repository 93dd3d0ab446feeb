"""The ``fitdf`` command line: it parses (:mod:`fitdf.cli_parser`), calls the library and prints
what the results say of themselves (their ``text()``; ``--json``: their ``to_dict()``).

Every user mistake (unknown core, missing file, bad CSV, unknown law, impossible option or
option value, an output path that cannot be written) is one line on stderr and exit code 2,
before any work; an internal failure says so and where to look (``--debug`` shows the
traceback). A reader that closes the output early (``fitdf audit | head -1``) ends the
command normally, and Ctrl-C or SIGTERM ends it with one line saying what was kept
(:mod:`fitdf.stop_signals`).

Start-up stays light: this module imports only the standard library, the parser and
``fitdf.errors`` at the top, so ``fitdf --version`` and every ``--help`` answer without loading
numpy, pandas, matplotlib or the fitting stack. Each subcommand handler (``cmd_*``) imports
what it needs when it runs -- the only function-level imports the package allows
(tests/test_architecture.py).
"""

from __future__ import annotations

import json
import os
import re
import sys
import textwrap
import traceback
from pathlib import Path

from fitdf.cli_parser import DEFAULT_CHAIN, UsageError, build_parser, validate
from fitdf.errors import FitdfError, ModelError, OptionError
from fitdf.stop_signals import EXIT_INTERRUPTED, EXIT_TERMINATED, Terminated, stop_signals

__all__ = ["main", "build_parser"]

EXIT_USAGE = 2
EXIT_INTERNAL = 1


class _OutputClosed(Exception):
    """The reader of stdout went away (``| head``): the command ends normally."""


def _out(text: str = "") -> None:
    """Print ``text`` on stdout, flushed; a closed pipe raises :class:`_OutputClosed`."""
    try:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()
    except BrokenPipeError:
        raise _OutputClosed from None


def _silence_stdout() -> None:
    """Point stdout at the null device, so that the interpreter's last flush of a closed
    pipe does not fail (Python's documented recipe for SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # not a file descriptor (a test's StringIO): nothing to do
        pass


def _flushed(code: int) -> int:
    """``code`` once stdout is flushed; a reader gone meanwhile is a normal end."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _silence_stdout()
    return code


#: Characters that end a line for ``str.splitlines`` (and for many terminals).
_LINE_BREAKS = re.compile("[\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029]")


def one_line(message: str) -> str:
    """``message`` on one line: line breaks a user typed into a value are shown escaped."""
    return _LINE_BREAKS.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), message)


def _note(text: str) -> None:
    """A warning or note on stderr, wrapped within 100 columns (an error stays one line)."""
    lines = textwrap.wrap(text, 100, subsequent_indent="  ", break_on_hyphens=False)
    print("\n".join(lines), file=sys.stderr)


def _emit_json(obj) -> None:
    """Print ``obj`` (already through :func:`fitdf._json.clean`) as strict JSON."""
    _out(json.dumps(obj, indent=2, allow_nan=False))


# ------------------------------------------------------------------ commands
def cmd_datasets(args):
    from fitdf._json import clean
    from fitdf.data import datasets
    from fitdf.data.presentation import datasets_text

    table = datasets.summary()
    if args.json:
        records = table.to_dict(orient="records")
        _emit_json(clean({"datasets": datasets.names(), "appendix_b": records}))
        return 0
    _out(datasets_text(datasets.names(), table, wide=args.wide))
    return 0


def cmd_audit(args):
    from fitdf._json import clean
    from fitdf.data import audit, datasets
    from fitdf.data.presentation import audit_text

    frame = audit.audit(datasets.load(args.data))
    if args.json:
        factors = audit.block_factors(frame) if "h1_output_v" in frame else None
        record = {
            "rows": len(frame),
            "flagged": frame[frame["flag"] != "ok"].to_dict(orient="records"),
            "block_factors": None if factors is None else factors.to_dict(orient="records"),
            "findings": audit.findings(frame),
        }
        _emit_json(clean(record))
        return 0
    _out(audit_text(frame, str(args.data), wide=args.wide))
    return 0


def cmd_models(args):
    from fitdf._json import clean
    from fitdf.chains import CHAINS
    from fitdf.models import ADDITIONAL_MODELS, MODELS, get_model, law_name
    from fitdf.params import DIMENSIONLESS

    chosen = None if args.law is None else _law_names([args.law], "LAW", law_name)[0]
    laws = [get_model(chosen)] if chosen is not None else list(MODELS.values())
    if args.json:
        chains = [
            {"name": c.name, "title": c.title, "parameters": [p.name for p in c.params]}
            for c in CHAINS.values()
        ]
        _emit_json(clean({"models": [m.describe() for m in laws], "chains": chains}))
        return 0
    if args.law is None:
        _out("\n\n".join(m.text(brief=True) for m in laws))
        _out("\nLaws fitted only when named (fitdf fit --models NAME):")
        _out("\n\n".join(m.text(brief=True) for m in ADDITIONAL_MODELS.values()))
        _out("\nMeasurement chains:")
        _out("\n".join(c.text(brief=True) for c in CHAINS.values()))
        _out("\n'fitdf models LAW' explains one law, its parameters and the chains' parameters.")
        return 0
    chains = [c.text(default=c.name == DEFAULT_CHAIN) for c in CHAINS.values()]
    note = (
        f"unit {DIMENSIONLESS}: dimensionless; scale log: the fits work with log10 of the "
        "value. Bounds are the default box (the prior support); with a core's geometry a fit "
        "narrows them to the material's physical limits."
    )
    _out(laws[0].text())
    _out("\nMeasurement chains (fitdf fit --chain; their parameters are fitted with the law's):")
    _out("\n\n".join(chains))
    _out("\n" + "\n".join(textwrap.wrap(note, 100)))
    return 0


def _law_names(given, option: str, law_name) -> list[str]:
    """The laws ``given`` name, in any case (``law_name``: :func:`fitdf.models.law_name`),
    the option named in the one-line error."""
    try:
        return [law_name(name) for name in given]
    except ModelError as exc:
        raise OptionError(f"{option}: {exc}") from None


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
    from fitdf.models import law_name, model_names

    models = _law_names(args.models, "--models", law_name) if args.models else model_names()
    geometry = parse_geometry(args.geometry) if args.geometry else "auto"
    sources, batch = fit_sources(args.data, {*datasets.names(), "appendix_b"})
    # every dataset is read and checked before the first fit, and before the fitting stack
    # is imported (~5 s): a bad file fails at once, naming file, row and column
    rows = [resolve_data(src, args.policy, args.source_impedance) for src in sources]
    for line in order_warnings(sources, rows, order_notes):
        _note(line)
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
    from fitdf.inference.presentation import summary_text
    from fitdf.inference.ranking import compare_fits

    records, summary = [], []
    show = not args.quiet and not args.json
    fit_kw = dict(n_steps=args.steps, max_steps=args.max_steps, geometry=geometry)
    if args.noise != "printed":  # (the default's cache key as it was)
        fit_kw["noise"] = args.noise
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
            summary.append(clean(comparison.summary_record(src)))
            if args.posterior_out:
                for path in write_posteriors(comparison.results, args.posterior_out):
                    if not args.quiet:
                        _note(f"fitdf fit: wrote {path}")
            if not args.json:
                _out(("\n" if batch else "") + comparison.text(wide=args.wide, brief=batch))
    per_fit = len(models) * len(args.chain) * (2 if args.method == "both" else 1)
    _reused_note(args, executor, per_fit * len(sources))
    if args.json:
        out = {"seed": args.seed, "rank_by": args.rank_by, "summary": summary}
        _emit_json({**out, "files": records} if batch else records[0])
    elif batch:
        _out(f"\nSummary ({len(summary)} datasets, best: the lowest AICc of the laws ranked):")
        _out(summary_text(summary, wide=args.wide))
    return 0


def _reused_note(args, executor, total: int) -> None:
    """The line on stderr saying how many fits were read from the cache, if any."""
    if executor.reused and not args.quiet:
        _note(
            f"fitdf {args.command}: {len(executor.reused)} of {total} fits read from "
            f"{args.job_caches[0].root}, kept by an earlier run of the same rows, options, code "
            "and machine (--no-cache computes them again)"
        )


def cmd_report(args):
    from fitdf.report.build import generate_report, job_cache
    from fitdf.report.settings import ReportSettings

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
            replace=args.replace,
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
    _out(f"report written to {out}/ (README.md, index.html, results.json, figures/)")
    return 0


def cmd_limit_cycle(args):
    from fitdf._json import clean
    from fitdf.data.resolve import resolve_data
    from fitdf.executor import Executor
    from fitdf.inference.cache import comparison_cache
    from fitdf.loop.fitted import fitted_limit_cycles
    from fitdf.models import law_name
    from fitdf.plots.limit_cycles import plot_nyquist

    model = None if args.model is None else _law_names([args.model], "--model", law_name)[0]
    args.job_caches = []  # (after Ctrl-C, the one line says what the cache kept)
    cache = None
    if not args.no_cache:
        rows = resolve_data(args.data, source_impedance=args.source_impedance)
        cache = comparison_cache(
            args.cache,
            rows,
            seed=args.seed,
            cross_validation=False,
            command="limit-cycle",
            chain=args.chain,
            model=model,
            source_impedance=args.source_impedance,
        )
        args.job_caches.append(cache)
    show = not args.quiet and not args.json
    with Executor(workers=1, progress=show, cache=cache) as executor:
        found = fitted_limit_cycles(
            args.data,
            args.plant,
            args.gain,
            args.source_impedance,
            model=model,
            chain=args.chain,
            seed=args.seed,
            time_scale=args.time_scale,
            runner=executor.run,
        )
    _reused_note(args, executor, len(found.fits))
    if args.plot is not None:
        try:
            plot_nyquist(found.response).savefig(args.plot)
        except (OSError, ValueError) as exc:  # the folder went away, the disk filled, ...
            reason = getattr(exc, "strerror", None) or exc
            raise OptionError(
                f"--plot {args.plot}: the figure could not be written ({reason})"
            ) from None
    if args.json:
        _emit_json(clean(found.to_dict()))
        return 0
    _out(found.text())
    if args.plot:
        _out(f"Nyquist-plane figure written to {args.plot}")
    return 0


#: The handler of each subcommand.
HANDLERS = {
    "datasets": cmd_datasets,
    "audit": cmd_audit,
    "models": cmd_models,
    "fit": cmd_fit,
    "report": cmd_report,
    "limit-cycle": cmd_limit_cycle,
}


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
    if args.command in ("fit", "limit-cycle"):
        return f"fitdf: {what}; no results printed{resume}"
    return f"fitdf: {what}"


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        print(one_line(str(exc)), file=sys.stderr)
        return EXIT_USAGE
    except SystemExit:  # --help, --version: printed; a reader gone meanwhile is no error
        _flushed(0)
        raise
    if not getattr(args, "command", None):
        parser.print_help()
        return _flushed(EXIT_USAGE)
    try:
        with stop_signals():
            validate(args)
            return _flushed(HANDLERS[args.command](args))
    except _OutputClosed:
        _silence_stdout()
        return 0
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
