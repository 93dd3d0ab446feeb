"""How often the selection rule picks the true law: synthetic rows from three laws of
different size, at several numbers of rows (``docs/method/ranking.rst``, *Model selection*).

Each trial (``tests/selection_trials.py``): the independent referee (``tests/referee.py``:
the law's loop Fourier-integrated, the ``winding`` circuit solved by a root finder of its
own) makes ``n`` rows of a true law (constant_width, jiles_atherton or preisach: 5, 7 and 8
parameters with the chain's two), with Gaussian noise of half the printed digit (0.005 in
magnitude, 0.5 degree) and rounded as Appendix B prints (2 decimals, whole degrees); six
candidate laws are fitted by least squares; the rule of :mod:`fitdf.inference.selection`
names a best law and its ties. Trial ``r`` of a cell draws its noise with seed
``1000 * truth + 100 * size + r`` (truth and size by position:
``selection_trials.trial_seed``) and fits with seed ``r``.

Besides the rule it tabulates, from the same fits, the rule with AICc's own minimum of rows
(``2 n >= k + 2``) and the old order by in-sample RMS, and writes every fit's numbers to
``benchmarks/selection_study.json``. ``--replicates 4`` (default) runs 360 fits, about 10
minutes on two Xeon cores.

    python benchmarks/selection_study.py [--replicates N] [--sizes 5 7 10 20 37]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from selection_trials import (  # noqa: E402
    CANDIDATES,
    SIZES,
    TRUTHS,
    fit_candidates,
    outcome,
    rms_outcome,
    trial_frame,
    trial_seed,
)

OUTCOMES = ("picked", "tie", "wrong", "not_ranked")


def aicc_minimum(n_params: int) -> int:
    """Rows AICc itself needs: ``N = 2 n >= k + 2``."""
    return (n_params + 3) // 2


def run(sizes, replicates, out: Path) -> list[dict]:
    trials = []
    for truth in TRUTHS:
        for n in sizes:
            for r in range(replicates):
                t0 = time.perf_counter()
                frame = trial_frame(truth, n, trial_seed(truth, n, r))
                fits = fit_candidates(frame, CANDIDATES, seed=r)
                trials.append(
                    {
                        "truth": truth,
                        "n_rows": n,
                        "replicate": r,
                        "fits": fits,
                        "rule": outcome(truth, fits),
                        "aicc_minimum": outcome(truth, fits, aicc_minimum),
                        "rms": rms_outcome(truth, fits),
                        "seconds": time.perf_counter() - t0,
                    }
                )
                print(
                    f"{truth:15s} n={n:3d} r={r}: rule {trials[-1]['rule']:10s} "
                    f"aicc-min {trials[-1]['aicc_minimum']:10s} rms {trials[-1]['rms']:7s} "
                    f"({trials[-1]['seconds']:.0f} s)",
                    flush=True,
                )
                out.write_text(json.dumps({"trials": trials}, indent=1))
    return trials


def table(trials, key: str) -> list[str]:
    """An RST list-table of outcome counts per true law and size."""
    cells = {}
    for tr in trials:
        cells.setdefault((tr["truth"], tr["n_rows"]), Counter())[tr[key]] += 1
    lines = []
    for (truth, n), c in cells.items():
        total = sum(c.values())
        lines.append(
            f"{truth:15s} {n:4d} "
            + " ".join(f"{o}={c[o]}/{total}" for o in OUTCOMES if key != "rms" or o in c)
        )
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--replicates", type=int, default=4)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES), choices=SIZES)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "selection_study.json")
    ap.add_argument("--table", action="store_true", help="only print the tables of --out")
    args = ap.parse_args(argv)
    if args.table:
        trials = json.loads(args.out.read_text())["trials"]
    else:
        trials = run(args.sizes, args.replicates, args.out)
    for key in ("rule", "aicc_minimum", "rms"):
        print(f"\n{key}:")
        print("\n".join(table(trials, key)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
