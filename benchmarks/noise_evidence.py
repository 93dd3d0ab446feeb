"""The noise laws and the Rayleigh-Preisach law ranked by the evidence (``docs/method/noise.rst``).

Nested sampling (:func:`fitdf.inference.nested.fit_nested`, nautilus, 300 live points, the
default convergence: 400 effective draws and an evidence error of 0.3 at most) through the
``voltage`` chain:

1. **Noise laws.** The Preisach law under the ``constant``, ``reading`` and ``student``
   noise laws (:mod:`fitdf.inference.noise_models`; their parameters sampled with the law's,
   log-uniform on their boxes) on Tables B.2 and B.3 (``--blocks`` adds B.5): ``ln Z`` with
   its error, the effective draws, the likelihood evaluations and the wall time; the Bayes
   factors ``ln Z(reading) - ln Z(constant)`` and ``ln Z(student) - ln Z(constant)``
   beside the AICc gaps of the same fits by least squares (``benchmarks/noise_laws.json``:
   ``-Delta AICc / 2`` is the log Bayes factor AICc approximates); the posterior medians of
   the law's parameters under each noise law, and of the noise parameters.
2. **Low field.** ``preisach_rayleigh`` against ``preisach`` on Table B.2 (Deltamax's
   single table, :data:`fitdf.datasets.CORES`), under the ``printed`` noise (the two scales
   integrated out, :mod:`fitdf.inference.noise`: the evidence the report ranks by; Preisach's
   is the committed report's posterior) and under the ``reading`` law: ``ln Z`` of each and
   the Bayes factor.

The sampler starts from the prior, so no least-squares fit is run first (the result's
``lsq_chi2`` is NaN). Each run is written to the json as it ends (``--json``, default
``benchmarks/noise_evidence.json``), and a run the json holds is not run again: the
committed json holds the runs one budget of 35 min of wall time allowed (B.2 under
``constant`` and ``reading``, ``preisach_rayleigh`` under ``printed``), 8-12 min each on two
shared cores. ``--from-json`` prints the tables again.

    python benchmarks/noise_evidence.py                     # the rest of B.2, B.3 (~1 h)
    python benchmarks/noise_evidence.py --blocks B.2 B.3 B.5
    python benchmarks/noise_evidence.py --from-json
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from types import SimpleNamespace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from fitdf.inference.api import resolve_data, resolve_geometry
from fitdf.inference.nested import fit_nested
from fitdf.inference.problem import FitProblem

HERE = Path(__file__).resolve().parent
#: The noise laws compared on the Preisach law, per block.
NOISE = ("constant", "reading", "student")
#: Deltamax's single table (Table B.5 is Deltamax too, with 12 times the rows' cost).
LOW_FIELD_BLOCK = "B.2"
#: (preisach under ``printed`` is the committed report's posterior, ``reports/results.json``:
#: the same likelihood, prior and sampler settings; run here only when named by ``--only``)
LOW_FIELD_RUNS = (
    ("preisach", "printed"),
    ("preisach_rayleigh", "printed"),
    ("preisach", "reading"),
    ("preisach_rayleigh", "reading"),
)
#: The run the committed report's posterior stands for unless ``--only`` names it.
FROM_REPORT = f"{LOW_FIELD_BLOCK}/preisach/printed"
#: The stand-in for the least-squares fit :func:`fit_nested` records (none is run).
NO_LSQ = SimpleNamespace(metrics={})


def run_one(block, law, noise, seed):
    fd = resolve_data(block)
    problem = FitProblem(
        fd, law, "voltage", None, None, resolve_geometry("auto", fd), noise_law=noise
    )
    t0, c0 = time.perf_counter(), time.process_time()
    r = fit_nested(problem, NO_LSQ, seed=seed)
    d = r.diagnostics
    rec = {
        "block": block,
        "law": law,
        "noise": noise,
        "log_evidence": d["log_evidence"],
        "log_evidence_error": d["log_evidence_error"],
        "n_effective": d["n_effective"],
        "n_likelihood_evaluations": d["n_likelihood_evaluations"],
        "converged": d["converged"],
        "seconds": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
        "ndim": problem.ndim + (0 if problem.noise_law is None else len(problem.noise_law.names)),
        "rms_complex": r.metrics["rms_complex"],
        "median": {k: v["p50"] for k, v in r.intervals.items()},
        "interval68": {k: [v["p16"], v["p84"]] for k, v in r.intervals.items()},
        "warnings": list(r.warnings),
    }
    if problem.noise_law is not None:
        rec["noise_median"] = r.info["noise_law"]["median"]
        rec["noise_intervals"] = r.info["noise_law"]["intervals"]
    else:
        rec["noise_median"] = {
            k.replace("_interval", ""): v["p50"]
            for k, v in d.items()
            if k.endswith("_interval") and k.startswith("sigma_")
        }
    return rec


def report_record(block, law):
    """The committed report's nested posterior of ``law`` on ``block`` (``printed`` noise,
    the same sampler settings), in this script's record, or None: ``median`` holds the
    report's point estimate (its records carry no median)."""
    path = HERE.parent / "reports" / "results.json"
    if not path.exists():
        return None
    fits = json.loads(path.read_text())["blocks"].get(block, {}).get("fits_posterior", {})
    if law not in fits:
        return None
    r = fits[law]
    d = r["diagnostics"]
    names = [p["parameter"] for p in r["parameters"]]
    return {
        "block": block,
        "law": law,
        "noise": "printed",
        "source": "reports/results.json",
        "log_evidence": d["log_evidence"],
        "log_evidence_error": d["log_evidence_error"],
        "n_effective": d["n_effective"],
        "n_likelihood_evaluations": d["n_likelihood_evaluations"],
        "converged": d["converged"],
        "seconds": float("nan"),
        "ndim": len(names),
        "rms_complex": r["metrics"]["rms_complex"],
        "median": {p["parameter"]: p["value"] for p in r["parameters"]},
        "interval68": {p["parameter"]: [p["p16"], p["p84"]] for p in r["parameters"]},
        "noise_median": {
            k.replace("_interval", ""): v["p50"]
            for k, v in d.items()
            if k.endswith("_interval") and k.startswith("sigma_")
        },
    }


def key(rec):
    return f"{rec['block']}/{rec['law']}/{rec['noise']}"


def plan(blocks):
    runs = [(b, "preisach", n) for b in blocks[:1] for n in NOISE]
    runs += [(LOW_FIELD_BLOCK, law, n) for law, n in LOW_FIELD_RUNS]
    runs += [(b, "preisach", n) for b in blocks[1:] for n in NOISE]
    return runs


def tables(records, aicc) -> str:
    by = {key(r): r for r in records}
    for law in ("preisach", "preisach_rayleigh"):  # the report's, where not run here
        k = f"{LOW_FIELD_BLOCK}/{law}/printed"
        if k not in by and report_record(LOW_FIELD_BLOCK, law) is not None:
            by[k] = report_record(LOW_FIELD_BLOCK, law)
    lines = ["1. Noise laws on the Preisach law (nested sampling, 300 live points)", ""]
    lines.append(
        f"{'block':6}{'noise':10}{'ndim':>5}{'ln Z':>10}{'+-':>6}{'n_eff':>7}{'evals':>8}"
        f"{'s':>7}{'rms':>8}{'lnB vs const':>14}{'-dAICc/2':>10}"
    )
    blocks = sorted({r["block"] for r in records if r["law"] == "preisach" and r["noise"] in NOISE})
    for b in blocks:
        base = by.get(f"{b}/preisach/constant")
        for n in NOISE:
            r = by.get(f"{b}/preisach/{n}")
            if r is None:
                continue
            lnb = r["log_evidence"] - base["log_evidence"] if base else np.nan
            err = np.hypot(r["log_evidence_error"], base["log_evidence_error"]) if base else np.nan
            gap = aicc.get(b, {}).get(n, np.nan)
            lnb_s = "" if n == "constant" else f"{lnb:8.1f}+-{err:.2f}"
            gap_s = "" if n == "constant" else f"{gap:10.1f}"
            lines.append(
                f"{b:6}{n:10}{r['ndim']:5d}{r['log_evidence']:10.2f}{r['log_evidence_error']:6.2f}"
                f"{r['n_effective']:7.0f}{r['n_likelihood_evaluations']:8d}{r['seconds']:7.0f}"
                f"{r['rms_complex']:8.4f}{lnb_s:>14}{gap_s}"
            )
    lines += ["", "posterior medians (the law's parameters; then the noise's)"]
    for b in blocks:
        for n in NOISE:
            r = by.get(f"{b}/preisach/{n}")
            if r is None:
                continue
            law = "  ".join(f"{k}={v:.4g}" for k, v in r["median"].items())
            noise = "  ".join(f"{k}={v:.3g}" for k, v in r["noise_median"].items())
            lines.append(f"  {b} {n:9} {law}")
            lines.append(f"  {'':3} {'':9} noise: {noise}")
    lines += ["", f"2. preisach_rayleigh against preisach on {LOW_FIELD_BLOCK}", ""]
    for n in ("printed", "reading"):
        a = by.get(f"{LOW_FIELD_BLOCK}/preisach/{n}")
        c = by.get(f"{LOW_FIELD_BLOCK}/preisach_rayleigh/{n}")
        for r in (a, c):
            if r is not None:
                lines.append(
                    f"  {n:8} {r['law']:18} ndim {r['ndim']:2d}  ln Z {r['log_evidence']:9.2f} "
                    f"+- {r['log_evidence_error']:.2f}  n_eff {r['n_effective']:5.0f}  "
                    f"evals {r['n_likelihood_evaluations']:6d}  {r['seconds']:5.0f} s  "
                    f"rms {r['rms_complex']:.4f}" + (f"  ({r['source']})" if "source" in r else "")
                )
        if a is not None and c is not None:
            lnb = c["log_evidence"] - a["log_evidence"]
            err = np.hypot(c["log_evidence_error"], a["log_evidence_error"])
            lines.append(f"  {n:8} ln B(preisach_rayleigh : preisach) = {lnb:.2f} +- {err:.2f}")
            common = [k for k in a["median"] if k in c["median"]]
            what = "point estimate" if "source" in a else "median"
            lines.append(
                f"           preisach's {what} -> preisach_rayleigh's median: "
                + "  ".join(f"{k} {a['median'][k]:.4g}->{c['median'][k]:.4g}" for k in common)
            )
            extra = [k for k in c["median"] if k not in a["median"]]
            lines.append(
                "           the Rayleigh part: "
                + "  ".join(f"{k} {c['median'][k]:.4g}" for k in extra)
            )
    return "\n".join(lines)


def aicc_gaps() -> dict:
    """``-Delta AICc / 2`` of each noise law against ``constant`` for the Preisach law's
    least-squares fits (``benchmarks/noise_laws.json``): AICc's estimate of ``ln B``."""
    path = HERE / "noise_laws.json"
    if not path.exists():
        return {}
    nl = json.loads(path.read_text())
    out = {}
    for b, laws in nl.items():
        rec = laws.get("preisach")
        if rec:
            base = rec["constant"]["aicc"]
            out[b] = {n: -(rec[n]["aicc"] - base) / 2.0 for n in NOISE if n in rec}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--blocks", nargs="+", default=["B.2", "B.3"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=str(HERE / "noise_evidence.json"))
    ap.add_argument("--from-json", action="store_true")
    ap.add_argument("--only", nargs="*", default=None, help="block/law/noise keys to run")
    args = ap.parse_args(argv)
    path = Path(args.json)
    records = json.loads(path.read_text())["runs"] if path.exists() else []
    if not args.from_json:
        done = {key(r) for r in records}
        for block, law, noise in plan(args.blocks):
            k = f"{block}/{law}/{noise}"
            if k in done or (args.only is not None and k not in args.only):
                continue
            if k == FROM_REPORT and (args.only is None or k not in args.only):
                continue  # the committed report's (report_record)
            rec = run_one(block, law, noise, args.seed)
            records.append(rec)
            print(
                f"# {k}: ln Z {rec['log_evidence']:.2f} +- {rec['log_evidence_error']:.2f}, "
                f"{rec['n_likelihood_evaluations']} evaluations, {rec['seconds']:.0f} s",
                flush=True,
            )
            path.write_text(json.dumps({"seed": args.seed, "runs": records}, indent=1) + "\n")
    print(tables(records, aicc_gaps()))


if __name__ == "__main__":
    main()
