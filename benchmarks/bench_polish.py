"""The least-squares polish: calibration gains rescaled in the Jacobian, against solving them.

Run from the repository root::

    python benchmarks/bench_polish.py            # about two minutes
    python benchmarks/bench_polish.py --quick    # one timed repeat

One polish (:func:`fitdf.inference.lsq._polish`, lmfit's trust region, ``max_nfev`` 4000)
from the same start (40 % into each parameter's box), through the exact ``voltage`` chain,
two ways in one process:

* **solved** (the peer): every column of the forward-difference Jacobian is a solve of the
  chain at a shifted vector, the points scipy's ``least_squares(diff_step=1e-4)`` evaluates
  (one batched call);
* **rescaled** (fitdf): the columns of the calibration gains, which only multiply the
  prediction, are the prediction at ``x`` rescaled (:meth:`FitProblem.rescaled`).

Table B.3 has one gain, the Permalloy joint block (B.1 + B.3) two. The table gives each
way's time (median of the repeats, after one untimed call), the chain solves it counted
(``nfev``), the chi-square it reached and their ratio. Nothing is asserted (the Jacobian's
agreement with scipy's is tested in tests/test_fitting.py); the load average is printed.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench_voltage import median_time, timed_repeats  # (benchmarks/ is the script's folder)

from fitdf.inference import lsq
from fitdf.inference.api import resolve_data, resolve_geometry
from fitdf.inference.problem import FitProblem

CASES = (
    ("B.3", "constant_width"),
    ("B.3", "preisach"),
    ("permalloy", "constant_width"),
    ("permalloy", "preisach"),
)


class _SolveEveryColumn(FitProblem):
    """The peer: no parameter counts as a pure rescaling, so every column is solved."""

    @property
    def output_scale_indices(self):
        return []


def _problem(cls, data, law):
    rows = resolve_data(data)
    return cls(rows, law, "voltage", geometry=resolve_geometry("auto", rows))


def main(argv=None) -> int:
    repeats = timed_repeats(__doc__, argv)
    print(
        f"{'block':10s} {'law':15s} {'gains':>5s} {'solved':>9s} {'nfev':>5s} {'chi2':>11s}"
        f" {'rescaled':>9s} {'nfev':>5s} {'chi2':>11s} {'speed-up':>8s}"
    )
    for data, law in CASES:
        row = []
        for cls in (_SolveEveryColumn, FitProblem):
            problem = _problem(cls, data, law)
            lo, hi = problem.internal_bounds().T
            start = lo + 0.4 * (hi - lo)
            result = {}

            def once(problem=problem, start=start, result=result):
                result["out"] = lsq._polish(problem, start, max_nfev=4000)

            seconds = median_time(once, repeats)
            out, _, chi2 = result["out"]
            row.append((seconds, out.nfev, chi2))
        gains = len(_problem(FitProblem, data, law).output_scale_indices)
        (t0, n0, c0), (t1, n1, c1) = row
        print(
            f"{data:10s} {law:15s} {gains:5d} {t0:8.2f}s {n0:5d} {c0:11.4f}"
            f" {t1:8.2f}s {n1:5d} {c1:11.4f} {t0 / t1:7.2f}x",
            flush=True,
        )
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
