"""The audit's column-order rule (check 6) on a corpus: its detection and false-alarm rates.

Run from the repository root::

    python benchmarks/audit_order_corpus.py            # ~1 minute, 5 draws a case
    python benchmarks/audit_order_corpus.py --draws 1  # the reduced corpus of the test

The corpus starts from Appendix B with the bundled decision applied (Table B.5's 10 c/s
phase column in the order the data description gives, ``datasets/decisions.csv``), so that
every block is a genuine measurement; each case changes one column of one frequency block
and audits that core's rows (the blocks the rule compares with):

* ``reversal`` (should be flagged when material): the DF or phase column of a block in
  reverse order, every block of every table, exactly (draw 0) and then with noise at the
  printed precision. A reversal is **material** when it moves the column by an RMS of at
  least half the audit's spike threshold (4 deg in phase, 0.04 in DF): that is ~9 times the
  within-block scatter of the tables (0.46 deg, 0.006), and a cell moved by that much is a
  different reading, not rounding; a smaller change (B.1's nearly flat columns, a minimum in
  mid-block) leaves the column what it was within the precision the audit's other checks
  work at. Both counts are printed.
* genuine shapes that are not reversals (should not be flagged): ``monotone`` (the phase
  rising with amplitude over the whole block, or the DF rising or falling throughout: one
  frequency that never reaches, or never leaves, saturation), ``eddy`` (at the highest
  frequency of each table only: the phase rising by 10-40 deg, or the DF falling by 10-40 %,
  towards the largest inputs, as eddy-current loss grows with the flux), ``u_shape`` (a phase
  minimum or DF peak anywhere in the block, arms of any height), ``bump`` (the genuine column
  with a bump or dip of 10-30 deg or 0.1-0.3 in DF somewhere), ``noise`` (the genuine column
  with one unit of the last printed digit of Gaussian noise, rounded again), and the
  ``genuine`` tables themselves.

Held out: the rule was designed on Tables B.1, B.3 and B.5 and the classes other than
``bump``; Tables B.2 and B.4 (8 of the 21 blocks) and every ``bump`` case were not looked at
until the rule was fixed, and their rates are printed apart. A detection counts when the
reversed column itself is flagged; a false alarm when any column of the core is flagged in
a case without a reversal (or a column other than the reversed one in a case with one).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from fitdf.data import audit, datasets  # noqa: E402
from fitdf.data.audit_rules import MAG_SPIKE, PHASE_SPIKE  # noqa: E402

#: Columns reversed or reshaped, with the half spike threshold that makes a change material.
COLUMNS = {"phase_lead_deg": PHASE_SPIKE / 2, "df_reported": MAG_SPIKE / 2}
DEVELOPMENT_TABLES = ("B.1", "B.3", "B.5")
HELD_OUT_TABLES = ("B.2", "B.4")
HELD_OUT_CLASSES = ("bump",)
NEGATIVE_CLASSES = ("monotone", "eddy", "u_shape", "bump", "noise")
CLASSES = ("reversal", *NEGATIVE_CLASSES, "genuine")


@dataclass
class Case:
    """One audited copy: which column of which block was changed, and how."""

    cls: str
    marks: bool
    table: str
    frequency: float
    column: str
    draw: int
    frame: pd.DataFrame
    change: float = np.nan  # RMS change of the column (reversals)
    material: bool = False

    @property
    def held_out(self) -> bool:
        return self.table in HELD_OUT_TABLES or self.cls in HELD_OUT_CLASSES

    @property
    def target(self):
        return (self.table, self.frequency, self.column)


def clean_base(marks: bool = True) -> pd.DataFrame:
    """Appendix B with the bundled decision applied: every block a genuine measurement.

    ``marks=False`` drops the ``**`` saturation marks, as a user's file often has none.
    """
    frame = datasets.load("appendix_b")
    decided = frame["reversed_by_decision"].fillna("").astype(str)
    for key, g in frame[decided != ""].groupby(["table", "frequency_hz"]):
        frame = reverse(frame, *key, decided[g.index[0]].split(","))
    frame = frame.assign(reversed_by_decision="")
    return frame if marks else frame.assign(saturation=False)


def block_rows(frame, table, f) -> pd.Index:
    g = frame[(frame["table"] == table) & (frame["frequency_hz"] == f)]
    return g.sort_values("row_in_block", kind="stable").index


def reverse(frame, table, f, columns) -> pd.DataFrame:
    """``frame`` with ``columns`` of one block in reverse printed order."""
    out, idx = frame.copy(), block_rows(frame, table, f)
    for c in columns:
        for name in (c, f"{c}_decimals"):
            if name in out:
                out.loc[idx, name] = out.loc[idx, name].to_numpy()[::-1]
    return out


def _decimals(frame, idx, column) -> int:
    name = f"{column}_decimals"
    if name not in frame:
        return 0
    d = frame.loc[idx, name].dropna().astype(int)
    return int(d.mode().iloc[0]) if len(d) else 2


def _replace(frame, idx, column, values) -> pd.DataFrame:
    """Put ``values`` (rounded to the block's printed precision) in one block's column, and
    keep the output column consistent with a new DF (``h1 = df * input / factor``)."""
    out = frame.copy()
    dec = _decimals(frame, idx, column)
    values = np.round(np.clip(values, 0.0, 90.0 if column == "phase_lead_deg" else 2.0), dec)
    keep = np.isfinite(out.loc[idx, column].to_numpy(float))
    out.loc[idx[keep], column] = values[keep]
    if column == "df_reported" and "h1_output_v" in out:
        a, d, h = (frame.loc[idx, c].to_numpy(float) for c in ("input_v", column, "h1_output_v"))
        ok = (h > 0) & (d > 0)
        if ok.any():
            k = np.median(d[ok] * a[ok] / h[ok])
            hd = _decimals(frame, idx, "h1_output_v")
            out.loc[idx[ok], "h1_output_v"] = np.round(values[ok] * a[ok] / k, hd)
    return out


def _unit(frame, idx, column) -> float:
    return 1.0 if column == "phase_lead_deg" else 10.0 ** -_decimals(frame, idx, column)


def _shape(cls, rng, frame, idx, column, top) -> np.ndarray | None:
    """New values of one block's column for a class of genuine shape (None: not applicable)."""
    y = frame.loc[idx, column].to_numpy(float)
    a = frame.loc[idx, "input_v"].to_numpy(float)
    u = np.log(a)
    lo_u, hi_u = u.min(), u.max()
    span = hi_u - lo_u
    phase = column == "phase_lead_deg"
    if cls == "noise":
        return y + rng.normal(0.0, _unit(frame, idx, column), y.size)
    if cls == "monotone":
        s = 1.0 / (
            1.0
            + np.exp(
                -(u - rng.uniform(lo_u + span / 4, hi_u - span / 4))
                / (rng.uniform(0.1, 0.3) * span)
            )
        )
        if phase:  # the phase rising with amplitude
            low = rng.uniform(0.0, 15.0)
            return low + rng.uniform(20.0, 60.0) * s
        low, high = np.sort(rng.uniform(0.1, 1.0, 2))
        if high - low < 0.2:
            high = low + 0.2
        return low + (high - low) * (s if rng.random() < 0.5 else 1.0 - s)
    if cls == "eddy":
        if not top:
            return None
        s = ((a - a.min()) / (a.max() - a.min())) ** rng.uniform(1.0, 3.0)
        return y + rng.uniform(10.0, 40.0) * s if phase else y * (1.0 - rng.uniform(0.1, 0.4) * s)
    if cls == "u_shape":
        mid = rng.uniform(lo_u, hi_u)
        gamma = rng.uniform(1.0, 2.5)
        left = np.clip((mid - u) / max(mid - lo_u, 1e-9), 0, None) ** gamma
        right = np.clip((u - mid) / max(hi_u - mid, 1e-9), 0, None) ** gamma
        if phase:
            bottom = rng.uniform(0.0, 10.0)
            return bottom + rng.uniform(10.0, 60.0) * left + rng.uniform(10.0, 60.0) * right
        peak = rng.uniform(0.6, 1.0)
        return peak - rng.uniform(0.1, 0.6) * left - rng.uniform(0.1, 0.6) * right
    if cls == "bump":
        size = rng.uniform(10.0, 30.0) if phase else rng.uniform(0.1, 0.3)
        width = rng.uniform(0.1, 0.3) * span
        centre = rng.uniform(lo_u, hi_u)
        return y + rng.choice([-1.0, 1.0]) * size * np.exp(-0.5 * ((u - centre) / width) ** 2)
    raise ValueError(cls)


def cases(draws: int = 5, seed: int = 0, classes=CLASSES, marks: bool = True):
    """Every case of the corpus (a generator: each holds a copy of one core's rows)."""
    base = clean_base(marks)
    keys = list(base.groupby(["table", "frequency_hz"], sort=True).groups)
    top = {t: max(f for tt, f in keys if tt == t) for t, _ in keys}
    if "genuine" in classes:
        for core, rows in base.groupby("core", sort=False):
            yield Case("genuine", marks, str(rows["table"].iloc[0]), np.nan, core, 0, rows)
    for k, (table, f) in enumerate(keys):
        core = base.loc[base["table"] == table, "core"].iloc[0]
        rows = base[base["core"] == core]
        idx = block_rows(rows, table, f)
        for j, column in enumerate(COLUMNS):
            for cls in classes:
                if cls == "genuine":
                    continue
                for draw in range(draws):
                    rng = np.random.default_rng([seed, k, j, CLASSES.index(cls), draw])
                    if cls == "reversal":
                        frame = reverse(rows, table, f, [column])
                        if draw:
                            noisy = _shape("noise", rng, frame, idx, column, False)
                            frame = _replace(frame, idx, column, noisy)
                        y = rows.loc[idx, column].to_numpy(float)
                        ok = np.isfinite(y) & np.isfinite(y[::-1])
                        change = float(np.sqrt(np.mean((y[ok] - y[::-1][ok]) ** 2)))
                        material = change >= COLUMNS[column]
                        yield Case(cls, marks, table, f, column, draw, frame, change, material)
                        continue
                    values = _shape(cls, rng, rows, idx, column, f == top[table])
                    if values is not None:
                        frame = _replace(rows, idx, column, values)
                        yield Case(cls, marks, table, f, column, draw, frame)


def flagged(frame) -> set:
    """(table, frequency, column) of every column the rule reports as printed reversed."""
    order = audit.reversals(frame)
    hit = order[order["reversed"].astype(bool) & ~order["verdict"].str.startswith("reads")]
    return set(zip(hit["table"], hit["frequency_hz"], hit["column"]))


def outcomes(corpus) -> pd.DataFrame:
    """One row per case: its class, split, materiality, detection and false alarm."""
    rows = []
    for case in corpus:
        found = flagged(case.frame)
        rows.append(
            {
                "class": case.cls,
                "marks": case.marks,
                "split": "held out" if case.held_out else "development",
                "table": case.table,
                "frequency_hz": case.frequency,
                "column": case.column,
                "draw": case.draw,
                "change": case.change,
                "material": case.material,
                "detected": case.target in found,
                # a flag on a case without a reversal, or on another column than the reversed
                "false_alarm": bool(found - {case.target} if case.cls == "reversal" else found),
            }
        )
    return pd.DataFrame(rows)


def rates(out: pd.DataFrame) -> pd.DataFrame:
    """Detection rate (material reversals flagged) and false-alarm rate, per class and split."""
    table = []
    for (marks, split, cls), g in out.groupby(["marks", "split", "class"], sort=False):
        rev = cls == "reversal"
        mat = g[g["material"]] if rev else g
        table.append(
            {
                "marks": marks,
                "split": split,
                "class": cls,
                "cases": len(g),
                "material": int(g["material"].sum()) if rev else None,
                "detected": int(mat["detected"].sum()) if rev else None,
                "detection_rate": float(mat["detected"].mean()) if rev and len(mat) else None,
                "immaterial_flagged": int(g.loc[~g["material"], "detected"].sum()) if rev else None,
                "false_alarms": int(g["false_alarm"].sum()),
                "false_alarm_rate": float(g["false_alarm"].mean()),
            }
        )
    order = {c: i for i, c in enumerate(CLASSES)}
    return (
        pd.DataFrame(table)
        .sort_values(
            ["marks", "split", "class"],
            ascending=[False, True, True],
            key=lambda s: s.map(order) if s.name == "class" else s,
        )
        .reset_index(drop=True)
    )


def summary(out: pd.DataFrame) -> pd.DataFrame:
    """The headline per split: material reversals detected, negatives falsely flagged."""
    rows = []
    groups = [*out.groupby(["marks", "split"], sort=True), ((None, "all"), out)]
    for (marks, split), g in groups[::-1]:
        pos = g[(g["class"] == "reversal") & g["material"]]
        neg = g[g["class"] != "reversal"]
        rows.append(
            {
                "marks": "both" if marks is None else "yes" if marks else "no",
                "split": split,
                "material_reversals": len(pos),
                "detection_rate": float(pos["detected"].mean()),
                "negatives": len(neg),
                "false_alarm_rate": float(neg["false_alarm"].mean()),
                "reversals_with_another_flag": int(
                    g.loc[g["class"] == "reversal", "false_alarm"].sum()
                ),
            }
        )
    return pd.DataFrame(rows)


def by_column(out: pd.DataFrame) -> pd.DataFrame:
    """Material reversals detected, per reversed column and per kind of block."""
    pos = out[(out["class"] == "reversal") & out["material"]]
    return (
        pos.groupby(["column", "marks"])["detected"]
        .agg(material_reversals="size", detection_rate="mean")
        .reset_index()
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--draws", type=int, default=5, help="draws per (block, column, class)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--misses", action="store_true", help="list the missed and false cases")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    out = pd.concat(
        [outcomes(cases(args.draws, args.seed, marks=marks)) for marks in (True, False)],
        ignore_index=True,
    )
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(rates(out).to_string(index=False, float_format=lambda x: f"{x:.3f}"))
        print()
        print(summary(out).to_string(index=False, float_format=lambda x: f"{x:.3f}"))
        print()
        print(by_column(out).to_string(index=False, float_format=lambda x: f"{x:.3f}"))
        if args.misses:
            bad = out[
                ((out["class"] == "reversal") & out["material"] & ~out["detected"])
                | ((out["class"] != "reversal") & out["false_alarm"])
            ]
            print(bad.to_string(index=False))
    print(f"\n{len(out)} cases, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
