"""The ``fitdf`` command line: a thin layer that parses options and calls the library.

Every user mistake (unknown core, missing file, bad CSV, unknown model, impossible
option combination) is one line on stderr and exit code 2; an internal failure says so
and where to look (``--debug`` shows the traceback).
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback

import pandas as pd
from tqdm.auto import tqdm

from fitdf import __version__
from fitdf._json import clean
from fitdf.chains import CHAINS, chain_names
from fitdf.data import audit, datasets
from fitdf.data.cores import parse_geometry
from fitdf.errors import FitdfError, OptionError
from fitdf.inference.api import DEFAULT_CHAIN
from fitdf.inference.ranking import METHOD_CHOICES, RANK_COLUMNS, compare_fits
from fitdf.loop.fitted import fitted_limit_cycles
from fitdf.models import MODELS, model_names
from fitdf.plots.limit_cycles import plot_nyquist
from fitdf.report.build import generate_report

EXIT_USAGE = 2
EXIT_INTERNAL = 1


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit code 2)."""

    def error(self, message):
        raise _UsageError(f"{self.prog}: {message}")


class _UsageError(Exception):
    pass


def _emit_json(obj):
    json.dump(clean(obj), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


# ------------------------------------------------------------------ commands
def cmd_datasets(args):
    table = datasets.summary()
    if args.json:
        _emit_json(
            {"datasets": datasets.names(), "appendix_b": clean(table.to_dict(orient="records"))}
        )
        return 0
    print("Bundled datasets: " + ", ".join(datasets.names()))
    print("\nAppendix B rows per table and frequency:")
    print(table.to_string(index=False))
    return 0


def cmd_audit(args):
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
    if factors is not None:
        print("DF factor per block (printed vs followed by the data):")
        print(factors.to_string(index=False), "\n")
    if not flagged.empty:
        with pd.option_context("display.max_colwidth", 200, "display.width", 250):
            print(flagged[cols].to_string(index=False))
    for line in audit.findings(frame):
        print("- " + line)
    return 0


def cmd_models(args):
    if args.json:
        _emit_json(
            {
                "models": [m.describe() for m in MODELS.values()],
                "chains": [
                    {"name": c.name, "title": c.title, "parameters": [p.name for p in c.params]}
                    for c in CHAINS.values()
                ],
            }
        )
        return 0
    for m in MODELS.values():
        print(
            f"{m.name}: {m.title} ({m.equations})"
            + ("  [N depends on frequency]" if m.frequency_dependent else "")
        )
        for p in m.params:
            print(
                f"    {p.name:<11s} {p.unit:<8s} bounds [{p.bounds[0]:g}, {p.bounds[1]:g}]  {p.description}"
                + (f" ({p.equation})" if p.equation else "")
            )
    print("\nMeasurement chains:")
    for c in CHAINS.values():
        print(f"{c.name}: {c.title}; parameters: {', '.join(p.name for p in c.params) or 'none'}")
    return 0


def _ranking_text(table):
    cols = [
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
        "indistinguishable_from",
    ]
    show = table[[c for c in cols if c in table and not table[c].isna().all()]]
    return show.to_string(index=False, float_format=lambda v: f"{v:.4g}")


def cmd_fit(args):
    models = args.models or model_names()
    methods = len(METHOD_CHOICES[args.method])
    progress = None
    if not args.quiet and not args.json:
        progress = tqdm(
            total=len(models) * len(args.chain) * methods,
            desc="fitting",
            file=sys.stderr,
            disable=None,
        )
    try:
        comparison = compare_fits(
            args.data,
            models=models,
            chains=tuple(args.chain),
            method=args.method,
            seed=args.seed,
            rank_by=args.rank_by,
            cross_validation=not args.no_cv,
            progress=progress,
            source_impedance=args.source_impedance,
            policy=args.policy,
            n_steps=args.steps,
            max_steps=args.max_steps,
            geometry=parse_geometry(args.geometry) if args.geometry else "auto",
        )
    finally:
        if progress is not None:
            progress.close()
    table, results, best = comparison.table, comparison.results, comparison.best
    if args.json:
        _emit_json(
            clean(
                {
                    "data": str(args.data),
                    "seed": args.seed,
                    "rank_by": args.rank_by,
                    "ranking": table.to_dict(orient="records"),
                    "fits": [r.to_dict() for r in results],
                }
            )
        )
        return 0
    print(
        f"Ranking on {results[0].label} ({results[0].metrics['n_points']} rows, seed {args.seed}), "
        f"ordered by {args.rank_by}:"
    )
    print(_ranking_text(table))
    print("\nBest model:")
    print(best.summary())
    print(_material_text(best))
    for r in results:
        if r.method == "mcmc":
            d = r.diagnostics
            print(
                f"MCMC {r.model}: {'converged' if d['converged'] else 'NOT converged'} "
                f"(steps/tau {d['steps_over_tau']:.0f}, max R-hat {max(d['rhat'].values()):.3f}, "
                f"min ESS {min(d['ess_bulk'].values()):.0f}, acceptance {d['acceptance_mean']:.2f})"
            )
    return 0


def _material_text(result) -> str:
    """The best fit's material constants beside the Appendix A ranges (when there is a geometry)."""
    if result.material is None:
        return "  (no core geometry: material constants not computed; see --geometry)"
    check = result.material.get("appendix_a_check")
    if not check:
        c = result.material["constants"]
        return (
            f"  material: mu_i {c['initial_permeability']:.4g}, mu_max {c['maximum_permeability']:.4g}, "
            f"H_c {c['coercive_force_oe']:.3g} Oe, B_p {c['peak_flux_density_gauss']:.4g} G, "
            f"B_r/B_p {c['squareness']:.3g} (no catalogue ranges for this core)"
        )
    lines = ["  material constants vs Appendix A:"]
    for row in check:
        high = "" if row["high"] is None else f"{row['high']:.4g}"
        fitted = "n/a" if row["fitted"] is None else f"{row['fitted']:.4g}"
        mark = "inside" if row["inside"] else "OUTSIDE"
        lines.append(
            f"    {row['quantity']:<24s} {fitted:>10s} {row['unit']:<13s} "
            f"range {row['low']:.4g}..{high:<8s} {mark}"
        )
    return "\n".join(lines)


def cmd_report(args):
    out = generate_report(
        out_dir=args.out, seed=args.seed, quick=args.quick, progress=not args.quiet
    )
    print(f"report written to {out}/ (README.md, index.html, results.json, figures/)")
    return 0


def cmd_limit_cycle(args):
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
        _emit_json(result)
        return 0
    print(format_limit_cycle_table(result))
    if args.plot:
        print(f"Nyquist-plane figure written to {args.plot}")
    return 0


def format_limit_cycle_table(result: dict) -> str:
    """Plain-text table of a :class:`~fitdf.loop.fitted.FittedLimitCycles` record (``to_dict``)."""
    lines = [
        f"Limit cycles of {result['plant']} with the {result['model']} core "
        f"({result['chain']} chain) fitted to {result['data']} at {result['source_impedance_ohm']:g} ohm",
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
    crit = result.get("critical_gain")
    point = result.get("critical_point", {})
    lines.append("")
    if crit is None:
        lines.append("No gain gives a limit cycle in the amplitude range searched.")
    else:
        where = " (at the edge of the amplitude range)" if point.get("at_boundary") else ""
        lines.append(
            f"Oscillations die out below gain {crit:.4g}; the first cycle appears at "
            f"A = {point.get('amplitude'):.3g} V, omega = {point.get('omega'):.3g} rad/s{where}."
        )
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

    def add(name, func, help, examples):
        sp = sub.add_parser(
            name,
            help=help,
            description=help,
            formatter_class=argparse.RawDescriptionHelpFormatter,
            epilog="examples:\n" + "\n".join(f"  {e}" for e in examples),
        )
        sp.set_defaults(func=func)
        sp.add_argument("--json", action="store_true", help="print JSON on stdout instead of text")
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
    add(
        "models",
        cmd_models,
        "list the candidate models with their parameters and equations",
        ["fitdf models", "fitdf models --json"],
    )
    sp = add(
        "fit",
        cmd_fit,
        "fit every model to a core and print the ranking",
        [
            "fitdf fit permalloy",
            "fitdf fit B.3 --method both --steps 2000",
            "fitdf fit deltamax --source-impedance 600 --models constant_width rayleigh --json",
        ],
    )
    sp.add_argument(
        "data", help="core name (permalloy, deltamax, supermalloy), table (B.1..B.5) or CSV path"
    )
    sp.add_argument("--method", choices=["lsq", "mcmc", "both"], default="lsq")
    sp.add_argument("--models", nargs="+", metavar="MODEL", help="models to fit (default: all)")
    sp.add_argument(
        "--chain",
        nargs="+",
        default=[DEFAULT_CHAIN],
        choices=chain_names(),
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
        type=float,
        default=None,
        metavar="OHM",
        help="only rows at this source impedance (default: all, fitted jointly)",
    )
    sp.add_argument("--seed", type=int, default=0)
    sp.add_argument(
        "--steps", type=int, default=1000, help="minimum MCMC steps per walker (default 1000)"
    )
    sp.add_argument(
        "--max-steps",
        type=int,
        default=5000,
        help="extend the chain up to this many steps until it is 50 autocorrelation times long",
    )
    sp.add_argument("--rank-by", default="rms_complex", choices=list(RANK_COLUMNS))
    sp.add_argument(
        "--policy",
        default="default",
        choices=["default", "all", "strict"],
        help="which audited rows to use (datasets/README.md)",
    )
    sp.add_argument(
        "--no-cv", action="store_true", help="skip the leave-one-frequency-out cross-validation"
    )

    sp = add(
        "report",
        cmd_report,
        "fit every model to every core and write the comparison report",
        ["fitdf report", "fitdf report --out /tmp/myreport --seed 3", "fitdf report --quick"],
    )
    sp.add_argument(
        "--out", default="reports", metavar="DIR", help="output folder (default: reports)"
    )
    sp.add_argument("--seed", type=int, default=0)
    sp.add_argument("--quick", action="store_true", help="least squares only, for a fast look")

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
        "--gain", type=float, nargs="+", default=[1.0], metavar="K", help="loop gain(s) K"
    )
    sp.add_argument(
        "--source-impedance",
        type=float,
        default=None,
        metavar="OHM",
        help="rows and DF at this source impedance (default: the data's only one)",
    )
    sp.add_argument(
        "--model", default=None, help="model to use (default: the lowest AICc of all models)"
    )
    sp.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        metavar="ALPHA",
        help="run the plant as G(s/ALPHA), e.g. for a time-scaled analog computer (default 1)",
    )
    sp.add_argument("--chain", default=DEFAULT_CHAIN, choices=chain_names())
    sp.add_argument("--seed", type=int, default=0)
    sp.add_argument(
        "--plot", default=None, metavar="FILE.png", help="write the Nyquist-plane figure"
    )
    return p


def _validate(args):
    if getattr(args, "model", None) and args.model not in model_names():
        raise OptionError(f"unknown model {args.model!r}; known: {', '.join(model_names())}")
    if getattr(args, "models", None):
        unknown = [m for m in args.models if m not in model_names()]
        if unknown:
            raise OptionError(
                f"unknown model(s) {', '.join(unknown)}; known: {', '.join(model_names())}"
            )
    if getattr(args, "steps", None) is not None and args.steps < 50:
        raise OptionError("--steps must be at least 50")
    if getattr(args, "time_scale", 1.0) <= 0:
        raise OptionError("--time-scale must be positive")
    if getattr(args, "max_steps", None) is not None and args.max_steps < args.steps:
        raise OptionError("--max-steps must be at least --steps")
    if (
        getattr(args, "rank_by", None) in ("looic", "waic")
        and getattr(args, "method", "mcmc") == "lsq"
    ):
        raise OptionError(f"--rank-by {args.rank_by} needs --method mcmc or both")


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except _UsageError as exc:
        print(str(exc), file=sys.stderr)
        return EXIT_USAGE
    if not getattr(args, "command", None):
        parser.print_help()
        return EXIT_USAGE
    try:
        _validate(args)
        return args.func(args)
    except FitdfError as exc:
        print(f"fitdf {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("fitdf: interrupted", file=sys.stderr)
        return 130
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
