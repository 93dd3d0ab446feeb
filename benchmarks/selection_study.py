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

Besides the rule it tabulates, from the same fits, the rule with a row per parameter as the
minimum (``n >= k``) and the order by in-sample RMS, and writes every fit's numbers to
``benchmarks/selection_study.json`` (``--table`` prints the table of those again). The
default (:data:`REPLICATES`: 84 trials, 504 fits) takes about 25 minutes on two shared Xeon
cores.

    python benchmarks/selection_study.py [--replicates N] [--sizes 5 7 10 20 37] [--resume]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from selection_trials import (  # noqa: E402
    CANDIDATES,
    SIZES,
    TRUTHS,
    VARIANTS,
    fit_candidates,
    rst_table,
    trial_frame,
    trial_seed,
)

#: Trials per cell: 12 on 7 rows, where the rule (AICc's own minimum of rows) ranks the
#: 8-parameter law and a row per parameter would not, 4 elsewhere.
REPLICATES = {5: 4, 7: 12, 10: 4, 20: 4, 37: 4}


def dumps(trials) -> str:
    """The trials as JSON, one a line."""
    return '{"trials": [\n' + ",\n".join(json.dumps(t) for t in trials) + "\n]}\n"


def run(sizes, replicates, out: Path, resume: bool) -> list[dict]:
    """The trials of every cell (kept in ``out`` after each one; ``resume`` keeps those
    ``out`` already holds)."""
    trials = json.loads(out.read_text())["trials"] if resume and out.exists() else []
    done = {(t["truth"], t["n_rows"], t["replicate"]) for t in trials}
    for truth in TRUTHS:
        for n in sizes:
            for r in range(replicates or REPLICATES[n]):
                if (truth, n, r) in done:
                    continue
                t0 = time.perf_counter()
                frame = trial_frame(truth, n, trial_seed(truth, n, r))
                fits = fit_candidates(frame, CANDIDATES, seed=r)
                seconds = time.perf_counter() - t0
                trials.append(
                    {"truth": truth, "n_rows": n, "replicate": r, "fits": fits, "seconds": seconds}
                )
                said = " ".join(f"{k} {f(truth, fits)}" for k, f in VARIANTS.items())
                print(f"{truth:15s} n={n:3d} r={r:2d}: {said} ({seconds:.0f} s)", flush=True)
                out.write_text(dumps(trials))
    return trials


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--replicates", type=int, default=None, help="per cell (default REPLICATES)")
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES), choices=SIZES)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "selection_study.json")
    ap.add_argument("--table", action="store_true", help="only print the tables of --out")
    ap.add_argument("--resume", action="store_true", help="keep the trials --out holds")
    args = ap.parse_args(argv)
    if args.table:
        trials = json.loads(args.out.read_text())["trials"]
    else:
        trials = run(args.sizes, args.replicates, args.out, args.resume)
    print(rst_table(trials))
    print(f"\n{len(trials)} trials, {sum(len(t['fits']) for t in trials)} fits, ", end="")
    print(f"{sum(t['seconds'] for t in trials) / 60:.0f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
