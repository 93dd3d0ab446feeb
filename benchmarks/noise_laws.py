"""The noise laws of the printed tables compared on Tables B.1-B.5 (``docs/method/noise.rst``).

For each block and each of its best laws (the committed ranking's first three), the law is
fitted by least squares under each noise law of :mod:`fitdf.inference.noise_models`:
``printed`` (the default fixed scales, multi-start) and, polished from that optimum, the fitted
``constant``, ``reading``, ``student`` and ``reading-student`` laws. Printed per fit: the
in-sample RMS, the maximised log-likelihood, AICc and BIC with the noise parameters counted
(approximations of the evidence from the maximum: AICc's and BIC's), the leave-one-frequency-
out RMS and log score (the held-out rows' log density under the law and noise fitted without
them), and the noise parameters. Then, per noise law, the order of the laws by AICc, and the
rows the printed-scale best fits miss most: how many of their residuals fall outside each
law's 95 % interval.

    python benchmarks/noise_laws.py                 # all five blocks (about 27 min of CPU)
    python benchmarks/noise_laws.py --blocks B.2 --laws 2 --json out.json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from scipy import stats

from fitdf.inference.api import resolve_data, resolve_geometry
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.noise_models import NOISE_LAWS, get_noise_law
from fitdf.inference.problem import FitProblem
from fitdf.inference.ranking import cross_validate

#: The committed report's three lowest-AICc laws per block (least squares, voltage chain).
BLOCK_LAWS = {
    "B.1": ("preisach", "jiles_atherton", "rayleigh"),
    "B.2": ("preisach", "jiles_atherton", "cubic_hc"),
    "B.3": ("preisach", "jiles_atherton", "constant_width"),
    "B.4": ("preisach", "jiles_atherton", "cubic_hc"),
    "B.5": ("preisach", "cubic_hc", "constant_width"),
}
#: How many of the rows the printed-scale best fits miss most (complex error) are examined.
N_WORST = 25


def _z(result):
    """Standardised magnitude and arc residuals of a fit under its fitted noise law (rows)."""
    problem = result.problem
    law = problem.noise_law
    radial, tang = problem.error_components(problem.predict(result.internal))
    sm, st = law.scales(result.info["noise_law"]["log10"], law.context(problem.data))
    return radial / sm, np.where(np.abs(problem.data.measured) > 0, tang / st, np.nan)


def run(blocks, n_laws, seed):
    out = {}
    for block in blocks:
        fd = resolve_data(block)
        geo = resolve_geometry("auto", fd)
        out[block] = {}
        for law in BLOCK_LAWS[block][:n_laws]:
            t0 = time.process_time()
            today = fit_lsq(FitProblem(fd, law, "voltage", None, None, geo), seed=seed)
            cv = cross_validate(today, seed)
            err = np.abs(today.problem.predict(today.internal) - fd.measured)
            rec = {
                "printed": {
                    "rms_complex": today.metrics["rms_complex"],
                    "aicc": today.metrics["aicc"],
                    "cv_rms_complex": cv["cv_rms_complex"],
                    "n_params": today.metrics["n_params"],
                    "values": today.values,
                }
            }
            for name in list(NOISE_LAWS)[1:]:
                problem = FitProblem(fd, law, "voltage", None, None, geo, noise_law=name)
                r = fit_lsq(problem, seed=seed, starts=today.internal)
                cv = cross_validate(r, seed)
                zm, zt = _z(r)
                nu = r.info["noise_law"]["values"].get("nu")
                q = 1.959963984540054 if nu is None else float(stats.t.ppf(0.975, nu))
                rec[name] = {
                    **{
                        k: r.metrics[k]
                        for k in ("rms_complex", "log_likelihood", "aicc", "bic", "n_params")
                    },
                    "n_noise_params": r.metrics["n_noise_params"],
                    "cv_rms_complex": cv["cv_rms_complex"],
                    "cv_log_score": cv["cv_log_score"],
                    "noise": r.info["noise_law"]["values"],
                    "values": r.values,
                    # per row: how many of its (one or two) terms fall outside the law's
                    # central 95 % interval, and how many terms it has
                    "outside_rows": (
                        (np.abs(zm) > q).astype(int) + (np.abs(np.nan_to_num(zt)) > q)
                    ).tolist(),
                    "terms_rows": (1 + np.isfinite(zt)).tolist(),
                    "warnings": [w for w in r.warnings if "noise" in w],
                }
            rec["rows"] = {
                "input_v": fd.amplitude.tolist(),
                "frequency_hz": fd.frequency.tolist(),
                "error_printed": err.tolist(),
            }
            rec["cpu_s"] = time.process_time() - t0
            out[block][law] = rec
            print(f"# {block} {law}: {rec['cpu_s']:.0f} s CPU", flush=True)
    return out


def table(out) -> str:
    names = list(NOISE_LAWS)
    lines = []
    head = (
        f"{'block':6}{'law':16}{'noise':16}{'k':>3}{'rms':>8}{'lnL':>9}{'AICc':>9}{'BIC':>9}"
        f"{'cv_rms':>8}{'cv_lnL':>9}  noise parameters"
    )
    lines.append(head)
    for block, laws in out.items():
        for law, rec in laws.items():
            for name in names:
                r = rec[name]
                k = r["n_params"] + r.get("n_noise_params", 0)
                noise = "  ".join(f"{a}={b:.3g}" for a, b in r.get("noise", {}).items())
                lnl = r.get("log_likelihood", np.nan)
                bic = r.get("bic", np.nan)
                cvl = r.get("cv_log_score", np.nan)
                lines.append(
                    f"{block:6}{law:16}{name:16}{k:3d}{r['rms_complex']:8.4f}{lnl:9.1f}"
                    f"{r['aicc']:9.1f}{bic:9.1f}{r['cv_rms_complex']:8.4f}{cvl:9.1f}  {noise}"
                )
    lines.append("")
    lines.append("order of the laws by AICc (printed: the default's profile AICc), per noise law")
    for block, laws in out.items():
        for name in names:
            order = sorted(laws, key=lambda law: laws[law][name]["aicc"])
            best = min(names[1:], key=lambda n: min(laws[law][n]["aicc"] for law in laws))
            lines.append(
                f"  {block} {name:16}: {' < '.join(order)}"
                + ("   <- lowest" if name == best else "")
            )
    lines.append("")
    lines.append(worst_rows(out))
    return "\n".join(lines)


def worst_rows(out) -> str:
    """The rows the printed-scale best fit of each block misses most, pooled: their inputs and, under
    each fitted noise law, the share of their terms (magnitude, arc) outside the law's central
    95 % interval, against all rows' (5 % for a law that describes them)."""
    noises = list(NOISE_LAWS)[1:]
    pooled = []
    for block, laws in out.items():
        rec = laws[next(iter(laws))]
        rows = rec["rows"]
        for i, e in enumerate(rows["error_printed"]):
            cover = {n: (rec[n]["outside_rows"][i], rec[n]["terms_rows"][i]) for n in noises}
            pooled.append((e, block, rows["frequency_hz"][i], rows["input_v"][i], cover))
    pooled.sort(key=lambda p: -p[0])
    worst = pooled[:N_WORST]

    def share(rows, n):
        return sum(p[4][n][0] for p in rows) / sum(p[4][n][1] for p in rows)

    lines = [
        f"the {len(worst)} rows the printed-scale best fits miss most (of {len(pooled)}): median input "
        f"{np.median([p[3] for p in worst]):.3g} V (all rows "
        f"{np.median([p[3] for p in pooled]):.3g} V), RMS error "
        f"{np.sqrt(np.mean([p[0] ** 2 for p in worst])):.4f}",
        "  share of their terms outside each fitted law's central 95 % interval (5 % expected):",
    ]
    for n in noises:
        lines.append(
            f"    {n:16} worst rows {share(worst, n):6.1%}   all rows {share(pooled, n):6.1%}"
        )
    for e, block, f, v, cover in pooled:
        if block == "B.3" and f == 6.0 and v == 0.1:
            zs = "  ".join(f"{n} {cover[n][0]}/{cover[n][1]}" for n in noises)
            lines.append(f"  B.3 6 c/s 0.1 V: error {e:.3f}; terms outside: {zs}")
    return "\n".join(lines)


#: Input-amplitude (V) and output-amplitude (V) bins of the residual study.
INPUT_BINS = (0.0, 0.1, 0.25, 0.5, 1.0, 2.0, np.inf)
OUTPUT_BINS = (0.0, 0.03, 0.1, 0.3, 1.0, np.inf)


def residual_study(results_json="reports/results.json") -> str:
    """The printed-scale best least-squares fit of each block (the committed report's optimum, not
    refitted): RMS magnitude and phase residual by input and by output amplitude, and the
    log-log slope of the residuals' size against each."""
    from fitdf.inference.metrics import phase_difference_deg

    with open(results_json) as fh:
        blocks = json.load(fh)["blocks"]
    lines = ["printed-scale best fits: RMS magnitude / phase (deg) residual [rows] by amplitude"]
    pooled = {"vin": [], "vout": [], "mag": [], "ph": []}
    for block in BLOCK_LAWS:
        law = blocks[block]["ranking_lsq"][0]["model"]
        fit = blocks[block]["fits_lsq"][law]
        fd = resolve_data(block)
        values = {p["parameter"]: p["value"] for p in fit["parameters"]}
        fixed = {p["parameter"]: p["value"] for p in fit["parameters"] if p["fixed"]}
        problem = FitProblem(fd, law, "voltage", None, fixed or None, resolve_geometry("auto", fd))
        M = problem.predict(problem.to_internal(values))
        D = fd.measured
        mag = np.abs(M) - np.abs(D)
        ph = np.where(np.abs(D) > 0, phase_difference_deg(M, D), np.nan)
        vout = fd.rows["h1_output_v"].to_numpy(float)
        for key, arr in zip(pooled, (fd.amplitude, vout, mag, ph)):
            pooled[key].append(arr)
        cells = []
        for lo, hi in zip(INPUT_BINS[:-1], INPUT_BINS[1:]):
            m = (fd.amplitude > lo) & (fd.amplitude <= hi)
            if m.any():
                cells.append(
                    f"{lo:g}-{hi:g} V: {_rms(mag[m]):.3f}/{_rms(ph[m]):.1f} [{int(m.sum())}]"
                )
        lines.append(f"  {block} {law}: " + "; ".join(cells))
    p = {k: np.concatenate(v) for k, v in pooled.items()}
    for name, x, bins in (("input", p["vin"], INPUT_BINS), ("output", p["vout"], OUTPUT_BINS)):
        cells = []
        for lo, hi in zip(bins[:-1], bins[1:]):
            m = (x > lo) & (x <= hi)
            if m.any():
                cells.append(f"{lo:g}-{hi:g} V: {_rms(p['mag'][m]):.3f}/{_rms(p['ph'][m]):.1f}")
        lines.append(f"  all blocks by {name}: " + "; ".join(cells))
    for col, xname in (("mag", "vin"), ("ph", "vout"), ("ph", "vin")):
        y, x = np.abs(p[col]), p[xname]
        ok = np.isfinite(y) & (y > 0) & (x > 0)
        slope = np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0]
        lines.append(f"  log-log slope of |{col}| against {xname}: {slope:.2f}")
    return "\n".join(lines)


def _rms(x):
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", nargs="+", default=list(BLOCK_LAWS))
    ap.add_argument("--laws", type=int, default=3, help="the best N laws of each block")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None, help="write the numbers to this file")
    ap.add_argument("--from-json", default=None, help="print the table of a saved run")
    ap.add_argument(
        "--residuals",
        action="store_true",
        help="only the residual study of the printed-scale fits (reports/results.json; seconds)",
    )
    args = ap.parse_args(argv)
    if args.residuals:
        print(residual_study())
        return
    if args.from_json:
        with open(args.from_json) as fh:
            out = json.load(fh)
    else:
        for name in NOISE_LAWS:
            get_noise_law(name)
        out = run(args.blocks, args.laws, args.seed)
        if args.json:
            with open(args.json, "w") as fh:
                json.dump(out, fh)
    print(table(out))


if __name__ == "__main__":
    main()
