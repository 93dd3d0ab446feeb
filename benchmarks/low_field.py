"""Low-field behaviour: today's laws against Rayleigh's law, and the Preisach-Rayleigh law measured.

Prints five tables:

1. **The laws at low field** (the fits of the committed report, ``reports/results.json``):
   for each block's Preisach fit its relay density at the origin relative to a flat
   density (``exp(-1/(2 sigma_c^2))``), its Rayleigh constant ``gamma`` and where its
   Rayleigh region ends (the amplitude at which ``-Im N 3 pi / (4 A)`` leaves ``gamma`` by
   10 %, in units of ``i_c``); for each Jiles-Atherton fit ``L0``, ``g`` of
   ``N -> L0 + g A (1 - j)`` (:func:`fitdf.models.low_field.ja_low_field`) and the ratio
   ``-Im N / (Re N - L0)`` at ``A = 1e-3 k`` (Rayleigh: 0.424).
2. **Least squares through the ``voltage`` chain**, per block: today's best law (from the
   committed report: RMS, AICc, cross-validation RMS) beside ``preisach_rayleigh`` fitted
   here, polished from the report's Preisach optimum with a Rayleigh population added
   (``f_ray`` in 1e-4 .. 0.2, ``i_ray`` 0.1 .. 3 ``i_c``; the law nests Preisach as
   ``f_ray -> 0``) plus :data:`SCREEN` starts screened from the box, and cross-validated
   the report's way (:func:`fitdf.inference.ranking.cross_validate`). ``--wide`` is a
   second pass: 12 more starts, Rayleigh-dominated (``l_rev`` x 0.05-0.3 of Preisach's,
   ``f_ray`` 0.3-0.7), and 18 screened.
3. **B.3 6 c/s 0.1 V and the 25 worst rows** (the 5 rows per single-table block that every
   law of the report misses most): the smallest residual of the report's laws against the
   new law's, and their RMS.
4. **Appendix A**: the initial permeability and how many of the material checks of
   :func:`fitdf.inference.material.appendix_a_check` hold, Preisach (the report's) and the
   new law.
5. **Supermalloy's mu' at small flux** (Table B.4, :func:`fitdf.inference.matched_flux`):
   at each frequency's smallest flux, the rows' ``mu'`` against Preisach's (refitted here)
   and the new law's, each inverted through its own fitted circuit.

Run from the repository root: ``python benchmarks/low_field.py`` (~5-10 min on two shared
cores; ``--quick`` skips the cross-validation).
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from fitdf.chains import VoltageChain
from fitdf.inference.api import resolve_data, resolve_geometry
from fitdf.inference.lsq import fit_lsq
from fitdf.inference.matched_flux import matched_flux
from fitdf.inference.material import with_material
from fitdf.inference.problem import FitProblem
from fitdf.inference.ranking import cross_validate
from fitdf.models import get_model
from fitdf.models.low_field import RAYLEIGH_RATIO, ja_low_field, rayleigh_slopes
from fitdf.models.preisach import rayleigh_constant
from fitdf.models.preisach_rayleigh import rayleigh_constant as new_law_gamma

LAW = "preisach_rayleigh"
BLOCKS = ("B.1", "B.2", "B.3", "B.4", "B.5", "permalloy-joint", "deltamax-joint")
#: Starts screened from the box beside the warm ones (the report polishes 6 screened starts).
SCREEN = 6
F_RAY = (1e-4, 0.01, 0.05, 0.2)
I_RAY = (0.1, 0.3, 1.0, 3.0)  # x i_c
#: The second pass (``--wide``): l_rev (x the Preisach fit's) and f_ray of its extra starts.
L_REV_WIDE = (0.05, 0.3)
F_RAY_WIDE = (0.3, 0.7)


def _values(fit_record, model):
    names = set(get_model(model).param_names())
    return {p["parameter"]: p["value"] for p in fit_record["parameters"] if p["parameter"] in names}


def _all_values(fit_record):
    return {p["parameter"]: p["value"] for p in fit_record["parameters"]}


def low_field_table(report):
    print("1. The laws at low field (the report's fits)")
    print(
        f"{'block':<16} {'law':<15} {'q(0,0)/flat':>11} {'gamma H/A':>10} "
        f"{'end / i_c':>9}   {'JA L0 H':>8} {'g H/A':>9} {'-Im/dRe':>7}"
    )
    P, JA = get_model("preisach"), get_model("jiles_atherton")
    for block in BLOCKS:
        fits = report["blocks"][block]["fits_lsq"]
        th = _values(fits["preisach"], "preisach")
        gamma = float(rayleigh_constant(**th))
        A = th["i_c"] * np.geomspace(1e-4, 1.0, 81)
        s = rayleigh_slopes(P, A, **th)
        # (the quadrature part: only the relays have loss; the reversible arctangent's
        # in-phase part falls as -(A/i_r)^2 and hides a tiny gamma A)
        off = np.flatnonzero(np.abs(s["quadrature"] / gamma - 1) > 0.1)
        end = A[off[0]] / th["i_c"] if off.size else np.inf
        line = (
            f"{block:<16} {'preisach':<15} {np.exp(-0.5 / th['sigma_c'] ** 2):>11.2e} "
            f"{gamma:>10.3g} {end:>9.3g}"
        )
        if "jiles_atherton" in fits:
            tj = _values(fits["jiles_atherton"], "jiles_atherton")
            L0, g = ja_low_field(**tj)
            r = rayleigh_slopes(JA, np.array([1e-3 * tj["k"]]), **tj)
            line += f"   {L0:>8.3g} {g:>9.3g} {r['ratio'][0]:>7.3f}"
        print(line)
    print(f"(Rayleigh's loop: -Im N / (Re N - mu_i) = {RAYLEIGH_RATIO:.3f})\n")


def fit_new_law(block, report, cv: bool, wide: bool = False):
    rows = resolve_data(block.removesuffix("-joint"), "default", None)
    problem = FitProblem(rows, LAW, "voltage", None, None, resolve_geometry("auto", rows))
    pre = _all_values(report["blocks"][block]["fits_lsq"]["preisach"])
    starts = []
    for f_ray in F_RAY:
        for i_ray in I_RAY:
            v = dict(pre, f_ray=f_ray, i_ray=i_ray * pre["i_c"])
            starts.append(np.clip(problem.to_internal(v), *problem.internal_bounds().T))
    if wide:  # a second pass: Rayleigh-dominated starts (small l_rev, much mass at 0)
        for l_rev in L_REV_WIDE:
            for f_ray in F_RAY_WIDE:
                for i_ray in I_RAY[1:]:
                    v = dict(pre, l_rev=l_rev * pre["l_rev"], f_ray=f_ray, i_ray=i_ray * pre["i_c"])
                    starts.append(np.clip(problem.to_internal(v), *problem.internal_bounds().T))
    t0 = time.perf_counter()
    result = fit_lsq(
        problem, seed=int(wide), starts=np.array(starts), also_screen=(3 if wide else 1) * SCREEN
    )
    result = with_material(result)
    seconds = time.perf_counter() - t0
    cv_rms = cross_validate(result)["cv_rms_complex"] if cv else float("nan")
    return result, cv_rms, seconds


def best_of_report(report, block):
    row = report["blocks"][block]["ranking_lsq"][0]
    return row["model"], row["rms_complex"], row["aicc"], row["cv_rms_complex"]


def fits_table(report, cv: bool, wide: bool = False):
    print("2. Least squares through the voltage chain: today's best law against " + LAW)
    print(
        f"{'block':<16} {'best law':<9} {'RMS':>7} {'AICc':>8} {'CV':>7}   "
        f"{'RMS':>7} {'AICc':>8} {'dAICc':>7} {'CV':>7}  {'f_ray':>8} {'i_ray/i_c':>9} "
        f"{'gamma H/A':>9} {'s':>5}"
    )
    results = {}
    for block in BLOCKS:
        name, rms, aicc, cv_best = best_of_report(report, block)
        result, cv_new, seconds = fit_new_law(block, report, cv, wide)
        results[block] = result
        m, v = result.metrics, result.values
        gamma = float(new_law_gamma(**{k: v[k] for k in get_model(LAW).param_names()}))
        print(
            f"{block:<16} {name:<9} {rms:>7.4f} {aicc:>8.1f} {cv_best or np.nan:>7.4f}   "
            f"{m['rms_complex']:>7.4f} {m['aicc']:>8.1f} {m['aicc'] - aicc:>7.1f} {cv_new:>7.4f}"
            f"  {v['f_ray']:>8.2e} {v['i_ray'] / v['i_c']:>9.3g} {gamma:>9.3g} {seconds:>5.0f}"
        )
    print()
    return results


def _row_key(r):
    return (
        r["table"],
        float(r["source_impedance_ohm"]),
        float(r["frequency_hz"]),
        float(r["input_v"]),
    )


def worst_rows_table(report, results):
    print("3. The rows every law of the report misses most (5 per single-table block)")
    print(
        "   (passive: the reading's distance to the disc |w - g/2| <= g/2 of every reading a "
        "passive core gives\n    behind a resistor, g the new law's fitted gain; 0 inside)"
    )
    print(
        "   (loss: the loss angle of the core the reading implies, inverted through the new "
        "law's fitted circuit;\n    I/i_c: the new law's peak current there over its i_c)"
    )
    old, new, floor, lines = [], [], [], []
    law = get_model(LAW)
    for block in ("B.1", "B.2", "B.3", "B.4", "B.5"):
        res = results[block].residuals
        v = results[block].values
        gain = v["gain"]
        by_key = {_row_key(r): r["complex_residual"] for r in res.to_dict(orient="records")}
        for w in report["blocks"][block]["where_models_fail"]["rows"]:
            key = _row_key(w)
            old.append(w["smallest_complex_residual"])
            new.append(by_key[key])
            mag, lead = w["df_measured"], w["phase_lead_measured_deg"]
            floor.append(passive_distance(mag, lead, gain))
            reading = mag * np.exp(1j * np.radians(lead))
            z = (key[1] + v["r_series"]) * reading / (gain - reading)  # w = g Z / (R + Z)
            current = VoltageChain.core_current(
                law,
                np.array([key[3]]),
                np.array([key[2]]),
                np.array([key[1]]),
                [v[n] for n in law.param_names()],
                [v["r_series"], gain],
            )[0]
            loss = np.degrees(np.arctan2(z.real, z.imag))
            lines.append((key, mag, lead, loss, current / v["i_c"]))
    for (key, mag, lead, loss, ratio), o, n, p in zip(lines, old, new, floor):
        mark = "  <- B.3 6 c/s 0.1 V" if key == ("B.3", 600.0, 6.0, 0.1) else ""
        print(
            f"  {key[0]} {key[1]:>3.0f} ohm {key[2]:>2.0f} c/s {key[3]:>4.3g} V  "
            f"|DF| {mag:.3f} lead {lead:>4.1f} loss {loss:>5.1f} I/i_c {ratio:>5.2f}  "
            f"report {o:.3f}  {LAW} {n:.3f}  passive {p:.3f}{mark}"
        )
    old, new, floor = np.array(old), np.array(new), np.array(floor)
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    print(
        f"  RMS over the {old.size} rows: the report's best per row {rms(old):.4f}, {LAW} "
        f"{rms(new):.4f} (ratio {rms(new) / rms(old):.2f}); outside the passive disc: "
        f"{int(np.sum(floor > 0))} rows, RMS of their distance over all {old.size} {rms(floor):.4f}\n"
    )


def passive_distance(magnitude, lead_deg, gain):
    """Distance of a reading from the disc ``|w - g/2| <= g/2``: behind a resistor a passive
    core (any loop, the exact circuit) gives only readings inside it (the source's power is
    at least the resistor's share of the fundamental, ``1 - Re w/g >= |1 - w/g|^2``)."""
    w = magnitude * np.exp(1j * np.radians(lead_deg))
    return max(abs(w - gain / 2) - gain / 2, 0.0)


def appendix_a_table(report, results):
    print("4. Appendix A checks (fitdf.inference.material): initial permeability and checks inside")
    print(
        f"{'block':<16} {'range mu_i':>14}   {'preisach mu_i':>13} {'inside':>6}   "
        f"{LAW + ' mu_i':>22} {'inside':>6}"
    )
    for block in BLOCKS:
        old = report["blocks"][block]["fits_lsq"]["preisach"]["appendix_a_check"] or []
        new = results[block].material.get("appendix_a_check") or []
        row = {c["quantity"]: c for c in old}.get("initial_permeability")
        row_new = {c["quantity"]: c for c in new}.get("initial_permeability")
        if row is None or row_new is None:
            continue
        inside = lambda checks: f"{sum(bool(c.get('inside_range')) for c in checks)}/{len(checks)}"  # noqa: E731
        print(
            f"{block:<16} {row['low']:>6.0f}-{row['high']:<7.0f}   {row['fitted']:>13.0f} "
            f"{inside(old):>6}   {row_new['fitted']:>22.0f} {inside(new):>6}"
        )
    print(
        "(inside: the fitted value's range over the geometry's iron fraction meets Appendix A's)\n"
    )


def supermalloy_table(new_b4, draws):
    print("5. Supermalloy (Table B.4): mu' at each frequency's smallest flux")
    rows = resolve_data("B.4", "default", None)
    pre = with_material(
        fit_lsq(FitProblem(rows, "preisach", "voltage", None, None, resolve_geometry("auto", rows)))
    )
    old = matched_flux(pre, draws=draws).small_flux
    new = matched_flux(new_b4, draws=draws).small_flux
    print(
        f"{'f c/s':>6} {'flux mV s':>9} {'rows':>7} {'preisach':>8} {'ratio':>6}   "
        f"{'rows':>7} {LAW:>17} {'ratio':>6}"
    )
    for (_, o), (_, n) in zip(old.iterrows(), new.iterrows()):
        print(
            f"{o['frequency_hz']:>6.0f} {1e3 * o['flux_vs']:>9.3f} {o['mu']:>7.0f} "
            f"{o['mu_static']:>8.0f} {o['mu_static'] / o['mu']:>6.2f}   {n['mu']:>7.0f} "
            f"{n['mu_static']:>17.0f} {n['mu_static'] / n['mu']:>6.2f}"
        )
    print()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="no cross-validation")
    parser.add_argument("--report", default="reports/results.json")
    parser.add_argument("--draws", type=int, default=200, help="printed-precision draws")
    parser.add_argument(
        "--wide",
        action="store_true",
        help="second pass: 12 more starts, Rayleigh-dominated (l_rev x 0.05-0.3, f_ray 0.3-0.7), "
        "and 18 screened",
    )
    args = parser.parse_args(argv)
    with open(args.report) as fh:
        report = json.load(fh)
    low_field_table(report)
    results = fits_table(report, cv=not args.quick, wide=args.wide)
    worst_rows_table(report, results)
    appendix_a_table(report, results)
    supermalloy_table(results["B.4"], args.draws)


if __name__ == "__main__":
    main()
