"""Preisach branch: the compiled Everett loop against its NumPy/Owen's-``T`` reference.

Run from the repository root::

    python benchmarks/bench_preisach.py            # under a minute
    python benchmarks/bench_preisach.py --quick    # fewer repeats

Times, in one process, the rising branch ``P_up(x) = -E(A, -A) + 2 E(x, -A)`` of the steady
loop two ways: :func:`fitdf.models._preisach_everett._preisach_branch_reference` (NumPy, the
Everett function as four bivariate normals by Owen's ``T``: the tests' reference) and
:func:`fitdf.models._preisach_everett.preisach_branch` (the compiled loop, two bivariate
normals per point by Genz's algorithm), on a table of the ``voltage`` chain's shape (36
amplitudes x 127 nodes) at the least-squares fits of Tables B.3 and B.5 in ``REPORT_FITS``
(``r = s/S`` 0.72 and 0.43); then one ``FitProblem.predict`` of the ``voltage`` chain on those
tables, for one parameter set and for 22 (the pilot's walkers, parameters scattered by
0.1 %), with the branch switched between the two. Medians of repeats, interleaved; the
largest difference between the two is printed (their agreement is a test,
tests/test_models_preisach_ja.py). The load average is printed: the two cores are shared.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np
from bench_voltage import median_time  # (benchmarks/ is the script's folder)

from fitdf.inference.api import resolve_data, resolve_geometry
from fitdf.inference.problem import FitProblem
from fitdf.models import _preisach_everett as everett_module
from fitdf.models import preisach as preisach_module

#: Least-squares fits of the committed report (reports/results.json), B.3 and B.5.
REPORT_FITS = {
    "B.3": dict(
        lambda_s=0.03728,
        i_c=3.309e-4,
        sigma_c=0.3082,
        i_i=9.894e-5,
        l_rev=6.148,
        f_rev=0.1317,
        r_series=52.41,
        gain=1.057,
    ),
    "B.5": dict(
        lambda_s=0.02342,
        i_c=3.705e-4,
        sigma_c=0.1481,
        i_i=1.146e-4,
        l_rev=0.5311,
        f_rev=0.007429,
        r_series=30.66,
        gain=0.8118,
    ),
}
BRANCHES = {
    "NumPy/Owen's T": everett_module._preisach_branch_reference,
    "compiled": everett_module.preisach_branch,
}


_ROWS = preisach_module.preisach_flux_rows


def use(name):
    """Make the Preisach law read the branch ``name`` (the compiled one on the chain's
    tables through its row loop, :func:`~fitdf.models._preisach_everett.preisach_flux_rows`)."""
    preisach_module.preisach_branch = BRANCHES[name]
    preisach_module.preisach_flux_rows = _ROWS if name == "compiled" else lambda *a, **k: None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    repeats = 3 if parser.parse_args().quick else 7
    print(f"Preisach branch; load average {os.getloadavg()[0]:.1f}")
    print(f"{'':44s} {'NumPy/Owen' + chr(39) + 's T':>16s} {'compiled':>12s} {'speed-up':>9s}")
    for table, values in REPORT_FITS.items():
        shape = {k: values[k] for k in ("i_c", "sigma_c", "i_i")}
        A = np.geomspace(1e-5, 1e-2, 36)[:, None]
        x = A * np.sin(0.5 * np.pi * np.linspace(-1.0, 1.0, 127))
        rows = resolve_data(table, "default", None)
        problem = FitProblem(
            rows, "preisach", "voltage", None, None, resolve_geometry("auto", rows)
        )
        point = problem.to_internal(values)
        walkers = point + 1e-3 * np.random.default_rng(0).standard_normal((22, point.size))
        cases = {
            f"{table} ascending branch, (36, 127) table": lambda: BRANCHES[active](x, A, **shape),
            f"{table} voltage predict, one parameter set": lambda: problem.predict(point),
            f"{table} voltage predict, 22 parameter sets": lambda: problem.predict(walkers),
        }
        for label, fn in cases.items():
            times, results = {}, {}
            for active in (*BRANCHES, *BRANCHES):
                use(active)
                times.setdefault(active, []).append(median_time(fn, repeats))
                results[active] = fn()
            use("compiled")
            ref, new = (float(np.median(times[k])) for k in BRANCHES)
            diff = np.abs(results["compiled"] - results["NumPy/Owen's T"]).max()
            print(
                f"{label:44s} {ref * 1e3:13.2f} ms {new * 1e3:9.2f} ms {ref / new:8.2f}x"
                f"   max diff {diff:.1e}"
            )


if __name__ == "__main__":
    main()
