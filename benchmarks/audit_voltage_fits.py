"""The ``voltage`` chain where the fits go: its DF against the exact reference at the report's fits.

Run from the repository root::

    python benchmarks/audit_voltage_fits.py                       # ~10 min on one core
    python benchmarks/audit_voltage_fits.py --laws constant_width --blocks B.2 B.5

``bench_voltage.py`` measures the chain's accuracy on a designed grid of Permalloy-like
parameters. The fits go elsewhere: Deltamax's nearly rectangular loops, sides of 10^3 H,
``V/R`` just above a coercive current. Here every piecewise-linear law's least-squares
optimum in the committed report (``reports/results.json``) on each single-table block, and
``--scatter`` sets around it (internal coordinates, normal with standard deviation 0.05,
seeded, clipped to the box), are evaluated at the block's own rows, and the chain's DF is
compared with the exact piecewise integration of ``tests/test_voltage_chain.py`` (brentq on
the peak current, each linear piece in closed form). Printed per law, block and set: the
largest ``|DF - DF_ref|`` and its row, the rows beyond 5e-4, and the rows where the
reference does not apply (a branch it cannot split into linear pieces: cubic_hc's cubic
width). No thresholds: numbers only.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from test_voltage_chain import reference_piecewise  # noqa: E402

from fitdf.chains import VoltageChain  # noqa: E402
from fitdf.inference.api import resolve_data, resolve_geometry  # noqa: E402
from fitdf.inference.problem import FitProblem  # noqa: E402

LAWS = (
    "constant_width",
    "cubic_hc",
    "proportional_width",
    "proportional_width_fig42",
    "frequency_hc",
)
BLOCKS = ("B.1", "B.3", "B.2", "B.5", "B.4")


def audit(law: str, block: str, fits: dict, scatter: int, seed: int) -> None:
    rows = resolve_data(block, "default", None)
    problem = FitProblem(rows, law, "voltage", None, None, resolve_geometry("auto", rows))
    values = {q["parameter"]: q["value"] for q in fits[block]["fits_lsq"][law]["parameters"]}
    x0 = problem.to_internal(values)
    lo, hi = problem.internal_bounds().T
    rng = np.random.default_rng(seed)
    sets = np.clip(np.vstack([x0, x0 + 0.05 * rng.standard_normal((scatter, x0.size))]), lo, hi)
    d = problem.data
    for i, x in enumerate(sets):
        nat = problem.full_natural(x)
        theta = [float(nat[s.name]) for s in problem.model.params]
        r_w = float(nat["r_series"])
        op = VoltageChain.operating_point(
            problem.model, d.amplitude, d.frequency, d.source_impedance, theta, [r_w, 1.0]
        )
        err = np.full(d.n, np.nan)
        for j in range(d.n):
            try:
                df, _ = reference_piecewise(
                    problem.model,
                    theta,
                    d.amplitude[j],
                    d.frequency[j],
                    d.source_impedance[j] + r_w,
                )
            except (AssertionError, ValueError, RuntimeError):  # not piecewise linear / no bracket
                continue
            err[j] = abs(op.df[j] - df)
        if np.all(np.isnan(err)):
            print(f"{law:25s} {block:5s} {i:3d}  (the reference applies to no row)")
            continue
        j = int(np.nanargmax(err))
        print(
            f"{law:25s} {block:5s} {i:3d}  {np.nanmax(err):9.1e}  "
            f"V {d.amplitude[j]:<5g} f {d.frequency[j]:<4g} Rs {d.source_impedance[j]:<4g}"
            f"{int(np.sum(err > 5e-4)):6d} {int(np.sum(np.isnan(err))):6d} / {d.n}",
            flush=True,
        )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", nargs="+", default=list(LAWS), choices=LAWS)
    parser.add_argument("--blocks", nargs="+", default=list(BLOCKS), choices=BLOCKS)
    parser.add_argument("--scatter", type=int, default=3, help="sets around each optimum")
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--results", default=str(ROOT / "reports" / "results.json"))
    args = parser.parse_args(argv)
    fits = json.loads(Path(args.results).read_text())["blocks"]
    print(
        f"{'law':25s} {'block':5s} {'set':>3s}  {'max err':>9s}  {'at':26s}{'>5e-4':>6s} {'no ref':>6s}"
    )
    for law in args.laws:
        for block in args.blocks:
            audit(law, block, fits, args.scatter, args.seed)


if __name__ == "__main__":
    main()
