"""The model-selection study's trials (a helper of ``benchmarks/selection_study.py`` and
``tests/test_selection.py``, not a test).

A trial: rows made by the independent referee (``tests/referee.py``) from a true law, at
the tables' printed precision, every candidate law fitted by least squares through the
``winding`` chain, and the rule of :mod:`fitdf.inference.selection` applied. The outcome
is one of

* ``picked``: the rule calls the true law best;
* ``tie``: it calls another law best and names the true law among its ties;
* ``wrong``: it calls another law best, and the true law is not among its ties;
* ``not_ranked``: the rows are too few for the true law (the rule cannot pick it).

:func:`rst_table` counts them per true law and size (:data:`VARIANTS`: the rule, the rule
with a row per parameter as its minimum, the lowest in-sample RMS), as the documents show.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pandas as pd
from referee import referee_row

import fitdf
from fitdf.inference.selection import pick, rank_reason

#: True laws: fitted to Permalloy (Tables B.1 and B.3, ``winding`` chain) and rounded;
#: Jiles-Atherton's mean field at 0.9 (the fit's sits at its limit 1).
TRUTHS = {
    "constant_width": {"k": 50.0, "b": 1.0e-4, "c": 0.041},
    "jiles_atherton": {"lambda_s": 0.046, "a": 4.4e-4, "k": 4.0e-4, "c": 0.18, "zeta": 0.9},
    "preisach": {
        "lambda_s": 0.041,
        "i_c": 3.4e-4,
        "sigma_c": 0.32,
        "i_i": 5.7e-5,
        "l_rev": 7.7,
        "f_rev": 0.26,
    },
}
#: The series resistance (ohm) and calibration gain of every trial.
CHAIN = {"r_series": 80.0, "gain": 0.97}
#: The candidates: three laws of 3 parameters, two of 5 and one of 6 (5, 7 and 8 with the
#: chain's two).
CANDIDATES = (
    "constant_width",
    "proportional_width",
    "rayleigh",
    "frequency_hc",
    "jiles_atherton",
    "preisach",
)
#: (source impedance ohm, frequency Hz) blocks, taken in turn by the rows.
BLOCKS = ((0.0, 3.0), (600.0, 6.0), (0.0, 10.0), (600.0, 3.0), (0.0, 6.0), (600.0, 10.0))
#: The numbers of rows of the study (``benchmarks/selection_study.py``).
SIZES = (5, 7, 10, 20, 37)
#: The tables' printed precision: Gaussian noise of half a unit in the last digit
#: (magnitude to 2 decimals, the most common in Appendix B; phase to 1 degree), then rounded.
SIGMA = (0.005, 0.5)
DECIMALS = (2, 0)


def trial_seed(truth: str, n_rows: int, replicate: int) -> int:
    """The noise seed of a trial: ``1000 * truth + 100 * size + replicate``, the true law
    and the size by their positions in :data:`TRUTHS` and :data:`SIZES`."""
    return 1000 * list(TRUTHS).index(truth) + 100 * SIZES.index(n_rows) + replicate


def design(n_rows: int) -> list[tuple[float, float, float]]:
    """``(volts, ohm, Hz)`` of ``n_rows`` rows: amplitudes geometric over 0.1-5 V, the rows
    dealt to :data:`BLOCKS` in turn (both source impedances from two rows on)."""
    volts = np.geomspace(0.1, 5.0, n_rows) if n_rows > 1 else np.array([1.0])
    return [(float(v), *BLOCKS[i % len(BLOCKS)]) for i, v in enumerate(volts)]


def trial_frame(truth: str, n_rows: int, seed: int) -> pd.DataFrame:
    """The referee's rows of ``truth`` at ``n_rows`` rows, noise drawn with ``seed``."""
    rng = np.random.default_rng(seed)
    rows = [
        referee_row(truth, TRUTHS[truth], CHAIN, v, f, rs, rng, SIGMA, DECIMALS)
        for v, rs, f in design(n_rows)
    ]
    return pd.DataFrame(rows)


def fit_candidates(frame, candidates=CANDIDATES, seed=0) -> list[dict]:
    """Every candidate fitted to ``frame`` (least squares, ``winding`` chain): per law
    ``model``, ``chain``, ``method``, ``n_points``, ``n_params``, ``aicc``, ``rms_complex``."""
    out = []
    for model in candidates:
        r = fitdf.fit(frame, model, chain="winding", policy="all", seed=seed, geometry=None)
        m = r.metrics
        out.append(
            {
                "model": model,
                "chain": r.chain,
                "method": r.method,
                "n_points": int(m["n_points"]),
                "n_params": int(m["n_params"]),
                "aicc": float(m["aicc"]),
                "rms_complex": float(m["rms_complex"]),
            }
        )
    return out


def outcome(truth: str, fits, rows_needed=None) -> str:
    """The rule's outcome on one trial's ``fits`` (module docstring).

    ``rows_needed``: a function of the parameter count replacing the rule's threshold (the
    study compares thresholds on the same fits); default the rule's own.
    """

    def ranked(r):
        if rows_needed is None:
            return rank_reason(r["n_points"], r["n_params"]) is None
        return r["n_points"] >= rows_needed(r["n_params"])

    rows = [r for r in fits if ranked(r)]
    if not any(r["model"] == truth for r in rows):
        return "not_ranked"
    best, ties = pick(rows)
    if rows[best]["model"] == truth:
        return "picked"
    return "tie" if any(rows[i]["model"] == truth for i in ties) else "wrong"


def rms_outcome(truth: str, fits) -> str:
    """The outcome of ranking by the in-sample RMS complex residual (no ties, no threshold)."""
    best = min(fits, key=lambda r: r["rms_complex"])
    return "picked" if best["model"] == truth else "wrong"


#: What the table counts: the rule, the variant with a row per parameter, the in-sample RMS.
VARIANTS = {
    "rule": lambda truth, fits: outcome(truth, fits),
    "row_per_parameter": lambda truth, fits: outcome(truth, fits, lambda k: k),
    "rms": rms_outcome,
}


def counts(trials) -> dict:
    """``(truth, n) -> {variant: Counter of outcomes}``, outcomes recomputed from the fits."""
    cells = {}
    for t in sorted(trials, key=lambda t: (list(TRUTHS).index(t["truth"]), t["n_rows"])):
        cell = cells.setdefault((t["truth"], t["n_rows"]), {k: Counter() for k in VARIANTS})
        for key, f in VARIANTS.items():
            cell[key][f(t["truth"], t["fits"])] += 1
    return cells


def rst_table(trials) -> str:
    """The study's table as RST (docs/method/ranking.rst)."""
    k = {t["truth"]: f["n_params"] for t in trials for f in t["fits"] if f["model"] == t["truth"]}
    head = [
        "true law (parameters)",
        "rows",
        "trials",
        "rule: true law best",
        "tie",
        "another law",
        "not rankable",
        "a row per parameter: true law best",
        "not rankable",
        "lowest RMS: true law",
    ]
    lines = [".. list-table::", "   :header-rows: 1", ""]
    rows = [head]
    for (truth, n), c in counts(trials).items():
        rule, row, rms = c["rule"], c["row_per_parameter"], c["rms"]
        rows.append(
            [
                f"{truth} ({k[truth]})",
                n,
                sum(rule.values()),
                rule["picked"],
                rule["tie"],
                rule["wrong"],
                rule["not_ranked"],
                row["picked"],
                row["not_ranked"],
                rms["picked"],
            ]
        )
    for r in rows:
        lines += [f"   * - {r[0]}", *(f"     - {v}" for v in r[1:])]
    return "\n".join(lines)
